"""Batch acquisition of CoMBiNa's attitude state from its first measured attitudes (lcnav's addition to Maestrini et al. §IV.B).

Why. The attitude UKF (eqs 25–32) starts from ``P_0`` (eq. 48): the attitude
known to ~70°, the rate to 3e-4 rad/s, ``k`` to 0.3. On a fast tumbler a
``k`` error of 0.3 turns one 3 s prediction by tens of degrees and moves
``ω`` by tenths of rad/s, so the first corrections meet a posterior over
``(ω, k)`` that is far from Gaussian; the filter then settled in a wrong
``(ω, k)`` basin, or its sigma points blew up (measured on development seeds
at 0.9–1.05 rad/s: most of the non-converged runs). A handful of
measurements, on the other hand, pins ``k`` down sharply: the body-frame
rotation between two measurement epochs depends only on ``ω`` and ``k``.

What. The torque-free rigid body (eqs 28–29) makes the state
``x = [q_IT, ω_T, k]`` at one epoch determine the attitude at every other.
Given the measured attitudes ``q_i`` at ``t_i`` (a body-frame registration
error ``N(0, s² I)``, i.e. the error MRP of eq. 30 with ``R = (s/4)² I``) and
the filter's Gaussian prior ``(x̂_0, P_0)`` at ``t_0``, the maximum a
posteriori *initial* state minimises

    J(x_0) = Σ_i |δσ_i(x_0)|² / (s/4)² + (x_0 ⊖ x̂_0)ᵀ P_0⁻¹ (x_0 ⊖ x̂_0),

``δσ_i`` the error MRP between the attitude ``x_0`` predicts at ``t_i`` and the
measured one, ``⊖`` the error MRP for the attitude and the difference for
``ω`` and ``k``. It is found in three steps:

1. **Grid over k.** Rigid-body ratios (:func:`estimators.combina.attitude.physical_k`)
   on a grid over the prior's ``±n_sd`` σ box, ``ω(t_0) = ω̂_0``: per grid
   point the body-frame rotations ``Δq_i`` from ``t_0`` are integrated
   (:func:`estimators.combina.attitude.propagate_rigid_body`, all points in
   one batch) and ``q(t_0)`` is the mean of ``q_i ⊗ Δq_i⁻¹`` over the
   candidates that agree with each other; ``J`` with each measurement's term
   capped at the χ²₃ 99.9 % quantile (a misregistration of tens of degrees
   counts once, whatever its size).
2. **Refinement.** From the lowest local minima of the grid cost (distinct
   basins), Levenberg–Marquardt (:func:`scipy.optimize.least_squares`) on the
   eight initial states, without the measurements the grid step found to be
   outliers (and without any the refined fit finds beyond the same quantile).
   The lowest ``J`` wins.
3. **Covariance.** The Laplace approximation ``(Aᵀ A)⁻¹`` of the whitened
   residuals' Jacobian ``A`` at the minimum, in the UKF's error-MRP chart
   about the estimate. The filter restarts from it at ``t_0`` and carries it
   to the last epoch with its own unscented prediction.

Why at ``t_0``. There the prior is exactly Gaussian and only the measurement
functions are nonlinear. At the last epoch the posterior is curved:
``ω(t_n) ≈ ω(t_0) + ∫ω̇(k) dt``, with ``ω(t_0)`` known to 3e-4 rad/s and ``k``
to a tenth; its Laplace approximation there put the truth at a NEES (8 dof)
of 10² to 10⁵ on a third of 20 development arcs at 0.9 rad/s (median 25),
and the filter restarted from it stayed over-confident. At ``t_0``: median
8.2, all 20 below χ²₈'s 99 % quantile; carried to ``t_n`` by the unscented
prediction, median 6.2 and 19 of 20.

The filter keeps running the same model afterwards; the acquisition only
replaces its Gaussian treatment of the first few, most nonlinear, updates.

References
----------
.. [1] Maestrini, De Luca, Di Lizia, *Relative Navigation Strategy About Unknown and Uncooperative
   Targets*, Journal of Guidance, Control, and Dynamics, 2023.
.. [2] Moré, *The Levenberg–Marquardt algorithm: implementation and theory*, Numerical Analysis,
   Lecture Notes in Mathematics 630, 1978.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg import solve_triangular
from scipy.optimize import least_squares
from scipy.stats import chi2

from estimators.attitude import mrp_to_quat, quat_conjugate, quat_multiply, quat_normalize, quat_to_mrp
from estimators.combina.attitude import physical_k, propagate_rigid_body

#: A measurement whose whitened squared residual exceeds the χ²₃ 99.9 % quantile is a misregistration.
OUTLIER_CHI2 = float(chi2.ppf(0.999, 3))
#: Forward-difference step of the refinement's Jacobian (error MRP, rad/s, 1).
_FD_STEP = 1e-7


@dataclass(frozen=True)
class AttitudeAcquisition:
    """The MAP initial state given a short arc of measured attitudes, and its Laplace covariance."""

    t_s: float  #: epoch of the estimate: the prior's ``t_0`` (s)
    x: np.ndarray  #: (8,) ``[σ_IT (global MRP), ω_T (rad/s), k1, k2]`` at ``t_s``
    P: np.ndarray  #: (8, 8) covariance, the error MRP in the first block (:class:`estimators.combina.attitude.AttitudeUKF`'s convention)
    cost: float  #: ``J`` at the minimum (each measurement left out counts :data:`OUTLIER_CHI2`)
    used: np.ndarray  #: (n,) bool, the measurements in the fit (False: outliers)
    n_basins: int  #: grid basins refined

    @property
    def fit_chi2(self) -> float:
        """The fit's χ²: whitened squared residuals of the measurements used and of the prior (``3 n_used`` degrees of freedom)."""
        return self.cost - OUTLIER_CHI2 * float(np.sum(~self.used))

    def fits(self, confidence: float = 0.999, max_outliers: int = 1) -> bool:
        """Whether a rigid body explains the arc: at most ``max_outliers`` measurements left out and :attr:`fit_chi2` below its χ² quantile.

        An axisymmetric target's registrations carry a random roll about its
        axis (§IV.C), which no rigid-body motion fits: the acquisition then does not fit.
        """
        n_used = int(np.sum(self.used))
        return int(np.sum(~self.used)) <= max_outliers and self.fit_chi2 <= float(chi2.ppf(confidence, 3 * n_used))


