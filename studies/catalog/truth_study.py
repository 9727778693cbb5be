"""Study ``truth``: the truth-model check.

Every filter study trusts two things: the truth simulator (two independent
DOP853 integrations of servicer and target, ``studies/sim/truth.py``) and the
filters' process model (the 15-state relative dynamics, eq. 21 of Renis et al.,
propagated by RK4 in ``estimators.dynamics.propagate_relative``). This study
checks them against each other and against conservation laws, over the
scenarios and many random initial conditions:

* per seed, the target's initial attitude is drawn uniformly
  (``random_quaternion``) and its initial LVLH position offset by a Gaussian
  jitter, so the check is not tied to one geometry;
* the relative state ``x0`` of the truth is propagated by RK4 of eq. 21 with
  step ``rk4_dt_s`` and compared with the truth at every sample: maximum
  position, attitude (principal angle) and rate errors; the model is accepted
  when the position error stays below ``rk4_tolerance_m`` (1 mm);
* the truth's own consistency: ``max | |q_TS| − 1 |`` and the relative drift of
  the target's rotational energy and angular-momentum norm (torque-free
  motion conserves both);
* the geometry the filters will see: range min / mean / max.

Each run writes ``run.rrd`` (truth, the RK4 model as ``/estimate/rk4/...`` and
its errors) with the viewer layout of :mod:`studies.recording.blueprint`.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pandas as pd

from estimators.attitude import attitude_angle, random_quaternion
from estimators.dynamics import angular_momentum_norm, propagate_relative, rotational_energy
from estimators.state import Q_TS, R_I, R_ST_T, W_B, W_ST_T
from studies.catalog.figures import pyplot, save_png
from studies.catalog.filter_common import TRUTH_FIELD
from studies.recording.blueprint import run_blueprint, send_estimate, send_truth
from studies.engine.config import ConfigError, Field, StudyConfig
from studies.recording.writer import recording
from studies.sim.scenarios import SCENARIOS, get_scenario
from studies.engine.stats import describe
from studies.engine.sweep import RunSpec, make_specs
from studies.engine.tables import Table
from studies.sim.truth import simulate_truth
from studies.recording.truth import log_truth

TITLE = "Truth-model check: truth simulator vs the RK4 relative model (eq. 21 of Renis et al.), conservation, geometry"

FIELDS: dict[str, Field] = {
    "scenarios": Field("list[str]", "Scenarios to check.", choices=tuple(SCENARIOS)),
    "n_seeds": Field("int", "Random initial conditions per scenario.", ge=1),
    "duration_s": Field("float", "Simulated time per run, s.", gt=0),
    "dt_s": Field("float", "Sampling step of the truth and of the comparison, s.", gt=0),
    "rk4_dt_s": Field("float", "RK4 step of the relative model, s; must divide dt_s.", gt=0),
    "rk4_tolerance_m": Field("float", "Accepted maximum RK4 position error over a run, m.", gt=0, default=1e-3),
    "random_attitude": Field("bool", "Draw the target's initial attitude uniformly per run.", default=True),
    "position_jitter_m": Field("float", "Std of the Gaussian offset of the initial LVLH position, m.", ge=0, default=5.0),
    "confidence": Field("float", "Confidence level of the intervals in the summary.", gt=0, le=0.999, default=0.95),
    "record": Field("bool", "Write run.rrd for every run.", default=True),
    "truth": TRUTH_FIELD,
}

#: The per-run parameters (everything but the summary-only fields).
_RUN_FIELDS = ("duration_s", "dt_s", "rk4_dt_s", "rk4_tolerance_m", "random_attitude", "position_jitter_m", "record", "truth")


def check(params: dict) -> None:
    """Cross-field rules: ``rk4_dt_s`` divides ``dt_s`` and ``dt_s <= duration_s``."""
    ratio = params["dt_s"] / params["rk4_dt_s"]
    if abs(ratio - round(ratio)) > 1e-9 or round(ratio) < 1:
        raise ConfigError(f"rk4_dt_s {params['rk4_dt_s']}: expected a divisor of dt_s = {params['dt_s']} s (whole steps)")
    if params["dt_s"] > params["duration_s"]:
        raise ConfigError(f"dt_s {params['dt_s']}: expected at most duration_s = {params['duration_s']} s")


def expand(config: StudyConfig) -> list[RunSpec]:
    """Scenarios × seeds; run ids ``<scenario>-s<index>``."""
    common = {k: config[k] for k in _RUN_FIELDS}
    return make_specs(
        config.seed,
        ((f"{sc}-s{i:03d}", {"scenario": sc, "seed_index": i, **common}) for sc in config["scenarios"] for i in range(config["n_seeds"])),
    )


def perturbed_scenario(name: str, rng: np.random.Generator, random_attitude: bool, position_jitter_m: float):
    """The scenario ``name`` with a random initial attitude and a jittered initial LVLH position."""
    sc = get_scenario(name)
    q_IT0 = tuple(random_quaternion(rng).tolist()) if random_attitude else sc.q_IT0
    r0 = np.asarray(sc.r_TS0_L_m) + position_jitter_m * rng.standard_normal(3)
    return dataclasses.replace(sc, q_IT0=q_IT0, r_TS0_L_m=tuple(r0.tolist()))


def execute(spec: RunSpec, workdir: Path) -> dict:
    """One run: truth, RK4 of eq. 21 from the truth's initial state, errors and conservation checks."""
    p = spec.params
    rng = np.random.default_rng(spec.seed)
    sc = perturbed_scenario(p["scenario"], rng, p["random_attitude"], p["position_jitter_m"])
    truth = simulate_truth(sc, p["duration_s"], p["dt_s"], p["truth"])
    stride = int(round(p["dt_s"] / p["rk4_dt_s"]))
    x_rk4, s_rk4 = propagate_relative(truth.x[0], truth.servicer[0], truth.J_S_diag, p["rk4_dt_s"], (len(truth.t) - 1) * stride, stride=stride)
    pos_err = np.linalg.norm(x_rk4[:, R_ST_T] - truth.x[:, R_ST_T], axis=1)
    att_err = attitude_angle(x_rk4[:, Q_TS], truth.x[:, Q_TS])
    rate_err = np.linalg.norm(x_rk4[:, W_ST_T] - truth.x[:, W_ST_T], axis=1)
    w_T = truth.target[:, W_B]
    energy = rotational_energy(w_T, truth.J_T_diag)
    momentum = angular_momentum_norm(w_T, truth.J_T_diag)
    rng_m = np.linalg.norm(truth.x[:, R_ST_T], axis=1)
    if p["record"]:
        with recording(workdir / "run.rrd", recording_id=f"truth-{spec.run_id}", blueprint=run_blueprint(
            quantities=["w_ST_T", "r_ST_T", "range_m"], filters=["rk4"]
        )) as rec:
            log_truth(rec, truth)
            send_truth(rec, "r_ST_T", truth.t, truth.x[:, R_ST_T])
            send_estimate(rec, "rk4", "w_ST_T", truth.t, x_rk4[:, W_ST_T], truth=truth.x[:, W_ST_T])
            send_estimate(rec, "rk4", "r_ST_T", truth.t, x_rk4[:, R_ST_T], truth=truth.x[:, R_ST_T])
    return {
        "n_samples": len(truth.t),
        "range_min_m": float(rng_m.min()),
        "range_mean_m": float(rng_m.mean()),
        "range_max_m": float(rng_m.max()),
        "quat_norm_err_max": float(np.abs(np.linalg.norm(truth.x[:, Q_TS], axis=1) - 1.0).max()),
        "energy_drift_rel": float(np.ptp(energy) / energy[0]),
        "momentum_drift_rel": float(np.ptp(momentum) / momentum[0]),
        "rk4_pos_err_max_m": float(pos_err.max()),
        "rk4_att_err_max_rad": float(att_err.max()),
        "rk4_rate_err_max_rad_s": float(rate_err.max()),
        "rk4_servicer_pos_err_max_m": float(np.linalg.norm(s_rk4[:, R_I] - truth.servicer[:, R_I], axis=1).max()),
        "rk4_within_tolerance": bool(pos_err.max() < p["rk4_tolerance_m"]),
    }


