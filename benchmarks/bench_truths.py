"""Consistency of the default filters on both truths, over ten minutes and over an orbit (lcnav issue 31, deliverable 5).

``python -m benchmarks truths``. Per scenario (SC1, SC3) × truth (``torque-free``: the paper's world, what the torque-free
model describes; ``perturbed``: gravity gradient, J2, drag and nutation damping, :mod:`estimators.perturbations`) × filter
(EKF, UKF): :func:`studies.sim.navigation.consistency_check` of that world's default tuning
(:func:`estimators.tuning.default_tuning`: ``fixed-lag`` models the gravity-gradient torque and carries the process noise
matched to what its model leaves out; ``fixed-lag-torque-free`` has neither) — ``N`` runs at 1 s, initial errors drawn
from ``N(0, P_0)``, Gaussian pose noise with the filters' own ``R_d``, statistics from the settling time on; seeds
:data:`FIRST_SEED` + i in every row. On the perturbed truth run i starts at its own argument of latitude
(:func:`studies.sim.navigation.dispersed_truth`: the runs sample the disturbance, as the chi-square bands assume; one
truth flown by every run was a bias common to the runs, measured 2026-11-27: SC3 0.97 undispersed against 1.24 dispersed).

Sizes (environment): ``LCNAV_BENCH_TRUTHS_RUNS`` × ``LCNAV_BENCH_TRUTHS_DURATION_S`` for the first table (30 × 600 s),
``LCNAV_BENCH_TRUTHS_ORBIT_RUNS`` runs of one orbit (5700 s; default 30) per scenario on the perturbed truth with the EKF and
``LCNAV_BENCH_TRUTHS_ORBIT_RUNS_OTHER`` (default 10) on the torque-free truth with the EKF and on the perturbed one with the UKF; measurements every 5 and 10 s
(``INTERVAL_CASES``, 30 runs of 600 s, both filters, the perturbed truth). Wall time on 2 cores: several hours (2026-11-29).

Rows are kept as they finish in :data:`ROWS_FILE` (each with the commit and date it was measured at): a run resumes
from it and measures only the rows it lacks, a row that raises is reported as failed without losing the others, and a
stopped run keeps what finished. ``LCNAV_BENCH_TRUTHS_FRESH=1`` measures every row again; ``LCNAV_BENCH_TRUTHS_PARTS``
(comma-separated from ``orbit``, ``ten-minutes``, ``intervals``; default all) chooses the tables measured now — the
others are written from the rows kept.
"""

from __future__ import annotations

import datetime
import json
import os
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path

from benchmarks.bench_consistency import INTERVAL_HEADER, _interval_row
from benchmarks.provenance import commit
from estimators.tuning import default_tuning, get_tuning
from studies.sim.metrics import SETTLING_S
from studies.sim.navigation import consistency_check
from studies.sim.scenarios import get_scenario
from studies.engine.io import write_json
from studies.sim.truth import simulate_truth

RUNS = int(os.environ.get("LCNAV_BENCH_TRUTHS_RUNS", "30"))
DURATION_S = float(os.environ.get("LCNAV_BENCH_TRUTHS_DURATION_S", "600"))
ORBIT_RUNS = int(os.environ.get("LCNAV_BENCH_TRUTHS_ORBIT_RUNS", "30"))
ORBIT_RUNS_OTHER = int(os.environ.get("LCNAV_BENCH_TRUTHS_ORBIT_RUNS_OTHER", "10"))
ORBIT_S = 5700.0
SCENARIOS = ("SC1", "SC3")
PHYSICS = ("perturbed", "torque-free")
FILTERS = ("ekf", "ukf")
#: measurement intervals beyond 1 s (issue 31 deliverable 4: the UKF survives them; both filters reported)
INTERVAL_CASES = [(sc, dt) for sc in ("SC3", "SC4") for dt in (5.0, 10.0)]
GROUPS = ("q", "w", "r", "v", "k")
#: Seeds ``FIRST_SEED + i``: fresh ones — the noise budget's choices (eq. 4's horizon, no noise on k) were made looking at
#: runs of seeds 1000–1019 (2026-11-29), so the benchmark reports on others.
FIRST_SEED = 3000
#: the rows measured so far (module docstring), keyed by their case
ROWS_FILE = Path(__file__).with_name("truths_rows.json")
PARTS = ("orbit", "ten-minutes", "intervals")


