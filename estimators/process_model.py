"""The filters' process model: eq. 21 of Renis et al. over one sampling time, with its Jacobian.

``f`` is the RK4 (``ode4``) of the relative dynamics over ``τ_s`` with the
servicer's absolute state from its AODS (``s = [r_S_I, v_S_I, q_IS, ω_S_S]``
at the step start) propagated alongside (:mod:`estimators.dynamics`), the
quaternion normalised at the end.

The EKF's ``F_k = ∂f/∂x`` (eq. 25) is analytic: the continuous Jacobian
``A = ∂ẋ/∂x`` of eq. 21 (derived in :func:`_jac`) is integrated with the
same RK4 as the state, ``Φ̇ = A Φ`` evaluated at the RK4 stages. Runge–Kutta
methods commute with linearisation, so this ``Φ`` is the *exact* Jacobian of
the discrete map ``f`` (not an approximation of the continuous one), which is
what the central-difference test in ``tests/estimators/test_process_model.py``
checks to 1e-6. ``Φ`` (15×15) is then mapped to the 14 error states
(:mod:`estimators.error_state`): ``F = G_out Φ G_in``. The Jacobian is taken
in the 15 states first because eq. 21 is written in them; the error-state
form is what the filter needs (a 15×15 ``P`` would be singular along the
quaternion's norm).

Compiled with numba like the dynamics it differentiates (a 15×15 Jacobian
assembled from 3-vectors four times per step: numpy's per-call overhead would
dominate).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numba
import numpy as np

from estimators.dynamics import (
    MU_EARTH,
    _rk4_joint,
    cross3,
    euler_rate,
    get3,
    gravity_gradient_rate,
    get4,
    joint_rhs,
    mat_t_vec,
    mat_vec,
    propagate_relative,
    propagate_relative_batch,
    quat_to_dcm_nb,
    rk4_joint_step,
)
from estimators.error_state import boxminus, boxplus, state_to_error_jacobians
from estimators.state import JOINT_S, JOINT_X, K, N_ABSOLUTE, N_ERROR, N_STATE, Q_IB, Q_TS, R_I, R_ST_T, V_ST_T, W_B, W_ST_T


#: The identity as nested tuples, for the compiled Jacobian (tuples: see estimators.dynamics).
_EYE3 = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))
_ZERO33 = ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0))
_ZERO32 = ((0.0, 0.0), (0.0, 0.0), (0.0, 0.0))


@numba.njit(cache=True)
def _skew(u):
    """``[u×]`` as nested tuples (rows)."""
    return ((0.0, -u[2], u[1]), (u[2], 0.0, -u[0]), (-u[1], u[0], 0.0))


@numba.njit(cache=True)
def _mm(a, b, i, j):
    """``(a @ b)[i, j]`` of a 3-column ``a`` and a 3-row ``b`` (nested tuples, by rows), summed over the columns in turn."""
    return a[i][0] * b[0][j] + a[i][1] * b[1][j] + a[i][2] * b[2][j]


@numba.njit(cache=True)
def _dRu(q, u):
    """``∂(R(q) u)/∂q`` (3×4, nested tuples) for ``R(q) = (q0² − |q_v|²) I + 2 q_v q_vᵀ + 2 q0 [q_v×]``."""
    qv = (q[1], q[2], q[3])
    c = cross3(qv, u)
    d = qv[0] * u[0] + qv[1] * u[1] + qv[2] * u[2]
    S = _skew(u)
    return (_dRu_row(q[0], qv, u, c, d, S, 0), _dRu_row(q[0], qv, u, c, d, S, 1), _dRu_row(q[0], qv, u, c, d, S, 2))


@numba.njit(cache=True)
def _dRu_row(q0, qv, u, c, d, S, i):
    """Row ``i`` of :func:`_dRu` (``c = q_v × u``, ``d = q_v · u``, ``S = [u×]``)."""
    return (
        2.0 * (q0 * u[i] + c[i]),
        2.0 * ((d if i == 0 else 0.0) + qv[i] * u[0] - u[i] * qv[0] - q0 * S[i][0]),
        2.0 * ((d if i == 1 else 0.0) + qv[i] * u[1] - u[i] * qv[1] - q0 * S[i][1]),
        2.0 * ((d if i == 2 else 0.0) + qv[i] * u[2] - u[i] * qv[2] - q0 * S[i][2]),
    )


@numba.njit(cache=True, error_model="numpy")
def _gravity_gradient_row(mu, y, rt, i):
    """Row ``i`` of ``∂(μ y/|y|³)/∂y = μ (I/|y|³ − 3 y yᵀ/|y|⁵)`` (``rt = |y|``)."""
    return (
        mu * (_EYE3[i][0] / rt**3 - 3.0 * (y[i] * y[0]) / rt**5),
        mu * (_EYE3[i][1] / rt**3 - 3.0 * (y[i] * y[1]) / rt**5),
        mu * (_EYE3[i][2] / rt**3 - 3.0 * (y[i] * y[2]) / rt**5),
    )


@numba.njit(cache=True)
def _transport_row(v, r, w_T, E, i):
    """Row ``i`` of ``M = ∂a/∂ω_T`` (the path through ``ω̇_T = E ω_T`` included): ``2[v×] + [r×]E − (ω_T·r) I − ω_T rᵀ + 2 r ω_Tᵀ``."""
    Sv, Sr = _skew(v), _skew(r)
    wr = w_T[0] * r[0] + w_T[1] * r[1] + w_T[2] * r[2]
    return (
        2.0 * Sv[i][0] + _mm(Sr, E, i, 0) - wr * _EYE3[i][0] - w_T[i] * r[0] + 2.0 * (r[i] * w_T[0]),
        2.0 * Sv[i][1] + _mm(Sr, E, i, 1) - wr * _EYE3[i][1] - w_T[i] * r[1] + 2.0 * (r[i] * w_T[1]),
        2.0 * Sv[i][2] + _mm(Sr, E, i, 2) - wr * _EYE3[i][2] - w_T[i] * r[2] + 2.0 * (r[i] * w_T[2]),
    )


# error_model="numpy": a state far from any physical one (a fit's profile probe pushed ``k`` to 913, where e^-k2
# underflows to 0) gives inf/NaN, which the callers test for, instead of a ZeroDivisionError escaping the filter
@numba.njit(cache=True, error_model="numpy")
def _jac(z, J_S, mu, gg):
    """``A = ∂ẋ/∂x`` (15×15) of eq. 21 at the joint vector ``z = [x, s]`` (``s`` is exogenous).

    With ``R = R(q_TS)``, ``ω_T = R ω_S − ω``, ``ω̇_T = E(ω_T)`` (Euler, torque-free):

    * ``q̇ = ½ Ω(ω) q``: ``∂/∂q = ½ Ω(ω)``, ``∂/∂ω = ½ [−q_vᵀ; q0 I − [q_v×]]``;
    * ``α = ω × Rω_S + R ω̇_S − ω̇_T``: ``∂/∂ω = −[(Rω_S)×] + ∂E/∂ω_T``,
      ``∂/∂q = [ω×] ∂(Rω_S)/∂q + ∂(Rω̇_S)/∂q − ∂E/∂ω_T ∂(Rω_S)/∂q``,
      ``∂/∂k = −∂E/∂k``;
    * ``a = a_I − 2 ω_T × v − ω̇_T × r − ω_T × (ω_T × r)`` with
      ``a_I = −μ r_S_T/r_S³ + μ r_T_T/|r_T_T|³``, ``r_S_T = R p``, ``r_T_T = R p − r``;
    * with ``gg`` (:func:`estimators.dynamics.joint_rhs`) ``ω̇_T = E(ω_T) + g(r_T_T)``, ``g = −n E(r_T_T)``,
      ``n = 3μ/|r_T_T|⁵``: ``∂g/∂r_T_T = −n E'(r_T_T) + 5n/|r_T_T|² E(r_T_T) r_T_Tᵀ`` (``E'`` the Jacobian of Euler's
      right-hand side, here at ``r_T_T``), ``∂g/∂k = −n ∂E(r_T_T)/∂k``; it enters through ``r_T_T``'s ``∂/∂q = ∂(Rp)/∂q``
      and ``∂/∂r = −I``, into ``α`` (``−g``) and into ``a`` (``r × g``).

    The blocks are filled entry by entry from tuples (:mod:`estimators.dynamics`: with 3×3 arrays and views this
    took 6.3 µs, now 0.2 µs), each entry summed in the order of the matrix product it comes from.
    """
    X, S = JOINT_X.start, JOINT_S.start
    q = get4(z, Q_TS, X)
    w = get3(z, W_ST_T, X)
    r = get3(z, R_ST_T, X)
    v = get3(z, V_ST_T, X)
    e1 = np.exp(z[X + K.start])
    em2 = np.exp(-z[X + K.start + 1])
    JT = (e1, 1.0, em2)
    r_SI = get3(z, R_I, S)
    w_S = get3(z, W_B, S)
    R = quat_to_dcm_nb(q)
    R_IS = quat_to_dcm_nb(get4(z, Q_IB, S))
    dw_S = euler_rate(w_S, J_S)
    w_S_T = mat_vec(R, w_S)
    w_T = (w_S_T[0] - w[0], w_S_T[1] - w[1], w_S_T[2] - w[2])
    dw_T = euler_rate(w_T, JT)
    # Euler: ω̇0 = c0 ω1 ω2, ω̇1 = c1 ω2 ω0, ω̇2 = c2 ω0 ω1 with J = diag(e^k1, 1, e^-k2)
    c0 = (1.0 - em2) / e1
    c1 = em2 - e1
    c2 = (e1 - 1.0) / em2
    E = ((0.0, c0 * w_T[2], c0 * w_T[1]), (c1 * w_T[2], 0.0, c1 * w_T[0]), (c2 * w_T[1], c2 * w_T[0], 0.0))
    Dk = _euler_k_jacobian(w_T, e1, em2, c0, c2)
    # translation geometry (eqs 8-15) and, with gg, the gravity-gradient rate g(r_T_T) and its Jacobians
    p = mat_t_vec(R_IS, r_SI)
    r_S_T = mat_vec(R, p)
    r_T_T = (r_S_T[0] - r[0], r_S_T[1] - r[1], r_S_T[2] - r[2])
    dRp = _dRu(q, p)
    dg_dr, dg_dk = _ZERO33, _ZERO32
    if gg != 0.0:
        g = gravity_gradient_rate(r_T_T, JT, mu)
        dw_T = (dw_T[0] + gg * g[0], dw_T[1] + gg * g[1], dw_T[2] + gg * g[2])
        dg_dr, dg_dk = _gravity_gradient_jacobians(r_T_T, JT, mu, gg, c0, c1, c2, e1, em2)

    A = np.zeros((N_STATE, N_STATE))
    iq, iw, ir, iv, ik = Q_TS.start, W_ST_T.start, R_ST_T.start, V_ST_T.start, K.start
    # quaternion kinematics: q̇ = ½ [0, ω] ⊗ q; rows/columns iq and iq + 1…3 are q_TS's scalar and vector parts
    Sw, Sq = _skew(w), _skew((q[1], q[2], q[3]))
    for i in range(3):
        A[iq, iq + 1 + i] = -0.5 * w[i]
        A[iq + 1 + i, iq] = 0.5 * w[i]
        A[iq, iw + i] = -0.5 * q[1 + i]
        for j in range(3):
            A[iq + 1 + i, iq + 1 + j] = 0.5 * Sw[i][j]
            A[iq + 1 + i, iw + j] = 0.5 * (q[0] * _EYE3[i][j] - Sq[i][j])

    # relative angular acceleration (eq. 7); with gg, ω̇_T's gravity-gradient part g(r_T_T): −∂g/∂r_T_T ∂r_T_T/∂(q, r), −∂g/∂k
    dRwS = _dRu(q, w_S)
    dRdwS = _dRu(q, dw_S)
    Sst = _skew(w_S_T)
    for i in range(3):
        for j in range(4):
            A[iw + i, iq + j] = _mm(Sw, dRwS, i, j) + dRdwS[i][j] - _mm(E, dRwS, i, j) - _mm(dg_dr, dRp, i, j)
        for j in range(3):
            A[iw + i, iw + j] = -Sst[i][j] + E[i][j]
            A[iw + i, ir + j] = dg_dr[i][j]
        for j in range(2):
            A[iw + i, ik + j] = -Dk[i][j] - dg_dk[i][j]

    # translation (eqs 8-15); r × ω̇_T carries g's Jacobians as [r×] ∂g
    rs = np.sqrt(r_SI[0] ** 2 + r_SI[1] ** 2 + r_SI[2] ** 2)
    rt = np.sqrt(r_T_T[0] ** 2 + r_T_T[1] ** 2 + r_T_T[2] ** 2)
    G = (_gravity_gradient_row(mu, r_T_T, rt, 0), _gravity_gradient_row(mu, r_T_T, rt, 1), _gravity_gradient_row(mu, r_T_T, rt, 2))
    M = (_transport_row(v, r, w_T, E, 0), _transport_row(v, r, w_T, E, 1), _transport_row(v, r, w_T, E, 2))
    Sr, Sdw, SwT = _skew(r), _skew(dw_T), _skew(w_T)
    for i in range(3):
        A[ir + i, iv + i] = 1.0
        for j in range(4):
            A[iv + i, iq + j] = (-mu / rs**3) * dRp[i][j] + _mm(G, dRp, i, j) + _mm(M, dRwS, i, j) + _mm3(Sr, dg_dr, dRp, i, j)
        for j in range(3):
            A[iv + i, iw + j] = -M[i][j]
            A[iv + i, ir + j] = -G[i][j] - Sdw[i][j] - _mm(SwT, SwT, i, j) - _mm(Sr, dg_dr, i, j)
            A[iv + i, iv + j] = -2.0 * SwT[i][j]
        for j in range(2):
            A[iv + i, ik + j] = _mm(Sr, Dk, i, j) + _mm(Sr, dg_dk, i, j)
    return A


@numba.njit(cache=True, error_model="numpy")
def _euler_k_jacobian(u, e1, em2, c0, c2):
    """``∂E(u)/∂(k1, k2)`` (3×2, rows) of Euler's right-hand side ``E(u) = (c0 u1 u2, c1 u2 u0, c2 u0 u1)`` in ``J = diag(e^k1, 1, e^-k2)``."""
    p01 = u[1] * u[2]
    p20 = u[2] * u[0]
    p01b = u[0] * u[1]
    return ((-c0 * p01, em2 / e1 * p01), (-e1 * p20, -em2 * p20), (e1 / em2 * p01b, c2 * p01b))