class _Arc:
    """The measured arc and the prior: whitened residuals of a batch of initial states."""

    def __init__(self, t_s, q_IT, sd_mrp: float, x0, P0, t0_s: float, max_step_s: float, max_angle_rad: float, orbit=None):
        self.t, self.q, self.sd = t_s, q_IT, sd_mrp
        self.t0 = t0_s
        edges = np.concatenate([[t0_s], t_s])
        # the gravity gradient of each interval at its mid-time (the filter's own model, AttitudeUKF(orbit=)); None: torque-free
        self.gg = [None] * t_s.size if orbit is None else [orbit.gravity_gradient(0.5 * (a + b)) for a, b in zip(edges[:-1], edges[1:])]
        self.q0_hat = mrp_to_quat(x0[:3])
        self.x0 = x0
        self.L0 = np.linalg.cholesky(P0)
        self.steps = {"max_step_s": max_step_s, "max_angle_rad": max_angle_rad}

    def prior_residuals(self, Y0: np.ndarray) -> np.ndarray:
        """Whitened ``x(t_0) ⊖ x̂_0`` of rows ``[q_IT, ω, k]`` (m, 9) at ``t_0``."""
        e = np.concatenate([quat_to_mrp(quat_multiply(quat_conjugate(self.q0_hat), Y0[:, :4])), Y0[:, 4:] - self.x0[3:]], axis=1)
        return solve_triangular(self.L0, e.T, lower=True).T

    def measurement_residuals(self, q_pred: np.ndarray) -> np.ndarray:
        """Whitened error MRPs (m, n, 3) of the measured attitudes relative to predicted ones ``q_pred`` (m, n, 4)."""
        return quat_to_mrp(quat_multiply(quat_conjugate(q_pred), self.q[None, :, :])) / self.sd

    def forwards(self, Y0: np.ndarray) -> np.ndarray:
        """Rows at ``t_0`` (m, 9) → the attitudes they predict at the measurement epochs (m, n, 4)."""
        q_pred = np.empty((Y0.shape[0], self.t.size, 4))
        Y, t_prev = Y0, self.t0
        for i, ti in enumerate(self.t):
            Y = propagate_rigid_body(Y, ti - t_prev, gravity_gradient=self.gg[i], **self.steps)
            q_pred[:, i], t_prev = Y[:, :4], ti
        return q_pred

    def residuals(self, p: np.ndarray, q_ref: np.ndarray, used: np.ndarray) -> np.ndarray:
        """Whitened residuals (m, 3n + 8) of parameter rows ``[δσ about q_ref, ω, k]`` (m, 8) at ``t_0``."""
        Y0 = np.concatenate([quat_multiply(q_ref, mrp_to_quat(p[:, :3])), p[:, 3:]], axis=1)
        r = self.measurement_residuals(self.forwards(Y0)) * used[None, :, None]
        return np.concatenate([r.reshape(p.shape[0], -1), self.prior_residuals(Y0)], axis=1)

    def jacobian(self, p: np.ndarray, q_ref: np.ndarray, used: np.ndarray) -> np.ndarray:
        """Forward-difference Jacobian (3n + 8, 8) of :meth:`residuals` at ``p`` (8,), the nine rows integrated in one batch."""
        rows = np.vstack([p, p + _FD_STEP * np.eye(8)])
        r = self.residuals(rows, q_ref, used)
        return ((r[1:] - r[0]) / _FD_STEP).T


