"""Batch acquisition of CoMBiNa's attitude state (estimators.combina.acquisition): k from four measured attitudes of a fast tumbler."""

import numpy as np
import pytest

from estimators.attitude import attitude_angle, mrp_to_quat, quat_conjugate, quat_multiply, quat_to_mrp, random_quaternion, rotvec_to_quat
from estimators.combina.acquisition import LearningRefits, acquire_attitude
from estimators.combina.attitude import AttitudeUKF, error_mrp_noise_covariance, physical_k, propagate_rigid_body
from estimators.dynamics import inertia_from_k, integrate_absolute
from studies.sim.combina import process_noise

TU_S = 963.65  # the CoMBiNa scenario's time unit (1/n)
#: Eq. 48 of Maestrini et al.: P_0 = 0.1 I in scaled units (attitude MRP, rate in rad/TU, k).
P0 = np.diag([0.1] * 3 + [0.1 / TU_S**2] * 3 + [0.1] * 2)
SD_ATT = np.deg2rad(2.0)
DT_S = 3.03  # 0.33 Hz
Q_ATT = process_noise("asymmetric")[1]  # the closed loop's attitude process noise


def _arc(seed: int, rate_rad_s: float, n: int, roll_axis=None):
    """A random rigid body (k uniform in [-1.5, 1.5]², redrawn until physical) tumbling at ``rate_rad_s``: DOP853 truth at 0.33 Hz,
    the prior drawn from eq. 48's ``P_0`` about the truth at t = 0, and ``n`` measured attitudes (2° per axis; with ``roll_axis``,
    each also rolled by a uniform angle about that body axis, as BCPD does on an axisymmetric target)."""
    rng = np.random.default_rng(seed)
    k = rng.uniform(-1.5, 1.5, 2)
    while not physical_k(k):
        k = rng.uniform(-1.5, 1.5, 2)
    d = rng.normal(size=3)
    w0 = rate_rad_s * d / np.linalg.norm(d)
    q0 = random_quaternion(rng)
    t = DT_S * np.arange(n + 1)
    truth = integrate_absolute(np.concatenate([[7e6, 0.0, 0.0, 0.0, 7.5e3, 0.0], q0, w0]), t, inertia_from_k(*k))
    x0 = np.concatenate([quat_to_mrp(q0), w0, k]) + np.sqrt(np.diag(P0)) * rng.normal(size=8)
    q_meas = np.array([quat_multiply(q, rotvec_to_quat(SD_ATT * rng.normal(size=3))) for q in truth.q_IB[1:]])
    if roll_axis is not None:
        q_meas = np.array([quat_multiply(q, rotvec_to_quat(rng.uniform(0, 2 * np.pi) * np.asarray(roll_axis, float))) for q in q_meas])
    return t[1:], q_meas, x0, truth, k


def _ukf_k(t, q_meas, x0) -> np.ndarray:
    """k after the attitude UKF's own corrections of the same measurements (the loop's settings: process noise, 3 iterations)."""
    f = AttitudeUKF(x0, P0, Q=Q_ATT, iterations=3)
    R = error_mrp_noise_covariance(SD_ATT)
    t_prev = 0.0
    for ti, q in zip(t, q_meas):
        f.predict(ti - t_prev)
        f.correct(f.innovation(q, R))
        t_prev = ti
    return f.x[6:]


N_BODIES = 20


@pytest.mark.slow
@pytest.mark.parametrize("rate_rad_s, min_acquired, max_ukf", [(0.9, 16, 12), (1.5, 16, 5)])
def test_four_attitudes_pin_k_where_gaussian_updates_do_not(rate_rad_s, min_acquired, max_ukf):
    """20 random rigid bodies, k 1-σ 0.3 (eq. 48), 4 attitudes at 0.33 Hz (156° and 260° per interval).

    Measured: the acquisition's k within 0.1 of the truth for 18/20 at both rates (the others are k it states as
    uncertain: k's NEES, 2 dof, below its 99.9 % quantile for 20/20); the UKF's Gaussian updates of the same
    measurements 9/20 and 2/20. Every acquisition fits (χ² at 99.9 %, no measurement left out).
    """
    from scipy.stats import chi2

    acquired = ukf = k_consistent = 0
    for seed in range(N_BODIES):
        t, q_meas, x0, truth, k = _arc(seed, rate_rad_s, 4)
        a = acquire_attitude(t, q_meas, SD_ATT, x0, P0)
        assert a is not None and a.fits() and a.used.all()
        e = a.x[6:] - k
        acquired += np.linalg.norm(e) < 0.1
        k_consistent += e @ np.linalg.solve(a.P[6:, 6:], e) < chi2.ppf(0.999, 2)
        try:
            ukf += np.linalg.norm(_ukf_k(t, q_meas, x0) - k) < 0.1
        except ValueError:  # a sigma point's propagation overflowed: the UKF diverged
            pass
    assert acquired >= min_acquired, acquired
    assert k_consistent >= N_BODIES - 1, k_consistent
    assert ukf <= max_ukf, ukf


