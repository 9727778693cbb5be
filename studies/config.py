"""Study configurations: editable TOML files, loaded and validated before anything runs.

Every study is defined by one TOML file (``studies/configs/<study>.toml`` by
default, ``--config FILE`` otherwise). Each file has

* ``study``: the study's name (must match the study being run);
* ``seed``: the study seed, from which every run's own seed is derived
  (:func:`studies.sweep.run_seed`), so results do not depend on where or on
  how many workers the runs went;
* the study's own fields, declared by the study as a mapping of name to
  :class:`Field` (kind, bounds, choices, default, documentation);
* an optional ``[quick]`` table overriding some of those fields for
  ``--quick`` (the small size the tests use).

A bad file raises :class:`ConfigError` (a ``ValueError``) whose one-line
message names the file, the field and the expected form, e.g.
``truth.toml: field 'n_seeds' must be an integer >= 1, got -3``; the CLI
prints that line and exits non-zero before writing anything.
"""

from __future__ import annotations

import json
import math
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

CONFIG_DIR = Path(__file__).resolve().parent / "configs"
"""Folder of the editable default configs, one ``<study>.toml`` per study."""

_REQUIRED = object()

_KIND_NAMES = {
    "int": "an integer",
    "float": "a number",
    "str": "a string",
    "bool": "true or false",
}
KINDS = tuple(_KIND_NAMES) + tuple(f"list[{k}]" for k in ("int", "float", "str"))


class ConfigError(ValueError):
    """A study config is malformed; the message names the field and the expected form."""


@dataclass(frozen=True)
class Field:
    """Declaration of one config field.

    ``kind`` is one of ``int``, ``float``, ``str``, ``bool``, ``list[int]``,
    ``list[float]``, ``list[str]``; bounds and choices apply to a scalar or to
    every element of a list. ``gt``/``ge``/``le`` are numeric bounds
    (exclusive / inclusive / inclusive). Without a ``default`` the field is
    required.
    """

    kind: str
    doc: str
    default: Any = _REQUIRED
    gt: float | None = None
    ge: float | None = None
    le: float | None = None
    choices: tuple | None = None
    min_len: int = 1

    def __post_init__(self):
        if self.kind not in KINDS:
            raise TypeError(f"Field kind must be one of {KINDS}, got {self.kind!r}")

    @property
    def required(self) -> bool:
        return self.default is _REQUIRED

    def expected(self) -> str:
        """The expected form in words, as used in error messages."""
        elem = self.kind[5:-1] if self.kind.startswith("list[") else self.kind
        words = _KIND_NAMES[elem]
        if self.choices is not None:
            words = "one of " + ", ".join(repr(c) for c in self.choices)
        bounds = [f"> {self.gt:g}" if self.gt is not None else "", f">= {self.ge:g}" if self.ge is not None else "",
                  f"<= {self.le:g}" if self.le is not None else ""]
        bounds = " and ".join(b for b in bounds if b)
        if bounds:
            words += " " + bounds
        if self.kind.startswith("list["):
            return f"a list of at least {self.min_len} item(s), each {words}"
        return words

    def check(self, value, name: str, where: str):
        """Return ``value`` converted to the field's kind; ConfigError naming ``name`` otherwise."""
        def fail():
            raise ConfigError(f"{where}: field {name!r} must be {self.expected()}, got {value!r}")

        if self.kind.startswith("list["):
            if not isinstance(value, list) or len(value) < self.min_len:
                fail()
            elem_field = Field(self.kind[5:-1], self.doc, gt=self.gt, ge=self.ge, le=self.le, choices=self.choices)
            try:
                return [elem_field._scalar(v) for v in value]
            except ValueError:
                fail()
        try:
            return self._scalar(value)
        except ValueError:
            fail()

    def _scalar(self, v):
        if self.kind == "bool":
            if not isinstance(v, bool):
                raise ValueError
            return v
        if self.kind == "str":
            if not isinstance(v, str) or (self.choices is not None and v not in self.choices):
                raise ValueError
            return v
        # TOML ints are fine where a float is expected; bools are not numbers here
        if isinstance(v, bool) or not isinstance(v, int | float) or (self.kind == "int" and not isinstance(v, int)):
            raise ValueError
        v = int(v) if self.kind == "int" else float(v)
        if not math.isfinite(v):
            raise ValueError
        if (self.gt is not None and not v > self.gt) or (self.ge is not None and not v >= self.ge) or (
            self.le is not None and not v <= self.le
        ):
            raise ValueError
        if self.choices is not None and v not in self.choices:
            raise ValueError
        return v


