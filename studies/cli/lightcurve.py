"""``lcnav lightcurve render|prior``: synthetic light curves to ECSV, and spin priors from light curves.

::

    lcnav lightcurve render --target atlas-centaur --axis 0,0,1 --rate-deg-s 5 \\
        --duration 400 --cadence 0.5 --seed 1 --out lc.ecsv [--record lc.rrd] \\
        [--epoch 2024-03-21T18:00:00 --site 28.2995,-16.5097,2393]
    lcnav lightcurve prior lc.ecsv [--json] [--record prior.rrd]
    lcnav lightcurve prior obs.csv --time-format mjd --columns time=mjd,mag=magnitude,mag_err=err

A numeric time column is read in the unit ``--time-format`` names; without it,
as seconds since any origin unless its values or spacing look like another
unit (:func:`lightcurves.io.ambiguous_time_unit`: MJD, JD, Unix time,
milliseconds), which is refused (exit 2) rather than turned into a confident
wrong rate. The prior's text and JSON (``time_input``) say how the times were read.

``--epoch`` (UTC) and ``--site`` (geodetic latitude, east longitude, height) say
when and where: the arc is the first one after the epoch in which the target is
visible from the site, so a user renders the nights they plan to observe. The
ECSV carries the per-sample geometry (target -> Sun and target -> observer unit
vectors in I, Sun distance). Inputs are validated before anything is written; the ECSV and the recording
are written atomically (:mod:`studies.engine.io`). ``--record`` logs to rerun:
``/lightcurve/mag``, ``/lightcurve/mag_true``, ``/lightcurve/geometry/*`` on
the ``sim_time`` timeline (seconds since the first sample) and the spectra
``/spectrum/dirty``, ``/spectrum/clean``, ``/spectrum/residual``,
``/spectrum/window`` (amplitude against frequency) with the adopted rotation
frequency ``/spectrum/rotation_frequency``.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import typer

from studies.engine import validate as v
from studies.engine.io import atomic_paths
from studies.recording.lightcurve import write_lightcurve_recording

lightcurve_app = typer.Typer(help="Synthetic light curves and spin priors.", no_args_is_help=True)


def _vector3(text: str, flag: str) -> np.ndarray:
    vec = v.check_floats(flag, text, 3, max_abs=1e12)
    if np.linalg.norm(vec) == 0:
        v.fail(flag, text, "three comma-separated numbers, not all zero, like 0,0,1")
    return vec / np.linalg.norm(vec)


#: Light-curve files ``prior`` reads: ECSV from ``render``; observers' CSV, FITS and VOTable tables (the suffixes of
#: ``lightcurves.io.TABLE_FORMATS``, written out so that parsing the command line does not import the readers).
LIGHTCURVE_SUFFIXES = (".ecsv", ".csv", ".fits", ".fit", ".fts", ".vot", ".votable", ".xml")


def _parse_columns(text: str | None) -> dict[str, str] | None:
    """``--columns time=mjd,mag=magnitude`` as ``{"time": "mjd", "mag": "magnitude"}`` (roles of :data:`lightcurves.io.COLUMN_ROLES`)."""
    from lightcurves.io import COLUMN_ROLES

    if text is None:
        return None
    expected = "ROLE=NAME pairs separated by commas, ROLE one of " + ", ".join(COLUMN_ROLES) + ", each once, like time=mjd,mag=magnitude"
    pairs = [item.split("=") for item in text.split(",")]
    if any(len(pair) != 2 or pair[0].strip() not in COLUMN_ROLES or not pair[1].strip() for pair in pairs):
        v.fail("--columns", text, expected)
    mapping = {role.strip(): name.strip() for role, name in pairs}
    if len(mapping) != len(pairs):
        v.fail("--columns", text, expected)
    if "mag" in mapping and "flux" in mapping:
        v.fail("--columns", text, "mag= or flux=, not both")
    return mapping


#: Most samples of a rendered light curve (duration / cadence): each one is a Mitsuba render.
MAX_SAMPLES = 10**5
#: Epochs a render accepts, ISO years: UTC with leap seconds starts in 1962; ERFA's leap-second table ends about 2100.
EPOCH_YEARS = (1962, 2100)
#: Site heights accepted, m above the WGS84 ellipsoid (the Dead Sea shore to above the highest observatories).
SITE_HEIGHT_M = (-500.0, 9000.0)


def _epoch(text: str | None):
    """``--epoch`` as an astropy UTC ``Time`` (ISO 8601, 'T' or space between date and time); None -> the simulator's default."""
    import warnings

    from astropy.time import Time
    from erfa import ErfaWarning

    from lightcurves.simulate import DEFAULT_EPOCH

    if text is None:
        return DEFAULT_EPOCH
    form = f"an ISO 8601 UTC time like 2024-03-21T18:00:00, years {EPOCH_YEARS[0]} to {EPOCH_YEARS[1]}"
    try:
        with warnings.catch_warnings():  # a year outside the leap-second table ("dubious year") is refused below, not warned about
            warnings.simplefilter("ignore", ErfaWarning)
            epoch = Time(text.strip(), format="isot" if "T" in text else "iso", scale="utc")
            year = int(epoch.utc.isot[:4]) if epoch.isscalar else None
    except ValueError:
        v.fail("--epoch", text, form)
    if year is None or not EPOCH_YEARS[0] <= year <= EPOCH_YEARS[1]:
        v.fail("--epoch", text, form)
    return epoch


