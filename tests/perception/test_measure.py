"""Pose measurements of eqs 3–8 of Maestrini et al.: MRP extraction, recovered pose, gates, degenerate clouds."""

from __future__ import annotations

import numpy as np
import pytest

from estimators.attitude import (
    attitude_angle,
    dcm_to_quat,
    mrp_shadow,
    mrp_to_quat,
    quat_to_dcm,
    quat_to_mrp,
    random_quaternion,
    rotvec_to_quat,
)
from perception.measure import measure_pose, mrp_of_C_TI
from tests.perception.shapes import box_wing, with_outliers


@pytest.mark.parametrize("angle_deg", [0.0, 90.0, 179.9, 180.0])
def test_eq6_7_mrp_against_foundation(angle_deg):
    rng = np.random.default_rng(int(angle_deg * 10))
    axis = rng.normal(size=3)
    axis /= np.linalg.norm(axis)
    q_IT = rotvec_to_quat(np.deg2rad(angle_deg) * axis)
    C_TI = quat_to_dcm(q_IT).T  # passive DCM inertial -> target
    sigma = mrp_of_C_TI(C_TI)
    expected = quat_to_mrp(q_IT)
    assert np.linalg.norm(sigma) <= 1.0 + 1e-12
    if angle_deg == 180.0:
        # at exactly 180 deg sigma and its shadow -sigma/|sigma|^2 = -sigma are the same rotation
        assert min(np.linalg.norm(sigma - expected), np.linalg.norm(sigma - mrp_shadow(expected))) < 1e-9
    else:
        assert np.allclose(sigma, expected, atol=1e-9)
    # and the MRP is the attitude q_IT itself: |sigma| = tan(angle/4)
    assert np.isclose(np.linalg.norm(sigma), np.tan(np.deg2rad(angle_deg) / 4), atol=1e-9)


def _scene(rng, q_IT, r_L, model_shape, n=800, noise_m=0.01, outliers=0.1):
    """A measured cloud in C for a target at attitude q_IT and LVLH position r_L."""
    C_IC = quat_to_dcm(random_quaternion(rng))
    C_IL = quat_to_dcm(random_quaternion(rng))
    p_T = model_shape(rng, n)
    p_I = p_T @ quat_to_dcm(q_IT).T + C_IL @ r_L
    cloud_C = p_I @ C_IC + rng.normal(scale=noise_m, size=p_I.shape)
    return with_outliers(rng, cloud_C, outliers), C_IC, C_IL


@pytest.mark.parametrize("angle_deg", [0.0, 90.0, 179.9, 180.0])
def test_recovers_pose_from_a_perturbed_estimate(angle_deg):
    rng = np.random.default_rng(100 + int(angle_deg))
    model = box_wing(rng, 8000)
    center = model.mean(axis=0)
    model -= center
    shape = lambda r, n: box_wing(r, n) - center  # noqa: E731
    axis = np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8])
    q_IT = rotvec_to_quat(np.deg2rad(angle_deg) * axis)
    r_L = np.array([2.0, -35.0, 4.0])
    cloud_C, C_IC, C_IL = _scene(rng, q_IT, r_L, shape)
    # filter estimate: 8 deg off in attitude, 0.4 m off in position
    q_err = rotvec_to_quat(np.deg2rad(8.0) * np.array([0.0, 0.6, 0.8]))
    C_TI_hat = quat_to_dcm(q_err) @ quat_to_dcm(q_IT).T
    r_L_hat = r_L + np.array([0.3, -0.2, 0.2])
    m = measure_pose(cloud_C, model, C_TI_hat=C_TI_hat, C_IC=C_IC, C_IL=C_IL, r_L_hat=r_L_hat, w=0.1)
    assert m.accepted, m.reason
    q_meas = dcm_to_quat(m.C_TI.T)
    assert np.rad2deg(attitude_angle(q_meas, q_IT)) < 1.0
    # the MRP describes the same attitude (either sign set at 180 deg)
    assert np.rad2deg(attitude_angle(mrp_to_quat(m.sigma_T), q_IT)) < 1.0
    assert np.linalg.norm(m.r_L - r_L) < 0.02
    assert abs(m.scale - 1) < 0.02


def test_scale_gate_rejects_a_deformed_cloud():
    rng = np.random.default_rng(7)
    model = box_wing(rng, 3000)
    model -= model.mean(axis=0)
    cloud = 1.5 * model[rng.choice(3000, 600, replace=False)]
    eye = np.eye(3)
    m = measure_pose(cloud, model, C_TI_hat=eye, C_IC=eye, C_IL=eye, r_L_hat=np.zeros(3))
    assert not m.accepted
    assert "scale gate" in m.reason
    assert m.scale < 0.8  # model ~ s * measured with s ~ 1/1.5


@pytest.mark.parametrize(
    "cloud, reason",
    [
        (np.zeros((0, 3)), "0 finite points"),
        (np.full((50, 3), np.nan), "0 finite points"),
        (np.outer(np.linspace(-1, 1, 50), [1.0, 2.0, 0.5]) + np.array([0, 0, -30.0]), "collinear"),
        (np.ones((50, 3)), "collinear"),
    ],
)
def test_degenerate_cloud_is_a_rejected_measurement(cloud, reason):
    eye = np.eye(3)
    model = box_wing(np.random.default_rng(0), 500)
    m = measure_pose(cloud, model, C_TI_hat=eye, C_IC=eye, C_IL=eye, r_L_hat=np.array([0, 0, -30.0]))
    assert not m.accepted
    assert reason in m.reason
    assert m.registration is None and np.all(np.isnan(m.sigma_T))


def test_bad_arguments_raise():
    eye = np.eye(3)
    with pytest.raises(ValueError, match="C_IC must be a 3x3 rotation"):
        measure_pose(np.zeros((30, 3)), np.zeros((30, 3)), C_TI_hat=eye, C_IC=2 * eye, C_IL=eye, r_L_hat=np.zeros(3))
    with pytest.raises(ValueError, match="cloud_C must be an \\(M, 3\\)"):
        measure_pose(np.zeros(30), np.zeros((30, 3)), C_TI_hat=eye, C_IC=eye, C_IL=eye, r_L_hat=np.zeros(3))
