"""Attitude UKF of Maestrini et al. §IV.B: process model (eqs 28–29) at fast rates, error-MRP sigma points across π, process noise."""

from functools import partial

import numpy as np
import pytest
from scipy.stats import chi2

from estimators.attitude import attitude_angle, mrp_to_quat, quat_conjugate, quat_multiply, quat_to_mrp, quat_to_rotvec, rotvec_to_quat
import estimators.combina.attitude as ca
from estimators.combina.attitude import AttitudeUKF, attitude_process_noise, error_mrp_noise_covariance, physical_k, project_k_physical, rate_from_attitudes
from estimators.dynamics import inertia_from_k, integrate_absolute
from estimators.process_noise import MatchedBudget

K = np.array([0.03, -0.1])
#: an unmodelled angular acceleration of 1e-7 rad/s² held over each 3 s step: the white-noise intensity q = σ² τ
WHITE = MatchedBudget(q_alpha_rad2_s3=1e-14 * 3.0, q_a_m2_s3=0.0)
W0 = np.array([-0.3953, -0.7065, -0.8153]) / 963.65


@pytest.mark.parametrize("rate_rad_s", [0.02, 1.2])
def test_prediction_matches_absolute_rigid_body(rate_rad_s):
    """Tiny covariance: 3 s predictions follow the DOP853 quaternion + Euler truth over 300 s.

    At 1.2 rad/s the target turns 206° per prediction; one RK4 step per prediction (the old
    setting) was off by radians, the rate-adaptive steps stay below 1e-4 rad (0.006°, against 2° of registration noise).
    """
    k = np.array([0.8, -0.6])
    w0 = rate_rad_s * np.array([0.3, -0.5, 0.81]) / np.linalg.norm([0.3, -0.5, 0.81])
    q0 = mrp_to_quat(np.array([-0.083, 0.220, -0.500]))
    f = AttitudeUKF(np.concatenate([quat_to_mrp(q0), w0, k]), 1e-14 * np.eye(8))
    y0 = np.concatenate([np.array([7e6, 0, 0, 0, 7.5e3, 0]), q0, w0])
    tr = integrate_absolute(y0, np.linspace(0.0, 300.0, 101), inertia_from_k(*k))
    for i in range(1, 101):
        f.predict(3.0)
        assert attitude_angle(tr.q_IB[i], f.q_IT) < 1e-4
        np.testing.assert_allclose(f.x[3:6], tr.w_B[i], rtol=0, atol=1e-5)
        assert np.linalg.norm(f.x[:3]) <= 1.0 + 1e-12  # the reported MRP stays in the |σ| ≤ 1 set


def test_sigma_points_straddling_180_degrees_keep_mean_and_covariance():
    """An estimate at 179° with 10° 1-σ: half the sigma points lie beyond 180° (the far MRP set).

    Averaging global MRPs across |σ| = 1 moved the mean by tens of degrees; with error MRPs
    a prediction at zero rate leaves the attitude (< 1e-9 rad) and its covariance unchanged.
    """
    axis = np.array([0.36, 0.48, 0.8])
    sd = np.deg2rad(10.0) / 4.0
    P0 = np.diag([sd**2] * 3 + [1e-16] * 3 + [1e-6] * 2)
    f = AttitudeUKF(np.concatenate([np.tan(np.deg2rad(179.0) / 4) * axis, np.zeros(3), K]), P0)
    q_before = f.q_IT.copy()
    f.predict(3.0)
    assert attitude_angle(q_before, f.q_IT) < 1e-9
    np.testing.assert_allclose(f.P[:3, :3], P0[:3, :3], rtol=1e-6, atol=1e-12)


def test_innovation_across_the_shadow_boundary_is_the_small_error():
    """Measured 1° beyond 180° from an estimate 0.5° below: the innovation is the 1° error (δσ ≈ δθ/4), not ~360°."""
    axis = np.array([0.0, 0.6, 0.8])
    f = AttitudeUKF(np.concatenate([np.tan(np.deg2rad(179.5) / 4) * axis, W0, K]), 1e-4 * np.eye(8))
    q_meas = rotvec_to_quat(np.deg2rad(180.5) * axis)
    inn = f.innovation(q_meas, error_mrp_noise_covariance(np.deg2rad(2.0)))
    assert np.linalg.norm(inn.y) == pytest.approx(np.tan(np.deg2rad(1.0) / 4), rel=1e-6)
    switched = f.correct(inn)
    assert switched  # the estimate crossed 180°: its global MRP moved to the other set (eqs 31–32's event)
    assert np.linalg.norm(f.x[:3]) <= 1.0
    assert attitude_angle(q_meas, f.q_IT) < np.deg2rad(0.5)
    assert np.min(np.linalg.eigvalsh(f.P)) > 0


