"""Study ``coverage``: CoMBiNa convergence against the target's tumbling rate (Maestrini et al. §VII, Fig. 20).

As in the paper: for each tumbling-rate level ``|ω_T|`` (rad/s), random
initial conditions draw the target's inertia ratios ``k1, k2`` uniformly in
``k_range``, its attitude ``σ_T`` uniformly (:func:`random_quaternion`) and the
direction of ``ω_T`` uniformly on the sphere; the chaser
measures the target's pose at ``measurement_rate_hz`` (0.33 Hz, the rate the
timing study allows) with the simulated BCPD-like source, for
``horizon_orbits`` of the chaser's orbit (half an orbit). A run has
*converged* when, at each of its last ``n_last`` measurement epochs, the
normalised estimation error squared ``eᵀ P⁻¹ e`` of every active filter
(translation, 6 states; attitude, 8 states, or the axisymmetric filter, 3
states, if the run switched) lies below the ``converged_confidence`` quantile
of its χ² distribution (:func:`studies.combina.filter_nees`) — "the errors of
the last 10 time steps have a probability of at least 99%". A filter that
breaks down numerically (a covariance that is no longer positive definite)
has not converged; such runs are counted as ``diverged``.

Units: the paper's Fig. 20 axis reads "Hz", but its coverage drop sits where
the target turns π between two 0.33 Hz measurements (π × 0.33 = 1.04 rad/s),
so its levels 0.15 … 1.5 are rad/s; they are used as such here.

The summary is Fig. 20 with intervals: per level, the converged fraction with
its Wilson interval (:func:`studies.stats.proportion_interval`), drawn as
``coverage.png``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
from scipy.stats import chi2

from estimators.attitude import attitude_angle, mrp_to_quat, random_quaternion
from estimators.combina.attitude import physical_k
from studies.sim.combina import TU, CombinaConfig, filter_nees, run_combina, simulate_lvlh_truth
from studies.recording.combina import write_recording
from studies.catalog.filter_common import TRUTH_FIELD
from studies.engine.config import ConfigError, Field, StudyConfig
from studies.engine.io import atomic_path
from studies.engine.stats import proportion_interval
from studies.engine.sweep import RunSpec, make_specs
from studies.engine.tables import Table

TITLE = "CoMBiNa coverage against tumbling rate (Maestrini et al. §VII, Fig. 20)"

FIELDS: dict[str, Field] = {
    "rate_levels_rad_s": Field("list[float]", "Tumbling-rate levels |ω_T|, rad/s.", gt=0),
    "n_initial_conditions": Field("int", "Random initial conditions per level.", ge=1),
    "n_initial_conditions_above": Field("int", "Random initial conditions per level above full_up_to_rad_s (0: n_initial_conditions).", ge=0, default=0),
    "full_up_to_rad_s": Field("float", "Levels up to this rate get n_initial_conditions.", gt=0, default=1.05),
    "measurement_rate_hz": Field("float", "Pose measurement rate, Hz.", gt=0),
    "horizon_orbits": Field("float", "Simulated time per run, in chaser orbits (2π TU).", gt=0),
    "k_range": Field("list[float]", "[low, high] of the uniform draw of k1 and k2.", min_len=2),
    "k_physical": Field("bool", "Draw k1, k2 from the rigid-body part of the k_range box only (rejection sampling).", default=False),
    "n_last": Field("int", "Converged: the NEES of the last n_last epochs pass the test.", ge=1),
    "converged_confidence": Field("float", "Probability of the chi-square test of the NEES.", gt=0, le=0.9999),
    "converged_rule": Field("str", "joint: the last n_last epochs pass together at converged_confidence (Bonferroni); per_epoch: each at it.",
                            default="joint", choices=("joint", "per_epoch")),
    "confidence": Field("float", "Confidence level of the Wilson intervals.", gt=0, le=0.999, default=0.95),
    "record": Field("bool", "Write run.rrd for every run that did not break down.", default=False),
    "truth": TRUTH_FIELD,
}

_RUN_FIELDS = ("measurement_rate_hz", "horizon_orbits", "k_range", "k_physical", "n_last", "converged_confidence", "converged_rule", "record", "truth")


def check(params: dict) -> None:
    """``k_range`` is ``[low, high]`` with ``low < high``; a run has at least ``n_last`` measurements."""
    k = params["k_range"]
    if len(k) != 2 or not k[0] < k[1]:
        raise ConfigError(f"k_range {k}: expected [low, high] with low < high")
    n = int(np.floor(params["horizon_orbits"] * 2 * np.pi * TU * params["measurement_rate_hz"]))
    if n < params["n_last"]:
        raise ConfigError(f"horizon_orbits {params['horizon_orbits']} ({n} measurements per run): expected at least n_last = {params['n_last']} measurements")


def n_runs_at(config: StudyConfig, rate_rad_s: float) -> int:
    """Initial conditions at one level: ``n_initial_conditions`` up to ``full_up_to_rad_s``, ``n_initial_conditions_above`` (if set) beyond."""
    above = config["n_initial_conditions_above"]
    return config["n_initial_conditions"] if rate_rad_s <= config["full_up_to_rad_s"] + 1e-9 or above == 0 else above


def expand(config: StudyConfig) -> list[RunSpec]:
    """Levels × initial conditions; run ids ``w<level>rads-ic<index>``."""
    common = {k: config[k] for k in _RUN_FIELDS}
    return make_specs(config.seed, ((f"w{w:.3f}rads-ic{i:03d}", {"rate_level_rad_s": w, "ic_index": i, **common})
                                    for w in config["rate_levels_rad_s"] for i in range(n_runs_at(config, w))))


def converged_last(nees: dict, t_last_s: float, confidence: float, *, joint: bool = False) -> dict[str, bool]:
    """Per filter active at epochs ``>= t_last_s``: every NEES there is below the χ²(dof) quantile.

    ``joint=False``: the ``confidence`` quantile at each epoch; a consistent
    filter then fails the window with probability up to ``1 − confidence^n``
    (9.6 % for 10 independent epochs at 99 %). ``joint=True``: the
    Bonferroni quantile ``1 − (1 − confidence)/n`` over the window's ``n``
    epochs, so that a consistent filter passes the whole window with
    probability at least ``confidence`` whatever the correlation between
    epochs — the paper's "the errors of the last 10 time steps have a
    probability of at least 99 %" read as one statement about the 10 steps.
    A filter with no epoch in that window (the attitude filter after a switch
    to the axisymmetric one) is left out.
    """
    out = {}
    for name, (t, e, dof) in nees.items():
        last = e[t >= t_last_s - 1e-9]
        if last.size:
            p = 1.0 - (1.0 - confidence) / last.size if joint else confidence
            out[name] = bool(np.all(last <= chi2.ppf(p, dof)))
    return out


def draw_inertia_ratios(rng: np.random.Generator, k_range, physical: bool) -> np.ndarray:
    """``k1, k2 ~ U(k_range)²``; with ``physical``, redrawn until they are a rigid body's (:func:`estimators.combina.attitude.physical_k`)."""
    for _ in range(1000):
        k = rng.uniform(*k_range, size=2)
        if not physical or physical_k(k):
            return k
    raise ConfigError(f"k_range {list(k_range)}: no physical inertia ratios in 1000 draws: expected a range holding physical inertia ratios")


