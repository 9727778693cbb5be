"""CoMBiNa's attitude UKF (Maestrini et al. §IV.B, eqs 25–32).

State ``x_a = [σ_IT, ω_T, k1, k2]`` (8): the MRP of the target's attitude
``q_IT`` (target frame T to inertial I; the paper's ``σ_T`` of ``C_TI``, see
:func:`estimators.attitude.dcm_to_mrp`), the target's angular velocity in its
own principal axes (rad/s), and the inertia ratios ``k1 = ln(A/B)``,
``k2 = ln(B/C)`` (eqs 26–27). Process model: the attitude kinematics of
eq. 28 (integrated in quaternion form, see below) and torque-free Euler
equations (eq. 29) with ``k̇ = 0`` plus process noise — in orbit (lcnav's, issue 31)
with the gravity-gradient torque about the servicer's own radial direction, whose
angular acceleration has Euler's own coefficients (:func:`_rigid_body_rk4_nb`);
measurement: the attitude (eq. 30, as an error MRP).

How the attitude is carried (the paper's global MRP fails on fast tumblers):

* **Error-MRP sigma points** (the USQUE of Crassidis & Markley, 2003). The
  estimate keeps a reference attitude ``q̂_IT``; the first three states are
  the body-frame *error* MRP ``δσ`` with ``q_IT = q̂_IT ⊗ q(δσ)``, zero after
  every reset, and ``P``'s first block is its covariance (``δσ ≈ δθ/4``).
  Each sigma point's attitude is ``q̂ ⊗ q(δσ_i)``, propagated as a quaternion
  (eq. 28's kinematics in quaternion form, no singularity at 360°), and
  turned back into an error MRP relative to the propagated central point.
  The canonical error MRP (``|δσ| ≤ 1``, :func:`estimators.attitude.quat_to_mrp`)
  *is* the shadow-set choice of eqs 31–32, made per sigma point: no point is
  ever carried across the ``|σ| = 1`` boundary, and the points of eqs 12–13
  are averaged in one chart whatever the attitude. A fast target turns by
  more than π between two measurements (1.5 rad/s × 3 s = 258°); the global
  MRP of the sigma points then straddled the singularity and the mean and
  covariance of eqs 12–13 were meaningless.
* The reported ``x[:3]`` is the global MRP of ``q̂_IT`` (``|σ| ≤ 1``);
  :meth:`AttitudeUKF.correct` reports a shadow switch when that MRP crossed
  ``|σ| = 1`` (``q̂``'s scalar part changed sign), the event eqs 31–32 handle.
* **Integration step.** RK4 with a step of at most ``max_step_s`` *and* at
  most ``max_angle_rad`` of rotation at the sigma points' largest rate
  (0.1 rad by default: about 1e-5 rad of attitude error after 100 predictions of 3 s at 1.2 rad/s,
  ``tests/estimators/test_combina_attitude.py``). The paper-era setting, one RK4 step per 3 s
  prediction, loses the attitude above ~0.3 rad/s. The loop over rows and steps is compiled
  (:func:`propagate_rigid_body`, shared with :mod:`estimators.combina.acquisition`, which integrates
  thousands of rows): a 3 s prediction at 1 rad/s is 30 steps of a few scalar operations, where
  numpy's per-call overhead dominated the closed loop's run time.
* **Process noise** (the paper has ``Q = 0``): ``Q`` per prediction, e.g.
  :func:`attitude_process_noise` (see there).
* **Measurement.** Eq. 30 becomes ``z = δσ_meas``, the error MRP of the
  measured attitude relative to ``q̂``; its noise is the registration's
  body-frame rotation error over 4 (:func:`error_mrp_noise_covariance`).

Spin priors (Renis et al. §6, used by the studies): ``ω_0`` and its ``P_0`` block
are simply the constructor's arguments; :meth:`rate_proxy_innovation` builds
the proxy measurement of the spin *rate* ``|ω|`` that a light curve gives.

References
----------
.. [1] Maestrini, De Luca, Di Lizia, *Relative Navigation Strategy About Unknown and Uncooperative
   Targets*, Journal of Guidance, Control, and Dynamics, 2023.
"""

from __future__ import annotations