def _site(text: str | None):
    """``--site 'LAT,LON,HEIGHT_M'`` (deg, deg east, m) as an astropy ``EarthLocation``; None -> the simulator's default site."""
    import astropy.units as u
    from astropy.coordinates import EarthLocation

    from lightcurves.geometry import DEFAULT_SITE

    if text is None:
        return DEFAULT_SITE
    form = (f"'LAT,LON,HEIGHT_M' like 28.2995,-16.5097,2393: latitude within [-90, 90] deg, longitude within [-180, 360] deg east, "
            f"height within [{SITE_HEIGHT_M[0]:g}, {SITE_HEIGHT_M[1]:g}] m")  # fmt: skip
    try:
        lat, lon, height = v.check_floats("--site", text, 3, max_abs=1e4)
    except v.InputError:
        v.fail("--site", text, form)
    if not (abs(lat) <= 90 and -180 <= lon <= 360 and SITE_HEIGHT_M[0] <= height <= SITE_HEIGHT_M[1]):
        v.fail("--site", text, form)
    return EarthLocation.from_geodetic(lon=lon * u.deg, lat=lat * u.deg, height=height * u.m)
#: Largest light-curve file ``prior`` reads, bytes (10⁵ rows of up to ~300 characters).
MAX_PRIOR_BYTES = 32 * 2**20


def _validate_render(target: str, axis: str, duration: float, cadence: float, albedo: float | None, pole_ra_dec: str | None):
    """Cross-option checks of ``render`` (single options are bounded by their callbacks)."""
    from lightcurves.samples import MIN_SAMPLES
    from lightcurves.targets import TARGETS

    if target not in TARGETS:
        v.fail("--target", target, "one of " + ", ".join(sorted(TARGETS)))
    axis_T = _vector3(axis, "--axis")
    if not cadence < duration or not MIN_SAMPLES <= duration / cadence <= MAX_SAMPLES:
        v.fail("--duration/--cadence", f"{duration:g}/{cadence:g}", f"--cadence < --duration and {MIN_SAMPLES} to {MAX_SAMPLES} samples")
    if albedo is not None and target != "sphere":
        raise v.InputError(f"--albedo {albedo:g} with --target {target!r}: expected --albedo with --target sphere only")
    pole_I = None
    if pole_ra_dec is not None:
        ra, dec = np.radians(v.check_floats("--pole-ra-dec", pole_ra_dec, 2, max_abs=360.0))
        if abs(dec) > np.pi / 2:
            v.fail("--pole-ra-dec", pole_ra_dec, "'RA,DEC' in degrees with DEC within [-90, 90]")
        pole_I = np.array([np.cos(dec) * np.cos(ra), np.cos(dec) * np.sin(ra), np.sin(dec)])
    return axis_T, pole_I


