"""Study ``combina``: CoMBiNa convergence and symmetry detection over many seeds (Maestrini et al. §VI).

The paper shows single runs: the convergence of the translational filter
(Fig. 10: errors in ``r``, ``v`` with 3-σ bounds), of the attitude filter for
an asymmetric target (Fig. 11: ``σ``, ``ω``, ``k``), the principal-angle
variation test that tells a symmetric target from an asymmetric one (Fig. 14,
eqs 33-34) and, for a symmetric target, the axisymmetric filter (Figs 15-17:
the axis ``(φ, δ)`` and ``Γ/A``, eqs 35-40). This study runs the closed loop of
:func:`studies.sim.combina.run_combina` for each target over ``n_seeds`` seeds
(each seed: its own initial estimate drawn from ``P_0`` of eq. 48 and its own
measurement noise) and reports, per target and component:

* the fraction of runs whose error norm converged below the tolerance of
  :data:`studies.sim.combina.TOLERANCES` and stayed there (Wilson interval),
* the convergence time (median with a bootstrap interval),
* the final error (mean with a Student-t interval),
* the fraction of steps after convergence whose error lies inside ±3σ
  (mean with a t interval) — the consistency the figures show by eye,
* per target the symmetry-detection rate (Wilson), the switch time and, for
  the symmetric target, the final axis error.

Figures: ``convergence_<target>.png`` (every seed's error and ±3σ per
component and axis, laid out like Figs 10-11 / 15-16) and ``symmetry.png``
(the discrepancy between the two principal-angle variation estimates per
check, with the detector's threshold, like Fig. 14). Each run writes
``run.rrd`` (:func:`studies.recording.combina.write_recording`) and
``errors.parquet`` (the per-step errors and 1-σ the figures are drawn from).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from estimators.combina.symmetry import SymmetryDetector
from studies.sim.combina import COMPONENT_SI, FILTER_COMPONENTS, SOURCES, COMBINA_TARGETS, TU, CombinaConfig, component_errors, run_combina, combina_metrics
from studies.recording.combina import write_recording
from studies.catalog.filter_common import TRUTH_FIELD
from studies.engine.config import ConfigError, Field, StudyConfig
from studies.engine.io import atomic_path, write_table
from studies.engine.stats import bootstrap_interval, describe, proportion_interval
from studies.engine.sweep import RunSpec, make_specs, run_dir
from studies.engine.tables import Table

TITLE = "CoMBiNa convergence and symmetry detection (Maestrini et al. §VI, Figs 10, 11, 14-17), over seeds"

FIELDS: dict[str, Field] = {
    "targets": Field("list[str]", "Targets: asymmetric (box-wing, eq. 47) and/or symmetric (rocket body).", choices=COMBINA_TARGETS),
    "n_seeds": Field("int", "Seeds per target (initial estimate drawn from P_0 and measurement noise).", ge=1),
    "duration_TU": Field("float", "Simulated time per run in TU (1 TU = 963.65 s).", gt=0),
    "measurement_period_s": Field("float", "Time between two pose measurements, s.", gt=0),
    "measurements": Field("str", "Measurement source: simulated (BCPD-like noisy poses) or rendered (Mitsuba stereo + BCPD).", choices=SOURCES),
    "confidence": Field("float", "Confidence level of the intervals in the summary.", gt=0, le=0.999, default=0.95),
    "record": Field("bool", "Write run.rrd for every run.", default=True),
    "truth": TRUTH_FIELD,
}

_RUN_FIELDS = ("duration_TU", "measurement_period_s", "measurements", "record", "truth")
#: Components per target, in the order of the paper's figures.
COMPONENTS = {"asymmetric": FILTER_COMPONENTS["translation"] + FILTER_COMPONENTS["attitude"],
              "symmetric": FILTER_COMPONENTS["translation"] + FILTER_COMPONENTS["axisymmetric"]}
UNIT_LABEL = {"r": "m", "v": "m/s", "sigma": "MRP", "w": "rad/s", "k": "-", "phi": "rad", "delta": "rad", "gamma_over_a": "rad/s"}


def check(params: dict) -> None:
    """At least two measurements per run."""
    if params["duration_TU"] * TU < 2 * params["measurement_period_s"]:
        raise ConfigError(f"duration_TU {params['duration_TU']}: expected at least two measurement periods "
                          f"({2 * params['measurement_period_s']:g} s)")


def expand(config: StudyConfig) -> list[RunSpec]:
    """Targets × seeds; run ids ``<target>-s<index>``."""
    common = {k: config[k] for k in _RUN_FIELDS}
    return make_specs(config.seed, ((f"{tg}-s{i:03d}", {"target": tg, "seed_index": i, **common})
                                    for tg in config["targets"] for i in range(config["n_seeds"])))


def errors_frame(run) -> pd.DataFrame:
    """Long table of every estimated component's error and 1-σ per step: ``t_s, component, axis, error, sigma`` (SI)."""
    parts = []
    for name, (t, err, sd) in component_errors(run).items():
        n, d = err.shape
        parts.append(pd.DataFrame({"t_s": np.repeat(t, d), "component": name, "axis": np.tile(np.arange(d), n),
                                   "error": err.ravel(), "sigma": sd.ravel()}))
    return pd.concat(parts, ignore_index=True)