def execute(spec: RunSpec, workdir: Path) -> dict:
    """One random initial condition at one tumbling rate; the convergence test of §VII."""
    p = spec.params
    rng = np.random.default_rng(spec.seed)
    k = draw_inertia_ratios(rng, p["k_range"], p["k_physical"])
    q_IT0 = random_quaternion(rng)
    direction = rng.normal(size=3)
    w_T0 = p["rate_level_rad_s"] * direction / np.linalg.norm(direction)
    cfg = CombinaConfig(target="asymmetric", duration_tu=p["horizon_orbits"] * 2 * np.pi, rate_hz=p["measurement_rate_hz"],
                        seed=int(rng.integers(2**62)), truth=p["truth"])
    cfg.validate()  # a bad configuration is an error, not a divergence
    t = cfg.epochs_s()
    truth = simulate_lvlh_truth("asymmetric", t[-1], t[1] - t[0], k=k, q_IT0=q_IT0, w_T0_rad_s=w_T0, physics=cfg.truth)
    out = {"k1": float(k[0]), "k2": float(k[1]), "rate_rad_s": float(np.linalg.norm(w_T0)),
           "rotation_per_measurement_deg": float(np.rad2deg(np.linalg.norm(w_T0) / cfg.rate_hz)), "n_steps": int(t.size)}
    try:
        run = run_combina(cfg, truth=truth)
    except (np.linalg.LinAlgError, ValueError) as e:  # the UKF's covariance lost positive definiteness
        return {**out, "diverged": True, "failure": f"{type(e).__name__}: {e}", "converged": False, "converged_per_epoch": False, "converged_joint": False,
                "symmetry_detected": False, "translation_ok": False, "attitude_ok": False}
    nees = filter_nees(run)
    ok_epoch = converged_last(nees, t[-p["n_last"]], p["converged_confidence"])
    ok_joint = converged_last(nees, t[-p["n_last"]], p["converged_confidence"], joint=True)
    ok = ok_joint if p["converged_rule"] == "joint" else ok_epoch
    last = run.steps[-1]
    out.update({
        "diverged": False, "failure": "", "converged": all(ok.values()),
        "converged_per_epoch": all(ok_epoch.values()), "converged_joint": all(ok_joint.values()),
        "symmetry_detected": run.switch_time_s is not None, "reacquisitions": run.reacquisitions, "acquisition_time_s": run.acquisition_time_s,
        "translation_restarts": run.translation_restarts, "attitude_refits": run.attitude_refits,
        "translation_ok": ok["translation"], "attitude_ok": ok.get("axisymmetric", ok.get("attitude", False)),
        "final_position_error_m": float(np.linalg.norm(last.x_s[:3] - truth.r_L[-1])),
        "final_attitude_error_deg": float(np.rad2deg(attitude_angle(mrp_to_quat(last.x_a[:3]), truth.q_IT[-1]))) if last.mode == "nominal" else None,
        "final_rate_error_rad_s": float(np.linalg.norm(last.x_a[3:6] - truth.w_T[-1])) if last.mode == "nominal" else None,
    })
    if p["record"]:
        write_recording(workdir / "run.rrd", run, recording_id=f"coverage-{spec.run_id}")
    return out


