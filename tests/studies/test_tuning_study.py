"""`lcnav study tuning --quick` (Renis et al. §6.1, Algorithm 1): outputs and recordings; the score and the selection."""

import numpy as np
import pandas as pd
import pytest

from quick_study_checks import check_outputs, check_recordings, run_quick
from studies.engine.config import default_config_path, read_toml


@pytest.fixture(scope="module")
def quick_tuning(tmp_path_factory):
    return run_quick("tuning", tmp_path_factory.mktemp("tuning-quick") / "out")


def test_outputs_and_recordings(quick_tuning, tmp_path, capsys):
    runs = check_outputs(quick_tuning, ["table3", "chosen", "scores", "statistics"], ["tuning_scores.png"])
    check_recordings(quick_tuning, runs, tmp_path, capsys)
    q = read_toml(default_config_path("tuning"))["quick"]
    n_points = len(q["q_exponents"]) ** len(q["q_blocks"])
    assert len(runs) == len(q["filters"]) * len(q["scenarios"]) * n_points * q["n_seeds"]
    # every grid point of a scenario sees the same seeds (paired comparison)
    assert (runs.groupby(["scenario", "seed_index"])["seed"].nunique() == 1).all()


def test_score_is_algorithm_1_and_the_selection_its_minimum(quick_tuning):
    runs = pd.read_parquet(quick_tuning / "runs.parquet")
    scores = pd.read_parquet(quick_tuning / "scores.parquet")
    for (f, sc), g in scores.groupby(["filter", "scenario"]):
        r = runs[(runs["filter"] == f) & (runs["scenario"] == sc)]
        ct = r.groupby("q_index")["C_t_s"].mean().loc[g["q_index"]].to_numpy()
        es = r.groupby("q_index")["E_SS"].mean().loc[g["q_index"]].to_numpy()
        norm = lambda x: (x - x.min()) / (x.max() - x.min()) if np.ptp(x) > 0 else 0 * x  # noqa: E731
        np.testing.assert_allclose(g["G"], 0.5 * norm(ct) + 0.5 * norm(es), atol=1e-12)
        assert g.loc[g["rank"] == 1, "G"].item() == g["G"].min()
    chosen = pd.read_parquet(quick_tuning / "chosen.parquet")
    sc4 = chosen[chosen["scenario"] == "SC4"]
    assert (sc4["KF_sc point"] == sc4["KF_gen point"]).all()  # KF_gen is the best on SC4 by definition
    assert (chosen["G of KF_sc"] <= chosen["G of KF_gen"]).all()


def test_more_rate_process_noise_gives_a_noisier_rate_estimate(quick_tuning):
    # a filter that trusts its (exact, torque-free) model less lets more measurement noise through:
    # on SC3 with Q_w = 1e-6 the rate converges below 2 deg/s on every seed; with Q_w = 1e-2 it ends
    # with a larger steady-state error or never converges, and its score term E_SS is larger, seed by seed
    runs = pd.read_parquet(quick_tuning / "runs.parquet")
    r = runs[(runs["scenario"] == "SC3") & (runs["q_exp_k"] == -6)]
    lo = r[r["q_exp_w_ST_T"] == -6].set_index("seed_index")
    hi = r[r["q_exp_w_ST_T"] == -2].set_index("seed_index").loc[lo.index]
    assert np.isfinite(lo["ess_w"]).all()
    assert (~np.isfinite(hi["ess_w"]) | (hi["ess_w"] > lo["ess_w"])).all()
    assert (hi["E_SS"] > lo["E_SS"]).all()


def test_a_grid_point_tunes_the_base_filter_it_names():
    """On ``fixed-lag`` a grid point keeps the window, settling phase and process model; its ω and v blocks set the matched
    budget's intensities, so its Q_d is eq. 1's discretisation of them (with the attitude–rate and position–velocity cross
    terms), not a diagonal; the point without exponents is the base itself."""
    from estimators.process_noise import relative_Q_d
    from estimators.tuning import get_tuning
    from studies.catalog.tuning_study import grid_tuning

    base = get_tuning("fixed-lag")
    t = grid_tuning({"q_base_tuning": "fixed-lag", "q_index": 3, "q_exp_w_ST_T": -11, "q_exp_v_ST_T": -9, "q_exp_q_TS": -7})
    assert (t.lag_s, t.relinearize_s, t.settling_s, t.gravity_gradient) == (base.lag_s, base.relinearize_s, base.settling_s, True)
    expected = relative_Q_d(1e-11, 1e-9, base.budget.q_kdot_1_s, 1.0) + np.diag(np.r_[[1e-7] * 3, [0.0] * 11])
    np.testing.assert_allclose(t.Q_d(1.0), expected, rtol=1e-12, atol=0)
    assert t.Q_d(1.0)[0, 3] != 0.0  # the rate's intensity reaches the attitude through the step
    assert grid_tuning({"q_base_tuning": "fixed-lag", "q_exp_w_ST_T": float("nan")}) is base
    # the paper's base has no budget: a block's rate is the diagonal Q_d rate, as in Algorithm 1
    g = grid_tuning({"q_base_tuning": "general-conservative", "q_exp_w_ST_T": -6})
    np.testing.assert_allclose(np.diag(g.Q_d(2.0))[3:6], 2e-6)


def test_a_sigma_budget_base_is_refused(tmp_path):
    from studies.engine.config import ConfigError
    from studies.engine.registry import get_study

    text = default_config_path("tuning").read_text().replace('q_base_tuning = "general-conservative"', 'q_base_tuning = "budgeted"')
    (tmp_path / "tuning.toml").write_text(text)
    with pytest.raises(ConfigError, match="budgeted.*σ budget"):
        get_study("tuning").load(tmp_path / "tuning.toml", quick=False)


def test_each_run_reports_its_settled_nees(quick_tuning):
    runs = pd.read_parquet(quick_tuning / "runs.parquet")
    ok = runs[~runs["diverged"].astype(bool)]
    assert np.isfinite(ok["nees_per_dof"]).all() and (ok["nees_per_dof"] > 0).all()
    chosen = pd.read_parquet(quick_tuning / "chosen.parquet")
    assert np.isfinite(chosen["NEES/dof of KF_sc"]).all()
