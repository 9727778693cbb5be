"""Study ``init``: the kinematic prior as initial condition (Renis et al. §6.2, Tables 4 and 5, Fig. 6).

SC3 (two axes, slow), 450 s at 1 s, the scenario-specific filter ``KF_sc``
(the named tuning ``tuning``). Each seed runs every filter twice on the same
measurements and the same initial inertia guess (paired runs: they share the
seed): without the prior (``ω̂_0 = 0``, the tuning's ``P_0``) and with it
(``ω̂_0`` from the truth off by ``prior_rate_error``, the ``ω`` block of ``P_0``
set to ``P0_w_prior``; :func:`estimators.prior.initialize_with_prior`).

Per run: §6's convergence time and steady-state RMSE per group, state based
and filter based (:func:`studies.sim.navigation.run_metrics`), ``errors.parquet``
(error magnitude and 1-σ per group per step, the data of Fig. 6) and
``run.rrd``. The summary: Table 4 (median convergence times), Table 5 (median
steady-state RMSE ×10⁻³), both with the state- and filter-based halves, the
paired change of the convergence time of ``k`` per filter, and the long table
with means, t intervals and median intervals; ``fig6_init_errors.png``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from estimators.navigation import FILTERS
from estimators.state import W_B, W_ST_T
from estimators.tuning import TUNINGS, get_tuning
from studies.catalog.filter_common import (
    COMMON_FIELDS, COMMON_RUN_FIELDS, GROUP_LABELS, PRIOR_FIELDS, PRIOR_RUN_FIELDS, check_common, study_prior, median_interval, metric_tables,
    paired_error_figure, paired_change, paired_specs, record_arm, pose_noise, thresholds,
)
from studies.engine.config import ConfigError, Field, StudyConfig
from studies.engine.io import atomic_path
from studies.sim.metrics import GROUPS
from studies.sim.navigation import NavigationSetup, considered_states, error_series, navigate, one_axis, run_metrics
from studies.sim.scenarios import SCENARIOS, get_scenario
from studies.engine.sweep import RunSpec
from studies.engine.tables import Table
from studies.sim.truth import simulate_truth

TITLE = "Initialisation with the kinematic prior (Renis et al. §6.2): convergence time and steady-state error, with and without the prior"

FIELDS: dict[str, Field] = {
    "filters": Field("list[str]", "Filters to run.", choices=tuple(FILTERS)),
    "scenario": Field("str", "Scenario (Renis et al. §6.2: SC3).", choices=tuple(SCENARIOS)),
    "n_seeds": Field("int", "Seeds (paired runs with and without the prior) per filter.", ge=2),
    "duration_s": Field("float", "Simulated time per run, s.", gt=0),
    "dt_s": Field("float", "Filter step = measurement period tau_s, s.", gt=0),
    "tuning": Field("str", "Named tuning of the filter (KF_sc of the scenario).", choices=tuple(TUNINGS)),
    "prior_rate_error": Field("float", "Relative error of the prior rate (Renis et al. §5.3: 0.05).", gt=0, default=0.05),
    "prior_error_direction": Field("str", "Direction of the prior's error.", choices=("random", "along"), default="random"),
    "P0_w_prior": Field("float", "P_0 diagonal of the rate block with the prior, (rad/s)^2.", gt=0, default=1e-4),
    **PRIOR_FIELDS,
    **COMMON_FIELDS,
}
_RUN_FIELDS = ("scenario", "duration_s", "dt_s", "tuning", "prior_rate_error", "prior_error_direction", "P0_w_prior", *PRIOR_RUN_FIELDS, *COMMON_RUN_FIELDS)
ARM_LABEL = {False: "", True: " +prior"}


def check(params: dict) -> None:
    """``dt_s <= duration_s``; the inertia guess range is ordered."""
    if params["dt_s"] > params["duration_s"] / 2:
        raise ConfigError(f"dt_s {params['dt_s']}: expected at most half of duration_s = {params['duration_s']} s")
    check_common(params)


def expand(config: StudyConfig) -> list[RunSpec]:
    """Filters × {no prior, prior} × seeds; run ids ``<filter>-<none|prior>-s<index>``, seeded per index (paired)."""
    return paired_specs(config, "prior", _RUN_FIELDS)


def execute(spec: RunSpec, workdir: Path) -> dict:
    """One filter run on the scenario, with or without the prior as initial condition."""
    p = spec.params
    rng = np.random.default_rng(spec.seed)
    sc = get_scenario(p["scenario"])
    tr = simulate_truth(sc, p["duration_s"], p["dt_s"], p["truth"])
    w_true = tr.target[0, W_B]  # scores the prior; builds it only with prior_source = "truth" (the paper's oracle)
    prior, prior_score = study_prior(p, sc.name, w_true, rng)  # the same in both arms (paired streams)
    setup = NavigationSetup(
        p["filter"], get_tuning(p["tuning"]), prior=prior, prior_use="init" if p["prior"] and prior is not None else "none",
        # the paper's fixed P_0 ω block goes with its oracle; a light-curve prior brings its own covariance
        P0_w_prior=p["P0_w_prior"] if p["prior_source"] == "truth" else None, pose_noise=pose_noise(p),
        gate_confidence=p["gate_confidence"], gate_start_s=p["gate_start_s"],
        consider=considered_states(sc, p["truth"]), inertia_range=tuple(p["inertia_guess_range"]),
    )
    run, meas = navigate(tr, setup, rng)
    if p["record"]:
        errors = error_series(tr, run)
        with atomic_path(workdir / "errors.parquet") as tmp:
            errors.to_parquet(tmp)
        record_arm(workdir / "run.rrd", tr, run, meas, p, "prior", recording_id=f"init-{spec.run_id}")
    return {
        "n_steps": len(tr.t),
        **prior_score,
        "w0_err_rad_s": float(np.linalg.norm(run.x[0, W_ST_T] - tr.x[0, W_ST_T])),
        **run_metrics(tr, run, thresholds(p)),
    }


def _arms(filters) -> list[tuple[str, str]]:
    return [(f"{f.upper()}{ARM_LABEL[p]}", f"filter == '{f}' and prior == {p}") for f in filters for p in (False, True)]


def paired_k_change(runs: pd.DataFrame, filters, confidence: float) -> pd.DataFrame:
    """Per filter: median convergence time of ``k`` without and with the prior, and the paired difference.

    A run that did not converge counts as +∞ in the medians; the difference
    (with − without) is taken over the seeds where both converged.
    """
    rows = []
    for f in filters:
        a = runs.query(f"filter == '{f}' and prior == False").set_index("seed_index")["ct_k_s"].astype(float)
        b = runs.query(f"filter == '{f}' and prior == True").set_index("seed_index")["ct_k_s"].astype(float)
        both = a.index.intersection(b.index)
        d = (b[both] - a[both]).to_numpy()
        dm, dlo, dhi = median_interval(d[np.isfinite(d)], confidence) if np.isfinite(d).any() else (np.nan,) * 3
        m0, m1 = median_interval(a, confidence)[0], median_interval(b, confidence)[0]
        rows.append({"filter": f.upper(), "seeds": len(both), "k conv. time no prior (s, median)": m0,
                     "k conv. time +prior (s, median)": m1, "converged no prior": int(np.isfinite(a).sum()),
                     "converged +prior": int(np.isfinite(b).sum()), "paired change (s, median)": dm,
                     "change lo": dlo, "change hi": dhi, "seeds faster with prior": int(np.sum(d < 0))})
    return pd.DataFrame(rows)


def paired_late_rmse(runs: pd.DataFrame, groups, confidence: float) -> pd.DataFrame:
    """Per filter and group: the RMSE over the second half of the run (``late_rmse_<g>``, the same steps in both arms)
    without and with the prior (medians, ×1e-3) and the paired change with − without (mean and t interval over the seeds)."""
    rows = []
    for g in groups:
        for r in paired_change(runs, "prior", f"late_rmse_{g}", confidence):
            rows.append({"filter": r["filter"].upper(), "component": GROUP_LABELS[g], "no prior (x1e-3, median)": 1e3 * r["without"],
                         "+prior (x1e-3, median)": 1e3 * r["with"], "paired change (x1e-3, mean)": 1e3 * r["mean"],
                         "change lo": 1e3 * r["lo"], "change hi": 1e3 * r["hi"], "seeds": r["seeds"], "seeds lower with prior": r["lower"]})
    return pd.DataFrame(rows)


def summarise(runs: pd.DataFrame, config: StudyConfig, out_dir: Path) -> list[Table]:
    """Tables 4 and 5 (medians over seeds, state and filter based), the paired k change, the long statistics; Fig. 6."""
    runs = runs.assign(prior=runs["prior"].astype(bool))
    filters = list(dict.fromkeys(runs["filter"]))
    groups = list(GROUPS) if not one_axis(get_scenario(config["scenario"]).w_T0_T_rad_s) else [g for g in GROUPS if g != "k"]
    conv, ess, stats = metric_tables(runs, _arms(filters), groups, confidence=config["confidence"])
    pct = int(round(100 * config["confidence"]))
    base = (f"{config['scenario']}, {config['duration_s']:g} s at {config['dt_s']:g} s, tuning {config['tuning']}; "
            f"{config['n_seeds']} seeds, each run without and with the prior on the same measurements and initial guess. "
            + (f"Prior: truth ± {100 * config['prior_rate_error']:g}% ({config['prior_error_direction']} direction; the paper's oracle), P_0 ω "
               f"block {config['P0_w_prior']:g} (rad/s)². " if config["prior_source"] == "truth" else
               f"Prior: {config['lc_nights']} rendered arcs of {config['lc_target']} inverted with its model (no truth reaches it), P_0 ω block "
               "its covariance. ")
            + "Medians over seeds; a run that did not converge counts as +∞, so '–' means most runs "
            "did not converge below the threshold (the paper's NaN).")
    plot_fig6(runs, config, out_dir / "fig6_init_errors.png")
    return [
        Table("summary", "Table 4 analogue: convergence time (s), median over seeds", conv, base, default_format=".1f"),
        Table("table5", "Table 5 analogue: steady-state RMSE (x1e-3), median over seeds", ess, base, default_format=".3g"),
        Table("k_convergence", "Convergence time of k with and without the prior (paired by seed)", paired_k_change(runs, filters, config["confidence"]),
              f"Paired change = with − without, over seeds where both converged; {pct}% order-statistic interval of its median.", default_format=".3g"),
        Table("late_rmse", "RMSE over the second half of the run, with and without the prior (paired by seed; the same steps in both arms)",
              paired_late_rmse(runs, groups, config["confidence"]),
              "Table 5 starts each run's window at its own convergence time, so the arm that converges sooner lets more of its "
              f"transient in; here both arms are scored over t ≥ T/2. Paired change = with − without, mean and {pct}% t interval.",
              default_format=".3g"),
        Table("statistics", f"Every metric: runs converged, mean with {pct}% t interval (converged runs), median with {pct}% order-statistic interval",
              stats, default_format=".4g"),
    ]


def plot_fig6(runs: pd.DataFrame, config: StudyConfig, path: Path) -> None:
    """Fig. 6 of Renis et al.: errors of q_TS, ω_ST and k against time, without and with the prior (median and IQR over seeds)."""
    th = thresholds(config)
    rows = [("q", np.degrees(1.0), "q_TS error (deg)", np.degrees(th["q"])), ("w", np.degrees(1.0), "ω_ST error (deg/s)", np.degrees(th["w"])),
            ("k", 1.0, "k error |δk|", th["k"])]
    paired_error_figure(runs, path, arm="prior", labels=("no prior", "with prior"), rows=rows, scenario=config["scenario"])