import numba
import numpy as np

from estimators.attitude import mrp_to_quat, quat_conjugate, quat_multiply, quat_to_mrp, quat_to_rotvec
from estimators.combina.unscented import Innovation, UnscentedCore
from estimators.dynamics import euler_rhs
from estimators.process_noise import MatchedBudget, white_noise_acceleration

#: Layout of the attitude state.
SIGMA, OMEGA, K = slice(0, 3), slice(3, 6), slice(6, 8)


def attitude_process_noise(dt_s: float, budget: MatchedBudget, *, k_rate_per_s: float = 1e-4) -> np.ndarray:
    """``Q`` (8×8) of one prediction over ``dt_s`` from the disturbance budget of what eq. 29 leaves out.

    * ``[δσ, ω]``: the target's unmodelled angular acceleration (gravity-gradient torque, nutation damping) as the
      white-noise-acceleration model of :mod:`estimators.process_noise` (its eq. 1) with the budget's matched intensity
      ``q = budget.q_alpha_rad2_s3`` per axis (its eq. 3, matched to a filter that measures the attitude,
      :func:`studies.sim.matched_noise.combina_matched_budget`): per axis ``Q_θθ = q τ³/3``, ``Q_θω = q τ²/2``,
      ``Q_ωω = q τ``, with the attitude block taken to the error MRP (``δσ ≈ δθ/4``: ``Q_σσ = Q_θθ/16``, ``Q_σω = Q_θω/4``);
    * ``k``: the ratios are constant for a rigid body (in both truths: the damping is a torque), so the budget has nothing
      for them; a random walk of ``k_rate_per_s`` (1/√s), ``Q_k = k_rate² Δt I``, keeps them adjustable while the
      torque-free model (eq. 29) is only an approximation. With 1e-4, a 3 s step adds 3e-8, i.e. a 1-σ wander of 0.008
      over an orbit (5,800 s) — far below the 0.1 tolerance of the studies. With the budget's ``q`` on ``ω`` it changes
      nothing measurable on the eq. 47 target (k's NEES over an orbit, 10 runs per truth: the same to 0.02 with and
      without it); without process noise on ``ω``, 1e-5 left k's final NEES over 10 seeds above its χ² band. The closed loop
      (:func:`studies.sim.combina.process_noise`) passes 0 since the UKF's own over-confidence while it learns ``k`` is
      mended by refits (:class:`estimators.combina.acquisition.LearningRefits`): a random walk there made the late ``k``
      conservative (its NEES per state 0.2–0.3 at the end of an orbit).
    """
    if not (np.isfinite(dt_s) and dt_s > 0):
        raise ValueError(f"dt_s: {dt_s!r}: expected a positive, finite step in s")
    b = white_noise_acceleration(budget.q_alpha_rad2_s3, dt_s) * np.array([[1.0 / 16.0, 0.25], [0.25, 1.0]])
    Q = np.zeros((8, 8))
    Q[:6, :6] = np.kron(b, np.eye(3))
    Q[K, K] = float(k_rate_per_s) ** 2 * dt_s * np.eye(2)
    return Q


def physical_k(k) -> np.ndarray:
    """Whether inertia ratios ``k = [ln(A/B), ln(B/C)]`` (..., 2) belong to a rigid body: each principal moment at most the sum of the other two.

    The triangle inequalities of the inertia tensor (``A ≤ B + C`` and its
    permutations) are equivalent to every Euler coefficient
    ``|(J_j − J_k)/J_i|`` of eq. 29 being at most 1. Of the box
    ``k ∈ [−1.5, 1.5]²``, 39.5 % is physical; ``k = (1.5, 1.5)`` has a
    coefficient of 15.6.
    """
    J = _moments(k)
    return 2.0 * np.max(J, axis=-1) <= np.sum(J, axis=-1) * (1.0 + 1e-12)


def _moments(k) -> np.ndarray:
    """``[A, B, C]`` with ``B = 1`` from ``k = [ln(A/B), ln(B/C)]`` (eq. 27) for a batch ``(..., 2)`` (:func:`estimators.dynamics.inertia_from_k` is scalar)."""
    k = np.asarray(k, dtype=float)
    return np.stack([np.exp(k[..., 0]), np.ones_like(k[..., 0]), np.exp(-k[..., 1])], axis=-1)


