"""The selectable truth (`--truth torque-free|perturbed`) and the disturbance budget built on it."""

import json
import numpy as np
import pandas as pd
import pytest

from estimators import dynamics as dyn
from estimators import perturbations as pt
from estimators.attitude import quat_to_dcm
from estimators.state import Q_IB, R_I, V_I, W_B, W_ST_T
from estimators.perturbations import TRUTH_PHYSICS
from studies.catalog import truth_study
from studies.cli import main
from studies.engine.config import ConfigError, default_config_path
from studies.engine.registry import get_study
from studies.engine.sweep import RunSpec
from studies.sim.disturbance import disturbance_budget
from studies.sim.scenarios import get_scenario
from studies.sim.truth import initial_states, simulate_truth


def test_torque_free_truth_is_the_two_keplerian_torque_free_integrations():
    sc = get_scenario("SC3")
    tr = simulate_truth(sc, 60.0, 1.0)
    target0, servicer0 = initial_states(sc)
    assert tr.physics.name == "torque-free"
    assert np.array_equal(tr.target, dyn.integrate_absolute(target0, tr.t, dyn.inertia_from_k(*sc.k)).y)
    assert np.array_equal(tr.servicer, dyn.integrate_absolute(servicer0, tr.t, np.asarray(sc.J_S_diag)).y)


def test_perturbed_truth_is_reproducible_and_its_relative_state_derived():
    sc = get_scenario("SC3")
    a = simulate_truth(sc, 60.0, 1.0, "perturbed")
    b = simulate_truth(sc, 60.0, 1.0, pt.get_truth_physics("perturbed"))
    assert np.array_equal(a.x, b.x) and np.array_equal(a.target, b.target)
    np.testing.assert_array_equal(a.x, dyn.relative_state(a.target, a.servicer, sc.k))
    ref = simulate_truth(sc, 60.0, 1.0)
    assert np.max(np.abs(a.x[:, W_ST_T] - ref.x[:, W_ST_T])) > 1e-6  # rad/s: the physics is there
    with pytest.raises(pt.TruthPhysicsError, match="expected torque-free or perturbed"):
        simulate_truth(sc, 60.0, 1.0, "kepler")


@pytest.fixture(scope="module")
def sc3_perturbed():
    sc = get_scenario("SC3")
    return sc, simulate_truth(sc, 600.0, 1.0, "perturbed"), disturbance_budget(sc, "perturbed", 600.0)


def test_budget_gravity_gradient_matches_the_analytic_angular_acceleration(sc3_perturbed):
    """``ω̇_x = 3μ/r⁵ (C − B)/A r_y r_z`` (and cyclic) in T, at most ``3 n² |ΔJ/J|/2``."""
    sc, tr, budget = sc3_perturbed
    A, B, C = dyn.inertia_from_k(*sc.k)
    r_T = np.einsum("nji,nj->ni", quat_to_dcm(tr.target[:, Q_IB]), tr.target[:, R_I])
    r = np.linalg.norm(r_T, axis=1)
    k = 3 * dyn.MU_EARTH / r**5
    w_dot = np.stack([k * (C - B) / A * r_T[:, 1] * r_T[:, 2], k * (A - C) / B * r_T[:, 2] * r_T[:, 0], k * (B - A) / C * r_T[:, 0] * r_T[:, 1]], 1)
    gg = budget.angular_T["gravity_gradient"]
    np.testing.assert_allclose(gg.rms_axis, np.sqrt(np.mean(w_dot**2, 0)), rtol=1e-9)
    n2_max = dyn.MU_EARTH / r.min() ** 3
    bound = 1.5 * n2_max * np.abs([(C - B) / A, (A - C) / B, (B - A) / C])
    assert np.all(np.max(np.abs(w_dot), 0) <= bound)
    assert gg.max > 0.5 * bound.max()  # a tumbler sees the full torque within 600 s
    assert budget.table().query("term == 'gravity_gradient'")["max"].iloc[0] == gg.max


def test_budget_differential_j2_is_the_gradient_times_the_separation(sc3_perturbed):
    """Over 50 m the differential J2 acceleration is the linearised one, ``G (r_S − r_T)``, to 1e-3, of order
    ``(3/2) J2 μ R_E²/r⁵ · d`` (factor 1 to 5)."""
    sc, tr, budget = sc3_perturbed
    f = pt.J2_EARTH, dyn.R_EARTH
    lin = []
    for rt, rs in zip(tr.target[:, R_I], tr.servicer[:, R_I]):
        G = np.array([(np.array(pt.j2_acceleration(tuple(rt + e), dyn.MU_EARTH, *f)) - pt.j2_acceleration(tuple(rt - e), dyn.MU_EARTH, *f)) / 2.0
                      for e in np.eye(3)]).T
        lin.append(G @ (rs - rt))
    C_LI = dyn.lvlh_dcm(tr.servicer[:, R_I], tr.servicer[:, V_I])
    lin_L = np.einsum("nij,nj->ni", C_LI, np.array(lin))
    j2 = budget.translational_L["j2"]
    np.testing.assert_allclose(j2.rms_axis, np.sqrt(np.mean(lin_L**2, 0)), rtol=1e-3)
    d, r = 50.0, sc.orbit_radius_m
    order = 1.5 * pt.J2_EARTH * dyn.MU_EARTH * dyn.R_EARTH**2 / r**5 * d
    assert order < j2.max < 5 * order
    assert budget.translational_T["j2"].rms == pytest.approx(j2.rms, rel=1e-12)  # a rotation keeps the norm
    assert budget.translational_L["srp"].max == 0.0  # off in 'perturbed'


