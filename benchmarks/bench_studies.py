"""Studies: wall time of the truth-model check study, 1 vs 2 local Dask workers, and recording sizes.

Each configuration runs ``run_study`` from scratch into a fresh folder (the
local cluster's start-up included, as a user would see it). The baseline of
the speed-up is the 1-worker run of the same size measured in the same run.
"""

from __future__ import annotations

import os
import re
import statistics
import tempfile
import time
from pathlib import Path

from studies.engine.config import default_config_path, read_toml
from studies.engine.registry import run_study
from studies.engine.sweep import dask_client


def _timed(quick: bool, workers: int, root: Path):
    out = root / f"truth-{'quick' if quick else 'full'}-{workers}w"
    t0 = time.perf_counter()
    res = run_study("truth", quick=quick, out=out, workers=workers, progress=False)
    wall = time.perf_counter() - t0
    sizes = [p.stat().st_size for p in out.glob("runs/*/run.rrd")]
    return wall, res, sizes


def _cluster_start(workers: int) -> float:
    t0 = time.perf_counter()
    with dask_client(workers=workers) as client:
        client.wait_for_workers(workers)
        started = time.perf_counter() - t0
    return started


#: Initial conditions per level in the measured fraction of the full coverage study (100 in the full study).
COVERAGE_FRACTION_ICS = 2


def _coverage_fraction_config(root: Path, n_ics: int) -> Path:
    """The full coverage config with ``n_initial_conditions = n_ics`` (every level, full horizon)."""
    text = default_config_path("coverage").read_text()
    new, n = re.subn(r"(?m)^n_initial_conditions\s*=\s*\d+", f"n_initial_conditions = {n_ics}", text, count=1)
    if n != 1:
        raise RuntimeError("coverage.toml: no n_initial_conditions line")
    path = root / "coverage-fraction.toml"
    path.write_text(new)
    return path


def run_coverage(n_ics: int = COVERAGE_FRACTION_ICS) -> str:
    """Full coverage study wall time with 1 and 2 local workers, from a measured fraction, extrapolated.

    The fraction keeps every rate level and the full half-orbit horizon with
    ``n_ics`` initial conditions per level instead of 100; the full study's wall
    time is extrapolated as (fraction wall − cluster start) × 100 / n_ics + start.
    """
    full_ics = read_toml(default_config_path("coverage"))["n_initial_conditions"]
    rows, per_level = [], None
    with tempfile.TemporaryDirectory(prefix="lcnav-bench-coverage-") as tmp:
        root = Path(tmp)
        cfg = _coverage_fraction_config(root, n_ics)
        base = None
        for workers in (1, 2):
            start = _cluster_start(workers)
            t0 = time.perf_counter()
            res = run_study("coverage", config_path=cfg, out=root / f"cov-{workers}w", workers=workers, progress=False)
            wall = time.perf_counter() - t0
            full = (wall - start) * full_ics / n_ics + start
            base = base or full
            rows.append((workers, len(res.runs), f"{wall:.0f}", f"{res.runs['elapsed_s'].sum() / wall:.2f}",
                         f"{full / 60:.0f}", f"{base / full:.2f}×"))
            per_level = res.runs.groupby("rate_level_rad_s")["elapsed_s"].median()
    lines = [
        "## Coverage study (`lcnav study coverage`, Maestrini et al. Fig. 20): full-size wall time from a measured fraction",
        "",
        f"Measured: every rate level at the full horizon (half an orbit, 0.33 Hz) with {n_ics} of the {full_ics} initial "
        f"conditions per level ({n_ics / full_ics:.0%} of the runs); full-size wall time extrapolated linearly "
        "(the cluster start counted once). Goal: under 30 minutes on 2 cores.",
        "",
        "| local workers | runs measured | wall time (s) | Σ run / wall | full study, extrapolated (min) | speed-up vs 1 worker |",
        "|---|---|---|---|---|---|",
    ]
    lines += ["| " + " | ".join(str(c) for c in r) + " |" for r in rows]
    lines += ["", "Median run time per rate level (s, 2 workers): "
              + ", ".join(f"{w:g} rad/s {v:.1f}" for w, v in per_level.items())
              + ". The truth (DOP853 at 1e-12 of the target's attitude) grows with the tumbling rate and dominates the fast levels.",
              f"1-min load average at the end: {os.getloadavg()[0]:.1f} (2 cores shared with other work)."]
    return "\n".join(lines)


