"""Attitude maths shared by every lcnav package: pure, vectorised functions.

Conventions (DESIGN.md):

* quaternions are scalar-first Hamilton ``[q0, q1, q2, q3]``;
* ``q_AB`` maps vectors from frame B to frame A: ``v_A = R(q_AB) v_B``, so
  ``q_AC = q_AB ⊗ q_BC`` and ``R(q_AC) = R(q_AB) R(q_BC)``;
* kinematics ``q̇_AB = ½ q_AB ⊗ [0, ω_B]`` with ω the rate of B relative to A
  expressed in B (eqs 2–3 of Renis et al.; ``Q(q)`` of eq. 3 is exactly the matrix
  of ``ω ↦ q ⊗ [0, ω]``);
* MRPs ``σ = q_v / (1 + q0)``, so ``σ`` and ``q`` describe the same rotation and
  ``R(σ) = R(q)``.

Every function accepts arrays with any number of leading (batch) dimensions:
a quaternion argument has shape ``(..., 4)``, a vector ``(..., 3)``, a matrix
``(..., 3, 3)``.

scipy's :class:`~scipy.spatial.transform.Rotation` is scalar-last; it is used
where it gives the same thing (DCM → quaternion, Shepperd's method) and the
order is converted at the call.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

__all__ = [
    "skew",
    "quat_multiply",
    "quat_conjugate",
    "quat_normalize",
    "quat_to_dcm",
    "dcm_to_quat",
    "quat_to_mrp",
    "mrp_to_quat",
    "mrp_to_dcm",
    "dcm_to_mrp",
    "mrp_shadow",
    "mrp_shadow_jacobian",
    "mrp_shadow_covariance",
    "kinematics_matrix",
    "quat_derivative",
    "mrp_derivative",
    "rotvec_to_quat",
    "quat_to_rotvec",
    "attitude_angle",
    "dcm_angle",
    "random_quaternion",
]


def _as_float(x) -> np.ndarray:
    return np.asarray(x, dtype=float)


def skew(v) -> np.ndarray:
    """Cross-product matrix ``[v×]`` so that ``skew(a) @ b == a × b``; shape ``(..., 3, 3)``."""
    v = _as_float(v)
    z = np.zeros_like(v[..., 0])
    return np.stack(
        [
            np.stack([z, -v[..., 2], v[..., 1]], axis=-1),
            np.stack([v[..., 2], z, -v[..., 0]], axis=-1),
            np.stack([-v[..., 1], v[..., 0], z], axis=-1),
        ],
        axis=-2,
    )


def quat_multiply(p, q) -> np.ndarray:
    """Hamilton product ``p ⊗ q`` (scalar first)."""
    p = _as_float(p)
    q = _as_float(q)
    # written out by component: ~2.5× faster than np.cross + concatenate on single quaternions
    p0, p1, p2, p3 = p[..., 0], p[..., 1], p[..., 2], p[..., 3]
    q0, q1, q2, q3 = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    return np.stack(
        [
            p0 * q0 - p1 * q1 - p2 * q2 - p3 * q3,
            p0 * q1 + p1 * q0 + p2 * q3 - p3 * q2,
            p0 * q2 - p1 * q3 + p2 * q0 + p3 * q1,
            p0 * q3 + p1 * q2 - p2 * q1 + p3 * q0,
        ],
        axis=-1,
    )


def quat_conjugate(q) -> np.ndarray:
    """Conjugate ``q*``; for a unit quaternion the inverse, ``q_BA = q_AB*``."""
    q = _as_float(q)
    return q * np.array([1.0, -1.0, -1.0, -1.0])


def quat_normalize(q) -> np.ndarray:
    """Unit quaternion ``q / |q|`` (eq. 28 of Renis et al.). Raises on a zero quaternion."""
    q = _as_float(q)
    n = np.linalg.norm(q, axis=-1, keepdims=True)
    if np.any(~np.isfinite(n)) or np.any(n == 0.0):
        raise ValueError("quaternion must be finite and non-zero to normalise")
    return q / n


def quat_to_dcm(q) -> np.ndarray:
    """Rotation matrix ``R(q)`` with ``v_A = R(q_AB) v_B``.

    ``R = (q0² − |q_v|²) I + 2 q_v q_vᵀ + 2 q0 [q_v×]``. ``q`` need not be
    normalised exactly; it is used as given (unit norm assumed).
    """
    q = _as_float(q)
    q0 = q[..., 0, None, None]
    qv = q[..., 1:]
    eye = np.eye(3)
    return (
        (q0**2 - np.sum(qv * qv, axis=-1)[..., None, None]) * eye
        + 2.0 * qv[..., :, None] * qv[..., None, :]
        + 2.0 * q0 * skew(qv)
    )


def _canonical(q: np.ndarray) -> np.ndarray:
    """Pick the sign with ``q0 ≥ 0`` (the rotation of at most 180°)."""
    sign = np.where(q[..., :1] < 0.0, -1.0, 1.0)
    return q * sign


def dcm_to_quat(C) -> np.ndarray:
    """Unit quaternion with ``R(q) = C``, sign chosen so that ``q0 ≥ 0``.

    Uses scipy's Shepperd-type extraction (scalar-last, converted here).
    """
    C = _as_float(C)
    shape = C.shape[:-2]
    xyzw = Rotation.from_matrix(C.reshape(-1, 3, 3)).as_quat()
    q = np.concatenate([xyzw[:, 3:], xyzw[:, :3]], axis=-1)
    return _canonical(q).reshape(shape + (4,))


def quat_to_mrp(q) -> np.ndarray:
    """MRP ``σ = q_v / (1 + q0)`` of the sign of ``q`` with ``q0 ≥ 0``, so ``|σ| ≤ 1``."""
    q = _canonical(_as_float(q))
    return q[..., 1:] / (1.0 + q[..., :1])


def mrp_to_quat(sigma) -> np.ndarray:
    """Unit quaternion of an MRP: ``q0 = (1 − σ²)/(1 + σ²)``, ``q_v = 2σ/(1 + σ²)``."""
    s = _as_float(sigma)
    s2 = np.sum(s * s, axis=-1, keepdims=True)
    return np.concatenate([(1.0 - s2) / (1.0 + s2), 2.0 * s / (1.0 + s2)], axis=-1)


def mrp_to_dcm(sigma) -> np.ndarray:
    """Rotation matrix of an MRP, ``R(σ) = R(q(σ))``."""
    return quat_to_dcm(mrp_to_quat(sigma))


def dcm_to_mrp(C, *, eps: float = 1e-2) -> np.ndarray:
    """MRP with ``|σ| ≤ 1`` of a rotation matrix, eqs 6–7 of Maestrini et al.

    In lcnav's convention (``R(σ) = C``) eq. 6 reads
    ``[σ×] = (C − Cᵀ) / (ζ (ζ + 2))`` with ``ζ = √(Tr C + 1)``. The converted
    text of Maestrini et al. prints ``ζ(ζ + 1)`` in the denominator; substituting the
    quaternion form of ``C`` (``Tr C + 1 = 4 q0²``, ``C − Cᵀ = 4 q0 [q_v×]``)
    shows that ``ζ(ζ + 2) = 4 q0 (1 + q0)`` is the one that gives
    ``σ = q_v/(1 + q0)`` (checked in ``tests/estimators/test_attitude.py``).
    The paper's ``C_TI`` is the passive DCM (Schaub's ``[BN]``); its ``σ_T``
    is ``dcm_to_mrp(C_TI.T)`` here.

    Near 180° (``ζ < eps``) numerator and denominator both vanish and eq. 7 is
    used: ``σ σᵀ = ½ (I + C)`` gives ``|σ_i|`` on the diagonal and the signs
    from the largest component's row; the antisymmetric part picks between
    ``±σ`` (both are valid MRPs at exactly 180°). Subtracting ``q0² I`` (known
    from the trace) makes the eq. 7 branch exact slightly off 180° too.
    """
    C = _as_float(C)
    shape = C.shape[:-2]
    Cf = C.reshape(-1, 3, 3)
    out = np.empty((Cf.shape[0], 3))
    tr = np.trace(Cf, axis1=-2, axis2=-1)
    zeta = np.sqrt(np.clip(tr + 1.0, 0.0, None))
    anti = Cf - np.swapaxes(Cf, -1, -2)
    vee = np.stack([anti[:, 2, 1], anti[:, 0, 2], anti[:, 1, 0]], axis=-1)  # 4 q0 q_v
    regular = zeta >= eps
    if np.any(regular):
        z = zeta[regular]
        out[regular] = vee[regular] / (z * (z + 2.0))[:, None]  # eq. 6
    for i in np.flatnonzero(~regular):
        # q0 from the antisymmetric part (|C − Cᵀ| = 4 q0 |q_v|, |q_v| ≈ 1 here) is
        # linear in round-off, where √(Tr C + 1) would amplify it to √eps.
        q0 = np.linalg.norm(vee[i]) / (4.0 * np.sqrt(max(1.0 - 0.25 * zeta[i] ** 2, 0.5)))
        # eq. 7 on the symmetric part; ½(I + sym C) = q0² I + q_v q_vᵀ, so removing
        # q0² I makes it exact (not only at 180°) near the singularity.
        M = 0.5 * (np.eye(3) + 0.5 * (Cf[i] + Cf[i].T)) - q0 * q0 * np.eye(3)
        j = int(np.argmax(np.diag(M)))
        qv = M[j] / np.sqrt(max(M[j, j], 1e-300))
        if np.dot(qv, vee[i]) < 0.0:
            qv = -qv
        out[i] = qv / (1.0 + q0)
    return out.reshape(shape + (3,))


def mrp_shadow(sigma) -> np.ndarray:
    """Shadow MRP ``σ^S = −σ / |σ|²`` (eq. 31 of Maestrini et al.); same rotation."""
    s = _as_float(sigma)
    s2 = np.sum(s * s, axis=-1, keepdims=True)
    if np.any(s2 == 0.0):
        raise ValueError("the shadow set of the zero MRP is at infinity")
    return -s / s2


def mrp_shadow_jacobian(sigma) -> np.ndarray:
    """Jacobian ``T = ∂σ^S/∂σ = 2 σσᵀ/|σ|⁴ − I/|σ|²`` (eq. 32 of Maestrini et al.).

    The converted paper prints ``2/|σ|⁴ − 4σσᵀ − I/|σ|²``; differentiating
    eq. 31 gives the form here, which a finite-difference test checks.
    """
    s = _as_float(sigma)
    s2 = np.sum(s * s, axis=-1)[..., None, None]
    outer = s[..., :, None] * s[..., None, :]
    return 2.0 * outer / s2**2 - np.eye(3) / s2


def mrp_shadow_covariance(sigma, P, n_mrp: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Switch ``σ`` to its shadow set and transform ``P`` (eqs 31–32 of Maestrini et al.).

    ``P`` is the full state covariance; the MRP occupies rows/columns
    ``n_mrp : n_mrp + 3``, every other block is carried by the identity.
    Returns ``(σ^S, P^S)``.
    """
    s = _as_float(sigma)
    P = _as_float(P)
    n = P.shape[-1]
    T = np.eye(n)
    T[n_mrp : n_mrp + 3, n_mrp : n_mrp + 3] = mrp_shadow_jacobian(s)
    return mrp_shadow(s), T @ P @ T.T


