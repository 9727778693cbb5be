"""Study ``timing``: per-iteration cost of the CoMBiNa filter (Maestrini et al. §VII, Fig. 19).

The paper times 1000 filter iterations sampled from simulated trajectories
(BCPD registration, update and prediction) on a Raspberry Pi 4 and reads off
the percentiles of the iteration time, hence the measurement rate 99% / 100%
of the iterations sustain (0.34 Hz / 0.30 Hz at 1.5 GHz, BCPD being ~99% of the
cost). Here ``n_seeds`` closed-loop runs of :func:`studies.sim.combina.run_combina`
(simulated BCPD-like source, each seed its own trajectory noise and initial
estimate) share ``n_iterations`` timed iterations; the first
``warmup_iterations`` of each run are run but not counted (caches, first
calls). Each iteration is split into

* *prediction + update*: both UKF predictions, the gates, the symmetry check
  and the corrections — the on-board filter cost;
* *registration*: the measurement source's ``measure`` — for the simulated
  source a draw around the true pose, not a BCPD registration (the rendered
  chain's BCPD is timed by ``benchmarks/bench_combina.py``).

The summary gives, per percentile, the pooled iteration time of each part with
a bootstrap interval, and the measurement rate it sustains; a second table the
spread over seeds of each seed's median and 99th percentile. ``timing.png``
draws Fig. 19's percentile lines for this machine. Wall times depend on the
machine and on what else runs on it (other sweep workers included).
"""

from __future__ import annotations

import platform
from pathlib import Path

import numpy as np
import pandas as pd

from studies.catalog.figures import pyplot, save_png
from studies.sim.combina import COMBINA_TARGETS, TU, CombinaConfig, run_combina
from studies.recording.combina import write_recording
from studies.engine.config import ConfigError, Field, StudyConfig
from studies.engine.io import write_table
from studies.engine.stats import bootstrap_interval, describe
from studies.engine.sweep import RunSpec, make_specs, run_dir
from studies.engine.tables import Table

TITLE = "CoMBiNa per-iteration time (Maestrini et al. §VII, Fig. 19) on this machine"
PARTS = {"filter_s": "prediction + update", "registration_s": "registration", "total_s": "iteration"}

FIELDS: dict[str, Field] = {
    "targets": Field("list[str]", "Targets whose runs are timed.", choices=COMBINA_TARGETS, default=["asymmetric"]),
    "n_iterations": Field("int", "Timed iterations in all (Maestrini et al. §VII: 1000), shared by the seeds.", ge=1),
    "n_seeds": Field("int", "Trajectories (runs) the iterations are sampled from, per target.", ge=1),
    "measurement_period_s": Field("float", "Time between two measurements, s.", gt=0, default=3.0),
    "percentiles": Field("list[float]", "Percentiles reported (0-100].", gt=0, le=100),
    "warmup_iterations": Field("int", "Untimed iterations at the start of each run.", ge=0, default=5),
    "confidence": Field("float", "Confidence level of the intervals.", gt=0, le=0.999, default=0.95),
    "record": Field("bool", "Write run.rrd for every run.", default=True),
}


def check(params: dict) -> None:
    """Percentiles increase strictly; each seed times at least one iteration."""
    p = params["percentiles"]
    if any(b <= a for a, b in zip(p, p[1:])):
        raise ConfigError(f"percentiles {p}: expected strictly increasing values")
    if params["n_iterations"] < params["n_seeds"]:
        raise ConfigError(f"n_iterations {params['n_iterations']}: expected at least n_seeds = {params['n_seeds']}")


def iterations_per_seed(n_iterations: int, n_seeds: int) -> list[int]:
    """``n_iterations`` split as evenly as possible over the seeds."""
    base, extra = divmod(n_iterations, n_seeds)
    return [base + (i < extra) for i in range(n_seeds)]


def expand(config: StudyConfig) -> list[RunSpec]:
    """Targets × seeds; run ids ``<target>-s<index>``, each with its share of the timed iterations."""
    shares = iterations_per_seed(config["n_iterations"], config["n_seeds"])
    return make_specs(config.seed, ((f"{tg}-s{i:03d}", {"target": tg, "seed_index": i, "timed_iterations": shares[i],
                                                         "warmup_iterations": config["warmup_iterations"],
                                                         "measurement_period_s": config["measurement_period_s"], "record": config["record"]})
                                    for tg in config["targets"] for i in range(config["n_seeds"])))


def execute(spec: RunSpec, workdir: Path) -> dict:
    """One timed run: ``timing.parquet`` (per iteration: registration, prediction + update, total) and ``run.rrd``."""
    p = spec.params
    n = p["timed_iterations"] + p["warmup_iterations"]
    period = p["measurement_period_s"]
    cfg = CombinaConfig(target=p["target"], duration_tu=(n + 0.5) * period / TU, rate_hz=1.0 / period, seed=spec.seed)
    run = run_combina(cfg)
    it = pd.DataFrame({"iteration": np.arange(1, run.iteration_s.size + 1), "t_s": period * np.arange(1, run.iteration_s.size + 1),
                       "registration_s": run.registration_s, "filter_s": run.iteration_s - run.registration_s, "total_s": run.iteration_s})
    it["warmup"] = it["iteration"] <= p["warmup_iterations"]
    write_table(workdir / "timing.parquet", it)
    if p["record"]:
        write_recording(workdir / "run.rrd", run, recording_id=f"timing-{spec.run_id}")
    timed = it[~it["warmup"]]
    return {"n_steps": len(run.steps), "n_timed": len(timed), "mode": run.steps[-1].mode, "machine": platform.machine(),
            **{f"{col}_p{q:g}_ms": 1e3 * float(np.percentile(timed[col], q)) for col in PARTS for q in (50, 99)}}


