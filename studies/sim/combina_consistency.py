"""Monte-Carlo consistency of CoMBiNa's filters: NEES, NIS and gate rates over runs (lcnav issue 31, deliverable 2).

Run ``i`` of :func:`combina_consistency` is :func:`studies.sim.combina.run_combina` with seed ``first_seed + i``: its own
initial estimates (drawn from eq. 48's ``P_0`` about the truth, Maestrini et al.), its own measurement noise and outliers
(:class:`perception.simulated_bcpd.SimulatedBCPD`) and, on a truth with unmodelled physics, its own orbit phase: the chaser's
argument of latitude at ``t = 0`` drawn ``U(0, 2π)`` from the run's own stream (:func:`orbit_phase`), so that
the runs sample the disturbance (gravity gradient, J2, drag) instead of all meeting one history, as the chi-square bands
assume (:func:`studies.sim.navigation.dispersed_truth` does the same for the 15-state filters).

Per filter — ``translation`` (6 dof: ``r, v``), ``attitude`` (8: ``δσ, ω, k``; asymmetric target only: on the symmetric one it
is fed measurements with a random roll until it is replaced), ``axisymmetric`` (3: ``φ, δ, Γ/A``; after the symmetry switch)
— the NEES ``eᵀ P⁻¹ e`` of each step (:func:`studies.sim.combina.filter_nees`); per measurement source (``translation``,
``attitude``, ``axis``) the NIS of the Mahalanobis gate (eq. 18, recorded in the gate decisions) of the *nominal*
registrations — the simulated outliers are the gate's job, not the filter's noise model, and their kind is read from the
simulation for scoring only. Steps count from ``settling_s`` after the filter started (a fixed settling time, the same for
every run: a per-run convergence time would select the steps that look good, :mod:`studies.sim.metrics`).

Statistics (Bar-Shalom, Li & Kirubarajan, *Estimation with Applications to Tracking and Navigation*, Wiley 2001, §5.4):
at each epoch the mean NEES (NIS) over the ``n`` runs that have one is tested against the two-sided band of the mean of ``n``
χ²(dof) values (:func:`studies.sim.metrics.chi_square_band`); ``n`` is the number of runs with a value at that epoch (the
axisymmetric filter starts at each run's own switch, outliers leave gaps in the NIS). Per run, the mean NEES/dof over its
steps, with a Student-t interval over runs; the worst run's. Gate: rate of nominal measurements above the one-sided
``gate_confidence`` bound (rejected; nominal ``1 − gate_confidence``) and below the lower two-sided bound (nominal
``(1 − gate_confidence)/2``, counted, never rejected), Wilson intervals; the misaligned outliers the gate let through.

Process noise (:func:`studies.sim.combina.process_noise`): in orbit each filter's ``Q`` covers what its model leaves out of
the perturbed truth (:data:`studies.sim.combina.COMBINA_BUDGETS`; the attitude filter models the gravity gradient there);
in the torque-free world the translational, attitude and axisymmetric models are the truth's motion and have none. In
orbit the rocket body's axisymmetric filter has the gravity gradient turning ``Γ`` in its model
(:class:`estimators.combina.axisymmetric.AxisymmetricOrbitUKF`) and the rocket body's residual budget. Until 2026-12-02
its model held ``Γ`` fixed with the whole gravity gradient's budget as process noise in both worlds: over-confident in
orbit (NEES/dof 6.3) and, on the torque-free truth, conservative by the fixed amount eq. 4 of :mod:`estimators.process_noise`
predicts (an expected NEES per state of 1/2 in steady state, for any ``q/r``): 0.32 over the benchmark's 30 runs.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.stats import chi2

from studies.engine.stats import proportion_interval, t_interval
from studies.sim.combina import CombinaConfig, CombinaRun, filter_nees, run_combina, simulate_lvlh_truth, target_k

#: Degrees of freedom of each filter's error state and of each source's innovation.
FILTER_DOF = {"translation": 6, "attitude": 8, "axisymmetric": 3}
SOURCE_DOF = {"translation": 3, "attitude": 3, "axis": 2}
#: Filters and sources scored per target: the symmetric target's registrations carry a random roll (§V.B), so its attitude
#: filter's errors and innovations are not what its model says until the axisymmetric filter replaces it.
SCORED = {"asymmetric": (("translation", "attitude"), ("translation", "attitude")),
          "symmetric": (("translation", "axisymmetric"), ("translation", "axis"))}
#: Fixed settling time after a filter starts, s (0.3 TU: 95 measurements at 0.33 Hz).
SETTLING_S = 300.0


@dataclass(frozen=True)
class RunSeries:
    """One run on its epoch grid ``t`` (N,): per filter its NEES (NaN where it is not running or still settling), per source the
    NIS of nominal registrations (NaN elsewhere), and per source the Mahalanobis decisions on misaligned outliers (accepted, tested)."""

    t: np.ndarray
    nees: dict[str, np.ndarray]
    nis: dict[str, np.ndarray]
    outliers: dict[str, tuple[int, int]]


def run_series(run: CombinaRun, settling_s: float = SETTLING_S) -> RunSeries:
    """The per-epoch NEES and NIS of ``run`` (see :class:`RunSeries`), each filter's first ``settling_s`` seconds left out."""
    t = run.truth.t
    nees = {}
    for name, (tf, e, _) in filter_nees(run).items():
        x = np.full(t.size, np.nan)
        idx = np.searchsorted(t, tf)
        keep = tf >= tf[0] + settling_s
        x[idx[keep]] = e[keep]
        nees[name] = x
    kind = {m.t: m.kind for m in run.measurements}
    nis = {s: np.full(t.size, np.nan) for s in SOURCE_DOF}
    outliers = {s: [0, 0] for s in SOURCE_DOF}
    start = {}
    for g in run.gates:
        if g.source not in SOURCE_DOF or not np.isfinite(g.e2):
            continue  # the scale gate's decisions (no e², eq. 18 is not reached)
        start.setdefault(g.source, g.t)
        if g.t < start[g.source] + settling_s:
            continue
        if kind[g.t] == "nominal":
            nis[g.source][np.searchsorted(t, g.t)] = g.e2
        elif kind[g.t] == "misaligned":
            outliers[g.source][0] += int(g.accepted)
            outliers[g.source][1] += 1
    return RunSeries(t=t, nees=nees, nis=nis, outliers={s: (a, n) for s, (a, n) in outliers.items()})


