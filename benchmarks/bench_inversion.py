"""Calibration of the spin-state inversion on simulated objects (lcnav issue 28, deliverable 2): the run and its report.

``python -m benchmarks inversion``. The objects — drawn, simulated, inverted and scored — are
:mod:`benchmarks.inversion_objects`'s (its docstring says how); this module runs them (:func:`run`), keeps their rows and
writes the Markdown section (coverage, accuracy, per-target, timing and brute-force tables).

Sizes (:data:`SIZES`, chosen by ``$LCNAV_BENCH_INVERSION_SIZE``): "full" is the issue's benchmark
(200 facet objects of 600 samples per night); "reduced" the same draws at 150 samples per night;
"smoke" a few objects. ``$LCNAV_BENCH_INVERSION_BUDGET_S`` stops starting objects after that many
seconds (the kinds are interleaved, so every kind is measured); the section says how many were left out.

Rows are kept in :data:`ROWS_FILE` as each object finishes (keyed by size and schedule index, stamped with the commit,
the code — Git's object ids of :data:`CODE_PATHS`, the library and :mod:`benchmarks.inversion_objects` — and the date). A run resumes: it measures
only the scheduled objects that have no row measured by the same code, so the full schedule (~4.5 h on 2 cores) can be
measured over several runs with a budget each; a change to ``lightcurves/`` or to :mod:`benchmarks.inversion_objects` (the draws, the scoring; not this
module's report)
starts it again. Code with uncommitted changes reuses nothing. ``LCNAV_BENCH_INVERSION_FRESH=1`` drops every kept row.
"""

from __future__ import annotations

import datetime
import json
import os
import time
from pathlib import Path

import numpy as np
from scipy import stats

from benchmarks.inversion_objects import (
    ALT_POLE_DEG,
    BRUTE_POLE_STEP_DEG,
    DCHI2_MISS,
    LEVELS,
    MAX_NIGHTS,
    MITSUBA_NIGHTS,
    PERIOD_HALF_WIDTH,
    PERIOD_JITTER,
    REPORT_SEED,
    SIZES,
    TIMING_SAMPLES,
    TIMING_TARGETS,
    Size,
    measure,
)
from benchmarks.provenance import code, commit
from studies.engine.io import write_json
from studies.engine.stats import proportion_interval

SIZE_ENV = "LCNAV_BENCH_INVERSION_SIZE"  #: name of a key of SIZES (default "full")
BUDGET_ENV = "LCNAV_BENCH_INVERSION_BUDGET_S"  #: wall-clock budget, s: no object is started after it (default: none)
FRESH_ENV = "LCNAV_BENCH_INVERSION_FRESH"  #: "1": measure every object again (the kept rows are dropped)
ROWS_FILE = Path(__file__).with_name("inversion_rows.json")  #: every measured row, keyed "size:schedule index", stamped (module docstring)
#: the code a kept row must have been measured by to be reused: the library and the objects' module, not this report
CODE_PATHS = ("lightcurves", "benchmarks/inversion_objects.py")
SPAN_BINS_DEG = (0.0, 10.0, 20.0, 180.0)  #: phase-angle span classes of the accuracy table

def _ok(rows) -> list[dict]:
    return [r for r in rows if "error" not in r]


def _coverage_cell(hits: np.ndarray, level: float) -> str:
    """``k/n = x % [lo, hi]`` with the Wilson 95 % interval, and whether the nominal ``level`` lies in it."""
    k, n = int(np.sum(hits)), int(hits.size)
    if n == 0:
        return "—"
    ci = proportion_interval(k, n)
    verdict = "pass" if ci.lo <= level <= ci.hi else ("**over-confident**" if ci.hi < level else "**under-confident**")
    return f"{k}/{n} = {100 * ci.estimate:.1f} % [{100 * ci.lo:.1f}, {100 * ci.hi:.1f}] {verdict}"


