"""Study ``chain``: the prior studies of Renis et al. §6 with the prior from a rendered light curve (issue 7, study 4).

Studies 1–3 of Renis et al. assume a prior with a 5 % error about the true axis. Here, per seed, the
prior is *measured*, as a user would: several arcs of light curves of the rocket body spinning like
the scenario's target about a drawn pole are rendered (Mitsuba, a ground site, seeded photometric noise
and sampling, :func:`studies.sim.chain.render_prior`), and the prior is built from those light curves
and the target's model only — the longest arc's period bounds a known-shape inversion, whose modes
become ``ω_T`` with a full covariance (:mod:`studies.sim.lightcurve_prior`). The truth scores the
prior (axis, pole and period errors, the Mahalanobis distance of the truth under the prior), never
builds it. Then, on the same simulated pose measurements, every filter runs in three arms:

* ``none`` — no prior: the ``general-conservative`` tuning, ``ω̂_0 = 0``;
* ``tuning`` — the prior's first use (§6.1): the scenario-specific tuning
  :func:`estimators.prior.tuning_for_prior` picks from the measured rate;
* ``init`` (experiment ``init``: SC3, 450 s, §6.2) — that tuning and the prior
  as initial condition; or ``proxy`` (experiment ``proxy``: SC1, 300 s with a
  120 s fault window, §6.3) — that tuning, the initial condition and the
  prior pushed as an ``ω`` measurement at every step.

Per run (one experiment, one seed) the row holds the light curve's rate
error, the chosen tuning and whether it is the scenario's own, and for every
filter and arm the convergence time and steady-state RMSE of each group
(state and filter based, ``studies.sim.metrics``; for ``proxy`` also the RMSE
after the fault plus a settling time, Table 6). A filter that breaks down
numerically (``ValueError`` from the filter: covariance not positive definite,
NaN) is a result, not a crash: ``<filter>_<arm>_failed`` holds its message and
the summary counts it (as not converged). The summary gives mean, spread,
t interval of the mean and bootstrap interval of the median over the seeds.

Each run folder holds ``lightcurve.rrd`` (``/lightcurve``, ``/spectrum``),
``spectrum.png`` and one recording per filter and arm, ``<filter>_<arm>.rrd``
(the ``lcnav run`` layout).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
from scipy.stats import chi2

from estimators.navigation import FILTERS
from lightcurves.targets import TARGETS
from studies.catalog.figures import plot_spectrum, pyplot, save_png
from studies.catalog.filter_common import TRUTH_FIELD
from studies.sim.chain import ARM_LABELS, arm_tuning, flat_metrics, navigate_arm, record_lightcurve, record_run, render_prior
from studies.engine.config import ConfigError, Field, StudyConfig
from studies.sim.metrics import GROUPS
from studies.sim.scenarios import SCENARIOS, get_scenario
from studies.engine.stats import describe, proportion_interval, t_interval
from studies.engine.sweep import RunSpec, make_specs
from studies.engine.tables import Table
from studies.sim.truth import simulate_truth

TITLE = "End to end: light curves -> inversion prior -> tuning choice, initialisation, proxy (Renis et al. §6 with a measured prior)"
EXPERIMENTS = ("init", "proxy")

FIELDS: dict[str, Field] = {
    "filters": Field("list[str]", "Filters to run.", choices=tuple(FILTERS)),
    "experiments": Field("list[str]", "Prior studies to chain: init (§6.2) and/or proxy (§6.3).", choices=EXPERIMENTS),
    "n_seeds": Field("int", "Seeds (light curves) per experiment.", ge=1),
    "target": Field("str", "Rendered target model (lightcurves/targets.py).", choices=tuple(TARGETS), default="atlas-centaur"),
    "nights": Field("int", "Light-curve arcs observed (each the first visible arc after its start time).", ge=1, le=10, default=3),
    "night_spacing_days": Field("float", "Time between the arcs' start times, days.", gt=0, le=60, default=0.125),
    "observation_duration_s": Field("float", "Light-curve arc, s.", gt=0),
    "cadence_s": Field("float", "Light-curve sampling interval, s.", gt=0),
    "render_resolution_px": Field("int", "Film pixels per side of the renders.", ge=4),
    "render_spp": Field("int", "Samples per pixel (1, 4, 16, 64 or 256).", choices=(1, 4, 16, 64, 256), default=4),
    "false_alarm_level": Field("float", "Significance level of a light-curve period.", gt=0, le=0.5, default=0.01),
    "init_scenario": Field("str", "Scenario of the init experiment.", choices=tuple(SCENARIOS), default="SC3"),
    "init_duration_s": Field("float", "Filter run of the init experiment, s.", gt=0, default=450.0),
    "proxy_scenario": Field("str", "Scenario of the proxy experiment.", choices=tuple(SCENARIOS), default="SC1"),
    "proxy_duration_s": Field("float", "Filter run of the proxy experiment, s.", gt=0, default=300.0),
    "dt_s": Field("float", "Sampling time of filter and pose measurements, s.", gt=0, default=1.0),
    "fault_start_s": Field("float", "Start of the proxy experiment's fault window, s.", ge=0, default=90.0),
    "fault_duration_s": Field("float", "Length of the fault window, s (Renis et al. §6.3: 120).", gt=0, default=120.0),
    "settling_s": Field("float", "RMSE of the proxy experiment from fault end + this, s.", ge=0, default=30.0),
    "gate_confidence": Field("float", "Chi-square gate confidence per source.", gt=0, le=0.999, default=0.99),
    "gate_start_s": Field("float", "Gates test measurements from this time on, s.", ge=0, default=10.0),
    "confidence": Field("float", "Confidence level of the intervals in the summary.", gt=0, le=0.999, default=0.95),
    "record": Field("bool", "Write lightcurve.rrd and one recording per filter and arm in every run.", default=True),
    "truth": TRUTH_FIELD,
}

_RUN_FIELDS = ("filters", "target", "nights", "night_spacing_days",
               "observation_duration_s", "cadence_s", "render_resolution_px", "render_spp", "false_alarm_level",
               "dt_s", "gate_confidence", "gate_start_s", "record", "truth")


def check(params: dict) -> None:
    """Cross-field rules: samples in the light curve, dt within the runs, the fault window within the proxy run."""
    if params["observation_duration_s"] / params["cadence_s"] < 20:
        raise ConfigError(f"cadence_s {params['cadence_s']}: expected at least 20 light-curve samples over observation_duration_s = "
                          f"{params['observation_duration_s']} s")
    for e in params["experiments"]:
        if params["dt_s"] > params[f"{e}_duration_s"]:
            raise ConfigError(f"dt_s {params['dt_s']}: expected at most {e}_duration_s = {params[f'{e}_duration_s']} s")
    if "proxy" in params["experiments"] and params["fault_start_s"] + params["fault_duration_s"] + params["settling_s"] >= params["proxy_duration_s"]:
        raise ConfigError(f"proxy_duration_s {params['proxy_duration_s']}: expected more than fault_start_s + fault_duration_s + settling_s = "
                          f"{params['fault_start_s'] + params['fault_duration_s'] + params['settling_s']} s")


def expand(config: StudyConfig) -> list[RunSpec]:
    """Experiments × seeds; run ids ``<experiment>-s<index>``."""
    common = {k: config[k] for k in _RUN_FIELDS}
    runs = []
    for e in config["experiments"]:
        extra = {"scenario": config[f"{e}_scenario"], "duration_s": config[f"{e}_duration_s"]}
        if e == "proxy":
            extra |= {"fault_start_s": config["fault_start_s"], "fault_duration_s": config["fault_duration_s"], "settling_s": config["settling_s"]}
        runs += [(f"{e}-s{i:03d}", {"experiment": e, "seed_index": i, **extra, **common}) for i in range(config["n_seeds"])]
    return make_specs(config.seed, runs)


def execute(spec: RunSpec, workdir: Path) -> dict:
    """One experiment and seed: render, extract, then every filter in the arms none, tuning and the experiment's use."""
    p = spec.params
    rng = np.random.default_rng(spec.seed)
    measurement_seed = int(rng.integers(2**63))
    sc = get_scenario(p["scenario"])
    rendered = render_prior(sc, rng, target=p["target"], nights=p["nights"], night_spacing_days=p["night_spacing_days"],
                            duration_s=p["observation_duration_s"], cadence_s=p["cadence_s"], resolution_px=p["render_resolution_px"],
                            spp=p["render_spp"])
    x = rendered.extracted
    row = {
        "experiment": p["experiment"], "scenario": sc.name, "lc_samples": int(sum(len(lc) for lc in rendered.observed.lightcurves)),
        "lc_truth_rate_deg_s": float(np.degrees(rendered.truth_rate_rad_s)), "prior_significant": bool(x.significant),
        "lc_rate_deg_s": float(np.degrees(rendered.built.inversion_prior.rate_rad_s)) if rendered.spin is not None else float("nan"),
        "lc_rate_sigma_deg_s": float(np.degrees(rendered.built.inversion_prior.rate_sigma_rad_s)) if rendered.spin is not None else float("nan"),
        "lc_rate_error_pct": 100.0 * rendered.rate_error, "lc_maxima_per_rotation": x.maxima_per_rotation or 0,
        "lc_single_night_rate_deg_s": x.rate_deg_s if x.significant else float("nan"),
        "lc_prior_sigma_norm_deg_s": float(np.degrees(np.linalg.norm(rendered.spin.sigma_rad_s))) if rendered.spin is not None else float("nan"),
        **rendered.score(),
        "tuning_expected": f"{sc.name.lower()}-conservative",
        "tuning_chosen": arm_tuning("tuning", rendered.built.tuning_spin) if rendered.spin is not None else "",
    }
    row["tuning_correct"] = row["tuning_chosen"] == row["tuning_expected"]
    faults, rmse_from = (), None
    if p["experiment"] == "proxy":
        faults = ((p["fault_start_s"], p["fault_duration_s"]),)
        rmse_from = p["fault_start_s"] + p["fault_duration_s"] + p["settling_s"]
    arms = ("none", "tuning", p["experiment"]) if rendered.spin is not None else ("none",)
    truth = simulate_truth(sc, p["duration_s"], p["dt_s"], p["truth"])
    row["n_steps"] = len(truth.t)
    for f in p["filters"]:
        for arm in arms:
            try:
                run, meas, _ = navigate_arm(truth, f, arm, rendered.spin, measurement_seed, tuning_spin=rendered.built.tuning_spin, faults=faults,
                                            gate_confidence=p["gate_confidence"], gate_start_s=p["gate_start_s"])
            except ValueError as e:  # the filter broke down numerically (P not positive definite, NaN): a result, counted
                row[f"{f}_{arm}_failed"] = str(e)
                continue
            row[f"{f}_{arm}_failed"] = ""
            row |= flat_metrics(truth, run, f"{f}_{arm}", rmse_from_s=rmse_from)
            if p["record"]:
                record_run(workdir / f"{f}_{arm}.rrd", truth, run, meas, spec.seed, f"{f}_{arm}")
    if p["record"]:
        record_lightcurve(workdir / "lightcurve.rrd", rendered, recording_id=f"chain-lightcurve-{spec.run_id}-{spec.seed}")
        plot_spectrum(rendered, workdir / "spectrum.png")
    return row