def test_process_noise_keeps_k_adjustable():
    """Q adds variance to ω and k per step (without it k's variance collapses); a 3 s step adds 3e-8 to k.

    A white acceleration of intensity ``q = σ² τ`` (a constant 1e-7 rad/s² over the 3 s step) gives ``Q_ωω = q τ = (σ τ)²``,
    and the attitude block is the error MRP's, ``Q_θθ/16 = q τ³/48`` (eq. 1 of :mod:`estimators.process_noise`)."""
    Q = attitude_process_noise(3.0, WHITE)
    assert Q.shape == (8, 8) and np.all(np.diag(Q) > 0)
    assert Q[6, 6] == pytest.approx(1e-8 * 3.0)
    assert Q[3, 3] == pytest.approx((1e-7 * 3.0) ** 2)
    assert Q[0, 0] == pytest.approx(1e-14 * 3.0 * 3.0**3 / 48.0)
    assert Q[0, 3] == pytest.approx(1e-14 * 3.0 * 3.0**2 / 8.0) and Q[0, 4] == 0.0
    f = AttitudeUKF(np.concatenate([np.zeros(3), W0, K]), 1e-12 * np.eye(8), Q=partial(attitude_process_noise, budget=WHITE))
    f.predict(3.0)
    assert f.P[6, 6] >= 1e-12 + 3e-8 - 1e-14


def test_rate_proxy_measures_the_spin_rate():
    f = AttitudeUKF(np.concatenate([np.zeros(3), W0, K]), np.diag([1e-2] * 3 + [1e-9] * 3 + [1e-2] * 2))
    inn = f.rate_proxy_innovation(1.1 * np.linalg.norm(W0), 1e-10)
    assert inn.z_pred[0] == pytest.approx(np.linalg.norm(W0), rel=1e-3)
    f.correct(inn)
    assert np.linalg.norm(f.x[3:6]) > np.linalg.norm(W0)  # pulled towards the proxy rate


def _euler_coefficients(k) -> np.ndarray:
    """``|(J_j − J_k)/J_i|`` of eq. 29 for the three cyclic (i, j, k), from the scalar :func:`estimators.dynamics.inertia_from_k`."""
    J = np.array([inertia_from_k(*kk) for kk in np.atleast_2d(k)])
    return np.abs(np.stack([(J[:, 1] - J[:, 2]) / J[:, 0], (J[:, 2] - J[:, 0]) / J[:, 1], (J[:, 0] - J[:, 1]) / J[:, 2]], axis=1))


def test_physical_k_is_every_euler_coefficient_at_most_one():
    """A rigid body's moments obey the triangle inequalities ⇔ every Euler coefficient of eq. 29 is ≤ 1.

    39.5 % of the study's old k ∈ [−1.5, 1.5]² box is physical (±0.3 % at 4σ over 20,000 draws);
    k = (1.5, 1.5) has a coefficient of 15.6.
    """
    rng = np.random.default_rng(5)
    k = rng.uniform(-3.0, 3.0, size=(4000, 2))
    np.testing.assert_array_equal(physical_k(k), np.max(_euler_coefficients(k), axis=1) <= 1.0)
    box = rng.uniform(-1.5, 1.5, size=(20000, 2))
    assert physical_k(box).mean() == pytest.approx(0.395, abs=0.014)
    assert np.max(_euler_coefficients([1.5, 1.5])) == pytest.approx(15.6, abs=0.05)


def test_projection_moves_only_non_physical_k_onto_the_flat_plate_boundary():
    rng = np.random.default_rng(6)
    k = rng.uniform(-3.0, 3.0, size=(4000, 2))
    kp = project_k_physical(k)
    inside = physical_k(k)
    np.testing.assert_allclose(kp[inside], k[inside], rtol=0, atol=1e-12)
    assert physical_k(kp).all()
    np.testing.assert_allclose(np.max(_euler_coefficients(kp[~inside]), axis=1), 1.0, atol=1e-9)  # the largest moment = the sum of the others


