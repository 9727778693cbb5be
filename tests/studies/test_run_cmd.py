"""`lcnav run`: the three outputs, their content, and one-line refusal of bad input with no output."""

import dataclasses
import json

import numpy as np
import pandas as pd
import pytest

from estimators.state import K_STATES, R_ST_T
from studies.cli import main
from studies.sim.scenarios import get_scenario
from tests.rerun_cli import assert_rrd_verifies, rerun



def test_run_writes_metrics_states_and_recording(tmp_path, capsys):
    out = tmp_path / "run"
    args = ["run", "--scenario", "SC1", "--filter", "ukf", "--duration", "40", "--dt", "1", "--prior", "proxy", "--prior-error", "0.05",
            "--fault", "20,5", "--runs", "2", "--seed", "3", "--out", str(out)]
    assert main(args) == 0
    m = json.loads((out / "metrics.json").read_text())
    assert m["filter"] == "ukf" and m["scenario"] == "SC1"
    # the printed summary is metrics.json's: one line per group with its mean t_conv and RMSE, then NEES/NIS and gates
    printed = capsys.readouterr().out.splitlines()
    for g, c in m["components_mean_over_runs"].items():
        row = next(line.split() for line in printed if line.split()[:1] == [g])
        t_conv, rmse = c["convergence_time_s"], c["steady_state_rmse"]
        assert row[1] == ("–" if t_conv is None else f"{t_conv:.1f}") and row[2] == ("–" if rmse is None else f"{rmse:.3g}")
    assert any("NEES in its 95 % band" in line for line in printed) and any(line.strip().startswith("gates") for line in printed)
    assert set(m["components"]) == {"q", "w", "r", "v", "k"}
    for c in m["components"].values():
        assert set(c) == {"convergence_time_s", "steady_state_rmse"}
    assert m["nees_fraction_in_95"] is None or 0.0 <= m["nees_fraction_in_95"] <= 1.0
    assert set(m["nis_fraction_in_95"]) == {"attitude", "position"}
    assert m["nees"]["runs"] == 2 and m["nees"]["dof"] == 12  # k considered, not estimated, in SC1
    assert "per_dof_alone" not in m["nees"]  # 40 s: no step after the 60-s settling time to average
    assert m["config"]["tuning"] == "fixed-lag-torque-free"  # the torque-free world's default, with a prior too (estimators.tuning.DEFAULT_TUNINGS)
    np.testing.assert_allclose(m["config"]["prior_w_T_T_rad_s"], [0.0, 0.0, 0.0525])
    df = pd.read_parquet(out / "states.parquet")
    assert len(df) == 41
    for col in ["t_s", "true_q_TS_0", "est_w_ST_T_z_rad_s", "sigma3_r_x_m", "sigma3_dq_z_rad", "nis_attitude", "accepted_position", "proxy_used"]:
        assert col in df.columns
    q = df[[f"est_q_TS_{i}" for i in range(4)]].to_numpy()
    np.testing.assert_allclose(np.linalg.norm(q, axis=1), 1.0, atol=1e-12)
    assert df["proxy_used"].iloc[1:].all()  # --proxy-mode always
    # the state-based metric agrees with the table: r error below 1 m from its convergence time on
    err_r = np.linalg.norm(df[[f"est_r_ST_T_{a}_m" for a in "xyz"]].to_numpy() - df[[f"true_r_ST_T_{a}_m" for a in "xyz"]].to_numpy(), axis=1)
    tc = m["components"]["r"]["convergence_time_s"]
    if tc is not None:
        assert np.all(err_r[df["t_s"] >= tc] < 1.0)
        assert m["components"]["r"]["steady_state_rmse"] == pytest.approx(np.sqrt(np.mean(err_r[df["t_s"] >= tc] ** 2)))
    assert_rrd_verifies(out / "run.rrd")
    printed = rerun("rrd", "print", out / "run.rrd").stdout
    for path in ["/truth/w_ST_T/z", "/estimate/ukf/r_ST_T/x", "/estimate/ukf/error/q_TS/x/plus3sigma", "/measurement/position/r_ST_T/y",
                 "/gate/ukf/attitude/e2", "/gate/ukf/position/upper", "/gate/ukf/log"]:
        assert path in printed, path


