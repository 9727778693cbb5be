"""CoMBiNa coverage against tumbling rate (Maestrini et al. §VII, Fig. 20): the full ``lcnav study coverage``, table and figure.

``python -m benchmarks coverage`` runs the study with its default config
(``studies/catalog/configs/coverage.toml``: levels 0.15 … 1.5 rad/s, 30 initial
conditions each up to 1.05 rad/s and 10 above, rigid-body k) on 2 local workers, copies its ``coverage.png`` (Fig. 20 with
Wilson intervals) to ``benchmarks/coverage.png`` and returns the summary table
as this section. ``lcnav study coverage --out DIR`` gives the same table and
figure in ``DIR``. Nothing is asserted here; the binomial checks are in
``tests/studies/test_coverage_study.py``.
"""

from __future__ import annotations

import shutil
import tempfile
import time
from pathlib import Path

import pandas as pd

from studies.engine.registry import run_study
from studies.engine.tables import to_markdown

HERE = Path(__file__).resolve().parent


def section(out_dir: Path, outcome_tables, wall_s: float, runs: pd.DataFrame) -> str:
    """The Markdown section of a finished coverage study in ``out_dir``; copies its figure next to RESULTS.md."""
    shutil.copyfile(out_dir / "coverage.png", HERE / "coverage.png")
    summary = next(t for t in outcome_tables if t.name == "summary")
    fr = summary.frame
    low = fr[fr["tumbling rate (rad/s)"] <= 1.0 + 1e-9]
    lines = [
        "## CoMBiNa coverage against tumbling rate (`lcnav study coverage`, Maestrini et al. §VII Fig. 20)",
        "",
        f"Full default study: {len(runs)} runs, {runs['elapsed_s'].sum() / 60:.1f} min of run time, {wall_s / 60:.1f} min wall on 2 workers. "
        f"Levels ≤ 1.0 rad/s: converged {low['converged runs'].sum()}/{low['runs'].sum()} "
        f"(lowest level fraction {low['converged'].min():.0%}); false symmetry switches on this asymmetric target: "
        f"{int(fr['false symmetry switches'].sum())}/{int(fr['runs'].sum())}. Figure: `benchmarks/coverage.png`.",
        "",
        to_markdown(summary),
    ]
    return "\n".join(lines)


def run() -> str:
    with tempfile.TemporaryDirectory(prefix="lcnav-bench-coverage-") as tmp:
        out = Path(tmp) / "coverage"
        t0 = time.perf_counter()
        res = run_study("coverage", out=out, workers=2, progress=False)
        return section(out, res.tables, time.perf_counter() - t0, res.runs)