@numba.njit(cache=True, error_model="numpy")
def _gravity_gradient_jacobians(r_T, JT, mu, gg, c0, c1, c2, e1, em2):
    """``(gg ∂g/∂r_T (3×3), gg ∂g/∂k (3×2))`` of ``g = −n E(r_T)``, ``n = 3μ/|r_T|⁵`` (:func:`_jac`'s docstring)."""
    r2 = r_T[0] ** 2 + r_T[1] ** 2 + r_T[2] ** 2
    n = 3.0 * mu / (r2 * r2 * np.sqrt(r2))
    e = euler_rate(r_T, JT)
    Er = ((0.0, c0 * r_T[2], c0 * r_T[1]), (c1 * r_T[2], 0.0, c1 * r_T[0]), (c2 * r_T[1], c2 * r_T[0], 0.0))
    f = 5.0 * n / r2
    dr = ((gg * (f * e[0] * r_T[0] - n * Er[0][0]), gg * (f * e[0] * r_T[1] - n * Er[0][1]), gg * (f * e[0] * r_T[2] - n * Er[0][2])),
          (gg * (f * e[1] * r_T[0] - n * Er[1][0]), gg * (f * e[1] * r_T[1] - n * Er[1][1]), gg * (f * e[1] * r_T[2] - n * Er[1][2])),
          (gg * (f * e[2] * r_T[0] - n * Er[2][0]), gg * (f * e[2] * r_T[1] - n * Er[2][1]), gg * (f * e[2] * r_T[2] - n * Er[2][2])))
    Dk = _euler_k_jacobian(r_T, e1, em2, c0, c2)
    m = -gg * n
    dk = ((m * Dk[0][0], m * Dk[0][1]), (m * Dk[1][0], m * Dk[1][1]), (m * Dk[2][0], m * Dk[2][1]))
    return dr, dk