def test_no_non_physical_sigma_point_is_propagated(monkeypatch):
    """k near the flat-plate boundary with 1-σ 0.3: about half the sigma points of a prediction and of the
    iterated correction lie outside the rigid-body set; with ``physical`` none of them reaches eq. 29."""
    seen = []
    propagate = ca.propagate_rigid_body

    def spy(Y, dt_s, **steps):
        seen.append(Y[:, 7:9].copy())
        return propagate(Y, dt_s, **steps)

    monkeypatch.setattr(ca, "propagate_rigid_body", spy)
    k0 = project_k_physical(np.array([1.2, 0.4]))  # A = B + C
    P0 = np.diag([1e-4] * 3 + [1e-6] * 3 + [0.09] * 2)
    R = error_mrp_noise_covariance(np.deg2rad(2.0))
    for physical in (False, True):
        seen.clear()
        f = AttitudeUKF(np.concatenate([np.zeros(3), [0.3, 0.5, -0.6], k0]), P0, physical=physical, iterations=2)
        f.predict(3.0)
        f.correct(f.innovation(mrp_to_quat(np.array([0.01, 0.0, 0.0])), R))
        f.predict(3.0)
        frac_physical = physical_k(np.concatenate(seen)).mean()
        if physical:
            assert frac_physical == 1.0
            assert np.all(np.isfinite(f.P)) and np.min(np.linalg.eigvalsh(f.P)) > 0
        else:
            assert frac_physical < 0.8  # the set-up does exercise the projection


def test_rate_from_two_attitudes_of_a_torque_free_tumbler():
    """Two noise-free attitudes 3 s apart (DOP853 truth, rigid-body k known): the rate at the second is within ``0.25 Δt |ω|²``
    per axis at 0.3–0.9 rad/s (turns < π per interval) on 30 random ICs (the re-acquisition's 1-σ, with k uncertain by 0.3,
    is ``0.1 Δt |ω|²``), and exact for a spin about a principal axis; the mean rate alone (no eq. 29 extrapolation) is worse on average."""
    rng = np.random.default_rng(8)
    dt = 3.0
    err_ext, err_mean = [], []
    for i in range(30):
        k = rng.uniform(-1.5, 1.5, 2)
        while not physical_k(k):
            k = rng.uniform(-1.5, 1.5, 2)
        d = rng.normal(size=3)
        w0 = (0.3 + 0.6 * i / 29) * d / np.linalg.norm(d)
        q0 = rotvec_to_quat(rng.normal(size=3))
        tr = integrate_absolute(np.concatenate([[7e6, 0, 0, 0, 7.5e3, 0], q0, w0]), np.array([0.0, dt]), inertia_from_k(*k))
        w1 = rate_from_attitudes(tr.q_IB[0], tr.q_IB[1], dt, k)
        assert np.all(np.abs(w1 - tr.w_B[1]) <= 0.25 * dt * (w0 @ w0)), (k, w0)
        err_ext.append(np.linalg.norm(w1 - tr.w_B[1]))
        err_mean.append(np.linalg.norm(quat_to_rotvec(quat_multiply(quat_conjugate(tr.q_IB[0]), tr.q_IB[1])) / dt - tr.w_B[1]))
    assert np.mean(err_ext) < np.mean(err_mean)
    spin = np.array([0.0, 0.0, 0.8])
    q1 = quat_multiply(q0, rotvec_to_quat(spin * dt))
    np.testing.assert_allclose(rate_from_attitudes(q0, q1, dt, [0.3, -0.2]), spin, atol=1e-12)


def test_bad_input():
    with pytest.raises(ValueError, match="x0"):
        AttitudeUKF(np.zeros(7), np.eye(7))
    with pytest.raises(ValueError, match="max_angle_rad"):
        AttitudeUKF(np.zeros(8), np.eye(8), max_angle_rad=0.0)
    f = AttitudeUKF(np.zeros(8), np.eye(8))
    with pytest.raises(ValueError, match="dt_s"):
        f.predict(-1.0)
    with pytest.raises(ValueError, match="proxy"):
        f.rate_proxy_innovation(-1.0, 1.0)
    with pytest.raises(ValueError, match="attitude_sigma_rad"):
        error_mrp_noise_covariance(0.0)
    with pytest.raises(ValueError, match="dt_s"):
        rate_from_attitudes([1.0, 0, 0, 0], [1.0, 0, 0, 0], 0.0, K)


