"""The CoMBiNa run recording (``combina.rrd``) and its states table (``states.parquet``)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from estimators.attitude import mrp_to_quat
from studies.recording.blueprint import run_blueprint, send_error
from studies.recording.writer import recording, rr, send_poses, send_scalars, set_sim_time, time_column
from studies.sim.combina import FILTER_COMPONENTS, CombinaRun, component_errors


AXES = ("x", "y", "z")


def states_table(run: CombinaRun) -> pd.DataFrame:
    """One row per epoch (the initial one has no measurement)."""
    tr = run.truth
    S = run.steps
    cols: dict[str, object] = {"t_s": [s.t for s in S], "mode": [s.mode for s in S], "shadow_switch": [s.shadow_switch for s in S]}

    def put(prefix, arr, names):
        arr = np.asarray(arr, dtype=float)
        for j, n in enumerate(names):
            cols[f"{prefix}_{n}"] = arr[:, j]

    put("true_r_L_m", tr.r_L, AXES)
    put("true_v_L_m_s", tr.v_L, AXES)
    put("true_q_IT", tr.q_IT, ("0", "1", "2", "3"))
    put("true_w_T_rad_s", tr.w_T, AXES)
    put("est_r_L_m", [s.x_s[:3] for s in S], AXES)
    put("sd_r_L_m", [s.sd_s[:3] for s in S], AXES)
    put("est_v_L_m_s", [s.x_s[3:] for s in S], AXES)
    put("sd_v_L_m_s", [s.sd_s[3:] for s in S], AXES)
    put("est_sigma_IT", [s.x_a[:3] for s in S], ("1", "2", "3"))
    put("sd_sigma_IT", [s.sd_a[:3] for s in S], ("1", "2", "3"))
    put("est_w_T_rad_s", [s.x_a[3:6] for s in S], AXES)
    put("sd_w_T_rad_s", [s.sd_a[3:6] for s in S], AXES)
    put("est_k", [s.x_a[6:8] for s in S], ("1", "2"))
    put("sd_k", [s.sd_a[6:8] for s in S], ("1", "2"))
    cols["true_k_1"], cols["true_k_2"] = float(tr.k[0]), float(tr.k[1])
    put("est_axisym", [s.x_ax for s in S], ("phi_rad", "delta_rad", "gamma_over_a_rad_s"))
    put("sd_axisym", [s.sd_ax for s in S], ("phi_rad", "delta_rad", "gamma_over_a_rad_s"))
    put("est_axis_I", [s.axis_I for s in S], AXES)
    put("est_spin", [s.spin_e for s in S], ("e_rad_s", "wy_over_a_sq"))
    put("sd_spin", [s.spin_sd for s in S], ("e_rad_s", "wy_over_a_sq"))
    nan3 = np.full(3, np.nan)
    put("meas_r_L_m", [nan3] + [m.r_L for m in run.measurements], AXES)
    put("meas_q_IT", [np.full(4, np.nan)] + [m.q_IT for m in run.measurements], ("0", "1", "2", "3"))
    cols["meas_scale"] = [np.nan] + [m.scale for m in run.measurements]
    cols["meas_kind"] = [""] + [m.kind for m in run.measurements]
    decided: dict[tuple[str, float], bool] = {}
    for g in run.gates:  # the last decision of a filter at an epoch is the deciding one
        decided[(g.source, g.t)] = g.accepted
    for src in ("translation", "attitude", "axis"):
        cols[f"accepted_{src}"] = [decided.get((src, s.t), None) if i > 0 else None for i, s in enumerate(S)]
    return pd.DataFrame(cols)


def C_IL_at(run: CombinaRun, t: float) -> np.ndarray:
    """The chaser's ``C_IL`` at epoch ``t``."""
    return run.truth.C_LI[int(np.argmin(np.abs(run.truth.t - t)))].T


def combina_blueprint(run: CombinaRun):
    """The viewer layout: each filter's errors within ±3σ, gate events (and clouds for the rendered chain)."""
    errs = component_errors(run)
    filters = [f for f, comps in FILTER_COMPONENTS.items() if comps[0] in errs]
    return run_blueprint(quantities=[c for f in filters for c in FILTER_COMPONENTS[f]], filters=filters, gates=True,
                         cloud=any(m.cloud_L is not None for m in run.measurements))