def test_a_misregistration_is_left_out():
    """Five attitudes at 0.9 rad/s, the third turned by a further 120° (a misaligned registration): it is left out, the rest fit."""
    t, q_meas, x0, truth, k = _arc(3, 0.9, 5)
    q_meas[2] = quat_multiply(q_meas[2], rotvec_to_quat(np.deg2rad(120.0) * np.array([0.6, 0.0, 0.8])))
    a = acquire_attitude(t, q_meas, SD_ATT, x0, P0)
    assert a is not None and a.fits()
    np.testing.assert_array_equal(a.used, [True, True, False, True, True])
    assert np.linalg.norm(a.x[6:] - k) < 0.1
    assert attitude_angle(truth.q_IB[0], mrp_to_quat(a.x[:3])) < np.deg2rad(3.0)


def test_a_random_roll_fits_no_rigid_body():
    """An axisymmetric target's registrations roll at random about its axis (body y): no rigid-body motion explains them."""
    for seed in range(3):
        t, q_meas, x0, *_ = _arc(seed, 0.3, 4, roll_axis=[0.0, 1.0, 0.0])
        a = acquire_attitude(t, q_meas, SD_ATT, x0, P0)
        assert a is None or not a.fits()


@pytest.mark.slow
def test_initial_state_posterior_is_consistent_and_the_filter_carries_it():
    """The acquisition's NEES (8 dof) of the initial state over 30 random rigid bodies at 0.9 rad/s (eq. 48's prior, 4 attitudes):
    mean within the 99.8 % band of χ²₈, in the error MRP of :class:`AttitudeUKF` (truth = estimate ⊗ q(δσ)); and the UKF
    started from it and carried through the arc's epochs to the last one (as the closed loop does, with the torque-free world's
    process noise: none) puts the truth inside its 95 % region at that rate (binomial, 99.9 %).

    Measured: mean 8.6 at t_0 (median 8.2); at the last epoch 27 of 30 inside the 95 % region (mean 10.4, median 8.0: one run
    at 66). With the perturbed world's former process noise (1.38e-12 rad²/s³ and a random walk on ``k``) the carried mean was
    8.4–9.4, a margin that covered the tail. The Laplace covariance of the MAP *last* state (where ω(t_n) ≈ ω(t_0) + ∫ω̇(k) is
    curved in k) had a median NEES of 75 on the same arcs, 14 of 30 above 10²."""
    from scipy.stats import binom, chi2

    nees_0, nees_n = [], []
    for seed in range(30):
        t, q_meas, x0, truth, k = _arc(200 + seed, 0.9, 4)
        a = acquire_attitude(t, q_meas, SD_ATT, x0, P0)
        assert a.t_s == 0.0
        e = np.concatenate([quat_to_mrp(quat_multiply(quat_conjugate(mrp_to_quat(a.x[:3])), truth.q_IB[0])), truth.w_B[0] - a.x[3:6], k - a.x[6:]])
        nees_0.append(float(e @ np.linalg.solve(a.P, e)))
        f = AttitudeUKF(a.x, a.P, Q=process_noise("asymmetric", "torque-free")[1])
        for dt in np.diff(np.concatenate([[a.t_s], t])):
            f.predict(dt)
        e = np.concatenate([f.error_mrp(truth.q_IB[-1]), truth.w_B[-1] - f.x[3:6], k - f.x[6:]])
        nees_n.append(float(e @ np.linalg.solve(f.P, e)))
    lo, hi = chi2.ppf([0.001, 0.999], 8 * 30) / 30
    assert lo <= np.mean(nees_0) <= hi, np.mean(nees_0)
    inside = int(np.sum(np.array(nees_n) <= chi2.ppf(0.95, 8)))
    assert inside >= binom.ppf(0.001, 30, 0.95), (inside, np.round(nees_n, 1))