#: The filter studies of Renis et al. §6 (their --quick sizes are set in studies/catalog/configs/<name>.toml).
FILTER_STUDIES = ("tuning", "init", "proxy")


def filter_studies_section(root: Path) -> str:
    """Wall time of the Renis et al. §6 studies at --quick with 1 and 2 local workers, and their recording size per run."""
    rows = []
    for name in FILTER_STUDIES:
        base = None
        for workers in (1, 2):
            out = root / f"{name}-quick-{workers}w"
            t0 = time.perf_counter()
            res = run_study(name, quick=True, out=out, workers=workers, progress=False)
            wall = time.perf_counter() - t0
            base = base or wall
            sizes = [p.stat().st_size for p in out.glob("runs/*/run.rrd")]
            rows.append((name, workers, len(res.runs), f"{wall:.1f}", f"{base / wall:.2f}×", f"{res.runs['elapsed_s'].median():.2f}",
                         f"{res.runs['n_steps'].iloc[0]}", f"{statistics.mean(sizes) / 1024:.0f}"))
    lines = [
        "### Filter studies of Renis et al. §6 at `--quick` (`lcnav study tuning|init|proxy --quick`)",
        "",
        "| study | local workers | runs | wall time (s) | speed-up vs 1 worker | median run (s) | steps per run | recording per run (KiB) |",
        "|---|---|---|---|---|---|---|---|",
    ]
    lines += ["| " + " | ".join(str(c) for c in r) + " |" for r in rows]
    lines += ["", "Wall time includes the local Dask cluster's start-up; a run includes its truth, filter, metrics, errors.parquet and run.rrd."]
    return "\n".join(lines)


def run() -> str:
    rows, notes = [], []
    load_before = os.getloadavg()[0]
    starts = {w: _cluster_start(w) for w in (1, 2)}
    with tempfile.TemporaryDirectory(prefix="lcnav-bench-studies-") as tmp:
        root = Path(tmp)
        for quick in (True, False):
            base = None
            for workers in (1, 2):
                wall, res, sizes = _timed(quick, workers, root)
                base = base or wall
                n = len(res.runs)
                run_s = res.runs["elapsed_s"]
                rows.append((
                    "quick" if quick else "full", workers, n, f"{wall:.1f}", f"{base / wall:.2f}×",
                    f"{run_s.median():.2f}", f"{run_s.sum() / wall:.2f}", f"{statistics.mean(sizes) / 1024:.0f}",
                ))
            if not quick:
                s = res.tables[0].frame
                worst = dict(zip(s["scenario"], s["worst (mm)"]))
                notes.append("Worst RK4 position error over a full run (mm): "
                             + ", ".join(f"{k} {v:.3g}" for k, v in worst.items()) + ".")
    lines = [
        "## Studies (truth-model check, `lcnav study truth`)",
        "",
        "| size | local workers | runs | wall time (s) | speed-up vs 1 worker | median run (s) | Σ run / wall | recording per run (KiB) |",
        "|---|---|---|---|---|---|---|---|",
    ]
    lines += ["| " + " | ".join(str(c) for c in r) + " |" for r in rows]
    lines += ["", "Quick: SC1 and SC4 × 3 seeds × 60 s; full: SC1-SC4 and COMBINA × 10 seeds × 300 s, RK4 at 0.05 s.",
              "Wall time includes starting the local Dask cluster: "
              + ", ".join(f"{starts[w]:.1f} s with {w} worker{'s' if w > 1 else ''}" for w in (1, 2))
              + " (measured alone in the same run). The machine's 2 cores are shared with other work, so the",
              f"speed-up is what a user would see here, not the ideal 2× (1-min load average {load_before:.1f} before,",
              f"{os.getloadavg()[0]:.1f} after). Σ run / wall is the parallelism achieved (run times summed over wall time).", *notes]
    with tempfile.TemporaryDirectory(prefix="lcnav-bench-filter-studies-") as tmp:
        lines += ["", filter_studies_section(Path(tmp))]
    return "\n".join(lines) + "\n\n" + run_coverage()
