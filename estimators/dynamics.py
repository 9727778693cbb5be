"""Dynamics models: rigid bodies, orbits, relative motion, precession.

Everything is SI (m, s, rad). Vectors are named with their frame
(``r_ST_T``: servicer relative to target, in the target frame); see DESIGN.md.

Models
------
* torque-free rigid body, Euler's equations (eq. 29 of Maestrini et al.), with the
  inertia parametrised by ``k1 = ln(A/B)``, ``k2 = ln(B/C)``,
  ``J = diag(e^k1, 1, e^-k2)`` (eq. 18 of Renis et al.);
* Keplerian two-body motion;
* the 15-state relative model of Renis et al. (eqs 1–21) in the target frame,
  driven by the servicer's own absolute state (:func:`relative_rhs`);
* the nonlinear equations of relative motion in LVLH (eq. 9 of Maestrini et al.) and
  the Clohessy–Wiltshire closed form;
* the axisymmetric precession model of Maestrini et al. §V.A (eqs 35–40);
* a fixed-step RK4 (the papers' ``ode4``) and a tight ``solve_ivp`` (DOP853)
  for truth.

The relative model and its RK4 loop are compiled with numba: the model is a
few dozen 3-vector operations, where numpy's fixed cost of about a microsecond
per small-array operation would dominate. Compiled, on tuples rather than
small arrays (the note before :func:`get3`), one evaluation inside the RK4 loop
costs about 0.1 µs and 30 000 steps about 0.012 s (``benchmarks/RESULTS.md``).
It is the only implementation (no numpy twin).

References
----------
.. [1] Renis, Price, Hellmich, Battipede, Salzmann, *Leveraging Light-Curve Inversion for Real-Time
   Kinematic State Estimation of Uncooperative Targets*.
.. [2] Maestrini, De Luca, Di Lizia, *Relative Navigation Strategy About Unknown and Uncooperative
   Targets*, Journal of Guidance, Control, and Dynamics, 2023.
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np
from scipy.integrate import solve_ivp

from estimators.attitude import quat_conjugate, quat_multiply, quat_to_dcm
from estimators.state import JOINT_S, JOINT_X, K, N_ABSOLUTE, N_STATE, Q_IB, Q_TS, R_I, R_ST_T, V_I, V_ST_T, W_B, W_ST_T

MU_EARTH = 3.986004418e14
"""Earth's gravitational parameter, m³/s² (EGM96/WGS-84)."""
R_EARTH = 6378137.0
"""Earth's equatorial radius, m (WGS-84)."""

# ---------------------------------------------------------------- inertia


def inertia_from_k(k1, k2) -> np.ndarray:
    """Normalised principal inertia ``[e^k1, 1, e^-k2]`` (eq. 18 of Renis et al.)."""
    return np.array([np.exp(k1), 1.0, np.exp(-k2)], dtype=float)


def k_from_inertia(J_diag) -> tuple[float, float]:
    """``k1 = ln(A/B)``, ``k2 = ln(B/C)`` (eq. 19 of Renis et al.) of principal moments ``A, B, C``."""
    A, B, C = (float(v) for v in J_diag)
    if min(A, B, C) <= 0:
        raise ValueError(f"principal moments must be positive, got {J_diag!r}")
    return float(np.log(A / B)), float(np.log(B / C))


def euler_rhs(w_B, J_diag) -> np.ndarray:
    """Torque-free Euler equations ``J ω̇ + ω × J ω = 0`` (eq. 29 of Maestrini et al.)."""
    w = np.asarray(w_B, dtype=float)
    J = np.asarray(J_diag, dtype=float)
    return -np.cross(w, J * w) / J


def rotational_energy(w_B, J_diag) -> np.ndarray:
    """``½ ωᵀ J ω``."""
    w = np.asarray(w_B, dtype=float)
    return 0.5 * np.sum(np.asarray(J_diag) * w * w, axis=-1)


def angular_momentum_norm(w_B, J_diag) -> np.ndarray:
    """``|J ω|`` (body-frame magnitude equals the inertial one)."""
    return np.linalg.norm(np.asarray(J_diag) * np.asarray(w_B, dtype=float), axis=-1)


def orbital_energy(r_I, v_I, mu: float = MU_EARTH) -> np.ndarray:
    """Specific orbital energy ``v²/2 − μ/r``."""
    r = np.linalg.norm(np.asarray(r_I, dtype=float), axis=-1)
    v = np.linalg.norm(np.asarray(v_I, dtype=float), axis=-1)
    return 0.5 * v * v - mu / r


