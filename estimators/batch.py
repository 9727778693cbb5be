"""The full-information posterior of the relative state: a batch fit of every accepted measurement.

Why (issue 12, measured with 30 runs on SC3 from the default ``P_0``): the
EKF and the UKF linearise each step once, about their estimate of the moment,
and never revisit it. The inertia ratios make that fatal: ``k1 + k2 = ln(A/C)``
drives ``ω̇_y = (C − A)/B ω_x ω_z`` through ``e^k1 − e^−k2``, a difference of
two numbers near 4.3, while ``k1 − k2`` acts only through ``ω_y ≈ 0``, so the
posterior of ``k`` is a curved ridge (a "banana"). Started from errors of the
size of a converged filter (0.02 rad, 1e-3 rad/s, 0.1 on ``k``) with
``Q_d = 0``, both filters drift over-confident (NEES/dof of ``k`` 1.4 → 2.5
over 300 s; 0.3 on ``k``: they diverge), and no constant ``Q_d`` is both safe
and honest (:mod:`estimators.tuning`). The truth has no process noise, so
the whole trajectory is fixed by its initial state, ``x_k = f^k(x_0)``, and the
posterior of ``x_0`` given the prior ``N(x̂_0, P_0)`` and the measurements
``z_j`` (covariance ``R_j``, at grid step ``k_j``) is, up to a constant,

``−2 log p(x_0 | z) = ‖x_0 ⊟ x̂_0‖²_{P_0⁻¹} + Σ_j ‖z_j ⊟ h_j(f^{k_j}(x_0))‖²_{R_j⁻¹}``.

:func:`posterior` minimises it by Gauss–Newton with Levenberg–Marquardt
damping (Nocedal & Wright, §10.3) on ``x_0 = x_ref ⊞ δ``: every residual is
linearised through the error-state transition ``Φ_k`` of the whole trajectory
(:meth:`~estimators.process_model.RelativeProcessModel.trajectory`), giving the
normal equations ``A δ = b`` with ``A = P_0⁻¹ + Σ Φᵀ Hᵀ R⁻¹ H Φ``. With
``Q_d = 0`` this is the iterated extended Kalman smoother of Bell (1994): it
re-linearises *every* residual about the *current* best trajectory. The
Laplace covariance of ``x_0`` is ``A⁻¹`` at the minimum, that of the last state
``Φ A⁻¹ Φᵀ``. The prior's chart is taken as additive in ``δ`` (its attitude
term is second order once the data dominate it, after a few seconds).

Two refinements, each measured on SC3 (30 runs, seeds 1000–1029, mean NEES/dof
of the last state, 14 dof, band 0.87–1.14):

* *Quadrature along the weak inertia direction.* While the posterior's
  largest ``k`` standard deviation ``σ_u`` exceeds :data:`WEAK_SIGMA`, its
  Laplace approximation is over-confident (1.93 at 60 s, 2.32 at 80 s, 1.12 at
  100 s): along the ridge the well-determined combination of ``k1, k2`` turns.
  The posterior *mean and covariance* are then computed instead
  (Rao–Blackwellised): on :data:`NODES` values of the weak coordinate
  (``σ_u`` apart) the other 13 error states are fitted conditionally (a
  Gaussian given the node, their problem being nearly linear), each node
  weighted by its marginal likelihood ``exp(−½ cost) |Aᶜ|^{−½}``, and the
  moments are those of the mixture: 1.07, 1.05, 1.01 at 60, 80, 100 s.
  The trapezoid rule on a smooth, decaying density with nodes one standard
  deviation apart is accurate to ~1e-8 for a Gaussian, so 9 nodes suffice.
* *The Laplace approximation tested, not assumed* (found on SC1-near-axis:
  SC1 with 1e-4 rad/s off the intermediate spin axis, ``k`` estimated, data
  nobody tuned on). There the rate's growth ``e^{λ(k) t}`` makes the
  posterior curved along *both* inertia directions for the first 100–170 s,
  and the curvature at the mode can be much sharper than the posterior is
  wide: seed 1000 at 60 s had a Laplace ``σ`` of 0.05 along ``k``'s strong
  direction and an error of 0.24 along it (NEES/dof 58; seed 1007 at 80 s:
  135). Every fit that estimates ``k`` therefore tests both eigen-directions
  of its ``k`` covariance by the profile of the cost (the other 13 error
  states re-fitted at ``±4σ``: a Gaussian's cost has risen by 16 there). A
  direction whose cost rises by less than :data:`PROFILE_RISE` (12) joins the
  quadrature, as does one with ``σ > WEAK_SIGMA``; the reach of its nodes
  is then doubled (at most :data:`MAX_EXTENT` σ) until the cost has risen by
  12 there, and the nodes spread out to it with the mode's resolution kept
  (:class:`_StretchedAxis`), so that they cover the posterior rather than the
  mode's curvature; with two directions, a 2-D grid (:data:`NODE_SPACING`).
  The filter considers the integrated directions until the next fit.
  Fits at 60 and 80 s on SC1-NEAR-AXIS, 24 draws: mean NEES/dof 4.36
  (worst 40.5) with the weak direction only, 0.90 and 1.08 with the test
  (``tests/estimators/test_batch.py``).
* *Restarts across the inertia prior* (:func:`_restart_over_inertia`): each
  fit starts from the previous one, and near the intermediate axis the cost
  has more than one basin in ``k``; a fit that estimates ``k`` also starts
  from :data:`RESTARTS` values of ``k`` across its prior and keeps the lowest
  cost. SC1-NEAR-AXIS at 130 s from a wrong basin, seeds 1025/1000/1001:
  NEES/dof 6.45, 8.11, 5.8e7 without, 1.49, 0.78, 1.01 with them.
* *Considered states* (``k`` in a one-axis tumble, where it does not move
  the state): held at the prior, with the consider covariance of Tapley,
  Schutz & Born (2004, §6.3), ``C_ee = A_ee⁻¹ + S P_cc Sᵀ``,
  ``S = −A_ee⁻¹ A_ec``. SC1 and SC2 spin about the intermediate axis
  (``A = 4.33 > C = 4.22 > B = 1``), so the fitted trajectory's sensitivity to
  a held, wrong ``k`` grows like ``e^{λt}`` (``λ ≈ 0.01–0.04 /s`` on SC1,
  0.06–0.16 /s on SC2). On SC2 the consider term reached 1e16 by 170 s; a fit
  whose consider term exceeds an estimated state's prior variance is
  therefore not used (the held states, not the data, decide it). Estimating
  ``k`` and putting it back to the prior afterwards (the Schmidt form of one
  batch update) was tried: no blow-up on SC2, but SC1 went from 99 % of the
  steps in band to 19 % (mean NEES/dof 1.19): the fit learns ``k`` from the
  same sensitivity and the estimated states with it.

*The fit's own outlier screen.* The filters' gates reject an innovation
beyond its 99 % bound, i.e. mostly when the filter is off: a fit of only the
accepted measurements lacked exactly those that disagreed with the filter,
and was over-confident (SC3, seeds 1000–1029, 300 s, mean NEES/dof 1.11 and
87 % of the steps in band; fitting every measurement, 1.05 and 95 %). The fit
starts from the gates' verdicts, then keeps the measurements whose residual
against its own trajectory passes :data:`SCREEN_QUANTILE`, and refits.
Starting from the verdicts can lock a lost filter out for good: its gates
reject every measurement that disagrees with it, and a fit of the few that
pass explains those and screens the rest out again (SC3 perturbed, UKF, 5-s
measurements, seed 3013: from 50 s the fixed-lag windows kept 9–12 of their
~60 degrees of freedom, passed their test, and the run ended at NEES/dof
1512). A fit that keeps less than :data:`CONSENSUS` of all the window's
measurements is therefore redone from every one of them, gate-rejected ones
included (the same screen then drops the outliers), and that fit is used if
it passes its test keeping more of them: the trajectory that explains more
of the data. On that run the windows then kept all their measurements from
20 s on and the run ended at NEES/dof 0.66 (NIS/dof 0.94, 0.89).

*A prior that contradicts the data.* §6 of Renis et al. starts the filters
from a fixed guess (``r = 0`` with the target 50 m away, ``q_TS = 1``) that the
default ``P_0`` (1 m on the position) does not describe; the filters recover
from it within a few measurements, but as a term of the fit it would pull the
whole trajectory 50 σ towards it. A component of the fitted initial state more
than :data:`PRIOR_Z` prior standard deviations from the prior mean (5 σ: a
chance of 6e-7 when the prior is right, so the draws of a consistent prior
never trip it) has its prior made nearly flat and the fit is redone; the data
alone determine the attitude, the position and their rates within seconds.

A fit whose minimum cost exceeds the 99.9 % quantile of its chi-square (the
measurements' degrees of freedom) has not found the data's trajectory (a
local minimum from a poor start): :attr:`BatchPosterior.usable` says so, and
the caller keeps its filter's estimate. So has a fit whose screen left no
measurement at all (every residual beyond its bound: the trajectory is far
from all the data). Its cost is then 0 with 0 degrees of freedom, which the
test used to pass as ``χ²(1)``; its covariance is the prior's run forward with
no data, and on SC3 with a light-curve prior about the wrong axis (5°/s about
``z_T``, 550 σ from the truth) such fits at 120, 180 and 190 s reset the EKF to
rate standard deviations of 1e4 rad/s; the next prediction's sigma points
could not factor that ``P`` ("11-th leading minor … not positive definite").
Likewise a fit whose screen kept less than :data:`SCREEN_MIN_KEPT` of the
measurements the gates accepted (on the same run, at 160 and 200 s: 30 and 15
of ~1000 degrees of freedom, "passing" with rate σ of 1e-3 and velocity σ of 35 m/s).

The per-component test above does not catch such a spin prior: held 550 σ
off (σ 7.7e-5 rad/s), the rate stays within 5 σ of it and the fit bends the
inertia ratios instead, and fails its chi-square test at every time; the
filter, reset by only two fits (40 and 50 s), diverged by 148 s. A prior whose parts stand or fall
together (a light curve's rate about an assumed axis) is therefore named
``suspect``: a fit that fails its test is redone whole with that block nearly
flat, and used if it passes (``prior_flattened`` then names the block). On
that run the refit at 10 s passes (cost 19.7 for 39 dof, against 71.7 for 33
with the prior) at a relative rate of 3.3°/s (2.9°/s at 20 s; the truth's
2.82°/s, the prior's 5.0°/s), and the 300-s run ends with the rate's RMSE
0.0016 rad/s from 10 s on, every fit from 10 s passing this way.

*Process noise* (a moving window, issue 31: :class:`estimators.navigation._Relinearization` with ``lag_s``;
``posterior``'s ``Q``). A truth with unmodelled physics (gravity gradient, J2, drag, nutation damping) is not
fixed by its initial state: ``x_{k+1} = f(x_k) ⊞ w_k``, ``w_k ~ N(0, Q)`` per step (``Q``: the disturbance
budget's ``Q_d``, :mod:`estimators.process_noise`). The fit keeps the window's trajectory deterministic and
lets ``Q`` enter twice:

1. Each measurement's noise is inflated by the process noise accumulated from the window's start to its step,
   mapped through ``H``: ``R_j' = R_j + H_j Σ_{k_j} H_jᵀ``, ``Σ_{k+1} = F_k Σ_k F_kᵀ + Q``, ``Σ_0 = 0`` (the
   ``F_k`` along the prior's trajectory, fixed during the fit). Exact for each residual's *marginal* variance
   (to first order); it ignores the correlation of the accumulated noise between residuals
   (``Cov(w̄_i, w̄_j) = Φ(k_j, k_i) Σ_{k_i}`` for ``k_i ≤ k_j``), so the fitted trajectory is not the smoother's.
   It serves what the fit decides: where the window's trajectory lies (the re-linearisation point), the
   screen and the chi-square test, which a deterministic trajectory fails once the disturbance's drift over
   the window exceeds the measurement noise.
2. The last state's moments are then the Kalman recursion with ``Q`` along the fitted trajectory, from the
   prior at the window's start (:func:`_end_moments`): ``P⁻ = F P Fᵀ + Q``, and the mean's correction ``δ``
   carried with it. That recursion is linear in the data given the reference trajectory, so on a linear model
   it *is* the Kalman filter, whatever the reference: the approximation of 1. then does not reach the
   estimate at all (``tests/estimators/test_fixed_lag.py``: equal to 1e-9). On the nonlinear model it
   is one forward pass of the iterated extended Kalman smoother (Bell 1994) about the fit. With the weak-direction
   quadrature the process noise's part is added to the mixture's moments as the difference of the recursion with
   and without ``Q`` at the mode (an approximation: the nodes' own recursions are not redone).

References
----------
.. [1] Bell, *The iterated Kalman smoother as a Gauss–Newton method*, SIAM J. Optim. 4(3), 1994.
.. [2] Nocedal, Wright, *Numerical Optimization*, 2nd ed., Springer, 2006, §10.3.
.. [3] Tapley, Schutz, Born, *Statistical Orbit Determination*, Elsevier, 2004, §6.3 (consider covariance).
"""