def execute(spec: RunSpec, workdir: Path) -> dict:
    """One closed-loop run; metrics flattened per component, ``errors.parquet``, ``symmetry.parquet`` and ``run.rrd``."""
    p = spec.params
    cfg = CombinaConfig(target=p["target"], measurements=p["measurements"], duration_tu=p["duration_TU"],
                        rate_hz=1.0 / p["measurement_period_s"], seed=spec.seed, truth=p["truth"])
    run = run_combina(cfg)
    m = combina_metrics(run)
    write_table(workdir / "errors.parquet", errors_frame(run))
    write_table(workdir / "symmetry.parquet", pd.DataFrame({
        "t_s": [c.t for c in run.symmetry], "discrepancy_rad": [c.discrepancy_rad for c in run.symmetry]}))
    if p["record"]:
        write_recording(workdir / "run.rrd", run, recording_id=f"combina-{spec.run_id}")
    out = {"n_steps": len(run.steps), "mode": m["mode"], "symmetry_detected": m["symmetry_detected"],
           "switch_time_s": m["switch_time_s"], "axis_error_deg": m.get("axis_error_deg"),
           "shadow_switches": m["shadow_switches"], "rejected_scale": m["gate_counts"]["rejected_scale"],
           "rejected_mahalanobis": m["gate_counts"]["rejected_mahalanobis"], "accepted": m["gate_counts"]["accepted"]}
    for name in COMPONENTS[p["target"]]:
        c = m["components"].get(name, {"converged": False, "convergence_time_s": None, "final_error": None, "fraction_within_3sigma": None})
        out.update({f"{name}_{k}": v for k, v in c.items()})
    return out


def summarise(runs: pd.DataFrame, config: StudyConfig, out_dir: Path) -> list[Table]:
    """Per target and component: convergence, final error, 3-σ consistency; per target: symmetry detection."""
    conf = config["confidence"]
    pct = int(round(100 * conf))
    rng = np.random.default_rng(config.seed)
    rows = []
    for target in dict.fromkeys(runs["target"]):
        sub = runs[runs["target"] == target]
        for name in COMPONENTS[target]:
            conv = sub[f"{name}_converged"].astype(bool)
            frac = proportion_interval(int(conv.sum()), len(sub), conf)
            tconv = bootstrap_interval(sub.loc[conv, f"{name}_convergence_time_s"].astype(float), np.median, conf, rng=rng)
            long = pd.DataFrame({"g": 0, "final": sub[f"{name}_final_error"].astype(float),
                                 "in3": sub[f"{name}_fraction_within_3sigma"].astype(float)})
            d = describe(long, ["g"], ["final", "in3"], confidence=conf).iloc[0]
            rows.append({
                "target": target, "component": name, "unit": UNIT_LABEL[name], "runs": len(sub),
                "converged": frac.estimate, f"conv. {pct}% lo": frac.lo, f"conv. {pct}% hi": frac.hi,
                "conv. time median (s)": tconv.estimate, f"time {pct}% lo": tconv.lo, f"time {pct}% hi": tconv.hi,
                "final error mean": d["final_mean"], "final error sd": d["final_sd"],
                f"final {pct}% lo": d["final_ci_lo"], f"final {pct}% hi": d["final_ci_hi"],
                "within 3σ mean": d["in3_mean"], f"within 3σ {pct}% lo": d["in3_ci_lo"], f"within 3σ {pct}% hi": d["in3_ci_hi"],
            })
    summary = pd.DataFrame(rows)
    sym_rows = []
    for target in dict.fromkeys(runs["target"]):
        sub = runs[runs["target"] == target]
        det = sub["symmetry_detected"].astype(bool)
        iv = proportion_interval(int(det.sum()), len(sub), conf)
        sw = bootstrap_interval(sub.loc[det, "switch_time_s"].astype(float), np.median, conf, rng=rng)
        ax = sub.loc[det, "axis_error_deg"].astype(float) if "axis_error_deg" in sub else pd.Series(dtype=float)
        sym_rows.append({"target": target, "runs": len(sub), "symmetry detected": iv.estimate,
                         f"{pct}% lo": iv.lo, f"{pct}% hi": iv.hi, "switch time median (s)": sw.estimate,
                         f"switch {pct}% lo": sw.lo, f"switch {pct}% hi": sw.hi,
                         "final axis error median (deg)": float(ax.median()) if ax.notna().any() else np.nan,
                         "Mahalanobis rejections mean": float(sub["rejected_mahalanobis"].mean()),
                         "scale rejections mean": float(sub["rejected_scale"].mean())})
    symmetry = pd.DataFrame(sym_rows)
    detector = SymmetryDetector()
    notes = (
        f"{config['n_seeds']} seeds per target, {config['duration_TU']:g} TU ({config['duration_TU'] * TU:.0f} s), one "
        f"{config['measurements']} pose measurement every {config['measurement_period_s']:g} s. Errors in SI (m, m/s, MRP, rad/s, 1, rad, rad/s); "
        "converged = the error norm falls below the tolerance of studies.sim.combina.TOLERANCES and stays there to the end "
        f"(Wilson interval); convergence time: median over the converged runs (BCa bootstrap); final error: mean with a "
        "Student-t interval; within 3σ: per run, the fraction of steps after convergence (all steps if it never converged) "
        "where every axis of the error lies inside ±3σ of the filter's covariance, then its mean over runs."
    )
    sym_notes = (f"Symmetry declared when the median of the last {detector.window} angles between the measured relative "
                 "rotation of consecutive registrations and the filter's integrated prediction (eqs 33-34, counted only "
                 f"while 3σ of the prediction is below the threshold) exceeds {np.rad2deg(detector.threshold_rad):g}°, or "
                 "(rendered chain) when the clouds rolled by 90/180/270° about the body y axis fit the coarse model nearly as "
                 "well as unrolled, measured against a perpendicular 90° turn (RollSymmetryTest); the detection rate carries "
                 "a Wilson interval, the switch time a BCa "
                 "bootstrap interval of the median.")
    for target in dict.fromkeys(runs["target"]):
        plot_convergence(runs[runs["target"] == target], target, out_dir, out_dir / f"convergence_{target}.png")
    plot_symmetry(runs, out_dir, out_dir / "symmetry.png", np.rad2deg(detector.threshold_rad))
    return [Table("summary", TITLE, summary, notes, formats={"converged": ".0%", "within 3σ mean": ".1%"}, default_format=".3g"),
            Table("symmetry", "Symmetry detection (Fig. 14 of Maestrini et al.) and the axisymmetric mode", symmetry, sym_notes, default_format=".3g")]