def _bad_measurements(tmp_path):
    p = tmp_path / "meas.csv"
    t = np.arange(1.0, 11.0)
    df = pd.DataFrame({"t_s": t, "q_TS_0": 1.0, "q_TS_1": 0.0, "q_TS_2": 0.0, "q_TS_3": 0.0, "r_ST_T_x_m": 0.0, "r_ST_T_y_m": 50.0, "r_ST_T_z_m": 0.0})
    df.loc[4, "r_ST_T_y_m"] = np.nan
    df.to_csv(p, index=False)
    return p


def test_prior_from_a_light_curve_json(tmp_path):
    """`lcnav lightcurve prior --json` output as the prior (rate about the assumed z axis)."""
    pj = tmp_path / "prior.json"
    pj.write_text(json.dumps({"significant": True, "rate_rad_s": 0.0504, "rate_sigma_rad_s": 0.001}))
    out = tmp_path / "run"
    assert main(["run", "--scenario", "SC1", "--duration", "20", "--prior", "init", "--prior-json", str(pj), "--out", str(out)]) == 0
    m = json.loads((out / "metrics.json").read_text())
    np.testing.assert_allclose(m["config"]["prior_w_T_T_rad_s"], [0.0, 0.0, 0.0504])
    df = pd.read_parquet(out / "states.parquet")
    # ω_ST_0 = R(q̂_0) ω_S − ω_prior with q̂_0 = 1 and the servicer's orbit rate about its z
    n = get_scenario("SC1").mean_motion_rad_s  # the servicer is LVLH-pointing: ω_S_S = [0, 0, n]
    assert df["est_w_ST_T_z_rad_s"].iloc[0] == pytest.approx(n - 0.0504, abs=1e-12)
    assert df["est_w_ST_T_x_rad_s"].iloc[0] == 0.0 and df["est_w_ST_T_y_rad_s"].iloc[0] == 0.0


@pytest.mark.parametrize(
    "extra, message",
    [
        (["--filter", "kf"], "--filter 'kf': expected one of ekf, ukf"),
        (["--prior", "init", "--prior-rate-deg-s", " "], "prior without a rate"),
        (["--prior", "init", "--prior-rate-deg-s", "0,nan,3"], "--prior-rate-deg-s (prior rate) '0,nan,3': expected 3 comma-separated finite numbers"),
        (["--p0-diag", ",".join(["1"] * 13 + ["-1"])], "expected 14 variances > 0 (P_0 positive definite)"),
        (["--p0-diag", "1,2"], "--p0-diag '1,2': expected 14 comma-separated"),
        ("MEAS", "row 4 has a NaN, Inf or empty cell"),
        ("NORATE", "prior without a rate"),
        (["--prior", "sometimes"], "--prior 'sometimes': expected one of none, init, proxy"),
        (["--tuning", "fast"], "--tuning 'fast': expected one of"),
        (["--fault", "10"], "--fault '10': expected 2 comma-separated"),
        (["--runs", "0"], "--runs 0: expected an integer within [1, 1000]"),
    ],
)
def test_bad_input_one_line_nonzero_exit_no_output(tmp_path, capsys, extra, message):
    out = tmp_path / "out"
    if extra == "MEAS":
        extra = ["--measurements", str(_bad_measurements(tmp_path))]
    if extra == "NORATE":  # a light curve without a significant period
        pj = tmp_path / "prior.json"
        pj.write_text(json.dumps({"significant": False, "rate_rad_s": None, "rate_sigma_rad_s": None}))
        extra = ["--prior", "proxy", "--prior-json", str(pj)]
    code = main(["run", "--scenario", "SC1", "--duration", "10", "--dt", "1", "--out", str(out), *extra])
    err = capsys.readouterr().err
    assert code != 0
    assert err.count("\n") == 1 and err.startswith("lcnav: ") and message in err, err
    assert not out.exists()


