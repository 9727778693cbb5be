"""Simulated pose measurements (eqs 33–34 of Renis et al.): noise statistics, faults, range scaling, seeds."""

import numpy as np
import pytest

from estimators.attitude import attitude_angle, quat_conjugate, quat_multiply, quat_to_rotvec
from estimators.state import Q_TS, R_ST_T
from perception.simulated_pose import simulate_pose_measurements


def _truth(n=4001, dt=0.5, r0=50.0):
    t = dt * np.arange(n)
    x = np.zeros((n, 15))
    ang = 0.05 * t
    x[:, 0] = np.cos(ang / 2)
    x[:, 3] = np.sin(ang / 2)
    x[:, 7] = r0
    x[:, 8] = 0.01 * t
    return t, x


def test_isotropic_noise_has_the_papers_statistics():
    t, x = _truth()
    m = simulate_pose_measurements(t, x, np.random.default_rng(3), tau_s=0.5)
    assert len(m.t) == len(t) - 1 and m.t[0] == 0.5
    i = np.rint(m.t / 0.5).astype(int)
    # eq. 33: q̃ = q ⊗ δq_n, with |α_n| half-normal of σ = 0.12 rad, axis uniform
    dq = quat_multiply(quat_conjugate(x[i, Q_TS]), m.q_TS)
    ang = attitude_angle(x[i, Q_TS], m.q_TS)
    assert np.mean(ang) == pytest.approx(0.12 * np.sqrt(2 / np.pi), rel=0.05)
    rv = quat_to_rotvec(dq)
    np.testing.assert_allclose(np.cov(rv.T), 0.12**2 / 3 * np.eye(3), atol=0.0008)
    dr = m.r_ST_T - x[i, R_ST_T]
    assert np.sqrt(np.mean(np.sum(dr**2, axis=1))) == pytest.approx(0.37, rel=0.05)
    np.testing.assert_allclose(np.cov(dr.T), 0.37**2 / 3 * np.eye(3), atol=0.01)
    np.testing.assert_allclose(np.linalg.norm(m.q_TS, axis=1), 1.0, atol=1e-12)


def test_gaussian_noise_has_the_same_covariance_and_chi_square_norm():
    t, x = _truth()
    m = simulate_pose_measurements(t, x, np.random.default_rng(4), tau_s=0.5, noise="gaussian")
    i = np.rint(m.t / 0.5).astype(int)
    dr = m.r_ST_T - x[i, R_ST_T]
    np.testing.assert_allclose(np.cov(dr.T), 0.37**2 / 3 * np.eye(3), atol=0.01)
    e2 = np.sum(dr**2, axis=1) / (0.37**2 / 3)
    assert np.mean(e2 > 9.348) == pytest.approx(0.025, abs=0.01)  # χ²₃ upper 2.5 % point


def test_faults_range_scaling_rate_and_seed():
    t, x = _truth(n=201, dt=0.5, r0=100.0)
    kw = dict(tau_s=1.0, faults=[(20.0, 30.0)], range_scaling=True)
    a = simulate_pose_measurements(t, x, np.random.default_rng(5), **kw)
    b = simulate_pose_measurements(t, x, np.random.default_rng(5), **kw)
    np.testing.assert_array_equal(a.q_TS, b.q_TS)
    np.testing.assert_allclose(np.diff(a.t), 1.0)
    assert a.faulty.sum() == 30 and np.all(a.faulty == ((a.t >= 20) & (a.t < 50)))
    np.testing.assert_allclose(a.sigma_r_m[~a.faulty], 0.37 * np.linalg.norm(x[np.rint(a.t / 0.5).astype(int)][~a.faulty, R_ST_T], axis=1) / 50.0)
    assert np.all(a.sigma_r_m[a.faulty] == 20.0)
    with pytest.raises(ValueError, match="not on the truth time grid"):
        simulate_pose_measurements(t, x, np.random.default_rng(5), tau_s=0.3)
    with pytest.raises(ValueError, match="fault window"):
        simulate_pose_measurements(t, x, np.random.default_rng(5), tau_s=1.0, faults=[(10.0, -1.0)])
    with pytest.raises(ValueError, match="noise must be one of"):
        simulate_pose_measurements(t, x, np.random.default_rng(5), tau_s=1.0, noise="laplace")