def project_k_physical(k) -> np.ndarray:
    """``k`` (..., 2) with every non-physical ratio moved onto the flat-plate boundary of :func:`physical_k`.

    A violation has one moment larger than the sum of the other two; it is set
    to that sum (the flat-plate limit, Euler coefficient 1) and ``k`` is
    recomputed from the moments (eq. 27). Physical ``k`` is returned unchanged.
    """
    J = _moments(k)
    i = np.argmax(J, axis=-1)[..., None]
    j_max = np.take_along_axis(J, i, axis=-1)
    others = np.sum(J, axis=-1, keepdims=True) - j_max
    np.put_along_axis(J, i, np.minimum(j_max, others), axis=-1)
    return np.stack([np.log(J[..., 0] / J[..., 1]), np.log(J[..., 1] / J[..., 2])], axis=-1)


def rate_from_attitudes(q_IT_0, q_IT_1, dt_s: float, k) -> np.ndarray:
    """Body rate ``ω_T`` (rad/s) at the second of two attitudes ``dt_s`` apart, for a body of inertia ratios ``k``.

    ``q_IT_1 = q_IT_0 ⊗ δq`` (a body-frame rotation, eq. 28 integrated); the
    rotation vector of ``δq`` over ``dt_s`` is the interval's mean body rate
    ``ω̄`` — unambiguous only while the body turns less than π in ``dt_s``
    (1.04 rad/s at 0.33 Hz: the paper's coverage drop). It is carried to the
    interval's end with eq. 29: ``ω(t₁) ≈ ω̄ + (dt/2) ω̇(ω̄, k)``.
    """
    if not (np.isfinite(dt_s) and dt_s > 0):
        raise ValueError(f"dt_s must be positive and finite, got {dt_s!r}")
    w_mean = quat_to_rotvec(quat_multiply(quat_conjugate(np.asarray(q_IT_0, dtype=float)), np.asarray(q_IT_1, dtype=float))) / dt_s
    return w_mean + 0.5 * dt_s * euler_rhs(w_mean, _moments(np.asarray(k, dtype=float)))


def error_mrp_noise_covariance(attitude_sigma_rad: float) -> np.ndarray:
    """``R`` (3×3, MRP²) of a measured error MRP whose attitude error is a body-frame rotation ``N(0, s² I)``.

    ``δσ = tan(θ/4) e ≈ δθ/4``, so ``R = (s/4)² I``. (The paper's constant
    ``R_a = 0.01`` on the global MRP is a 23° 1-σ attitude error.)
    """
    s = float(attitude_sigma_rad)
    if not (np.isfinite(s) and s > 0):
        raise ValueError(f"attitude_sigma_rad must be positive and finite, got {attitude_sigma_rad!r}")
    return (s / 4.0) ** 2 * np.eye(3)