def test_navigate_draws_and_filters_with_one_pose_noise():
    """``navigate`` simulates with ``pose_noise`` and gives the filter the same ``R_d`` (unless told to mis-model)."""
    from estimators.measurement import PoseNoise
    from estimators.tuning import get_tuning
    from studies.sim.navigation import NavigationSetup, navigate
    from studies.sim.scenarios import get_scenario
    from studies.sim.truth import simulate_truth

    tr = simulate_truth(get_scenario("SC1"), 400.0, 1.0)
    noise = PoseNoise(0.03, 1.2, "gaussian")
    setup = NavigationSetup("ekf", get_tuning("sc1-paper"), pose_noise=noise, consider=K_STATES)
    run, (_, _, r, _) = navigate(tr, setup, np.random.default_rng(3))
    assert run.pose_noise == noise
    # 1200 position-error components of sd 1.2/sqrt(3): their variance within 15 % of R (0.48 m²; ~4 % sd at this size)
    assert np.var(r - tr.x[1:, R_ST_T]) == pytest.approx(noise.R_position[0, 0], rel=0.15)
    wrong = PoseNoise()
    run, _ = navigate(tr, dataclasses.replace(setup, filter_noise=wrong), np.random.default_rng(3))
    assert run.pose_noise == wrong


def _simulated_files(tmp_path, dt_truth="0.5"):
    """``lcnav simulate`` of SC1 (70 s at ``dt_truth``) and a measurement file drawn from it at 1 s (eqs 33–34 noise)."""
    from perception.simulated_pose import simulate_pose_measurements

    sim = tmp_path / f"sim{dt_truth}"
    assert main(["simulate", "--scenario", "SC1", "--duration", "70", "--dt", dt_truth, "--out", str(sim)]) == 0
    truth = pd.read_parquet(sim / "truth.parquet")
    on_grid = np.isclose(truth["t_s"] % 1.0, 0.0) | np.isclose(truth["t_s"] % 1.0, 1.0)
    x = truth.loc[on_grid, [c for c in truth.columns if c.startswith(("q_TS", "w_ST", "r_ST", "v_ST", "k"))]].to_numpy()
    t = truth.loc[on_grid, "t_s"].to_numpy()
    m = simulate_pose_measurements(t, x, np.random.default_rng(5), tau_s=1.0, sigma_q_rad=0.03, sigma_r_m=0.2)
    meas = tmp_path / "meas.parquet"
    cols = {"t_s": m.t, **{f"q_TS_{i}": m.q_TS[:, i] for i in range(4)}, **{f"r_ST_T_{a}_m": m.r_ST_T[:, j] for j, a in enumerate("xyz")}}
    pd.DataFrame(cols).to_parquet(meas, index=False)
    return sim / "truth.parquet", meas


