"""Run a relative-navigation filter over a measurement sequence (arrays in, a result out).

:func:`make_filter` builds the EKF or the UKF by name (studies swap them by
name); :func:`run_navigation` drives it at the sampling time ``τ_s``: at
every step ``k ≥ 1`` it predicts from ``t_{k−1}`` with the servicer's AODS
state at ``t_{k−1}``, then updates with the pose measurement taken at ``t_k``
(if any), gated per source, and with the spin-prior proxy if asked.

References
----------
.. [1] Renis, Price, Hellmich, Battipede, Salzmann, *Leveraging Light-Curve Inversion for Real-Time
   Kinematic State Estimation of Uncooperative Targets*.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass

import numpy as np
from scipy.stats import chi2

from estimators.batch import BatchFitError, MeasurementHistory, posterior
from estimators.ekf import ExtendedKalmanFilter
from estimators.error_state import boxminus
from estimators.filter import NonFiniteError
from estimators.gates import GateDecision
from estimators.measurement import PoseNoise
from estimators.prior import PROXY_MODES, R_OMEGA_PROXY, BodyRatePrior, rate_proxy
from estimators.process_model import RelativeProcessModel
from estimators.reacquisition import Reacquisition
from estimators.state import DK, DW_ST_T, N_ABSOLUTE, N_ERROR, N_STATE
from estimators.tuning import Tuning
from estimators.ukf import UnscentedKalmanFilter

FILTERS = {"ekf": ExtendedKalmanFilter, "ukf": UnscentedKalmanFilter}
SOURCES = ("attitude", "position")
#: Least fraction (degrees of freedom) of the gate-accepted measurements a fit's screen keeps for its result to anchor a fixed-lag window
#: (:class:`_Relinearization`): the screen leaves out ~1e-4 of good measurements; a whole pose source is 50 %.
ANCHOR_KEPT = 0.9
#: Longest fixed-lag window, in lags (:class:`_Relinearization`): with no trusted anchor within it, the window starts at the
#: filter's own output one lag back. Measured without the bound (SC1 perturbed, EKF, seed 1003): every fit failed from 340 s on,
#: the window reached back to the last fit that passed, and the CPU per step grew 3 → 58 → 195 → 2192 ms over 500-s blocks.
MAX_WINDOW_LAGS = 3
#: Confidence of the region of the filter's estimate inside which a window fit from a last-resort anchor may reset it.
AGREEMENT_CONFIDENCE = 0.99


def make_filter(name: str, model, x0, P0, Q, **kwargs):
    """``FILTERS[name](model, x0, P0, Q, **kwargs)``; ValueError for an unknown name."""
    try:
        cls = FILTERS[name]
    except KeyError:
        raise ValueError(f"unknown filter {name!r}: expected one of {sorted(FILTERS)}") from None
    return cls(model, x0, P0, Q, **kwargs)


@dataclass(frozen=True)
class NavigationRun:
    """One filter run on the step grid ``t`` (N,).

    ``x`` (N, 15) and ``P`` (N, 14, 14) after each step's update;
    ``nis[source]`` (N,) the normalised innovation squared ``e²`` of each
    camera source (NaN where it had no measurement), ``accepted[source]`` (N,)
    its gate decision, ``proxy_used`` (N,) whether the prior proxy was pushed,
    ``decisions`` every gate decision in order, ``reacquisitions`` when a
    locked-out source was re-acquired (:mod:`estimators.reacquisition`).
    """

    filter: str
    t: np.ndarray
    x: np.ndarray
    P: np.ndarray
    nis: dict
    accepted: dict
    proxy_used: np.ndarray
    decisions: tuple[GateDecision, ...]
    pose_noise: PoseNoise = PoseNoise()  #: the noise model the filter's ``R_d`` came from
    reacquisitions: tuple[tuple[float, str], ...] = ()  #: ``(t, source)`` of each re-acquisition
    #: ``(t, nodes, usable, dof)`` of each re-linearisation about the full-information fit (:mod:`estimators.batch`); ``dof``: the
    #: degrees of freedom of the measurements it fitted
    relinearizations: tuple[tuple[float, int, bool, int], ...] = ()
    #: times (s since ``t[0]``) of the re-linearisations whose fit passed only with the spin prior's rate made flat:
    #: the prior contradicts the measurements (:func:`estimators.batch.posterior`, ``suspect``)
    prior_contradicted: tuple[float, ...] = ()
    #: times (s since ``t[0]``) of the fixed-lag windows used only after a refit with the inertia ratios' prior widened to
    #: ``P_0``'s (:class:`_Relinearization`): the filter's own ``k`` had left the data's basin
    inertia_resets: tuple[float, ...] = ()
    #: UKF: sigma-point draws whose covariance had no Cholesky factor and was floored (:func:`estimators.ukf.scaled_cholesky`)
    regularizations: int = 0
    #: (N,) seconds per step by ``run_navigation``'s ``clock`` (predict, updates, re-linearisation; NaN at step 0), or None
    step_s: np.ndarray | None = None


def run_navigation(
    filter_name: str,
    t,
    servicer,
    J_S_diag,
    t_meas,
    q_meas,
    r_meas,
    *,
    x0,
    tuning: Tuning,
    pose_noise: PoseNoise,
    P0=None,
    gate_confidence: float | None = 0.99,
    gate_start_s: float = 0.0,
    prior: BodyRatePrior | None = None,
    proxy: str | None = None,
    R_w: float = R_OMEGA_PROXY,
    reacquire_window: int | None = 5,
    clock=None,
    **filter_kwargs,
) -> NavigationRun:
    """Filter the pose measurements ``(t_meas, q_meas (M,4), r_meas (M,3))`` on the grid ``t`` (N,).

    ``servicer`` (N, 13): the servicer's absolute state at each grid time (its
    AODS); ``t`` must be evenly spaced by ``τ_s``; every measurement time must
    be a grid time after ``t[0]``. ``x0``/``P0`` (default ``tuning.P_0``) is the
    initial estimate, e.g. from :func:`estimators.prior.initialize_with_prior`.
    ``pose_noise``: the pose estimator's noise, the filter's ``R_d`` — the same
    object the measurements were simulated with, unless a study mis-models on purpose.
    ``proxy``: ``None``, ``"always"`` or ``"on_reject"`` (needs ``prior``).
    ``gate_start_s``: the gates test measurements from this time on (s since
    ``t[0]``); before it every measurement is used (acquisition from ``x̂_0``).
    ``reacquire_window``: after this many rejections in a row of a camera
    source whose innovations lie on a line, the filter is re-acquired from
    them (:mod:`estimators.reacquisition`); ``None`` turns this off (the
    paper's filters, which a long blackout can lock out for good).
    ``clock``: a callable returning seconds (e.g. ``time.process_time``) read around every
    step; the differences are ``NavigationRun.step_s`` (what ``benchmarks/bench_realtime.py`` plots).
    """
    t, servicer, tau = _check_grid(t, servicer)
    if proxy is not None and proxy not in PROXY_MODES:
        raise ValueError(f"proxy must be None or one of {PROXY_MODES}, got {proxy!r}")
    if proxy is not None and prior is None:
        raise ValueError("the proxy measurement needs a spin prior with a rate")
    q_meas, r_meas, meas_at = _measurements_on_grid(t, tau, t_meas, q_meas, r_meas)
    model = RelativeProcessModel(J_S_diag, gravity_gradient=tuning.gravity_gradient)
    filt = make_filter(filter_name, model, x0, tuning.P_0 if P0 is None else P0, tuning.Q_d(tau), gate_confidence=gate_confidence, **filter_kwargs)
    att, pos = pose_noise.sources()

    n = len(t)
    xs = np.empty((n, N_STATE))
    Ps = np.empty((n, N_ERROR, N_ERROR))
    nis = {s: np.full(n, np.nan) for s in SOURCES}
    accepted = {s: np.zeros(n, dtype=bool) for s in SOURCES}
    proxy_used = np.zeros(n, dtype=bool)
    reacq = Reacquisition(reacquire_window) if reacquire_window is not None else None
    xs[0], Ps[0] = filt.x, filt.P
    consider = filt.consider
    relin = _Relinearization(model, servicer, tau, tuning, filt, consider, spin_prior=prior is not None) if tuning.relinearize_s > 0 else None
    tick = clock or _no_clock
    step_s = np.full(n, np.nan)
    for k in range(1, n):
        c0 = tick()
        if tuning.settling_s > 0:  # the tuning's settling and release phases (estimators.tuning)
            _set_phase(filt, tuning, tau, t[k - 1] - t[0], consider, relin, model, servicer[k - 1])
        filt.predict(servicer[k - 1], tau)
        x_prior = filt.x
        parts = []
        if k in meas_at:
            i = meas_at[k]
            parts = [(att, q_meas[i]), (pos, r_meas[i])]
        if proxy == "always":
            parts.append(rate_proxy(prior, servicer[k], R_w))
        gate = t[k] - t[0] >= gate_start_s
        decisions = filt.update(parts, t=t[k], gate=gate)
        if k in meas_at:
            _record_camera_sources(filt, decisions, k, nis, accepted)
            if reacq is not None and gate:
                innovations = dict(filt.innovations)
                for src in (att, pos):
                    reacq.step(filt, src, accepted[src.name][k], t[k], innovations[src.name][0], x_prior)
        proxy_used[k] = proxy == "always"
        if proxy == "on_reject" and not all(accepted[s][k] for s in SOURCES):
            parts.append(rate_proxy(prior, servicer[k], R_w))
            filt.update(parts[-1:], t=t[k])
            proxy_used[k] = True
        if relin is not None:
            relin.step(filt, k, t[k] - t[0], parts, decisions)
        xs[k], Ps[k] = filt.x, filt.P
        step_s[k] = tick() - c0
    return NavigationRun(
        filter=filter_name, t=t, x=xs, P=Ps, nis=nis, accepted=accepted, proxy_used=proxy_used, pose_noise=pose_noise,
        decisions=tuple(filt.gate_decisions), reacquisitions=tuple(reacq.events) if reacq is not None else (),
        relinearizations=tuple(relin.events) if relin is not None else (),
        prior_contradicted=tuple(relin.prior_contradicted) if relin is not None else (),
        inertia_resets=tuple(relin.inertia_resets) if relin is not None else (),
        regularizations=filt.regularizations, step_s=step_s if clock is not None else None,
    )


def _no_clock() -> float:
    return 0.0


class _Relinearization:
    """The tuning's periodic re-linearisation: the filter's ``x, P`` replaced by the full-information posterior.

    Every ``tuning.relinearize_s`` from the end of the settling phase on, the
    measurements so far (camera sources with the gate's verdicts, the prior
    proxy) are fitted together with the filter's initial ``x̂_0, P_0``
    (:func:`estimators.batch.posterior`); the first fit starts from the
    filter's estimate run back to ``t[0]``, each later one from the latest
    fit that passed.

    *Fixed lag* (``tuning.lag_s > 0``, issue 31): a fit at step ``k`` takes as its prior the filter's own output
    ``(x, P)`` at the window's start, an *anchor*: the latest fit result at or before step ``k − L`` (``L = lag / τ``;
    ``lag`` a multiple of the fit period, so normally the fit at exactly ``k − L``) that passed its test having kept
    at least :data:`ANCHOR_KEPT` of the measurements the gates accepted, with a Gaussian posterior (no quadrature
    along the inertia ridge, :mod:`estimators.batch`), or ``x̂_0, P_0`` at ``t[0]`` while there is none (until
    ``t ≥ lag`` the fit is the full-information one). Only the measurements after the anchor are fitted;
    older ones are forgotten (:meth:`estimators.batch.MeasurementHistory.prune`). A failing fit lengthens the next
    windows until one passes, up to :data:`MAX_WINDOW_LAGS` lags; a window that would reach further back starts instead
    at the filter's own output at the fit one lag back (passed or not: its ``x, P`` condition on the measurements up
    to its step only, as any anchor's); such a fit resets the filter only if it lies inside the filter's own 99 % region
    (:func:`_agrees`). So a fit's cost and the memory are bounded whatever the elapsed time and however many fits fail.
    Why the anchor test: a fit early in the acquisition (SC1 at 2 s steps from §6's guess 50 m off, 10 and 20 s) passed
    its chi-square test with its screen leaving out a whole pose source (50 % of the data, allowed by
    :data:`estimators.batch.SCREEN_MIN_KEPT`); the full-information fit recovers from that at the next fit (its prior is
    the broad ``P_0``), a window anchored on it did not (NEES/dof 200–700 over 400 s). And a window's prior is
    Gaussian, ``(x, P)``: while the full fit needs its quadrature over the inertia ratios' curved ridge, that summary
    loses the ridge, and a window fit fell into the wrong basin of ``k1 − k2`` (SC3 perturbed, UKF, seed 1002: at 80 s,
    from the output at 20 s, ``k`` 0.65 off with a standard deviation of 0.003, NEES/dof 3600; mean NEES/dof of the
    30 runs 4.6 against 0.69 for the EKF). The information sets are
    disjoint: the anchor is the filter's output at its step, which conditions on the measurements at steps up to its
    own only (its fit used its own anchor's output and the measurements after that, and so on back to ``x̂_0, P_0``), so the
    window's measurement noises are independent of it; nothing is counted twice. What the prior
    does not carry is the correlation a smoother would keep between the state at ``k − L`` and the states before it:
    a fixed-lag fit cannot revise those (not needed for the estimate at ``k``). The tuning's process noise
    (``tuning.Q_d`` after the settling phase, the disturbance budget) enters the fit (``posterior``'s ``Q``): the
    window's trajectory is deterministic, each measurement's ``R_j`` is inflated by the noise accumulated from the
    window's start, and the last state's moments are the window's Kalman recursion with ``Q`` about the fitted
    trajectory (:mod:`estimators.batch`, *Process noise*). The EKF and the UKF each keep their own outputs, so
    their windows start from their own estimates. A fit that fails its tests (:attr:`estimators.batch.BatchPosterior.usable`)
    leaves the filter as it is, and puts it back into its settling phase until one passes.
    *The inertia ratios' window prior widened* (issue 31): a window's prior on ``k`` is the filter's own output, the
    Gaussian summary of a curved ridge (above), which can be narrow and wrong. SC1 perturbed, seed 3026 (600 s, EKF):
    from 160 s the window fits moved ``k`` by more than their σ from one to the next, at 280 s one put it at
    (0.16, −1.35) with σ (0.24, 0.13) against the truth's (1.47, −1.44); every later window failed its χ² test and the
    filter, ``k`` held, lost the rate (the run's NEES/dof 240, all of the ten-minute SC1 row's 9.0). A window that
    estimates ``k`` and fails is therefore refitted once with ``k``'s prior replaced by the filter's initial one
    (``P_0``'s ``k`` block, uncorrelated with the rest, so the window's data and the restarts across that prior of
    :mod:`estimators.batch` decide ``k``), and used if that fit passes; the time is noted in ``inertia_resets``. It only
    forgets what earlier windows knew of ``k``; nothing is counted twice. Making ``k``'s prior flat instead (as a spin
    prior's rate is) sent that run's ``k`` into another wrong basin, (−1.46, −0.12): a 60-s window of a one-axis
    tumble does not fix ``k`` on its own.
    With a spin prior (``spin_prior``) the rate is ``suspect`` to the fit: a fit that
    fails is redone with the prior's rate made flat, and if that one passes, the
    filter is reset to it and the time is noted in ``prior_contradicted``.
    """

    def __init__(self, model, servicer, tau: float, tuning: Tuning, filt, consider, *, spin_prior: bool = False):
        self.model, self.servicer, self.tau, self.consider = model, servicer, tau, consider
        #: the inertia ratios' error indices for the fit's quadrature; none when they are considered (held)
        self.k_states = None if np.isin(np.arange(N_ERROR)[DK], consider).any() else np.arange(N_ERROR)[DK]
        self.x0_prior, self.P0 = filt.x.copy(), filt.P.copy()
        self.first_s, self.every_s = (tuning.settling_s or tuning.relinearize_s), tuning.relinearize_s
        self.history = MeasurementHistory()
        #: fixed lag: the window ``L`` in steps, the anchors ``(k, x, P)`` (the oldest one in use first), the window's process noise
        self.lag_steps = int(round(tuning.lag_s / tau))
        self.max_steps = MAX_WINDOW_LAGS * self.lag_steps
        self.anchors: deque = deque([(0, self.x0_prior, self.P0)])
        #: the filter's output ``(k, x, P)`` after each fit of the last ``max_steps``, passed or not: the anchors of last resort
        self.outputs: deque = deque()
        self.Q = tuning.Q_d(tau) if self.lag_steps else None
        self.x0_fit = None  #: the initial state of the latest fit that passed, where the next one starts
        self.trusted = False  #: the latest fit passed its tests
        #: (d, n_error), d = 0–2: the weak inertia directions of the latest fit's quadrature, which the filter
        #: considers until the next fit (its posterior along them is not Gaussian: the fit, not the filter, learns them)
        self.weak_directions = np.zeros((0, N_ERROR))
        self.events: list[tuple[float, int, bool]] = []
        self.suspect = np.arange(N_ERROR)[DW_ST_T] if spin_prior else ()
        self.prior_contradicted: list[float] = []
        #: steps (s since ``t[0]``) whose window was used only after refitting it with ``k``'s prior widened to ``P_0``'s
        self.inertia_resets: list[float] = []

    def step(self, filt, k: int, t_s: float, parts, decisions) -> None:
        """Record step ``k``'s accepted measurements; fit and reset the filter when a re-linearisation is due."""
        rejected = {d.source for d in decisions if not d.accepted}
        for src, z in parts:
            self.history.add(k, src, z, accepted=src.name not in rejected)
        due = t_s + 1e-9 >= self.first_s and abs((t_s - self.first_s) / self.every_s - round((t_s - self.first_s) / self.every_s)) < 1e-6
        if due and len(self.history):
            self._fit(filt, k, t_s)

    def _fit(self, filt, k: int, t_s: float) -> None:
        """Fit the window ending at step ``k`` and reset the filter to it if it passes (class docstring)."""
        while len(self.anchors) > 1 and self.anchors[1][0] <= k - self.lag_steps:  # the latest anchor at or before k − L
            self.anchors.popleft()
        k_start, x_prior, P_prior = self.anchors[0] if self.lag_steps else (0, self.x0_prior, self.P0)
        last_resort = bool(self.lag_steps and k - k_start > self.max_steps)
        if last_resort:  # no trusted anchor within the bound: the filter's output one lag back
            k_start, x_prior, P_prior = max((o for o in self.outputs if o[0] <= k - self.lag_steps), key=lambda o: o[0],
                                            default=(k_start, x_prior, P_prior))  # there is one: a fit every period since the first
        if k_start > 0:  # a window from the filter's own output (class docstring)
            self.history.prune(k_start)
            start = x_prior
        else:
            start = self.x0_fit if self.x0_fit is not None else self.model.rewind(filt.x, self.servicer[1 : k + 1], self.tau)
        try:
            post = posterior(self.model, self.servicer, self.history, x_prior, P_prior, k, self.tau, k_start=k_start, x0_start=start,
                             consider=self.consider, k_states=self.k_states, suspect=self.suspect, Q=self.Q)
        except BatchFitError:
            self.events.append((float(t_s), 0, False, 0))
            self.trusted = False
            self._keep_output(filt, k)
            return
        # a window from a last-resort anchor resets the filter only where it agrees with it (same prior, same data: a fit far
        # from the filter is a linearisation the filter does not share; measured once on SC1 perturbed without this test,
        # a fit that passed its own χ² test at 1010 s took the NEES/dof from 0.9 to 37 for 50 s)
        usable = post.usable and (not last_resort or _agrees(filt, post.x))
        if not usable and self.lag_steps and self.k_states is not None:  # the window's k prior may be what is wrong (class docstring)
            wide = self._refit_with_initial_inertia(x_prior, P_prior, k, k_start, start)
            if wide is not None:
                post, usable = wide, True
                self.inertia_resets.append(float(t_s))
        self.events.append((float(t_s), post.nodes, usable, post.dof))
        self.trusted = usable
        self.weak_directions = np.zeros((0, N_ERROR)) if post.weak_directions is None else post.weak_directions
        if usable:
            filt.reset(post.x, post.P, f"re-linearisation at t={t_s}")
            if len(self.suspect) and np.isin(self.suspect, post.prior_flattened).all():
                self.prior_contradicted.append(float(t_s))
            self.x0_fit = post.x0
            if self.lag_steps and post.nodes == 0 and post.dof >= ANCHOR_KEPT * post.offered:
                self.anchors.append((k, filt.x.copy(), filt.P.copy()))
        self._keep_output(filt, k)

    def _refit_with_initial_inertia(self, x_prior, P_prior, k: int, k_start: int, start):
        """The failed window refitted with the inertia ratios' prior widened to the filter's initial one (``P_0``'s ``k``
        block, uncorrelated with the rest), if that fit passes its tests; else None."""
        ks = self.k_states
        P_wide = P_prior.copy()
        P_wide[ks, :] = 0.0
        P_wide[:, ks] = 0.0
        P_wide[np.ix_(ks, ks)] = self.P0[np.ix_(ks, ks)]
        try:
            alt = posterior(self.model, self.servicer, self.history, x_prior, P_wide, k, self.tau, k_start=k_start, x0_start=start,
                            consider=self.consider, k_states=ks, suspect=self.suspect, Q=self.Q)
        except BatchFitError:
            return None
        return alt if alt.usable else None

    def _keep_output(self, filt, k: int) -> None:
        """Keep the filter's output after the fit at step ``k``; forget those older than the bound (bounded memory)."""
        if self.lag_steps:
            self.outputs.append((k, filt.x.copy(), filt.P.copy()))
            while self.outputs[0][0] < k - self.max_steps:
                self.outputs.popleft()


def _agrees(filt, x) -> bool:
    """``x`` lies inside the filter's own :data:`AGREEMENT_CONFIDENCE` region: ``(x ⊟ x̂)ᵀ P⁻¹ (x ⊟ x̂)`` over the
    estimated (not considered) error states below the chi-square quantile of their number."""
    idx = np.setdiff1d(np.arange(N_ERROR), filt.consider)
    d = boxminus(x, filt.x)[idx]
    try:
        d2 = float(d @ np.linalg.solve(filt.P[np.ix_(idx, idx)], d))
    except np.linalg.LinAlgError:
        return False
    return bool(np.isfinite(d2) and d2 <= chi2.ppf(AGREEMENT_CONFIDENCE, len(idx)))


def _check_grid(t, servicer) -> tuple[np.ndarray, np.ndarray, float]:
    """``(t, servicer, τ_s)``: the step grid (N ≥ 2, evenly spaced) and the servicer's state (N, 13) on it."""
    t = np.asarray(t, dtype=float)
    servicer = np.asarray(servicer, dtype=float)
    if t.ndim != 1 or len(t) < 2 or servicer.shape != (len(t), N_ABSOLUTE):
        raise ValueError(f"t must be (N>=2,) and servicer (N, 13), got {t.shape} and {servicer.shape}")
    steps = np.diff(t)
    tau = float(steps[0])
    if not (tau > 0 and np.allclose(steps, tau, rtol=0, atol=1e-9)):
        raise ValueError("t must be evenly spaced by the sampling time tau_s > 0")
    return t, servicer, tau


def _measurements_on_grid(t: np.ndarray, tau: float, t_meas, q_meas, r_meas) -> tuple[np.ndarray, np.ndarray, dict]:
    """``(q_meas, r_meas, meas_at)``: the checked measurements and ``{step k: measurement index}``."""
    t_meas = np.asarray(t_meas, dtype=float)
    q_meas = np.asarray(q_meas, dtype=float)
    r_meas = np.asarray(r_meas, dtype=float)
    if q_meas.shape != (len(t_meas), 4) or r_meas.shape != (len(t_meas), 3):
        raise ValueError(f"q_meas must be (M, 4) and r_meas (M, 3) with M = len(t_meas), got {q_meas.shape}, {r_meas.shape}")
    if not (np.all(np.isfinite(q_meas)) and np.all(np.isfinite(r_meas)) and np.all(np.isfinite(t_meas))):
        raise ValueError("measurements contain NaN or Inf")
    k_meas = np.rint((t_meas - t[0]) / tau).astype(int)
    if np.any(k_meas < 1) or np.any(k_meas >= len(t)) or np.any(np.abs(t[np.clip(k_meas, 0, len(t) - 1)] - t_meas) > 1e-6):
        raise ValueError("every measurement time must be a grid time after t[0]")
    return q_meas, r_meas, {int(k): i for i, k in enumerate(k_meas)}


def _set_phase(filt, tuning: Tuning, tau: float, t_s: float, consider, relin, model, servicer_state) -> None:
    """The filter's set-up for the step from ``t_s`` (s since ``t[0]``): settling, release or neither (:mod:`estimators.tuning`).

    With re-linearisation the settling phase lasts until a full-information fit
    has passed its tests, and comes back while the latest one fails them; while
    a fit's posterior is not Gaussian along the weak inertia direction, the
    filter considers that direction until the next fit.
    """
    k_axes = np.arange(N_ERROR)[DK]
    settling = t_s < tuning.settling_s or (relin is not None and not relin.trusted)
    _set_settling(filt, tuning, tau, settling, np.union1d(consider, k_axes).astype(int) if settling else consider)
    releasing = not settling and t_s < tuning.settling_s + tuning.release_s and not np.isin(k_axes, consider).any()
    if releasing:
        filt.consider_directions = weak_inertia_direction(model, filt.x, servicer_state, tau)
    else:
        filt.consider_directions = relin.weak_directions if relin is not None and relin.trusted else np.zeros((0, N_ERROR))


def _set_settling(filt, tuning: Tuning, tau: float, settling: bool, consider) -> None:
    """In or out of the tuning's settling phase (:mod:`estimators.tuning`): its ``Q_d``, considered states, EKF linearisation."""
    filt.Q = tuning.Q_d(tau, settling=settling)
    filt.consider = consider
    if isinstance(filt, ExtendedKalmanFilter):
        filt.linearization_covariance = settling
    else:  # the UKF's sigma points carry the nonlinearity along the considered states too
        filt.consider_linearly = not settling


def weak_inertia_direction(model: RelativeProcessModel, x, servicer_state, tau: float) -> np.ndarray:
    """The combination of ``δk1, δk2`` that moves the rate least over one step, as a (1, 14) error-space row.

    The right singular vector of the smaller singular value of ``∂ω(t + τ)/∂k``
    (the ``δω``–``δk`` block of the step's Jacobian ``F``). On SC3 (``A ≈ C``)
    ``ω̇_y = (C − A)/B ω_x ω_z`` fixes ``k1 + k2`` within seconds, while
    ``k1 − k2`` acts through ``ω_y``, which is itself about zero and, at the end
    of the settling phase, known only to ~0.004 rad/s; both filters then
    "learnt" ``k1 − k2`` from a gradient of the wrong size and sign and ended
    several σ off (measured: issue 12, ``benchmarks/RESULTS.md``). Considering
    this combination for the tuning's ``release_s`` after the settling phase lets
    the well-observed one converge first.
    """
    _, F = model.propagate_with_jacobian(np.asarray(x, dtype=float), servicer_state, tau)
    if not np.all(np.isfinite(F[DW_ST_T, DK])):  # a diverged estimate (SC4 EKF at 5 s: "SVD did not converge")
        raise NonFiniteError(f"the step's Jacobian dω/dk at the estimate is not finite over dt={tau}; the filter has diverged")
    v = np.linalg.svd(F[DW_ST_T, DK])[2][-1]
    u = np.zeros((1, N_ERROR))
    u[0, DK] = v
    return u


def _record_camera_sources(filt, decisions, k: int, nis: dict, accepted: dict) -> None:
    """Step ``k``'s NIS and gate decision per camera source (an ungated update counts as accepted)."""
    verdict = {d.source: d for d in decisions}
    for s in SOURCES:
        y, S = filt.innovations[s]
        nis[s][k] = verdict[s].e2 if s in verdict else float(y @ np.linalg.solve(S, y))
        accepted[s][k] = verdict[s].accepted if s in verdict else True