from __future__ import annotations

import copy
import dataclasses
from dataclasses import dataclass

import numpy as np
from scipy.optimize import brentq
from scipy.stats import chi2

from estimators.filter import _block_diag

#: Largest ``k`` standard deviation (along the weak direction) at which the Laplace covariance is trusted.
WEAK_SIGMA = 0.05
#: Profile test of the Laplace approximation along an inertia direction (:func:`_profile_extent`): at 4 standard
#: deviations a Gaussian's cost (``−2 log p``) has risen by 16; below ``PROFILE_RISE`` (a posterior ≥ 1.15 times wider
#: than the curvature at the mode says) the direction is integrated by quadrature as well, its nodes spread out to where
#: the cost has risen by ``PROFILE_RISE``, at most ``MAX_EXTENT`` Laplace standard deviations.
PROFILE_RISE = 12.0
MAX_EXTENT = 32.0
#: Quadrature nodes along the weak inertia direction, in its standard deviations.
NODES = np.arange(-4.0, 5.0)
#: The nodes' spacing (in the quadrature's coordinates ξ, Laplace standard deviations near the mode) with one weak
#: direction (9 nodes, −4…4) and with two (29 nodes: the grid of spacing 4/3 within radius 4; at spacing 1, 49
#: conditional fits made a 300-s SC1-near-axis run take 95 s). The truncated trapezoid rule's variance of a unit
#: Gaussian: 0.99993 at spacing 1, 0.9993 at 4/3 (0.86 at 2).
NODE_SPACING = (1.0, 4.0 / 3.0)
#: Levenberg–Marquardt: most iterations, and the decrease of the cost (``−2 log p``, χ² units) that counts as converged:
#: 1e-3 changes a quadrature weight by 0.05 %.
MAX_ITERATIONS = 30
COST_TOL = 1e-3
#: Where in ``k`` (prior standard deviations from the prior mean) a fit that estimates ``k`` also starts
#: (:func:`_restart_over_inertia`): the prior mean and ±1.5 σ along each of ``k1``, ``k2``.
RESTARTS = np.array([[0.0, 0.0], [1.5, 0.0], [-1.5, 0.0], [0.0, 1.5], [0.0, -1.5]])
#: Chi-square quantile above which a fit's minimum is not the data's trajectory.
FIT_QUANTILE = 0.999
#: A fit that keeps less than this fraction (degrees of freedom) of all the window's measurements is redone from every
#: measurement of the window, gate-rejected ones included, and that fit used if it passes keeping more (module docstring).
CONSENSUS = 0.5
#: A measurement whose whitened residual against the fitted trajectory exceeds this chi-square quantile is left out of
#: the fit (1e-4 of good ones; a fault of 1.5 rad or 20 m is 20–400 times the bound); at most SCREEN_PASSES refits.
SCREEN_QUANTILE = 0.9999
SCREEN_PASSES = 3
#: Least fraction (in degrees of freedom) of the gate-accepted measurements a usable fit keeps after its screen: a 120-s
#: fault in a 300-s run is 40 % of them, a fit near the data's trajectory leaves out ~1e-4 (:func:`_passes`).
SCREEN_MIN_KEPT = 0.5
#: Floor of the covariance's eigenvalues relative to its largest (:func:`_factorable`).
EIGEN_FLOOR = 1e-14
#: A fitted initial state this many prior standard deviations from the prior mean in one component contradicts the prior
#: there; that component's prior variance is then multiplied by :data:`FLAT_PRIOR_SCALE` (nearly flat) and the fit redone.
PRIOR_Z = 5.0
FLAT_PRIOR_SCALE = 1e6


