"""Study configurations: editable TOML files, loaded and validated before anything runs.

Every study is defined by one TOML file (``studies/catalog/configs/<study>.toml`` by
default, ``--config FILE`` otherwise). Each file has

* ``study``: the study's name (must match the study being run);
* ``seed``: the study seed, from which every run's own seed is derived
  (:func:`studies.engine.sweep.run_seed`), so results do not depend on where or on
  how many workers the runs went;
* the study's own fields, declared by the study as a mapping of name to
  :class:`Field` (kind, bounds, choices, default, documentation);
* an optional ``[quick]`` table overriding some of those fields for
  ``--quick`` (the small size the tests use).

A bad file raises :class:`ConfigError` (a ``ValueError``) whose one-line
message names the file, the field and the expected form, e.g.
``truth.toml: n_seeds -3: expected an integer >= 1 and <= 100000``; the CLI
prints that line and exits non-zero before writing anything.

Sizes are bounded so that no config can make a study hang or exhaust memory:
a number without its own upper bound must lie within ``±DEFAULT_MAX[kind]``
(integers 1e5, numbers 1e6), every ``*duration*_s`` field divided by a step
field (``dt_s``, ``cadence_s``, ``rk4_dt_s``, ``measurement_period_s``) gives at
most :data:`MAX_STEPS` steps, and a file is at most 1 MiB.
"""

from __future__ import annotations

import json
import math
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from studies.engine.validate import plain

CONFIG_DIR = Path(__file__).resolve().parent.parent / "catalog" / "configs"
"""Folder of the editable default configs, one ``<study>.toml`` per study."""

_REQUIRED = object()

_KIND_NAMES = {
    "int": "an integer",
    "float": "a number",
    "str": "a string",
    "bool": "true or false",
}
KINDS = tuple(_KIND_NAMES) + tuple(f"list[{k}]" for k in ("int", "float", "str"))

#: Bounds of a number without its own (counts, durations, sizes): ``-DEFAULT_MAX <= v <= DEFAULT_MAX``.
DEFAULT_MAX = {"int": 10**5, "float": 1e6}
#: Steps a run may take: every ``*duration*_s`` field over every step field.
MAX_STEPS = 10**6
STEP_FIELDS = ("dt_s", "cadence_s", "rk4_dt_s", "measurement_period_s")
#: Largest config file, bytes; longest list, items.
MAX_CONFIG_BYTES = 2**20
MAX_LIST = 10**4


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
        lo, hi = self._limits()
        bounds = [f"> {self.gt:g}" if self.gt is not None else "", f">= {lo:g}" if self.gt is None and lo is not None else "",
                  f"<= {hi:g}" if hi is not None else ""]
        bounds = " and ".join(b for b in bounds if b)
        if bounds:
            words += " " + bounds
        if self.kind.startswith("list["):
            return f"a list of {self.min_len} to {MAX_LIST} item(s), each {words}"
        return words

    def _limits(self) -> tuple[float | None, float | None]:
        """``(ge, le)`` with the defaults of :data:`DEFAULT_MAX` where the field sets none (numbers only)."""
        elem = self.kind[5:-1] if self.kind.startswith("list[") else self.kind
        if elem not in DEFAULT_MAX or self.choices is not None:
            return self.ge, self.le
        return (self.ge if self.ge is not None else -DEFAULT_MAX[elem]), (self.le if self.le is not None else DEFAULT_MAX[elem])

    def check(self, value, name: str, where: str):
        """Return ``value`` converted to the field's kind; ConfigError naming ``name`` otherwise."""
        def fail():
            raise ConfigError(f"{where}: {name} {plain(value)}: expected {self.expected()}")

        if self.kind.startswith("list["):
            if not isinstance(value, list) or not self.min_len <= len(value) <= MAX_LIST:
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
            if not isinstance(v, str) or (self.choices is not None and v not in self.choices) or len(v) > 1000 or not v.isprintable():
                raise ValueError
            return v
        # TOML ints are fine where a float is expected; bools are not numbers here
        if isinstance(v, bool) or not isinstance(v, int | float) or (self.kind == "int" and not isinstance(v, int)):
            raise ValueError
        v = int(v) if self.kind == "int" else float(v)
        if not math.isfinite(v):
            raise ValueError
        lo, hi = self._limits()
        if (self.gt is not None and not v > self.gt) or (lo is not None and not v >= lo) or (hi is not None and not v <= hi):
            raise ValueError
        if self.choices is not None and v not in self.choices:
            raise ValueError
        return v


