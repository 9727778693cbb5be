"""`lcnav study proxy --quick` (Renis et al. §6.3): outputs and recordings; the proxy holds the rate through the fault."""

import numpy as np
import pandas as pd
import pytest

from quick_study_checks import check_outputs, check_recordings, run_quick


@pytest.fixture(scope="module")
def quick_proxy(tmp_path_factory):
    return run_quick("proxy", tmp_path_factory.mktemp("proxy-quick") / "out")


def test_outputs_and_recordings(quick_proxy, tmp_path, capsys):
    runs = check_outputs(quick_proxy, ["fault", "statistics"], ["fig7_proxy_errors.png"])
    check_recordings(quick_proxy, runs, tmp_path, capsys)
    # the proxy is pushed at every step after the first ("always"), never without it
    n = runs["n_steps"]
    assert (runs.loc[runs["proxy"], "proxy_steps"] == n[runs["proxy"]] - 1).all()
    assert (runs.loc[~runs["proxy"], "proxy_steps"] == 0).all()


def test_proxy_keeps_the_rate_error_during_the_fault_below_no_proxy(quick_proxy):
    runs = pd.read_parquet(quick_proxy / "runs.parquet")
    for f, g in runs.groupby("filter"):
        with_proxy = np.median(g.loc[g["proxy"], "fault_w_err_rms_rad_s"])
        without = np.median(g.loc[~g["proxy"], "fault_w_err_rms_rad_s"])
        assert with_proxy < without, f


def test_gate_rejects_most_faulty_measurements_and_table6_matches_runs(quick_proxy):
    runs = pd.read_parquet(quick_proxy / "runs.parquet")
    # 50x the pose noise: the chi-square gate (99 %) rejects the bulk of the fault's measurements
    for s in ("attitude", "position"):
        rej, acc = runs[f"fault_{s}_rejected"].sum(), runs[f"fault_{s}_accepted"].sum()
        assert rej > 4 * acc, s
    table = pd.read_parquet(quick_proxy / "summary.parquet").set_index(["basis", "component"])
    ekf = runs[(runs["filter"] == "ekf") & runs["proxy"]]
    assert table.loc[("state", "ω_ST"), "EKF +proxy"] == pytest.approx(1e3 * np.median(ekf["ess_w"]))
    assert "J_T^k" not in table.index.get_level_values("component")  # SC1: k considered, not estimated