def _k_grid(k_hat, sd_k, step: float, n_sd: float) -> tuple[np.ndarray, np.ndarray]:
    """``(k (m, 2), mask (a, b))``: the rigid-body points of a regular grid over ``k̂ ± n_sd σ``; ``mask`` marks them on the full grid."""
    axes = [np.arange(k - n_sd * s, k + n_sd * s + 0.5 * step, step) for k, s in zip(k_hat, sd_k)]
    K1, K2 = np.meshgrid(*axes, indexing="ij")
    k = np.stack([K1, K2], axis=-1)
    mask = physical_k(k)
    return k[mask], mask


def _consensus_attitude(A: np.ndarray, sd_mrp: float) -> tuple[np.ndarray, np.ndarray]:
    """``(mean (m, 4), χ² (n, m))`` of candidate attitudes ``A`` (n, m, 4) that should agree within the noise: a few may be misregistrations.

    Per column, the candidate with the most others within the outlier quantile
    (ties: the smallest capped cost) is the reference; the mean is taken over
    it and the candidates it agrees with (signs aligned to it), and ``χ²`` is
    every candidate's whitened squared error MRP from that mean.
    """
    n, m = A.shape[:2]
    pair = np.sum(quat_to_mrp(quat_multiply(quat_conjugate(A)[:, None], A[None, :])) ** 2, axis=-1) / sd_mrp**2  # (n, n, m)
    score = np.sum(pair <= OUTLIER_CHI2, axis=1) - np.sum(np.minimum(pair, OUTLIER_CHI2), axis=1) / (n * OUTLIER_CHI2 + 1.0)
    ref = np.argmax(score, axis=0)
    cols = np.arange(m)
    w = pair[ref, :, cols].T <= OUTLIER_CHI2  # (n, m)
    s = np.sign(np.einsum("nmi,mi->nm", A, A[ref, cols]))
    s[s == 0] = 1.0
    mean = quat_normalize(np.einsum("nm,nmi->mi", w * s, A))
    return mean, np.sum(quat_to_mrp(quat_multiply(quat_conjugate(mean)[None], A)) ** 2, axis=-1) / sd_mrp**2