def test_budget_of_the_torque_free_truth_is_zero():
    b = disturbance_budget(get_scenario("SC1"), "torque-free", 10.0)
    assert all(s.max == 0.0 for d in (b.angular_T, b.translational_L, b.translational_T) for s in d.values())


def test_simulate_truth_flag_writes_the_perturbed_truth_and_says_so(tmp_path):
    args = ["simulate", "--scenario", "SC3", "--duration", "60", "--dt", "1"]
    assert main([*args, "--out", str(tmp_path / "tf")]) == 0
    assert main([*args, "--truth", "perturbed", "--out", str(tmp_path / "p")]) == 0
    tf, p = pd.read_parquet(tmp_path / "tf" / "truth.parquet"), pd.read_parquet(tmp_path / "p" / "truth.parquet")
    assert tf.attrs["truth"] == "torque-free" and p.attrs["truth"] == "perturbed"
    assert p.attrs["truth_physics"]["terms"] == ["gravity_gradient", "j2", "drag", "dissipation"]
    cols = [f"w_ST_T_{a}_rad_s" for a in "xyz"]
    assert np.array_equal(tf[cols].iloc[0], p[cols].iloc[0])  # same initial state
    assert np.max(np.abs(tf[cols].to_numpy() - p[cols].to_numpy())) > 1e-6  # rad/s after 60 s


@pytest.mark.parametrize("command", ["simulate", "run"])
def test_bad_truth_is_one_line_and_exit_2(tmp_path, capsys, command):
    out = tmp_path / "bad"
    assert main([command, "--truth", "kepler", "--out", str(out)]) == 2
    assert capsys.readouterr().err.strip().splitlines() == ["lcnav: error: --truth 'kepler': expected torque-free or perturbed"]
    assert not out.exists()


def test_run_records_the_truth_in_metrics(tmp_path):
    out = tmp_path / "run"
    assert main(["run", "--scenario", "SC3", "--duration", "20", "--dt", "1", "--truth", "perturbed", "--out", str(out)]) == 0
    cfg = json.loads((out / "metrics.json").read_text())["config"]
    assert cfg["truth"] == "perturbed" and cfg["truth_physics"]["nutation_time_constant_s"] == 86400.0


@pytest.mark.parametrize("study", ["truth", "tuning", "init", "proxy", "chain", "combina", "coverage"])
def test_study_configs_default_to_the_torque_free_truth_and_refuse_another_name(tmp_path, study):
    definition = get_study(study)
    assert definition.load().params["truth"] == "torque-free"
    bad = tmp_path / f"{study}.toml"
    bad.write_text(default_config_path(study).read_text().replace('truth = "torque-free"', 'truth = "kepler"'))
    with pytest.raises(ConfigError, match=r"truth 'kepler': expected one of 'torque-free', 'perturbed'"):
        definition.load(bad)


def test_truth_study_run_sees_the_unmodelled_physics(tmp_path):
    """The truth study's RK4 of eq. 21 (Kepler, torque-free) matches the torque-free truth to < 1 mm, not the perturbed one."""
    config = get_study("truth").load(quick=True)
    params = {k: config[k] for k in truth_study._RUN_FIELDS}
    params.update(scenario="SC3", seed_index=0, duration_s=60.0, record=False)
    err = {}
    for physics in TRUTH_PHYSICS:
        row = truth_study.execute(RunSpec("SC3-s000", 7, {**params, "truth": physics}), tmp_path)
        err[physics] = row["rk4_pos_err_max_m"]
    assert err["torque-free"] < 1e-3 < err["perturbed"]


def test_dispersed_truth_moves_only_the_orbit_phase_and_the_disturbance_with_it():
    """A dispersed Monte-Carlo run (`consistency_check(..., disperse_orbit_phase=True)`) flies the scenario from another point
    of its orbit: torque-free attitude motion does not depend on where the orbit is (the body rate history is the same to
    integration precision), the servicer sits at the drawn argument of latitude, the target at the scenario's LVLH offset;
    under gravity gradient the body rate history changes with the phase (the disturbance is sampled, not repeated)."""
    from estimators.dynamics import lvlh_dcm
    from studies.sim.navigation import dispersed_truth

    sc = get_scenario("SC3")
    for physics in ("torque-free", "perturbed"):
        tr = simulate_truth(sc, 300.0, 1.0, physics)
        d = dispersed_truth(tr, np.random.default_rng(7))
        u = d.scenario.arg_latitude_rad
        assert d.physics.name == physics and np.array_equal(d.t, tr.t) and 0.0 <= u < 2 * np.pi and abs(u) > 0.1
        r_S = d.servicer[0, R_I]
        lat = np.arctan2(r_S[2] / np.sin(sc.inclination_rad), r_S[0] * np.cos(sc.raan_rad) + r_S[1] * np.sin(sc.raan_rad))
        assert abs(np.angle(np.exp(1j * (lat - u)))) < 1e-12
        r_L = lvlh_dcm(d.servicer[0, R_I], d.servicer[0, V_I]) @ (d.target[0, R_I] - d.servicer[0, R_I])
        np.testing.assert_allclose(r_L, sc.r_TS0_L_m, atol=1e-6)
        dw = np.max(np.abs(d.target[:, W_B] - tr.target[:, W_B]))
        if physics == "torque-free":
            assert dw < 1e-10  # rad/s
        else:
            assert dw > 1e-6