# ---------------------------------------------------------------- absolute motion


@dataclass(frozen=True)
class AbsoluteTrajectory:
    """A body's absolute state sampled at ``t`` (s), with the dense solution kept."""

    t: np.ndarray  #: (N,) s
    y: np.ndarray  #: (N, 13) ``[r_I, v_I, q_IB, ω_B]``
    J_diag: np.ndarray  #: (3,) principal inertia (any scale)

    @property
    def r_I(self) -> np.ndarray:
        return self.y[:, R_I]

    @property
    def v_I(self) -> np.ndarray:
        return self.y[:, V_I]

    @property
    def q_IB(self) -> np.ndarray:
        return self.y[:, Q_IB]

    @property
    def w_B(self) -> np.ndarray:
        return self.y[:, W_B]


def integrate_absolute(y0, t_eval, J_diag, mu: float = MU_EARTH, rtol: float = 1e-12, atol: float = 1e-12, *, rhs=None) -> AbsoluteTrajectory:
    """Truth integration of :func:`absolute_rhs_nb` with DOP853 at tight tolerances.

    Position and velocity are integrated in units scaled by the initial radius and
    circular speed so that one ``atol`` fits every component. ``rhs(s) -> ṡ`` (13)
    replaces :func:`absolute_rhs_nb` (the perturbed truth of :mod:`estimators.perturbations`).
    """
    y0 = np.asarray(y0, dtype=float)
    t_eval = np.asarray(t_eval, dtype=float)
    J = np.asarray(J_diag, dtype=float)
    L = np.linalg.norm(y0[R_I])
    V = np.sqrt(mu / L)
    scale = np.concatenate([np.full(3, L), np.full(3, V), np.ones(7)])

    f = (lambda s: absolute_rhs_nb(s, J, mu)) if rhs is None else rhs

    def rhs_scaled(t, z):
        return f(z * scale) / scale

    sol = solve_ivp(rhs_scaled, (t_eval[0], t_eval[-1]), y0 / scale, method="DOP853", t_eval=t_eval, rtol=rtol, atol=atol)
    if not sol.success:
        raise RuntimeError(f"truth integration failed: {sol.message}")
    y = sol.y.T * scale
    y[:, Q_IB] /= np.linalg.norm(y[:, Q_IB], axis=1, keepdims=True)
    return AbsoluteTrajectory(t=t_eval, y=y, J_diag=J)


def circular_orbit_state(a_m: float, inclination_rad: float = 0.0, raan_rad: float = 0.0, arg_lat_rad: float = 0.0, mu: float = MU_EARTH) -> np.ndarray:
    """ECI position and velocity ``[r_I, v_I]`` on a circular orbit of radius ``a_m``."""
    if not (np.isfinite(a_m) and a_m > 0):
        raise ValueError(f"orbit radius must be positive and finite, got {a_m!r}")
    u, i, O = arg_lat_rad, inclination_rad, raan_rad
    v = np.sqrt(mu / a_m)
    r_pf = a_m * np.array([np.cos(u), np.sin(u), 0.0])
    v_pf = v * np.array([-np.sin(u), np.cos(u), 0.0])
    cO, sO, ci, si = np.cos(O), np.sin(O), np.cos(i), np.sin(i)
    R = np.array([[cO, -sO * ci, sO * si], [sO, cO * ci, -cO * si], [0.0, si, ci]])
    return np.concatenate([R @ r_pf, R @ v_pf])


def lvlh_dcm(r_I, v_I) -> np.ndarray:
    """``C_LI``: rows are the LVLH axes (x radial, y along-track, z orbit normal) in ECI."""
    r = np.asarray(r_I, dtype=float)
    v = np.asarray(v_I, dtype=float)
    x = r / np.linalg.norm(r, axis=-1, keepdims=True)
    z = np.cross(r, v)
    z = z / np.linalg.norm(z, axis=-1, keepdims=True)
    y = np.cross(z, x)
    return np.stack([x, y, z], axis=-2)


# ---------------------------------------------------------------- relative motion (Renis et al. eqs 1–21)


