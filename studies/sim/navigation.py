"""One navigation run as the filter studies and ``lcnav run`` do it: measurements, initial guess, filter, metrics.

Shared by ``lcnav run`` (:mod:`studies.cli.run`) and the studies of Renis et al.
§6 (:mod:`studies.catalog.tuning_study`, :mod:`studies.catalog.init_study`,
:mod:`studies.catalog.proxy_study`):

* :func:`initial_guess` — §6's initial estimate: ``q_TS = 1``, ``ω = r = v = 0``,
  ``k`` from the true inertia scaled by ``U(lo, hi)`` per axis;
* :func:`navigate` — simulated pose measurements (eqs 33–34, with fault
  windows), the initial guess, optionally the prior as initial condition
  (§6.2) and/or as proxy measurement (§6.3), then the filter;
* :func:`run_metrics` — §6's convergence time and steady-state RMSE per
  group, state and filter based, as a flat dict for a study's runs table;
* :func:`consistency_check` — Monte-Carlo NEES/NIS and gate rates of one
  filter and tuning from initial errors drawn from its ``P_0``;
* :func:`error_series` — per-step error magnitude and 1-σ per group, the
  data of the error-vs-time figures (Figs 6 and 7 of Renis et al.);

Its recording is :func:`studies.recording.navigation.record_navigation`; what the filter studies share
(config fields, thresholds, tables, figures) is :mod:`studies.catalog.filter_common`.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from estimators.dynamics import k_from_inertia
from estimators.error_state import boxplus
from estimators.measurement import PoseNoise
from estimators.navigation import SOURCES, NavigationRun, run_navigation
from estimators.prior import R_OMEGA_PROXY, BodyRatePrior, initialize_with_prior
from estimators.state import DK, DW_ST_T, K, K_STATES, N_ERROR, N_STATE, Q_TS
from estimators.tuning import Tuning
from perception.simulated_pose import simulate_pose_measurements
from studies.sim.metrics import GROUPS, SETTLING_S, chi_square_band, evaluate, filter_sigmas, fraction_in_band, nees, state_errors
from studies.sim.truth import Truth



def one_axis(w) -> bool:
    """A tumble about one body axis (at most one non-zero rate component): ``k`` is then unobservable."""
    return int(np.count_nonzero(np.asarray(w, dtype=float))) <= 1


def initial_guess(tr: Truth, rng: np.random.Generator, inertia_range=(0.7, 1.3)) -> np.ndarray:
    """§6 of Renis et al.: ``q_TS = 1``, ``ω = r = v = 0``, ``k`` of ``J_T · a``, ``a_i ~ U(lo, hi)``."""
    a = rng.uniform(inertia_range[0], inertia_range[1], 3)
    x0 = np.zeros(N_STATE)
    x0[Q_TS] = (1.0, 0.0, 0.0, 0.0)
    x0[K] = k_from_inertia(tr.J_T_diag * a)
    return x0


def navigate(
    tr: Truth,
    filter_name: str,
    tuning: Tuning,
    rng: np.random.Generator,
    *,
    P0=None,
    prior: BodyRatePrior | None = None,
    prior_use: str = "none",
    proxy_mode: str = "always",
    R_w: float = R_OMEGA_PROXY,
    pose_noise: PoseNoise = PoseNoise(),
    filter_noise: PoseNoise | None = None,
    faults=(),
    fault_sigma_q_rad: float = 1.5,
    fault_sigma_r_m: float = 20.0,
    gate_confidence: float | None = 0.99,
    gate_start_s: float = 10.0,
    reacquire_window: int | None = 5,
    consider=(),
    inertia_range=(0.7, 1.3),
    meas=None,
    P0_w_prior: float | None = None,
):
    """One filter run on the truth ``tr``; returns ``(NavigationRun, (t_meas, q_meas, r_meas, faulty))``.

    Draws, in this order from ``rng``: the measurements (unless ``meas`` is
    given; noise ``pose_noise``, eqs 33–34), then the initial inertia guess — so runs that share a seed share
    both. The filter's ``R_d`` is ``pose_noise`` too; ``filter_noise`` gives the
    filter another one, for a study that mis-models the noise on purpose. ``prior_use``: ``"none"``, ``"init"`` (``ω̂_0`` and ``P_0``'s ω block
    from the prior, §6.2; ``P0_w_prior`` overrides that block's variance) or
    ``"proxy"`` (also initialises, and pushes the prior as a ``ω`` measurement
    per ``proxy_mode``, §6.3). ``reacquire_window``: see
    :func:`estimators.navigation.run_navigation` (``None``: no re-acquisition).
    """
    if meas is None:
        m = simulate_pose_measurements(tr.t, tr.x, rng, tau_s=float(tr.t[1] - tr.t[0]), sigma_q_rad=pose_noise.sigma_q_rad,
                                       sigma_r_m=pose_noise.sigma_r_m, faults=faults, fault_sigma_q_rad=fault_sigma_q_rad,
                                       fault_sigma_r_m=fault_sigma_r_m, noise=pose_noise.model)
        meas = (m.t, m.q_TS, m.r_ST_T, m.faulty)
    x0 = initial_guess(tr, rng, inertia_range)
    P0 = tuning.P_0 if P0 is None else np.asarray(P0, dtype=float)
    if prior_use in ("init", "proxy"):
        x0, P0 = initialize_with_prior(x0, P0, prior, tr.servicer[0])
        if P0_w_prior is not None:
            P0[DW_ST_T, DW_ST_T] = P0_w_prior * np.eye(3)
    run = run_navigation(
        filter_name, tr.t, tr.servicer, tr.J_S_diag, *meas[:3], x0=x0, P0=P0, tuning=tuning,
        pose_noise=pose_noise if filter_noise is None else filter_noise,
        gate_confidence=gate_confidence, gate_start_s=gate_start_s, prior=prior,
        proxy=proxy_mode if prior_use == "proxy" else None, R_w=R_w, consider=consider,
        reacquire_window=reacquire_window,
    )
    return run, meas


def consistency_check(tr: Truth, filter_name: str, tuning: Tuning, *, n_runs: int = 30, first_seed: int = 1000,
                      pose_noise: PoseNoise = PoseNoise(), gate_confidence: float = 0.99, gate_start_s: float = 10.0,
                      settling_s: float = SETTLING_S, confidence: float = 0.95) -> dict:
    """NEES, NIS and gate statistics of ``n_runs`` runs on ``tr`` from initial errors drawn from ``N(0, P_0)``.

    Run ``i`` draws from ``default_rng(first_seed + i)`` the measurements
    (``pose_noise``, also the filter's ``R_d``), then the initial error
    ``δx ~ N(0, tuning.P_0)``, ``x̂_0 = x ⊞ δx`` — so that the NEES means what it
    says from the first step (§6's fixed guess ``q = 1, r = 0`` is 50 m off in
    position against a 1 m ``P_0``). One-axis tumbles consider ``k`` and test
    12 states. Steps from ``settling_s`` on count (:data:`studies.sim.metrics.SETTLING_S`).

    Returns a flat dict: ``nees_in_band`` (fraction of steps whose ``n_runs``-mean
    NEES lies in its two-sided ``confidence`` band), ``nees_below``/``nees_above``,
    ``nees_in_band_from_start`` (the same over every step after ``t[0]``, settling included),
    ``nees_per_dof`` with its t interval over runs (``_lo``/``_hi``),
    ``nees_per_dof_worst_run``; per source ``nis_<s>_in_band``, ``nis_<s>_per_dof``
    (t interval), ``gate_<s>_rejected`` (rate above the one-sided bound, Wilson
    interval, nominal ``1 − gate_confidence``) and ``nis_<s>_low`` (rate below the
    lower two-sided bound, nominal ``(1 − gate_confidence)/2``: counted, never rejected).
    """
    from scipy.stats import chi2

    from studies.engine.stats import proportion_interval, t_interval

    oa = one_axis(tr.scenario.w_T0_T_rad_s)
    states = np.arange(DK.start) if oa else np.arange(N_ERROR)
    dof = len(states)
    sel = (tr.t - tr.t[0]) >= settling_s
    if not sel.any():
        raise ValueError(f"settling_s ({settling_s} s) must be shorter than the run ({tr.t[-1] - tr.t[0]} s)")
    E, E_all, nis = [], [], {s: [] for s in SOURCES}
    for i in range(n_runs):
        rng = np.random.default_rng(first_seed + i)
        m = simulate_pose_measurements(tr.t, tr.x, rng, tau_s=float(tr.t[1] - tr.t[0]), sigma_q_rad=pose_noise.sigma_q_rad,
                                       sigma_r_m=pose_noise.sigma_r_m, noise=pose_noise.model)
        x0 = boxplus(tr.x[0], rng.multivariate_normal(np.zeros(N_ERROR), tuning.P_0))
        run = run_navigation(filter_name, tr.t, tr.servicer, tr.J_S_diag, m.t, m.q_TS, m.r_ST_T, x0=x0, tuning=tuning,
                             pose_noise=pose_noise, gate_confidence=gate_confidence, gate_start_s=gate_start_s,
                             consider=K_STATES if oa else ())
        E_all.append(nees(run.x, run.P, tr.x, states)[1:])
        E.append(E_all[-1][sel[1:]])
        for s in SOURCES:
            nis[s].append(run.nis[s][sel])
    E = np.array(E)
    lo, hi = chi_square_band(dof, n_runs, confidence)
    avg = E.mean(axis=0)
    avg_all = np.mean(E_all, axis=0)
    per_run = E.mean(axis=1) / dof
    iv = t_interval(per_run, confidence)
    out = {"filter": filter_name, "scenario": tr.scenario.name, "tuning": tuning.name, "runs": n_runs, "dof": dof,
           "settling_s": settling_s, "duration_s": float(tr.t[-1] - tr.t[0]),
           "nees_in_band": float(np.mean((avg >= lo) & (avg <= hi))), "nees_below": float(np.mean(avg < lo)),
           "nees_above": float(np.mean(avg > hi)), "nees_in_band_from_start": float(np.mean((avg_all >= lo) & (avg_all <= hi))),
           "nees_per_dof": iv.estimate, "nees_per_dof_lo": iv.lo,
           "nees_per_dof_hi": iv.hi, "nees_per_dof_worst_run": float(per_run.max())}
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
    """§6 metrics as a flat dict: ``ct_<g>_s``/``ess_<g>`` (state based), ``ct_f_<g>_s``/``ess_f_<g>`` (filter based).

    NaN where the group did not converge below its threshold.
    """
    m = evaluate(tr.t, run.x, run.P, tr.x, thresholds)
    out = {}
    for kind, prefix in (("state", ""), ("filter", "f_")):
        for g in GROUPS:
            out[f"ct_{prefix}{g}_s"] = m[kind][g].convergence_time_s
            out[f"ess_{prefix}{g}"] = m[kind][g].steady_state_rmse
    return out


def error_series(tr: Truth, run: NavigationRun) -> pd.DataFrame:
    """Per step: ``t_s``, the state-based error magnitude ``err_<g>`` and the filter's 1-σ ``sigma_<g>`` per group."""
    cols = {"t_s": tr.t - tr.t[0]}
    cols.update({f"err_{g}": v for g, v in state_errors(run.x, tr.x).items()})
    cols.update({f"sigma_{g}": v for g, v in filter_sigmas(run.P).items()})
    return pd.DataFrame(cols)
