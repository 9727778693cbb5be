"""Sweeps of independent runs through Dask: on this machine or on a cluster, resumable.

A sweep is a list of :class:`RunSpec` (a run id, a seed, JSON-able
parameters) and a module-level function ``execute(spec, workdir) -> dict``
that does one run and returns its metrics; it may write files (a ``.rrd``
recording, figures) into ``workdir``.

* **Where it runs**: a :class:`distributed.LocalCluster` sized to the machine
  by default (``workers``), or an existing cluster at ``scheduler``
  (``tcp://HOST:PORT``). Each run executes in a private temporary folder on
  its worker; its metrics and files travel back to this process, which writes
  them, so workers need no shared file system.
* **Independent of where**: every run's seed is derived from the study seed
  and its run id (:func:`run_seed`), never from the order or place of
  execution; the table is ordered by the specs, not by completion.
* **Resumable**: each finished run lands atomically in
  ``DIR/runs/<run_id>/`` — its files first, then ``metrics.json`` last, which
  marks the run done. Re-running skips runs whose ``metrics.json`` exists, so a
  killed sweep finishes with no run lost or counted twice.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import logging
import warnings
import math
import os
import re
import signal
import tempfile
import time
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from studies.engine.io import atomic_path, write_json
from studies.engine.validate import InputError, check_count, fail

RUN_ID_RE = re.compile(r"^[A-Za-z0-9][A-Za-z0-9._-]{0,127}$")
SCHEDULER_RE = re.compile(r"^(tcp|tls)://[^\s:/]+:\d{1,5}$")
RESULT_FILE = "metrics.json"
ELAPSED_COLUMN = "elapsed_s"
"""The one column of ``runs.parquet`` that depends on where a run went: its wall time."""


@dataclass(frozen=True)
class RunSpec:
    """One run of a sweep: its id (a file name), its seed and its parameters (JSON-able scalars)."""

    run_id: str
    seed: int
    params: Mapping[str, Any] = field(default_factory=dict)


@dataclass(frozen=True)
class RunOutput:
    """What a worker sends back: the run's metrics, the files it wrote, its wall time."""

    run_id: str
    metrics: dict
    files: dict  #: file name -> bytes
    elapsed_s: float


@dataclass(frozen=True)
class SweepResult:
    """The finished sweep: one row per spec, and how many runs this call executed or skipped."""

    table: pd.DataFrame
    n_executed: int
    n_skipped: int


class SweepError(RuntimeError):
    """Some runs raised; the others were written and a re-run retries only the failed ones."""


def run_seed(study_seed: int, run_id: str) -> int:
    """Seed of run ``run_id`` of a study seeded ``study_seed`` (a 63-bit integer).

    ``numpy.random.SeedSequence(study_seed, spawn_key=words(sha256(run_id)))``:
    distinct, well-mixed streams per run id that do not depend on run order.
    """
    words = np.frombuffer(hashlib.sha256(run_id.encode()).digest(), dtype="<u4")
    state = np.random.SeedSequence(int(study_seed), spawn_key=tuple(int(w) for w in words)).generate_state(2, np.uint32)
    return int((int(state[0]) << 32 | int(state[1])) >> 1)


def make_specs(study_seed: int, runs: Iterable[tuple]) -> list[RunSpec]:
    """RunSpecs from ``(run_id, params)`` or ``(run_id, params, seed_key)`` items.

    Each run is seeded by :func:`run_seed` of its ``seed_key`` (default: its run
    id). Runs that share a ``seed_key`` share their seed: paired comparisons,
    e.g. the same measurement noise with and without a prior. Run ids must be
    unique file names (letters, digits, ``._-``).
    """
    specs, seen = [], set()
    for item in runs:
        run_id, params, seed_key = (*item, item[0]) if len(item) == 2 else item
        if not RUN_ID_RE.match(run_id):
            raise ValueError(f"run id {run_id!r} must be 1-128 letters, digits, '.', '_' or '-', starting with a letter or digit")
        if run_id in seen:
            raise ValueError(f"run id {run_id!r} appears twice in the sweep")
        seen.add(run_id)
        json.dumps(dict(params))  # parameters travel as JSON: fail here, not on a worker
        specs.append(RunSpec(run_id, run_seed(study_seed, str(seed_key)), dict(params)))
    return specs


def default_workers() -> int:
    """Workers of the local cluster: the cores this process may use."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


#: Most local Dask worker processes per core (more only thrash memory and the scheduler).
MAX_WORKERS_PER_CORE = 4


def check_scheduler(address: str | None) -> None:
    """ValueError unless ``address`` is None or of the form ``tcp://HOST:PORT`` (port 1-65535)."""
    if address is not None and (not isinstance(address, str) or not SCHEDULER_RE.match(address) or not 0 < int(address.rsplit(":", 1)[1]) < 65536):
        fail("--scheduler", address, "the form tcp://HOST:PORT (a Dask scheduler, port 1-65535)")


def check_workers(workers: int | None) -> None:
    """ValueError unless ``workers`` is None or an integer within ``[1, MAX_WORKERS_PER_CORE × cores]``."""
    if workers is not None:
        check_count("--workers", workers, 1, MAX_WORKERS_PER_CORE * default_workers())