class BatchFitError(ValueError):
    """The fit could not start: the trajectory from its starting point is not finite."""


class MeasurementHistory:
    """The measurements a filter took, by source, with its gate's verdicts: what :func:`posterior` fits.

    ``add(k, source, z, accepted)`` records measurement ``z`` of ``source`` (an
    object with ``R``, ``residual(Z, X)`` and ``jacobians(X)``,
    :mod:`estimators.measurement`) taken at grid step ``k``, and whether the
    filter's gate accepted it. The fit starts from those verdicts and then
    screens every measurement against its own trajectory (:data:`SCREEN_QUANTILE`).
    """

    def __init__(self):
        self._rows: dict[int, tuple[object, list, list, list]] = {}

    def add(self, k: int, source, z, accepted: bool = True) -> None:
        entry = self._rows.setdefault(id(source), (source, [], [], []))
        entry[1].append(int(k))
        entry[2].append(np.asarray(z, dtype=float))
        entry[3].append(bool(accepted))

    def __len__(self) -> int:
        return sum(len(ks) for _, ks, _, _ in self._rows.values())

    def prune(self, k_keep: int) -> None:
        """Forget the measurements at steps ``k ≤ k_keep`` (a moving window's prior holds them): memory bounded by the window."""
        for key, (src, ks, zs, acc) in list(self._rows.items()):
            first = int(np.searchsorted(np.asarray(ks), int(k_keep), side="right"))  # steps are added in order
            if first == len(ks):
                del self._rows[key]
            elif first:
                self._rows[key] = (src, ks[first:], zs[first:], acc[first:])

    def groups(self, k_start: int, k_end: int):
        """``(source, ks, Z, accepted)`` per source, for steps ``k_start < k ≤ k_end``, ``ks`` counted from ``k_start``."""
        for src, ks, zs, acc in self._rows.values():
            ks_a = np.asarray(ks)
            keep = (ks_a > k_start) & (ks_a <= k_end)
            if keep.any():
                yield src, ks_a[keep] - k_start, np.asarray(zs)[keep], np.asarray(acc)[keep]


@dataclass(frozen=True)
class BatchPosterior:
    """The posterior at the last fitted step.

    ``x`` (n_state,) and ``P`` (n_error, n_error): its mean and covariance
    (the mode and the Laplace covariance unless ``nodes > 0``); ``x0``: the
    fitted state at the prior's step (mode), the start of the next fit;
    ``cost``: the minimum of ``−2 log p`` (measurement and prior terms),
    ``dof`` the measurements' degrees of freedom; ``iterations``: accepted
    Levenberg–Marquardt steps; ``nodes``: quadrature nodes along the weak
    inertia direction (0: Laplace). ``usable``: ``cost`` below the
    :data:`FIT_QUANTILE` of ``χ²(dof)`` (else a local minimum or an
    unmodelled error) and no consider term beyond an estimated state's prior
    variance.
    """

    x: np.ndarray
    P: np.ndarray
    x0: np.ndarray
    cost: float
    dof: int
    usable: bool
    iterations: int
    nodes: int
    prior_flattened: tuple[int, ...] = ()  #: error-state indices whose prior contradicted the data (:data:`PRIOR_Z`)
    #: the weak inertia directions the quadrature integrated over, as rows (d, n_error); ``None`` without quadrature
    weak_directions: np.ndarray | None = None
    #: degrees of freedom of the measurements the filter's gates accepted (``dof``: of those the fit's screen kept)
    offered: int = 0