def long_runs(runs: pd.DataFrame, filters, experiments) -> pd.DataFrame:
    """One row per run, filter and arm (columns ``<group>_conv_s``, ``<group>_rmse``, ...) from the flat runs table."""
    parts = []
    for e in experiments:
        sub = runs[runs["experiment"] == e]
        for f in filters:
            for arm in ("none", "tuning", e):
                failed = f"{f}_{arm}_failed"
                if failed not in sub.columns:
                    continue
                cols = {c: c[len(f"{f}_{arm}_"):] for c in sub.columns if c.startswith(f"{f}_{arm}_") and c != failed}
                d = sub[["run_id", "seed", "experiment"] + list(cols)].rename(columns=cols)
                d[list(cols.values())] = d[list(cols.values())].astype(float)  # None (did not converge or failed) -> NaN
                parts.append(d.assign(filter=f, arm=arm, failed=sub[failed].fillna("").astype(str).ne("")))
    return pd.concat(parts, ignore_index=True)


def summarise(runs: pd.DataFrame, config: StudyConfig, out_dir: Path) -> list[Table]:
    """Tables ``summary`` (per experiment, filter, arm, group), ``lightcurve`` (rate error, tuning choice) and,
    with the proxy experiment, ``proxy_window`` (RMSE after the fault); figures ``rate_error.png`` and ``convergence.png``."""
    conf = config["confidence"]
    pct = int(round(100 * conf))
    rng = np.random.default_rng(config.seed)
    experiments, filters = config["experiments"], config["filters"]
    long = long_runs(runs, filters, experiments)
    rows = []
    for g in GROUPS:
        d = describe(long.assign(group=g), ["experiment", "filter", "arm", "group"], [f"{g}_conv_s", f"{g}_rmse"], confidence=conf,
                     median_of=[f"{g}_conv_s"], rng=rng)
        conv = long.groupby(["experiment", "filter", "arm"], sort=False)[f"{g}_conv_s"].apply(lambda s: float(np.isfinite(s).mean()))
        d["converged"] = [conv[(e, f, a)] for e, f, a in zip(d["experiment"], d["filter"], d["arm"])]
        fail = long.groupby(["experiment", "filter", "arm"], sort=False)["failed"].sum()
        d["failed"] = [int(fail[(e, f, a)]) for e, f, a in zip(d["experiment"], d["filter"], d["arm"])]
        d.columns = [c.removeprefix(f"{g}_") for c in d.columns]
        rows.append(d)
    order = {a: i for i, a in enumerate(("none", "tuning", "init", "proxy"))}
    summ = pd.concat(rows, ignore_index=True)
    summ = summ.sort_values(["experiment", "filter", "arm", "group"],
                            key=lambda s: s.map(order) if s.name == "arm" else s.map(GROUPS.index) if s.name == "group" else s,
                            kind="stable").reset_index(drop=True)
    summ["arm"] = summ["arm"].map(ARM_LABELS)
    cols = {"experiment": "experiment", "filter": "filter", "arm": "prior", "group": "group", "n_runs": "runs", "failed": "failed", "converged": "converged",
            "conv_s_mean": "t_conv mean (s)", "conv_s_sd": "t_conv sd", "conv_s_ci_lo": f"mean {pct}% lo", "conv_s_ci_hi": f"mean {pct}% hi",
            "conv_s_median": "t_conv median (s)", "conv_s_med_lo": f"median {pct}% lo", "conv_s_med_hi": f"median {pct}% hi",
            "rmse_mean": "RMSE mean", "rmse_sd": "RMSE sd", "rmse_ci_lo": f"RMSE {pct}% lo", "rmse_ci_hi": f"RMSE {pct}% hi"}
    summary = summ[list(cols)].rename(columns=cols)
    notes = (f"Per seed {config['nights']} arcs of {config['target']} ({config['observation_duration_s']:g} s at {config['cadence_s']:g} s, "
             f"{config['render_resolution_px']} px, {config['night_spacing_days']:g} d apart) are rendered about a drawn pole and inverted with the "
             "target's model; the prior ω_T and its covariance come from the inversion's modes (no truth reaches it: table 'prior'). "
             "Arms: no prior (general-conservative tuning, ω̂_0 = 0); prior: tuning (tuning_for_prior); prior: tuning + init (§6.2); "
             "prior: tuning + init + proxy (§6.3, with the fault window). Same measurements in every arm. State-based metrics of §6 "
             "(RMSE units: q rad, w rad/s, r m, v m/s, k –); 'failed': runs in which the filter broke down numerically "
             "(counted as not converged, message in runs.parquet); 'converged': fraction of seeds converged; t statistics over converged seeds; "
             f"mean with a Student-t interval, median with a BCa bootstrap interval ({pct}%). Filter-based metrics are in runs.parquet. "
             "Paired differences against the no-prior arm: table 'paired'.")
    tables = [Table("summary", TITLE, summary, notes, default_format=".3g")]

    lc_rows = []
    for e in experiments:
        sub = runs[runs["experiment"] == e]
        d = describe(sub.assign(abs_err=sub["lc_rate_error_pct"].abs()), ["experiment"], ["lc_rate_error_pct"], confidence=conf,
                     median_of=["abs_err"], rng=rng).iloc[0]
        tc = proportion_interval(int(sub["tuning_correct"].sum()), len(sub), conf)
        lc_rows.append({"experiment": e, "scenario": sub["scenario"].iloc[0], "runs": len(sub), "significant": int(sub["prior_significant"].sum()),
                        "truth rate (°/s)": float(sub["lc_truth_rate_deg_s"].iloc[0]),
                        "rate error mean (%)": d["lc_rate_error_pct_mean"], "sd (%)": d["lc_rate_error_pct_sd"],
                        f"mean {pct}% lo": d["lc_rate_error_pct_ci_lo"], f"mean {pct}% hi": d["lc_rate_error_pct_ci_hi"],
                        "median |error| (%)": d["abs_err_median"], "max |error| (%)": float(sub["lc_rate_error_pct"].abs().max()),
                        "σ_rate mean (°/s)": float(sub["lc_rate_sigma_deg_s"].mean()),
                        "tuning chosen": ", ".join(sorted(set(sub["tuning_chosen"]))), "tuning correct": tc.estimate,
                        f"correct {pct}% lo": tc.lo, f"correct {pct}% hi": tc.hi})
    tables.append(Table("lightcurve", "Light-curve prior: rate error against the rendered truth, and the tuning it picks (§6.1)",
                        pd.DataFrame(lc_rows), "Rate error = the prior's rate / rendered rate − 1 (the inversion's sidereal period against the "
                        "truth's). 'tuning correct': the scenario-specific tuning picked is the scenario's own "
                        f"(Wilson {pct}% interval).", default_format=".3g"))
    tables.append(prior_table(runs, experiments, conf))
    tables.append(paired_table(long, runs, filters, experiments, conf))
    if "proxy" in experiments:
        pl = long[long["experiment"] == "proxy"]
        metrics = [f"{g}_rmse_after" for g in ("q", "w", "r", "v")]
        d = describe(pl, ["filter", "arm"], metrics, confidence=conf)
        d["arm"] = d["arm"].map(ARM_LABELS)
        keep = {"filter": "filter", "arm": "prior", "n_runs": "runs"}
        for m, u in zip(metrics, ("rad", "rad/s", "m", "m/s")):
            keep |= {f"{m}_mean": f"RMSE {m[0]} ({u})", f"{m}_ci_lo": f"{m[0]} {pct}% lo", f"{m}_ci_hi": f"{m[0]} {pct}% hi"}
        t0 = config["fault_start_s"] + config["fault_duration_s"] + config["settling_s"]
        tables.append(Table("proxy_window", "Proxy experiment: RMSE after the fault (analogue of Renis et al. Table 6)", d[list(keep)].rename(columns=keep),
                            f"{config['proxy_scenario']}, fault {config['fault_start_s']:g}–{config['fault_start_s'] + config['fault_duration_s']:g} s; "
                            f"RMSE of the state error from {t0:g} s to the end, mean with a t interval.", default_format=".3g"))
    plot_rate_errors(runs, experiments, out_dir / "rate_error.png")
    plot_convergence(long, filters, experiments, out_dir / "convergence.png")
    return tables