def kinematics_matrix(q) -> np.ndarray:
    """``Q(q)`` of eq. 3 of Renis et al., shape ``(..., 4, 3)``: ``Q(q) ω = q ⊗ [0, ω]``."""
    q = _as_float(q)
    q0, q1, q2, q3 = (q[..., i] for i in range(4))
    return np.stack(
        [
            np.stack([-q1, -q2, -q3], axis=-1),
            np.stack([q0, -q3, q2], axis=-1),
            np.stack([q3, q0, -q1], axis=-1),
            np.stack([-q2, q1, q0], axis=-1),
        ],
        axis=-2,
    )


def quat_derivative(q, w_B) -> np.ndarray:
    """``q̇_AB = ½ Q(q_AB) ω_B`` (eq. 2 of Renis et al. in DESIGN.md's convention)."""
    return 0.5 * np.einsum("...ij,...j->...i", kinematics_matrix(q), _as_float(w_B))


def mrp_derivative(sigma, w_B) -> np.ndarray:
    """``σ̇ = ¼ [(1 − σ²) I + 2[σ×] + 2σσᵀ] ω_B`` (eq. 28 of Maestrini et al.)."""
    s = _as_float(sigma)
    w = _as_float(w_B)
    s2 = np.sum(s * s, axis=-1, keepdims=True)
    return 0.25 * ((1.0 - s2) * w + 2.0 * np.cross(s, w) + 2.0 * s * np.sum(s * w, axis=-1, keepdims=True))