def relative_state(target: np.ndarray, servicer: np.ndarray, k) -> np.ndarray:
    """The 15-state ``[q_TS, ω_ST_T, r_ST_T, v_ST_T, k1, k2]`` from two absolute states.

    ``q_TS = q_IT* ⊗ q_IS``; ``ω_ST_T = R_TS ω_S_S − ω_T_T`` (eq. 1);
    ``r_ST_T = R_TI (r_S_I − r_T_I)`` (eq. 8);
    ``v_ST_T = R_TI (v_S_I − v_T_I) − ω_T_T × r_ST_T`` (eq. 9).
    ``target`` and ``servicer`` are ``(..., 13)`` absolute states.
    """
    tg = np.asarray(target, dtype=float)
    sv = np.asarray(servicer, dtype=float)
    q_TS = quat_multiply(quat_conjugate(tg[..., Q_IB]), sv[..., Q_IB])
    q_TS = q_TS * np.where(q_TS[..., :1] < 0, -1.0, 1.0)
    R_TS = quat_to_dcm(q_TS)
    R_TI = np.swapaxes(quat_to_dcm(tg[..., Q_IB]), -1, -2)
    w_T = tg[..., W_B]
    w_ST = np.einsum("...ij,...j->...i", R_TS, sv[..., W_B]) - w_T
    r = np.einsum("...ij,...j->...i", R_TI, sv[..., R_I] - tg[..., R_I])
    v = np.einsum("...ij,...j->...i", R_TI, sv[..., V_I] - tg[..., V_I]) - np.cross(w_T, r)
    kk = np.broadcast_to(np.asarray(k, dtype=float), q_TS.shape[:-1] + (2,))
    return np.concatenate([q_TS, w_ST, r, v, kk], axis=-1)


# The compiled dynamics work on tuples: numba keeps them in registers, where every small array costs a heap allocation
# and every array view (``z[W_ST_T]``) reference counting that the compiled code keeps (~10 ns each, more than the
# arithmetic). With arrays and views :func:`joint_rhs` took 1.5 µs, with tuples 0.1 µs. Every helper sums in the order
# the array code did (``a @ v`` over the columns in turn), so the numbers are the same to the last bit. Divisions follow
# numpy (``x/0 → inf``, as that code's array expressions did): Python's zero check made each call ~50 ns slower.


@numba.njit(cache=True)
def get3(a, block, at=0):
    """``a[at + block]`` of a 3-long block (a slice of :mod:`estimators.state`) as a tuple."""
    i = at + block.start
    return (a[i], a[i + 1], a[i + 2])


@numba.njit(cache=True)
def get4(a, block, at=0):
    """``a[at + block]`` of a 4-long block (a quaternion) as a tuple."""
    i = at + block.start
    return (a[i], a[i + 1], a[i + 2], a[i + 3])


@numba.njit(cache=True)
def put3(a, block, v, at=0):
    """``a[at + block] = v`` for a 3-long block and a 3-vector ``v``."""
    i = at + block.start
    a[i], a[i + 1], a[i + 2] = v[0], v[1], v[2]


@numba.njit(cache=True)
def cross3(a, b):
    """``a × b`` of two 3-vectors, as a tuple."""
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


@numba.njit(cache=True)
def mat_vec(a, v):
    """``a @ v`` of a 3×3 matrix (nested tuples, by rows) and a 3-vector, as a tuple."""
    return (
        a[0][0] * v[0] + a[0][1] * v[1] + a[0][2] * v[2],
        a[1][0] * v[0] + a[1][1] * v[1] + a[1][2] * v[2],
        a[2][0] * v[0] + a[2][1] * v[1] + a[2][2] * v[2],
    )


@numba.njit(cache=True)
def mat_t_vec(a, v):
    """``aᵀ @ v`` of a 3×3 matrix (nested tuples, by rows) and a 3-vector, as a tuple."""
    return (
        a[0][0] * v[0] + a[1][0] * v[1] + a[2][0] * v[2],
        a[0][1] * v[0] + a[1][1] * v[1] + a[2][1] * v[2],
        a[0][2] * v[0] + a[1][2] * v[1] + a[2][2] * v[2],
    )


@numba.njit(cache=True, error_model="numpy")
def euler_rate(w, J):
    """``ω̇ = −ω × (J ω) / J``: Euler's torque-free equations for the principal inertia ``J`` (3-vectors), as a tuple."""
    c = cross3(w, (J[0] * w[0], J[1] * w[1], J[2] * w[2]))
    return (-c[0] / J[0], -c[1] / J[1], -c[2] / J[2])