def _local_minima(cost_full: np.ndarray) -> np.ndarray:
    """Flat indices of the grid points whose cost is finite and no larger than their 8 neighbours', lowest first."""
    c = np.pad(cost_full, 1, constant_values=np.inf)
    centre = c[1:-1, 1:-1]
    is_min = np.isfinite(centre)
    for di in (-1, 0, 1):
        for dj in (-1, 0, 1):
            if di or dj:
                is_min &= centre <= c[1 + di:c.shape[0] - 1 + di, 1 + dj:c.shape[1] - 1 + dj]
    idx = np.flatnonzero(is_min)
    return idx[np.argsort(cost_full.ravel()[idx])]


def _grid_step(arc: _Arc, k_step: float, n_sd: float, n_basins: int) -> list[tuple[np.ndarray, np.ndarray]]:
    """Step 1: ``[(row [q_IT, ω, k] (9,) at t_0, used (n,))]`` of the ``n_basins`` lowest grid basins.

    ``used``: the measurements within the outlier quantile of the basin's grid point.
    """
    x0, P0 = arc.x0, arc.L0 @ arc.L0.T
    k, mask = _k_grid(x0[6:8], np.sqrt(np.diag(P0)[6:8]), k_step, n_sd)
    m = k.shape[0]
    dq = arc.forwards(np.concatenate([np.tile([1.0, 0.0, 0.0, 0.0], (m, 1)), np.tile(x0[3:6], (m, 1)), k], axis=1))  # body rotation t_0 → t_i
    dq = np.swapaxes(dq, 0, 1)  # (n, m, 4)
    q0, chi = _consensus_attitude(quat_multiply(arc.q[:, None, :], quat_conjugate(dq)), arc.sd)  # from each measurement's q(t_0)
    Y0 = np.concatenate([q0, np.tile(x0[3:6], (m, 1)), k], axis=1)
    cost = np.sum(np.minimum(chi, OUTLIER_CHI2), axis=0) + np.sum(arc.prior_residuals(Y0) ** 2, axis=1)
    cost_full = np.full(mask.shape, np.inf)
    cost_full[mask] = cost
    order = np.cumsum(mask.ravel()) - 1  # full-grid flat index -> row of k
    best = [int(order[i]) for i in _local_minima(cost_full)[:n_basins]]
    return [(Y0[b], chi[:, b] <= OUTLIER_CHI2) for b in best]


def _refine(arc: _Arc, Y0: np.ndarray, used: np.ndarray, max_nfev: int) -> tuple[np.ndarray, np.ndarray, float, np.ndarray]:
    """Step 2 from one basin: ``(q_IT (4), [ω, k] (5), J, used)`` at the minimum.

    ``J`` is the truncated cost of step 1: each measurement left out (beyond the
    outlier quantile at the minimum, then refitted without it) counts the quantile.
    """
    q_ref, p = Y0[:4], np.concatenate([np.zeros(3), Y0[4:]])
    for _ in range(used.size):
        if np.sum(used) < 2:
            break
        sol = least_squares(lambda v: arc.residuals(v[None], q_ref, used)[0], p, jac=lambda v: arc.jacobian(v, q_ref, used), method="lm", max_nfev=max_nfev)
        p = sol.x
        r = arc.residuals(p[None], q_ref, np.ones_like(used))[0, : 3 * used.size].reshape(-1, 3)
        outliers = np.sum(r**2, axis=1) > OUTLIER_CHI2
        if not np.any(outliers & used):
            q = quat_normalize(quat_multiply(q_ref, mrp_to_quat(p[:3])))
            return q, p[3:], float(2.0 * sol.cost + OUTLIER_CHI2 * np.sum(~used)), used
        used = used & ~outliers
    return Y0[:4], Y0[4:], np.inf, used