@numba.njit(cache=True)
def _mm3(a, b, c, i, j):
    """``(a @ b @ c)[i, j]`` of 3×3 ``a``, ``b`` and a 3-row ``c`` (nested tuples, by rows)."""
    return a[i][0] * _mm(b, c, 0, j) + a[i][1] * _mm(b, c, 1, j) + a[i][2] * _mm(b, c, 2, j)


@numba.njit(cache=True)
def _rk4_stm(x0, s0, J_S, mu, gg, dt, n_steps):
    """RK4 of ``[x, s]`` together with ``Φ̇ = A Φ`` at the same stages; returns ``(x, s, Φ)``."""
    z = np.empty(N_STATE + N_ABSOLUTE)
    z[JOINT_X] = x0
    z[JOINT_S] = s0
    Phi = np.eye(N_STATE)
    for _ in range(n_steps):
        k1 = joint_rhs(z, J_S, mu, gg)
        K1 = _jac(z, J_S, mu, gg) @ Phi
        z2 = z + 0.5 * dt * k1
        k2 = joint_rhs(z2, J_S, mu, gg)
        K2 = _jac(z2, J_S, mu, gg) @ (Phi + 0.5 * dt * K1)
        z3 = z + 0.5 * dt * k2
        k3 = joint_rhs(z3, J_S, mu, gg)
        K3 = _jac(z3, J_S, mu, gg) @ (Phi + 0.5 * dt * K2)
        z4 = z + dt * k3
        k4 = joint_rhs(z4, J_S, mu, gg)
        K4 = _jac(z4, J_S, mu, gg) @ (Phi + dt * K3)
        z = z + dt / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
        Phi = Phi + dt / 6.0 * (K1 + 2.0 * K2 + 2.0 * K3 + K4)
    return z[JOINT_X].copy(), z[JOINT_S].copy(), Phi