#: Fields every study config has.
COMMON_FIELDS: dict[str, Field] = {
    "study": Field("str", "Name of the study this file configures."),
    "seed": Field("int", "Study seed; each run's seed derives from it and the run id.", ge=0, le=2**63 - 1),
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
    """``studies/catalog/configs/<study>.toml``."""
    return CONFIG_DIR / f"{study}.toml"


def read_toml(path) -> dict:
    """Parse ``path``; ConfigError (one line, with the position) for a syntax error."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"config file {path} does not exist")
    if path.stat().st_size > MAX_CONFIG_BYTES:
        raise ConfigError(f"{path.name}: {path.stat().st_size} bytes: expected a config of at most {MAX_CONFIG_BYTES} bytes")
    try:
        with path.open("rb") as f:
            return tomllib.load(f)
    except tomllib.TOMLDecodeError as e:
        raise ConfigError(f"{path.name}: not valid TOML ({str(e).splitlines()[0]}): expected a TOML file") from None
    except UnicodeDecodeError:
        raise ConfigError(f"{path.name}: not UTF-8 text: expected a TOML file") from None


def _check_fields(raw: Mapping, fields: Mapping[str, Field], where: str, prefix: str = "", fill_defaults: bool = True) -> dict:
    out = {}
    for name, value in raw.items():
        if name not in fields:
            known = ", ".join(sorted(fields))
            raise ConfigError(f"{where}: unknown field {prefix + name!r}: expected one of: {known}")
        out[name] = fields[name].check(value, prefix + name, where)
    if fill_defaults:
        for name, field in fields.items():
            if name not in out:
                if field.required:
                    raise ConfigError(f"{where}: {prefix + name} missing: expected {field.expected()} ({field.doc})")
                out[name] = field.default
    return out


def _check_steps(params: Mapping, where: str) -> None:
    """Every ``*duration*_s`` field over every step field present gives at most :data:`MAX_STEPS` steps."""
    steps = {k: params[k] for k in STEP_FIELDS if isinstance(params.get(k), int | float) and params[k] > 0}
    for name, duration in params.items():
        if "duration" in name and name.endswith("_s") and isinstance(duration, int | float):
            for step_name, step in steps.items():
                if duration / step > MAX_STEPS:
                    raise ConfigError(f"{where}: {name} / {step_name} {duration:g} / {step:g} ({duration / step:.3g} steps): "
                                      f"expected at most {MAX_STEPS} steps")


def validate_config(raw: Mapping, study: str, fields: Mapping[str, Field], *, quick: bool = False, where: str = "config") -> StudyConfig:
    """Validate the parsed TOML ``raw`` of study ``study`` against ``fields``.

    ``quick`` applies the ``[quick]`` table's overrides; unknown fields,
    missing required fields and values of the wrong form raise ConfigError.
    """
    raw = dict(raw)
    if not raw:
        raise ConfigError(f"{where}: empty: expected a TOML config with study = {study!r}, seed and the study's fields")
    quick_raw = raw.pop("quick", {})
    common = _check_fields({k: raw.pop(k) for k in list(raw) if k in COMMON_FIELDS}, COMMON_FIELDS, where)
    if common["study"] != study:
        raise ConfigError(f"{where}: study {plain(common['study'])}: expected {study!r} (the study being run)")
    params = _check_fields(raw, fields, where)
    if not isinstance(quick_raw, dict):
        raise ConfigError(f"{where}: quick {plain(quick_raw)}: expected a table of overrides ([quick])")
    overrides = _check_fields(quick_raw, fields, where, prefix="quick.", fill_defaults=False)
    if quick:
        params.update(overrides)
    _check_steps(params, where)
    return StudyConfig(study=study, seed=common["seed"], params=params, quick=quick, source=where)


def load_config(path, study: str, fields: Mapping[str, Field], *, quick: bool = False) -> StudyConfig:
    """Read and validate the TOML file ``path`` (see :func:`validate_config`)."""
    path = Path(path)
    cfg = validate_config(read_toml(path), study, fields, quick=quick, where=path.name)
    return StudyConfig(cfg.study, cfg.seed, cfg.params, cfg.quick, str(path))