@lightcurve_app.command("render")
def render(
    target: str = typer.Option("atlas-centaur", help="atlas-centaur, vespa, box-wing or sphere", callback=v.text()),
    axis: str = typer.Option("0,0,1", help="spin axis in the target's principal frame T, 'x,y,z'", callback=v.text()),
    rate_deg_s: float = typer.Option(5.0, help="spin rate, deg/s (at most 360)", callback=v.number(0, 360, lo_open=True, unit="deg/s")),
    duration: float = typer.Option(400.0, help="arc length, s", callback=v.number(0, 1e6, lo_open=True, unit="s")),
    cadence: float = typer.Option(0.5, help="nominal sampling interval, s", callback=v.number(0, 1e5, lo_open=True, unit="s")),
    seed: int = typer.Option(1, help="seed of every random draw (phase, sampling, noise)", callback=v.seed()),
    out: Path = typer.Option(..., help="output light curve (.ecsv)", callback=v.out_file(".ecsv")),
    record: Path | None = typer.Option(None, help="also write a rerun recording (.rrd)", callback=v.out_file(".rrd")),
    albedo: float | None = typer.Option(None, help="sphere albedo (--target sphere)", callback=v.number(0, 1, lo_open=True)),
    pole_ra_dec: str | None = typer.Option(None, help="inertial spin-axis direction 'RA,DEC' in degrees (default: normal of the phase plane)",
                                           callback=v.text()),
    noise: bool = typer.Option(True, help="photometric noise (--no-noise for the clean curve)"),
    even: bool = typer.Option(False, help="even sampling, no gaps"),
    variant: str | None = typer.Option(None, help="Mitsuba variant: llvm_ad_rgb or scalar_rgb (default: best available)",
                                       callback=v.text(("llvm_ad_rgb", "scalar_rgb"))),
    resolution: int = typer.Option(64, help="film pixels per side (4 to 1024)", callback=v.count(4, 1024)),
    spp: int = typer.Option(4, help="samples per pixel (1, 4, 16, 64 or 256)", callback=v.one_of((1, 4, 16, 64, 256))),
    epoch: str | None = typer.Option(None, help="UTC start of the search for a visible arc, ISO 8601 like 2024-03-21T18:00:00 "
                                     "(default: lightcurves.simulate.DEFAULT_EPOCH)", callback=v.text()),
    site: str | None = typer.Option(None, help="observer 'LAT,LON,HEIGHT_M': geodetic degrees, degrees east, metres "
                                    "(default: ESA's OGS at Teide, lightcurves.geometry.DEFAULT_SITE)", callback=v.text()),
    phase_deg: float | None = typer.Option(None, help="rotational phase at J2000.0 (2000-01-01T12:00:00 TT), deg (default: drawn from --seed); "
                                           "nights rendered with one --pole-ra-dec, --phase-deg and rate are one continuous rotation",
                                           callback=v.number(-360, 360, unit="deg")),
) -> None:
    """Render a synthetic light curve and write it as ECSV (with the Sun and observer directions per sample)."""
    from astropy.time import Time
    from astropy.utils import iers
    from tqdm import tqdm

    from lightcurves import extract_spin_prior
    from lightcurves.io import to_timeseries
    from lightcurves.render import UnresolvedRenderer
    from lightcurves.simulate import simulate_lightcurve
    from lightcurves.targets import get_target

    axis_T, pole_I = _validate_render(target, axis, duration, cadence, albedo, pole_ra_dec)
    when, where = _epoch(epoch), _site(site)
    if record is not None and record.absolute() == out.absolute():
        v.fail("--record", str(record), "a file other than --out")
    tgt = get_target(target, **({"albedo": albedo} if albedo is not None else {}))
    renderer = UnresolvedRenderer(tgt, resolution=resolution, spp=spp, variant=variant)
    typer.echo(f"lcnav: rendering {target} with Mitsuba {renderer.variant}", err=True)
    rng = np.random.default_rng(seed)
    # Nights to plan lie beyond the IERS table's measured Earth orientation: accept its predictions however old
    # (astropy refuses them past 30 days by default). A UT1 error below 1 s turns the site by < 15", nothing a light curve sees.
    with iers.conf.set_temp("auto_max_age", None), tqdm(total=None, unit="sample", desc="render", leave=False) as bar:

        def progress(done, total):
            bar.total = total
            bar.n = done
            bar.refresh()

        sim = simulate_lightcurve(
            tgt, axis_T=axis_T, rate_rad_s=np.radians(rate_deg_s), duration_s=duration, cadence_s=cadence, rng=rng, pole_I=pole_I, epoch=when, site=where,
            phase_rad=None if phase_deg is None else np.radians(phase_deg), phase_epoch=Time("2000-01-01T12:00:00", scale="tt"),
            noise=noise, uneven=not even, renderer=renderer, meta={"seed": seed, "resolution": resolution, "spp": spp}, progress=progress,
        )  # fmt: skip
    ts = to_timeseries(sim.lightcurve)
    # the light curve and its recording appear together or not at all
    with atomic_paths(*[p for p in (out, record) if p is not None]) as tmps:
        ts.write(tmps[0], format="ascii.ecsv", overwrite=True)
        if record is not None:
            lc = sim.lightcurve
            prior = extract_spin_prior(lc.t_s, lc.mag, lc.mag_err if np.all(np.isfinite(lc.mag_err)) else None)
            from lightcurves.render import flux_to_mag

            write_lightcurve_recording(tmps[1], lc, prior, mag_true=flux_to_mag(sim.flux_true_w_m2), recording_id=f"lightcurve-{record.stem}")
    typer.echo(f"lcnav: wrote {out} ({len(sim.lightcurve)} samples, {renderer.variant})" + (f" and {record}" if record is not None else ""), err=True)