def coverage_table(rows: list[dict]) -> str:
    """Coverage of the 68 / 95 % regions: best mode (pole 2-D, pole + period 3-D), the mixture of all listed modes, the
    pole's profile likelihood at the truth (:func:`~lightcurves.inversion.profile.pole_profile_chi2`) and the region the CLI
    maps (:func:`~lightcurves.inversion.profile.pole_profile_region`, its level at the truth's cell)."""
    lines = ["| region | 68 % | 95 % |", "|---|---|---|"]
    kinds = (("best mode, pole (2-D)", "in{}_pole", None), ("best mode, pole + period (3-D)", "in{}_3d", None),
             ("mixture of modes, pole (2-D)", None, "mix_level_pole"), ("mixture of modes, pole + period (3-D)", None, "mix_level_3d"),
             ("profile likelihood, pole (2-D)", None, "profile_level_pole"),
             ("profile likelihood, mapped region (`--pole-region`)", None, "region_level_pole"))
    for label, key, mix in kinds:
        cells = []
        for level in LEVELS:
            if key is not None:
                hits = np.array([r[key.format(int(round(100 * level)))] for r in rows], dtype=bool)
            else:
                hits = np.array([r[mix] <= level for r in rows], dtype=bool)
            cells.append(_coverage_cell(hits, level))
        lines.append(f"| {label} | {cells[0]} | {cells[1]} |")
    return "\n".join(lines)


