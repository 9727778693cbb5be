"""The 14-dimensional error state shared by the EKF and the UKF.

The state of eq. 17 of Renis et al. has 15 numbers,
``x = [q_TS, ω_ST_T, r_ST_T, v_ST_T, k1, k2]``, but only 14 degrees of
freedom: the quaternion has unit norm. Both filters therefore keep their
covariance ``P`` over the *error state* (14)

``δx = [δp, δω_ST_T, δr_ST_T, δv_ST_T, δk1, δk2]``

where the attitude error is ``δq = q_TS ⊗ q̂_TS⁻¹`` (expressed in T, the form
of eq. 29 of Renis et al.) written as the generalised Rodrigues parameters of
Crassidis & Markley (2003, eq. 33) with ``a = 1, f = 2(a + 1) = 4``, i.e.
four times the MRP: ``δp = 4 δq_v / (1 + δq0)``. For small errors ``δp`` equals
the rotation vector to third order, so the attitude block of ``P`` is in rad²
for both filters and NEES/NIS have 14/3 degrees of freedom, not a singular
quaternion direction. Everything else is additive.

``boxplus`` (``x ⊞ δx``) and ``boxminus`` (``x ⊟ x_ref``) are vectorised over
leading dimensions, so the UKF applies them to all sigma points at once.
"""

from __future__ import annotations

import numba
import numpy as np

from estimators.state import DTHETA, DX_ADDITIVE, N_ADDITIVE, N_ERROR, N_STATE, Q_TS, X_ADDITIVE

#: GRP scale ``f`` with ``a = 1`` (Crassidis & Markley 2003, eq. 33): ``δp = f · MRP``.
GRP_F = 4.0


def _as_rows(a: np.ndarray, lead: tuple) -> np.ndarray:
    """``a (..., n)`` broadcast to ``lead + (n,)`` and flattened to ``(N, n)`` rows."""
    if a.shape[:-1] != lead:
        a = np.broadcast_to(a, lead + a.shape[-1:])
    return a.reshape(-1, a.shape[-1])


def _paired_rows(a: np.ndarray, b: np.ndarray) -> tuple[tuple, np.ndarray, np.ndarray]:
    """``(lead, a_rows, b_rows)`` for the kernels below: the leading shape of ``a`` and ``b`` broadcast together,
    ``a`` as ``(N, n)`` rows, ``b`` as ``(N, m)`` rows or, when it is a single vector, one row (reused for all).

    The common cases (same leading shape, or ``b`` a single vector) skip
    ``np.broadcast_shapes``, which alone costs as much as a kernel call.
    """
    if b.ndim == 1 or a.shape[:-1] == b.shape[:-1]:
        lead = a.shape[:-1]
    else:
        lead = np.broadcast_shapes(a.shape[:-1], b.shape[:-1])
    return lead, _as_rows(a, lead), (b[None, :] if b.ndim == 1 else _as_rows(b, lead))


# The two charts below are compiled: on one quaternion the composition of the
# vectorised attitude.py functions costs ~25 µs (numpy's per-call overhead on
# 4-vectors), these kernels with their wrappers ~2.5 µs. They perform the same operations in the same
# order as quat_multiply/quat_conjugate/quat_to_mrp and mrp_to_quat/
# quat_multiply/quat_normalize, so their results are bit-identical.


@numba.njit(cache=True)
def _attitude_error_rows(q, q_ref):
    """``δp = f σ(q ⊗ q_ref⁻¹)`` per row: ``q`` (N, 4), ``q_ref`` (N, 4) or (1, 4) (one for all rows).

    ``δq = q ⊗ q_ref*`` (Hamilton product with the conjugate written out),
    then the MRP ``σ = δq_v / (1 + δq0)`` of the sign with ``δq0 ≥ 0`` (so
    ``|σ| ≤ 1``) scaled by ``f = GRP_F`` (eq. 33 of Crassidis & Markley 2003, ``a = 1``).
    """
    out = np.empty((q.shape[0], 3))
    for i in range(q.shape[0]):
        a = q[i]
        r = q_ref[i if q_ref.shape[0] > 1 else 0]
        d0 = a[0] * r[0] + a[1] * r[1] + a[2] * r[2] + a[3] * r[3]
        d1 = -a[0] * r[1] + a[1] * r[0] - a[2] * r[3] + a[3] * r[2]
        d2 = -a[0] * r[2] + a[1] * r[3] + a[2] * r[0] - a[3] * r[1]
        d3 = -a[0] * r[3] - a[1] * r[2] + a[2] * r[1] + a[3] * r[0]
        if d0 < 0.0:
            d0, d1, d2, d3 = -d0, -d1, -d2, -d3
        out[i, 0] = GRP_F * (d1 / (1.0 + d0))
        out[i, 1] = GRP_F * (d2 / (1.0 + d0))
        out[i, 2] = GRP_F * (d3 / (1.0 + d0))
    return out


