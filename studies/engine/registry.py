"""The study registry and engine: what ``lcnav study NAME`` runs (:func:`run_study`).

A study is a :class:`StudyDefinition` in :data:`STUDIES`. :func:`run_study`

1. loads and validates the config (``studies/catalog/configs/<NAME>.toml`` or
   ``--config FILE``; ``--quick`` applies its ``[quick]`` table) — a bad config
   stops here with one line naming the field, before anything is written;
2. expands it into run specs (each with ``run_id`` and ``seed``);
3. runs them through :func:`studies.engine.sweep.run_sweep` (a local Dask cluster of
   ``--workers`` processes, or ``--scheduler tcp://HOST:PORT``), skipping runs
   already stored in ``DIR/runs/`` (resume);
4. writes ``DIR/runs.parquet`` (+ CSV: one row per run with its parameters and
   metrics), the study's tables (``DIR/summary.parquet``, ``DIR/summary.csv``,
   ``DIR/summary.md``, and any others) and returns the Markdown.

``DIR`` defaults to ``runs/<NAME>-<UTC timestamp>/``; ``DIR/study.json``
records the resolved config, and resuming into a folder of another config is
refused.
"""

from __future__ import annotations

import datetime
import json
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import pandas as pd

from studies.catalog import chain_study, combina_study, coverage_study, init_study, proxy_study, timing_study, truth_study, tuning_study
from studies.engine.config import Field, StudyConfig, default_config_path, load_config
from studies.engine import validate as v
from studies.engine.io import COMPLETE_FILE, output_folder, write_json, write_table
from studies.engine.sweep import RunSpec, check_scheduler, check_workers, run_sweep
from studies.engine.tables import Table, write_tables


@dataclass(frozen=True)
class StudyDefinition:
    """How a study plugs into the engine.

    * ``fields``: its config fields (besides ``study`` and ``seed``), see :class:`studies.engine.config.Field`;
    * ``check(params)``: cross-field rules, raising :class:`studies.engine.config.ConfigError`;
    * ``expand(config) -> list[RunSpec]``: the runs (use :func:`studies.engine.sweep.make_specs`, which
      derives each run's seed from the study seed and the run id);
    * ``execute(spec, workdir) -> dict``: one run, a module-level function (it is shipped to the
      Dask workers by reference); it draws only from ``numpy.random.default_rng(spec.seed)``,
      returns a flat dict of numbers/strings/booleans and may write files (``run.rrd``, PNGs) into
      ``workdir``, which end up in ``DIR/runs/<run_id>/``;
    * ``summarise(runs, config, out_dir) -> list[Table]``: the paper-style tables from the runs
      table, the first named ``summary``; it may write figures (PNG) into ``out_dir``.
    """

    name: str
    title: str
    fields: dict[str, Field]
    expand: Callable[[StudyConfig], list[RunSpec]]
    execute: Callable[[RunSpec, Path], dict]
    summarise: Callable[[pd.DataFrame, StudyConfig, Path], Sequence[Table]]
    check: Callable[[dict], None] | None = None

    def load(self, path: Path | None = None, *, quick: bool = False) -> StudyConfig:
        """Load and validate the study's config (its default file without ``path``)."""
        cfg = load_config(path or default_config_path(self.name), self.name, self.fields, quick=quick)
        if self.check is not None:
            try:
                self.check(dict(cfg.params))
            except ValueError as e:
                raise type(e)(f"{Path(cfg.source).name}: {e}") from None
        return cfg


STUDIES: dict[str, StudyDefinition] = {
    d.name: d
    for d in [
        StudyDefinition("truth", truth_study.TITLE, truth_study.FIELDS, truth_study.expand, truth_study.execute,
                        truth_study.summarise, truth_study.check),
        *(StudyDefinition(m.__name__.split(".")[-1].removesuffix("_study"), m.TITLE, m.FIELDS, m.expand, m.execute, m.summarise, m.check)
          for m in (tuning_study, init_study, proxy_study, chain_study, combina_study, coverage_study, timing_study)),
    ]
}


def get_study(name: str) -> StudyDefinition:
    """The registered study ``name``; ValueError naming the runnable ones otherwise."""
    if name not in STUDIES:
        raise ValueError(f"unknown study {name!r}: expected one of the known studies: {', '.join(STUDIES)}")
    return STUDIES[name]


def default_out_dir(name: str) -> Path:
    """``runs/<name>-<UTC timestamp>``."""
    return Path("runs") / f"{name}-{datetime.datetime.now(datetime.UTC):%Y%m%dT%H%M%SZ}"


#: Most runs one study may expand to.
MAX_RUNS = 10**5


def _check_out_dir(out: Path, config: StudyConfig) -> None:
    """A folder to resume must hold a study of the same config (``study.json``); read under the --out lock."""
    stamp = out / "study.json"
    if stamp.is_file():
        try:
            old = json.loads(stamp.read_text())
        except (ValueError, RecursionError):
            raise v.InputError(f"--out {str(out)!r}: study.json is not JSON: expected the folder of a study (or a new --out)") from None
        if not isinstance(old, dict) or json.dumps(old, sort_keys=True) != config.identity_json():
            study = old.get("study") if isinstance(old, dict) else None
            raise v.InputError(f"--out {str(out)!r} holds a {study!r} study with another config (see {stamp}): expected a new --out or the same config")


@dataclass(frozen=True)
class StudyOutcome:
    out_dir: Path
    runs: pd.DataFrame
    tables: list[Table]
    markdown: str
    n_executed: int
    n_skipped: int


def run_study(name: str, *, config_path: Path | None = None, quick: bool = False, out: Path | None = None,
              scheduler: str | None = None, workers: int | None = None, progress: bool = True,
              connect_timeout_s: float | None = None) -> StudyOutcome:
    """Everything ``lcnav study`` does, as a function (validation first, then the sweep, then the tables)."""
    study = get_study(name)
    check_scheduler(scheduler)
    check_workers(workers)
    if scheduler is not None and workers is not None:
        raise ValueError(f"--workers {workers} with --scheduler: expected one of them (--workers sizes the local cluster; it cannot be combined "
                         "with --scheduler: size the remote cluster there)")
    if config_path is not None:
        v.check_in_file("--config", config_path, (".toml",))
    config = study.load(config_path, quick=quick)
    specs = study.expand(config)
    if len(specs) > MAX_RUNS:
        raise v.InputError(f"{Path(config.source).name}: {len(specs)} runs: expected a study of at most {MAX_RUNS} runs")
    out = v.check_out_dir("--out", Path(out) if out is not None else default_out_dir(name))

    def prepare():  # the first write, once the cluster answers: the folder is unfinished from here on
        (out / COMPLETE_FILE).unlink(missing_ok=True)
        write_json(out / "study.json", config.identity())

    with output_folder(out, "study", staged=False, check=lambda d: _check_out_dir(d, config)):
        sweep = run_sweep(specs, study.execute, out, scheduler=scheduler, workers=workers, progress=progress, desc=name, prepare=prepare,
                          connect_timeout_s=connect_timeout_s)
        write_table(out / "runs.parquet", sweep.table, csv=True)
        tables = list(study.summarise(sweep.table, config, out))
        if not tables or tables[0].name != "summary":
            raise RuntimeError(f"study {name}: summarise must return the 'summary' table first")
        md = write_tables(out, tables, heading=f"{name}{' (quick)' if quick else ''}: {len(sweep.table)} runs")
    return StudyOutcome(out, sweep.table, tables, md, sweep.n_executed, sweep.n_skipped)