#: How long a ``--scheduler`` has to answer by default (``lcnav study --connect-timeout-s``), and at most, s.
CONNECT_TIMEOUT_S = 20.0
MAX_CONNECT_TIMEOUT_S = 600.0


#: Run by each local worker process as it starts (a Dask preload given as script text). A terminal's Ctrl-C goes to the
#: whole process group; the lcnav process alone handles it (:mod:`studies.engine.interrupt`) and closes the cluster,
#: which stops the workers. A worker that gets it goes quiet instead: its stdout and stderr go to the null device, so
#: neither a KeyboardInterrupt traceback nor the error logs of a worker losing its closing scheduler ("Failed to
#: communicate with scheduler during heartbeat", measured on 1 of 3 interrupted ``study truth --quick``) reach the
#: terminal around ``lcnav: aborted``. Workers start with SIGINT blocked (:func:`_sigint_blocked`), so a Ctrl-C while
#: they import is held until this handler is in place, then unblocked and handled here.
WORKER_PRELOAD = """\
import os, signal  # lcnav: Ctrl-C is for the lcnav process; a worker goes quiet and waits to be stopped


def _quiet(signum, frame):
    null = os.open(os.devnull, os.O_WRONLY)
    os.dup2(null, 1)
    os.dup2(null, 2)


signal.signal(signal.SIGINT, _quiet)
signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})
"""


@contextlib.contextmanager
def _sigint_blocked():
    """SIGINT blocked in this thread for the block: threads started in it, and processes they start, inherit the mask.

    Around the creation of a local cluster: its event-loop thread and the threads that spawn the worker processes inherit
    the mask, so a worker starts with SIGINT held (:data:`WORKER_PRELOAD` unblocks it once its quiet handler is
    installed). A Ctrl-C meanwhile waits until the block ends and raises KeyboardInterrupt there — unless a thread of
    lcnav started before the block takes it, in which case Python raises it in the main thread at once, as without the
    block; workers already started then exit with lcnav (Dask's parent-alive pipe). The same pattern as
    :mod:`multiprocessing.resource_tracker`, which starts its process with SIGINT blocked.
    """
    old = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)


@contextlib.contextmanager
def dask_client(scheduler: str | None = None, workers: int | None = None, *, connect_timeout_s: float | None = None):
    """A Dask client: on ``scheduler`` if given, else on a new local cluster of ``workers`` processes.

    An unreachable scheduler is bad input: ValueError naming the address, raised once
    ``connect_timeout_s`` (default :data:`CONNECT_TIMEOUT_S`) has passed.
    """
    from distributed import Client, LocalCluster

    check_scheduler(scheduler)
    check_workers(workers)
    connect_timeout_s = CONNECT_TIMEOUT_S if connect_timeout_s is None else connect_timeout_s
    if scheduler is not None:
        try:
            client = Client(scheduler, timeout=f"{connect_timeout_s}s")
        except (OSError, TimeoutError, MemoryError, ValueError) as e:  # refused, silent, or something else answering (garbage lengths)
            raise ValueError(f"--scheduler {scheduler}: no Dask scheduler answered within {connect_timeout_s:g} s ({type(e).__name__}): "
                             "expected a running scheduler at that address (or a longer --connect-timeout-s)") from None
        with client:
            yield client
        return
    with warnings.catch_warnings():
        # distributed may still warn that its default dashboard port is taken by another cluster on this machine (two
        # studies at once, a parallel test run) although the dashboard is off: nothing a user must act on
        warnings.filterwarnings("ignore", message=r"Port \d+ is already in use", category=UserWarning)
        with contextlib.ExitStack() as stack:
            with _sigint_blocked():  # the cluster's close is registered before a held Ctrl-C can raise
                cluster = stack.enter_context(LocalCluster(
                    n_workers=workers or default_workers(), threads_per_worker=1, processes=True, dashboard_address=None,
                    silence_logs=logging.ERROR, preload=[WORKER_PRELOAD]))
            yield stack.enter_context(Client(cluster))


def execute_in_tmp(execute: Callable[[RunSpec, Path], dict], spec: RunSpec) -> RunOutput:
    """Run ``execute(spec, workdir)`` in a private temporary folder and collect what it wrote.

    This is what runs on a worker. The metrics must be a flat dict of JSON
    scalars (numbers, strings, booleans); non-finite floats travel as None.
    """
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix=f"lcnav-{spec.run_id}-") as tmp:
        metrics = execute(spec, Path(tmp))
        files = {p.name: p.read_bytes() for p in sorted(Path(tmp).iterdir()) if p.is_file()}
    return RunOutput(spec.run_id, _check_metrics(spec.run_id, metrics), files, time.perf_counter() - t0)


def _check_metrics(run_id: str, metrics) -> dict:
    if not isinstance(metrics, Mapping):
        raise TypeError(f"run {run_id}: execute must return a dict of metrics, got {type(metrics).__name__}")
    out = {}
    for k, v in metrics.items():
        if isinstance(v, np.generic):
            v = v.item()
        if not isinstance(v, bool | int | float | str) and v is not None:
            raise TypeError(f"run {run_id}: metric {k!r} must be a number, string or boolean, got {type(v).__name__}")
        out[str(k)] = None if isinstance(v, float) and not math.isfinite(v) else v
    return out


