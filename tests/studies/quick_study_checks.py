"""Checks every filter study's ``--quick`` run must pass (tuning, init, proxy): outputs, recordings, export."""

from pathlib import Path

import numpy as np
import pandas as pd

from studies.cli import main
from studies.recording.reader import TIME_COLUMN
from tests.rerun_cli import assert_rrd_verifies

PNG = b"\x89PNG\r\n\x1a\n"


def run_quick(name: str, out: Path) -> Path:
    """``lcnav study NAME --quick --workers 2 --out OUT``; returns OUT."""
    assert main(["study", name, "--quick", "--workers", "2", "--out", str(out)]) == 0
    return out


def check_outputs(out: Path, tables, figures) -> pd.DataFrame:
    """runs/summary tables (Parquet, CSV, Markdown), the named extra tables and figures exist; returns the runs table."""
    runs = pd.read_parquet(out / "runs.parquet")
    for name in ["runs", "summary", *tables]:
        assert (out / f"{name}.parquet").is_file() and (out / f"{name}.csv").is_file(), name
    md = (out / "summary.md").read_text()
    assert md.count("\n### ") >= 1 + len(tables)
    for fig in figures:
        data = (out / fig).read_bytes()
        assert data[:8] == PNG and len(data) > 10_000, fig
    return runs


def check_recordings(out: Path, runs: pd.DataFrame, tmp_path: Path, capsys) -> None:
    """One run.rrd per run, all pass ``rerun rrd verify``; ``lcnav inspect --export`` gives one row per step."""
    rrds = [out / "runs" / rid / "run.rrd" for rid in runs["run_id"]]
    assert all(p.is_file() for p in rrds)
    assert_rrd_verifies(*rrds)
    for row in (runs.iloc[0], runs.iloc[-1]):
        exp = tmp_path / f"{row['run_id']}.parquet"
        assert main(["inspect", str(out / "runs" / row["run_id"]), "--export", str(exp)]) == 0
        capsys.readouterr()
        df = pd.read_parquet(exp)
        n = int(row["n_steps"])
        assert len(df) == n == int(round(row["duration_s"] / row["dt_s"])) + 1
        np.testing.assert_allclose(df[TIME_COLUMN], np.arange(n) * row["dt_s"])