@numba.njit(cache=True)
def _rigid_body_rk4_nb(Y, h, n_sub, g, r_I):
    """``n_sub`` RK4 steps of ``h`` seconds of every row ``[q_IT, ω_T, k]`` of ``Y`` (m, 9): eq. 28 in quaternion form, eq. 29 with
    the gravity-gradient torque, ``k̇ = 0``.

    ``q̇ = ½ q ⊗ [0, ω]``; ``ω̇_x = (B − C)/A (ω_y ω_z − g r_y r_z)`` and cyclically, with ``[A, B, C] = [e^k1, 1, e^−k2]``
    (eq. 27), ``r = R(q)ᵀ r_I`` the row's unit radial direction ``r_I[row]`` in T and ``g[row] = 3μ/|R|³`` (rad²/s²; 0:
    torque-free). The torque ``3μ/|R|⁵ (R_T × J R_T)`` (Hughes 1986) divided by ``J`` has Euler's own coefficients, so
    the two terms share them. ``q`` renormalised after every step.
    """
    out = Y.copy()
    d = np.empty((4, 7))
    for r in range(Y.shape[0]):
        A, C = np.exp(Y[r, 7]), np.exp(-Y[r, 8])
        c0, c1, c2 = (1.0 - C) / A, C - A, (A - 1.0) / C
        gr, ex, ey, ez = g[r], r_I[r, 0], r_I[r, 1], r_I[r, 2]
        s = Y[r, :7].copy()
        for _ in range(n_sub):
            for j in range(4):
                x = s if j == 0 else s + (h if j == 3 else 0.5 * h) * d[j - 1]
                q0, q1, q2, q3, w0, w1, w2 = x[0], x[1], x[2], x[3], x[4], x[5], x[6]
                d[j, 0] = 0.5 * (-q1 * w0 - q2 * w1 - q3 * w2)
                d[j, 1] = 0.5 * (q0 * w0 - q3 * w1 + q2 * w2)
                d[j, 2] = 0.5 * (q3 * w0 + q0 * w1 - q1 * w2)
                d[j, 3] = 0.5 * (-q2 * w0 + q1 * w1 + q0 * w2)
                t0, t1, t2 = w1 * w2, w2 * w0, w0 * w1
                if gr != 0.0:  # r = R(q)ᵀ r_I, with the stage's quaternion normalised (a factor 2/|q|²)
                    f = 2.0 / (q0 * q0 + q1 * q1 + q2 * q2 + q3 * q3)
                    bx = (1.0 - f * (q2 * q2 + q3 * q3)) * ex + f * (q1 * q2 + q0 * q3) * ey + f * (q1 * q3 - q0 * q2) * ez
                    by = f * (q1 * q2 - q0 * q3) * ex + (1.0 - f * (q1 * q1 + q3 * q3)) * ey + f * (q2 * q3 + q0 * q1) * ez
                    bz = f * (q1 * q3 + q0 * q2) * ex + f * (q2 * q3 - q0 * q1) * ey + (1.0 - f * (q1 * q1 + q2 * q2)) * ez
                    t0 -= gr * by * bz
                    t1 -= gr * bz * bx
                    t2 -= gr * bx * by
                d[j, 4] = c0 * t0
                d[j, 5] = c1 * t1
                d[j, 6] = c2 * t2
            s = s + h / 6.0 * (d[0] + 2.0 * d[1] + 2.0 * d[2] + d[3])
            s[:4] /= np.sqrt(s[0] ** 2 + s[1] ** 2 + s[2] ** 2 + s[3] ** 2)
        out[r, :7] = s
    return out


def propagate_rigid_body(Y: np.ndarray, dt_s: float, *, max_step_s: float = 1.0, max_angle_rad: float = 0.1, gravity_gradient=None) -> np.ndarray:
    """Rows ``[q_IT (4), ω_T (3), k (2)]`` (m, 9) integrated over ``dt_s`` with eqs 28–29, ``k̇ = 0``.

    RK4 (compiled, :func:`_rigid_body_rk4_nb`) with a step of at most
    ``max_step_s`` and at most ``max_angle_rad`` of rotation at the rows'
    largest rate (see :class:`AttitudeUKF`); at most 200 steps, so that a
    diverged filter's absurd rate cannot stall the loop. Raises ``ValueError``
    when a row is no longer finite (a diverged filter's sigma points).
    ``gravity_gradient``: ``(g, r_I)`` — ``3μ/|R|³`` (rad²/s², scalar or (m,)) and the unit radial direction in I ((3,) or
    (m, 3)), held over the interval — adds the target's gravity-gradient torque (:func:`_rigid_body_rk4_nb`); None: torque-free.
    """
    Y = np.ascontiguousarray(Y, dtype=float)
    w_max = float(np.max(np.linalg.norm(Y[:, 4:7], axis=1)))
    if not np.isfinite(w_max):
        raise ValueError("the rigid-body propagation was given a non-finite rate: the filter has diverged")
    n_sub = min(max(1, int(np.ceil(abs(dt_s) / max_step_s)), int(np.ceil(w_max * abs(dt_s) / max_angle_rad))), 200)
    m = Y.shape[0]
    if gravity_gradient is None:
        g, r_I = np.zeros(m), np.zeros((m, 3))
    else:
        g = np.ascontiguousarray(np.broadcast_to(np.asarray(gravity_gradient[0], dtype=float), (m,)))
        r_I = np.ascontiguousarray(np.broadcast_to(np.asarray(gravity_gradient[1], dtype=float), (m, 3)))
    out = _rigid_body_rk4_nb(Y, float(dt_s) / n_sub, n_sub, g, r_I)
    if not np.all(np.isfinite(out)):
        raise ValueError("the rigid-body propagation overflowed: the filter has diverged")
    return out