def _row(case: tuple) -> dict:
    """``(scenario, physics, filter, duration s, runs, dt s)`` → the consistency statistics of that world's default tuning."""
    sc, physics, f, duration, runs, dt = case
    tr = simulate_truth(get_scenario(sc), duration, dt, physics)
    r = consistency_check(tr, f, get_tuning(default_tuning(physics)), n_runs=runs, first_seed=FIRST_SEED, disperse_orbit_phase=physics != "torque-free")
    return {**r, "truth": physics if physics == "torque-free" else f"{physics}, dispersed", "dt_s": dt}


def _detail(r: dict) -> str:
    blocks = " / ".join(f"{r[f'nees_per_dof_{g}']:.2f}" if f"nees_per_dof_{g}" in r else "–" for g in GROUPS)
    given = " / ".join(f"{r[f'nees_per_dof_{g}_given_rest']:.2f}" if f"nees_per_dof_{g}_given_rest" in r else "–" for g in GROUPS)
    return (f"| {r['scenario']} | {r['truth']} | {r['tuning']} | {r['filter'].upper()} | {int(r['runs'])} × {r['duration_s'] + 1:.0f} s | "
            f"{100 * r['nees_in_band']:.0f} ({100 * r['nees_below']:.0f} below, {100 * r['nees_above']:.0f} above) | "
            f"{r['nees_per_dof']:.3f} [{r['nees_per_dof_lo']:.3f}, {r['nees_per_dof_hi']:.3f}] | {r['nees_per_dof_worst_run']:.2f} | {blocks} | {given} | "
            f"{100 * r['nis_attitude_in_band']:.0f} / {100 * r['nis_position_in_band']:.0f} | "
            f"{100 * r['gate_attitude_rejected']:.2f} / {100 * r['gate_position_rejected']:.2f} | {r['commit']}, {r['date']} |")


def _key(case: tuple) -> str:
    """A row's key: its case without the number of runs (a kept row of fewer runs is shown until measured again)."""
    sc, physics, f, duration, _runs, dt = case
    return json.dumps([sc, physics, f, duration, dt, FIRST_SEED])


def _missing(case: tuple, kept: dict) -> bool:
    r = kept.get(_key(case))
    return r is None or "error" in r or int(r["runs"]) + int(r.get("diverged", 0)) < case[4]  # runs: those that did not diverge


def _measure(cases: list[tuple], kept: dict) -> None:
    """Measure ``cases`` on every core, adding each row to ``kept`` and to :data:`ROWS_FILE` as it finishes."""
    if not cases:  # every row kept: no worker processes to start
        return
    stamp = {"commit": commit(), "date": datetime.date.today().isoformat()}
    with ProcessPoolExecutor(max_workers=os.cpu_count()) as pool:
        futures = {pool.submit(_row, c): c for c in cases}  # the long orbit runs first: the workers finish together
        for fut in as_completed(futures):
            case = futures[fut]
            try:
                row = {k: v.item() if hasattr(v, "item") else v for k, v in fut.result().items()} | stamp  # numpy scalars → JSON
            except Exception as exc:  # noqa: BLE001 - reported in the table, the other rows kept
                row = {"error": f"{type(exc).__name__}: {exc}", **stamp}
            kept[_key(case)] = row
            write_json(ROWS_FILE, kept)
            print(f"[truths] {case}: {row.get('error', 'done')}", flush=True)


def _lines(cases: list[tuple], kept: dict, render) -> list[str]:
    out = []
    for c in cases:
        r = kept.get(_key(c))
        if r is None or "error" in r:
            what = "not measured" if r is None else f"failed ({r['commit']}, {r['date']}): {r['error']}"
            out.append(f"| {c[0]} | {c[1]} | {c[2].upper()} | {c[4]} × {c[3]:.0f} s at {c[5]:g} s | {what} |")
        else:
            out.append(render(r))
    return out


