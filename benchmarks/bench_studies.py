"""Studies: wall time of the truth-model check study and the §6 filter studies, 1 vs 2 local Dask workers, and recording sizes.

The coverage study's wall time is in its own benchmark (``python -m benchmarks coverage``, the full study).

Each configuration runs ``run_study`` from scratch into a fresh folder (the
local cluster's start-up included, as a user would see it). The baseline of
the speed-up is the 1-worker run of the same size measured in the same run.
"""

from __future__ import annotations

import os
import statistics
import tempfile
import time
from pathlib import Path

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
    return "\n".join(lines)