class AttitudeUKF:
    """UKF on ``[δσ, ω_T (rad/s), k1, k2]`` about a reference ``q̂_IT`` (eqs 28–32 of Maestrini et al.), SI units.

    Parameters
    ----------
    x0 : (8,)
        initial estimate ``[σ_IT, ω_T, k1, k2]`` (global MRP, any set).
    P0 : (8, 8)
        its covariance; the MRP block is read as the error MRP's (the two
        agree to first order at ``σ = 0`` and differ by ``(1 + |σ|²)²/16``
        in general; a body-frame attitude error of ``θ`` rad is ``θ/4``).
    max_step_s : float
        longest RK4 step of the propagation.
    max_angle_rad : float
        largest rotation per RK4 step at the sigma points' fastest rate.
    Q : (8, 8) or callable, optional
        additive process noise per prediction, or ``Q(dt_s)``
        (e.g. :func:`attitude_process_noise`).
    iterations : int
        iterations of the posterior-linearised attitude correction
        (:meth:`_correct_iterated`); 0 is the plain UKF correction.
    iterate_k_sd : float
        the correction iterates only while the prior's largest 1-σ of ``k``
        exceeds this (the prediction's nonlinearity comes from ``k``; once
        it is known the plain UKF is accurate and 4× cheaper).
    physical : bool
        project every sigma point's ``k`` onto the rigid-body set before it is
        propagated (:func:`project_k_physical`; the sigma-point projection of
        Kandepu et al., J. Process Control 2008): a point several σ outside it
        has Euler coefficients above 1 and a stiff, inaccurate propagation.
    orbit : optional
        in orbit, the servicer's own orbit (:class:`estimators.combina.own_orbit.ChaserOrbit`): the process model then has the
        target's gravity-gradient torque (:func:`propagate_rigid_body`, the radial direction at each prediction's mid-time);
        None: torque-free (eq. 29, the paper's).
    t0_s : float
        epoch of ``x0`` on the orbit's clock (s).
    """

    def __init__(self, x0, P0, *, max_step_s: float = 1.0, max_angle_rad: float = 0.1, Q=None, iterations: int = 0, iterate_k_sd: float = 0.01,
                 physical: bool = False, alpha: float = 1.0, beta: float = 2.0, kappa: float = 0.0, orbit=None, t0_s: float = 0.0):
        x0 = np.asarray(x0, dtype=float)
        if x0.shape != (8,):
            raise ValueError(f"x0 must have shape (8,) [sigma, w, k1, k2], got {x0.shape}")
        for name, v in (("max_step_s", max_step_s), ("max_angle_rad", max_angle_rad)):
            if not (np.isfinite(v) and v > 0):
                raise ValueError(f"{name} must be positive and finite, got {v!r}")
        self.q_ref = _canonical_quat(mrp_to_quat(x0[SIGMA]))
        xe = x0.copy()
        xe[SIGMA] = 0.0
        self.core = UnscentedCore(xe, P0, alpha=alpha, beta=beta, kappa=kappa)
        self.max_step_s = float(max_step_s)
        self.max_angle_rad = float(max_angle_rad)
        self.Q = Q if (Q is None or callable(Q)) else np.asarray(Q, dtype=float)
        if int(iterations) != iterations or iterations < 0:
            raise ValueError(f"iterations must be a non-negative integer, got {iterations!r}")
        self.iterations = int(iterations)
        self.iterate_k_sd = float(iterate_k_sd)
        self.physical = bool(physical)
        self.orbit = orbit
        self.t_s = float(t0_s)
        self._prior = None
        self._attitude_inn = None
        self.n_shadow_switches = 0

    @property
    def x(self) -> np.ndarray:
        """``[σ_IT (global MRP, |σ| ≤ 1), ω_T, k1, k2]``."""
        x = self.core.x.copy()
        x[SIGMA] = quat_to_mrp(self.q_IT)
        return x

    @property
    def P(self) -> np.ndarray:
        """Covariance of ``[δσ, ω_T, k]`` (the error MRP in the first block)."""
        return self.core.P

    @property
    def q_IT(self) -> np.ndarray:
        """Estimated attitude as a scalar-first quaternion (T to I)."""
        return _canonical_quat(quat_multiply(self.q_ref, mrp_to_quat(self.core.x[SIGMA])))

    def error_mrp(self, q_IT) -> np.ndarray:
        """``δσ`` with ``q_IT = q̂_IT ⊗ q(δσ)`` (``|δσ| ≤ 1``) — also the filter's attitude error convention."""
        return quat_to_mrp(quat_multiply(quat_conjugate(self.q_ref), q_IT))

    def _integrate(self, X: np.ndarray, dt: float, q_ref: np.ndarray, t_s: float) -> np.ndarray:
        """Sigma points ``[δσ, ω, k]`` about ``q_ref`` at ``t_s`` → ``[q_IT, ω, k]`` (9 columns) after ``dt`` (eqs 28–29, RK4 substeps)."""
        k = project_k_physical(X[:, K]) if self.physical else X[:, K]
        Y = np.concatenate([quat_multiply(q_ref, mrp_to_quat(X[:, SIGMA])), X[:, OMEGA], k], axis=1)
        gg = None if self.orbit is None else self.orbit.gravity_gradient(t_s + 0.5 * dt)
        return propagate_rigid_body(Y, dt, max_step_s=self.max_step_s, max_angle_rad=self.max_angle_rad, gravity_gradient=gg)

    def _propagate(self, X: np.ndarray, dt: float) -> np.ndarray:
        """Sigma points ``[δσ, ω, k]`` about ``q_ref`` → propagated, as error MRPs about the propagated central point.

        Sets ``q_ref`` to the propagated central point's attitude.
        """
        Y = self._integrate(X, dt, self.q_ref, self.t_s)
        self.q_ref = _canonical_quat(Y[0, :4])
        return np.concatenate([self.error_mrp(Y[:, :4]), Y[:, 4:]], axis=1)  # canonical: the shadow choice per point

    def _reset(self) -> bool:
        """Move the error MRP into ``q_ref`` (``δσ = 0``), redraw the sigma points; True if the global MRP changed set (eqs 31–32's event)."""
        q = quat_multiply(self.q_ref, mrp_to_quat(self.core.x[SIGMA]))
        switched = bool(q[0] < 0.0)
        self.q_ref = _canonical_quat(q)
        x = self.core.x.copy()
        x[SIGMA] = 0.0
        self.core.x = x
        self.core.sigmas = self.core.points.sigma_points(self.core.x, self.core.P)
        self.n_shadow_switches += int(switched)
        return switched

    def predict(self, dt_s: float) -> None:
        """Eqs 10–13 with the process model of eqs 28–29 over ``dt_s`` seconds."""
        if not (np.isfinite(dt_s) and dt_s > 0):
            raise ValueError(f"dt_s must be positive and finite, got {dt_s!r}")
        Q = self.Q(dt_s) if callable(self.Q) else self.Q
        # the posterior this prediction starts from, for the iterated correction (δσ = 0 after the reset)
        self._prior = (self.core.x.copy(), self.core.P.copy(), self.q_ref.copy(), float(dt_s), Q, self.t_s)
        self._attitude_inn = None
        self.core.predict(lambda X: self._propagate(X, dt_s), Q=Q)
        self.t_s += float(dt_s)
        # the mean error MRP moves into q̂ and the sigma points of eqs 14–17 are redrawn about it from P,
        # so that P, S and P_xz describe the same set of points
        self._reset()

    def innovation(self, q_IT_meas, R) -> Innovation:
        """Eqs 30, 15–17, 23 for a measured attitude (quaternion T to I) with error-MRP covariance ``R`` (3×3)."""
        z = self.error_mrp(np.asarray(q_IT_meas, dtype=float))
        inn = self.core.innovation(z, R, lambda X: X[:, SIGMA])  # eq. 30
        self._attitude_inn = (inn, np.asarray(R, dtype=float))
        return inn

    def rate_proxy_innovation(self, rate_rad_s: float, var_rad2_s2: float) -> Innovation:
        """A proxy measurement of the spin rate ``|ω|`` (a light-curve prior), ``h(x) = |ω|``."""
        if not (np.isfinite(rate_rad_s) and rate_rad_s > 0 and np.isfinite(var_rad2_s2) and var_rad2_s2 > 0):
            raise ValueError("the proxy rate and its variance must be positive and finite")
        return self.core.innovation([rate_rad_s], [[var_rad2_s2]], lambda X: np.linalg.norm(X[:, OMEGA], axis=1, keepdims=True))

    def correct(self, inn: Innovation) -> bool:
        """Eqs 21–22, 24, then the reset of the error MRP into ``q̂``.

        With ``iterations > 0`` and the attitude innovation of the last
        prediction, the correction is the iterated posterior linearisation of
        :meth:`_correct_iterated` instead. Returns whether the global MRP
        switched to its shadow set (eqs 31–32's event).
        """
        pending = getattr(self, "_attitude_inn", None)
        k_uncertain = self._prior is not None and np.sqrt(np.max(np.diag(self._prior[1])[K])) > self.iterate_k_sd
        if self.iterations > 0 and pending is not None and pending[0] is inn and k_uncertain:
            self._attitude_inn = None
            return self._correct_iterated(inn.z, pending[1])
        self.core.correct(inn)
        return self._reset()

    def _correct_iterated(self, z: np.ndarray, R: np.ndarray) -> bool:
        """Iterated posterior linearisation of prediction + measurement (García-Fernández et al., IEEE TSP 2015).

        The measured error MRP ``z`` (about the predicted ``q̂``) is a nonlinear
        function of the state at the *previous* epoch, ``z = h(f(x_{k−1})) + v``
        (eqs 28–30). While ``k`` is uncertain, one 3 s prediction of a fast
        tumbler spreads the sigma points' ``ω`` by radians per second and their
        attitude by more than π: the statistical linearisation about the
        prior (the plain UKF) is then meaningless. Here ``h∘f`` is linearised
        by statistical linear regression (``A``, ``b``, ``Ω``) over sigma points
        drawn from the current *posterior* of ``x_{k−1}``; the prior of
        ``x_{k−1}`` is updated with that linear model; repeat
        ``iterations`` times; the posterior of ``x_{k−1}`` is then propagated
        (eqs 10–13, plus ``Q``) to the measurement epoch. The first iteration
        is the UKF's own linearisation; each later one is taken where the
        posterior mass lies.
        """
        x0, P0, q0, dt, Q, t0 = self._prior
        q_c = self.q_ref.copy()  # the chart of z
        pts = self.core.points
        Wm, Wc = pts.Wm, pts.Wc
        m, Pm = x0.copy(), P0.copy()
        for _ in range(self.iterations):
            X = pts.sigma_points(m, Pm)
            Y = self._integrate(X, dt, q0, t0)
            Z = quat_to_mrp(quat_multiply(quat_conjugate(q_c), Y[:, :4]))
            z_bar = Wm @ Z
            dX, dZ = X - m, Z - z_bar
            Psi = (Wc[:, None] * dX).T @ dZ
            A = np.linalg.solve(Pm, Psi).T  # (3, 8): A = Ψᵀ P⁻¹
            Omega = (Wc[:, None] * dZ).T @ dZ - A @ Pm @ A.T
            S = A @ P0 @ A.T + 0.5 * (Omega + Omega.T) + R
            K = np.linalg.solve(S, A @ P0).T
            m = x0 + K @ (z - z_bar - A @ (x0 - m))
            Pm = P0 - K @ S @ K.T
            Pm = 0.5 * (Pm + Pm.T)
        self.q_ref = q0.copy()
        self.core.x, self.core.P = m, Pm
        self.t_s = t0
        self.core.predict(lambda X: self._propagate(X, dt), Q=Q)
        self.t_s = t0 + dt
        return self._reset()


def _canonical_quat(q) -> np.ndarray:
    """``q`` with ``q0 ≥ 0``."""
    q = np.asarray(q, dtype=float)
    return -q if q[0] < 0.0 else q.copy()