def prior_table(runs: pd.DataFrame, experiments, conf: float) -> Table:
    """Table ``prior``: how the inversion's prior scores against the truth, per experiment (pole, sense, modes, calibration)."""
    pct = int(round(100 * conf))
    rows = []
    for e in experiments:
        sub = runs[(runs["experiment"] == e) & runs["prior_available"].astype(bool)]
        n = len(sub)
        sense = proportion_interval(int(sub["prior_sense_right"].astype(bool).sum()), n, conf)
        inside = proportion_interval(int((sub["prior_w_mahalanobis2"] <= chi2.ppf(conf, 3)).sum()), n, conf)
        pole = sub["prior_pole_err_deg"].astype(float)
        rows.append({"experiment": e, "priors": n, "pole error median (°)": float(pole.median()), "pole error max (°)": float(pole.max()),
                     "pole within 5°": int((pole <= 5.0).sum()), "sense right": sense.estimate, f"sense {pct}% lo": sense.lo,
                     f"sense {pct}% hi": sense.hi, "ambiguous (> 1 mode)": int((sub["prior_n_modes"] > 1).sum()),
                     "period error median |%|": float(sub["prior_period_err_pct"].abs().median()),
                     f"truth ω in {pct}% region": inside.estimate, f"region {pct}% lo": inside.lo, f"region {pct}% hi": inside.hi})
    return Table("prior", "The inversion's prior scored against the truth (the truth never builds it)", pd.DataFrame(rows),
                 f"Pole: angle between the best mode's pole and the true angular-momentum direction (a reversed sense is ~180°). "
                 f"'truth ω in {pct}% region': the true ω_T inside the prior's {pct}% ellipsoid (Mahalanobis² ≤ χ²₃ quantile). Intervals: "
                 "Wilson. An axisymmetric target's prior knows the rate and that ω is ⟂ its long axis, not the azimuth about it, so a wrong "
                 "pole does not make its ω_T wrong.", default_format=".3g")