def _savefig(fig, path: Path) -> None:
    import matplotlib.pyplot as plt

    with atomic_path(path) as tmp:
        fig.savefig(tmp, format="png", dpi=110)
    plt.close(fig)


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def plot_convergence(runs: pd.DataFrame, target: str, out_dir: Path, path: Path) -> None:
    """Every seed's error (solid) and ±3σ (dashed) per component (rows) and axis (columns), as Figs 10-11 / 15-16."""
    plt = _pyplot()
    comps = COMPONENTS[target]
    frames = [pd.read_parquet(run_dir(out_dir, rid) / "errors.parquet") for rid in runs["run_id"]]
    fig, axes = plt.subplots(len(comps), 3, figsize=(10, 1.7 * len(comps)), sharex=True, layout="constrained", squeeze=False)
    colors = plt.cm.viridis(np.linspace(0, 0.9, max(len(frames), 1)))
    for i, name in enumerate(comps):
        scale = COMPONENT_SI[name]
        for j in range(3):
            ax = axes[i, j]
            for col, df in zip(colors, frames):
                d = df[(df["component"] == name) & (df["axis"] == j)]
                if d.empty:
                    continue
                tt = d["t_s"] / TU
                ax.plot(tt, d["error"], color=col, lw=0.8)
                ax.plot(tt, 3 * d["sigma"], color=col, lw=0.6, ls="--")
                ax.plot(tt, -3 * d["sigma"], color=col, lw=0.6, ls="--")
            if not ax.lines:
                ax.set_visible(False)
                continue
            lim = 3 * float(np.nanmax([df.loc[(df["component"] == name) & (df["axis"] == j), "sigma"].median() for df in frames] + [1e-12 * scale]))
            ax.set_ylim(-4 * lim, 4 * lim)
            ax.set_ylabel(f"{name}[{j}] ({UNIT_LABEL[name]})", fontsize=8)
            ax.tick_params(labelsize=7)
    for ax in axes[-1]:
        ax.set_xlabel("time (TU)")
    fig.suptitle(f"CoMBiNa, {target} target: error (solid) and ±3σ (dashed), {len(frames)} seeds", fontsize=10)
    _savefig(fig, path)


def plot_symmetry(runs: pd.DataFrame, out_dir: Path, path: Path, threshold_deg: float) -> None:
    """Discrepancy between the principal-angle variation estimates per check, one panel per target (Fig. 14)."""
    plt = _pyplot()
    targets = list(dict.fromkeys(runs["target"]))
    fig, axes = plt.subplots(1, len(targets), figsize=(5 * len(targets), 3.4), sharey=True, layout="constrained", squeeze=False)
    for ax, target in zip(axes[0], targets):
        for rid in runs.loc[runs["target"] == target, "run_id"]:
            d = pd.read_parquet(run_dir(out_dir, rid) / "symmetry.parquet")
            ax.scatter(d["t_s"] / TU, np.rad2deg(d["discrepancy_rad"]), s=4, alpha=0.6)
        ax.axhline(threshold_deg, color="tab:red", ls="--", label=f"detector threshold {threshold_deg:g}° (window median)")
        ax.set(title=f"{target} target", xlabel="time (TU)", yscale="log")
        ax.legend(fontsize=7)
    axes[0, 0].set_ylabel("|Φ − Φ̂| (deg), eqs 33-34")
    _savefig(fig, path)