def modality_table(rows: list[dict]) -> str:
    """95 % coverage of each region split by what the search reported: one pole (one mode, or cycle-count aliases within
    :data:`~benchmarks.inversion_objects.ALT_POLE_DEG` of it) or several poles (a listed mode at least that far from the
    best: mirror poles, the reversed sense, another body axis). Where the calibration fails, by which kind of result."""
    lines = ["| result | n | best mode, pole | mixture of modes, pole | profile likelihood, pole | mapped region |", "|---|---|---|---|---|---|"]
    for label, alt in (("one pole", False), (f"several poles (≥ {ALT_POLE_DEG:g}° apart)", True)):
        sel = [r for r in rows if bool(r["alt_pole_listed"]) == alt]
        cells = [_coverage_cell(np.array([r["in95_pole"] for r in sel], dtype=bool), 0.95)]
        cells += [_coverage_cell(np.array([r[key] <= 0.95 for r in sel], dtype=bool), 0.95)
                  for key in ("mix_level_pole", "profile_level_pole", "region_level_pole")]
        lines.append(f"| {label} | {len(sel)} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def basin_table(rows: list[dict]) -> str:
    """68 / 95 % coverage split by where the search ended against the truth (conditioned on the outcome, so not a calibration
    figure itself: it says where a failing one loses its coverage). *Best mode is the truth's*: the best pole within
    :data:`~benchmarks.inversion_objects.ALT_POLE_DEG` of the truth, where only the mode's own covariance can hold it; *the
    truth's mode listed, not best*: the mixture's mode probabilities decide; *not listed*: no listed pole that near the truth,
    which no region of the listed modes can cover (the search's mode list, not the posterior's shape, failed)."""
    lines = ["| where the search ended | n | best mode, pole 68 % | best mode, pole 95 % | mixture of modes, pole 68 % | mixture of modes, pole 95 % |",
             "|---|---|---|---|---|---|"]
    cases = (("best mode is the truth's", lambda r: r["pole_err_deg"] < ALT_POLE_DEG),
             ("the truth's mode listed, not best", lambda r: r["pole_err_deg"] >= ALT_POLE_DEG > r["closest_pole_err_deg"]),
             ("the truth's mode not listed", lambda r: r["closest_pole_err_deg"] >= ALT_POLE_DEG))
    for label, where in cases:
        sel = [r for r in rows if where(r)]
        cells = [_coverage_cell(np.array([r[f"in{int(round(100 * lv))}_pole"] for r in sel], dtype=bool), lv) for lv in LEVELS]
        cells += [_coverage_cell(np.array([r["mix_level_pole"] <= lv for r in sel], dtype=bool), lv) for lv in LEVELS]
        lines.append(f"| {label} | {len(sel)} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def _span_label(lo: float, hi: float) -> str:
    return f"< {hi:.0f}°" if lo == 0 else (f"≥ {lo:.0f}°" if hi >= 180 else f"{lo:.0f}–{hi:.0f}°")


def accuracy_table(rows: list[dict]) -> str:
    """Pole error (best mode) median / 90th percentile by number of nights × phase-angle span, with sense and period right."""
    lines = ["| nights | phase-angle span | n | pole error median / p90 (°) | closest mode median (°) | sense right | "
             "\\|ΔP/P\\| median | in 95 % (pole) |", "|---|---|---|---|---|---|---|---|"]
    for k in range(1, MAX_NIGHTS + 1):
        for lo, hi in zip(SPAN_BINS_DEG[:-1], SPAN_BINS_DEG[1:]):
            sel = [r for r in rows if r["nights"] == k and lo <= r["span_deg"] < hi]
            if not sel:
                continue
            e = np.array([r["pole_err_deg"] for r in sel])
            lines.append(f"| {k} | {_span_label(lo, hi)} | {len(sel)} | {np.median(e):.1f} / {np.percentile(e, 90):.1f} | "
                         f"{np.median([r['closest_pole_err_deg'] for r in sel]):.1f} | {sum(r['sense_right'] for r in sel)}/{len(sel)} | "
                         f"{np.median([abs(r['period_rel_err']) for r in sel]):.1e} | {sum(r['in95_pole'] for r in sel)}/{len(sel)} |")
    return "\n".join(lines)


def requirement_line(rows: list[dict]) -> str:
    """The issue's accuracy requirement: pole error median ≤ 5° with ≥ 3 nights spanning ≥ 20° of phase angle."""
    sel = [r["pole_err_deg"] for r in rows if r["nights"] >= 3 and r["span_deg"] >= 20.0]
    if not sel:
        return "No object with ≥ 3 nights spanning ≥ 20° of phase angle."
    med = float(np.median(sel))
    lo, hi = _median_ci(np.array(sel))
    return (f"≥ 3 nights spanning ≥ 20° of phase angle: n = {len(sel)}, pole error median {med:.2f}° (95 % CI {lo:.2f}–{hi:.2f}°), "
            f"requirement ≤ 5°: **{'met' if med <= 5.0 else 'not met'}**.")


def _median_ci(x: np.ndarray, confidence: float = 0.95) -> tuple[float, float]:
    """Distribution-free confidence interval of the median from order statistics (binomial(n, ½) quantiles)."""
    x = np.sort(x)
    n = x.size
    lo = int(stats.binom.ppf((1 - confidence) / 2, n, 0.5))
    hi = int(stats.binom.isf((1 - confidence) / 2, n, 0.5))
    return float(x[max(lo - 1, 0)]), float(x[min(hi, n - 1)])


def target_table(rows: list[dict]) -> str:
    """Per target: accuracy, modes, fit quality and the search check (χ² at the truth minus the best mode's)."""
    lines = ["| target | n | pole error median (°) | sense right | body axis right (± 10°) / same moment | modes (mean) | alternative pole listed | "
             "χ²/dof median | Δχ²(truth − best) < −" f"{DCHI2_MISS:g} (search missed) |", "|---|---|---|---|---|---|---|---|---|"]
    for name, kind in dict.fromkeys((r["target"], r["axis_kind"]) for r in rows):
        sel = [r for r in rows if r["target"] == name and r["axis_kind"] == kind]
        n = len(sel)
        lines.append(f"| {name} ({kind} axis) | {n} | {np.median([r['pole_err_deg'] for r in sel]):.1f} | {sum(r['sense_right'] for r in sel)}/{n} | "
                     f"{sum(r['axis_right'] for r in sel)}/{n} / {sum(r['axis_moment_right'] for r in sel)}/{n} | "
                     f"{np.mean([r['n_modes'] for r in sel]):.1f} | {sum(r['alt_pole_listed'] for r in sel)}/{n} | "
                     f"{np.median([r['chi2_dof'] for r in sel]):.2f} | {sum(r['dchi2_truth'] < -DCHI2_MISS for r in sel)}/{n} |")
    return "\n".join(lines)


def time_line(rows: list[dict]) -> str:
    """Inversion time per object for 3 nights (3 × the size's samples per night): wall and CPU (all threads), median and max,
    with the 1-min load average at each object's start."""
    sel = [r for r in rows if r["nights"] == 3]
    if not sel:
        return "No 3-night object measured."
    t, cpu, load = (np.array([r.get(k, np.nan) for r in sel]) for k in ("time_s", "cpu_s", "load"))
    samples = np.median([r["samples"] for r in sel])
    return (f"Time per object, 3 nights (median {samples:.0f} samples), {t.size} objects: wall median {np.median(t):.1f} s, max {t.max():.1f} s; "
            f"CPU median {np.median(cpu):.1f} s, max {cpu.max():.1f} s; load average {np.min(load):.1f}–{np.max(load):.1f} "
            f"(2 cores shared; requirement ≤ 10 s wall: **{'met' if np.median(t) <= 10 else 'not met'}** at the median).")


def timing_table(rows: list[dict]) -> str:
    """The issue's timing case: one row per 3-night × ``TIMING_SAMPLES``-sample facet object (:data:`TIMING_TARGETS`), then
    :func:`time_line` over them."""
    lines = ["| target | samples | wall (s) | CPU (s) | load | pole error (°) | \\|ΔP/P\\| | Δχ²(truth − best) |", "|---|---|---|---|---|---|---|---|"]
    for r in rows:
        if "error" in r:
            lines.append(f"| {r['target']} | error: {r['error']} |" + " |" * 6)
            continue
        lines.append(f"| {r['target']} | {r['samples']} | {r['time_s']:.1f} | {r['cpu_s']:.1f} | {r['load']:.1f} | {r['pole_err_deg']:.2f} | "
                     f"{abs(r['period_rel_err']):.1e} | {r['dchi2_truth']:.1f} |")
    return "\n".join(lines + ["", time_line(_ok(rows))])


def brute_table(rows: list[dict]) -> str:
    """Brute-force grid against :func:`invert` on the same data and likelihood."""
    lines = ["| target | samples | grid states | χ² invert | χ² grid | χ² truth | grid − invert | grid pole to best mode (°) | to nearest mode (°) | "
             "time invert (s) | time grid (s) | grid / invert |", "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        if "error" in r:
            lines.append(f"| {r['target']} | error: {r['error']} |" + " |" * 10)
            continue
        lines.append(f"| {r['target']} | {r['samples']} | {r['n_states']:.2e} | {r['chi2_invert']:.1f} | {r['chi2_grid']:.1f} | {r['chi2_truth']:.1f} | "
                     f"{r['chi2_grid'] - r['chi2_invert']:+.1f} | {r['grid_to_best_deg']:.1f} | {r['grid_to_mode_deg']:.1f} | {r['t_invert_s']:.1f} | "
                     f"{r['t_grid_s']:.1f} | {r['t_grid_s'] / r['t_invert_s']:.0f}× |")
    ok = _ok(rows)
    if ok:
        beaten = sum(r["chi2_grid"] < r["chi2_invert"] - DCHI2_MISS for r in ok)
        near = sum(r["grid_to_mode_deg"] <= BRUTE_POLE_STEP_DEG for r in ok)
        lines += ["", f"The grid found a lower χ² than `invert` (by more than {DCHI2_MISS:g}) on {beaten} of {len(ok)} objects; its optimum lies within "
                  f"the grid spacing ({BRUTE_POLE_STEP_DEG:g}°) of a listed mode on {near} of {len(ok)}."]
    return "\n".join(lines)


def _errors(rows: dict) -> str:
    bad = [(kind, r) for kind, rs in rows.items() for r in rs if "error" in r]
    if not bad:
        return "No object failed."
    return "Failures (counted as such, not dropped silently):\n\n" + "\n".join(f"* {kind} {r['target']}: {r['error']}" for kind, r in bad)


def report(rows: dict, size: Size, header: str) -> str:
    """The Markdown section from :func:`measure`'s rows."""
    facet = [r for r in _ok(rows["facet"]) if r["target"] != "sphere"]
    sphere = [r for r in _ok(rows["facet"]) if r["target"] == "sphere"]
    mitsuba = [r for r in _ok(rows["mitsuba"]) if r["target"] != "sphere"]
    parts = ["## Inversion: calibration of the spin-state posterior on simulated objects", "", header, ""]
    parts += ["### Facet-rendered objects (inverse crime: the model that fits made the data)", "",
              f"{len(facet)} objects (atlas-centaur, vespa, box-wing), 1–{MAX_NIGHTS} nights of ~{size.samples_per_night} samples; the true sidereal period "
              f"was inside the range given on {sum(r['truth_in_range'] for r in facet)} of {len(facet)}.", "",
              coverage_table(facet), "", "By what the search reported (95 % regions; a NaN profile level, the search's optimum "
              "beaten at the truth's pole, counts as outside):", "", modality_table(facet), "",
              "By where the search ended against the truth's pole:", "", basin_table(facet), "",
              requirement_line(facet), "",
              accuracy_table(facet), "", target_table(facet), "", time_line(facet), ""]
    parts += [f"### Mitsuba-rendered objects (model mismatch: the honest rows), {MITSUBA_NIGHTS} nights × ~{size.mitsuba_samples_per_night} samples", "",
              f"{len(mitsuba)} objects.", "", coverage_table(mitsuba), "", accuracy_table(mitsuba), "", target_table(mitsuba), ""]
    parts += ["### Sphere (the spin does not change the light curve: not identifiable)", ""]
    if sphere:
        parts += [f"{len(sphere)} objects: pole error median {np.median([r['pole_err_deg'] for r in sphere]):.0f}°, reported pole σ median "
                  f"{np.median([r['pole_sigma_deg'] for r in sphere]):.0f}°, truth in the best mode's 95 % region "
                  f"{sum(r['in95_pole'] for r in sphere)}/{len(sphere)}, "
                  f"in the mixture's 95 % region {sum(r['mix_level_pole'] <= 0.95 for r in sphere)}/{len(sphere)}.", ""]
    parts += [f"### Timing: 3 nights × {TIMING_SAMPLES} samples, facet-rendered ({', '.join(TIMING_TARGETS)}; full models)", "",
              timing_table(rows["timing"]), ""]
    parts += [f"### Brute force: a dense grid of the same likelihood (one night of ~{size.brute_samples} samples)", "", brute_table(rows["brute"]), "",
              _errors(rows)]
    return "\n".join(parts)


def _plain(row: dict) -> dict:
    """A row with numpy scalars as Python ones (JSON)."""
    return {k: v.item() if hasattr(v, "item") else v for k, v in row.items()}


def _kept_rows(name: str, fingerprint: str) -> dict[int, dict]:
    """Rows of :data:`ROWS_FILE` for size ``name`` measured by the code ``fingerprint`` (not ``+changes``), by schedule index."""
    if os.environ.get(FRESH_ENV) == "1" or not ROWS_FILE.exists() or fingerprint.endswith("+changes") or fingerprint == "unknown":
        return {}
    stored = json.loads(ROWS_FILE.read_text())
    return {int(key.split(":")[1]): row for key, row in stored.items() if key.split(":")[0] == name and row.get("code") == fingerprint}


def _provenance(rows: dict, stamp: dict) -> str:
    """Which commits and dates the reported rows were measured at (a resumed run reports rows of earlier runs of the same code);
    rows measured in this run carry no stamp yet and are this run's ``stamp``."""
    stamps = {}
    for kind_rows in rows.values():
        for r in kind_rows:
            key = (r.get("commit", stamp["commit"]), r.get("date", stamp["date"]))
            stamps[key] = stamps.get(key, 0) + 1
    return "; ".join(f"{n} at commit {c} on {d}" for (c, d), n in sorted(stamps.items(), key=lambda kv: kv[0][1]))


def run() -> str:
    """Measure and report at the size named by ``$LCNAV_BENCH_INVERSION_SIZE`` (default "full") within ``$LCNAV_BENCH_INVERSION_BUDGET_S``,
    resuming from the rows of :data:`ROWS_FILE` measured by the same code (module docstring)."""
    name = os.environ.get(SIZE_ENV, "full")
    if name not in SIZES:
        raise ValueError(f"{SIZE_ENV}: {name!r}: expected one of {sorted(SIZES)}")
    budget = float(os.environ.get(BUDGET_ENV, "inf"))
    size = SIZES[name]
    fingerprint = code(*CODE_PATHS)
    stamp = {"commit": commit(), "code": fingerprint, "date": datetime.date.today().isoformat()}
    kept = _kept_rows(name, fingerprint)
    stored = json.loads(ROWS_FILE.read_text()) if ROWS_FILE.exists() and os.environ.get(FRESH_ENV) != "1" else {}

    def save(j: int, kind: str, row: dict) -> None:
        stored[f"{name}:{j}"] = _plain(row) | {"kind": kind} | stamp
        write_json(ROWS_FILE, stored)

    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    t0 = time.perf_counter()
    processes = os.cpu_count() or 1
    rows, not_run = measure(np.random.default_rng(REPORT_SEED), size, budget_s=budget, processes=processes, kept=kept, on_row=save)
    stopped = (f" **The wall-clock budget of {budget:.0f} s stopped the run: {not_run} scheduled objects were not measured.**" if not_run else "")
    header = (f"Size \"{name}\" {size}; seed {REPORT_SEED}; 1-min load average {load:.1f} at start; objects in {processes} processes of one thread "
              f"each, the timing objects before them alone on all cores; this run {time.perf_counter() - t0:.0f} s, "
              f"{sum(map(len, rows.values())) - len(kept)} objects; {len(kept)} rows kept from earlier runs of the same code "
              f"(`{fingerprint}`: `lightcurves/` and `benchmarks/inversion_objects.py`). "
              f"Rows measured: {_provenance(rows, stamp)} (`benchmarks/{ROWS_FILE.name}`).{stopped} "
              f"Period range given: ±{100 * PERIOD_HALF_WIDTH:g} % around the true synodic period, "
              f"centre jittered by ±{100 * PERIOD_JITTER:g} %. Coverage cells: hits/n, Wilson 95 % interval, pass when the nominal level lies inside it.")
    return report(rows, size, header)