@dataclass(frozen=True)
class _Linearisation:
    """The residuals at a start ``x0``, whitened, and (with a Jacobian) their rows ``J`` in the error of ``x0``.

    Kept as rows rather than as the normal matrix ``A = Jᵀ J``: ``Φ`` spans
    1e-5…1e5 (rate errors move positions by ``50 m × t``), so ``A`` spans the
    square of that and its Cholesky factor failed on SC2 (0.2 rad/s), while
    the QR factor of ``J`` has the conditioning of ``J``.
    """

    J: np.ndarray | None  #: (rows, n_error): whitened residual Jacobians, the prior's rows first
    y: np.ndarray  #: (rows,): whitened residuals (prior: ``−P_0^{−½}(x0 ⊟ x̂_0)``)
    cost: float  #: ``yᵀ y``
    x_end: np.ndarray
    Phi_end: np.ndarray | None

    def step(self, E: np.ndarray, lam: float) -> np.ndarray | None:
        """The Levenberg–Marquardt step ``E d`` of ``(EᵀAE + λ diag(EᵀAE)) d = Eᵀ Jᵀ y``; ``None`` if it is not finite.

        A restart far out in ``k`` on a fast tumble (SC4) can have rows of ``J``
        whose squares overflow ``EᵀAE``: that step is refused like one that
        raises the cost (the caller increases ``λ``).
        """
        JE = self.J @ E
        with np.errstate(over="ignore", invalid="ignore"):
            AE = JE.T @ JE
            try:
                d = E @ np.linalg.solve(AE + lam * np.diag(np.diag(AE)), JE.T @ self.y)
            except np.linalg.LinAlgError:
                return None
        return d if np.all(np.isfinite(d)) else None

    def root(self, E: np.ndarray) -> tuple[np.ndarray, float]:
        """``(G, log|EᵀAE|)`` with ``G Gᵀ = (EᵀAE)⁻¹``, from the QR factor ``R`` of ``J E`` (``G = R⁻¹``)."""
        R = np.linalg.qr(self.J @ E, mode="r")
        return np.linalg.inv(R), 2.0 * float(np.sum(np.log(np.abs(np.diag(R)))))


class _Problem:
    """The cost of :func:`posterior` and its Gauss–Newton pieces, for one data set."""

    def __init__(self, model, servicer, history: MeasurementHistory, x0_prior, P0, k_start: int, k_end: int, dt: float, keep=None, Q=None):
        """``keep``: per source (in ``history``'s order) the mask of the measurements to fit; default the gate's verdicts.

        ``Q`` (n_error, n_error): the process noise per step inside the window, or ``None`` (deterministic); each
        measurement's ``R_j`` is then inflated by :func:`_process_noise_at` (module docstring, *Process noise*).
        """
        self.model, self.dt = model, float(dt)
        self.servicer = np.asarray(servicer, dtype=float)[int(k_start) : int(k_end)]
        self.x0_prior = np.asarray(x0_prior, dtype=float)
        self.P0 = np.asarray(P0, dtype=float)
        self.Q = None if Q is None or not np.any(Q) else np.asarray(Q, dtype=float)
        self.prior_root = _inverse_root(0.5 * (self.P0 + self.P0.T), "the window's prior covariance")  # P_0⁻¹ = L Lᵀ: prior rows Lᵀ δ
        rows = list(history.groups(int(k_start), int(k_end)))
        # every measurement, whitened: (source, ks, Z, L) with R⁻¹ = L Lᵀ (residual rows Lᵀ y); with process noise one L per measurement
        if self.Q is None:
            self.every = [(src, ks, Z, np.linalg.cholesky(np.linalg.inv(src.R))) for src, ks, Z, _ in rows]
        else:
            X, _, F = model.trajectory(self.x0_prior, self.servicer, self.dt)
            Sigma = _process_noise_at(F, self.Q)
            self.every = [(src, ks, Z, _inflated_root(src.R, _sandwich(src.jacobians(X[ks]), Sigma[ks]))) for src, ks, Z, _ in rows]
        #: degrees of freedom of every measurement of the window, whatever the gates or the screen said
        self.every_dof = int(sum(len(ks) * src.R.shape[0] for src, ks, _, _ in self.every))
        self._select([acc for *_, acc in rows] if keep is None else keep)

    def _select(self, keep) -> None:
        self.keep = keep
        self.groups = [(src, ks[m], Z[m], L if L.ndim == 2 else L[m]) for (src, ks, Z, L), m in zip(self.every, self.keep) if m.any()]
        self.dof = int(sum(len(ks) * src.R.shape[0] for src, ks, _, _ in self.groups))

    def with_keep(self, keep) -> _Problem:
        """The same problem fitting the measurements ``keep`` (per source, a mask over ``every``)."""
        out = copy.copy(self)
        out._select(keep)
        return out

    def screen(self, x0) -> list[np.ndarray]:
        """Per source, the measurements whose whitened residual against the trajectory from ``x0`` passes :data:`SCREEN_QUANTILE`."""
        X = self.model.trajectory(x0, self.servicer, self.dt, jacobian=False)[0]
        out = []
        for src, ks, Z, L in self.every:
            Yw = _whiten(src.residual(Z, X[ks]), L)
            out.append(np.sum(Yw * Yw, axis=1) <= chi2.ppf(SCREEN_QUANTILE, src.R.shape[0]))
        return out

    def linearise(self, x0, jacobian: bool = True) -> _Linearisation | None:
        """Residuals at ``x0`` and, with ``jacobian``, their rows; ``None`` if the trajectory or its Jacobian is not finite."""
        with np.errstate(over="ignore", invalid="ignore"):
            X, Phi, _ = self.model.trajectory(x0, self.servicer, self.dt, jacobian=jacobian)
            if not (np.all(np.isfinite(X)) and (Phi is None or np.all(np.isfinite(Phi[-1])))):
                return None
            n = self.P0.shape[0]
            ys = [-self.prior_root.T @ self.model.boxminus(x0, self.x0_prior)]
            Js = [self.prior_root.T] if jacobian else []
            for src, ks, Z, L in self.groups:
                ys.append(_whiten(src.residual(Z, X[ks]), L).reshape(-1))  # rows of Lᵀ y
                if jacobian:
                    Js.append(np.einsum("ji,njk->nik" if L.ndim == 2 else "nji,njk->nik", L, src.jacobians(X[ks]) @ Phi[ks]).reshape(-1, n))
            y = np.concatenate(ys)
            J = np.vstack(Js) if jacobian else None
            cost = float(y @ y)
            if not (np.isfinite(cost) and (J is None or np.all(np.isfinite(J)))):
                return None
        return _Linearisation(J, y, cost, X[-1], Phi[-1] if jacobian else None)

    def minimise(self, x0, E: np.ndarray) -> tuple[np.ndarray, _Linearisation, int]:
        """Levenberg–Marquardt on ``x0 ⊞ E d`` (``E``: n_error × m, the free directions); returns ``(x0, lin, steps)``."""
        lin = self.linearise(x0)
        if lin is None:
            raise BatchFitError("the trajectory from the fit's start is not finite")
        lam, steps = 1e-6, 0
        for _ in range(MAX_ITERATIONS):
            d = lin.step(E, lam)
            x_new = None if d is None else self.model.boxplus(x0, d)
            trial = None if d is None else self.linearise(x_new, jacobian=False)
            if trial is not None and trial.cost <= lin.cost and lin.cost - trial.cost < COST_TOL:
                # converged: keep the Jacobian of the last (tiny) step's start
                return x_new, _Linearisation(lin.J, trial.y, trial.cost, trial.x_end, lin.Phi_end), steps + 1
            new = self.linearise(x_new) if trial is not None and trial.cost <= lin.cost else None
            if new is not None:
                x0, lin, steps, lam = x_new, new, steps + 1, max(lam / 10.0, 1e-12)
            else:
                lam *= 10.0
                if lam > 1e12:
                    break
        return x0, lin, steps