@numba.njit(cache=True)
def _apply_attitude_error_rows(dp, q_ref):
    """``q = δq(δp) ⊗ q_ref / |…|`` per row (eq. 28 of Renis et al.): ``dp`` (N, 3), ``q_ref`` (N, 4) or (1, 4).

    ``δq`` is the unit quaternion of the MRP ``σ = δp / f``:
    ``δq0 = (1 − σ²)/(1 + σ²)``, ``δq_v = 2σ/(1 + σ²)``.
    """
    out = np.empty((dp.shape[0], 4))
    for i in range(dp.shape[0]):
        r = q_ref[i if q_ref.shape[0] > 1 else 0]
        s1, s2, s3 = dp[i, 0] / GRP_F, dp[i, 1] / GRP_F, dp[i, 2] / GRP_F
        ss = s1 * s1 + s2 * s2 + s3 * s3
        p0, p1, p2, p3 = (1.0 - ss) / (1.0 + ss), 2.0 * s1 / (1.0 + ss), 2.0 * s2 / (1.0 + ss), 2.0 * s3 / (1.0 + ss)
        q0 = p0 * r[0] - p1 * r[1] - p2 * r[2] - p3 * r[3]
        q1 = p0 * r[1] + p1 * r[0] + p2 * r[3] - p3 * r[2]
        q2 = p0 * r[2] - p1 * r[3] + p2 * r[0] + p3 * r[1]
        q3 = p0 * r[3] + p1 * r[2] - p2 * r[1] + p3 * r[0]
        n = np.sqrt(q0 * q0 + q1 * q1 + q2 * q2 + q3 * q3)
        if not (np.isfinite(n) and n != 0.0):
            raise ValueError("quaternion must be finite and non-zero to normalise")
        out[i, 0], out[i, 1], out[i, 2], out[i, 3] = q0 / n, q1 / n, q2 / n, q3 / n
    return out


def attitude_error(q, q_ref) -> np.ndarray:
    """``δp`` (≈ rotation vector, rad) of ``δq = q ⊗ q_ref⁻¹``; ``|δp| ≤ 4`` (angle ≤ π)."""
    lead, q, q_ref = _paired_rows(np.asarray(q, dtype=float), np.asarray(q_ref, dtype=float))
    return _attitude_error_rows(q, q_ref).reshape(lead + (3,))


def apply_attitude_error(dp, q_ref) -> np.ndarray:
    """``q = δq(δp) ⊗ q_ref``, normalised (eq. 28 of Renis et al.)."""
    lead, dp, q_ref = _paired_rows(np.asarray(dp, dtype=float), np.asarray(q_ref, dtype=float))
    return _apply_attitude_error_rows(dp, q_ref).reshape(lead + (4,))


def boxplus(x, dx) -> np.ndarray:
    """``x ⊞ δx``: ``(..., 15)`` state and ``(..., 14)`` error → ``(..., 15)`` state."""
    x = np.asarray(x, dtype=float)
    dx = np.asarray(dx, dtype=float)
    rest = x[..., X_ADDITIVE] + dx[..., DX_ADDITIVE]
    out = np.empty(rest.shape[:-1] + (N_STATE,))
    out[..., Q_TS] = apply_attitude_error(dx[..., DTHETA], x[..., Q_TS])
    out[..., X_ADDITIVE] = rest
    return out


def boxminus(x, x_ref) -> np.ndarray:
    """``x ⊟ x_ref``: the error state ``(..., 14)`` that takes ``x_ref`` to ``x``."""
    x = np.asarray(x, dtype=float)
    x_ref = np.asarray(x_ref, dtype=float)
    rest = x[..., X_ADDITIVE] - x_ref[..., X_ADDITIVE]
    out = np.empty(rest.shape[:-1] + (N_ERROR,))
    out[..., DTHETA] = attitude_error(x[..., Q_TS], x_ref[..., Q_TS])
    out[..., DX_ADDITIVE] = rest
    return out


@numba.njit(cache=True)
def attitude_chart_jacobians(q):
    """``(∂q/∂δp, ∂δp/∂q)`` at ``δp = 0`` about the unit quaternion ``q`` (4×3, 3×4).

    ``δq ⊗ q ≈ q + ½ [0, δp] ⊗ q = q + ½ Ξ(q) δp`` with
    ``Ξ(q) = [−q_vᵀ; q0 I − [q_v×]]``; inversely ``δp ≈ 2 vec(q' ⊗ q⁻¹) = 2 Ξ(q)ᵀ q'``
    (``Ξᵀ q = 0`` and ``Ξᵀ Ξ = I`` for a unit ``q``).
    """
    q0, q1, q2, q3 = q[0], q[1], q[2], q[3]
    Xi = np.array(((-q1, -q2, -q3), (q0, q3, -q2), (-q3, q0, q1), (q2, -q1, q0)))
    return 0.5 * Xi, 2.0 * Xi.T


@numba.njit(cache=True)
def state_to_error_jacobians(x_in, x_out):
    """``G_in = ∂x/∂δx`` (15×14) at ``x_in`` and ``G_out = ∂δx/∂x`` (14×15) at ``x_out``.

    A Jacobian ``Φ`` of the 15-state map turns into the error-state one as
    ``F = G_out Φ G_in``.
    """
    G_in = np.zeros((N_STATE, N_ERROR))
    G_out = np.zeros((N_ERROR, N_STATE))
    G_in[Q_TS, DTHETA] = attitude_chart_jacobians(x_in[Q_TS])[0]
    G_out[DTHETA, Q_TS] = attitude_chart_jacobians(x_out[Q_TS])[1]
    G_in[X_ADDITIVE, DX_ADDITIVE] = np.eye(N_ADDITIVE)
    G_out[DX_ADDITIVE, X_ADDITIVE] = np.eye(N_ADDITIVE)
    return G_in, G_out
