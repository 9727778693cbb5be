"""The recording of one navigation run (EKF/UKF of Renis et al.): truth, estimate, error ±3σ, measurements, gates."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from estimators.error_state import boxminus
from estimators.navigation import SOURCES, NavigationRun
from estimators.state import DK, DR_ST_T, DTHETA, DV_ST_T, DW_ST_T, K, Q_TS, R_ST_T, V_ST_T, W_ST_T
from studies.recording.blueprint import AXES, converged_range, hemisphere_continuous, run_blueprint, send_error, send_estimate, send_quaternion, send_truth
from studies.recording.writer import recording, send_scalars, set_sim_time
from studies.sim.truth import Truth

QUAT_AXES = ("0", "1", "2", "3")
#: Recorded vector quantities: (state slice, error-state slice, axis names).
QUANTITIES = {"w_ST_T": (W_ST_T, DW_ST_T, AXES), "r_ST_T": (R_ST_T, DR_ST_T, AXES), "v_ST_T": (V_ST_T, DV_ST_T, AXES), "k": (K, DK, ("k1", "k2"))}


def _send_states(rec, f: str, t, run: NavigationRun, x_true) -> None:
    """The estimate of every state quantity; with ``x_true`` (N, 15) also the truth and the errors against the filter's ±3σ."""
    sig = np.sqrt(np.diagonal(run.P, axis1=1, axis2=2))
    if x_true is None:
        send_estimate(rec, f, "q_TS", t, hemisphere_continuous(run.x[:, Q_TS]), axes=QUAT_AXES)
    else:
        send_quaternion(rec, f, "q_TS", t, run.x[:, Q_TS], x_true[:, Q_TS], QUAT_AXES)
        # attitude error δp ≈ rotation vector of q̂ ⊗ q⁻¹ (rad), against the filter's own 3σ
        send_error(rec, f, "q_TS", t, boxminus(run.x, x_true)[:, DTHETA], sig[:, DTHETA])
    for name, (sl, esl, axes) in QUANTITIES.items():
        if x_true is not None:
            send_truth(rec, name, t, x_true[:, sl], axes)
        send_estimate(rec, f, name, t, run.x[:, sl], truth=None if x_true is None else x_true[:, sl], sigma=sig[:, esl], axes=axes)


def record_navigation(path: Path, tr: Truth, run: NavigationRun, meas, *, recording_id: str, extra_scalars: dict | None = None,
                      with_truth: bool = True) -> None:
    """``path`` (``.rrd``) in the layout of :mod:`studies.recording.blueprint`, with its viewer layout.

    ``with_truth=False`` (measurements whose truth is unknown): the estimate only, no ``/truth/...``
    and no errors; ``tr`` then only gives the times.

    ``meas``: ``(t, q_TS, r_ST_T, ...)`` as the filter saw them; ``extra_scalars``:
    ``{entity: (t, values)}`` further series (e.g. ``/measurement/faulty``).
    """
    import rerun as rr

    f, t = run.filter, tr.t
    sig = np.sqrt(np.diagonal(run.P, axis1=1, axis2=2))
    error_ranges, gate_range = None, None
    if with_truth:
        error = {"q_TS": (boxminus(run.x, tr.x)[:, DTHETA], sig[:, DTHETA])}
        error.update({name: (run.x[:, sl] - tr.x[:, sl], sig[:, esl]) for name, (sl, esl, _) in QUANTITIES.items()})
        # visible ranges from the converged part: the initial transient would flatten the rest of each plot
        error_ranges = {(f, name): converged_range(t, e, 3.0 * s, -3.0 * s) for name, (e, s) in error.items()}
    upper = max((d.upper for d in run.decisions), default=0.0)  # the gates' chi-square bound stays in view
    gate_range = converged_range(t, np.column_stack([run.nis[s] for s in SOURCES]), floor=1.25 * upper)
    blueprint = run_blueprint(quantities=["q_TS", *QUANTITIES], filters=[f], gates=True, error_ranges=error_ranges, gate_range=gate_range)
    with recording(path, recording_id=recording_id, blueprint=blueprint) as rec:
        _send_states(rec, f, t, run, tr.x if with_truth else None)
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
        set_sim_time(rec, 0.0)
        for d in run.decisions:
            if not d.accepted:
                set_sim_time(rec, d.t)
                rec.log(f"/gate/{f}/log", rr.TextLog(f"{d.source} rejected: e2 = {d.e2:.3g} outside [{d.lower:.3g}, {d.upper:.3g}] ({d.reason})", level="WARN"))
        for t_re, source in run.reacquisitions:
            set_sim_time(rec, t_re)
            rec.log(f"/gate/{f}/log", rr.TextLog(f"{source} re-acquired from its last rejected innovations (estimators.reacquisition)", level="INFO"))
        if run.proxy_used.any():
            send_scalars(rec, f"/estimate/{f}/proxy_used", t, run.proxy_used.astype(float))
        for entity, (te, values) in (extra_scalars or {}).items():
            send_scalars(rec, entity, te, values)
