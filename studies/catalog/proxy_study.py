"""Study ``proxy``: the kinematic prior as a proxy measurement through a fault (Renis et al. §6.3, Table 6, Fig. 7).

SC1 (one axis, slow), 300 s at 1 s, the scenario-specific tuning; in both arms
the prior initialises the rate as in study 2 (§6.3: "the kinematic priors are
introduced as an initial condition as in study 2"). A fault window of
``fault_duration_s`` from ``fault_start_s`` makes both pose parts
``fault_sigma_scale`` times noisier; the chi-square gate (§4.3) rejects what it
can. With the proxy, the prior rate is pushed as a fictitious ``ω``
measurement with ``R_ω = R_omega I`` (:func:`estimators.prior.rate_proxy`) at
every step (``proxy_mode = "always"``, the paper's) or only on rejection.
Each seed runs every filter with and without the proxy on the same
measurements and initial guess (paired).

Per run: the steady-state RMSE per group from fault end + ``settling_s`` to the
end (Table 6), state based and filter based (the 1-σ of ``P``); during the
fault: the RMS and maximum ``ω`` and attitude errors, the gate's rejections;
``errors.parquet`` (the data of Fig. 7) and ``run.rrd`` (with
``/measurement/faulty``). Summary: Table 6 (medians over seeds), the fault
table (medians with intervals and the paired change), statistics; Fig. 7.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from estimators.navigation import FILTERS, SOURCES
from estimators.prior import PROXY_MODES
from estimators.state import W_B
from estimators.tuning import TUNINGS, get_tuning
from studies.catalog.filter_common import (
    COMMON_FIELDS, COMMON_RUN_FIELDS, PRIOR_FIELDS, PRIOR_RUN_FIELDS, GROUP_LABELS, check_common, study_prior, median_interval, paired_error_figure,
    paired_specs, record_arm, pose_noise,
)
from studies.engine.config import ConfigError, Field, StudyConfig
from studies.engine.io import atomic_path
from studies.sim.metrics import GROUPS
from studies.sim.navigation import NavigationSetup, considered_states, error_series, navigate, one_axis
from studies.sim.scenarios import SCENARIOS, get_scenario
from studies.engine.stats import t_interval
from studies.engine.sweep import RunSpec
from studies.engine.tables import Table
from studies.sim.truth import simulate_truth

TITLE = "Kinematic prior as proxy measurement through a fault (Renis et al. §6.3): steady-state error after the fault, errors during it"

FIELDS: dict[str, Field] = {
    "filters": Field("list[str]", "Filters to run.", choices=tuple(FILTERS)),
    "scenario": Field("str", "Scenario (Renis et al. §6.3: SC1).", choices=tuple(SCENARIOS)),
    "n_seeds": Field("int", "Seeds (paired runs with and without the proxy) per filter.", ge=2),
    "duration_s": Field("float", "Simulated time per run, s.", gt=0),
    "dt_s": Field("float", "Filter step = measurement period tau_s, s.", gt=0),
    "tuning": Field("str", "Named tuning of the filter (KF_sc of the scenario).", choices=tuple(TUNINGS)),
    "fault_start_s": Field("float", "Start of the fault window, s.", ge=0),
    "fault_duration_s": Field("float", "Length of the fault window, s (Renis et al. §6.3: 120).", gt=0),
    "fault_sigma_scale": Field("float", "Fault noise as a multiple of the nominal pose noise.", gt=1, default=50.0),
    "settling_s": Field("float", "Steady-state RMSE from fault end + this, s (Renis et al. Table 6: 30).", ge=0, default=30.0),
    "prior_rate_error": Field("float", "Relative error of the prior rate (Renis et al. §5.3: 0.05).", gt=0, default=0.05),
    "prior_error_direction": Field("str", "Direction of the prior's error.", choices=("random", "along"), default="along"),
    "R_omega": Field("float", "Variance of the pushed prior per axis, (rad/s)^2 (Renis et al. §6.3: 1e-3).", gt=0, default=1e-3),
    "proxy_mode": Field("str", "When the proxy is pushed.", choices=PROXY_MODES, default="always"),
    **PRIOR_FIELDS,
    **COMMON_FIELDS,
}
_RUN_FIELDS = ("scenario", "duration_s", "dt_s", "tuning", "fault_start_s", "fault_duration_s", "fault_sigma_scale", "settling_s",
               "prior_rate_error", "prior_error_direction", "R_omega", "proxy_mode", *PRIOR_RUN_FIELDS, *COMMON_RUN_FIELDS)
ARM_LABEL = {False: "", True: " +proxy"}


def check(params: dict) -> None:
    """The fault and the settling time end before the run does; ``dt_s`` fits the fault."""
    end = params["fault_start_s"] + params["fault_duration_s"] + params["settling_s"]
    if end >= params["duration_s"]:
        raise ConfigError(f"duration_s {params['duration_s']}: expected more than fault_start_s + fault_duration_s + settling_s = {end:g} s")
    if params["dt_s"] > params["fault_duration_s"]:
        raise ConfigError(f"dt_s {params['dt_s']}: expected at most fault_duration_s = {params['fault_duration_s']} s")
    check_common(params)


def expand(config: StudyConfig) -> list[RunSpec]:
    """Filters × {no proxy, proxy} × seeds; run ids ``<filter>-<none|proxy>-s<index>``, seeded per index (paired)."""
    return paired_specs(config, "proxy", _RUN_FIELDS)


def _rms(x) -> float:
    return float(np.sqrt(np.mean(np.square(x)))) if len(x) else float("nan")


def execute(spec: RunSpec, workdir: Path) -> dict:
    """One filter run through the fault, with or without the proxy."""
    p = spec.params
    rng = np.random.default_rng(spec.seed)
    sc = get_scenario(p["scenario"])
    tr = simulate_truth(sc, p["duration_s"], p["dt_s"], p["truth"])
    # the truth scores the prior; builds it only with prior_source = "truth" (the paper's oracle)
    prior, prior_score = study_prior(p, sc.name, tr.target[0, W_B], rng)
    if prior is None:
        raise RuntimeError("the light curves gave no significant period: the proxy study needs a prior (see prior_source)")
    scale = p["fault_sigma_scale"]
    setup = NavigationSetup(
        p["filter"], get_tuning(p["tuning"]), prior=prior, prior_use="proxy" if p["proxy"] else "init",
        proxy_mode=p["proxy_mode"], R_w=p["R_omega"], faults=[(p["fault_start_s"], p["fault_duration_s"])],
        pose_noise=pose_noise(p), fault_sigma_q_rad=scale * p["sigma_q_rad"],
        fault_sigma_r_m=scale * p["sigma_r_m"], gate_confidence=p["gate_confidence"], gate_start_s=p["gate_start_s"],
        consider=considered_states(sc, p["truth"]), inertia_range=tuple(p["inertia_guess_range"]),
    )
    run, meas = navigate(tr, setup, rng)
    err = error_series(tr, run)
    t = err["t_s"].to_numpy()
    t_end = p["fault_start_s"] + p["fault_duration_s"]
    fault = (t >= p["fault_start_s"]) & (t < t_end)
    steady = t >= t_end + p["settling_s"]
    out = {"n_steps": len(t)}
    for g in GROUPS:
        out[f"ess_{g}"] = _rms(err[f"err_{g}"].to_numpy()[steady])  # Table 6, state based
        out[f"ess_f_{g}"] = _rms(err[f"sigma_{g}"].to_numpy()[steady])  # filter based
    w_f, q_f = err["err_w"].to_numpy()[fault], err["err_q"].to_numpy()[fault]
    out.update({
        "fault_w_err_rms_rad_s": _rms(w_f), "fault_w_err_max_rad_s": float(w_f.max()),
        "fault_q_err_rms_rad": _rms(q_f), "fault_q_err_max_rad": float(q_f.max()),
        "fault_r_err_rms_m": _rms(err["err_r"].to_numpy()[fault]),
        "pre_fault_w_err_rad_s": float(err["err_w"].to_numpy()[np.flatnonzero(t < p["fault_start_s"])[-1]]),
        **prior_score,
    })
    k_fault = np.flatnonzero(fault)
    for s in SOURCES:
        out[f"fault_{s}_rejected"] = int(np.sum(np.isfinite(run.nis[s][k_fault]) & ~run.accepted[s][k_fault]))
        out[f"fault_{s}_accepted"] = int(np.sum(np.isfinite(run.nis[s][k_fault]) & run.accepted[s][k_fault]))
    out["proxy_steps"] = int(run.proxy_used.sum())
    if p["record"]:
        with atomic_path(workdir / "errors.parquet") as tmp:
            err.to_parquet(tmp)
        record_arm(workdir / "run.rrd", tr, run, meas, p, "proxy", recording_id=f"proxy-{spec.run_id}",
                   extra_scalars={"/measurement/faulty": (meas[0], np.asarray(meas[3], dtype=float))})
    return out


def _arms(filters) -> list[tuple[str, str]]:
    return [(f"{f.upper()}{ARM_LABEL[p]}", f"filter == '{f}' and proxy == {p}") for f in filters for p in (False, True)]


def fault_table(runs: pd.DataFrame, filters, confidence: float) -> pd.DataFrame:
    """Per filter and arm: ω and attitude errors during the fault (medians with intervals), rejections; paired ω change."""
    rows = []
    for f in filters:
        base = runs.query(f"filter == '{f}' and proxy == False").set_index("seed_index")
        for proxy in (False, True):
            sub = runs.query(f"filter == '{f}' and proxy == {proxy}").set_index("seed_index")
            w = sub["fault_w_err_rms_rad_s"].astype(float) * 1e3
            med, lo, hi = median_interval(w, confidence)
            iv = t_interval(w, confidence)
            d = (w - base["fault_w_err_rms_rad_s"].astype(float).reindex(w.index) * 1e3).to_numpy()
            rows.append({
                "arm": f"{f.upper()}{ARM_LABEL[proxy]}", "runs": len(sub),
                "ω err RMS in fault (mrad/s, median)": med, "median lo": lo, "median hi": hi,
                "mean": iv.estimate, "mean lo": iv.lo, "mean hi": iv.hi,
                "ω err max in fault (mrad/s, median)": float(np.median(sub["fault_w_err_max_rad_s"].astype(float))) * 1e3,
                "q err RMS in fault (deg, median)": float(np.degrees(np.median(sub["fault_q_err_rms_rad"].astype(float)))),
                "paired ω change (mrad/s, median)": float(np.median(d)) if proxy else np.nan,
                "seeds lower with proxy": int(np.sum(d < 0)) if proxy else np.nan,
                "attitude rejected / accepted": f"{int(sub['fault_attitude_rejected'].sum())} / {int(sub['fault_attitude_accepted'].sum())}",
                "position rejected / accepted": f"{int(sub['fault_position_rejected'].sum())} / {int(sub['fault_position_accepted'].sum())}",
            })
    return pd.DataFrame(rows)


def summarise(runs: pd.DataFrame, config: StudyConfig, out_dir: Path) -> list[Table]:
    """Table 6 (medians over seeds, state and filter based), the fault table, the long statistics; Fig. 7."""
    runs = runs.assign(proxy=runs["proxy"].astype(bool))
    filters = list(dict.fromkeys(runs["filter"]))
    groups = [g for g in GROUPS if not (g == "k" and one_axis(get_scenario(config["scenario"]).w_T0_T_rad_s))]
    arms = _arms(filters)
    pct = int(round(100 * config["confidence"]))
    rows, stats = [], []
    for basis, prefix in (("state", ""), ("filter", "f_")):
        for g in groups:
            row = {"basis": basis, "component": GROUP_LABELS[g]}
            for label, query in arms:
                v = runs.query(query)[f"ess_{prefix}{g}"].astype(float).to_numpy() * 1e3
                med, lo, hi = median_interval(v, config["confidence"])
                iv = t_interval(v, config["confidence"])
                row[label] = med
                stats.append({"basis": basis, "component": GROUP_LABELS[g], "arm": label, "runs": len(v), "mean": iv.estimate,
                              "sd": float(np.std(v, ddof=1)), "mean lo": iv.lo, "mean hi": iv.hi, "median": med, "median lo": lo, "median hi": hi})
            rows.append(row)
    t_end = config["fault_start_s"] + config["fault_duration_s"]
    notes = (f"{config['scenario']}, {config['duration_s']:g} s at {config['dt_s']:g} s, tuning {config['tuning']}, fault "
             f"[{config['fault_start_s']:g}, {t_end:g}) s at {config['fault_sigma_scale']:g}x the pose noise; prior ±{100 * config['prior_rate_error']:g}% "
             f"({config['prior_error_direction']}) as initial condition in both arms, +proxy: pushed as a ω measurement ({config['proxy_mode']}, "
             f"R_ω = {config['R_omega']:g} (rad/s)²). RMSE from {t_end + config['settling_s']:g} s to the end (x1e-3; rad, rad/s, m, m/s), "
             f"median over {config['n_seeds']} paired seeds.")
    plot_fig7(runs, config, out_dir / "fig7_proxy_errors.png")
    return [
        Table("summary", "Table 6 analogue: steady-state RMSE after the fault (x1e-3), median over seeds", pd.DataFrame(rows), notes, default_format=".3g"),
        Table("fault", "Errors during the fault window, with and without the proxy", fault_table(runs, filters, config["confidence"]),
              f"{pct}% intervals: order-statistic for the median, Student t for the mean. Paired change = with − without proxy, same seed.",
              default_format=".3g"),
        Table("statistics", f"Table 6 metrics: mean with {pct}% t interval, median with {pct}% order-statistic interval", pd.DataFrame(stats),
              default_format=".4g"),
    ]


def plot_fig7(runs: pd.DataFrame, config: StudyConfig, path: Path) -> None:
    """Fig. 7 of Renis et al.: q_TS and ω_ST errors against time, without and with the proxy, the fault window shaded."""
    rows = [("q", np.degrees(1.0), "q_TS error (deg)", None), ("w", np.degrees(1.0), "ω_ST error (deg/s)", None)]
    paired_error_figure(runs, path, arm="proxy", labels=("no proxy", "with proxy"), rows=rows, scenario=config["scenario"],
                        shade=(config["fault_start_s"], config["fault_start_s"] + config["fault_duration_s"]))