@numba.njit(cache=True, error_model="numpy")
def gravity_gradient_torque(r_B, J, mu):
    """Gravity-gradient torque on a rigid body, ``τ_B = 3μ/r⁵ (r_B × J r_B)`` (Hughes 1986; Wie 2008 ch. 6).

    ``r_B``: the body's position from the Earth's centre in its principal frame B (m, 3-tuple);
    ``J``: principal inertia (3-tuple, any unit: the torque comes out in that unit × s⁻²);
    ``mu``: m³/s². Zero when ``r_B`` lies along a principal axis, and for ``A = B = C``.
    Returns a 3-tuple in B. Lives here, not in :mod:`estimators.perturbations`, because the filters' model may
    include it (:func:`joint_rhs`, ``gg``): the torque is known physics given the inertia ratios and the orbit.
    """
    r2 = r_B[0] ** 2 + r_B[1] ** 2 + r_B[2] ** 2
    k = 3.0 * mu / (r2 * r2 * np.sqrt(r2))
    c = cross3(r_B, (J[0] * r_B[0], J[1] * r_B[1], J[2] * r_B[2]))
    return (k * c[0], k * c[1], k * c[2])


@numba.njit(cache=True)
def quat_to_dcm_nb(q):
    """``R(q)`` of one quaternion as nested tuples (rows), compiled twin of :func:`estimators.attitude.quat_to_dcm` for numba code."""
    q0, q1, q2, q3 = q[0], q[1], q[2], q[3]
    return (
        (q0 * q0 + q1 * q1 - q2 * q2 - q3 * q3, 2 * (q1 * q2 - q0 * q3), 2 * (q1 * q3 + q0 * q2)),
        (2 * (q1 * q2 + q0 * q3), q0 * q0 - q1 * q1 + q2 * q2 - q3 * q3, 2 * (q2 * q3 - q0 * q1)),
        (2 * (q1 * q3 - q0 * q2), 2 * (q2 * q3 + q0 * q1), q0 * q0 - q1 * q1 - q2 * q2 + q3 * q3),
    )


@numba.njit(cache=True, error_model="numpy")
def _absolute_rhs_into(s, J, mu, out, at):
    """:func:`absolute_rhs_nb` of ``s[at : at + 13]`` written into ``out[at : at + 13]``."""
    r = get3(s, R_I, at)
    q = get4(s, Q_IB, at)
    w = get3(s, W_B, at)
    rn = np.sqrt(r[0] ** 2 + r[1] ** 2 + r[2] ** 2)
    put3(out, R_I, get3(s, V_I, at), at)
    put3(out, V_I, (-mu * r[0] / rn**3, -mu * r[1] / rn**3, -mu * r[2] / rn**3), at)
    # q̇ = ½ q ⊗ [0, ω] = ½ Q(q) ω (eq. 3 of Renis et al.)
    i = at + Q_IB.start
    out[i] = 0.5 * (-q[1] * w[0] - q[2] * w[1] - q[3] * w[2])
    out[i + 1] = 0.5 * (q[0] * w[0] - q[3] * w[1] + q[2] * w[2])
    out[i + 2] = 0.5 * (q[3] * w[0] + q[0] * w[1] - q[1] * w[2])
    out[i + 3] = 0.5 * (-q[2] * w[0] + q[1] * w[1] + q[0] * w[2])
    put3(out, W_B, euler_rate(w, J), at)


@numba.njit(cache=True)
def absolute_rhs_nb(s, J, mu):
    """Keplerian orbit plus torque-free attitude: ``ṡ`` of ``s = [r_I, v_I, q_IB, ω_B]`` (13), compiled.

    ``q̇_IB = ½ q_IB ⊗ [0, ω_B]`` (DESIGN.md), ``ω̇_B`` from Euler's equations. The truth
    integrations call it tens of thousands of times, and the relative model uses it for the servicer.
    """
    out = np.empty(N_ABSOLUTE)
    _absolute_rhs_into(s, J, mu, out, 0)
    return out


@numba.njit(cache=True, error_model="numpy")
def gravity_gradient_rate(r_T_T, JT, mu):
    """``ω̇`` of the gravity-gradient torque: ``J⁻¹ τ = 3μ/|r|⁵ J⁻¹ (r × J r) = −3μ/|r|⁵ E(r)`` with ``E`` Euler's
    torque-free right-hand side (:func:`euler_rate`) evaluated at ``r`` instead of ``ω`` (the two share the form
    ``J⁻¹ (u × J u)``). ``r_T_T``: the body's position from the Earth's centre in its principal frame (m)."""
    r2 = r_T_T[0] ** 2 + r_T_T[1] ** 2 + r_T_T[2] ** 2
    n3 = 3.0 * mu / (r2 * r2 * np.sqrt(r2))
    e = euler_rate(r_T_T, JT)
    return (-n3 * e[0], -n3 * e[1], -n3 * e[2])


