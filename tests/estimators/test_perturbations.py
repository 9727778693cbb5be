"""The perturbed truth's terms against analytic references (Hughes 1986, Vallado 2013, the energy-sink model)."""

import numpy as np
import pytest

from estimators import dynamics as dyn
from estimators import perturbations as pt
from estimators.attitude import dcm_to_quat, quat_to_dcm
from estimators.state import Q_IB, R_I, V_I, W_B

MU, RE = dyn.MU_EARTH, dyn.R_EARTH
A_500 = RE + 500e3
Q0 = np.array([0.9, 0.1, -0.3, 0.2]) / np.linalg.norm([0.9, 0.1, -0.3, 0.2])  #: a generic attitude


def _params(**switches) -> np.ndarray:
    """Target parameters of a physics with only ``switches`` on, at 500 km."""
    return pt.with_terms(pt.get_truth_physics("torque-free"), **switches).body_params("target", [A_500, 0.0, 0.0])


# ---------------------------------------------------------------- gravity gradient


def test_gravity_gradient_torque_hand_computed_and_symmetries():
    J = (1.0, 2.0, 3.0)
    R = 7.0e6
    a = R / np.sqrt(2.0)
    # r = (a, a, 0): r × J r = (0, 0, a·2a − a·a) = (0, 0, R²/2), so τ = 3μ/R⁵ · R²/2 = 1.5 μ/R³ along z
    np.testing.assert_allclose(pt.gravity_gradient_torque((a, a, 0.0), J, MU), (0.0, 0.0, 1.5 * MU / R**3), rtol=1e-14, atol=1e-30)
    for axis in np.eye(3):  # along a principal axis: no torque
        assert pt.gravity_gradient_torque(tuple(R * axis), J, MU) == (0.0, 0.0, 0.0)
    r = (3.1e6, -2.2e6, 5.4e6)
    assert np.allclose(pt.gravity_gradient_torque(r, (2.0, 2.0, 2.0), MU), 0.0, atol=1e-25)  # sphere: none
    t1 = np.array(pt.gravity_gradient_torque(r, J, MU))
    assert np.allclose(pt.gravity_gradient_torque(r, tuple(10 * np.array(J)), MU), 10 * t1, rtol=1e-14)  # linear in J
    assert abs(t1 @ np.array(r)) < 1e-12 * np.linalg.norm(t1) * np.linalg.norm(r)  # ⟂ r


def _pitch_libration(J, theta0, t):
    """A body on a circular orbit with A radial, B along-track, C on the orbit normal, pitched by theta0 about the normal."""
    rv = dyn.circular_orbit_state(A_500, np.radians(51.6), 0.3, 0.0)
    n = np.sqrt(MU / A_500**3)
    C_IL = dyn.lvlh_dcm(rv[R_I], rv[V_I]).T
    c, s = np.cos(theta0), np.sin(theta0)
    C_LB = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    y0 = np.concatenate([rv, dcm_to_quat(C_IL @ C_LB), [0.0, 0.0, n]])
    tr = pt.integrate_perturbed(y0, t, np.asarray(J), _params(gravity_gradient=True))
    C_LI = dyn.lvlh_dcm(tr.r_I, tr.v_I)
    x_L = np.einsum("nij,nj->ni", C_LI, quat_to_dcm(tr.q_IB)[:, :, 0])  # body x axis in LVLH
    return tr, n, np.arctan2(x_L[:, 1], x_L[:, 0])


def test_pitch_libration_period_matches_gravity_gradient_theory():
    """Small pitch libration about the orbit normal: ``ω_lib = n √(3 (B − A)/C)`` (Hughes 1986), to < 1 %."""
    J = (1.0, 2.0, 2.5)  # A radial (minimum), B along-track, C about the orbit normal
    t = np.arange(0.0, 11000.0, 5.0)
    _, n, theta = _pitch_libration(J, 0.01, t)
    w_lib = n * np.sqrt(3 * (J[1] - J[0]) / J[2])
    k = np.flatnonzero(np.sign(theta[:-1]) != np.sign(theta[1:]))
    t0 = t[k] - theta[k] * (t[k + 1] - t[k]) / (theta[k + 1] - theta[k])  # zero crossings, interpolated
    assert len(t0) >= 3
    period = 2 * np.mean(np.diff(t0))
    assert period == pytest.approx(2 * np.pi / w_lib, rel=0.01)
    assert np.max(np.abs(theta)) == pytest.approx(0.01, rel=0.01)  # it librates, it does not tumble