def test_bad_input():
    t, q_meas, x0, *_ = _arc(0, 0.3, 3)
    with pytest.raises(ValueError, match="strictly increasing"):
        acquire_attitude(t[::-1], q_meas, SD_ATT, x0, P0)
    with pytest.raises(ValueError, match="q_IT_meas"):
        acquire_attitude(t, q_meas[:2], SD_ATT, x0, P0)
    with pytest.raises(ValueError, match="attitude_sigma_rad"):
        acquire_attitude(t, q_meas, 0.0, x0, P0)


def _learning_run(seed: int, refits: bool, n_steps: int) -> float:
    """NEES (8 dof) at the last of ``n_steps`` 3.03 s epochs of the attitude UKF (no process noise) on its own model: eq. 47's
    slow, near-spherical box-wing (k = (0.03, −0.1), 1.2e-3 rad/s) integrated finely, 2° registrations, the start drawn from a
    prior with eq. 48's 1-σ of 0.3 on ``k`` and 3.3e-4 rad/s on ω (attitude 1°); with ``refits``, restarted from
    :class:`LearningRefits` whenever it says a refit is due."""
    from studies.sim.combina import K_TARGETS, SCENARIO

    rng = np.random.default_rng(seed)
    k, q0, w0 = K_TARGETS["asymmetric"], np.array(SCENARIO.q_IT0), np.array(SCENARIO.w_T0_T_rad_s)
    P_start = np.diag([(np.deg2rad(1.0) / 4) ** 2] * 3 + [3.3e-4**2] * 3 + [0.3**2] * 2)
    d = rng.multivariate_normal(np.zeros(8), P_start)
    x0 = np.concatenate([quat_to_mrp(quat_multiply(q0, mrp_to_quat(d[:3]))), w0 + d[3:6], k + d[6:]])
    Y = np.concatenate([q0, w0, k])[None]
    f = AttitudeUKF(x0, P_start)
    learning = LearningRefits(0.0, x0, P_start, SD_ATT) if refits else None
    for i in range(1, n_steps + 1):
        Y = propagate_rigid_body(Y, DT_S, max_step_s=0.05, max_angle_rad=0.005)
        f.predict(DT_S)
        q_meas = quat_multiply(Y[0, :4], rotvec_to_quat(SD_ATT * rng.normal(size=3)))
        f.correct(f.innovation(q_meas, error_mrp_noise_covariance(SD_ATT)))
        if learning is not None:
            learning.add(i * DT_S, q_meas)
            a = learning.refit(f.x) if learning.due(f.P) else None
            if a is not None:
                f = AttitudeUKF(a.x, a.P)
                for dt in np.diff(np.concatenate([[a.t_s], learning.t_s])):
                    f.predict(dt)
    e = np.concatenate([f.error_mrp(Y[0, :4]), Y[0, 4:7] - f.x[3:6], Y[0, 7:] - f.x[6:]])
    return float(e @ np.linalg.solve(f.P, e))


@pytest.mark.slow
def test_refits_mend_most_of_the_ukfs_over_confidence_while_it_learns_k():
    """On its own model with no process noise (:func:`_learning_run`, 30 seeds, 450 epochs = 1360 s, while ``k``'s 1-σ falls
    from 0.3 to ~0.05) the plain UKF's NEES at the last epoch is far above χ²₈ (its sum over the seeds beyond the 99.5 %
    quantile of χ²₂₄₀; measured 4.5 per state): the bug the refits mend. With :class:`LearningRefits` the sum is less than
    half of it (measured 1.4 per state: still above the band between two refits, the last one at 256 epochs, `docs/known-limitations.md`)."""
    from scipy.stats import chi2

    plain = [_learning_run(seed, False, 450) for seed in range(30)]
    refitted = [_learning_run(seed, True, 450) for seed in range(30)]
    assert np.sum(plain) > chi2.ppf(0.995, 240), np.round(plain, 1)
    assert np.sum(refitted) < 0.5 * np.sum(plain), (np.round(refitted, 1), np.round(plain, 1))