@numba.njit(cache=True)
def _rk4_error_state(x0, s0, J_S, mu, gg, dt, n_steps):
    """``(f(x0), F)``: :func:`_rk4_stm`, the quaternion normalised (eq. 28), ``F = G_out Φ G_in`` (eq. 25).

    One compiled call for the EKF's prediction of the state and its Jacobian
    (the last two steps cost ~30 µs as numpy calls).
    """
    x1, _, Phi = _rk4_stm(x0, s0, J_S, mu, gg, dt, n_steps)
    return _error_state_step(x0, x1, Phi)


@numba.njit(cache=True)
def _normalize_q_ts(x):
    """``x`` with its quaternion ``q_TS`` normalised in place (eq. 28)."""
    q = x[Q_TS]
    x[Q_TS] = q / np.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    return x


@numba.njit(cache=True)
def _error_state_step(x0, x1, Phi):
    """``(x1, F)``: the quaternion of ``x1`` normalised (eq. 28) and the 15-state ``Φ`` mapped to ``F = G_out Φ G_in`` (eq. 25)."""
    _normalize_q_ts(x1)
    G_in, G_out = state_to_error_jacobians(x0, x1)
    return x1, G_out @ Phi @ G_in


@numba.njit(cache=True)
def _step_coarse_stm(x0, s0, J_S, mu, gg, dt, n_steps):
    """``(f(x0), F)`` like :func:`_rk4_error_state`, with ``Φ`` from RK4 steps twice as long as the state's.

    The state takes the same ``n_steps`` RK4 steps of ``dt`` (the same
    numbers); ``Φ̇ = A Φ`` takes one RK4 step per pair of them, with ``A`` at the
    pair's start, middle and end states. Three Jacobian evaluations per pair
    instead of eight: ~3× less work, at a relative error of ``Φ`` of order
    ``(ω · 2dt)⁵/120`` (3e-8 at 0.05 rad/s and 0.5 s), far below what a
    Gauss–Newton step or a covariance needs. ``n_steps`` must be even.
    """
    z = np.empty(N_STATE + N_ABSOLUTE)
    work = np.empty((5, N_STATE + N_ABSOLUTE))
    z[JOINT_X] = x0
    z[JOINT_S] = s0
    Phi = np.eye(N_STATE)
    A0 = _jac(z, J_S, mu, gg)
    for _pair in range(n_steps // 2):
        rk4_joint_step(z, J_S, mu, gg, dt, work)
        Am = _jac(z, J_S, mu, gg)
        rk4_joint_step(z, J_S, mu, gg, dt, work)
        A1 = _jac(z, J_S, mu, gg)
        h = 2.0 * dt
        K1 = A0 @ Phi
        K2 = Am @ (Phi + 0.5 * h * K1)
        K3 = Am @ (Phi + 0.5 * h * K2)
        K4 = A1 @ (Phi + h * K3)
        Phi = Phi + h / 6.0 * (K1 + 2.0 * K2 + 2.0 * K3 + K4)
        A0 = A1
    return _error_state_step(x0, z[JOINT_X].copy(), Phi)


@numba.njit(cache=True)
def _trajectory_stm(x0, S, J_S, mu, gg, dt, n_steps):
    """States ``X (N+1, 15)`` on the grid, the error-state transitions ``Φ_k (N+1, 14, 14)`` from ``x0`` and the steps' ``F_k (N, 14, 14)``.

    Step ``k`` starts from the servicer's state ``S[k]`` (its AODS), as the
    filters' prediction does; ``Φ_k = F_k ⋯ F_1`` (``Φ_0 = I``) maps an error
    at the first grid time to one at the ``k``-th, each in the chart about the
    trajectory's own state. ``F_k`` from :func:`_step_coarse_stm` when the step
    count is even, else exact (:func:`_rk4_error_state`).
    """
    N = S.shape[0]
    X = np.empty((N + 1, N_STATE))
    Phi = np.empty((N + 1, N_ERROR, N_ERROR))
    F = np.empty((N, N_ERROR, N_ERROR))
    X[0] = x0
    Phi[0] = np.eye(N_ERROR)
    for k in range(N):
        if n_steps % 2 == 0:
            X[k + 1], F[k] = _step_coarse_stm(X[k], S[k], J_S, mu, gg, dt, n_steps)
        else:
            X[k + 1], F[k] = _rk4_error_state(X[k], S[k], J_S, mu, gg, dt, n_steps)
        Phi[k + 1] = F[k] @ Phi[k]
    return X, Phi, F


@numba.njit(cache=True)
def _trajectory_states(x0, S, J_S, mu, gg, dt, n_steps):
    """:func:`_trajectory_stm` without the transitions (the same RK4 stages, so the same states)."""
    N = S.shape[0]
    X = np.empty((N + 1, N_STATE))
    X[0] = x0
    for k in range(N):
        xs, _ = _rk4_joint(X[k], S[k], J_S, mu, gg, dt, n_steps, n_steps)
        X[k + 1] = _normalize_q_ts(xs[-1])
    return X


def relative_jacobian(x, servicer, J_S_diag, mu: float = MU_EARTH, *, gravity_gradient: bool = False) -> np.ndarray:
    """Continuous Jacobian ``∂ẋ/∂x`` (15×15) of eq. 21 (the servicer's state is an input), with the target's
    gravity-gradient torque if ``gravity_gradient`` (:func:`estimators.dynamics.joint_rhs`)."""
    z = np.concatenate([np.asarray(x, dtype=float), np.asarray(servicer, dtype=float)])
    return _jac(z, np.asarray(J_S_diag, dtype=float), float(mu), 1.0 if gravity_gradient else 0.0)


@dataclass(frozen=True)
class RelativeProcessModel:
    """Process model ``f`` of the filters (eq. 22 with eq. 21), on the 14-error-state manifold.

    ``J_S_diag``: the servicer's principal inertia (known to it; any scale).
    ``max_step_s``: longest RK4 step; a sampling time ``τ_s`` is split into
    ``ceil(τ_s / max_step_s)`` equal steps. The paper integrates one ``ode4``
    step per ``τ_s`` (``max_step_s = inf`` here); at ``τ_s = 1`` s in SC1 that
    step's truncation error is 3e-5 m and 3e-6 m/s per step, which a filter
    with a small ``Q_d`` cannot absorb (its NEES grows without bound), while
    0.25 s steps bring it to 1e-7 m (``tests/estimators/test_process_model.py``).
    Even that is too much over an orbit: the error is a steady push on the
    relative orbit, which for a formation along the track reads like a pitch of
    the target frame (:mod:`estimators.process_noise`, eq. 5). Measured (SC3
    torque-free, EKF with ``Q_d = 0`` from a converged start, 20 runs of one
    orbit): the joint NEES/dof rose from 1.1 to 8.8 with 0.25 s steps, to 1.42
    with 0.125 s and 1.34 with 0.0625 s; 0.125 s (16× less truncation error
    than 0.25 s, twice the cost) is the default.
    The control input ``u`` of the filter interface is the servicer's absolute
    state ``s`` (13) at the step start.
    ``gravity_gradient``: the target's gravity-gradient torque in Euler's equations (beyond eq. 21:
    :func:`estimators.dynamics.joint_rhs`): known physics for a target in orbit, given the inertia ratios the filter
    estimates and the servicer's AODS; off, the paper's torque-free target.
    """

    J_S_diag: np.ndarray
    max_step_s: float = 0.125
    mu: float = MU_EARTH
    gravity_gradient: bool = False
    n_state: int = field(default=N_STATE, init=False)
    n_error: int = field(default=N_ERROR, init=False)

    def __post_init__(self):
        J = np.asarray(self.J_S_diag, dtype=float)
        if J.shape != (3,) or not np.all(np.isfinite(J)) or np.any(J <= 0):
            raise ValueError(f"J_S_diag must be three positive principal moments, got {self.J_S_diag!r}")
        if not self.max_step_s > 0:
            raise ValueError(f"max_step_s must be positive, got {self.max_step_s!r}")
        object.__setattr__(self, "J_S_diag", J)
        object.__setattr__(self, "gravity_gradient", bool(self.gravity_gradient))

    @property
    def _gg(self) -> float:
        return 1.0 if self.gravity_gradient else 0.0

    boxplus = staticmethod(boxplus)
    boxminus = staticmethod(boxminus)

    def _steps(self, dt: float) -> tuple[float, int]:
        """``(h, n)``: RK4 step and count covering ``dt``."""
        dt = float(dt)
        if not (math.isfinite(dt) and dt > 0):
            raise ValueError(f"dt must be positive and finite, got {dt!r}")
        n = max(1, math.ceil(dt / self.max_step_s - 1e-9))
        return dt / n, n

    @staticmethod
    def _normalized(x: np.ndarray) -> np.ndarray:
        x = np.array(x, dtype=float)
        x[..., Q_TS] /= np.linalg.norm(x[..., Q_TS], axis=-1, keepdims=True)
        return x

    def propagate(self, x, servicer, dt: float) -> np.ndarray:
        """``x_{k+1} = f(x_k)`` over ``dt`` seconds."""
        h, n = self._steps(dt)
        xs, _ = propagate_relative(x, servicer, self.J_S_diag, h, n, stride=n, mu=self.mu, gravity_gradient=self.gravity_gradient)
        return self._normalized(xs[-1])

    def propagate_batch(self, X, servicer, dt: float) -> np.ndarray:
        """``f`` applied to every row of ``X`` (N, 15) — the UKF's sigma points."""
        h, n = self._steps(dt)
        return self._normalized(propagate_relative_batch(X, servicer, self.J_S_diag, h, n, mu=self.mu, gravity_gradient=self.gravity_gradient))

    def propagate_with_jacobian(self, x, servicer, dt: float) -> tuple[np.ndarray, np.ndarray]:
        """``(f(x), F)`` with ``F = ∂(f(x ⊞ δx) ⊟ f(x))/∂δx`` (14×14) at ``δx = 0`` (eq. 25)."""
        h, n = self._steps(dt)
        return _rk4_error_state(np.asarray(x, dtype=float), np.asarray(servicer, dtype=float), self.J_S_diag, float(self.mu), self._gg, h, n)

    def trajectory(self, x0, servicer, dt: float, *, jacobian: bool = True) -> tuple[np.ndarray, np.ndarray | None, np.ndarray | None]:
        """``f`` applied ``N`` times from ``x0``: the states ``X (N+1, 15)`` and, with ``jacobian``, ``Φ (N+1, 14, 14)`` and ``F (N, 14, 14)``.

        ``servicer (N, 13)``: the servicer's state at the start of each step.
        ``F_k`` is step ``k``'s error-state Jacobian and ``Φ_k`` the transition
        from the first grid time to the ``k``-th (their product), what a batch
        least-squares fit of the initial state needs (:mod:`estimators.batch`).
        """
        h, n = self._steps(dt)
        x0 = np.asarray(x0, dtype=float)
        S = np.ascontiguousarray(servicer, dtype=float).reshape(-1, N_ABSOLUTE)
        if jacobian:
            return _trajectory_stm(x0, S, self.J_S_diag, float(self.mu), self._gg, h, n)
        return _trajectory_states(x0, S, self.J_S_diag, float(self.mu), self._gg, h, n), None, None

    def rewind(self, x, servicer, dt: float) -> np.ndarray:
        """The state ``len(servicer)`` steps of ``dt`` before ``x``: RK4 run backwards, step ``j`` from ``servicer[-1 - j]``.

        ``servicer (N, 13)``: the servicer's state at the *end* of each of the
        ``N`` steps, oldest first (so ``servicer[-1]`` is its state at ``x``'s time).
        Torque-free rigid bodies, the gravity-gradient torque and Kepler orbits are reversible, so the same
        RK4 with ``−dt`` undoes :meth:`propagate` to its truncation error.
        """
        h, n = self._steps(dt)
        x = np.asarray(x, dtype=float)
        for s in np.asarray(servicer, dtype=float).reshape(-1, N_ABSOLUTE)[::-1]:
            x = self._normalized(_rk4_joint(x, s, self.J_S_diag, float(self.mu), self._gg, -h, n, n)[0][-1])
        return x


@dataclass(frozen=True)
class LinearProcessModel:
    """``x_{k+1} = F x_k`` on a plain vector state (``⊞``/``⊟`` are ``+``/``−``).

    The textbook case: both filters must reproduce a linear Kalman filter on it.
    ``F`` may depend on the step length through ``F_of_dt`` (e.g. a
    constant-velocity model); the control input ``u`` is ignored.
    """

    F_of_dt: object  #: callable ``dt -> (n, n)`` transition matrix

    def _F(self, dt: float) -> np.ndarray:
        return np.atleast_2d(np.asarray(self.F_of_dt(dt), dtype=float))

    @property
    def n_state(self) -> int:
        return self._F(1.0).shape[0]

    n_error = n_state

    @staticmethod
    def boxplus(x, dx):
        return np.asarray(x, dtype=float) + np.asarray(dx, dtype=float)

    @staticmethod
    def boxminus(x, x_ref):
        return np.asarray(x, dtype=float) - np.asarray(x_ref, dtype=float)

    def propagate(self, x, u, dt: float) -> np.ndarray:
        return self._F(dt) @ np.asarray(x, dtype=float)

    def propagate_batch(self, X, u, dt: float) -> np.ndarray:
        return np.asarray(X, dtype=float) @ self._F(dt).T

    def propagate_with_jacobian(self, x, u, dt: float):
        F = self._F(dt)
        return F @ np.asarray(x, dtype=float), F

    def trajectory(self, x0, u, dt: float, *, jacobian: bool = True):
        """``X (N+1, n)``, ``Φ_k = F^k`` and the steps' ``F`` for ``N = len(u)`` steps (``u``: any sequence, ignored)."""
        F = self._F(dt)
        N = len(u)
        Phi = np.empty((N + 1,) + F.shape)
        Phi[0] = np.eye(F.shape[0])
        for k in range(N):
            Phi[k + 1] = F @ Phi[k]
        X = Phi @ np.asarray(x0, dtype=float)
        return (X, Phi, np.broadcast_to(F, (N,) + F.shape)) if jacobian else (X, None, None)

    def rewind(self, x, u, dt: float):
        """The state ``len(u)`` steps before ``x``: ``F^{−N} x``."""
        return np.linalg.matrix_power(np.linalg.inv(self._F(dt)), len(u)) @ np.asarray(x, dtype=float)