def test_gravity_gradient_keeps_the_jacobi_integral_of_a_tumbling_body():
    """On a circular Kepler orbit the gravity-gradient attitude motion keeps the Jacobi integral (Hughes 1986)

    ``h = ½ ω_relᵀ J ω_rel − ½ n² c3ᵀ J c3 + (3/2) n² c1ᵀ J c1``, ``ω_rel = ω_B − n c3``, with c1 (radial) and c3 (orbit
    normal) in B, while the rotational energy alone changes.
    """
    J = dyn.inertia_from_k(1.466, -1.439)
    rv = dyn.circular_orbit_state(A_500, np.radians(51.6))
    n = np.sqrt(MU / A_500**3)
    t = np.linspace(0.0, 3000.0, 301)
    tr = pt.integrate_perturbed(np.concatenate([rv, Q0, [0.02, 0.0, 0.045]]), t, J, _params(gravity_gradient=True))
    C_BI = np.swapaxes(quat_to_dcm(tr.q_IB), 1, 2)
    C_LI = dyn.lvlh_dcm(tr.r_I, tr.v_I)
    c1 = np.einsum("nij,nj->ni", C_BI, C_LI[:, 0])
    c3 = np.einsum("nij,nj->ni", C_BI, C_LI[:, 2])
    w_rel = tr.w_B - n * c3
    h = 0.5 * np.sum(J * w_rel**2, 1) - 0.5 * n**2 * np.sum(J * c3**2, 1) + 1.5 * n**2 * np.sum(J * c1**2, 1)
    E = dyn.rotational_energy(tr.w_B, J)
    assert np.max(np.abs(h / h[0] - 1)) < 1e-9
    assert np.max(np.abs(E / E[0] - 1)) > 1e-4  # the torque does work: the test is not the torque-free one


# ---------------------------------------------------------------- J2, drag, SRP


def test_j2_acceleration_is_the_gradient_of_the_j2_potential():
    """``a = −∇V``, ``V_J2 = μ J2 R_E² (3 z²/r² − 1)/(2 r³)`` (Vallado 2013 ch. 8), by central differences."""
    def V(r):
        rn = np.linalg.norm(r)
        return MU * pt.J2_EARTH * RE**2 * (3 * r[2] ** 2 / rn**2 - 1) / (2 * rn**3)

    r = np.array([4.1e6, -3.3e6, 4.6e6])
    h = 1.0
    grad = np.array([(V(r + h * e) - V(r - h * e)) / (2 * h) for e in np.eye(3)])
    np.testing.assert_allclose(pt.j2_acceleration(tuple(r), MU, pt.J2_EARTH, RE), -grad, rtol=1e-6)


def test_j2_nodal_regression_rate():
    """Secular node rate ``dΩ/dt = −(3/2) n J2 (R_E/p)² cos i`` (Vallado 2013 eq. 9-41), from two orbit-averaged nodes, < 2 %."""
    a, inc = A_500, np.radians(51.6)
    n = np.sqrt(MU / a**3)
    T = 2 * np.pi / n
    t = np.linspace(0.0, 2 * T, 2001)
    y0 = np.concatenate([dyn.circular_orbit_state(a, inc, 0.3), [1.0, 0, 0, 0], [0, 0, 0]])
    tr = pt.integrate_perturbed(y0, t, np.ones(3), _params(j2=True))
    h = np.cross(tr.r_I, tr.v_I)
    node = np.unwrap(np.arctan2(h[:, 0], -h[:, 1]))
    rate = (node[1000:2000].mean() - node[:1000].mean()) / T  # the short-period terms average out over an orbit
    expected = -1.5 * n * pt.J2_EARTH * (RE / a) ** 2 * np.cos(inc)
    assert rate == pytest.approx(expected, rel=0.02)


