"""``lcnav demo`` and ``lcnav study chain --quick``: wall time on this machine, and recording sizes.

The demo's goal (issue 7): under 5 minutes on 2 cores (``make demo``). The
baseline measured in the same run is the demo's ``--quick`` size. The chain
study's quick size runs with 1 and with 2 local Dask workers (speed-up).
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

from studies.catalog.demo import QUICK, DemoConfig, run_demo
from studies.engine.registry import run_study

GOAL_S = 300.0


def _demo(config: DemoConfig, out: Path) -> tuple[float, dict]:
    t0 = time.perf_counter()
    run_demo(out, config, progress=False, echo=lambda *_: None)
    elapsed = time.perf_counter() - t0
    return elapsed, {p.name: p.stat().st_size for p in out.glob("*.rrd")}


def run() -> str:
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        t_quick, _ = _demo(QUICK, tmp / "quick")
        t_full, sizes = _demo(DemoConfig(), tmp / "full")
        chain = {}
        for workers in (1, 2):
            t0 = time.perf_counter()
            run_study("chain", quick=True, out=tmp / f"chain-{workers}", workers=workers, progress=False)
            chain[workers] = time.perf_counter() - t0
    lines = [
        "## lcnav demo and the chain study",
        "",
        "| run | wall time (s) | vs demo --quick | vs 5-min goal |",
        "|---|---|---|---|",
        f"| `lcnav demo --quick` (baseline) | {t_quick:.1f} | 1.00 | {t_quick / GOAL_S:.2f} |",
        f"| `lcnav demo` (make demo) | {t_full:.1f} | {t_full / t_quick:.2f} | {t_full / GOAL_S:.2f} |",
        f"| `lcnav study chain --quick --workers 1` | {chain[1]:.1f} | {chain[1] / t_quick:.2f} | – |",
        f"| `lcnav study chain --quick --workers 2` | {chain[2]:.1f} | {chain[2] / t_quick:.2f} | – |",
        "",
        f"Chain quick speed-up with 2 workers: {chain[1] / chain[2]:.2f}× (2 runs; Dask start-up included).",
        "",
        "| demo recording | size (kB) |",
        "|---|---|",
        *(f"| {name} | {size / 1e3:.0f} |" for name, size in sorted(sizes.items())),
    ]
    return "\n".join(lines)