def run() -> str:
    t0 = time.perf_counter()
    orbit = [(sc, "perturbed", "ekf", ORBIT_S, ORBIT_RUNS, 1.0) for sc in SCENARIOS] if ORBIT_RUNS else []
    other = (("torque-free", "ekf"), ("perturbed", "ukf"))
    orbit += [(sc, p, f, ORBIT_S, ORBIT_RUNS_OTHER, 1.0) for sc in SCENARIOS for p, f in other] if ORBIT_RUNS_OTHER else []
    cases = [(sc, p, f, DURATION_S, RUNS, 1.0) for sc in SCENARIOS for p in PHYSICS for f in FILTERS]
    intervals = [(sc, "perturbed", f, DURATION_S, RUNS, dt) for sc, dt in INTERVAL_CASES for f in FILTERS]
    parts = [p.strip() for p in os.environ.get("LCNAV_BENCH_TRUTHS_PARTS", ",".join(PARTS)).split(",") if p.strip()]
    if unknown := sorted(set(parts) - set(PARTS)):
        raise SystemExit(f"LCNAV_BENCH_TRUTHS_PARTS: {unknown}: expected some of {list(PARTS)}")
    kept = {} if os.environ.get("LCNAV_BENCH_TRUTHS_FRESH") == "1" or not ROWS_FILE.exists() else json.loads(ROWS_FILE.read_text())
    chosen = [c for part, group in zip(PARTS, (orbit, cases, intervals)) if part in parts for c in group]
    _measure([c for c in chosen if _missing(c, kept)], kept)
    wall = time.perf_counter() - t0
    header = ("| scenario | truth | tuning | filter | runs | NEES in band (%) | NEES/dof [95 % CI] | worst run NEES/dof | "
              "per block NEES/dof q / w / r / v / k | given the other blocks q / w / r / v / k | NIS in band att / pos (%) | "
              "gate rejected att / pos (%) | measured |",
              "|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    lines = ["## Consistency of the default filters on both truths (issue 31)", "",
             f"Each world's default tuning: torque-free `{default_tuning('torque-free')}` ({get_tuning(default_tuning('torque-free')).description}); "
             f"perturbed `{default_tuning('perturbed')}` ({get_tuning(default_tuning('perturbed')).description}). Seeds {FIRST_SEED} + i, statistics from "
             f"{SETTLING_S:.0f} s; the perturbed truth dispersed (each run its own point of the orbit). NEES in band: steps whose run-mean "
             "NEES lies in its two-sided 95 % chi-square band; per block: each block's own NEES/dof (mean over runs and steps); given the "
             "other blocks: the block's NEES/dof given the other blocks' errors (studies.sim.metrics.conditional_nees: below 1, the "
             "filter states the blocks' errors as more independent than they are; '–': a row measured before it existed); gate: "
             "one-sided 99 % (nominal 1 %). Criterion of issue 31: ≥ 90 % of the steps in band over ≥ 1 orbit on the perturbed truth, SC1 "
             "and SC3, and still on the torque-free truth. Each row names the commit and date it was measured at "
             f"(`benchmarks/{ROWS_FILE.name}`).", "",
             "One orbit:", "", *header]
    lines += _lines(orbit, kept, _detail)
    lines += ["", f"{DURATION_S:.0f} s:", "", *header]
    lines += _lines(cases, kept, _detail)
    lines += ["", "Measurements every 5 and 10 s (the perturbed truth; the UKF must run through them):", "",
              INTERVAL_HEADER[0] + " measured |", INTERVAL_HEADER[1] + "---|"]
    lines += _lines(intervals, kept, lambda r: _interval_row(r, r["dt_s"]) + f" {r['commit']}, {r['date']} |")
    lines += ["", f"Wall time of the last writing {wall:.0f} s (tables measured then: {', '.join(parts) or 'none, written from the kept rows'})."]
    return "\n".join(lines)