def test_drag_at_the_band_base_and_srp_with_shadow():
    p = _params(drag=True, srp=True)
    r = (A_500, 0.0, 0.0)
    v = (0.0, 7600.0, 0.0)
    rho = pt.atmosphere_density(A_500, RE, p[pt.P_RHO0], p[pt.P_H0], p[pt.P_HSCALE])
    assert rho == pytest.approx(6.967e-13, rel=1e-12)  # Vallado Table 8-4 at 500 km
    v_rel = 7600.0 - pt.OMEGA_EARTH_RAD_S * A_500
    np.testing.assert_allclose(pt.drag_acceleration(r, v, 2.2 * 0.01, rho), (0.0, -0.5 * rho * 0.022 * v_rel**2, 0.0), rtol=1e-12)
    sun = (1.0, 0.0, 0.0)
    p_srp = pt.SOLAR_PRESSURE_N_M2 * 1.3 * 0.01
    assert p[pt.P_SRP] == pytest.approx(p_srp)
    np.testing.assert_allclose(pt.srp_acceleration(r, sun, p_srp, RE), (-p_srp, 0.0, 0.0))  # sunlit
    assert pt.srp_acceleration((-A_500, 0.0, 0.0), sun, p_srp, RE) == (0.0, 0.0, 0.0)  # behind the Earth
    assert pt.srp_acceleration((-A_500, 1.01 * RE, 0.0), sun, p_srp, RE) != (0.0, 0.0, 0.0)  # beside the shadow cylinder
    with pytest.raises(pt.TruthPhysicsError, match="altitude"):
        pt.atmosphere_band(200e3)


# ---------------------------------------------------------------- torque-free and dissipation


def _tumbler(t, params, J=None, w0=(0.02, 0.0, 0.045)):
    J = dyn.inertia_from_k(1.466, -1.439) if J is None else np.asarray(J)
    y0 = np.concatenate([dyn.circular_orbit_state(A_500, 0.9), Q0, w0])
    return pt.integrate_perturbed(y0, t, J, params), J


def test_switched_off_terms_give_the_torque_free_integration_bit_for_bit():
    t = np.linspace(0.0, 600.0, 61)
    tr, J = _tumbler(t, _params())
    ref = dyn.integrate_absolute(tr.y[0], t, J)
    assert np.array_equal(tr.y, ref.y)
    E = dyn.rotational_energy(tr.w_B, J)
    h_I = np.einsum("nij,nj->ni", quat_to_dcm(tr.q_IB), J * tr.w_B)
    assert np.max(np.abs(E / E[0] - 1)) < 1e-10
    assert np.max(np.linalg.norm(h_I - h_I[0], axis=1)) / np.linalg.norm(h_I[0]) < 1e-10


def test_dissipation_torque_is_normal_to_h_and_removes_energy(rng):
    J = (4.33, 1.0, 4.22)
    for w in rng.normal(size=(50, 3)) * 0.05:
        tau = np.array(pt.dissipation_torque(tuple(w), J, 1e-3))
        H = np.array(J) * w
        assert abs(tau @ H) <= 1e-12 * np.linalg.norm(tau) * np.linalg.norm(H)
        assert tau @ w < 0
    assert pt.dissipation_torque((0.0, 0.0, 0.05), J, 1e-3) == (0.0, 0.0, 0.0)  # a pure spin: nothing to damp


def test_dissipation_keeps_h_and_lowers_energy_at_the_model_rate():
    """Torque-free + dissipation: ``|H|`` kept to 1e-9, ``Ė = −(P⊥ω)ᵀJ(P⊥ω)/τ_d`` to < 2 %, ``E ≥ |H|²/(2 J_max)``."""
    tau_d = 600.0
    t = np.linspace(0.0, 3000.0, 3001)
    tr, J = _tumbler(t, pt.TruthPhysics("test", dissipation=True, nutation_time_constant_s=tau_d).body_params("target", [A_500, 0, 0]))
    H = dyn.angular_momentum_norm(tr.w_B, J)
    E = dyn.rotational_energy(tr.w_B, J)
    E_min = H**2 / (2 * J.max())
    assert np.max(np.abs(H / H[0] - 1)) < 1e-9
    assert np.all(E >= E_min * (1 - 1e-12))
    assert E[-1] < E[0] - 0.5 * (E[0] - E_min[0])  # it does dissipate
    Hv = J * tr.w_B
    p = tr.w_B - (np.sum(tr.w_B * Hv, 1) / np.sum(Hv * Hv, 1))[:, None] * Hv
    E_dot_model = -np.sum(J * p * p, 1) / tau_d
    E_dot = np.gradient(E, t, edge_order=2)
    sel = slice(1, -1)
    assert np.max(np.abs(E_dot[sel] / E_dot_model[sel] - 1)) < 0.02