def _whiten(Y: np.ndarray, L: np.ndarray) -> np.ndarray:
    """Residual rows ``Y (n, d)`` whitened, ``Lᵀ y`` per row: by one ``L (d, d)`` or by each measurement's own ``L (n, d, d)``."""
    return Y @ L if L.ndim == 2 else np.einsum("nj,nji->ni", Y, L)


def _sandwich(H: np.ndarray, S: np.ndarray) -> np.ndarray:
    """``H_j S_j H_jᵀ`` for stacks ``H (n, d, m)``, ``S (n, m, m)``: (n, d, d)."""
    return np.einsum("nij,njk,nlk->nil", H, S, H)


def _inflated_root(R: np.ndarray, S: np.ndarray) -> np.ndarray:
    """``L (n, d, d)`` with ``L_j L_jᵀ = (R + S_j)⁻¹``: ``L_j = C_j⁻ᵀ``, ``C_j`` the Cholesky factor of ``R + S_j``.

    Factored directly rather than through ``(R + S_j)⁻¹`` (whose Cholesky factor failed on SC1, where ``Φ`` grows like
    ``e^{λt}`` and ``S_j`` spans decades); ``R + S_j ≥ R`` is positive definite once ``S_j`` is symmetrised.
    """
    S = 0.5 * (S + np.swapaxes(S, -1, -2))
    if not np.all(np.isfinite(S)):
        raise BatchFitError("the process noise accumulated along the prior's trajectory is not finite")
    # S_j may span more decades than double precision holds (a window's trajectory run off)
    return _inverse_root(R + S, "the process noise accumulated along the prior's trajectory")


def _inverse_root(A: np.ndarray, what: str) -> np.ndarray:
    """``L`` (stacked like ``A``) with ``L Lᵀ = A⁻¹``: ``L = C⁻ᵀ``, ``C`` the Cholesky factor of the symmetric ``A``.

    Factored directly: ``A⁻¹`` of a covariance whose eigenvalues span many decades (the window's prior after an orbit without
    process noise, ``k`` considered: the SC1 torque-free runs of ``python -m benchmarks truths``) rounds to a matrix that is not
    positive definite, while ``A`` itself still factors. :class:`BatchFitError` (the filter goes on without the fit) when
    ``A`` is not positive definite to machine precision either."""
    try:
        C = np.linalg.cholesky(A)
    except np.linalg.LinAlgError:
        raise BatchFitError(f"{what} is not positive definite to machine precision") from None
    return np.swapaxes(np.linalg.inv(C), -1, -2)


def _process_noise_at(F: np.ndarray, Q: np.ndarray) -> np.ndarray:
    """``Σ_k = Σ_{i<k} Φ(k, i+1) Q Φ(k, i+1)ᵀ`` (N+1, n, n): the process noise accumulated from the window's start to step ``k``.

    ``F (N, n, n)``: the steps' error-state transitions along the prior's trajectory; ``Q``: the noise per step.
    The recursion ``Σ_{k+1} = F_k Σ_k F_kᵀ + Q``, ``Σ_0 = 0`` (module docstring, *Process noise*).
    """
    Sigma = np.zeros((len(F) + 1,) + Q.shape)
    for k in range(len(F)):
        Sigma[k + 1] = F[k] @ Sigma[k] @ F[k].T + Q
    return Sigma


def _initial_root(lin: _Linearisation, P0: np.ndarray, est: np.ndarray, con: np.ndarray) -> np.ndarray:
    """A root ``G`` of the fitted initial state's covariance, ``C = G Gᵀ``: ``A_ee⁻¹`` plus the considered states' part.

    Consider covariance (Tapley et al. §6.3): ``C_ee = A_ee⁻¹ + S P_cc Sᵀ``,
    ``C_ec = S P_cc``, ``C_cc = P_cc`` with ``S = −A_ee⁻¹ A_ec``, i.e.
    ``G = [E_e A_ee^{−½}, (E_e S + E_c) P_cc^{½}]``. ``A`` holds the prior's
    rows too, so a prior that correlates the held and the estimated states
    (a filter's estimate as the prior of a later fit) enters ``S`` through
    ``(P⁻¹)_ec``. Covariances are carried as roots: ``Φ C Φᵀ`` formed directly
    lost definiteness on SC1 (an eigenvalue of −1e-17 where the filter's own
    was 5e-12), ``(Φ G)(Φ G)ᵀ`` is a Gram matrix.
    """
    n = lin.J.shape[1]
    E = np.eye(n)
    Ge, _ = lin.root(E[:, est])
    G = E[:, est] @ Ge
    if con.size:
        S = -Ge @ (Ge.T @ (lin.J[:, est].T @ lin.J[:, con]))
        G = np.hstack([G, (E[:, est] @ S + E[:, con]) @ np.linalg.cholesky(P0[np.ix_(con, con)])])
    return G


