"""`lcnav study timing --quick`: outputs, and ordered, positive percentiles of the iteration time (Fig. 19)."""

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from studies.catalog.timing_study import iterations_per_seed
from quick_study_checks import run_quick
from test_combina_study import assert_study_outputs


@pytest.fixture(scope="module")
def quick(tmp_path_factory) -> Path:
    return run_quick("timing", tmp_path_factory.mktemp("timing") / "out")


def test_outputs_recordings_and_export(quick, tmp_path):
    runs = assert_study_outputs(quick, ["timing.png"], tmp_path)
    assert runs["n_timed"].sum() == 40  # the quick config's n_iterations, shared by the seeds


def test_percentiles_ordered_positive_and_p99_reported(quick):
    s = pd.read_parquet(quick / "summary.parquet")
    assert s["percentile"].tolist() == [50.0, 90.0, 95.0, 99.0, 100.0]
    for col in ("prediction + update (ms)", "registration (ms)", "iteration (ms)"):
        v = s[col].to_numpy()
        assert np.all(v > 0) and np.all(np.diff(v) >= 0), col
    # an iteration is prediction + update + registration: each order statistic is at least the filter's
    assert np.all(s["iteration (ms)"] >= s["prediction + update (ms)"])
    p99 = s.loc[s["percentile"] == 99.0].iloc[0]
    assert np.isfinite(p99["prediction + update (ms)"])
    assert p99["prediction + update 95% lo"] <= p99["prediction + update (ms)"] <= p99["prediction + update 95% hi"]
    assert np.allclose(s["sustained rate (Hz)"], 1e3 / s["iteration (ms)"])
    assert "prediction + update" in (quick / "summary.md").read_text()


def test_iterations_split_evenly_over_seeds():
    assert iterations_per_seed(1000, 10) == [100] * 10
    assert iterations_per_seed(41, 3) == [14, 14, 13] and sum(iterations_per_seed(41, 3)) == 41
