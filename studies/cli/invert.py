"""``lcnav lightcurve invert``: the spin state (pole, sidereal period, phase, body axis) from several light curves.

::

    lcnav lightcurve invert night1.ecsv night2.ecsv night3.ecsv [--shape TARGET|convex|ellipsoid:A,B,C]
        [--period-range-h MIN,MAX] [--json] [--out DIR] [--record FILE.rrd] [--seed N] [--quick] [--pole-region]

Files: lcnav ECSV with geometry (``lcnav lightcurve render --epoch --site``), DAMIT/convexinv text, or CSV
with geometry columns (:func:`lightcurves.inversion.io.read_inversion_curves`). Everything is validated
before the search (one line ``lcnav: error: <value>: expected <form>``, exit 2, nothing written).

Output: one line per solution (best first) on stdout, or with ``--json`` the document of
:func:`studies.catalog.inversion.result_dict`; the progress bar of the search goes to stderr, only when
stderr is a terminal and never with ``--json`` (stdout stays pure JSON either way). ``--out DIR`` writes
``inversion.json``, ``solutions.csv``/``.parquet``, ``pole_posterior.png`` and ``fit_night_<k>.png``
as one unit (:func:`studies.engine.io.output_folder`); ``--record`` a rerun recording
(:mod:`studies.recording.inversion`). ``--pole-region`` also maps the pole's profile-likelihood region around every
mode (:func:`lightcurves.inversion.profile.pole_profile_region`): the credible region that follows a ridge or a plateau
of the likelihood where the modes' Gaussians stop; it is printed as a summary line, listed in the JSON
(``pole_profile_regions``) and drawn on the pole figure and in the recording.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import typer

from studies.engine import validate as v

#: Largest MAX/MIN of a period range (a user knows the period to ~1 % from one night; a decade is a blind search).
MAX_PERIOD_RATIO = 10.0
#: Most sidereal-rate trials of the search's grid (the span of the data sets the step, ΔP ≈ P²/(4 T)).
MAX_PERIOD_TRIALS = 400
#: Search sizes: default, and ``--quick`` (a coarser pole lattice and fewer samples in the grid: a first look).
SEARCH_OPTIONS = {False: {}, True: {"pole_step_deg": 15.0, "n_grid_samples": 60, "n_candidates": 6, "n_periods_per_pole": 1, "n_phases": 12}}


def _shape(text: str) -> str:
    """``--shape``: a target name, ``convex`` or ``ellipsoid:A,B,C`` (semi-axes a ≥ b ≥ c > 0, m)."""
    from lightcurves.targets import TARGETS

    form = f"one of {', '.join(sorted(TARGETS))}, convex, or ellipsoid:A,B,C (semi-axes in m, A >= B >= C > 0)"
    if text == "convex" or text in TARGETS:
        return text
    if text.startswith("ellipsoid:"):
        try:
            a, b, c = v.check_floats("--shape", text.split(":", 1)[1], 3, max_abs=1e7)
        except v.InputError:
            v.fail("--shape", text, form)
        if a >= b >= c > 0:
            return text
    v.fail("--shape", text, form)


def _period_range_s(text: str) -> tuple[float, float]:
    """``--period-range-h MIN,MAX`` in hours -> (min, max) in s, 0 < MIN < MAX ≤ 10 MIN, MIN ≥ 1 s."""
    form = f"'MIN,MAX' sidereal periods in hours with 0 < MIN < MAX <= {MAX_PERIOD_RATIO:g} MIN (and MIN >= 1 s)"
    try:
        lo, hi = v.check_floats("--period-range-h", text, 2, max_abs=1e6)
    except v.InputError:
        v.fail("--period-range-h", text, form)
    if not (lo * 3600.0 >= 1.0 and lo < hi <= MAX_PERIOD_RATIO * lo):
        v.fail("--period-range-h", text, form)
    return lo * 3600.0, hi * 3600.0


def _read(files: list[Path]) -> list:
    """Every curve of every file, in order (a file that does not parse stops the command with its reader's one line)."""
    from lightcurves.inversion.io import read_inversion_curves

    curves = []
    for f in files:
        curves.extend(read_inversion_curves(f))
    return curves


def _check_trials(ranges, curves, oversampling: float) -> None:
    from studies.catalog.inversion import period_trials

    n = period_trials(ranges, curves, oversampling)
    if n > MAX_PERIOD_TRIALS:
        spans = "; ".join(f"{r.lo_s / 3600:.6g} to {r.hi_s / 3600:.6g} h" for r in ranges)
        raise v.InputError(f"--period-range-h {spans}: {n} period trials over the data's time span: expected at most {MAX_PERIOD_TRIALS} "
                           "(narrow the range: a night's light curve gives the period to ~1 %)")


def _progress_bar(enabled: bool, desc: str = "invert"):
    """A tqdm bar on stderr fed by ``progress(n_done, n_total)``, or a no-op; returns (progress, close)."""
    if not enabled:
        return None, lambda: None
    from tqdm import tqdm

    bar = tqdm(total=None, unit="step", desc=desc, leave=False, file=sys.stderr)

    def progress(done, total):
        bar.total = total
        bar.n = done
        bar.refresh()

    return progress, bar.close


def _text_line(rank: int, s: dict) -> str:
    axis = ""
    if "body_spin_axis_T" in s:
        axis = "  body axis T (" + ", ".join(f"{x:+.3f}" for x in s["body_spin_axis_T"]) + ")"
    return (f"#{rank} p={s['probability']:.3f}  pole λ={s['pole_ecliptic_lon_deg']:.1f}° β={s['pole_ecliptic_lat_deg']:+.1f}° "
            f"(RA {s['pole_ra_deg']:.1f}° Dec {s['pole_dec_deg']:+.1f}°) ±{s['pole_sigma_deg']:.2f}°  "
            f"P={s['sidereal_period_h']:.8g} ± {s['sidereal_period_sigma_h']:.2g} h  phase {s['phase_deg']:.1f}° at JD {s['epoch_jd']:.6f}{axis}")


def _region_line(r: dict) -> str:
    inside = {lv: len({(round(p["pole_ra_deg"], 9), round(p["pole_dec_deg"], 9)) for p in r["poles"] if p["level"] <= lv}) for lv in (0.68, 0.95)}
    return ("pole profile-likelihood region: "
            f"95 % {r['solid_angle_95_deg2']:.3g} deg² ({inside[0.95]} poles), 68 % {r['solid_angle_68_deg2']:.3g} deg² ({inside[0.68]} poles); "
            f"{r['n_poles_mapped']} poles mapped to {100 * r['mapped_to_level']:g} %" + ("" if r["complete"] else " (stopped at the pole limit: incomplete)"))


def _write_out(out: Path, run, doc: dict, fitted: list, regions: tuple) -> None:
    from studies.catalog.inversion import solutions_table
    from studies.catalog.inversion_figures import plot_night_fit, plot_pole_posterior
    from studies.engine.io import output_folder, write_json, write_table

    with output_folder(out, "lightcurve invert") as stage:
        write_json(stage / "inversion.json", doc)
        write_table(stage / "solutions.parquet", solutions_table(doc), csv=True)
        plot_pole_posterior(run, stage / "pole_posterior.png", regions)
        for k, (c, f) in enumerate(zip(run.curves, fitted)):
            plot_night_fit(c, f, stage / f"fit_night_{k + 1}.png", f"curve {k + 1}: {c.name or 'unnamed'} ({'calibrated' if c.calibrated else 'relative'})")


def invert_command(
    files: list[Path] = typer.Argument(..., help="light curves with geometry: lcnav .ecsv, DAMIT text (.txt/.lcs/.dat), or .csv",
                                       callback=v.in_file()),
    shape: str = typer.Option("convex", help="TARGET (a known lcnav target), convex (unknown shape) or ellipsoid:A,B,C (semi-axes, m)",
                              callback=v.text()),
    period_range_h: str | None = typer.Option(None, help="sidereal period range 'MIN,MAX' in hours (default: from every curve's own period)",
                                              callback=v.text()),
    as_json: bool = typer.Option(False, "--json", help="print the solutions as JSON"),
    out: Path | None = typer.Option(None, help="write inversion.json, solutions.csv/.parquet and figures into this folder", callback=v.out_dir()),
    record: Path | None = typer.Option(None, help="write a rerun recording (.rrd)", callback=v.out_file(".rrd")),
    seed: int = typer.Option(0, help="seed of the search's random pole-lattice rotation", callback=v.seed()),
    quick: bool = typer.Option(False, help="a coarser, faster search (15° pole lattice, 60 samples per curve in the grid, 6 pole minima refined)"),
    pole_region: bool = typer.Option(False, help="also map the pole's profile-likelihood region (refits with the pole held around every "
                                                 "mode: seconds for a well-determined pole, minutes for a ridge of a heavy model)"),
) -> None:
    """Invert light curves of one object to its spin state: pole, sidereal period, phase and (known shape) body axis."""
    from lightcurves.inversion.periods import PeriodRange, PeriodRangeError, period_ranges
    from studies.catalog.inversion import fitted_brightness, profile_regions, result_dict, run_inversion

    shape = _shape(shape)
    given = None if period_range_h is None else _period_range_s(period_range_h)
    if out is not None and record is not None and record.absolute().parent == out.absolute():
        v.fail("--record", str(record), "a file outside --out (the folder is written as one unit)")
    curves = _read(files)
    if given is not None:
        ranges = [PeriodRange(given[0], given[1], "given (--period-range-h)")]
    else:
        try:
            ranges = period_ranges(curves)
        except PeriodRangeError as e:
            raise PeriodRangeError(f"{e}: expected --period-range-h MIN,MAX") from None
        for r in ranges:
            typer.echo(f"lcnav: period range {r.lo_s / 3600:.6g} to {r.hi_s / 3600:.6g} h derived from {r.source}", err=True)
    _check_trials(ranges, curves, SEARCH_OPTIONS[quick].get("period_oversampling", 1.0))
    progress, close = _progress_bar(not as_json and sys.stderr.isatty())
    try:
        run = run_inversion(curves, shape, ranges, rng=np.random.default_rng(seed), progress=progress, search_options=SEARCH_OPTIONS[quick])
    finally:
        close()
    regions = ()
    if pole_region:
        progress, close = _progress_bar(not as_json and sys.stderr.isatty(), "pole region")
        try:
            regions = profile_regions(run, progress)
        finally:
            close()
    doc = result_dict(run, [str(f) for f in files], seed, regions)
    fitted = fitted_brightness(run.result.best, run.result, run.curves) if (out is not None or record is not None) else None
    if out is not None:
        _write_out(out, run, doc, fitted, regions)
    if record is not None:
        from studies.recording.inversion import write_inversion_recording

        write_inversion_recording(record, run, fitted, doc, regions)
    if as_json:
        typer.echo(json.dumps(doc, indent=2))
        return
    for k, s in enumerate(doc["solutions"], start=1):
        typer.echo(_text_line(k, s))
    for r in doc.get("pole_profile_regions", []):
        typer.echo(_region_line(r))
    fit = doc["fit"]
    typer.echo(f"fit: χ²/dof {fit['chi2_per_dof']:.3f} ({fit['n_points']} points, {fit['n_curves']} curves, {doc['shape_mode']} shape); "
               f"periods searched: " + "; ".join(f"{r['min_h']:.6g} to {r['max_h']:.6g} h ({r['source']})" for r in doc["period_ranges"])
               + f"; {doc['time_s']:.1f} s")  # fmt: skip


def register(app: typer.Typer) -> None:
    """Add ``invert`` to the ``lcnav lightcurve`` app."""
    app.command("invert")(invert_command)