#: Largest magnitude (and magnitude error) a light curve may hold: brighter than the Sun (-26.7) or fainter than any survey
#: limit (about 30) is a unit or parsing mistake (a flux, a 1e300), not a magnitude.
MAX_ABS_MAG = 50.0


def _check_prior_input(path: Path, lc) -> None:
    """A light curve ``prior`` can handle in bounded time: at most :data:`MAX_SAMPLES` samples (about 4 s), magnitudes within ±50."""
    if len(lc) > MAX_SAMPLES:
        raise v.InputError(f"{path.name}: {len(lc)} samples: expected at most {MAX_SAMPLES} samples (bin or split a longer light curve)")
    for name, values in (("mag", lc.mag), ("mag_err", lc.mag_err)):
        bad = np.flatnonzero(np.abs(values) > MAX_ABS_MAG)  # NaN (no mag_err) compares False
        if bad.size:
            raise v.InputError(f"{path.name}: {name} {v.plain(values[bad[0]])} (sample {int(bad[0])}): expected magnitudes within ±{MAX_ABS_MAG:g}")


@lightcurve_app.command("prior")
def prior(
    path: Path = typer.Argument(..., help="light curve: .ecsv from 'render', or a table (.csv, .fits, .vot) with columns time and mag[,mag_err] "
                                "(or flux[,flux_err]); its time column is ISO 8601 text or numbers in the unit --time-format names (plain "
                                "numbers without it are read as seconds, and refused where they look like MJD, JD, Unix time or ms)",
                                callback=v.in_file(LIGHTCURVE_SUFFIXES, max_bytes=MAX_PRIOR_BYTES)),
    time_format: str | None = typer.Option(None, help="unit of a numeric time column: seconds or ms (since any origin), mjd, jd (days), unix (s since 1970), "
                                           "... or a text format: isot, iso, fits, yday (astropy Time formats)", callback=v.text()),
    time_scale: str = typer.Option("utc", help="time scale of the file's times: utc, tai, tt, tdb, tcg or tcb", callback=v.text()),
    columns: str | None = typer.Option(None, help="the file's column names, e.g. time=mjd,mag=magnitude,mag_err=err or time=jd,flux=counts,flux_err=sigma "
                                       "(flux of any unit becomes instrumental magnitudes)", callback=v.text()),
    as_json: bool = typer.Option(False, "--json", help="print the prior as JSON"),
    false_alarm_level: float = typer.Option(0.01, help="significance level of a period", callback=v.number(0, 1, lo_open=True, hi_open=True)),
    maxima_per_rotation: int | None = typer.Option(None, help="impose the number of maxima per rotation (1 to 16)", callback=v.count(1, 16)),
    record: Path | None = typer.Option(None, help="write the light curve and spectra to a rerun recording (.rrd)", callback=v.out_file(".rrd")),
) -> None:
    """Extract a spin prior (rate, 1-σ, candidates, warnings) from a light curve (multi-harmonic fits of the periodogram's peaks)."""
    from lightcurves import extract_spin_prior
    from lightcurves.io import TIME_FORMATS, TIME_SCALES, read_lightcurve

    if time_format is not None:
        v.check_text("--time-format", time_format, choices=TIME_FORMATS)
    v.check_text("--time-scale", time_scale, choices=TIME_SCALES)
    lc = read_lightcurve(path, time_format, time_scale=time_scale, columns=_parse_columns(columns))
    _check_prior_input(path, lc)
    err = lc.mag_err if np.all(np.isfinite(lc.mag_err)) else None
    phase = lc.phase_angle_rad if np.all(np.isfinite(lc.phase_angle_rad)) else None  # a lower bound of the synodic term of the 1-σ
    p = extract_spin_prior(lc.t_s, lc.mag, err, false_alarm_level=false_alarm_level, maxima_per_rotation=maxima_per_rotation,
                           phase_angle_rad=phase)
    d = p.to_dict()
    d["time_input"] = lc.meta.get("time_input", "")  # how the file's times were read: the unit every rate here rests on
    truth = lc.meta.get("truth_rate_deg_s")
    if truth is not None:
        d["truth_rate_deg_s"] = truth
    if as_json:
        typer.echo(json.dumps(d, indent=2))
    elif p.significant:
        maxima = "1 maximum" if p.maxima_per_rotation == 1 else f"{p.maxima_per_rotation} maxima"
        typer.echo(f"rate {p.rate_deg_s:.4f} ± {p.rate_sigma_deg_s:.4f} deg/s (period {p.period_s:.2f} s, {maxima} per rotation)")
        typer.echo(f"  {p.decision}")
        typer.echo(f"  time: {d['time_input']}")
        if truth is not None:
            typer.echo(f"  truth {truth:.4f} deg/s: error {100 * (p.rate_deg_s / truth - 1):+.2f} %")
        if p.npa_suspected:
            typer.echo("  non-principal-axis tumbling suspected: a strong peak is no harmonic of the rotation")
        for c in p.candidates[:5]:
            typer.echo(f"  candidate {c.frequency_hz:.6f} Hz  amplitude {c.amplitude_mag:.3f} mag  FAP {c.false_alarm_probability:.2g}  harmonic {c.harmonic}")
    else:
        typer.echo(p.decision)
        typer.echo(f"  time: {d['time_input']}")
    for w in [] if as_json else p.warnings:
        typer.echo(f"lcnav: warning: {w}", err=True)
    if record is not None:
        write_lightcurve_recording(record, lc, p)


def register(app: typer.Typer) -> None:
    """Add ``lcnav lightcurve ...`` to the root app."""
    from studies.cli import invert

    invert.register(lightcurve_app)
    app.add_typer(lightcurve_app, name="lightcurve")