def paired_table(long: pd.DataFrame, runs: pd.DataFrame, filters, experiments, conf: float) -> Table:
    """Table ``paired``: per experiment, filter, prior arm and group, the change against the no-prior arm on the same seed.

    ``Δ RMSE`` (steady state, defined once a run has converged) and ``Δ t_conv`` over the seeds where both arms have one:
    mean and Student-t interval of the per-seed differences; the runs whose prior has the wrong sense are also given on
    their own (``wrong-sense runs``).
    """
    pct = int(round(100 * conf))
    wrong = set(runs.loc[~runs["prior_sense_right"].astype(bool), "run_id"])
    rows = []
    for e in experiments:
        for f in filters:
            base = long[(long["experiment"] == e) & (long["filter"] == f) & (long["arm"] == "none")].set_index("run_id")
            for arm in ("tuning", e):
                other = long[(long["experiment"] == e) & (long["filter"] == f) & (long["arm"] == arm)].set_index("run_id")
                for g in GROUPS:
                    d_rmse = (other[f"{g}_rmse"] - base[f"{g}_rmse"]).dropna()
                    d_conv = (other[f"{g}_conv_s"] - base[f"{g}_conv_s"]).dropna()
                    ci_r, ci_c = t_interval(d_rmse, conf), t_interval(d_conv, conf)
                    w = d_rmse[d_rmse.index.isin(wrong)]
                    rows.append({"experiment": e, "filter": f, "prior": ARM_LABELS[arm], "group": g, "pairs": len(d_rmse),
                                 "Δ RMSE mean": ci_r.estimate, f"Δ RMSE {pct}% lo": ci_r.lo, f"Δ RMSE {pct}% hi": ci_r.hi,
                                 "Δ t_conv mean (s)": ci_c.estimate, f"Δ t_conv {pct}% lo": ci_c.lo,
                                 f"Δ t_conv {pct}% hi": ci_c.hi, "wrong-sense runs": len(w), "their Δ RMSE": float(w.mean()) if len(w) else np.nan})
    return Table("paired", "What the prior changes, seed by seed (prior arm − no-prior arm)", pd.DataFrame(rows),
                 f"Differences of the same seed's runs (same measurements); mean with a Student-t interval ({pct}%); negative is better. "
                 "'pairs': seeds where both arms converged (the steady-state RMSE and t_conv exist only then). 'wrong-sense runs': "
                 "those of the pairs whose prior's best pole has the reversed sense, and their mean Δ RMSE.", default_format=".3g")


