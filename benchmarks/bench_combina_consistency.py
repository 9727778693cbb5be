"""Consistency of CoMBiNa's filters on both truths: NEES, NIS and gate rates over Monte-Carlo runs (lcnav issue 31).

``python -m benchmarks combina_consistency``. Per target (the box-wing, ``asymmetric``; the rocket body, ``symmetric``) ×
truth (``torque-free``; ``perturbed``: gravity gradient, J2, drag, nutation damping, each run at its own orbit phase):
:func:`studies.sim.combina_consistency.combina_consistency` — ``RUNS`` runs of ``DURATION_TU`` (default one orbit, 2π TU)
of :func:`studies.sim.combina.run_combina` with simulated registrations, seeds 1000 + i (the process noise was developed on
seeds 500–509), statistics from 300 s after each filter starts. Not a speed benchmark. One process (the runs are
sequential; wall time on 2 shared cores ~25 min at the default size).

Sizes (environment): ``LCNAV_BENCH_COMBINA_RUNS`` (30) runs of ``LCNAV_BENCH_COMBINA_DURATION_TU`` (6.2832) TU.
"""

from __future__ import annotations

import os
import time

import numpy as np

from studies.sim.combina import COMBINA_BUDGETS
from studies.sim.combina_consistency import SETTLING_S, combina_consistency

RUNS = int(os.environ.get("LCNAV_BENCH_COMBINA_RUNS", "30"))
DURATION_TU = float(os.environ.get("LCNAV_BENCH_COMBINA_DURATION_TU", str(2.0 * np.pi)))
FIRST_SEED = 1000
CASES = [(target, truth) for target in ("asymmetric", "symmetric") for truth in ("perturbed", "torque-free")]


def _ci(s: dict, key: str) -> str:
    return f"{s[key]:.3f} [{s[key + '_lo']:.3f}, {s[key + '_hi']:.3f}]"


def _pct(s: dict, key: str) -> str:
    return f"{100 * s[key]:.2f} [{100 * s[key + '_lo']:.2f}, {100 * s[key + '_hi']:.2f}]"


def _filter_row(r: dict, name: str, s: dict) -> str:
    return (f"| {r['target']} | {r['truth']} | {name} | {s['dof']} | {s['runs']} | {100 * s['nees_in_band']:.0f} ({100 * s['nees_below']:.0f} below, "
            f"{100 * s['nees_above']:.0f} above) | {_ci(s, 'nees_per_dof')} | {s['nees_per_dof_worst_run']:.2f} |")


def _source_row(r: dict, name: str, s: dict) -> str:
    return (f"| {r['target']} | {r['truth']} | {name} | {s['dof']} | {s['nominal_measurements']} | {100 * s['nis_in_band']:.0f} | {_ci(s, 'nis_per_dof')} "
            f"| {_pct(s, 'gate_rejected')} | {_pct(s, 'nis_low')} | {s['misaligned_accepted']} / {s['misaligned_tested']} |")


