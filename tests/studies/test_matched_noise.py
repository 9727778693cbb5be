"""The filters' process noise matched to their model's prediction errors on the perturbed truth (:mod:`studies.sim.matched_noise`)."""

import numpy as np
import pytest

from estimators.perturbations import get_truth_physics
from estimators.state import DW_ST_T
from studies.sim.disturbance import unmodelled_accelerations
from studies.sim.matched_noise import angular_intensity, filter_memory_s, matched_angular, prediction_errors
from studies.sim.scenarios import get_scenario

R_ATT = 0.12**2 / 3  # the default pose noise's attitude variance per axis, rad², every 1 s


@pytest.fixture(scope="module")
def truths():
    return {p: unmodelled_accelerations(get_scenario("SC3"), get_truth_physics(p), 1800.0)[0] for p in ("perturbed", "torque-free")}


def test_the_model_predicts_the_torque_free_truth_and_not_the_perturbed_one(truths):
    """Over 120 s the filters' model reproduces the torque-free truth to its integration error (1e-7 per step), so eq. M1
    finds no intensity there; the perturbed truth's rate drifts off by ~2e-5 rad/s (the gravity gradient and the damping)."""
    d_free, M_free = prediction_errors(truths["torque-free"], 120.0)
    d_pert, M_pert = prediction_errors(truths["perturbed"], 120.0)
    assert np.max(np.abs(d_free[:, DW_ST_T])) < 1e-8
    assert 5e-6 < np.sqrt(np.mean(d_pert[:, DW_ST_T] ** 2)) < 1e-4
    assert angular_intensity(d_free, M_free) < 1e-6 * angular_intensity(d_pert, M_pert)


def test_a_white_rate_noise_accumulates_linearly_over_a_short_window(truths):
    """Over 5 s at 0.05 rad/s the Euler coupling barely acts: ``M_α,ωω`` is the random walk's ``q H I`` (q = 1) — its trace
    to 1 %, its entries to 10 % of ``H`` (the coupling mixes the axes by ~0.4 over 5 s)."""
    _, M = prediction_errors(truths["perturbed"], 5.0)
    Mw = M[:, DW_ST_T, DW_ST_T]
    np.testing.assert_allclose(np.trace(Mw, axis1=1, axis2=2), 15.0, rtol=0.01)
    np.testing.assert_allclose(Mw, np.broadcast_to(5.0 * np.eye(3), Mw.shape), atol=0.5)


def test_the_matched_horizon_is_the_filters_memory(truths):
    """Eq. M2 holds at the root: ``H = (r / q_α(H))^{1/4}`` within the bisection's resolution (and the memory changes by
    less than the resolution across it, since ``q_α`` varies slowly there on SC3)."""
    q, H = matched_angular(truths["perturbed"], R_ATT)
    assert abs(H - filter_memory_s(q, R_ATT)) <= 2.0 + 0.05 * H
    assert 100.0 < H < 450.0


@pytest.mark.slow
def test_the_fixed_lag_tunings_budget_is_the_matched_one():
    """The constants of :data:`estimators.tuning.MATCHED_BUDGET` are what :func:`matched_budget` measures on SC1 and SC3 (1 %)."""
    from estimators.tuning import MATCHED_BUDGET, get_tuning
    from studies.sim.matched_noise import matched_budget

    m = matched_budget([get_scenario("SC1"), get_scenario("SC3")], gravity_gradient=True)
    for name in ("q_alpha_rad2_s3", "q_a_m2_s3", "q_kdot_1_s"):
        assert getattr(MATCHED_BUDGET, name) == pytest.approx(getattr(m, name), rel=0.01), name
    assert get_tuning("fixed-lag").budget is MATCHED_BUDGET and get_tuning("fixed-lag").gravity_gradient


def test_modelling_the_gravity_gradient_leaves_the_damping_in_the_rates_prediction_errors(truths):
    """With the gravity-gradient torque in the filters' model, the rate's prediction errors over 120 s on the perturbed truth
    are the nutation damping's alone: smaller than without it, and equal to those of a truth with the damping but no gravity
    gradient (the model then has nothing else to miss: J2 and drag do not act on the rate)."""
    import dataclasses

    d_without, _ = prediction_errors(truths["perturbed"], 120.0)
    d_with, _ = prediction_errors(truths["perturbed"], 120.0, gravity_gradient=True)
    rms = {k: np.sqrt(np.mean(d[:, DW_ST_T] ** 2)) for k, d in (("without", d_without), ("with", d_with))}
    assert rms["with"] < 0.8 * rms["without"]
    no_gg = dataclasses.replace(get_truth_physics("perturbed"), gravity_gradient=False)
    d_damping, _ = prediction_errors(unmodelled_accelerations(get_scenario("SC3"), no_gg, 1800.0)[0], 120.0)
    np.testing.assert_allclose(rms["with"], np.sqrt(np.mean(d_damping[:, DW_ST_T] ** 2)), rtol=0.05)