def band_fractions(values: np.ndarray, dof: int, confidence: float = 0.95) -> dict[str, float]:
    """``in``/``below``/``above``: fractions of the epochs whose mean over the runs with a value lies in / below / above the
    two-sided ``confidence`` band of the mean of that many χ²(dof) values. ``values`` (runs, epochs), NaN = no value."""
    v = np.asarray(values, dtype=float)
    n = np.sum(np.isfinite(v), axis=0)
    has = n > 0
    if not has.any():
        return {"in": float("nan"), "below": float("nan"), "above": float("nan"), "epochs": 0}
    mean = np.nansum(v[:, has], axis=0) / n[has]
    lo = chi2.ppf(0.5 * (1.0 - confidence), dof * n[has]) / n[has]
    hi = chi2.ppf(0.5 * (1.0 + confidence), dof * n[has]) / n[has]
    return {"in": float(np.mean((mean >= lo) & (mean <= hi))), "below": float(np.mean(mean < lo)), "above": float(np.mean(mean > hi)),
            "epochs": int(has.sum())}


def _filter_stats(nees: np.ndarray, dof: int, confidence: float) -> dict:
    """NEES statistics of one filter over runs (rows of ``nees``, NaN where absent); ``runs`` 0 and NaN when it never ran."""
    ran = np.any(np.isfinite(nees), axis=1)
    if not ran.any():
        return {"dof": dof, "runs": 0, **dict.fromkeys(("nees_in_band", "nees_below", "nees_above", "nees_per_dof", "nees_per_dof_lo",
                                                       "nees_per_dof_hi", "nees_per_dof_worst_run"), float("nan"))}
    per_run = np.nanmean(nees[ran], axis=1) / dof
    iv = t_interval(per_run, confidence)
    b = band_fractions(nees[ran], dof, confidence)
    n = np.sum(np.isfinite(nees[ran]), axis=0)
    epoch_mean = np.where(n > 0, np.nansum(nees[ran], axis=0) / np.maximum(n, 1), np.nan) / dof
    return {"dof": dof, "runs": int(ran.sum()), "nees_in_band": b["in"], "nees_below": b["below"], "nees_above": b["above"], "epochs": b["epochs"],
            "nees_per_dof": iv.estimate, "nees_per_dof_lo": iv.lo, "nees_per_dof_hi": iv.hi, "nees_per_dof_worst_run": float(np.max(per_run)),
            "per_run_nees_per_dof": per_run, "epoch_mean_nees_per_dof": epoch_mean}


def _rate(k: int, n: int, confidence: float, key: str) -> dict:
    """``{key, key_lo, key_hi}``: ``k/n`` with its Wilson interval (NaN when ``n`` is 0)."""
    if n == 0:
        return dict.fromkeys((key, f"{key}_lo", f"{key}_hi"), float("nan"))
    p = proportion_interval(k, n, confidence)
    return {key: p.estimate, f"{key}_lo": p.lo, f"{key}_hi": p.hi}


