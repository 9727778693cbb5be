"""The 14-dimensional error state shared by the EKF and the UKF.

The state of eq. 17 of ``002_…`` has 15 numbers,
``x = [q_TS, ω_ST_T, r_ST_T, v_ST_T, k1, k2]``, but only 14 degrees of
freedom: the quaternion has unit norm. Both filters therefore keep their
covariance ``P`` over the *error state* (14)

``δx = [δp, δω_ST_T, δr_ST_T, δv_ST_T, δk1, δk2]``

where the attitude error is ``δq = q_TS ⊗ q̂_TS⁻¹`` (expressed in T, the form
of eq. 29 of ``002_…``) written as the generalised Rodrigues parameters of
Crassidis & Markley (2003, eq. 33) with ``a = 1, f = 2(a + 1) = 4``, i.e.
four times the MRP: ``δp = 4 δq_v / (1 + δq0)``. For small errors ``δp`` equals
the rotation vector to third order, so the attitude block of ``P`` is in rad²
for both filters and NEES/NIS have 14/3 degrees of freedom, not a singular
quaternion direction. Everything else is additive.

``boxplus`` (``x ⊞ δx``) and ``boxminus`` (``x ⊟ x_ref``) are vectorised over
leading dimensions, so the UKF applies them to all sigma points at once.
"""

from __future__ import annotations

import numpy as np

from estimators.attitude import mrp_to_quat, quat_conjugate, quat_multiply, quat_normalize, quat_to_mrp

N_STATE = 15
N_ERROR = 14
#: GRP scale ``f`` with ``a = 1`` (Crassidis & Markley 2003, eq. 33): ``δp = f · MRP``.
GRP_F = 4.0

#: Slices of the error state per component group.
ERROR_SLICES = {
    "q": slice(0, 3),
    "w": slice(3, 6),
    "r": slice(6, 9),
    "v": slice(9, 12),
    "k": slice(12, 14),
}


def attitude_error(q, q_ref) -> np.ndarray:
    """``δp`` (≈ rotation vector, rad) of ``δq = q ⊗ q_ref⁻¹``; ``|δp| ≤ 4`` (angle ≤ π)."""
    return GRP_F * quat_to_mrp(quat_multiply(q, quat_conjugate(q_ref)))


def apply_attitude_error(dp, q_ref) -> np.ndarray:
    """``q = δq(δp) ⊗ q_ref``, normalised (eq. 28 of ``002_…``)."""
    return quat_normalize(quat_multiply(mrp_to_quat(np.asarray(dp, dtype=float) / GRP_F), q_ref))


def boxplus(x, dx) -> np.ndarray:
    """``x ⊞ δx``: ``(..., 15)`` state and ``(..., 14)`` error → ``(..., 15)`` state."""
    x = np.asarray(x, dtype=float)
    dx = np.asarray(dx, dtype=float)
    q = apply_attitude_error(dx[..., 0:3], x[..., 0:4])
    rest = x[..., 4:] + dx[..., 3:]
    return np.concatenate([np.broadcast_to(q, rest.shape[:-1] + (4,)), rest], axis=-1)


def boxminus(x, x_ref) -> np.ndarray:
    """``x ⊟ x_ref``: the error state ``(..., 14)`` that takes ``x_ref`` to ``x``."""
    x = np.asarray(x, dtype=float)
    x_ref = np.asarray(x_ref, dtype=float)
    dp = attitude_error(x[..., 0:4], x_ref[..., 0:4])
    rest = x[..., 4:] - x_ref[..., 4:]
    return np.concatenate([np.broadcast_to(dp, rest.shape[:-1] + (3,)), rest], axis=-1)


def attitude_chart_jacobians(q) -> tuple[np.ndarray, np.ndarray]:
    """``(∂q/∂δp, ∂δp/∂q)`` at ``δp = 0`` about the unit quaternion ``q`` (4×3, 3×4).

    ``δq ⊗ q ≈ q + ½ [0, δp] ⊗ q = q + ½ Ξ(q) δp`` with
    ``Ξ(q) = [−q_vᵀ; q0 I − [q_v×]]``; inversely ``δp ≈ 2 vec(q' ⊗ q⁻¹) = 2 Ξ(q)ᵀ q'``
    (``Ξᵀ q = 0`` and ``Ξᵀ Ξ = I`` for a unit ``q``).
    """
    q = np.asarray(q, dtype=float)
    q0, qv = q[0], q[1:]
    Xi = np.empty((4, 3))
    Xi[0] = -qv
    Xi[1:] = q0 * np.eye(3) - np.array([[0.0, -qv[2], qv[1]], [qv[2], 0.0, -qv[0]], [-qv[1], qv[0], 0.0]])
    return 0.5 * Xi, 2.0 * Xi.T


def state_to_error_jacobians(x_in, x_out) -> tuple[np.ndarray, np.ndarray]:
    """``G_in = ∂x/∂δx`` (15×14) at ``x_in`` and ``G_out = ∂δx/∂x`` (14×15) at ``x_out``.

    A Jacobian ``Φ`` of the 15-state map turns into the error-state one as
    ``F = G_out Φ G_in``.
    """
    G_in = np.zeros((N_STATE, N_ERROR))
    G_out = np.zeros((N_ERROR, N_STATE))
    G_in[0:4, 0:3] = attitude_chart_jacobians(x_in[0:4])[0]
    G_out[0:3, 0:4] = attitude_chart_jacobians(x_out[0:4])[1]
    G_in[4:, 3:] = np.eye(11)
    G_out[3:, 4:] = np.eye(11)
    return G_in, G_out