def test_a_steady_push_is_matched_over_the_horizon():
    """Eq. (5) of :mod:`estimators.process_noise`: a white acceleration of ``3 |ā|² H / 4`` has, after ``H``, the position
    variance per axis ``q H³/3`` equal to the squared displacement ``(|ā| H²/2)²`` of the constant ``ā``."""
    from estimators.process_noise import constant_acceleration_intensity, white_noise_acceleration

    a, H = np.array([0.0, 2.3e-7, 0.0]), 900.0
    q = constant_acceleration_intensity(a, H)
    assert white_noise_acceleration(q, H)[0, 0] == pytest.approx((np.linalg.norm(a) * H**2 / 2) ** 2, rel=1e-12)
    with pytest.raises(ValueError, match="horizon_s"):
        constant_acceleration_intensity(a, 0.0)


@pytest.mark.slow
@pytest.mark.parametrize("target", ["asymmetric", "symmetric"])
def test_combina_budgets_are_the_matched_ones(target):
    """The constants of :data:`studies.sim.combina.COMBINA_BUDGETS` are what :func:`combina_matched_budget` measures (1 %): the
    one-step errors of eqs 9 and 29 along the perturbed truth, matched to the filters (eq. 3 of :mod:`estimators.process_noise`)."""
    from studies.sim.combina import COMBINA_BUDGETS
    from studies.sim.matched_noise import combina_matched_budget

    m = combina_matched_budget(target)
    for name in ("q_alpha_rad2_s3", "q_a_m2_s3", "q_kdot_1_s"):
        assert getattr(COMBINA_BUDGETS[target], name) == pytest.approx(getattr(m, name), rel=0.01, abs=1e-30), name


def test_combina_models_leave_out_only_what_they_do_not_model():
    """Eq. 9 (RK4 at the filter's step) and eq. 29 (the filter's rigid-body RK4) reproduce the torque-free truth to their
    integration error (below 1e-9 m/s² and 1e-12 rad/s²). In orbit the relative motion about the chaser's own orbit with J2
    leaves out of the perturbed truth only the differential drag — along-track, ½ ρ v² C_D (A/m_target − A/m_servicer) at the
    chaser (2 %), nothing radial or normal above 1e-10 m/s² — while eq. 29 leaves out the gravity gradient (> 2e-8 rad/s² RMS),
    and with the gravity gradient about the chaser's radial direction in it (the attitude filter's model in orbit) what is left,
    the nutation damping and the target's offset from the chaser, is below 1e-9 rad/s² RMS (measured 3.4e-10)."""
    from estimators.perturbations import R_EARTH, atmosphere_band, atmosphere_density, drag_acceleration, get_truth_physics
    from studies.sim.combina import SCENARIO, CombinaConfig, simulate_lvlh_truth, target_k
    from studies.sim.matched_noise import combina_model_errors

    _, a_free, alpha_free = combina_model_errors("asymmetric", 0.0, "torque-free", orbits=0.5)
    _, a_pert, alpha_pert = combina_model_errors("asymmetric", 0.0, "perturbed", orbits=0.5)
    assert np.max(np.abs(a_free)) < 1e-9 and np.max(np.abs(alpha_free)) < 1e-12
    assert np.sqrt(np.mean(alpha_pert**2)) < 1e-9
    assert np.sqrt(np.mean(combina_model_errors("asymmetric", 0.0, "perturbed", orbits=0.5, gravity_gradient=False)[2] ** 2)) > 2e-8
    p = get_truth_physics("perturbed")
    tau = 1.0 / CombinaConfig().rate_hz
    tr = simulate_lvlh_truth("asymmetric", a_pert.shape[0] * tau, tau, k=target_k("asymmetric"), physics="perturbed")
    h0, rho0, scale_h = atmosphere_band(SCENARIO.orbit_radius_m - R_EARTH)
    along = []
    for C, (r, v) in zip(tr.C_LI[:-1], tr.chaser_I[:-1].reshape(-1, 2, 3)):
        rho = atmosphere_density(np.linalg.norm(r), R_EARTH, rho0, h0, scale_h)
        d_I = np.subtract(drag_acceleration(r, v, p.drag_coefficient * p.target_area_to_mass_m2_kg, rho),
                          drag_acceleration(r, v, p.drag_coefficient * p.servicer_area_to_mass_m2_kg, rho))
        along.append((C @ d_I)[1])
    assert np.mean(along) < -1e-9
    assert np.mean(a_pert[:, 1]) == pytest.approx(np.mean(along), rel=0.02)
    assert np.max(np.abs(np.mean(a_pert[:, [0, 2]], axis=0))) < 1e-10