@numba.njit(cache=True, error_model="numpy")
def joint_rhs_into(z, J_S, mu, gg, out):
    """:func:`joint_rhs` written into ``out`` (28): what the RK4 loops call, on buffers they reuse."""
    X, S = JOINT_X.start, JOINT_S.start
    q = get4(z, Q_TS, X)
    w = get3(z, W_ST_T, X)  # ω_ST_T, rate of S relative to T, in T
    r = get3(z, R_ST_T, X)
    v = get3(z, V_ST_T, X)
    JT = (np.exp(z[X + K.start]), 1.0, np.exp(-z[X + K.start + 1]))

    r_SI = get3(z, R_I, S)
    R_TS = quat_to_dcm_nb(q)
    R_IS = quat_to_dcm_nb(get4(z, Q_IB, S))
    # servicer: Kepler + Euler
    rs = np.sqrt(r_SI[0] ** 2 + r_SI[1] ** 2 + r_SI[2] ** 2)
    _absolute_rhs_into(z, J_S, mu, out, S)
    dw_S = get3(out, W_B, S)
    r_S_T = mat_vec(R_TS, mat_t_vec(R_IS, r_SI))  # servicer position from Earth's centre, in T
    r_T_T = (r_S_T[0] - r[0], r_S_T[1] - r[1], r_S_T[2] - r[2])  # the target's

    # relative attitude: q̇_TS = ½ [0, ω_ST_T] ⊗ q_TS  (= ½ Q(q_TS) ω_ST_S, eq. 2)
    i = X + Q_TS.start
    out[i] = 0.5 * (-w[0] * q[1] - w[1] * q[2] - w[2] * q[3])
    out[i + 1] = 0.5 * (w[0] * q[0] + w[1] * q[3] - w[2] * q[2])
    out[i + 2] = 0.5 * (w[1] * q[0] + w[2] * q[1] - w[0] * q[3])
    out[i + 3] = 0.5 * (w[2] * q[0] + w[0] * q[2] - w[1] * q[1])

    w_S_T = mat_vec(R_TS, get3(z, W_B, S))
    w_T = (w_S_T[0] - w[0], w_S_T[1] - w[1], w_S_T[2] - w[2])  # eq. 1 solved for the target's own rate
    dw_T = euler_rate(w_T, JT)  # eq. 6, torque-free
    if gg != 0.0:  # the target's gravity-gradient torque (joint_rhs)
        g = gravity_gradient_rate(r_T_T, JT, mu)
        dw_T = (dw_T[0] + gg * g[0], dw_T[1] + gg * g[1], dw_T[2] + gg * g[2])
    # eq. 7: α_ST = ω_ST × ω_S_T + R_TS ω̇_S_S − ω̇_T_T   (ω_ST × ω_S_T = −ω_T × ω_ST)
    a = cross3(w, w_S_T)
    b = mat_vec(R_TS, dw_S)
    put3(out, W_ST_T, (a[0] + b[0] - dw_T[0], a[1] + b[1] - dw_T[1], a[2] + b[2] - dw_T[2]), X)

    # translation, eqs 8–15 via the transport theorem in the rotating T frame
    rt = np.sqrt(r_T_T[0] ** 2 + r_T_T[1] ** 2 + r_T_T[2] ** 2)
    put3(out, R_ST_T, v, X)
    c1 = cross3(w_T, v)
    c2 = cross3(dw_T, r)
    c3 = cross3(w_T, cross3(w_T, r))
    i = X + V_ST_T.start
    for j in range(3):
        a_I = -mu * r_S_T[j] / rs**3 + mu * r_T_T[j] / rt**3  # eqs 12–14
        out[i + j] = a_I - 2.0 * c1[j] - c2[j] - c3[j]
    out[X + K.start] = out[X + K.start + 1] = 0.0