def _nees_after_three_epochs(seed: int, iterations: int) -> float:
    """NEES of ``[δσ, ω, k]`` after 3 measurements of a 0.6 rad/s tumbler whose ``k`` starts with 1-σ 0.3."""
    rng = np.random.default_rng(seed)
    k = rng.uniform(-1.0, 1.0, 2)
    d = rng.normal(size=3)
    w0 = 0.6 * d / np.linalg.norm(d)
    q0 = rotvec_to_quat(rng.normal(size=3))
    sd = np.array([0.02] * 3 + [3e-4] * 3 + [0.3] * 2)  # eq. 48's ω and k 1-σ (0.1 I in scaled units)
    x0 = np.concatenate([quat_to_mrp(q0), w0, k]) + sd * rng.normal(size=8)
    f = AttitudeUKF(x0, np.diag(sd**2), iterations=iterations, iterate_k_sd=0.0)
    tr = integrate_absolute(np.concatenate([[7e6, 0, 0, 0, 7.5e3, 0], q0, w0]), np.linspace(0.0, 9.0, 4), inertia_from_k(*k))
    R = error_mrp_noise_covariance(np.deg2rad(2.0))
    for i in range(1, 4):
        f.predict(3.0)
        q_meas = quat_multiply(tr.q_IB[i], rotvec_to_quat(np.deg2rad(2.0) * rng.normal(size=3)))
        f.correct(f.innovation(q_meas, R))
    e = np.concatenate([f.error_mrp(tr.q_IB[3]), tr.w_B[3] - f.x[3:6], k - f.x[6:]])
    return float(e @ np.linalg.solve(f.P, e))


def test_iterated_correction_is_consistent_while_k_is_unknown():
    """40 seeds: after 3 epochs at 0.6 rad/s with k 1-σ 0.3, the iterated correction's NEES (8 dof) is χ².

    One 3 s prediction spreads the sigma points' ω by ~0.5 rad/s; the plain UKF linearises about
    that prior and is over-confident (measured: mean NEES 27, 31/40 below the 99% quantile). The
    posterior-linearised correction: mean NEES inside the 99.8% band of χ²(320)/40, and at least
    36/40 runs below the 99% quantile (P(X ≥ 5 | n=40, p=0.01) ≈ 6e-4).
    """
    seeds = range(40)
    nees = np.array([_nees_after_three_epochs(s, 3) for s in seeds])
    lo, hi = chi2.ppf([0.001, 0.999], 8 * len(nees)) / len(nees)
    assert lo <= nees.mean() <= hi
    assert np.sum(nees < chi2.ppf(0.99, 8)) >= 36
    plain = np.array([_nees_after_three_epochs(s, 0) for s in seeds])
    assert plain.mean() > hi  # the failure this correction removes


def test_gravity_gradient_prediction_follows_a_truth_with_only_that_torque():
    """In orbit (``AttitudeUKF(orbit=)``) 3 s predictions follow a DOP853 truth whose only perturbation is the target's
    gravity-gradient torque (``estimators.perturbations``, ``τ = 3μ/r⁵ (r × J r)``) on a two-body orbit, given that orbit's own
    samples: < 1e-5 rad and 1e-8 rad/s over 1200 s (measured at the end 3.7e-7 rad and 1.0e-9 rad/s), the torque's radial
    direction held at each prediction's mid-time. The torque-free prediction of the same start ends 5.3e-4 rad/s off."""
    from estimators.combina.own_orbit import ChaserOrbit
    from estimators.perturbations import TruthPhysics, integrate_perturbed

    k = np.array([0.5, -0.4])
    J = inertia_from_k(*k)
    w0 = 2e-3 * np.array([0.3, -0.5, 0.81]) / np.linalg.norm([0.3, -0.5, 0.81])
    q0 = mrp_to_quat(np.array([-0.083, 0.220, -0.500]))
    r0 = 6.9e6
    y0 = np.concatenate([[r0, 0.0, 0.0, 0.0, np.sqrt(3.986004418e14 / r0) * 0.8, np.sqrt(3.986004418e14 / r0) * 0.6], q0, w0])
    t = np.arange(0.0, 1200.0 + 1e-9, 3.0)
    physics = TruthPhysics(name="gravity-gradient", gravity_gradient=True)
    tr = integrate_perturbed(y0, t, J, physics.body_params("target", y0[:3]))
    orbit = ChaserOrbit(t, np.concatenate([tr.r_I, tr.v_I], axis=1), n_rad_s=1e-3, j2=False)
    x0 = np.concatenate([quat_to_mrp(q0), w0, k])
    f, free = AttitudeUKF(x0, 1e-14 * np.eye(8), orbit=orbit, t0_s=0.0), AttitudeUKF(x0, 1e-14 * np.eye(8))
    for i in range(1, t.size):
        f.predict(3.0)
        free.predict(3.0)
        assert attitude_angle(tr.q_IB[i], f.q_IT) < 1e-5
        np.testing.assert_allclose(f.x[3:6], tr.w_B[i], rtol=0, atol=1e-8)
    assert f.t_s == pytest.approx(t[-1])
    assert np.linalg.norm(free.x[3:6] - tr.w_B[-1]) > 1e-4
