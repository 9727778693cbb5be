"""Attitude UKF of 000 §IV.B: process model (eqs 28–29), MRP wrap in the innovation, shadow switch (eqs 31–32)."""

import numpy as np
import pytest

from estimators.attitude import attitude_angle, mrp_shadow, mrp_to_quat, quat_to_mrp, rotvec_to_quat
from estimators.combina_attitude import AttitudeUKF, nearest_mrp
from estimators.dynamics import inertia_from_k, integrate_absolute

K = np.array([0.03, -0.1])
W0 = np.array([-0.3953, -0.7065, -0.8153]) / 963.65


def test_prediction_matches_absolute_rigid_body():
    """Tiny covariance: the predicted MRP and rate follow the DOP853 quaternion + Euler truth over 600 s."""
    q0 = mrp_to_quat(np.array([-0.083, 0.220, -0.500]))
    x0 = np.concatenate([quat_to_mrp(q0), W0 * 20.0, K])  # 20× the paper's rate: ~14 rad turned
    f = AttitudeUKF(x0, 1e-14 * np.eye(8))
    y0 = np.concatenate([np.array([7e6, 0, 0, 0, 7.5e3, 0]), q0, W0 * 20.0])
    tr = integrate_absolute(y0, np.linspace(0.0, 600.0, 201), inertia_from_k(*K))
    for i in range(1, 201):
        f.predict(3.0)
        f.switch_to_shadow_if_needed()
        err = attitude_angle(tr.q_IB[i], f.q_IT)
        assert err < 1e-7
        np.testing.assert_allclose(f.x[3:6], tr.w_B[i], rtol=0, atol=1e-10)
    assert f.n_shadow_switches >= 1


def test_innovation_uses_the_predicted_sets_side():
    """Near |σ| = 1 the measured MRP is re-expressed on the estimate's side: a 1° difference, not ~360°."""
    axis = np.array([0.0, 0.6, 0.8])
    est = np.tan(np.deg2rad(179.5) / 4) * axis  # |σ| just below 1
    f = AttitudeUKF(np.concatenate([est, W0, K]), 1e-4 * np.eye(8))
    q_meas = rotvec_to_quat(np.deg2rad(180.5) * axis)  # 1° further: its |σ| ≤ 1 set is on the far side
    assert np.linalg.norm(quat_to_mrp(q_meas) - est) > 1.9
    inn = f.innovation(q_meas, 0.01 * np.eye(3))
    # 1° about the axis at |σ| ≈ 1 is dσ = dθ/4·(1+σ²) = dθ/2 along the axis
    assert np.linalg.norm(inn.y) == pytest.approx(np.deg2rad(1.0) / 2, rel=0.02)
    np.testing.assert_allclose(nearest_mrp(quat_to_mrp(q_meas), est), mrp_shadow(quat_to_mrp(q_meas)))


def test_shadow_switch_keeps_attitude_error_continuous():
    """A correction that pushes |σ| > 1 triggers eqs 31–32; the attitude (and its error) does not jump (< 1e-9 rad)."""
    axis = np.array([0.36, 0.48, 0.8])
    q_true = rotvec_to_quat(np.deg2rad(182.0) * axis)
    f = AttitudeUKF(np.concatenate([np.tan(np.deg2rad(178.0) / 4) * axis, W0, K]), np.diag([1e-2] * 3 + [1e-8] * 3 + [1e-2] * 2))
    inn = f.innovation(q_true, 1e-4 * np.eye(3))
    f.core.correct(inn)  # the update alone: |σ| > 1 now
    sigma_before, P_before = f.x[:3].copy(), f.P.copy()
    assert np.linalg.norm(sigma_before) > 1.0
    err_before = attitude_angle(q_true, mrp_to_quat(sigma_before))
    assert f.switch_to_shadow_if_needed()
    assert np.linalg.norm(f.x[:3]) < 1.0
    err_after = attitude_angle(q_true, f.q_IT)
    assert abs(err_after - err_before) < 1e-9
    assert attitude_angle(mrp_to_quat(sigma_before), f.q_IT) < 1e-9
    # covariance of the non-MRP states untouched, the MRP block transformed (positive definite)
    np.testing.assert_allclose(f.P[3:, 3:], P_before[3:, 3:])
    assert np.min(np.linalg.eigvalsh(f.P)) > 0


def test_rate_proxy_measures_the_spin_rate():
    f = AttitudeUKF(np.concatenate([np.zeros(3), W0, K]), np.diag([1e-2] * 3 + [1e-9] * 3 + [1e-2] * 2))
    inn = f.rate_proxy_innovation(1.1 * np.linalg.norm(W0), 1e-10)
    assert inn.z_pred[0] == pytest.approx(np.linalg.norm(W0), rel=1e-3)
    f.correct(inn)
    assert np.linalg.norm(f.x[3:6]) > np.linalg.norm(W0)  # pulled towards the proxy rate


def test_bad_input():
    with pytest.raises(ValueError, match="x0"):
        AttitudeUKF(np.zeros(7), np.eye(7))
    f = AttitudeUKF(np.zeros(8), np.eye(8))
    with pytest.raises(ValueError, match="dt_s"):
        f.predict(-1.0)
    with pytest.raises(ValueError, match="proxy"):
        f.rate_proxy_innovation(-1.0, 1.0)