def acquire_attitude(t_s, q_IT_meas, attitude_sigma_rad: float, x0, P0, t0_s: float = 0.0, *, k_step: float = 0.025, n_sd: float = 4.0,
                     n_basins: int = 3, max_nfev: int = 60, max_step_s: float = 1.0, max_angle_rad: float = 0.1, orbit=None) -> AttitudeAcquisition | None:
    """The MAP state at ``t0_s`` given the prior ``(x0, P0)`` there and the measured attitudes ``q_IT_meas`` (n, 4) at ``t_s`` (n,).

    None when no basin of the grid fits two or more of the measurements
    (whether the best one fits well enough is :meth:`AttitudeAcquisition.fits`).

    ``attitude_sigma_rad``: 1-σ of the registration's body-frame rotation error
    per axis; ``x0`` (8,) ``[σ_IT, ω_T, k]`` and ``P0`` (8, 8) as
    :class:`estimators.combina.attitude.AttitudeUKF` takes them; ``k_step``
    and ``n_sd`` the grid of step 1 (see the module docstring), ``n_basins``
    the grid minima refined, ``max_nfev`` the evaluations allowed per refinement; ``max_step_s``, ``max_angle_rad`` the
    integration steps (as the filter's); ``orbit`` the servicer's own orbit in orbit (the gravity-gradient torque in the model, as
    :class:`estimators.combina.attitude.AttitudeUKF` has it), None torque-free.
    """
    if not (k_step > 0 and n_sd > 0 and int(n_basins) == n_basins and n_basins >= 1):
        raise ValueError("k_step and n_sd must be positive and n_basins a positive integer")
    arc = _checked_arc(t_s, q_IT_meas, attitude_sigma_rad, x0, P0, t0_s, max_step_s, max_angle_rad, orbit)
    starts = _grid_step(arc, k_step, n_sd, int(n_basins))
    return _best_of(arc, starts, max_nfev)


def _best_of(arc: _Arc, starts: list[tuple[np.ndarray, np.ndarray]], max_nfev: int) -> AttitudeAcquisition | None:
    """Steps 2–3 from ``starts`` = [(row [q_IT, ω, k] (9,) at t_0, used (n,))]: the lowest refined ``J`` and its Laplace covariance."""
    q_best, wk_best, cost_best, used_best = min((_refine(arc, Y0, used, max_nfev) for Y0, used in starts), key=lambda r: r[2])
    if not np.isfinite(cost_best):
        return None
    A = arc.jacobian(np.concatenate([np.zeros(3), wk_best]), q_best, used_best)  # in the chart about the estimate
    P = np.linalg.inv(A.T @ A)
    return AttitudeAcquisition(t_s=arc.t0, x=np.concatenate([quat_to_mrp(q_best), wk_best]), P=0.5 * (P + P.T), cost=cost_best,
                               used=used_best, n_basins=len(starts))


def _checked_arc(t_s, q_IT_meas, attitude_sigma_rad: float, x0, P0, t0_s: float, max_step_s: float, max_angle_rad: float, orbit=None) -> _Arc:
    t = np.asarray(t_s, dtype=float)
    q = quat_normalize(np.asarray(q_IT_meas, dtype=float))
    x0 = np.asarray(x0, dtype=float)
    P0 = np.asarray(P0, dtype=float)
    if t.ndim != 1 or t.size < 2 or q.shape != (t.size, 4):
        raise ValueError(f"t_s must be (n,) with n >= 2 and q_IT_meas (n, 4); got {t.shape} and {q.shape}")
    if not (np.all(np.isfinite(t)) and np.all(np.diff(t) > 0) and t[0] >= t0_s):
        raise ValueError("t_s must be finite, strictly increasing and not before t0_s")
    if x0.shape != (8,) or P0.shape != (8, 8):
        raise ValueError(f"x0 must be (8,) and P0 (8, 8); got {x0.shape} and {P0.shape}")
    if not (np.isfinite(attitude_sigma_rad) and attitude_sigma_rad > 0):
        raise ValueError(f"attitude_sigma_rad must be positive and finite, got {attitude_sigma_rad!r}")
    return _Arc(t, q, attitude_sigma_rad / 4.0, x0, P0, float(t0_s), max_step_s, max_angle_rad, orbit)