def test_dissipation_near_the_major_axis_decays_at_the_linearised_rate():
    """Near the major-axis spin ``E − E_min ∝ exp(−(2 − (A + B)/C) t/τ_d)`` (the linearised model), to < 1 %."""
    J = np.array([1.0, 4.0, 5.0])  # axis 3 major
    tau_d = 1000.0
    t = np.linspace(0.0, 2000.0, 201)
    phys = pt.TruthPhysics("test", dissipation=True, nutation_time_constant_s=tau_d)
    tr, _ = _tumbler(t, phys.body_params("target", [A_500, 0, 0]), J=J, w0=(0.0, 1e-4, 0.05))
    H = dyn.angular_momentum_norm(tr.w_B, J)
    excess = dyn.rotational_energy(tr.w_B, J) - H**2 / (2 * J.max())
    rate = -np.polyfit(t, np.log(excess), 1)[0]
    assert rate == pytest.approx((2 - (J[0] + J[1]) / J[2]) / tau_d, rel=0.01)


def test_truth_physics_names_and_parameters():
    assert pt.get_truth_physics("torque-free").terms == ()
    assert pt.get_truth_physics("perturbed").terms == ("gravity_gradient", "j2", "drag", "dissipation")
    with pytest.raises(pt.TruthPhysicsError, match=r"truth: 'kepler': expected torque-free or perturbed"):
        pt.get_truth_physics("kepler")
    with pytest.raises(pt.TruthPhysicsError, match="nutation_time_constant_s"):
        pt.TruthPhysics("x", nutation_time_constant_s=-1.0)
    p_S = pt.get_truth_physics("perturbed").body_params("servicer", [A_500, 0, 0])
    assert p_S[pt.P_GG] == 0 and p_S[pt.P_INV_TAU] == 0 and p_S[pt.P_J2] == pt.J2_EARTH  # no torque on the servicer
    assert pt.with_terms(pt.get_truth_physics("perturbed"), drag=False).name == "gravity_gradient+j2+dissipation"


def test_perturbing_accelerations_along_a_trajectory_match_the_terms():
    t = np.linspace(0.0, 100.0, 11)
    params = pt.get_truth_physics("perturbed").body_params("target", [A_500, 0, 0])
    tr, J = _tumbler(t, params)
    acc = pt.perturbing_accelerations(tr.y, J, params)
    m = 7
    r_B = quat_to_dcm(tr.q_IB[m]).T @ tr.r_I[m]
    np.testing.assert_allclose(acc["gravity_gradient"][m], np.array(pt.gravity_gradient_torque(tuple(r_B), tuple(J), MU)) / J, rtol=1e-12)
    np.testing.assert_allclose(acc["j2"][m], pt.j2_acceleration(tuple(tr.r_I[m]), MU, pt.J2_EARTH, RE), rtol=1e-14)
    assert np.all(acc["srp"] == 0.0)
    rhs = pt.perturbed_rhs_nb(tr.y[m], J, params) - dyn.absolute_rhs_nb(tr.y[m], J, MU)
    np.testing.assert_allclose(rhs[V_I], acc["j2"][m] + acc["drag"][m], rtol=1e-12)
    np.testing.assert_allclose(rhs[W_B], acc["gravity_gradient"][m] + acc["dissipation"][m], rtol=1e-9)
    assert np.all(rhs[Q_IB] == 0.0)
    with pytest.raises(pt.TruthPhysicsError, match=r"y: shape \(13,\)"):
        pt.perturbing_accelerations(tr.y[0], J, params)