def write_recording(path: Path, run: CombinaRun, *, recording_id: str | None = None) -> None:
    """``combina.rrd``: errors with ±3σ, truth and estimated poses, measurements, gate events, mode switches, iteration times.

    Errors follow :mod:`studies.recording.blueprint`'s layout
    (``/estimate/<filter>/error/<component>/<axis>/{value,plus3sigma,minus3sigma}``) and the
    recording carries :func:`combina_blueprint`. Every entry lies on a measurement epoch.
    """
    ones = lambda n: np.ones(n, dtype=int)  # noqa: E731  one point per time step
    rid = recording_id or f"combina-{run.config.target}-seed{run.config.seed}"
    with recording(path, recording_id=rid, blueprint=combina_blueprint(run)) as rec:
        filter_of = {c: f for f, comps in FILTER_COMPONENTS.items() for c in comps}
        for name, (t, err, sd) in component_errors(run).items():
            send_error(rec, filter_of[name], name, t, err, sd, axes=[str(j) for j in range(err.shape[1])])
        t = np.array([s.t for s in run.steps])  # the measurement epochs (truth.t may differ in the last bit)
        send_poses(rec, "/truth/target", t, run.truth.r_L, run.truth.q_IT)
        nom = np.array([s.mode == "nominal" for s in run.steps])
        send_poses(rec, "/estimate/attitude/target", t[nom], np.array([s.x_s[:3] for s in run.steps])[nom],
                   mrp_to_quat(np.array([s.x_a[:3] for s in run.steps])[nom]))
        rr.send_columns("/truth/r_L", indexes=[time_column(t)], columns=rr.Points3D.columns(positions=run.truth.r_L).partition(ones(t.size)), recording=rec)
        est = np.array([s.x_s[:3] for s in run.steps])
        rr.send_columns("/estimate/translation/r_L", indexes=[time_column(t)], columns=rr.Points3D.columns(positions=est).partition(ones(t.size)),
                        recording=rec)
        mt = np.array([m.t for m in run.measurements])
        measured = rr.Points3D.columns(positions=np.array([m.r_L for m in run.measurements])).partition(ones(mt.size))
        rr.send_columns("/measurement/r_L", indexes=[time_column(mt)], columns=measured, recording=rec)
        send_scalars(rec, "/measurement/scale", mt, np.array([m.scale for m in run.measurements]))
        for m in run.measurements:  # rendered chain: measured cloud and the model at the measured pose (p_L = r_L + C_LT p_T)
            if m.cloud_L is None:
                continue
            set_sim_time(rec, m.t)
            rec.log("/cloud/measured", rr.Points3D(m.cloud_L, colors=[80, 160, 255]))
            if run.model_T is not None and np.isfinite(m.scale):
                rec.log("/cloud/model", rr.Points3D(m.r_L + run.model_T @ (m.C_TI @ C_IL_at(run, m.t)), colors=[255, 160, 60]))
        for g in run.gates:
            set_sim_time(rec, g.t)
            if not np.isnan(g.e2):
                rec.log(f"/gate/{g.source}/e2", rr.Scalars(g.e2))
            if not g.accepted:
                text = f"rejected: {g.reason} (e2={g.e2:.3g}, bounds [{g.lower:.3g}, {g.upper:.3g}])"
                rec.log(f"/gate/{g.source}/events", rr.TextLog(text, level=rr.TextLogLevel.WARN))
        if run.symmetry:
            send_scalars(rec, "/estimate/symmetry/discrepancy_rad", [c.t for c in run.symmetry], [c.discrepancy_rad for c in run.symmetry])
        t_it = t[1 : 1 + run.iteration_s.size]
        send_scalars(rec, "/timing/iteration_s", t_it, run.iteration_s)
        send_scalars(rec, "/timing/registration_s", t_it, run.registration_s)
        set_sim_time(rec, 0.0)
        rec.log("/estimate/mode", rr.TextLog("mode: nominal (translational + attitude UKF)"))
        if run.switch_time_s is not None:
            set_sim_time(rec, run.switch_time_s)
            rec.log("/estimate/mode", rr.TextLog("symmetry detected: switched to axisymmetric mode", level=rr.TextLogLevel.WARN))