@numba.njit(cache=True)
def joint_rhs(z, J_S, mu, gg):
    """Right-hand side of the joint vector ``[x (15), s (13)]``.

    ``x`` is the relative state of eq. 17; ``s = [r_S_I, v_S_I, q_IS, ω_S_S]``
    is the servicer's own absolute state (its AODS), propagated alongside so
    the relative model always sees the servicer at the right instant.
    ``gg``: 1 adds the gravity-gradient torque on the target to Euler's equations (beyond the paper's eq. 21:
    :func:`gravity_gradient_rate` at ``r_T_T = R_TS R_SI r_S_I − r_ST_T``, known given the inertia ratios and the
    servicer's AODS, and the largest term a torque-free model leaves out in LEO); 0, the paper's torque-free target.
    """
    out = np.empty(N_STATE + N_ABSOLUTE)
    joint_rhs_into(z, J_S, mu, gg, out)
    return out


@numba.njit(cache=True)
def rk4_joint_step(z, J_S, mu, gg, dt, work):
    """One RK4 step of :func:`joint_rhs` from ``z`` (28), in place; ``work`` (5, 28): scratch for the stages.

    Element by element in the order of ``z + dt/6 (k1 + 2 k2 + 2 k3 + k4)``: the numbers of the array
    expressions, without the allocation of each.
    """
    k1, k2, k3, k4, zt = work[0], work[1], work[2], work[3], work[4]
    joint_rhs_into(z, J_S, mu, gg, k1)
    for i in range(z.size):
        zt[i] = z[i] + 0.5 * dt * k1[i]
    joint_rhs_into(zt, J_S, mu, gg, k2)
    for i in range(z.size):
        zt[i] = z[i] + 0.5 * dt * k2[i]
    joint_rhs_into(zt, J_S, mu, gg, k3)
    for i in range(z.size):
        zt[i] = z[i] + dt * k3[i]
    joint_rhs_into(zt, J_S, mu, gg, k4)
    for i in range(z.size):
        z[i] = z[i] + dt / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])


def relative_rhs(x, servicer, J_S_diag, mu: float = MU_EARTH, *, gravity_gradient: bool = False) -> np.ndarray:
    """Time derivative of the 15-state relative vector (eq. 21 of Renis et al.).

    ``x = [q_TS, ω_ST_T, r_ST_T, v_ST_T, k1, k2]``; ``servicer = [r_S_I, v_S_I,
    q_IS, ω_S_S]`` is the servicer's absolute state, from its own attitude and
    orbit determination; ``J_S_diag`` its principal inertia.

    Derivation (done here because eqs 11 and 15 of the converted Renis et al.
    have sign and frame slips; the exactness test in
    ``tests/estimators/test_dynamics.py`` checks it against two independent
    absolute integrations):

    * attitude: ``q_TS`` maps S to T, so ``q̇_TS = ½ q_TS ⊗ [0, ω_{S/T}^S]
      = ½ [0, ω_ST_T] ⊗ q_TS``;
    * rate: differentiating ``ω_ST_T = R_TS ω_S_S − ω_T_T`` (eq. 1) in T with
      ``Ṙ_TS = [ω_ST_T×] R_TS`` gives
      ``α = ω_ST_T × ω_S_T + R_TS ω̇_S_S − ω̇_T_T`` (eq. 7, since
      ``ω_ST × ω_S = −ω_T × ω_ST``), with ``ω_T_T = R_TS ω_S_S − ω_ST_T`` and
      ``ω̇_T_T`` from Euler's equations in ``J = diag(e^k1, 1, e^-k2)``;
    * translation: with ``r_ST_T = R_TI (r_S − r_T)`` and the transport theorem
      in the target frame, which rotates at the target's own rate ω_T,
      ``a_ST_T = R_TI (r̈_S − r̈_T) − 2 ω_T × v − ω̇_T × r − ω_T × (ω_T × r)``,
      where ``r̈ = −μ r/|r|³`` for each body and
      ``r_S_T = R_TS R_SI r_S_I``, ``r_T_T = r_S_T − r_ST_T`` (eqs 12–14).

    ``gravity_gradient``: add the target's gravity-gradient torque (:func:`joint_rhs`).

    Accepts ``x`` of shape ``(15,)`` or ``(N, 15)`` (a batch, e.g. sigma points).
    """
    x = np.asarray(x, dtype=float)
    s = np.asarray(servicer, dtype=float)
    J = np.asarray(J_S_diag, dtype=float)
    gg = 1.0 if gravity_gradient else 0.0
    if x.ndim == 1:
        return joint_rhs(np.concatenate([x, s]), J, mu, gg)[JOINT_X]
    return np.stack([joint_rhs(np.concatenate([xi, s]), J, mu, gg)[JOINT_X] for xi in x])