def pooled_iterations(runs: pd.DataFrame, out_dir: Path) -> pd.DataFrame:
    """Every timed (non-warm-up) iteration of every run, with its run id and target."""
    frames = []
    for rid, target in zip(runs["run_id"], runs["target"]):
        d = pd.read_parquet(run_dir(out_dir, rid) / "timing.parquet")
        frames.append(d[~d["warmup"]].assign(run_id=rid, target=target))
    return pd.concat(frames, ignore_index=True)


def summarise(runs: pd.DataFrame, config: StudyConfig, out_dir: Path) -> list[Table]:
    """Per target and percentile: time of each part (ms) with a bootstrap interval and the rate it sustains."""
    conf = config["confidence"]
    pct = int(round(100 * conf))
    rng = np.random.default_rng(config.seed)
    pooled = pooled_iterations(runs, out_dir)
    rows = []
    for target, sub in pooled.groupby("target", sort=False):
        for q in config["percentiles"]:
            row = {"target": target, "percentile": q, "iterations": len(sub)}
            for col, label in PARTS.items():
                ms = 1e3 * sub[col].to_numpy()
                if q < 100:
                    iv = bootstrap_interval(ms, lambda x, axis=-1, q=q: np.percentile(x, q, axis=axis), conf, rng=rng, method="percentile")
                    est, lo, hi = iv.estimate, iv.lo, iv.hi
                else:  # the maximum has no bootstrap interval
                    est, lo, hi = float(ms.max()), np.nan, np.nan
                row.update({f"{label} (ms)": est, f"{label} {pct}% lo": lo, f"{label} {pct}% hi": hi})
            row["sustained rate (Hz)"] = 1e3 / row["iteration (ms)"]
            rows.append(row)
    summary = pd.DataFrame(rows)
    per_seed = describe(runs, ["target"], [f"{c}_p{q}_ms" for c in PARTS for q in (50, 99)], confidence=conf)
    names = {"n_runs": "runs"}
    for col, label in PARTS.items():
        for q in (50, 99):
            m = f"{col}_p{q}_ms"
            names.update({f"{m}_mean": f"{label} p{q} mean (ms)", f"{m}_sd": f"{label} p{q} sd",
                          f"{m}_ci_lo": f"{label} p{q} {pct}% lo", f"{m}_ci_hi": f"{label} p{q} {pct}% hi"})
    per_seed = per_seed[["target", *names]].rename(columns=names)
    notes = (
        f"{len(pooled)} timed iterations ({config['warmup_iterations']} warm-up iterations per run not counted) from "
        f"{config['n_seeds']} runs per target, one simulated pose measurement every {config['measurement_period_s']:g} s; "
        f"machine {platform.machine()} ({platform.processor() or 'unknown CPU'}), Python {platform.python_version()}. "
        "prediction + update: both UKF predictions, gates, symmetry check and corrections; registration: the simulated "
        f"source's draw (no BCPD). Intervals: percentile bootstrap of the pooled percentile ({pct}%); the maximum has none. "
        "Sustained rate = 1 / iteration time at that percentile (Maestrini et al. §VII: 0.34 Hz at p99, 0.30 Hz at p100 on a Raspberry Pi 4 with BCPD)."
    )
    plot_timing(pooled, config["percentiles"], out_dir / "timing.png")
    return [Table("summary", TITLE, summary, notes, default_format=".3g"),
            Table("per_seed", "Spread over runs of each run's median and 99th percentile (ms)", per_seed,
                  f"Per run percentiles, then mean, sd and Student-t {pct}% interval over the runs.", default_format=".3g")]


def plot_timing(pooled: pd.DataFrame, percentiles, path: Path) -> None:
    """Fig. 19 on one machine: iteration time at each percentile per part (left), and the distributions (right)."""
    plt = pyplot()

    fig, (ax, ax2) = plt.subplots(1, 2, figsize=(10, 3.8), layout="constrained")
    qs = np.asarray(percentiles, dtype=float)
    for (target, sub), ls in zip(pooled.groupby("target", sort=False), ("-", "--")):
        for (col, label), color in zip(PARTS.items(), ("tab:blue", "tab:orange", "k")):
            ms = 1e3 * sub[col].to_numpy()
            ax.plot(qs, np.percentile(ms, qs), marker="o", ls=ls, color=color, label=f"{label} ({target})")
            ax2.hist(ms, bins=np.geomspace(max(ms.min(), 1e-4), ms.max() * 1.01, 40), histtype="step", color=color, ls=ls, label=f"{label} ({target})")
    ax.set(yscale="log", xlabel="percentile of iterations", ylabel="time per iteration (ms)", title="time at each percentile")
    ax2.set(xscale="log", xlabel="time per iteration (ms)", ylabel="iterations", title="distribution")
    ax.legend(fontsize=7)
    save_png(fig, path)