def _weak_quadrature(problem: _Problem, x0: np.ndarray, lin: _Linearisation, G0: np.ndarray, k_idx: np.ndarray):
    """``(x, P, U, nodes)``: mean and covariance of the last state by quadrature over the weak inertia directions; ``None`` when not needed.

    ``G0``: a root of the Laplace covariance of the initial state; ``k_idx``:
    the error-state indices of ``k1, k2``. The weak directions ``U`` (d, n_error)
    are the eigenvectors of the ``k`` block whose Laplace standard deviation
    exceeds :data:`WEAK_SIGMA` or along which the Laplace approximation fails
    its profile test (:func:`_profile_extent`), d = 1 or 2. The nodes lie on a
    grid of spacing :data:`NODE_SPACING` within radius 4 in coordinates ``ξ``
    that are the Laplace standard deviations near the mode and stretch
    outwards (:class:`_StretchedAxis`) so that ``ξ = ±4`` reaches where the
    profile has risen by :data:`PROFILE_RISE`. See the module docstring.
    """
    C0 = G0 @ G0.T
    n = C0.shape[0]
    lam, V = np.linalg.eigh(C0[np.ix_(k_idx, k_idx)])
    sigma = np.sqrt(np.maximum(lam, 0.0))
    directions = np.zeros((n, len(k_idx)))
    directions[k_idx] = V
    weak, axes = [], []
    for j in range(len(k_idx)):
        reach = _profile_extent(problem, x0, lin, C0, directions[:, j], sigma[j])
        if sigma[j] > WEAK_SIGMA or max(reach) > NODES[-1]:
            weak.append(j)
            axes.append(_StretchedAxis(*reach))
    if not weak:
        return None
    U = directions[:, weak]
    E = _complement(U)  # the other n − d directions
    gain = C0 @ U / sigma[weak]  # Gaussian regression of the state on the weak coordinates, per Laplace standard deviation
    h = NODE_SPACING[len(weak) - 1]
    xi = h * np.arange(-np.floor(NODES[-1] / h + 1e-9), np.floor(NODES[-1] / h + 1e-9) + 1.0)
    grid = np.stack(np.meshgrid(*[xi] * len(weak), indexing="ij"), axis=-1).reshape(-1, len(weak))
    grid = grid[np.sum(grid * grid, axis=1) <= NODES[-1] ** 2 + 1e-9]
    log_w, D, roots = [], [], []
    for g in grid:
        offset = np.array([ax.at(v) for ax, v in zip(axes, g)])
        try:
            _, ln, _ = problem.minimise(problem.model.boxplus(x0, gain @ offset), E)
        except BatchFitError:  # a node whose trajectory is not finite has no weight
            continue
        G, logdet = ln.root(E)
        log_w.append(-0.5 * ln.cost - 0.5 * logdet + sum(np.log(ax.slope(v)) for ax, v in zip(axes, g)))
        D.append(problem.model.boxminus(ln.x_end, lin.x_end))
        roots.append(ln.Phi_end @ E @ G)
    w = np.exp(np.array(log_w) - max(log_w))
    w /= w.sum()
    D = np.array(D)
    m = w @ D
    # the mixture's covariance Σ w_j (C_j + (d_j − m)(d_j − m)ᵀ), as the Gram matrix of one stacked root
    L = np.hstack([np.sqrt(wj) * np.hstack([Gj, (dj - m)[:, None]]) for wj, Gj, dj in zip(w, roots, D)])
    return problem.model.boxplus(lin.x_end, m), L @ L.T, U.T, len(grid)


class _StretchedAxis:
    """A quadrature axis ``x(ξ)`` (in Laplace standard deviations) that is ``ξ`` near the mode and reaches ``reach`` at ``ξ = ±4``.

    ``x = sinh(b ξ) / b`` on each side, ``b`` solving ``sinh(4 b) / b = reach``
    (``b = 0``: ``x = ξ``), so the nodes keep the mode's resolution (a node per
    Laplace σ, where a uniform stretch by ``reach / 4`` let the narrow peak
    fall between nodes: SC1-near-axis seeds 1000–1001, ``k``'s NEES/dof at the
    fits 1.9–5.3) and still cover a posterior wider than the mode's
    curvature. The trapezoid rule in ``ξ`` weights each node by ``dx/dξ``.
    """

    def __init__(self, reach_plus: float, reach_minus: float):
        self.b = {1.0: self._rate(reach_plus), -1.0: self._rate(reach_minus)}

    @staticmethod
    def _rate(reach: float) -> float:
        if reach <= NODES[-1] * (1.0 + 1e-9):
            return 0.0
        return float(brentq(lambda b: np.sinh(NODES[-1] * b) / b - reach, 1e-9, 5.0))

    def at(self, xi: float) -> float:
        b = self.b[1.0 if xi >= 0 else -1.0]
        return float(xi if b == 0.0 else np.sinh(b * xi) / b)

    def slope(self, xi: float) -> float:
        return float(np.cosh(self.b[1.0 if xi >= 0 else -1.0] * xi))


def _restart_over_inertia(problem: _Problem, x0, lin: _Linearisation, k_idx: np.ndarray) -> tuple[np.ndarray, _Linearisation, int]:
    """The fit from ``x0`` or from :data:`RESTARTS` other values of ``k`` across its prior, whichever has the lower cost.

    A fit started from the previous one follows its basin as the arc grows;
    near the intermediate axis the cost in ``k`` has more than one (SC1-NEAR-AXIS
    seed 1025: from 120 s on, the warm-started fit's cost exceeded that of a fit
    started at the truth by 7 at 120 s and by 450 at 200 s, its ``k`` 0.6 off
    with a 1σ of 0.005, NEES/dof up to 2e4). Each restart takes ``x0`` with
    ``k`` moved to the prior mean plus the offset (prior standard deviations).
    """
    sd = np.sqrt(np.diag(problem.P0)[k_idx])
    k_prior = problem.model.boxminus(problem.x0_prior, x0)[k_idx]  # the prior's k, relative to x0
    steps = 0
    for offset in RESTARTS:
        d = np.zeros(problem.P0.shape[0])
        d[k_idx] = k_prior + offset * sd
        try:
            x_r, lin_r, more = problem.minimise(problem.model.boxplus(x0, d), np.eye(len(d)))
        except BatchFitError:
            continue
        steps += more
        if lin_r.cost < lin.cost - COST_TOL:
            x0, lin = x_r, lin_r
    return x0, lin, steps


def _complement(U: np.ndarray) -> np.ndarray:
    """Orthonormal columns spanning the complement of the orthonormal columns ``U`` (n, d)."""
    n, d = U.shape
    return np.linalg.svd(np.eye(n) - U @ U.T)[0][:, : n - d]


def _profile_extent(problem: _Problem, x0, lin: _Linearisation, C0, u, sigma: float) -> tuple[float, float]:
    """``(z₊, z₋)``: how far along ``±u`` (in its Laplace standard deviations ``σ``) the posterior reaches.

    The profile of the cost along ``u``: the other directions re-fitted at
    ``±z σ``. A Gaussian posterior's cost has risen by ``z²`` there, 16 at the
    last node (``z = 4``); where it has risen by less than :data:`PROFILE_RISE`
    (the posterior is wider than its curvature at the mode says), ``z``
    doubles until it has, up to :data:`MAX_EXTENT` (the prior bounds it).
    ``z = 4`` on both sides: the Laplace approximation holds along ``u``.
    See the module docstring.
    """
    E = _complement(u[:, None])
    gain = C0 @ u / sigma
    reach = []
    for sign in (1.0, -1.0):
        z = NODES[-1]
        while z < MAX_EXTENT:
            try:
                _, ln, _ = problem.minimise(problem.model.boxplus(x0, gain * (sign * z)), E)
            except BatchFitError:  # a trajectory that breaks down there: the cost rises without bound
                break
            if ln.cost - lin.cost >= PROFILE_RISE:
                break
            z *= 2.0
        reach.append(z)
    return reach[0], reach[1]