#: Fields every study config has.
COMMON_FIELDS: dict[str, Field] = {
    "study": Field("str", "Name of the study this file configures."),
    "seed": Field("int", "Study seed; each run's seed derives from it and the run id.", ge=0),
}


@dataclass(frozen=True)
class StudyConfig:
    """A loaded, validated study config (``params`` has every study field, defaults filled in)."""

    study: str
    seed: int
    params: Mapping[str, Any]
    quick: bool
    source: str  #: the file it was read from

    def __getitem__(self, name: str):
        return self.params[name]

    def identity(self) -> dict:
        """What must match for a re-run to resume into the same output folder."""
        return {"study": self.study, "seed": self.seed, "quick": self.quick, "params": dict(self.params)}

    def identity_json(self) -> str:
        return json.dumps(self.identity(), sort_keys=True)


def default_config_path(study: str) -> Path:
    """``studies/configs/<study>.toml``."""
    return CONFIG_DIR / f"{study}.toml"


def read_toml(path) -> dict:
    """Parse ``path``; ConfigError (one line, with the position) for a syntax error."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"config file {path} does not exist")
    try:
        with path.open("rb") as f:
            return tomllib.load(f)
    except tomllib.TOMLDecodeError as e:
        raise ConfigError(f"{path.name}: not valid TOML: {str(e).splitlines()[0]}") from None
    except UnicodeDecodeError:
        raise ConfigError(f"{path.name}: not valid TOML: the file is not UTF-8 text") from None


def _check_fields(raw: Mapping, fields: Mapping[str, Field], where: str, prefix: str = "", fill_defaults: bool = True) -> dict:
    out = {}
    for name, value in raw.items():
        if name not in fields:
            known = ", ".join(sorted(fields))
            raise ConfigError(f"{where}: unknown field {prefix + name!r}; expected one of: {known}")
        out[name] = fields[name].check(value, prefix + name, where)
    if fill_defaults:
        for name, field in fields.items():
            if name not in out:
                if field.required:
                    raise ConfigError(f"{where}: missing field {prefix + name!r}: {field.expected()} ({field.doc})")
                out[name] = field.default
    return out


def validate_config(raw: Mapping, study: str, fields: Mapping[str, Field], *, quick: bool = False, where: str = "config") -> StudyConfig:
    """Validate the parsed TOML ``raw`` of study ``study`` against ``fields``.

    ``quick`` applies the ``[quick]`` table's overrides; unknown fields,
    missing required fields and values of the wrong form raise ConfigError.
    """
    raw = dict(raw)
    quick_raw = raw.pop("quick", {})
    common = _check_fields({k: raw.pop(k) for k in list(raw) if k in COMMON_FIELDS}, COMMON_FIELDS, where)
    if common["study"] != study:
        raise ConfigError(f"{where}: field 'study' must be {study!r} (the study being run), got {common['study']!r}")
    params = _check_fields(raw, fields, where)
    if not isinstance(quick_raw, dict):
        raise ConfigError(f"{where}: field 'quick' must be a table of overrides ([quick]), got {quick_raw!r}")
    overrides = _check_fields(quick_raw, fields, where, prefix="quick.", fill_defaults=False)
    if quick:
        params.update(overrides)
    return StudyConfig(study=study, seed=common["seed"], params=params, quick=quick, source=where)


def load_config(path, study: str, fields: Mapping[str, Field], *, quick: bool = False) -> StudyConfig:
    """Read and validate the TOML file ``path`` (see :func:`validate_config`)."""
    path = Path(path)
    cfg = validate_config(read_toml(path), study, fields, quick=quick, where=path.name)
    return StudyConfig(cfg.study, cfg.seed, cfg.params, cfg.quick, str(path))
