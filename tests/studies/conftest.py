"""Shared fixtures of the studies tests: one quick truth study run on a local Dask cluster."""

import os
from pathlib import Path

import pytest

from studies.cli import main

REPO = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="session")
def lcnav_env() -> dict:
    """The environment for lcnav/dask subprocesses: this checkout first on the path, analytics off."""
    env = dict(os.environ, RERUN_ANALYTICS="0", MPLBACKEND="Agg")
    env["PYTHONPATH"] = os.pathsep.join([str(REPO), *filter(None, [os.environ.get("PYTHONPATH")])])
    return env


@pytest.fixture(scope="session")
def quick_truth(tmp_path_factory) -> Path:
    """``lcnav study truth --quick --workers 2``: its output folder."""
    out = tmp_path_factory.mktemp("truth-quick") / "out"
    assert main(["study", "truth", "--quick", "--workers", "2", "--out", str(out)]) == 0
    return out