def posterior(model, servicer, history: MeasurementHistory, x0_prior, P0, k_end: int, dt: float, *, k_start: int = 0,
              x0_start=None, consider=(), k_states=None, suspect=(), Q=None) -> BatchPosterior:
    """The posterior of the state at grid step ``k_end`` given a prior at step ``k_start`` and the measurements after it.

    ``model``: the process model (``trajectory``, ``boxplus``/``boxminus``);
    ``servicer (≥ k_end, 13)``: the servicer's state at each step start
    (the filters' control input); ``x0_prior``/``P0``: the estimate and
    covariance at grid step ``k_start`` (a filter's initial ones for
    ``k_start = 0``, the full history; a filter's later estimate for a moving
    window, whose measurements it has not seen); ``dt``: the grid step (s);
    ``x0_start``: where the fit of the state at ``k_start`` starts (default
    ``x0_prior``; a filter's current estimate run back with ``model.rewind`` is
    a better one for the first fit); ``consider``: error-state indices held at
    the prior (consider covariance); ``k_states``: the error-state indices of
    the inertia ratios, for the quadrature along their weak direction
    (``None``: no quadrature); ``suspect``: error-state indices of a prior that
    may contradict the data as a whole (a spin prior's rate about an assumed
    axis): when the fit fails its test, it is redone from the gates' verdicts with
    the prior made nearly flat there (module docstring), and
    ``prior_flattened`` names them if that fit is the one returned.
    ``BatchPosterior.x0`` is the state at ``k_start``. ``Q`` (n_error, n_error): process noise per grid step inside
    the window (``None``: the deterministic fit of the module docstring; else its section *Process noise*).
    """
    problem = _Problem(model, servicer, history, x0_prior, P0, k_start, k_end, dt, Q=Q)
    offered = problem.dof  # the measurements the gates accepted
    n = problem.P0.shape[0]
    con = np.asarray(sorted(set(int(i) for i in consider)), dtype=int)
    est = np.setdiff1d(np.arange(n), con)
    start = problem.x0_prior if x0_start is None else np.asarray(x0_start, dtype=float)
    held = np.zeros(n)
    held[con] = problem.model.boxminus(problem.x0_prior, start)[con]  # the held states at the prior's values
    x_begin = problem.model.boxplus(start, held)
    k_fit = k_states if not con.size else None

    def refit(P, keep):
        return _Problem(model, servicer, history, x0_prior, P, k_start, k_end, dt, keep=keep, Q=Q)

    verdicts = problem
    problem, x0, lin, steps, flat = _fit_from(verdicts, x_begin, est, k_fit, refit)
    if problem.dof < CONSENSUS * problem.every_dof:  # the fit explains few of the window's measurements (module docstring)
        try:
            alt = _fit_from(verdicts.with_keep([np.ones(len(ks), bool) for _, ks, _, _ in verdicts.every]), x_begin, est, k_fit, refit)
        except BatchFitError:
            alt = None
        if alt is not None:
            steps += alt[3]
            if alt[0].dof > problem.dof and _passes(alt[2], alt[0].dof, offered):
                problem, x0, lin, _, flat = alt
    suspect = np.asarray(suspect, dtype=int)
    if suspect.size and not _passes(lin, problem.dof, offered):  # a suspect prior that contradicts the data as a whole (module docstring)
        alt = posterior(model, servicer, history, x0_prior, _flattened(np.asarray(P0, dtype=float), suspect), k_end, dt, k_start=k_start,
                        x0_start=x0_start, consider=consider, k_states=k_states, Q=Q)
        if alt.usable:
            return dataclasses.replace(alt, iterations=alt.iterations + steps,
                                       prior_flattened=tuple(int(i) for i in np.union1d(alt.prior_flattened, suspect)))
    G0 = _initial_root(lin, problem.P0, est, con)
    # a consider term beyond the estimated states' prior: the held states, not the data, decide the fit (SC2, module docstring)
    held_dominate = bool(con.size) and bool(np.any(np.sum(G0[est] ** 2, axis=1) > np.diag(problem.P0)[est]))
    moments = None
    if k_states is not None and not con.size:
        moments = _weak_quadrature(problem, x0, lin, G0, np.asarray(k_states, dtype=int))
    if moments is not None:
        x, P, weak, nodes = moments
    else:
        x, P, weak, nodes = lin.x_end, _end_moments(problem, x0, con, None)[1], None, 0
    if problem.Q is not None:  # the process noise inside the window (module docstring, *Process noise*)
        d_q, P_q = _end_moments(problem, x0, con, problem.Q)
        d_0, P_0 = (0.0, P) if moments is None else _end_moments(problem, x0, con, None)
        x, P = problem.model.boxplus(x, d_q - d_0), P + P_q - P_0
    return BatchPosterior(x=x, P=_factorable(P), x0=x0, cost=lin.cost, dof=problem.dof, usable=_passes(lin, problem.dof, offered) and not held_dominate,
                          iterations=steps, nodes=nodes, prior_flattened=tuple(int(i) for i in flat), weak_directions=weak, offered=offered)


def _fit_from(problem: _Problem, x0, est: np.ndarray, k_states, refit) -> tuple[_Problem, np.ndarray, _Linearisation, int, np.ndarray]:
    """``(problem, x0, lin, steps, flat)``: the fit from ``x0`` of ``problem``'s measurements (with the restarts over
    the inertia ratios ``k_states``, or ``None``), the fit's own screen (:data:`SCREEN_QUANTILE`, at most
    :data:`SCREEN_PASSES` refits), then the prior made nearly flat where the fit contradicts it (:data:`PRIOR_Z`; ``flat``
    those error components) and refitted; ``problem`` the final one (``refit(P0, keep)`` makes a problem, module docstring)."""
    n = problem.P0.shape[0]
    x0, lin, steps = problem.minimise(x0, np.eye(n)[:, est])
    if k_states is not None:
        x0, lin, more = _restart_over_inertia(problem, x0, lin, np.asarray(k_states, dtype=int))
        steps += more
    for _ in range(SCREEN_PASSES):  # the measurements by the fit's own residuals, not the filter's gate (module docstring)
        keep = problem.screen(x0)
        if all(np.array_equal(a, b) for a, b in zip(keep, problem.keep)):
            break
        problem = problem.with_keep(keep)
        x0, lin, more = problem.minimise(x0, np.eye(n)[:, est])
        steps += more
    z = problem.model.boxminus(x0, problem.x0_prior) / np.sqrt(np.diag(problem.P0))
    flat = np.flatnonzero(np.abs(z) > PRIOR_Z)
    if flat.size:  # the prior contradicts the data there: let the data decide (module docstring)
        problem = refit(_flattened(problem.P0, flat), problem.keep)
        x0, lin, more = problem.minimise(x0, np.eye(n)[:, est])
        steps += more
    return problem, x0, lin, steps, flat


