"""Dynamics against conservation laws, independent integrations and closed forms."""

import numpy as np
import pytest

from estimators import dynamics as dyn
from estimators.attitude import attitude_angle, quat_to_dcm
from estimators.state import Q_TS, R_ST_T, V_ST_T, W_B, W_ST_T
from studies.sim.scenarios import LU_COMBINA_M, TU_COMBINA_S, get_scenario
from studies.sim.truth import initial_states, simulate_truth


def test_inertia_parametrisation_round_trip():
    J = dyn.inertia_from_k(1.466, -1.439)
    np.testing.assert_allclose(J, [np.exp(1.466), 1.0, np.exp(1.439)])
    assert dyn.k_from_inertia(3.0 * J) == pytest.approx((1.466, -1.439))
    with pytest.raises(ValueError, match="positive"):
        dyn.k_from_inertia([1.0, 0.0, 2.0])


@pytest.fixture(scope="module")
def one_orbit():
    sc = get_scenario("SC4")
    target0, servicer0 = initial_states(sc)
    period = 2 * np.pi / sc.mean_motion_rad_s
    t = np.linspace(0.0, period, 200)
    J_T = dyn.inertia_from_k(*sc.k)
    return (dyn.integrate_absolute(target0, t, J_T), dyn.integrate_absolute(servicer0, t, np.asarray(sc.J_S_diag)))


@pytest.mark.parametrize("body", [0, 1], ids=["target", "servicer"])
def test_energy_and_momentum_conserved_over_one_orbit(one_orbit, body):
    tr = one_orbit[body]
    E = dyn.rotational_energy(tr.w_B, tr.J_diag)
    H = dyn.angular_momentum_norm(tr.w_B, tr.J_diag)
    Eo = dyn.orbital_energy(tr.r_I, tr.v_I)
    assert np.max(np.abs(E / E[0] - 1)) < 1e-9
    assert np.max(np.abs(H / H[0] - 1)) < 1e-9
    assert np.max(np.abs(Eo / Eo[0] - 1)) < 1e-9
    # the inertial angular momentum vector is fixed too: R(q_IB) J ω
    h_I = np.einsum("nij,nj->ni", quat_to_dcm(tr.q_IB), tr.J_diag * tr.w_B)
    assert np.max(np.linalg.norm(h_I - h_I[0], axis=1)) / np.linalg.norm(h_I[0]) < 1e-9


@pytest.mark.parametrize("name", ["SC1", "SC3", "SC4"])
def test_relative_model_reproduces_independent_absolute_integrations(name):
    """Eq. 21 of Renis et al. integrated alone (RK4, 0.01 s) = relative state of two absolute truths."""
    truth = simulate_truth(get_scenario(name), 300.0, 1.0)
    xs, _ = dyn.propagate_relative(truth.x[0], truth.servicer[0], truth.J_S_diag, 0.01, 30000, stride=100)
    assert np.max(np.linalg.norm(xs[:, R_ST_T] - truth.x[:, R_ST_T], axis=1)) < 1e-3  # m
    assert np.max(attitude_angle(xs[:, Q_TS], truth.x[:, Q_TS])) < 1e-6  # rad
    assert np.max(np.linalg.norm(xs[:, W_ST_T] - truth.x[:, W_ST_T], axis=1)) < 1e-6  # rad/s


def test_printed_eq15_sign_slip_would_fail_the_exactness_test():
    """Flipping the Coriolis sign (one of the slips of the printed eq. 11) breaks the model."""
    truth = simulate_truth(get_scenario("SC3"), 60.0, 1.0)
    x0 = truth.x[0]
    f = dyn.relative_rhs(x0, truth.servicer[0], truth.J_S_diag)
    # finite-difference derivative of the truth at t = 0
    fd = (simulate_truth(get_scenario("SC3"), 2e-3, 1e-3).x[1] - x0) / 1e-3
    np.testing.assert_allclose(f[R_ST_T], fd[R_ST_T], atol=1e-4)
    np.testing.assert_allclose(f[V_ST_T], fd[V_ST_T], atol=1e-4)
    w_T = quat_to_dcm(x0[Q_TS]) @ truth.servicer[0, W_B] - x0[W_ST_T]
    wrong = f[V_ST_T] + 4.0 * np.cross(w_T, x0[V_ST_T])  # −2ω×v → +2ω×v
    assert np.max(np.abs(wrong - fd[V_ST_T])) > 10 * np.max(np.abs(f[V_ST_T] - fd[V_ST_T]))