def summarise(runs: pd.DataFrame, config: StudyConfig, out_dir: Path) -> list[Table]:
    """Per scenario: runs, range, RK4 errors (mean with a t interval, median with a bootstrap interval, worst), drifts.

    Also draws ``rk4_error.png`` into ``out_dir``.
    """
    runs = runs.assign(rk4_pos_err_max_mm=runs["rk4_pos_err_max_m"] * 1e3, rk4_att_err_max_urad=runs["rk4_att_err_max_rad"] * 1e6)
    rng = np.random.default_rng(config.seed)
    d = describe(runs, ["scenario"], ["range_mean_m", "rk4_pos_err_max_mm"], confidence=config["confidence"],
                 median_of=["rk4_pos_err_max_mm"], rng=rng)
    worst = runs.groupby("scenario", sort=False).agg(
        rk4_pos_err_worst_mm=("rk4_pos_err_max_mm", "max"),
        rk4_att_err_worst_urad=("rk4_att_err_max_urad", "max"),
        energy_drift_worst=("energy_drift_rel", "max"),
        momentum_drift_worst=("momentum_drift_rel", "max"),
        quat_norm_err_worst=("quat_norm_err_max", "max"),
        runs_within_tolerance=("rk4_within_tolerance", "sum"),
    ).reset_index()
    table = d.merge(worst, on="scenario")
    pct = int(round(100 * config["confidence"]))
    cols = {
        "scenario": "scenario", "n_runs": "runs",
        "range_mean_m_mean": "mean range (m)", "range_mean_m_ci_lo": f"range {pct}% lo", "range_mean_m_ci_hi": f"range {pct}% hi",
        "rk4_pos_err_max_mm_mean": "RK4 pos err (mm) mean", "rk4_pos_err_max_mm_ci_lo": f"mean {pct}% lo", "rk4_pos_err_max_mm_ci_hi": f"mean {pct}% hi",
        "rk4_pos_err_max_mm_median": "median", "rk4_pos_err_max_mm_med_lo": f"median {pct}% lo", "rk4_pos_err_max_mm_med_hi": f"median {pct}% hi",
        "rk4_pos_err_worst_mm": "worst (mm)", "rk4_att_err_worst_urad": "RK4 att err worst (µrad)",
        "energy_drift_worst": "energy drift", "momentum_drift_worst": "|H| drift", "quat_norm_err_worst": "max ||q|-1|",
        "runs_within_tolerance": f"runs < {config['rk4_tolerance_m'] * 1e3:g} mm",
    }
    summary = table[list(cols)].rename(columns=cols)
    notes = (
        f"Per scenario, {config['n_seeds']} runs of {config['duration_s']:g} s with random initial attitude and "
        f"{config['position_jitter_m']:g} m position jitter. RK4 errors are each run's maximum over the run "
        f"(step {config['rk4_dt_s']:g} s) against two DOP853 integrations at 1e-12; mean with a Student-t interval, "
        "median with a BCa bootstrap interval. Drifts are (max − min)/initial of the target's rotational energy and |H|."
    )
    plot_rk4_errors(runs, config, out_dir / "rk4_error.png")
    return [Table("summary", TITLE, summary, notes, default_format=".3g")]


def plot_rk4_errors(runs: pd.DataFrame, config: StudyConfig, path: Path) -> None:
    """``rk4_error.png``: each run's maximum RK4 position error per scenario (log scale) and the tolerance."""
    plt = pyplot()

    scenarios = list(dict.fromkeys(runs["scenario"]))
    fig, ax = plt.subplots(figsize=(6.4, 3.6), layout="constrained")
    jitter = np.random.default_rng(0).uniform(-0.15, 0.15, len(runs))  # spread the dots only
    xs = np.array([scenarios.index(s) for s in runs["scenario"]]) + jitter
    ax.scatter(xs, runs["rk4_pos_err_max_m"] * 1e3, s=14, color="tab:blue", label="one run (max over the run)")
    ax.axhline(config["rk4_tolerance_m"] * 1e3, color="tab:red", ls="--", label=f"tolerance {config['rk4_tolerance_m'] * 1e3:g} mm")
    ax.set(xticks=range(len(scenarios)), xticklabels=scenarios, yscale="log", ylabel="RK4 position error (mm)",
           title=f"RK4 of eq. 21 (step {config['rk4_dt_s']:g} s) vs truth over {config['duration_s']:g} s")
    ax.legend(fontsize=8)
    save_png(fig, path, dpi=120)
