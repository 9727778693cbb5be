"""One navigation run as the filter studies and ``lcnav run`` do it: measurements, initial guess, filter, metrics.

Shared by ``lcnav run`` (:mod:`studies.cli.run`) and the studies of Renis et al.
§6 (:mod:`studies.catalog.tuning_study`, :mod:`studies.catalog.init_study`,
:mod:`studies.catalog.proxy_study`):

* :func:`initial_guess` — §6's initial estimate: ``q_TS = 1``, ``ω = r = v = 0``,
  ``k`` from the true inertia scaled by ``U(lo, hi)`` per axis;
* :class:`NavigationSetup` — one run's filter, tuning, prior and its use,
  noise, faults, gates, re-acquisition and considered states, validated;
* :func:`navigate` — simulated pose measurements (eqs 33–34, with fault
  windows, :func:`simulate_measurements`), the initial guess, optionally the
  prior as initial condition (§6.2) and/or as proxy measurement (§6.3), then the filter;
* :func:`run_metrics` — §6's convergence time and steady-state RMSE per
  group, state and filter based, as a flat dict for a study's runs table;
* :func:`consistency_check` — Monte-Carlo NEES/NIS and gate rates of one
  filter and tuning from initial errors drawn from its ``P_0``, on one truth or on one per run
  (:func:`dispersed_truth`: the scenario started at a random point of its orbit);
* :func:`error_series` — per-step error magnitude and 1-σ per group, the
  data of the error-vs-time figures (Figs 6 and 7 of Renis et al.);

Its recording is :func:`studies.recording.navigation.record_navigation`; what the filter studies share
(config fields, thresholds, tables, figures) is :mod:`studies.catalog.filter_common`.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import pandas as pd

from estimators.dynamics import k_from_inertia
from estimators.error_state import boxplus
from estimators.filter import DivergenceError
from estimators.measurement import PoseNoise
from estimators.perturbations import get_truth_physics
from estimators.navigation import FILTERS, SOURCES, NavigationRun, run_navigation
from estimators.prior import PROXY_MODES, R_OMEGA_PROXY, BodyRatePrior, initialize_with_prior
from estimators.state import DW_ST_T, K, K_STATES, N_ERROR, N_STATE, Q_TS
from estimators.tuning import Tuning
from perception.simulated_pose import parse_faults, simulate_pose_measurements
from studies.sim.metrics import (GROUPS, SETTLING_S, block_nees_per_dof, chi_square_band, evaluate, filter_sigmas, fraction_in_band, late_rmse, nees,
                                 state_errors)
from studies.sim.truth import Truth, simulate_truth



def one_axis(w) -> bool:
    """A tumble about one body axis (at most one non-zero rate component): ``k`` is then unobservable."""
    return int(np.count_nonzero(np.asarray(w, dtype=float))) <= 1


def considered_states(scenario, physics) -> tuple:
    """The error states a run's filter considers instead of estimating: ``k1, k2`` (:data:`estimators.state.K_STATES`) in a
    one-axis tumble of the torque-free world, where they stay unobservable; none in orbit (``physics`` not torque-free), where
    the gravity gradient moves every spin off its axis and the inertia ratios then drive the rate. Measured on SC1 (the
    intermediate axis: its spin flips within 1200 s of the perturbed truth; 20 runs of one orbit, EKF, gravity gradient
    modelled): with ``k`` considered, NEES/dof 48–6100 per 500 s; estimated, 0.86–1.82 (0.86–1.01 from 1000 s on).
    ``scenario``: a :class:`studies.sim.scenarios.Scenario`; ``physics``: a truth-physics name or object.
    """
    return K_STATES if one_axis(scenario.w_T0_T_rad_s) and get_truth_physics(physics).torque_free else ()


def initial_guess(tr: Truth, rng: np.random.Generator, inertia_range=(0.7, 1.3)) -> np.ndarray:
    """§6 of Renis et al.: ``q_TS = 1``, ``ω = r = v = 0``, ``k`` of ``J_T · a``, ``a_i ~ U(lo, hi)``."""
    a = rng.uniform(inertia_range[0], inertia_range[1], 3)
    x0 = np.zeros(N_STATE)
    x0[Q_TS] = (1.0, 0.0, 0.0, 0.0)
    x0[K] = k_from_inertia(tr.J_T_diag * a)
    return x0


#: How a run uses the spin prior: not at all, as initial condition (§6.2), or also as proxy measurement (§6.3).
PRIOR_USES = ("none", "init", "proxy")


def _check_number(name: str, value, *, lo: float = 0.0, lo_open: bool = True, hi: float = np.inf, hi_open: bool = True, optional: bool = False):
    """``value`` as a float within its bounds (``None`` passes when ``optional``); else a ``ValueError`` naming the field."""
    if value is None and optional:
        return None
    try:
        x = float(value)
    except (TypeError, ValueError):
        x = np.nan
    above = x > lo if lo_open else x >= lo
    below = x < hi if hi_open else x <= hi
    if not (np.isfinite(x) and above and below):
        bounds = f"{'(' if lo_open else '['}{lo:g}, {hi:g}{')' if hi_open else ']'}"
        raise ValueError(f"NavigationSetup.{name} must be a finite number in {bounds}{' or None' if optional else ''}, got {value!r}")
    return x


@dataclass(frozen=True)
class NavigationSetup:
    """One filter run's set-up besides the truth and the random stream, validated on construction.

    ``filter_name``/``tuning``/``P0`` (``None``: ``tuning.P_0``): the filter and its start.
    ``prior``/``prior_use``: the body-rate prior and how it is used (:data:`PRIOR_USES`:
    ``"none"``; ``"init"``, ``ω̂_0`` and ``P_0``'s ω block from the prior, §6.2, with
    ``P0_w_prior`` overriding that block's variance; ``"proxy"``, which also initialises
    and pushes the prior as an ``ω`` measurement of covariance ``R_w I`` per ``proxy_mode``, §6.3).
    ``pose_noise``: the simulated measurements' noise (eqs 33–34) and the filter's ``R_d``;
    ``filter_noise`` gives the filter another one, for a study that mis-models the noise on
    purpose. ``faults``: ``(start_s, length_s)`` windows of heavy noise
    (``fault_sigma_q_rad``, ``fault_sigma_r_m``). ``gate_confidence`` (``None``: no gates) from
    ``gate_start_s``; ``reacquire_window``: see :func:`estimators.navigation.run_navigation`
    (``None``: no re-acquisition). ``consider``: error-state indices considered, not estimated
    (:data:`estimators.state.K_STATES` in one-axis tumbles). ``inertia_range``: the initial
    inertia guess ``J_T · a``, ``a_i ~ U(lo, hi)`` (§6).
    """

    filter_name: str
    tuning: Tuning
    P0: np.ndarray | None = None
    prior: BodyRatePrior | None = None
    prior_use: str = "none"
    proxy_mode: str = "always"
    R_w: float = R_OMEGA_PROXY
    pose_noise: PoseNoise = PoseNoise()
    filter_noise: PoseNoise | None = None
    faults: tuple = ()
    fault_sigma_q_rad: float = 1.5
    fault_sigma_r_m: float = 20.0
    gate_confidence: float | None = 0.99
    gate_start_s: float = 10.0
    reacquire_window: int | None = 5
    consider: tuple = ()
    inertia_range: tuple = (0.7, 1.3)
    P0_w_prior: float | None = None

    def __post_init__(self):
        self._check_choices()
        self._check_numbers()
        if self.P0 is not None:
            P0 = np.asarray(self.P0, dtype=float)
            if P0.shape != (N_ERROR, N_ERROR) or not np.all(np.isfinite(P0)):
                raise ValueError(f"NavigationSetup.P0 must be a finite {N_ERROR}x{N_ERROR} covariance of the error state or None, got shape {P0.shape}")
            object.__setattr__(self, "P0", P0)
        object.__setattr__(self, "faults", parse_faults(self.faults))
        consider = tuple(int(i) for i in self.consider)
        if any(not 0 <= i < N_ERROR for i in consider):
            raise ValueError(f"NavigationSetup.consider must hold error-state indices 0..{N_ERROR - 1}, got {self.consider!r}")
        object.__setattr__(self, "consider", consider)
        lo, hi = (float(v) for v in self.inertia_range)
        if not (np.isfinite(lo) and np.isfinite(hi) and 0 < lo <= hi):
            raise ValueError(f"NavigationSetup.inertia_range must be (lo, hi) with 0 < lo <= hi, got {self.inertia_range!r}")
        object.__setattr__(self, "inertia_range", (lo, hi))

    def _check_choices(self) -> None:
        if self.filter_name not in FILTERS:
            raise ValueError(f"NavigationSetup.filter_name must be one of {tuple(FILTERS)}, got {self.filter_name!r}")
        if not isinstance(self.tuning, Tuning):
            raise ValueError(f"NavigationSetup.tuning must be a Tuning (estimators.tuning.get_tuning), got {type(self.tuning).__name__}")
        if self.prior_use not in PRIOR_USES:
            raise ValueError(f"NavigationSetup.prior_use must be one of {PRIOR_USES}, got {self.prior_use!r}")
        if self.prior_use != "none" and not isinstance(self.prior, BodyRatePrior):
            raise ValueError(f"NavigationSetup.prior must be a BodyRatePrior when prior_use is {self.prior_use!r}, got {self.prior!r}")
        if self.proxy_mode not in PROXY_MODES:
            raise ValueError(f"NavigationSetup.proxy_mode must be one of {PROXY_MODES}, got {self.proxy_mode!r}")
        for name in ("pose_noise", "filter_noise"):
            noise = getattr(self, name)
            if not (isinstance(noise, PoseNoise) or (name == "filter_noise" and noise is None)):
                raise ValueError(f"NavigationSetup.{name} must be a PoseNoise{' or None' if name == 'filter_noise' else ''}, got {noise!r}")

    def _check_numbers(self) -> None:
        _check_number("R_w", self.R_w)
        _check_number("fault_sigma_q_rad", self.fault_sigma_q_rad)
        _check_number("fault_sigma_r_m", self.fault_sigma_r_m)
        _check_number("gate_confidence", self.gate_confidence, hi=1.0, optional=True)
        _check_number("gate_start_s", self.gate_start_s, lo_open=False)
        _check_number("P0_w_prior", self.P0_w_prior, optional=True)
        w = self.reacquire_window
        if w is not None and (isinstance(w, bool) or not isinstance(w, int | np.integer) or w < 1):
            raise ValueError(f"NavigationSetup.reacquire_window must be a positive whole number of measurements or None, got {w!r}")


def simulate_measurements(tr: Truth, setup: NavigationSetup, rng: np.random.Generator) -> tuple:
    """``(t, q_TS, r_ST_T, faulty)``: the pose estimator's measurements of ``tr`` (eqs 33–34) with ``setup``'s noise and faults."""
    noise = setup.pose_noise
    m = simulate_pose_measurements(tr.t, tr.x, rng, tau_s=float(tr.t[1] - tr.t[0]), sigma_q_rad=noise.sigma_q_rad, sigma_r_m=noise.sigma_r_m,
                                   faults=setup.faults, fault_sigma_q_rad=setup.fault_sigma_q_rad, fault_sigma_r_m=setup.fault_sigma_r_m,
                                   noise=noise.model)
    return m.t, m.q_TS, m.r_ST_T, m.faulty


def navigate(tr: Truth, setup: NavigationSetup, rng: np.random.Generator, meas=None):
    """One filter run on the truth ``tr``; returns ``(NavigationRun, (t_meas, q_meas, r_meas, faulty))``.

    Draws, in this order from ``rng``: the measurements (unless ``meas`` is given,
    :func:`simulate_measurements`), then the initial inertia guess (:func:`initial_guess`) —
    so runs that share a seed share both. The prior is used as ``setup.prior_use`` says.
    """
    if meas is None:
        meas = simulate_measurements(tr, setup, rng)
    x0 = initial_guess(tr, rng, setup.inertia_range)
    P0 = setup.tuning.P_0 if setup.P0 is None else setup.P0
    if setup.prior_use in ("init", "proxy"):
        x0, P0 = initialize_with_prior(x0, P0, setup.prior, tr.servicer[0])
        if setup.P0_w_prior is not None:
            P0[DW_ST_T, DW_ST_T] = setup.P0_w_prior * np.eye(3)
    run = run_navigation(
        setup.filter_name, tr.t, tr.servicer, tr.J_S_diag, *meas[:3], x0=x0, P0=P0, tuning=setup.tuning,
        pose_noise=setup.pose_noise if setup.filter_noise is None else setup.filter_noise,
        gate_confidence=setup.gate_confidence, gate_start_s=setup.gate_start_s, prior=setup.prior,
        proxy=setup.proxy_mode if setup.prior_use == "proxy" else None, R_w=setup.R_w, consider=setup.consider,
        reacquire_window=setup.reacquire_window,
    )
    return run, meas


def dispersed_truth(tr: Truth, rng: np.random.Generator) -> Truth:
    """``tr`` flown again from an argument of latitude drawn ``U(0, 2π)``: same scenario otherwise, physics, steps and duration."""
    scenario = replace(tr.scenario, arg_latitude_rad=float(rng.uniform(0.0, 2.0 * np.pi)))
    return simulate_truth(scenario, float(tr.t[-1] - tr.t[0]), float(tr.t[1] - tr.t[0]), tr.physics)


def monte_carlo_run(tr: Truth, filter_name: str, tuning: Tuning, seed: int, *, pose_noise: PoseNoise = PoseNoise(), gate_confidence: float = 0.99,
                    gate_start_s: float = 10.0, disperse_orbit_phase: bool = False) -> tuple[Truth, NavigationRun]:
    """One Monte-Carlo run of :func:`consistency_check`: ``(truth flown, run)``.

    Draws from ``default_rng(seed)`` the pose measurements (``pose_noise``, also the filter's ``R_d``), then the initial
    error ``δx ~ N(0, tuning.P_0)``, ``x̂_0 = x ⊞ δx``; with ``disperse_orbit_phase`` the truth is first flown again from its
    own orbit phase (:func:`dispersed_truth`, stream ``default_rng((seed, 1))``). The states of :func:`considered_states` are
    considered. Raises :class:`estimators.filter.DivergenceError` when the filter breaks down.
    """
    rng = np.random.default_rng(seed)
    tr_i = dispersed_truth(tr, np.random.default_rng((seed, 1))) if disperse_orbit_phase else tr
    m = simulate_pose_measurements(tr_i.t, tr_i.x, rng, tau_s=float(tr_i.t[1] - tr_i.t[0]), sigma_q_rad=pose_noise.sigma_q_rad,
                                   sigma_r_m=pose_noise.sigma_r_m, noise=pose_noise.model)
    x0 = boxplus(tr_i.x[0], rng.multivariate_normal(np.zeros(N_ERROR), tuning.P_0))
    run = run_navigation(filter_name, tr_i.t, tr_i.servicer, tr_i.J_S_diag, m.t, m.q_TS, m.r_ST_T, x0=x0, tuning=tuning,
                         pose_noise=pose_noise, gate_confidence=gate_confidence, gate_start_s=gate_start_s,
                         consider=considered_states(tr_i.scenario, tr_i.physics))
    return tr_i, run


def consistency_check(tr: Truth, filter_name: str, tuning: Tuning, *, n_runs: int = 30, first_seed: int = 1000,
                      pose_noise: PoseNoise = PoseNoise(), gate_confidence: float = 0.99, gate_start_s: float = 10.0,
                      settling_s: float = SETTLING_S, confidence: float = 0.95, disperse_orbit_phase: bool = False) -> dict:
    """NEES, NIS and gate statistics of ``n_runs`` runs on ``tr`` from initial errors drawn from ``N(0, P_0)``.

    Run ``i`` draws from ``default_rng(first_seed + i)`` the measurements
    (``pose_noise``, also the filter's ``R_d``), then the initial error
    ``δx ~ N(0, tuning.P_0)``, ``x̂_0 = x ⊞ δx`` — so that the NEES means what it
    says from the first step (§6's fixed guess ``q = 1, r = 0`` is 50 m off in
    position against a 1 m ``P_0``). The states of :func:`considered_states` are considered, not tested
    (12 states in a one-axis tumble of the torque-free world). Steps from ``settling_s`` on count (:data:`studies.sim.metrics.SETTLING_S`).

    ``disperse_orbit_phase``: run ``i`` flies its own truth — ``tr``'s scenario, physics, steps and
    duration, started at an argument of latitude ``u_i ~ U(0, 2π)`` (drawn from its own stream,
    ``default_rng((first_seed + i, 1))``, so the other draws stay those of the undispersed runs). On a
    truth with unmodelled physics this is what the chi-square bands assume: the filter's process
    noise models the disturbance as a random process, and the runs must sample it. With one truth
    (the default) every run meets the *same* disturbance history — a bias common to all runs, which
    the run average does not shrink — so the per-step band tests that one history, not the noise
    model (Bar-Shalom, Li, Kirubarajan, *Estimation with Applications to Tracking and Navigation*,
    Wiley 2001, §5.4.2: independent process-noise realizations per run). On the torque-free truth the
    phase changes nothing the filters see but the orbit's position, so both modes agree there.

    A run whose filter breaks down (:class:`estimators.filter.DivergenceError`) is
    counted in ``diverged`` and left out of the statistics, which are over the
    other ``runs``; ``regularized_draws`` sums the UKF's floored sigma-point draws over them
    (:attr:`estimators.navigation.NavigationRun.regularizations`).

    Returns a flat dict: ``nees_in_band`` (fraction of steps whose ``runs``-mean
    NEES lies in its two-sided ``confidence`` band), ``nees_below``/``nees_above``,
    ``nees_in_band_from_start`` (the same over every step after ``t[0]``, settling included),
    ``nees_per_dof`` with its t interval over runs (``_lo``/``_hi``),
    ``nees_per_dof_worst_run``, ``nees_per_dof_<group>`` (each block of :data:`estimators.state.ERROR_GROUPS` alone, its
    own NEES/dof averaged over runs and steps: which block the joint figure's excess comes from), ``nees_per_dof_<group>_given_rest``
    (that block's NEES/dof given the other tested states' errors, :func:`studies.sim.metrics.conditional_nees`: whether ``P``
    states how the blocks' errors move together; a joint figure below the blocks' comes from there); per source ``nis_<s>_in_band``, ``nis_<s>_per_dof``
    (t interval), ``gate_<s>_rejected`` (rate above the one-sided bound, Wilson
    interval, nominal ``1 − gate_confidence``) and ``nis_<s>_low`` (rate below the
    lower two-sided bound, nominal ``(1 − gate_confidence)/2``: counted, never rejected).
    """
    from scipy.stats import chi2

    from studies.engine.stats import proportion_interval, t_interval

    consider = considered_states(tr.scenario, tr.physics)
    states = np.setdiff1d(np.arange(N_ERROR), consider)
    dof = len(states)
    sel = (tr.t - tr.t[0]) >= settling_s
    if not sel.any():
        raise ValueError(f"settling_s ({settling_s} s) must be shorter than the run ({tr.t[-1] - tr.t[0]} s)")
    E, E_all, nis = [], [], {s: [] for s in SOURCES}
    E_block, E_given = [], []
    diverged = regularized = 0
    for i in range(n_runs):
        try:
            tr_i, run = monte_carlo_run(tr, filter_name, tuning, first_seed + i, pose_noise=pose_noise, gate_confidence=gate_confidence,
                                        gate_start_s=gate_start_s, disperse_orbit_phase=disperse_orbit_phase)
        except DivergenceError:
            diverged += 1
            continue
        regularized += run.regularizations
        E_all.append(nees(run.x, run.P, tr_i.x, states)[1:])
        E.append(E_all[-1][sel[1:]])
        alone, given = block_nees_per_dof(run.x[sel], run.P[sel], tr_i.x[sel], states)
        E_block.append(alone)
        E_given.append(given)
        for s in SOURCES:
            nis[s].append(run.nis[s][sel])
    if not E:
        raise DivergenceError(f"{filter_name} with {tuning.name!r} diverged in all {n_runs} runs on {tr.scenario.name}")
    E = np.array(E)
    lo, hi = chi_square_band(dof, len(E), confidence)
    avg = E.mean(axis=0)
    avg_all = np.mean(E_all, axis=0)
    per_run = E.mean(axis=1) / dof
    iv = t_interval(per_run, confidence)
    out = {"filter": filter_name, "scenario": tr.scenario.name, "tuning": tuning.name, "runs": len(E), "diverged": diverged, "dof": dof,
           "orbit_phase": "dispersed" if disperse_orbit_phase else "fixed",
           "regularized_draws": regularized,
           "settling_s": settling_s, "duration_s": float(tr.t[-1] - tr.t[0]),
           "nees_in_band": float(np.mean((avg >= lo) & (avg <= hi))), "nees_below": float(np.mean(avg < lo)),
           "nees_above": float(np.mean(avg > hi)), "nees_in_band_from_start": float(np.mean((avg_all >= lo) & (avg_all <= hi))),
           "nees_per_dof": iv.estimate, "nees_per_dof_lo": iv.lo,
           "nees_per_dof_hi": iv.hi, "nees_per_dof_worst_run": float(per_run.max()),
           **{f"nees_per_dof_{g}": float(np.mean([b[g] for b in E_block])) for g in E_block[0]},
           **{f"nees_per_dof_{g}_given_rest": float(np.mean([b[g] for b in E_given])) for g in E_given[0]}}
    upper = chi2.ppf(gate_confidence, 3)
    lower = chi2.ppf(0.5 * (1.0 - gate_confidence), 3)
    for s in SOURCES:
        v = np.array(nis[s])
        ok = np.isfinite(v)
        out[f"nis_{s}_in_band"] = fraction_in_band(v, 3, confidence=confidence)
        niv = t_interval(np.nanmean(v, axis=1) / 3.0, confidence)
        out.update({f"nis_{s}_per_dof": niv.estimate, f"nis_{s}_per_dof_lo": niv.lo, f"nis_{s}_per_dof_hi": niv.hi})
        for key, k in ((f"gate_{s}_rejected", int(np.sum(v[ok] > upper))), (f"nis_{s}_low", int(np.sum(v[ok] < lower)))):
            p = proportion_interval(k, int(ok.sum()), confidence)
            out.update({key: p.estimate, f"{key}_lo": p.lo, f"{key}_hi": p.hi})
    return out


def run_metrics(tr: Truth, run: NavigationRun, thresholds: dict | None = None) -> dict:
    """§6 metrics as a flat dict: ``ct_<g>_s``/``ess_<g>`` (state based), ``ct_f_<g>_s``/``ess_f_<g>`` (filter based),
    and ``late_rmse_<g>``: the state-based RMSE over the second half of the run (:func:`studies.sim.metrics.late_rmse`,
    the same steps for every run on a truth: the paired comparison of two arms).

    NaN where the group did not converge below its threshold (``ct``/``ess``).
    """
    m = evaluate(tr.t, run.x, run.P, tr.x, thresholds)
    out = {}
    for kind, prefix in (("state", ""), ("filter", "f_")):
        for g in GROUPS:
            out[f"ct_{prefix}{g}_s"] = m[kind][g].convergence_time_s
            out[f"ess_{prefix}{g}"] = m[kind][g].steady_state_rmse
    out.update({f"late_rmse_{g}": late_rmse(tr.t, e) for g, e in state_errors(run.x, tr.x).items()})
    return out


def error_series(tr: Truth, run: NavigationRun) -> pd.DataFrame:
    """Per step: ``t_s``, the state-based error magnitude ``err_<g>`` and the filter's 1-σ ``sigma_<g>`` per group."""
    cols = {"t_s": tr.t - tr.t[0]}
    cols.update({f"err_{g}": v for g, v in state_errors(run.x, tr.x).items()})
    cols.update({f"sigma_{g}": v for g, v in filter_sigmas(run.P).items()})
    return pd.DataFrame(cols)