def run() -> str:
    t0 = time.perf_counter()
    rows = [combina_consistency(target, truth, n_runs=RUNS, duration_tu=DURATION_TU, first_seed=FIRST_SEED) for target, truth in CASES]
    wall = time.perf_counter() - t0
    lines = [
        "## CoMBiNa filters' consistency on both truths (issue 31)",
        "",
        f"`studies.sim.combina_consistency.combina_consistency`: {RUNS} runs of {DURATION_TU:.3g} TU ({rows[0]['duration_s']:.0f} s) of "
        "`lcnav combina --pose-source simulated` per row, seeds "
        f"{FIRST_SEED}–{FIRST_SEED + RUNS - 1} (each its own initial estimate drawn from eq. 48's `P_0`, its own registration noise and "
        "outliers; on the perturbed truth its own orbit phase, `U(0, 2π)`); in orbit (the perturbed truth) the translational filter "
        "propagates about the chaser's own orbit with J2 (`studies.sim.combina.chaser_orbit`), in the torque-free world by eq. 9, "
        "and the attitude filter has the gravity-gradient torque about the chaser's radial direction in orbit (eq. 29 in the "
        "torque-free world) and restarts from batch refits of its initial state while it learns `k` "
        "(`estimators.combina.acquisition.LearningRefits`); process noise from `COMBINA_BUDGETS` in orbit, none in the torque-free world "
        f"(q_a = {COMBINA_BUDGETS['asymmetric'].q_a_m2_s3:.3g} m²/s³; "
        f"q_α = {COMBINA_BUDGETS['asymmetric'].q_alpha_rad2_s3:.3g} / "
        f"{COMBINA_BUDGETS['symmetric'].q_alpha_rad2_s3:.3g} rad²/s³, box-wing / rocket body); the rocket body's axisymmetric filter "
        "has the gravity gradient turning Γ in its model in orbit and estimates B/A (`estimators.combina.axisymmetric.AxisymmetricOrbitUKF`, "
        "the rocket body's q_α on Γ/A and on Γ's tilt), and eqs 35–40 without process noise in the torque-free world; developed on seeds 500–529. "
        f"Statistics from {SETTLING_S:.0f} s after each filter starts (the axisymmetric filter: its run's symmetry switch). "
        "NEES in band: epochs whose mean NEES over the runs with one lies in the two-sided 95 % band of that many χ²(dof); "
        "NEES/dof: per-run mean, 95 % t interval over runs, and the worst run's. NIS: of the nominal registrations only (the "
        "simulated outliers are the gates' job; their kind is read from the simulation for scoring). Gate: one-sided 99 % "
        "(nominal 1 % of the nominal registrations rejected), NIS below the lower 0.5 % quantile (nominal 0.5 %), Wilson 95 % "
        "intervals; misaligned outliers let through. The attitude filter is scored on the box-wing only (the rocket body's "
        "registrations carry a random roll until the axisymmetric filter replaces it). Criterion of issue 31: ≥ 90 % of the "
        "epochs in band, NIS in band ≥ 90 %, gate rejections within 2× nominal, on both truths.",
        "",
        "| target | truth | filter | dof | runs | NEES in band (%) | NEES/dof [95 % CI] | worst run NEES/dof |",
        "|---|---|---|---|---|---|---|---|",
    ]
    lines += [_filter_row(r, name, s) for r in rows for name, s in r["filters"].items()]
    lines += ["", "| target | truth | source | dof | nominal registrations | NIS in band (%) | NIS/dof [95 % CI] | gate rejected (%) "
              "| NIS low (%) | misaligned accepted |", "|---|---|---|---|---|---|---|---|---|---|"]
    lines += [_source_row(r, name, s) for r in rows for name, s in r["sources"].items()]
    lines += ["", "Torque-free rows: no filter has process noise there. Until 2026-12-02 the axisymmetric filter kept the orbit's budget "
              "(4.93e-11 rad²/s³) in the torque-free world too: NEES/dof 0.32 [0.31, 0.34], every epoch below the band, as eq. 4 of "
              "`estimators.process_noise` predicts for a `Q` matched to a disturbance the truth lacks (an expected NEES per state of 1/2 "
              "in steady state, the rate-like `Γ/A` carrying most of it). The box-wing's attitude filter is over-confident early in the "
              "torque-free runs while `k` is still uncertain (joint NEES/dof 1.7–1.9 between refits, 300–900 s). "
              "Perturbed rocket body: its gravity gradient (A/C = 4, a tumble at the orbit rate) turns Γ by 40–50° and changes |ω| by up to "
              "30 % within an orbit. Until 2026-12-02 the axisymmetric filter's model held Γ fixed (eqs 35–40, with the whole gravity "
              "gradient's 4.93e-11 rad²/s³ as process noise): NEES/dof 6.30 [3.27, 9.34], worst run 47, 15 % of the epochs in band (70 % "
              "above), axis NIS in band 67 %, gate 3.4 %. Its model in orbit now has the torque turning Γ and estimates B/A "
              "(`AxisymmetricOrbitUKF`)."]
    diverged = {f"{r['target']}/{r['truth']}": r["diverged"] for r in rows if r["diverged"]}
    lines += ["", f"Runs stopped by a diverged filter: {diverged or 'none'}. Wall time {wall:.0f} s."]
    return "\n".join(lines)