@numba.njit(cache=True)
def _rk4_joint(x0, s0, J_S, mu, gg, dt, n_steps, stride):
    n_out = n_steps // stride + 1
    xs = np.empty((n_out, N_STATE))
    ss = np.empty((n_out, N_ABSOLUTE))
    z = np.empty(N_STATE + N_ABSOLUTE)
    work = np.empty((5, N_STATE + N_ABSOLUTE))
    z[JOINT_X] = x0
    z[JOINT_S] = s0
    xs[0] = x0
    ss[0] = s0
    j = 1
    for i in range(n_steps):
        rk4_joint_step(z, J_S, mu, gg, dt, work)
        if (i + 1) % stride == 0:
            xs[j] = z[JOINT_X]
            ss[j] = z[JOINT_S]
            j += 1
    return xs, ss


@numba.njit(cache=True)
def _rk4_batch(X, s0, J_S, mu, gg, dt, n_steps):
    out = np.empty_like(X)
    for b in range(X.shape[0]):
        xs, _ = _rk4_joint(X[b], s0, J_S, mu, gg, dt, n_steps, n_steps)
        out[b] = xs[-1]
    return out


def propagate_relative(x0, servicer0, J_S_diag, dt: float, n_steps: int, *, stride: int = 1, mu: float = MU_EARTH,
                       gravity_gradient: bool = False):
    """RK4 (``ode4``) of the relative model together with the servicer's state.

    Returns ``(x, s)``: the relative states ``(n_steps//stride + 1, 15)`` and the
    servicer states ``(…, 13)`` every ``stride`` steps, starting with the
    initial ones. ``gravity_gradient``: the target's gravity-gradient torque included (:func:`joint_rhs`).
    """
    if not (np.isfinite(dt) and dt > 0):
        raise ValueError(f"dt must be positive and finite, got {dt!r}")
    x0 = np.asarray(x0, dtype=float)
    s0 = np.asarray(servicer0, dtype=float)
    if x0.shape != (N_STATE,) or s0.shape != (N_ABSOLUTE,):
        raise ValueError(f"expected x0 of shape (15,) and servicer of shape (13,), got {x0.shape}, {s0.shape}")
    return _rk4_joint(x0, s0, np.asarray(J_S_diag, dtype=float), float(mu), 1.0 if gravity_gradient else 0.0, float(dt), int(n_steps), int(stride))


def propagate_relative_batch(X, servicer0, J_S_diag, dt: float, n_steps: int = 1, mu: float = MU_EARTH, *,
                             gravity_gradient: bool = False) -> np.ndarray:
    """Propagate a batch of relative states ``X (N, 15)`` by ``n_steps`` RK4 steps of ``dt``.

    Every member sees the same servicer trajectory (from ``servicer0``); used
    to push sigma points through eq. 21 in the UKF. ``gravity_gradient``: as :func:`propagate_relative`.
    """
    X = np.ascontiguousarray(X, dtype=float)
    return _rk4_batch(X, np.asarray(servicer0, dtype=float), np.asarray(J_S_diag, dtype=float), float(mu), 1.0 if gravity_gradient else 0.0,
                      float(dt), int(n_steps))


# ---------------------------------------------------------------- LVLH relative motion (Maestrini et al. eq. 9)


def nerm_rhs(t: float, x, n: float, R_t: float, mu: float = MU_EARTH) -> np.ndarray:
    """Nonlinear equations of relative motion in LVLH (eq. 9 of Maestrini et al.).

    ``x = [x, y, z, ẋ, ẏ, ż]`` (m, m/s) of the target relative to the chaser on
    a circular orbit of radius ``R_t`` and mean motion ``n``; accepts ``(..., 6)``.
    """
    x = np.asarray(x, dtype=float)
    px, py, pz, vx, vy, vz = (x[..., i] for i in range(6))
    d3 = ((R_t + px) ** 2 + py**2 + pz**2) ** 1.5
    ax = 2 * n * vy + n * n * px - mu * (R_t + px) / d3 + mu / R_t**2
    ay = -2 * n * vx + n * n * py - mu * py / d3
    az = -mu * pz / d3
    return np.stack([vx, vy, vz, ax, ay, az], axis=-1)


