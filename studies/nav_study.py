"""One navigation run as the filter studies and ``lcnav run`` do it: measurements, initial guess, filter, metrics, recording.

Shared by ``lcnav run`` (:mod:`studies.run_cmd`) and the studies of ``002_…``
§6 (:mod:`studies.tuning_study`, :mod:`studies.init_study`,
:mod:`studies.proxy_study`):

* :func:`initial_guess` — §6's initial estimate: ``q_TS = 1``, ``ω = r = v = 0``,
  ``k`` from the true inertia scaled by ``U(lo, hi)`` per axis;
* :func:`navigate` — simulated pose measurements (eqs 33–34, with fault
  windows), the initial guess, optionally the prior as initial condition
  (§6.2) and/or as proxy measurement (§6.3), then the filter;
* :func:`run_metrics` — §6's convergence time and steady-state RMSE per
  group, state and filter based, as a flat dict for a study's runs table;
* :func:`error_series` — per-step error magnitude and 1-σ per group, the
  data of the error-vs-time figures (Figs 6 and 7 of ``002_…``);
* :func:`record_navigation` — the run's ``.rrd`` in the layout of
  :mod:`studies.blueprint` (truth, estimate, error ±3σ, measurements, gates).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from estimators.dynamics import k_from_inertia
from estimators.error_state import ERROR_SLICES, boxminus
from estimators.navigation import SOURCES, NavigationRun, run_navigation
from estimators.prior import R_OMEGA_PROXY, SpinPrior, initialize_with_prior
from estimators.tuning import Tuning
from perception.simulated_pose import simulate_pose_measurements
from studies.blueprint import AXES, run_blueprint, send_error, send_estimate, send_truth
from studies.metrics import GROUPS, evaluate, filter_sigmas, state_errors
from studies.recording import TIMELINE, recording, send_scalars
from studies.truth import Truth

QUAT_AXES = ("0", "1", "2", "3")
#: Error-state indices of ``k1, k2`` (considered, not estimated, in one-axis tumbles).
K_STATES = (12, 13)


def one_axis(w) -> bool:
    """A tumble about one body axis (at most one non-zero rate component): ``k`` is then unobservable."""
    return int(np.count_nonzero(np.asarray(w, dtype=float))) <= 1


def initial_guess(tr: Truth, rng: np.random.Generator, inertia_range=(0.7, 1.3)) -> np.ndarray:
    """§6 of ``002_…``: ``q_TS = 1``, ``ω = r = v = 0``, ``k`` of ``J_T · a``, ``a_i ~ U(lo, hi)``."""
    a = rng.uniform(inertia_range[0], inertia_range[1], 3)
    x0 = np.zeros(15)
    x0[0] = 1.0
    x0[13:15] = k_from_inertia(tr.J_T_diag * a)
    return x0


def navigate(
    tr: Truth,
    filter_name: str,
    tuning: Tuning,
    rng: np.random.Generator,
    *,
    P0=None,
    prior: SpinPrior | None = None,
    prior_use: str = "none",
    proxy_mode: str = "always",
    R_w: float = R_OMEGA_PROXY,
    sigma_q_rad: float = 0.12,
    sigma_r_m: float = 0.37,
    faults=(),
    fault_sigma_q_rad: float = 1.5,
    fault_sigma_r_m: float = 20.0,
    noise: str = "isotropic",
    gate_confidence: float | None = 0.99,
    gate_start_s: float = 10.0,
    consider=(),
    inertia_range=(0.7, 1.3),
    meas=None,
    P0_w_prior: float | None = None,
):
    """One filter run on the truth ``tr``; returns ``(NavigationRun, (t_meas, q_meas, r_meas, faulty))``.

    Draws, in this order from ``rng``: the measurements (unless ``meas`` is
    given; pose noise amplitudes ``sigma_q_rad``, ``sigma_r_m``, eqs 33–34), then the initial inertia guess — so runs that share a seed share
    both. ``prior_use``: ``"none"``, ``"init"`` (``ω̂_0`` and ``P_0``'s ω block
    from the prior, §6.2; ``P0_w_prior`` overrides that block's variance) or
    ``"proxy"`` (also initialises, and pushes the prior as a ``ω`` measurement
    per ``proxy_mode``, §6.3).
    """
    if meas is None:
        m = simulate_pose_measurements(tr.t, tr.x, rng, tau_s=float(tr.t[1] - tr.t[0]), sigma_q_rad=sigma_q_rad,
                                       sigma_r_m=sigma_r_m, faults=faults, fault_sigma_q_rad=fault_sigma_q_rad,
                                       fault_sigma_r_m=fault_sigma_r_m, noise=noise)
        meas = (m.t, m.q_TS, m.r_ST_T, m.faulty)
    x0 = initial_guess(tr, rng, inertia_range)
    P0 = tuning.P_0 if P0 is None else np.asarray(P0, dtype=float)
    if prior_use in ("init", "proxy"):
        x0, P0 = initialize_with_prior(x0, P0, prior, tr.servicer[0])
        if P0_w_prior is not None:
            P0[3:6, 3:6] = P0_w_prior * np.eye(3)
    run = run_navigation(
        filter_name, tr.t, tr.servicer, tr.J_S_diag, *meas[:3], x0=x0, P0=P0, tuning=tuning,
        gate_confidence=gate_confidence, gate_start_s=gate_start_s, prior=prior,
        proxy=proxy_mode if prior_use == "proxy" else None, R_w=R_w, consider=consider,
    )
    return run, meas


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


def record_navigation(path: Path, tr: Truth, run: NavigationRun, meas, *, recording_id: str, extra_scalars: dict | None = None) -> None:
    """``path`` (``.rrd``) in the layout of :mod:`studies.blueprint`, with its viewer layout.

    ``meas``: ``(t, q_TS, r_ST_T, ...)`` as the filter saw them; ``extra_scalars``:
    ``{entity: (t, values)}`` further series (e.g. ``/measurement/faulty``).
    """
    import rerun as rr

    f, t = run.filter, tr.t
    sig = np.sqrt(np.diagonal(run.P, axis1=1, axis2=2))
    quantities = {"w_ST_T": (slice(4, 7), ERROR_SLICES["w"], AXES), "r_ST_T": (slice(7, 10), ERROR_SLICES["r"], AXES),
                  "v_ST_T": (slice(10, 13), ERROR_SLICES["v"], AXES), "k": (slice(13, 15), ERROR_SLICES["k"], ("k1", "k2"))}
    blueprint = run_blueprint(quantities=["q_TS", *quantities], filters=[f], gates=True)
    with recording(path, recording_id=recording_id, blueprint=blueprint) as rec:
        send_truth(rec, "q_TS", t, tr.x[:, 0:4], QUAT_AXES)
        send_estimate(rec, f, "q_TS", t, run.x[:, 0:4], axes=QUAT_AXES)
        # attitude error δp ≈ rotation vector of q̂ ⊗ q⁻¹ (rad), against the filter's own 3σ
        send_error(rec, f, "q_TS", t, boxminus(run.x, tr.x)[:, 0:3], sig[:, ERROR_SLICES["q"]])
        for name, (sl, esl, axes) in quantities.items():
            send_truth(rec, name, t, tr.x[:, sl], axes)
            send_estimate(rec, f, name, t, run.x[:, sl], truth=tr.x[:, sl], sigma=sig[:, esl], axes=axes)
        tm, qm, rm = meas[:3]
        send_scalars(rec, "/measurement/attitude/q_TS", tm, qm, list(QUAT_AXES))
        send_scalars(rec, "/measurement/position/r_ST_T", tm, rm, list(AXES))
        for s in SOURCES:
            ok = np.isfinite(run.nis[s])
            if ok.any():
                send_scalars(rec, f"/gate/{f}/{s}/e2", t[ok], run.nis[s][ok])
        by_source = {s: [d for d in run.decisions if d.source == s] for s in SOURCES}
        for s, ds in by_source.items():
            if ds:
                td = np.array([d.t for d in ds])
                send_scalars(rec, f"/gate/{f}/{s}/lower", td, np.array([d.lower for d in ds]))
                send_scalars(rec, f"/gate/{f}/{s}/upper", td, np.array([d.upper for d in ds]))
        rec.set_time(TIMELINE, duration=0.0)
        for d in run.decisions:
            if not d.accepted:
                rec.set_time(TIMELINE, duration=float(d.t))
                rec.log(f"/gate/{f}/log", rr.TextLog(f"{d.source} rejected: e2 = {d.e2:.3g} outside [{d.lower:.3g}, {d.upper:.3g}] ({d.reason})", level="WARN"))
        if run.proxy_used.any():
            send_scalars(rec, f"/estimate/{f}/proxy_used", t, run.proxy_used.astype(float))
        for entity, (te, values) in (extra_scalars or {}).items():
            send_scalars(rec, entity, te, values)
