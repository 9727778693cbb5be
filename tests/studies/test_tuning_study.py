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