def cw_stm(n: float, t) -> np.ndarray:
    """Clohessy–Wiltshire state-transition matrix ``Φ(t)`` (6×6, or ``(N, 6, 6)``)."""
    t = np.asarray(t, dtype=float)
    s, c = np.sin(n * t), np.cos(n * t)
    z, o = np.zeros_like(t), np.ones_like(t)
    rows = [
        [4 - 3 * c, z, z, s / n, 2 * (1 - c) / n, z],
        [6 * (s - n * t), o, z, -2 * (1 - c) / n, (4 * s - 3 * n * t) / n, z],
        [z, z, c, z, z, s / n],
        [3 * n * s, z, z, c, 2 * s, z],
        [-6 * n * (1 - c), z, z, -2 * s, 4 * c - 3, z],
        [z, z, -n * s, z, z, c],
    ]
    return np.moveaxis(np.array([[np.broadcast_to(e, t.shape) for e in row] for row in rows]), (0, 1), (-2, -1))


def cw_propagate(x0, n: float, t) -> np.ndarray:
    """Closed-form Clohessy–Wiltshire solution ``x(t) = Φ(t) x0``."""
    return np.einsum("...ij,j->...i", cw_stm(n, t), np.asarray(x0, dtype=float))


# ---------------------------------------------------------------- axisymmetric precession (Maestrini et al. §V.A)


def axisymmetric_rhs(t: float, x) -> np.ndarray:
    """Precession of the symmetry axis in the angular-momentum frame ``I_Γ`` (eqs 35–40).

    ``x = [φ, δ, Γ/A]``: azimuth and elevation (rad) of the symmetry axis
    ``J = [cos φ cos δ, sin φ cos δ, sin δ]`` in ``I_Γ`` (whose ``j`` axis is
    along the angular momentum Γ), and ``Γ/A`` (rad/s). From eq. 39,
    ``J̇ = (Γ/A) j × J`` gives ``J̇_x = (Γ/A) J_z``, ``J̇_y = 0``,
    ``J̇_z = −(Γ/A) J_x`` (the converted eq. 40 drops the third line), hence

    ``φ̇ = −(Γ/A) sin φ tan δ``, ``δ̇ = −(Γ/A) cos φ``, ``d(Γ/A)/dt = 0``.

    These keep ``J_y = sin φ cos δ`` constant, so that
    ``e = (Γ/A) √(1 − sin²φ cos²δ)`` (eq. 42) is constant too. Singular at
    ``δ = ±90°`` (the azimuth is undefined there).
    """
    x = np.asarray(x, dtype=float)
    phi, delta, g = x[..., 0], x[..., 1], x[..., 2]
    return np.stack([-g * np.sin(phi) * np.tan(delta), -g * np.cos(phi), np.zeros_like(g)], axis=-1)


def axis_from_spherical(phi, delta) -> np.ndarray:
    """Unit vector ``[cos φ cos δ, sin φ cos δ, sin δ]``."""
    phi = np.asarray(phi, dtype=float)
    delta = np.asarray(delta, dtype=float)
    return np.stack([np.cos(phi) * np.cos(delta), np.sin(phi) * np.cos(delta), np.sin(delta)], axis=-1)


def spherical_from_axis(u) -> tuple[np.ndarray, np.ndarray]:
    """Azimuth and elevation (rad) of a (not necessarily unit) vector."""
    u = np.asarray(u, dtype=float)
    return np.arctan2(u[..., 1], u[..., 0]), np.arctan2(u[..., 2], np.hypot(u[..., 0], u[..., 1]))


# ---------------------------------------------------------------- generic integrators


def rk4_step(f, t: float, x, dt: float, *args) -> np.ndarray:
    """One classical Runge–Kutta step (MATLAB's ``ode4``) of ``ẋ = f(t, x, *args)``."""
    x = np.asarray(x, dtype=float)
    k1 = f(t, x, *args)
    k2 = f(t + 0.5 * dt, x + 0.5 * dt * k1, *args)
    k3 = f(t + 0.5 * dt, x + 0.5 * dt * k2, *args)
    k4 = f(t + dt, x + dt * k3, *args)
    return x + dt / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)


def integrate_truth(f, t_eval, x0, *args, rtol: float = 1e-12, atol: float = 1e-12) -> np.ndarray:
    """``solve_ivp`` (DOP853) of ``ẋ = f(t, x, *args)`` sampled at ``t_eval``; returns ``(N, n)``."""
    t_eval = np.asarray(t_eval, dtype=float)
    sol = solve_ivp(lambda t, x: f(t, x, *args), (t_eval[0], t_eval[-1]), np.asarray(x0, dtype=float), method="DOP853", t_eval=t_eval, rtol=rtol, atol=atol)
    if not sol.success:
        raise RuntimeError(f"integration failed: {sol.message}")
    return sol.y.T
