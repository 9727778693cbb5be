"""`lcnav study init --quick` (Renis et al. §6.2): outputs and recordings; the prior as initial condition speeds up k."""

import numpy as np
import pandas as pd
import pytest

from quick_study_checks import check_outputs, check_recordings, run_quick
from studies.catalog.filter_common import median_interval


@pytest.fixture(scope="module")
def quick_init(tmp_path_factory):
    return run_quick("init", tmp_path_factory.mktemp("init-quick") / "out")


def test_outputs_and_recordings(quick_init, tmp_path, capsys):
    runs = check_outputs(quick_init, ["table5", "k_convergence", "late_rmse", "statistics"], ["fig6_init_errors.png"])
    check_recordings(quick_init, runs, tmp_path, capsys)
    # every seed runs each filter with and without the prior, on the same seed (paired)
    assert set(runs["filter"]) == {"ekf", "ukf"}
    for (_, _), g in runs.groupby(["filter", "seed_index"]):
        assert sorted(g["prior"]) == [False, True] and g["seed"].nunique() == 1


def test_prior_lowers_the_ekf_convergence_time_of_k(quick_init):
    runs = pd.read_parquet(quick_init / "runs.parquet")
    ekf = runs[runs["filter"] == "ekf"]
    without = median_interval(ekf.loc[~ekf["prior"], "ct_k_s"].astype(float))[0]
    with_prior = median_interval(ekf.loc[ekf["prior"], "ct_k_s"].astype(float))[0]
    assert np.isfinite(with_prior) and (not np.isfinite(without) or with_prior < without)
    # and the summary table says the same
    table = pd.read_parquet(quick_init / "summary.parquet").set_index(["basis", "component"])
    assert table.loc[("state", "J_T^k"), "EKF +prior"] == pytest.approx(with_prior)


def test_prior_starts_the_rate_within_its_error(quick_init):
    runs = pd.read_parquet(quick_init / "runs.parquet")
    # SC3: |ω_T| = 0.0492 rad/s; the prior is 5 % off; the servicer's own rate (orbital, 1.1e-3 rad/s)
    # enters ω_ST through the unknown attitude: |ω̂_0 − ω_0| <= |prior error| + 2|ω_S|
    w_T = np.hypot(0.020, 0.045)
    prior = runs[runs["prior"]]
    np.testing.assert_allclose(prior["prior_w_err_rad_s"], 0.05 * w_T, rtol=1e-9)
    assert (prior["w0_err_rad_s"] <= prior["prior_w_err_rad_s"] + 2 * 1.2e-3).all()
    assert (runs.loc[~runs["prior"], "w0_err_rad_s"] > 0.8 * w_T).all()
    # starting within the 2 deg/s threshold, the rate is converged from t = 0 (Table 4 of Renis et al.: 0 s)
    assert (prior["ct_w_s"] == 0).all()


def test_the_second_half_table_is_the_paired_change_of_the_runs(quick_init):
    """The ``late_rmse`` table against the runs: per filter and component the medians of both arms and the mean of the
    per-seed differences (with − without); every RMSE positive and finite (no run diverged in the quick size)."""
    runs = pd.read_parquet(quick_init / "runs.parquet")
    table = pd.read_parquet(quick_init / "late_rmse.parquet").set_index(["filter", "component"])
    for f in ("ekf", "ukf"):
        mine = runs[runs["filter"] == f]
        a = mine[~mine["prior"]].set_index("seed_index")["late_rmse_w"]
        b = mine[mine["prior"]].set_index("seed_index")["late_rmse_w"]
        assert np.all(np.isfinite(a)) and np.all(a > 0) and np.all(b > 0)
        row = table.loc[(f.upper(), "ω_ST")]
        assert row["no prior (x1e-3, median)"] == pytest.approx(1e3 * np.median(a))
        assert row["paired change (x1e-3, mean)"] == pytest.approx(1e3 * np.mean(b - a.loc[b.index]))
        assert row["change lo"] <= row["paired change (x1e-3, mean)"] <= row["change hi"]
