"""On a linear model both filters are the textbook Kalman filter (filterpy's ``KalmanFilter``) to 1e-10."""

import numpy as np
import pytest
from filterpy.kalman import KalmanFilter

from estimators.ekf import ExtendedKalmanFilter
from estimators.measurement import LinearMeasurement
from estimators.process_model import LinearProcessModel
from estimators.ukf import UnscentedKalmanFilter


def cv_transition(dt):
    """2-D constant-velocity model, state [x, y, vx, vy]."""
    F = np.eye(4)
    F[0, 2] = F[1, 3] = dt
    return F


@pytest.mark.parametrize("cls,linearization_covariance", [(ExtendedKalmanFilter, False), (ExtendedKalmanFilter, True), (UnscentedKalmanFilter, False)])
def test_linear_model_matches_textbook_kalman_filter(cls, linearization_covariance):
    """On a linear model the EKF's linearisation-error covariance (settling phase) is exactly zero."""
    rng = np.random.default_rng(7)
    dt = 0.5
    Q = np.diag([1e-3, 2e-3, 1e-2, 5e-3]) + 1e-4
    P0 = np.diag([4.0, 2.0, 1.0, 0.5])
    x0 = np.array([1.0, -2.0, 0.3, 0.1])
    sx = LinearMeasurement(H=[[1.0, 0, 0, 0]], R=[[0.2]], name="x")
    sy = LinearMeasurement(H=[[0, 1.0, 0, 0], [0, 0, 0, 1.0]], R=[[0.3, 0.05], [0.05, 0.1]], name="y")
    f = cls(LinearProcessModel(cv_transition), x0, P0, Q, gate_confidence=None)
    if linearization_covariance:
        f.linearization_covariance = True

    kf = KalmanFilter(dim_x=4, dim_z=3)
    kf.x, kf.P, kf.F, kf.Q = x0.copy(), P0.copy(), cv_transition(dt), Q

    truth = x0.copy()
    for k in range(60):
        truth = cv_transition(dt) @ truth
        f.predict(None, dt)
        kf.predict()
        np.testing.assert_allclose(f.x, kf.x, rtol=0, atol=1e-10)
        np.testing.assert_allclose(f.P, kf.P, rtol=0, atol=1e-10)
        # alternate full and partial measurements (the gate-less partial update path)
        zx = truth[:1] + rng.normal(0, 0.4, 1)
        zy = truth[[1, 3]] + rng.normal(0, 0.3, 2)
        if k % 3 == 2:
            f.update([(sx, zx)])
            kf.update(zx, R=sx.R, H=sx.H)
        else:
            f.update([(sx, zx), (sy, zy)])
            kf.update(np.concatenate([zx, zy]), R=np.block([[sx.R, np.zeros((1, 2))], [np.zeros((2, 1)), sy.R]]), H=np.vstack([sx.H, sy.H]))
        np.testing.assert_allclose(f.x, kf.x, rtol=0, atol=1e-10)
        np.testing.assert_allclose(f.P, kf.P, rtol=0, atol=1e-10)
        np.testing.assert_allclose(f.y, kf.y, rtol=0, atol=1e-10)
        np.testing.assert_allclose(f.S, kf.S, rtol=0, atol=1e-10)


@pytest.mark.parametrize("how", ["index", "direction"])
def test_ukf_considering_states_is_the_schmidt_kalman_filter(how):
    """Considered states (an index, or a direction mixing two states) enter the UKF's prediction linearly
    (:meth:`~estimators.ukf.UnscentedKalmanFilter._predict_considering`); on a linear model it is then the
    Schmidt–Kalman filter, which the EKF implements in closed form (``P⁻ = F P Fᵀ + Q``, gain zero along the
    considered space): same state, covariance and innovations to 1e-10."""
    rng = np.random.default_rng(8)
    dt = 0.5
    Q = np.diag([1e-3, 2e-3, 1e-2, 5e-3]) + 1e-4
    P0 = np.array([[4.0, 0.3, 0.5, 0.1], [0.3, 2.0, 0.0, 0.2], [0.5, 0.0, 1.0, 0.1], [0.1, 0.2, 0.1, 0.5]])
    x0 = np.array([1.0, -2.0, 0.3, 0.1])
    s = LinearMeasurement(H=[[1.0, 0, 0, 0], [0, 1.0, 0, 0]], R=[[0.2, 0.0], [0.0, 0.3]], name="xy")
    filters = [cls(LinearProcessModel(cv_transition), x0, P0, Q, gate_confidence=None) for cls in (ExtendedKalmanFilter, UnscentedKalmanFilter)]
    for f in filters:
        if how == "index":
            f.consider = np.array([3])
        else:
            f.consider_directions = np.array([[0.0, 0.0, 0.6, 0.8]])
    truth = x0.copy()
    for _ in range(40):
        truth = cv_transition(dt) @ truth
        z = truth[:2] + rng.normal(0, 0.4, 2)
        for f in filters:
            f.predict(None, dt)
            f.update([(s, z)])
        ekf, ukf = filters
        np.testing.assert_allclose(ukf.x, ekf.x, rtol=0, atol=1e-10)
        np.testing.assert_allclose(ukf.P, ekf.P, rtol=0, atol=1e-10)
        np.testing.assert_allclose(ukf.y, ekf.y, rtol=0, atol=1e-10)