def _passes(lin: _Linearisation, dof: int, offered: int) -> bool:
    """The fit's test: its minimum cost within the :data:`FIT_QUANTILE` of ``χ²(dof)``, and its screen kept enough measurements.

    ``dof``: the degrees of freedom of the measurements the fit kept;
    ``offered``: of those the filter's gates accepted. A fit whose screen kept
    no measurement has tested nothing (cost 0 of 0 degrees of freedom): its
    "posterior" is the prior run forward; one that kept less than
    :data:`SCREEN_MIN_KEPT` of them has explained a few that happen to agree with
    its start, not the data (module docstring).
    """
    return dof > 0 and dof >= SCREEN_MIN_KEPT * offered and bool(lin.cost <= chi2.ppf(FIT_QUANTILE, dof))


def _flattened(P0: np.ndarray, idx: np.ndarray) -> np.ndarray:
    """``P0`` with the prior of the error components ``idx`` made nearly flat (variance × :data:`FLAT_PRIOR_SCALE`, uncorrelated)."""
    P = P0.copy()
    P[idx, :] = P[:, idx] = 0.0
    P[idx, idx] = np.diag(P0)[idx] * FLAT_PRIOR_SCALE
    return P


def _factorable(P: np.ndarray) -> np.ndarray:
    """``P`` symmetric, its eigenvalues raised to at least :data:`EIGEN_FLOOR` times the largest.

    SC1 and SC2 spin about the intermediate axis: given ``k``, a long fit pins
    the unstable mode's initial amplitude to ``e^{−λt}`` (``λ`` 0.01–0.16 /s),
    and from 170 s on SC1 (100 s on SC2) the computed ``P`` has eigenvalues of
    1e-15…1e-19 of its largest, some negative: below what double precision
    resolves in a 14×14 product (``n ε ≈ 3e-15``), and the UKF's Cholesky
    factor of its sigma points failed on them. Raised to the floor, ``P``
    changes by less than its own rounding error.
    """
    P = 0.5 * (P + P.T)
    lam, V = np.linalg.eigh(P)
    floor = EIGEN_FLOOR * lam[-1]
    if lam[0] >= floor:
        return P
    return (V * np.maximum(lam, floor)) @ V.T


def _end_moments(problem: _Problem, x0: np.ndarray, con: np.ndarray, Q: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
    """``(δ, C)``: the last state's mean as an error ``δ`` (n_error,) about the fitted trajectory's end, and its covariance.

    The Kalman recursion along the fitted trajectory from ``x0``, linearised about it: one step's ``F`` at
    a time (Joseph form), as the filters do. Without process noise (``Q`` None) ``C`` is the Laplace
    covariance ``Φ C₀ Φᵀ`` (formed that way it lost definiteness where ``Φ`` spans decades: rate errors
    move positions by ``50 m × t``, and SC1–SC2 spin about the intermediate axis, so ``Φ`` grows like
    ``e^{λt}``; on SC2 the computed ``P`` had eigenvalues of −1e-19 where the filter's own were 5e-11) and
    ``δ ≈ 0`` (the fit is the minimum: the recursion's correction is ``Φ`` times the Gauss–Newton step). With
    ``Q`` (n_error, n_error) per step, ``P⁻ = F P Fᵀ + Q_ee``: the recursion is then the Kalman filter of the
    window's data from the prior, linearised about the fit, and ``δ`` its correction (module docstring, *Process
    noise*). With considered states ``c`` (held at the prior) it is the consider analysis of Tapley et al.
    §6.3: the filter of the estimated states ``e`` from the conditional prior ``P_e|c`` (``M = P_ec P_cc⁻¹``),
    and the sensitivity ``Ψ = ∂ε_e/∂δc`` of its error to the held states' error, ``Ψ⁻ = F_ee Ψ − F_ec``,
    ``Ψ = (I − K H_e) Ψ⁻ + K H_c``, ``Ψ_0 = −M``; then ``C_ee = P + Ψ P_cc Ψᵀ``, ``C_ec = −Ψ P_cc``, ``C_cc = P_cc``.
    """
    X, _, F = problem.model.trajectory(x0, problem.servicer, problem.dt)
    n = problem.P0.shape[0]
    est = np.setdiff1d(np.arange(n), con)
    at_step: dict[int, list] = {}
    for src, ks, Z, _ in problem.groups:
        for k, H, y in zip(ks, src.jacobians(X[ks]), src.residual(Z, X[ks])):
            at_step.setdefault(int(k), []).append((H, src.R, y))
    P0 = problem.P0
    Pcc = P0[np.ix_(con, con)]
    M = P0[np.ix_(est, con)] @ np.linalg.inv(Pcc) if con.size else np.zeros((est.size, 0))
    P = P0[np.ix_(est, est)] - M @ P0[np.ix_(con, est)]
    d_prior = problem.model.boxminus(problem.x0_prior, x0)
    d = d_prior[est] - M @ d_prior[con]  # the prior's mean about the fit, given the held states at the prior's values
    Psi = -M
    I = np.eye(est.size)
    Qee = None if Q is None else Q[np.ix_(est, est)]
    for k in range(1, len(X)):
        Fee, Fec = F[k - 1][np.ix_(est, est)], F[k - 1][np.ix_(est, con)]
        P = Fee @ P @ Fee.T if Qee is None else Fee @ P @ Fee.T + Qee
        d = Fee @ d
        Psi = Fee @ Psi - Fec
        if k in at_step:
            H = np.vstack([h for h, _, _ in at_step[k]])
            R = _block_diag([r for _, r, _ in at_step[k]])
            y = np.concatenate([v for _, _, v in at_step[k]])
            He, Hc = H[:, est], H[:, con]
            K = np.linalg.solve(He @ P @ He.T + R, He @ P).T
            IKH = I - K @ He
            P = IKH @ P @ IKH.T + K @ R @ K.T
            d = d + K @ (y - He @ d)
            Psi = IKH @ Psi + K @ Hc
    C = np.zeros((n, n))
    C[np.ix_(est, est)] = P + Psi @ Pcc @ Psi.T
    C[np.ix_(est, con)] = -Psi @ Pcc
    C[np.ix_(con, est)] = (-Psi @ Pcc).T
    C[np.ix_(con, con)] = Pcc
    delta = np.zeros(n)
    delta[est] = d
    return delta, C