def _source_stats(nis: np.ndarray, outliers: list[tuple[int, int]], dof: int, confidence: float, gate_confidence: float) -> dict:
    """NIS and gate statistics of one source over runs (rows of ``nis``, NaN where no nominal registration was gated)."""
    v = nis[np.isfinite(nis)]
    has = np.any(np.isfinite(nis), axis=1)
    iv = t_interval(np.nanmean(nis[has], axis=1) / dof, confidence) if has.any() else None
    nan = float("nan")
    upper, lower = chi2.ppf(gate_confidence, dof), chi2.ppf(0.5 * (1.0 - gate_confidence), dof)
    return {"dof": dof, "nominal_measurements": int(v.size), "nis_in_band": band_fractions(nis, dof, confidence)["in"],
            "nis_per_dof": iv.estimate if iv else nan, "nis_per_dof_lo": iv.lo if iv else nan, "nis_per_dof_hi": iv.hi if iv else nan,
            **_rate(int(np.sum(v > upper)), int(v.size), confidence, "gate_rejected"), **_rate(int(np.sum(v < lower)), int(v.size), confidence, "nis_low"),
            "misaligned_accepted": sum(a for a, _ in outliers), "misaligned_tested": sum(n for _, n in outliers)}


def orbit_phase(seed: int) -> float:
    """The chaser's argument of latitude at ``t = 0`` (rad) of run ``seed``: ``U(0, 2π)`` from the run's own stream
    ``default_rng((seed, 1))``, apart from the streams of :func:`studies.sim.combina.run_combina` (``SeedSequence(seed)``)."""
    return float(np.random.default_rng((seed, 1)).uniform(0.0, 2.0 * np.pi))


def monte_carlo_run(target: str, truth: str, seed: int, duration_tu: float, *, truth_lvlh=None) -> CombinaRun:
    """Run ``seed`` of the Monte Carlo: :func:`studies.sim.combina.run_combina` on ``truth_lvlh`` if given, else on the truth
    flown from the run's own orbit phase (:func:`orbit_phase`)."""
    cfg = CombinaConfig(target=target, truth=truth, duration_tu=duration_tu, seed=seed)
    if truth_lvlh is None:
        t = cfg.epochs_s()
        truth_lvlh = simulate_lvlh_truth(target, t[-1], float(t[1] - t[0]), k=target_k(target), physics=truth, arg_latitude_rad=orbit_phase(seed))
    return run_combina(cfg, truth=truth_lvlh)


def combina_consistency(target: str, truth: str, *, n_runs: int = 30, duration_tu: float = 2.0, first_seed: int = 1000,
                        disperse_orbit_phase: bool | None = None, settling_s: float = SETTLING_S, confidence: float = 0.95,
                        gate_confidence: float = 0.99, progress=None) -> dict:
    """NEES, NIS and gate statistics of CoMBiNa's filters over ``n_runs`` runs (module docstring).

    ``truth``: ``torque-free`` or ``perturbed``; ``disperse_orbit_phase`` (default: on for the perturbed truth, where it matters)
    gives every run its own orbit phase. A run that stops on a diverged filter (``ValueError`` from the propagation) is counted
    in ``diverged`` and left out. ``progress(i)`` is called after each run. Returns ``{"target", "truth", "runs", "diverged",
    "duration_s", "settling_s", "orbit_phase", "seeds", "filters": {name: stats}, "sources": {name: stats}}``.
    """
    if disperse_orbit_phase is None:
        disperse_orbit_phase = truth != "torque-free"
    base = CombinaConfig(target=target, truth=truth, duration_tu=duration_tu)
    base.validate()
    t = base.epochs_s()
    shared = None if disperse_orbit_phase else simulate_lvlh_truth(target, t[-1], float(t[1] - t[0]), k=target_k(target), physics=truth)
    series, diverged = [], 0
    for i in range(n_runs):
        try:
            series.append(run_series(monte_carlo_run(target, truth, first_seed + i, duration_tu, truth_lvlh=shared), settling_s))
        except ValueError:
            diverged += 1
        if progress is not None:
            progress(i)
    filters, sources = SCORED[target]
    return {"target": target, "truth": truth, "runs": len(series), "diverged": diverged, "duration_s": float(t[-1]), "settling_s": settling_s,
            "orbit_phase": "dispersed" if disperse_orbit_phase else "fixed", "seeds": (first_seed, first_seed + n_runs - 1),
            "filters": {f: _filter_stats(np.array([s.nees.get(f, np.full(t.size, np.nan)) for s in series]), FILTER_DOF[f], confidence) for f in filters},
            "sources": {s: _source_stats(np.array([r.nis[s] for r in series]), [r.outliers[s] for r in series], SOURCE_DOF[s], confidence, gate_confidence)
                        for s in sources}}