def plot_rate_errors(runs: pd.DataFrame, experiments, path: Path) -> None:
    """``rate_error.png``: each seed's light-curve rate error per experiment, with its 1-σ."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(6.4, 3.6), layout="constrained")
    for i, e in enumerate(experiments):
        sub = runs[runs["experiment"] == e]
        x = i + np.linspace(-0.2, 0.2, len(sub)) if len(sub) > 1 else np.array([float(i)])
        sig = 100 * sub["lc_rate_sigma_deg_s"] / sub["lc_truth_rate_deg_s"]
        ax.errorbar(x, sub["lc_rate_error_pct"], yerr=sig, fmt="o", ms=4, capsize=2, label=f"{e} ({sub['scenario'].iloc[0]})")
    ax.axhline(0.0, color="k", lw=0.6)
    ax.set(xticks=range(len(experiments)), xticklabels=list(experiments), ylabel="rate error (%)",
           title="The prior's rate from the inverted light curves vs truth (±1σ)")
    ax.legend(fontsize=8)
    save_png(fig, path)


def plot_convergence(long: pd.DataFrame, filters, experiments, path: Path) -> None:
    """``convergence.png``: per experiment and group, the median convergence time of each filter and arm (bars: quartiles)."""
    plt = pyplot()
    fig, axes = plt.subplots(len(experiments), 1, figsize=(8, 3.2 * len(experiments)), layout="constrained", squeeze=False)
    for ax, e in zip(axes[:, 0], experiments):
        sub = long[long["experiment"] == e]
        combos = [(f, a) for f in filters for a in ("none", "tuning", e)]
        width = 0.8 / len(combos)
        for j, (f, a) in enumerate(combos):
            s = sub[(sub["filter"] == f) & (sub["arm"] == a)]
            med, lo, hi = [], [], []
            for g in GROUPS:
                v = s[f"{g}_conv_s"].to_numpy(dtype=float)
                v = v[np.isfinite(v)]
                q = np.percentile(v, [25, 50, 75]) if v.size else np.full(3, np.nan)
                med.append(q[1])
                lo.append(q[1] - q[0])
                hi.append(q[2] - q[1])
            ax.bar(np.arange(len(GROUPS)) + (j - (len(combos) - 1) / 2) * width, med, width, yerr=[lo, hi], capsize=2,
                   label=f"{f.upper()}, {ARM_LABELS[a]}")
        ax.set(xticks=range(len(GROUPS)), xticklabels=list(GROUPS), ylabel="convergence time (s)", title=f"{e}: median over seeds (converged runs)")
        ax.legend(fontsize=7)
    save_png(fig, path)
