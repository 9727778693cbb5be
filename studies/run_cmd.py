"""``lcnav run``: one filter on one scenario, with or without a spin prior; metrics, states, recording.

Per run ``i`` (seed ``seed + i``): the scenario's truth (:mod:`studies.truth`),
simulated pose measurements at ``1/τ_s`` (:mod:`perception.simulated_pose`,
or a measurement file), the initial guess of §6 of ``002_…`` (``q_TS = 1``,
``ω = r = v = 0``, ``k`` from the true inertia scaled by ``U(0.7, 1.3)`` per
axis), optionally the prior as initial condition and/or proxy, then the filter.
Writes, after everything has run (nothing is written on an error):

* ``metrics.json`` — convergence time and steady-state RMSE per group of the
  first run (state based in ``components``, filter based in
  ``filter_components``), their means over the runs, the fraction of steps
  (from the fixed settling time :data:`studies.metrics.SETTLING_S`, 60 s) whose run-averaged NEES lies in its 95 %
  band, the same for each source's NIS (3 dof), gate rejection rates;
* ``states.parquet`` — per step of the first run: truth, estimate, 3-σ of
  each error state, NIS and gate decisions;
* ``run.rrd`` — the same on the ``sim_time`` timeline in the layout of
  :mod:`studies.blueprint` (``/truth/...``, ``/estimate/<filter>/...`` with
  errors and ±3σ, ``/measurement/<source>/...``, ``/gate/<filter>/<source>/e2``
  with its bounds and a log of rejections), with the viewer layout.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Optional

import numpy as np
import pandas as pd
import typer

from estimators.measurement import NOISE_MODELS, PoseNoise
from estimators.navigation import FILTERS, SOURCES, NavigationRun
from estimators.prior import PROXY_MODES, SpinPrior, prior_from_rate, tuning_for_prior
from estimators.tuning import TUNINGS, get_tuning
from perception.simulated_pose import parse_faults
from studies.io import write_json, write_table
from studies.metrics import GROUPS, SETTLING_S, chi_square_band, evaluate, fraction_in_band, nees
from studies.nav_study import K_STATES, navigate, one_axis, record_navigation
from studies.scenarios import get_scenario
from studies.truth import RELATIVE_COLUMNS, Truth, simulate_truth

PRIOR_USES = ("none", "init", "proxy")
ERROR_NAMES = ["dq_x_rad", "dq_y_rad", "dq_z_rad", "w_x_rad_s", "w_y_rad_s", "w_z_rad_s", "r_x_m", "r_y_m", "r_z_m", "v_x_m_s", "v_y_m_s", "v_z_m_s", "k1", "k2"]
MEASUREMENT_COLUMNS = ["t_s", "q_TS_0", "q_TS_1", "q_TS_2", "q_TS_3", "r_ST_T_x_m", "r_ST_T_y_m", "r_ST_T_z_m"]


def _floats(text: str, n: int, flag: str) -> np.ndarray:
    try:
        v = np.array([float(s) for s in str(text).split(",")], dtype=float)
    except ValueError:
        raise ValueError(f"{flag} must be {n} comma-separated numbers, got {text!r}") from None
    if v.shape != (n,) or not np.all(np.isfinite(v)):
        raise ValueError(f"{flag} must be {n} comma-separated finite numbers, got {text!r}")
    return v


def _read_measurements(path: Path):
    if not path.is_file():
        raise FileNotFoundError(f"--measurements {path} does not exist")
    df = pd.read_parquet(path) if path.suffix == ".parquet" else pd.read_csv(path)
    missing = [c for c in MEASUREMENT_COLUMNS if c not in df.columns]
    if missing:
        raise ValueError(f"--measurements {path} lacks columns {missing}; expected {MEASUREMENT_COLUMNS}")
    a = df[MEASUREMENT_COLUMNS].to_numpy(dtype=float)
    bad = np.flatnonzero(~np.all(np.isfinite(a), axis=1))
    if bad.size:
        raise ValueError(f"--measurements {path}: row {int(bad[0])} has a NaN or Inf measurement")
    q = a[:, 1:5]
    if np.any(np.abs(np.linalg.norm(q, axis=1) - 1.0) > 1e-6):
        raise ValueError(f"--measurements {path}: q_TS must be unit quaternions")
    return a[:, 0], q, a[:, 5:8]


def _metrics_dict(m) -> dict:
    return {g: {"convergence_time_s": _num(c.convergence_time_s), "steady_state_rmse": _num(c.steady_state_rmse)} for g, c in m.items()}


def _num(v: float):
    return None if not np.isfinite(v) else float(v)


def _states_table(tr: Truth, run: NavigationRun) -> pd.DataFrame:
    cols = {"t_s": tr.t}
    cols.update({f"true_{c}": v for c, v in zip(RELATIVE_COLUMNS, tr.x.T)})
    cols.update({f"est_{c}": v for c, v in zip(RELATIVE_COLUMNS, run.x.T)})
    sig = 3.0 * np.sqrt(np.diagonal(run.P, axis1=1, axis2=2))
    cols.update({f"sigma3_{c}": v for c, v in zip(ERROR_NAMES, sig.T)})
    for s in SOURCES:
        cols[f"nis_{s}"] = run.nis[s]
        cols[f"accepted_{s}"] = run.accepted[s]
    cols["proxy_used"] = run.proxy_used
    return pd.DataFrame(cols)


def run(
    scenario: str = typer.Option("SC3", help="Scenario name (SC1-SC4)."),
    filter_: str = typer.Option("ekf", "--filter", help=f"Filter: {'|'.join(FILTERS)}."),
    duration: float = typer.Option(300.0, help="Simulated time, s."),
    dt: float = typer.Option(1.0, help="Sampling time tau_s of the filter and the pose estimator, s."),
    prior: str = typer.Option("none", help="Spin prior use: none|init|proxy (proxy also initialises)."),
    prior_error: float = typer.Option(0.05, help="Prior rate error as a fraction of the true rate (002 §5.3)."),
    prior_rate_deg_s: Optional[str] = typer.Option(None, help="Prior rate 'wx,wy,wz' in deg/s (target frame); default: truth x (1 + prior-error)."),
    prior_json: Optional[Path] = typer.Option(None, help="Prior from `lcnav lightcurve prior --json` (rate_rad_s, rate_sigma_rad_s) about --prior-axis."),
    prior_axis: str = typer.Option("0,0,1", help="Spin axis 'x,y,z' in the target frame for --prior-json (a light curve gives no axis)."),
    proxy_mode: str = typer.Option("always", help=f"When the proxy is pushed: {'|'.join(PROXY_MODES)}."),
    tuning: Optional[str] = typer.Option(None, help=f"Named tuning ({', '.join(TUNINGS)}); default: from the prior, else 'settled'."),
    p0_diag: Optional[str] = typer.Option(None, help="Override P_0: 14 comma-separated variances (error states)."),
    fault: Optional[str] = typer.Option(None, help="Fault window 'START,LENGTH' in s (heavy measurement noise)."),
    runs: int = typer.Option(1, help="Monte-Carlo runs (seeds seed..seed+runs-1)."),
    seed: int = typer.Option(1, help="Seed of the first run."),
    noise: str = typer.Option(PoseNoise.model, help=f"Pose noise model: {'|'.join(NOISE_MODELS)} (the measurements' and the filter's R_d)."),
    sigma_q_rad: float = typer.Option(PoseNoise.sigma_q_rad, help="Pose attitude noise amplitude, rad (the measurements' and the filter's R_d)."),
    sigma_r_m: float = typer.Option(PoseNoise.sigma_r_m, help="Pose position noise amplitude, m (the measurements' and the filter's R_d)."),
    gate_confidence: float = typer.Option(0.99, help="Gate confidence per source (0 disables the gates)."),
    gate_start: float = typer.Option(10.0, help="Gates test measurements from this time on, s (acquisition before)."),
    reacquire_window: int = typer.Option(5, help="Re-acquire a source after this many rejections in a row that lie on a line (0: never; the paper's filters)."),
    measurements: Optional[Path] = typer.Option(None, help=f"Use these measurements (Parquet/CSV with {', '.join(MEASUREMENT_COLUMNS)}) instead of simulating."),
    out: Optional[Path] = typer.Option(None, help="Output folder for metrics.json, states.parquet, run.rrd."),
) -> None:
    """Run a filter on a scenario; write metrics.json, states.parquet and run.rrd."""
    # ---- validate everything before any work or output
    if filter_ not in FILTERS:
        raise ValueError(f"--filter must be one of {'|'.join(FILTERS)}, got {filter_!r}")
    sc = get_scenario(scenario)
    for name, value in (("--duration", duration), ("--dt", dt)):
        if not math.isfinite(value) or value <= 0:
            raise ValueError(f"{name} must be a positive finite number of seconds, got {value}")
    if dt > duration:
        raise ValueError(f"--dt ({dt} s) must not exceed --duration ({duration} s)")
    if prior not in PRIOR_USES:
        raise ValueError(f"--prior must be one of {'|'.join(PRIOR_USES)}, got {prior!r}")
    if reacquire_window != 0 and reacquire_window < 3:
        raise ValueError(f"--reacquire-window must be 0 (off) or at least 3 measurements, got {reacquire_window}")
    if proxy_mode not in PROXY_MODES:
        raise ValueError(f"--proxy-mode must be one of {'|'.join(PROXY_MODES)}, got {proxy_mode!r}")
    if not (math.isfinite(prior_error) and prior_error > 0):
        raise ValueError(f"--prior-error must be a positive fraction (e.g. 0.05), got {prior_error}")
    if runs < 1:
        raise ValueError(f"--runs must be at least 1, got {runs}")
    if seed < 0:
        raise ValueError(f"--seed must be a non-negative integer, got {seed}")
    if noise not in NOISE_MODELS:
        raise ValueError(f"--noise must be one of {'|'.join(NOISE_MODELS)}, got {noise!r}")
    for name, value in (("--sigma-q-rad", sigma_q_rad), ("--sigma-r-m", sigma_r_m)):
        if not (math.isfinite(value) and value > 0):
            raise ValueError(f"{name} must be a positive finite number, got {value}")
    pose_noise = PoseNoise(sigma_q_rad, sigma_r_m, noise)
    if not (0.0 <= gate_confidence < 1.0):
        raise ValueError(f"--gate-confidence must lie in [0, 1), got {gate_confidence}")
    if out is None:
        raise ValueError("--out DIR is required (where metrics.json, states.parquet and run.rrd go)")
    if out.exists() and not out.is_dir():
        raise NotADirectoryError(f"--out {out} exists and is not a folder")
    faults = parse_faults([_floats(fault, 2, "--fault")] if fault else ())
    tr = simulate_truth(sc, duration, dt)
    w_true = tr.target[0, 10:13]
    spin = None
    if prior_json is not None and prior_rate_deg_s is not None:
        raise ValueError("give the prior either as --prior-json or as --prior-rate-deg-s, not both")
    if prior != "none" or prior_rate_deg_s is not None or prior_json is not None:
        if prior_json is not None:
            if not prior_json.is_file():
                raise FileNotFoundError(f"--prior-json {prior_json} does not exist")
            try:
                d = json.loads(prior_json.read_text())
            except json.JSONDecodeError as e:
                raise ValueError(f"--prior-json {prior_json} is not JSON: {e}") from None
            if not isinstance(d, dict) or d.get("rate_rad_s") is None:
                raise ValueError(f"prior without a rate: --prior-json {prior_json} has no rate_rad_s (no significant period in the light curve)")
            spin = prior_from_rate(d["rate_rad_s"], d.get("rate_sigma_rad_s"), _floats(prior_axis, 3, "--prior-axis"), source=str(prior_json))
        elif prior_rate_deg_s is not None:
            if not prior_rate_deg_s.strip():
                raise ValueError("prior without a rate: --prior-rate-deg-s must be 'wx,wy,wz' in deg/s")
            w = np.radians(_floats(prior_rate_deg_s, 3, "--prior-rate-deg-s (prior rate)"))
            spin = SpinPrior(w, np.full(3, prior_error * max(float(np.linalg.norm(w)), 1e-6)), source="--prior-rate-deg-s")
        else:
            spin = SpinPrior.from_truth(w_true, prior_error)
    tuning_name = tuning or (tuning_for_prior(spin) if spin is not None and prior != "none" else "settled")
    tun = get_tuning(tuning_name)
    P0 = tun.P_0
    if p0_diag is not None:
        d = _floats(p0_diag, 14, "--p0-diag")
        if np.any(d <= 0):
            raise ValueError(f"--p0-diag: P_0 must be positive definite (all 14 variances > 0), got {p0_diag!r}")
        P0 = np.diag(d)
    meas = _read_measurements(measurements) if measurements is not None else None
    consider = K_STATES if one_axis(sc.w_T0_T_rad_s) else ()

    # ---- run
    results = []
    for i in range(runs):
        rng = np.random.default_rng(seed + i)
        run_i, meas_i = navigate(tr, filter_, tun, rng, P0=P0, prior=spin, prior_use=prior, proxy_mode=proxy_mode, faults=faults, pose_noise=pose_noise,
                                 gate_confidence=gate_confidence or None, gate_start_s=gate_start, consider=consider, meas=meas,
                                 reacquire_window=reacquire_window or None)
        results.append((run_i, meas_i, evaluate(tr.t, run_i.x, run_i.P, tr.x)))
    states = np.arange(12) if consider else np.arange(14)
    E = np.array([nees(r.x, r.P, tr.x, states) for r, _, _ in results])
    nees_from = SETTLING_S
    sel = (tr.t - tr.t[0]) >= nees_from
    lo, hi = chi_square_band(len(states), runs, 0.95)
    avg = E[:, sel].mean(axis=0)
    first, meas0, m0 = results[0]
    metrics = {
        "filter": filter_,
        "scenario": sc.name,
        "components": _metrics_dict(m0["state"]),
        "nees_fraction_in_95": _num(float(np.mean((avg >= lo) & (avg <= hi))) if avg.size else float("nan")),
        "filter_components": _metrics_dict(m0["filter"]),
        "components_mean_over_runs": {
            g: {k: _num(float(np.nanmean([getattr(r[2]["state"][g], k) for r in results])) if any(np.isfinite(getattr(r[2]["state"][g], k)) for r in results) else float("nan"))
                for k in ("convergence_time_s", "steady_state_rmse")}
            for g in GROUPS
        },
        "nees": {"dof": int(len(states)), "from_s": float(nees_from), "band_95": [lo, hi], "runs": runs},
        "nis_fraction_in_95": {s: _num(fraction_in_band(np.array([r.nis[s][sel] for r, _, _ in results]), 3)) for s in SOURCES},
        "reacquisitions": [[t_re, source] for t_re, source in first.reacquisitions],
        "gate_rejection_rate": {s: _num(float(np.mean([np.mean(~r.accepted[s][np.isfinite(r.nis[s])]) for r, _, _ in results]))) for s in SOURCES},
        "config": {"duration_s": duration, "dt_s": dt, "prior": prior, "prior_error": prior_error, "proxy_mode": proxy_mode if prior == "proxy" else None,
                   "tuning": tuning_name, "fault": [list(f) for f in faults], "runs": runs, "seed": seed, "noise": noise, "sigma_q_rad": sigma_q_rad, "sigma_r_m": sigma_r_m,
                   "gate_confidence": gate_confidence or None, "gate_start_s": gate_start, "k_estimated": not consider,
                   "reacquire_window": reacquire_window or None,
                   "prior_w_T_T_rad_s": None if spin is None else spin.w_T_T_rad_s.tolist()},
    }

    # ---- write (atomically, after everything has succeeded)
    out.mkdir(parents=True, exist_ok=True)
    write_table(out / "states.parquet", _states_table(tr, first))
    record_navigation(out / "run.rrd", tr, first, meas0, recording_id=f"run-{tr.scenario.name}-{filter_}-seed{seed}")
    write_json(out / "metrics.json", metrics)
    typer.echo(f"wrote {out / 'metrics.json'}, {out / 'states.parquet'} and {out / 'run.rrd'}")


def register(app: typer.Typer) -> None:
    app.command("run")(run)