def summarise(runs: pd.DataFrame, config: StudyConfig, out_dir: Path) -> list[Table]:
    """Per rate level: converged fraction with its Wilson interval, divergences, symmetry switches (Fig. 20)."""
    conf = config["confidence"]
    pct = int(round(100 * conf))
    rows = []
    for w, sub in runs.groupby("rate_level_rad_s", sort=True):
        conv = sub["converged"].astype(bool)
        iv = proportion_interval(int(conv.sum()), len(sub), conf)
        rows.append({
            "tumbling rate (rad/s)": w, "rotation per measurement (deg)": float(sub["rotation_per_measurement_deg"].iloc[0]),
            "runs": len(sub), "converged runs": int(conv.sum()), "converged": iv.estimate, f"{pct}% lo": iv.lo, f"{pct}% hi": iv.hi,
            "converged, per-epoch rule": float(sub["converged_per_epoch"].astype(bool).mean()),
            "translation passed": float(sub["translation_ok"].astype(bool).mean()), "attitude passed": float(sub["attitude_ok"].astype(bool).mean()),
            "diverged": int(sub["diverged"].astype(bool).sum()), "false symmetry switches": int(sub["symmetry_detected"].astype(bool).sum()),
            "median run (s)": float(sub["elapsed_s"].median()),
        })
    summary = pd.DataFrame(rows)
    n, c = config["n_last"], config["converged_confidence"]
    rule = (f"the NEES of every active filter at each of the last {n} epochs is below the χ² quantile {1 - (1 - c) / n:.2%} (Bonferroni: a "
            f"consistent filter passes the {n} epochs together with probability ≥ {c:.0%})") if config["converged_rule"] == "joint" else (
            f"the NEES of every active filter at each of the last {n} epochs is below the {c:.0%} χ² quantile")
    physical = ", redrawn until A ≤ B + C and its permutations hold (a rigid body)" if config["k_physical"] else ""
    n_ic = config["n_initial_conditions"]
    per_level = f"{n_ic}" if config["n_initial_conditions_above"] in (0, n_ic) else (
        f"{n_ic} (levels ≤ {config['full_up_to_rad_s']:g} rad/s; {config['n_initial_conditions_above']} above)")
    notes = (
        f"{per_level} random initial conditions per level (k1, k2 ~ U{tuple(config['k_range'])}{physical}, uniform attitude, "
        f"uniform direction of ω), simulated pose measurements at {config['measurement_rate_hz']:g} Hz for {config['horizon_orbits']:g} "
        f"chaser orbit(s). Converged: {rule}. 'converged, per-epoch rule': each epoch at {c:.0%} instead. Wilson {pct}% intervals. "
        "Diverged: the attitude propagation or the UKF covariance broke down numerically (counted as not converged)."
    )
    plot_coverage(summary, pct, out_dir / "coverage.png")
    pcts = {k: ".0%" for k in ("converged", "converged, per-epoch rule", "translation passed", "attitude passed")}
    return [Table("summary", TITLE, summary, notes, formats=pcts, default_format=".3g")]


def plot_coverage(summary: pd.DataFrame, pct: int, path: Path) -> None:
    """Fig. 20: converged fraction per tumbling-rate level as bars with Wilson intervals."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 3.6), layout="constrained")
    x = np.arange(len(summary))
    frac = summary["converged"].to_numpy()
    err = np.vstack([frac - summary[f"{pct}% lo"].to_numpy(), summary[f"{pct}% hi"].to_numpy() - frac])
    ax.bar(x, 100 * frac, color="tab:blue", alpha=0.8, label="converged runs")
    ax.errorbar(x, 100 * frac, yerr=100 * err, fmt="none", ecolor="k", capsize=3, label=f"Wilson {pct}% interval")
    for xi, (n, k) in enumerate(zip(summary["runs"], summary["converged runs"])):
        ax.text(xi, 102, f"{k}/{n}", ha="center", fontsize=7, color="tab:red")
    ax.set(xticks=x, xticklabels=[f"{w:g}" for w in summary["tumbling rate (rad/s)"]], xlabel="tumbling rate |ω| (rad/s)", ylabel="converged (%)",
           ylim=(0, 112), title="CoMBiNa coverage against tumbling rate (Maestrini et al. Fig. 20 analogue)")
    ax.legend(fontsize=7, loc="lower left")
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format="png", dpi=110)
    plt.close(fig)