def test_relative_rhs_batch_matches_single():
    truth = simulate_truth(get_scenario("SC3"), 10.0, 1.0)
    X = truth.x[:5]
    batch = dyn.relative_rhs(X, truth.servicer[0], truth.J_S_diag)
    for i in range(5):
        np.testing.assert_allclose(batch[i], dyn.relative_rhs(X[i], truth.servicer[0], truth.J_S_diag))
    P = dyn.propagate_relative_batch(X, truth.servicer[0], truth.J_S_diag, 0.5, 2)
    xs, _ = dyn.propagate_relative(X[3], truth.servicer[0], truth.J_S_diag, 0.5, 2)
    np.testing.assert_allclose(P[3], xs[-1])


def test_nerm_stays_within_one_percent_of_cw_football():
    """Eq. 46 of Maestrini et al. under NERM (eq. 9) vs the CW closed form over one orbit."""
    n = 1.0 / TU_COMBINA_S
    R_t = (dyn.MU_EARTH / n**2) ** (1 / 3)
    x0 = np.r_[LU_COMBINA_M * np.array([2.0, 0.0, 0.2]), LU_COMBINA_M * n * np.array([0.0, -4.0, 0.0])]
    t = np.linspace(0, 2 * np.pi / n, 400)
    nerm = dyn.integrate_truth(dyn.nerm_rhs, t, x0, n, R_t)
    cw = dyn.cw_propagate(x0, n, t)
    size = np.max(np.linalg.norm(cw[:, :3], axis=1))
    assert np.max(np.linalg.norm(nerm[:, :3] - cw[:, :3], axis=1)) < 0.01 * size
    # the CW football closes after one orbit (bounded, periodic relative orbit)
    np.testing.assert_allclose(cw[-1], x0, atol=1e-9)


def test_cw_stm_solves_the_linearised_equations():
    n = 1.1e-3
    x0 = np.array([10.0, -5.0, 3.0, 0.01, -0.02, 0.005])
    t = np.linspace(0, 3000, 50)

    def cw_rhs(t, x):
        return np.r_[x[3:], 3 * n * n * x[0] + 2 * n * x[4], -2 * n * x[3], -n * n * x[2]]

    np.testing.assert_allclose(dyn.cw_propagate(x0, n, t), dyn.integrate_truth(cw_rhs, t, x0), atol=1e-7)


def test_axisymmetric_precession_matches_torque_free_integration():
    """Eqs 35–40 of Maestrini et al.: the symmetry axis cones about Γ like the full rigid body says."""
    A, B = 1.0, 0.35  # symmetry axis = body y (moment B), A = C
    J = np.array([A, B, A])
    w0 = np.array([0.04, 0.10, -0.03])
    y0 = np.r_[7e6, 0, 0, 0, 7.5e3, 0, 1.0, 0, 0, 0, w0]
    t = np.linspace(0, 200, 101)
    body = dyn.integrate_absolute(y0, t, J)
    R_IB = quat_to_dcm(body.q_IB)
    gamma_I = R_IB[0] @ (J * w0)
    # I_Γ: j along Γ, i and k completing a right-handed frame
    j = gamma_I / np.linalg.norm(gamma_I)
    i = np.cross(j, [0.0, 0.0, 1.0])
    i /= np.linalg.norm(i)
    k = np.cross(i, j)
    C_GI = np.stack([i, j, k])
    axis_G = np.einsum("ij,nj->ni", C_GI, R_IB[:, :, 1])
    phi0, delta0 = dyn.spherical_from_axis(axis_G[0])
    model = dyn.integrate_truth(dyn.axisymmetric_rhs, t, np.array([phi0, delta0, np.linalg.norm(gamma_I) / A]))
    axis_model = dyn.axis_from_spherical(model[:, 0], model[:, 1])
    assert np.max(np.linalg.norm(axis_model - axis_G, axis=1)) < 1e-8
    # eq. 42: e = |ω_equatorial| = (Γ/A) √(1 − sin²φ cos²δ)
    e = model[0, 2] * np.sqrt(1 - np.sin(model[:, 0]) ** 2 * np.cos(model[:, 1]) ** 2)
    np.testing.assert_allclose(e, np.hypot(w0[0], w0[2]), rtol=1e-8)


def test_rk4_step_is_fourth_order():
    f = lambda t, x: -x  # noqa: E731
    errs = [abs(dyn.rk4_step(f, 0.0, np.array([1.0]), h)[0] - np.exp(-h)) for h in (0.1, 0.05)]
    assert errs[0] / errs[1] == pytest.approx(32, rel=0.1)  # local error O(h^5)


def test_propagate_refuses_bad_step():
    truth = simulate_truth(get_scenario("SC1"), 2.0, 1.0)
    with pytest.raises(ValueError, match="dt"):
        dyn.propagate_relative(truth.x[0], truth.servicer[0], truth.J_S_diag, float("nan"), 10)