def test_measurement_file_is_scored_only_against_its_truth_file(tmp_path, capsys):
    """A user's measurements: no truth-based metric without --truth-file; with it, the file's truth is the one scored against."""
    truth_file, meas = _simulated_files(tmp_path)
    base = ["run", "--scenario", "SC1", "--duration", "70", "--dt", "1", "--sigma-q-rad", "0.03", "--sigma-r-m", "0.2", "--measurements", str(meas)]
    capsys.readouterr()
    assert main([*base, "--out", str(tmp_path / "blind")]) == 0
    printed = capsys.readouterr().out
    m = json.loads((tmp_path / "blind" / "metrics.json").read_text())
    for key in ("components", "filter_components", "components_mean_over_runs", "nees", "nees_fraction_in_95"):
        assert key not in m
    assert set(m["nis_fraction_in_95"]) == {"attitude", "position"} and set(m["gate_rejection_rate"]) == {"attitude", "position"}
    assert m["config"]["scored_against"] is None
    assert "NEES" not in printed and "RMSE" not in printed and "NIS in band" in printed
    assert all(0.0 <= f <= 1.0 for f in m["nis_fraction_in_95"].values())  # 11 steps after the 60 s settling
    df = pd.read_parquet(tmp_path / "blind" / "states.parquet")
    assert not any(c.startswith("true_") for c in df.columns) and "nis_attitude" in df.columns
    assert "/truth/" not in rerun("rrd", "print", tmp_path / "blind" / "run.rrd").stdout

    assert main([*base, "--truth-file", str(truth_file), "--out", str(tmp_path / "scored")]) == 0
    m = json.loads((tmp_path / "scored" / "metrics.json").read_text())
    assert m["nees"]["dof"] == 12 and m["config"]["scored_against"] == str(truth_file)
    # the 11 steps after the settling time: NEES/dof of each block alone and given the other blocks (k considered in SC1)
    n = m["nees"]
    assert set(n["per_dof_alone"]) == set(n["per_dof_given_rest"]) == {"q", "w", "r", "v"}
    assert all(v > 0 for v in [n["per_dof"], *n["per_dof_alone"].values(), *n["per_dof_given_rest"].values()])
    line = next(line for line in capsys.readouterr().out.splitlines() if "given the other blocks" in line)
    assert f"NEES/dof {n['per_dof']:.2f}" in line and f"q {n['per_dof_given_rest']['q']:.2f}" in line
    df = pd.read_parquet(tmp_path / "scored" / "states.parquet")
    truth = pd.read_parquet(truth_file).set_index("t_s")
    # the true_* columns are the truth file's rows at the filter's times (every second row of a 0.5 s truth)
    np.testing.assert_array_equal(df["true_r_ST_T_y_m"].to_numpy(), truth.loc[df["t_s"], "r_ST_T_y_m"].to_numpy())
    err_r = np.linalg.norm(df[[f"est_r_ST_T_{a}_m" for a in "xyz"]].to_numpy() - df[[f"true_r_ST_T_{a}_m" for a in "xyz"]].to_numpy(), axis=1)
    tc = m["components"]["r"]["convergence_time_s"]
    if tc is not None:
        assert m["components"]["r"]["steady_state_rmse"] == pytest.approx(np.sqrt(np.mean(err_r[df["t_s"] >= tc] ** 2)))


def test_truth_file_at_other_times_is_refused(tmp_path, capsys):
    truth_file, meas = _simulated_files(tmp_path)
    other = tmp_path / "other"
    assert main(["simulate", "--scenario", "SC1", "--duration", "70", "--dt", "0.7", "--out", str(other)]) == 0
    other = other / "truth.parquet"
    capsys.readouterr()
    out = tmp_path / "out"
    code = main(["run", "--scenario", "SC1", "--duration", "70", "--dt", "1", "--measurements", str(meas), "--truth-file", str(other), "--out", str(out)])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and not out.exists(), err
    assert err.startswith("lcnav: error: --truth-file") and "expected a row at every filter time 0, 1, ..., 70 s" in err, err
    # a truth file without measurements, and another scenario's truth, are refused the same way
    for extra, message in ((["--truth-file", str(truth_file)], "expected it with --measurements"),
                           (["--scenario", "SC3", "--measurements", str(meas), "--truth-file", str(truth_file)],
                            "scenario 'SC1': expected the run's --scenario SC3")):
        code = main(["run", "--scenario", "SC1", "--duration", "70", "--dt", "1", *extra, "--out", str(out)])
        err = capsys.readouterr().err
        assert code == 2 and err.startswith("lcnav: error: ") and message in err and not out.exists(), err