#: :class:`LearningRefits`: a refit is due once the filter's largest 1-σ of ``k`` has fallen by this factor since the last fit,
REFIT_FACTOR = 2.0
#: and none is made once a fit has put that 1-σ below this (the UKF's own linearisation is then accurate).
REFIT_STOP_SD_K = 0.01
#: nor before the window holds as many measurements as an acquisition (:meth:`AttitudeAcquisition.fits` counts the
#: measurements' 3 n degrees of freedom, not the prior's 8, which matters only for a few).
MIN_REFIT_MEASUREMENTS = 4


class LearningRefits:
    """Batch refits of the attitude filter's initial state while it learns ``k`` (lcnav's, beyond Maestrini et al.).

    Why. The acquisition pins ``k`` down on a fast tumbler; on a slow one (eq. 47's target, 1.2e-3 rad/s, moments within
    10 % of each other) four measurements leave ``k`` at its prior 1-σ of 0.3, and the UKF learns it over thousands of
    seconds. Its Gaussian one-step updates of ``(ω, k)``, whose joint posterior is curved while ``k`` is uncertain, are
    over-confident, and a filter that is over-confident weighs the later data too little to catch up: on its own model
    (the truth integrated by the filter's own equations, exact Gaussian measurements, no process noise, 60 runs from eq.
    48's ``P_0``) the NEES per state of ``k`` grew from 1.0 to 4.0 over 3000 s and the joint one to 3.0 while ``k``'s 1-σ
    fell from 0.3 to 0.009, the same with sigma points spread by α = 0.1, 0.5 or 1 and with the iterated correction;
    from a ``k`` known to 0.01 the same filter stays at 1.0–1.1.

    What. The MAP initial state at ``t0_s`` given the start's prior ``(x0, P0)`` and every measured attitude the filter
    accepted since (:func:`acquire_attitude`'s cost and Laplace covariance, refined from the last fit and from the filter's
    state integrated back to ``t0_s``, no grid), each time the filter's largest 1-σ of ``k`` has fallen by
    :data:`REFIT_FACTOR` or the window has grown by that factor since the last fit, until a fit puts the 1-σ below
    :data:`REFIT_STOP_SD_K`; the filter restarts from it and predicts through the measurement epochs to the current one.
    Over the same 60 runs, refits at 600, 1200 and 2100 s held the joint NEES per state at 1.0–1.1 after the last of them;
    between two refits the filter drifts over-confident again (30 runs at 1360 s: 1.4 per state, against 4.5 without
    refits; ``tests/estimators/test_combina_acquisition.py``). Few fits are made (8–10 over an orbit of eq. 47's target),
    each of the arc so far; once ``k`` is known none is, and the filter's cost per step is flat again. The fit is of the
    deterministic model (eqs 28–29): it is right where the filter's process model is (the torque-free truth, or the model
    of the truth's torques the filter carries).
    """

    def __init__(self, t0_s: float, x0, P0, attitude_sigma_rad: float, *, fitted: AttitudeAcquisition | None = None, factor: float = REFIT_FACTOR,
                 stop_sd_k: float = REFIT_STOP_SD_K, max_nfev: int = 60, max_step_s: float = 1.0, max_angle_rad: float = 0.1, orbit=None):
        self.t0_s = float(t0_s)
        self.x0 = np.asarray(x0, dtype=float)
        self.P0 = np.asarray(P0, dtype=float)
        if self.x0.shape != (8,) or self.P0.shape != (8, 8):
            raise ValueError(f"x0 must be (8,) and P0 (8, 8); got {self.x0.shape} and {self.P0.shape}")
        if not (np.isfinite(factor) and factor > 1 and np.isfinite(stop_sd_k) and stop_sd_k > 0):
            raise ValueError(f"factor must exceed 1 and stop_sd_k be positive; got {factor!r}, {stop_sd_k!r}")
        self.sigma = float(attitude_sigma_rad)
        self.factor, self.stop_sd_k, self.max_nfev = float(factor), float(stop_sd_k), int(max_nfev)
        self.steps = (max_step_s, max_angle_rad)
        self.orbit = orbit
        # the last fit (the acquisition the window starts from, if any): its x at t0_s, k's 1-σ and number of measurements
        self.fitted = self.x0.copy() if fitted is None else fitted.x.copy()
        self.sd_k_fit = _sd_k(self.P0 if fitted is None else fitted.P)
        self.n_fitted = 0 if fitted is None else int(fitted.used.size)
        self.t_s: list[float] = []
        self.q_IT: list[np.ndarray] = []
        self.n_fits = 0

    def add(self, t_s: float, q_IT_meas) -> None:
        """A measured attitude the filter accepted at ``t_s``."""
        self.t_s.append(float(t_s))
        self.q_IT.append(np.asarray(q_IT_meas, dtype=float))

    def due(self, P_filter) -> bool:
        """Whether the filter (its covariance ``P_filter``) has learned enough ``k`` since the last fit for a new one."""
        if len(self.t_s) < MIN_REFIT_MEASUREMENTS or self.sd_k_fit <= self.stop_sd_k:
            return False
        return _sd_k(P_filter) <= self.sd_k_fit / self.factor or len(self.t_s) >= self.factor * self.n_fitted

    def refit(self, x_filter) -> AttitudeAcquisition | None:
        """The MAP initial state given every measurement added, started from the last fit and from the filter's estimate
        ``x_filter`` (8,) ``[σ_IT, ω, k]`` at the last measurement's epoch integrated back to ``t0_s``; None if no start converges
        or the best fit fails :meth:`AttitudeAcquisition.fits` (χ² at 99.9 %, at most one measurement in 20 left out)."""
        arc = _checked_arc(self.t_s, self.q_IT, self.sigma, self.x0, self.P0, self.t0_s, *self.steps, self.orbit)
        x_filter = np.asarray(x_filter, dtype=float)
        back = np.concatenate([mrp_to_quat(x_filter[:3]), x_filter[3:]])[None]
        edges = np.concatenate([[self.t0_s], arc.t])
        for i in range(arc.t.size - 1, -1, -1):  # interval by interval, as the filter predicted it (t_s is the last epoch)
            back = propagate_rigid_body(back, edges[i] - edges[i + 1], max_step_s=self.steps[0], max_angle_rad=self.steps[1], gravity_gradient=arc.gg[i])
        back = back[0]
        last = np.concatenate([mrp_to_quat(self.fitted[:3]), self.fitted[3:]])
        used = np.ones(arc.t.size, dtype=bool)
        fit = _best_of(arc, [(last, used), (back, used)], self.max_nfev)
        if fit is not None and not fit.fits(max_outliers=max(1, arc.t.size // 20)):
            return None  # no rigid body of the model fits the window (an axisymmetric target's random roll): no restart
        if fit is not None:
            self.fitted, self.sd_k_fit, self.n_fitted = fit.x, _sd_k(fit.P), arc.t.size
            self.n_fits += 1
        return fit


def _sd_k(P) -> float:
    """The largest 1-σ of ``k`` in an attitude covariance (8, 8)."""
    return float(np.sqrt(np.max(np.diag(np.asarray(P))[6:8])))
