"""Attitude maths: round trips, composition, shadow sets, kinematics (hypothesis)."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from scipy.spatial.transform import Rotation

from estimators import attitude as att

finite = st.floats(-1.0, 1.0, allow_nan=False, allow_infinity=False)
vec4 = arrays(float, 4, elements=finite).filter(lambda q: np.linalg.norm(q) > 0.1)
vec3 = arrays(float, 3, elements=st.floats(-3.0, 3.0))


def unit(q):
    return q / np.linalg.norm(q)


@given(vec4, vec4)
def test_product_composes_like_dcm_products(a, b):
    qa, qb = unit(a), unit(b)
    np.testing.assert_allclose(att.quat_to_dcm(att.quat_multiply(qa, qb)), att.quat_to_dcm(qa) @ att.quat_to_dcm(qb), atol=1e-12)


@given(vec4)
def test_dcm_is_orthonormal_and_matches_scipy(a):
    q = unit(a)
    R = att.quat_to_dcm(q)
    np.testing.assert_allclose(R @ R.T, np.eye(3), atol=1e-12)
    assert np.linalg.det(R) == pytest.approx(1.0, abs=1e-12)
    np.testing.assert_allclose(R, Rotation.from_quat(np.r_[q[1:], q[0]]).as_matrix(), atol=1e-12)


@given(vec4)
def test_conjugate_is_inverse(a):
    q = unit(a)
    np.testing.assert_allclose(att.quat_multiply(q, att.quat_conjugate(q)), [1, 0, 0, 0], atol=1e-12)


@given(vec4)
def test_quat_dcm_round_trip(a):
    q = unit(a)
    q2 = att.dcm_to_quat(att.quat_to_dcm(q))
    assert q2[0] >= 0
    # equal up to the sign (both signs are the same rotation; at q0 = 0 either may come back)
    assert min(np.abs(q2 - q).max(), np.abs(q2 + q).max()) < 1e-10


@given(vec4)
def test_mrp_round_trip_and_norm(a):
    q = unit(a)
    s = att.quat_to_mrp(q)
    assert np.linalg.norm(s) <= 1.0 + 1e-12
    np.testing.assert_allclose(att.mrp_to_dcm(s), att.quat_to_dcm(q), atol=1e-10)


@given(vec4)
def test_dcm_to_mrp_eq6_matches_quaternion_route(a):
    q = unit(a)
    s = att.dcm_to_mrp(att.quat_to_dcm(q))
    np.testing.assert_allclose(att.mrp_to_dcm(s), att.quat_to_dcm(q), atol=1e-9)
    assert np.linalg.norm(s) <= 1.0 + 1e-9


@pytest.mark.parametrize("angle_deg", [0.0, 90.0, 179.9, 180.0])
def test_dcm_to_mrp_at_special_angles(angle_deg):
    axis = unit(np.array([0.3, -0.5, 0.8]))
    q = att.rotvec_to_quat(np.radians(angle_deg) * axis)
    s = att.dcm_to_mrp(att.quat_to_dcm(q))
    assert np.linalg.norm(s) == pytest.approx(np.tan(np.radians(angle_deg) / 4), abs=1e-9)
    assert att.attitude_angle(att.mrp_to_quat(s), q) < 1e-8


def test_printed_eq6_denominator_is_wrong():
    """ζ(ζ+1) (as printed) does not give σ = q_v/(1+q0); ζ(ζ+2) does."""
    q = unit(np.array([0.8, 0.3, -0.2, 0.4]))
    C = att.quat_to_dcm(q)
    z = np.sqrt(np.trace(C) + 1)
    vee = np.array([C[2, 1] - C[1, 2], C[0, 2] - C[2, 0], C[1, 0] - C[0, 1]])
    expected = q[1:] / (1 + q[0])
    np.testing.assert_allclose(vee / (z * (z + 2)), expected, atol=1e-12)
    assert np.max(np.abs(vee / (z * (z + 1)) - expected)) > 1e-2


@given(vec3.filter(lambda s: 0.2 < np.linalg.norm(s) < 2.5))
def test_shadow_set_same_rotation_and_jacobian(s):
    sh = att.mrp_shadow(s)
    np.testing.assert_allclose(att.mrp_to_dcm(sh), att.mrp_to_dcm(s), atol=1e-9)
    # eq. 32 Jacobian against central differences
    h = 1e-6
    num = np.column_stack([(att.mrp_shadow(s + h * e) - att.mrp_shadow(s - h * e)) / (2 * h) for e in np.eye(3)])
    np.testing.assert_allclose(att.mrp_shadow_jacobian(s), num, rtol=1e-5, atol=1e-6)


def test_shadow_covariance_transform():
    s = np.array([0.6, -0.7, 0.5])
    P = np.diag(np.arange(1.0, 9.0)) * 1e-3
    sh, Ps = att.mrp_shadow_covariance(s, P)
    T = att.mrp_shadow_jacobian(s)
    np.testing.assert_allclose(Ps[:3, :3], T @ P[:3, :3] @ T.T)
    np.testing.assert_allclose(Ps[3:, 3:], P[3:, 3:])
    np.testing.assert_allclose(sh, -s / (s @ s))


@given(vec4, vec3)
@settings(max_examples=50)
def test_kinematics_against_numerical_derivative(a, w):
    """q̇ = ½ Q(q) ω equals d/dt of q(t) = q0 ⊗ exp(ω t / 2) at t = 0."""
    q = unit(a)
    h = 1e-6
    qp = att.quat_multiply(q, att.rotvec_to_quat(w * h))
    qm = att.quat_multiply(q, att.rotvec_to_quat(-w * h))
    np.testing.assert_allclose(att.quat_derivative(q, w), (qp - qm) / (2 * h), atol=1e-8)
    np.testing.assert_allclose(att.kinematics_matrix(q) @ w, att.quat_multiply(q, np.r_[0, w]), atol=1e-12)


@given(vec3.filter(lambda s: np.linalg.norm(s) < 0.9), vec3)
@settings(max_examples=50)
def test_mrp_kinematics_eq28_matches_quaternion_kinematics(s, w):
    h = 1e-6
    q = att.mrp_to_quat(s)
    sp = att.quat_to_mrp(att.quat_multiply(q, att.rotvec_to_quat(w * h)))
    sm = att.quat_to_mrp(att.quat_multiply(q, att.rotvec_to_quat(-w * h)))
    np.testing.assert_allclose(att.mrp_derivative(s, w), (sp - sm) / (2 * h), atol=1e-7)


@given(vec3.filter(lambda v: np.linalg.norm(v) < np.pi - 1e-3))
def test_rotvec_round_trip_and_angle(v):
    q = att.rotvec_to_quat(v)
    np.testing.assert_allclose(att.quat_to_rotvec(q), v, atol=1e-9)
    assert att.attitude_angle([1, 0, 0, 0], q) == pytest.approx(np.linalg.norm(v), abs=1e-9)
    assert att.dcm_angle(np.eye(3), att.quat_to_dcm(q)) == pytest.approx(np.linalg.norm(v), abs=1e-6)


def test_skew_is_cross_product():
    a, b = np.array([1.0, -2.0, 0.5]), np.array([0.3, 0.1, -4.0])
    np.testing.assert_allclose(att.skew(a) @ b, np.cross(a, b))


def test_normalise_refuses_zero():
    with pytest.raises(ValueError, match="non-zero"):
        att.quat_normalize([0.0, 0.0, 0.0, 0.0])


def test_random_quaternions_are_uniform():
    q = att.random_quaternion(np.random.default_rng(0), 20000)
    np.testing.assert_allclose(np.linalg.norm(q, axis=1), 1.0)
    # the rotated x axis of uniform rotations is uniform on the sphere: mean ≈ 0
    x = att.quat_to_dcm(q)[:, :, 0]
    assert np.all(np.abs(x.mean(axis=0)) < 0.03)