def run_dir(out_dir, run_id: str) -> Path:
    """``DIR/runs/<run_id>``: where a run's files and ``metrics.json`` go."""
    return Path(out_dir) / "runs" / run_id


def _write_output(out_dir: Path, spec: RunSpec, out: RunOutput) -> None:
    folder = run_dir(out_dir, spec.run_id)
    for name, data in out.files.items():
        with atomic_path(folder / name) as tmp:
            tmp.write_bytes(data)
    # metrics.json last: its presence marks the run as done
    write_json(
        folder / RESULT_FILE,
        {"run_id": spec.run_id, "seed": spec.seed, "params": dict(spec.params), "metrics": out.metrics,
         ELAPSED_COLUMN: out.elapsed_s, "files": sorted(out.files)},
    )


def read_result(out_dir, spec: RunSpec) -> dict | None:
    """The stored result of ``spec``, or None if the run has not finished.

    A result written for another seed or other parameters (a different
    config) is refused rather than silently mixed in.
    """
    path = run_dir(out_dir, spec.run_id) / RESULT_FILE
    if not path.is_file():
        return None
    expected = "the metrics.json of a finished run (delete it to run that run again)"
    try:
        rec = json.loads(path.read_bytes())
    except (ValueError, RecursionError) as e:  # JSONDecodeError, UnicodeDecodeError; nesting too deep
        raise InputError(f"{path}: not JSON ({type(e).__name__}: {str(e)[:80]}): expected {expected}") from None
    if not isinstance(rec, dict) or not isinstance(rec.get("metrics"), dict) or ELAPSED_COLUMN not in rec:
        raise InputError(f"{path}: no metrics or elapsed_s: expected {expected}")
    if rec.get("seed") != spec.seed or rec.get("params") != json.loads(json.dumps(dict(spec.params))):
        raise InputError(f"{path}: run {spec.run_id!r} of another config (seed or parameters differ): expected a new --out or the same config")
    return rec


def _row(rec: dict) -> dict:
    params = {k: (json.dumps(v) if isinstance(v, list | dict) else v) for k, v in rec["params"].items()}
    return {"run_id": rec["run_id"], "seed": rec["seed"], **params, **rec["metrics"], ELAPSED_COLUMN: rec[ELAPSED_COLUMN]}


def results_table(out_dir, specs: Sequence[RunSpec]) -> pd.DataFrame:
    """One row per finished spec, in spec order: ``run_id``, ``seed``, parameters, metrics, ``elapsed_s``."""
    rows = [_row(rec) for spec in specs if (rec := read_result(out_dir, spec)) is not None]
    return pd.DataFrame(rows)


def run_sweep(
    specs: Sequence[RunSpec],
    execute: Callable[[RunSpec, Path], dict],
    out_dir,
    *,
    scheduler: str | None = None,
    workers: int | None = None,
    progress: bool = True,
    desc: str = "runs",
    prepare: Callable[[], None] | None = None,
    connect_timeout_s: float | None = None,
) -> SweepResult:
    """Execute every spec without a stored result; return the table of all of them.

    ``execute`` must be importable by the workers (a module-level function).
    ``prepare()`` is called once the cluster is up (or at once if every run
    is stored), before the first result is written: a caller's first write
    (``study.json``) waits until an unreachable ``--scheduler`` has failed
    (after ``connect_timeout_s``, see :func:`dask_client`).
    Results are written as they arrive. If some runs raise, the others are
    still written and :class:`SweepError` names the failed ones.
    """
    from distributed import as_completed
    from tqdm import tqdm

    check_scheduler(scheduler)
    check_workers(workers)
    out_dir = Path(out_dir)
    todo = [s for s in specs if read_result(out_dir, s) is None]
    n_skipped = len(specs) - len(todo)
    failures = []
    if not todo and prepare is not None:
        prepare()
    if todo:
        with dask_client(scheduler, workers, connect_timeout_s=connect_timeout_s) as client, tqdm(
            total=len(specs), initial=n_skipped, desc=desc, unit="run", disable=not progress
        ) as bar:
            if prepare is not None:
                prepare()
            futures = [client.submit(execute_in_tmp, execute, s, pure=False, key=f"lcnav-{s.run_id}-{os.urandom(4).hex()}") for s in todo]
            spec_of = {fut.key: s for fut, s in zip(futures, todo)}
            for fut in as_completed(futures):
                spec = spec_of[fut.key]
                if fut.status == "error":
                    failures.append((spec.run_id, repr(fut.exception())))
                else:
                    _write_output(out_dir, spec, fut.result())
                fut.release()
                bar.update(1)
    if failures:
        listing = "; ".join(f"{rid}: {err}" for rid, err in failures[:5])
        raise SweepError(f"{len(failures)} of {len(specs)} runs failed ({listing}); the others are stored in {out_dir}")
    return SweepResult(results_table(out_dir, specs), len(todo), n_skipped)