def rotvec_to_quat(rotvec) -> np.ndarray:
    """Quaternion ``[cos(α/2), r sin(α/2)]`` of a rotation vector ``α r`` (eq. 34 of Renis et al.)."""
    v = _as_float(rotvec)
    angle = np.linalg.norm(v, axis=-1, keepdims=True)
    half = 0.5 * angle
    # sin(α/2)/α → 1/2 as α → 0; the series keeps full precision near zero.
    small = angle < 1e-8
    k = np.where(small, 0.5 - angle**2 / 48.0, np.sin(half) / np.where(small, 1.0, angle))
    return np.concatenate([np.cos(half), k * v], axis=-1)


def quat_to_rotvec(q) -> np.ndarray:
    """Rotation vector (angle ≤ π) of a unit quaternion."""
    q = _canonical(_as_float(q))
    vn = np.linalg.norm(q[..., 1:], axis=-1, keepdims=True)
    angle = 2.0 * np.arctan2(vn, q[..., :1])
    small = vn < 1e-12
    k = np.where(small, 2.0, angle / np.where(small, 1.0, vn))
    return k * q[..., 1:]


def attitude_angle(q_a, q_b) -> np.ndarray:
    """Principal angle (rad, in [0, π]) of the rotation between two attitudes.

    ``2 atan2(|v|, |s|)`` of ``q_a* ⊗ q_b``: well conditioned at 0 and π alike.
    """
    dq = quat_multiply(quat_conjugate(q_a), q_b)
    return 2.0 * np.arctan2(np.linalg.norm(dq[..., 1:], axis=-1), np.abs(dq[..., 0]))


def dcm_angle(C_a, C_b) -> np.ndarray:
    """Principal angle between two rotation matrices, ``arccos((Tr(C_b C_aᵀ) − 1)/2)``.

    This is eq. 33 of Maestrini et al. as it should read (the converted text has the
    ½ in the wrong place). Clipped to ``[-1, 1]`` against round-off.
    """
    M = _as_float(C_b) @ np.swapaxes(_as_float(C_a), -1, -2)
    c = 0.5 * (np.trace(M, axis1=-2, axis2=-1) - 1.0)
    return np.arccos(np.clip(c, -1.0, 1.0))


def random_quaternion(rng: np.random.Generator, size: int | tuple | None = None) -> np.ndarray:
    """Uniformly distributed unit quaternions (Shoemake), ``q0 ≥ 0``."""
    shape = () if size is None else (size if isinstance(size, tuple) else (size,))
    q = rng.normal(size=shape + (4,))
    return _canonical(q / np.linalg.norm(q, axis=-1, keepdims=True))
