"""``lcnav lightcurve render|prior``: synthetic light curves to ECSV, and spin priors from light curves.

::

    lcnav lightcurve render --target atlas-centaur --axis 0,0,1 --rate-deg-s 5 \\
        --duration 400 --cadence 0.5 --seed 1 --out lc.ecsv [--record lc.rrd]
    lcnav lightcurve prior lc.ecsv [--json] [--record prior.rrd]

Inputs are validated before anything is written; the ECSV and the recording
are written atomically (:mod:`studies.io`). ``--record`` logs to rerun:
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

from studies.io import atomic_path

lightcurve_app = typer.Typer(help="Synthetic light curves and spin priors.", no_args_is_help=True)


def _vector3(text: str, flag: str) -> np.ndarray:
    try:
        v = np.array([float(x) for x in text.split(",")])
    except ValueError:
        raise ValueError(f"{flag} must be three comma-separated numbers like 0,0,1, got {text!r}") from None
    if v.shape != (3,) or not np.all(np.isfinite(v)) or np.linalg.norm(v) == 0:
        raise ValueError(f"{flag} must be three comma-separated numbers, not all zero, like 0,0,1, got {text!r}")
    return v / np.linalg.norm(v)


def _out_path(path: Path | None, suffix: str, flag: str) -> Path | None:
    if path is None:
        return None
    if path.suffix.lower() != suffix:
        raise ValueError(f"{flag} must name a {suffix} file, got {str(path)!r}")
    if path.exists() and path.is_dir():
        raise ValueError(f"{flag} {str(path)!r} is a directory")
    return path


def write_lightcurve_recording(path: Path, lc, prior, mag_true=None, recording_id: str | None = None) -> None:
    """Log a light curve, its geometry and its spectra to a rerun recording at ``path`` (atomically).

    ``recording_id`` defaults to ``lightcurve-<file stem>``.
    """
    import rerun as rr

    t = lc.t_s
    with atomic_path(path) as tmp:
        rec = rr.RecordingStream("lcnav", recording_id=recording_id or f"lightcurve-{path.stem}")
        rec.save(tmp)
        idx = [rr.TimeColumn("sim_time", duration=t)]
        rec.send_columns("/lightcurve/mag", indexes=idx, columns=rr.Scalars.columns(scalars=lc.mag))
        if np.any(np.isfinite(lc.mag_err)):
            rec.send_columns("/lightcurve/mag_err", indexes=idx, columns=rr.Scalars.columns(scalars=lc.mag_err))
        if mag_true is not None:
            rec.send_columns("/lightcurve/mag_true", indexes=idx, columns=rr.Scalars.columns(scalars=mag_true))
        for name, values in (("phase_angle_deg", np.degrees(lc.phase_angle_rad)), ("range_km", lc.range_m / 1e3), ("elevation_deg", np.degrees(lc.elevation_rad))):
            if np.all(np.isfinite(values)):
                rec.send_columns(f"/lightcurve/geometry/{name}", indexes=idx, columns=rr.Scalars.columns(scalars=values))
        spec = prior.spectrum
        f = spec.frequency_hz
        for name, values, colour in (("dirty", spec.dirty, (150, 150, 150)), ("clean", spec.clean, (30, 120, 220)), ("residual", spec.residual, (220, 80, 40))):
            rec.log(f"/spectrum/{name}", rr.LineStrips2D([np.column_stack([f, 2.0 * np.abs(values)])], colors=[colour]), static=True)
        fw = spec.window_frequency_hz
        rec.log("/spectrum/window", rr.LineStrips2D([np.column_stack([fw, np.abs(spec.window)])]), static=True)
        if prior.significant:
            top = float(2.0 * np.abs(spec.clean).max())
            rec.log("/spectrum/rotation_frequency", rr.LineStrips2D([[[prior.frequency_hz, 0.0], [prior.frequency_hz, top]]], colors=[(40, 180, 60)]), static=True)
        rec.log("/spectrum/summary", rr.TextDocument(json.dumps(prior.to_dict(), indent=2), media_type="text/markdown"), static=True)
        rec.flush()
        rec.disconnect()


def _validate_render(target: str, axis: str, rate_deg_s: float, duration: float, cadence: float, albedo: float | None, spp: int, resolution: int, pole_ra_dec: str | None):
    from lightcurves.targets import TARGETS

    if target not in TARGETS:
        raise ValueError(f"unknown target {target!r}; known targets: {', '.join(sorted(TARGETS))}")
    axis_T = _vector3(axis, "--axis")
    if not (np.isfinite(rate_deg_s) and rate_deg_s > 0):
        raise ValueError(f"--rate-deg-s must be > 0, got {rate_deg_s}")
    if not (np.isfinite(duration) and duration > 0 and np.isfinite(cadence) and 0 < cadence < duration):
        raise ValueError(f"need --duration > --cadence > 0 (seconds), got --duration {duration} --cadence {cadence}")
    if duration / cadence < 20:
        raise ValueError(f"--duration/--cadence gives {int(duration / cadence) + 1} samples; at least 20 are needed")
    if albedo is not None and target != "sphere":
        raise ValueError("--albedo applies to --target sphere only")
    if spp not in (1, 4, 16, 64, 256):
        raise ValueError(f"--spp must be 1, 4, 16, 64 or 256, got {spp}")
    if resolution < 4:
        raise ValueError(f"--resolution must be >= 4 pixels, got {resolution}")
    pole_I = None
    if pole_ra_dec is not None:
        try:
            ra, dec = (np.radians(float(x)) for x in pole_ra_dec.split(","))
        except ValueError:
            raise ValueError(f"--pole-ra-dec must be 'RA,DEC' in degrees, got {pole_ra_dec!r}") from None
        pole_I = np.array([np.cos(dec) * np.cos(ra), np.cos(dec) * np.sin(ra), np.sin(dec)])
    return axis_T, pole_I


@lightcurve_app.command("render")
def render(
    target: str = typer.Option("atlas-centaur", help="atlas-centaur, vespa, box-wing or sphere"),
    axis: str = typer.Option("0,0,1", help="spin axis in the target's principal frame T, 'x,y,z'"),
    rate_deg_s: float = typer.Option(5.0, help="spin rate, deg/s"),
    duration: float = typer.Option(400.0, help="arc length, s"),
    cadence: float = typer.Option(0.5, help="nominal sampling interval, s"),
    seed: int = typer.Option(1, help="seed of every random draw (phase, sampling, noise)"),
    out: Path = typer.Option(..., help="output light curve (.ecsv)"),
    record: Path | None = typer.Option(None, help="also write a rerun recording (.rrd)"),
    albedo: float | None = typer.Option(None, help="sphere albedo (--target sphere)"),
    pole_ra_dec: str | None = typer.Option(None, help="inertial spin-axis direction 'RA,DEC' in degrees (default: normal of the phase plane)"),
    noise: bool = typer.Option(True, help="photometric noise (--no-noise for the clean curve)"),
    even: bool = typer.Option(False, help="even sampling, no gaps"),
    variant: str | None = typer.Option(None, help="Mitsuba variant: llvm_ad_rgb or scalar_rgb (default: best available)"),
    resolution: int = typer.Option(64, help="film pixels per side"),
    spp: int = typer.Option(4, help="samples per pixel (power of 4)"),
) -> None:
    """Render a synthetic light curve and write it as ECSV."""
    from tqdm import tqdm

    from lightcurves import extract_spin_prior
    from lightcurves.io import to_timeseries
    from lightcurves.render import UnresolvedRenderer
    from lightcurves.simulate import simulate_lightcurve
    from lightcurves.targets import get_target

    axis_T, pole_I = _validate_render(target, axis, rate_deg_s, duration, cadence, albedo, spp, resolution, pole_ra_dec)
    out = _out_path(out, ".ecsv", "--out")
    record = _out_path(record, ".rrd", "--record")
    tgt = get_target(target, **({"albedo": albedo} if albedo is not None else {}))
    renderer = UnresolvedRenderer(tgt, resolution=resolution, spp=spp, variant=variant)
    typer.echo(f"lcnav: rendering {target} with Mitsuba {renderer.variant}", err=True)
    rng = np.random.default_rng(seed)
    with tqdm(total=None, unit="sample", desc="render", leave=False) as bar:

        def progress(done, total):
            bar.total = total
            bar.n = done
            bar.refresh()

        sim = simulate_lightcurve(
            tgt, axis_T=axis_T, rate_rad_s=np.radians(rate_deg_s), duration_s=duration, cadence_s=cadence, rng=rng, pole_I=pole_I,
            noise=noise, uneven=not even, renderer=renderer, meta={"seed": seed, "resolution": resolution, "spp": spp}, progress=progress,
        )  # fmt: skip
    ts = to_timeseries(sim.lightcurve)
    with atomic_path(out) as tmp:
        ts.write(tmp, format="ascii.ecsv", overwrite=True)
    typer.echo(f"lcnav: wrote {out} ({len(sim.lightcurve)} samples, {renderer.variant})", err=True)
    if record is not None:
        lc = sim.lightcurve
        prior = extract_spin_prior(lc.t_s, lc.mag, lc.mag_err if np.all(np.isfinite(lc.mag_err)) else None)
        from lightcurves.render import flux_to_mag

        write_lightcurve_recording(record, lc, prior, mag_true=flux_to_mag(sim.flux_true_w_m2))
        typer.echo(f"lcnav: wrote {record}", err=True)


@lightcurve_app.command("prior")
def prior(
    path: Path = typer.Argument(..., help="light curve (.ecsv from 'render', or .csv with time,mag[,mag_err])"),
    as_json: bool = typer.Option(False, "--json", help="print the prior as JSON"),
    false_alarm_level: float = typer.Option(0.01, help="significance level of a period"),
    maxima_per_rotation: int | None = typer.Option(None, help="impose the number of maxima per rotation"),
    record: Path | None = typer.Option(None, help="write the light curve and spectra to a rerun recording (.rrd)"),
) -> None:
    """Extract a spin prior (rate, 1-σ, candidates) from a light curve with WindowCLEAN."""
    from lightcurves import extract_spin_prior
    from lightcurves.io import read_lightcurve

    if not (0.0 < false_alarm_level < 1.0):
        raise ValueError(f"--false-alarm-level must be in (0, 1), got {false_alarm_level}")
    record = _out_path(record, ".rrd", "--record")
    lc = read_lightcurve(path)
    err = lc.mag_err if np.all(np.isfinite(lc.mag_err)) else None
    p = extract_spin_prior(lc.t_s, lc.mag, err, false_alarm_level=false_alarm_level, maxima_per_rotation=maxima_per_rotation)
    d = p.to_dict()
    truth = lc.meta.get("truth_rate_deg_s")
    if truth is not None:
        d["truth_rate_deg_s"] = truth
    if as_json:
        typer.echo(json.dumps(d, indent=2))
    elif p.significant:
        maxima = "1 maximum" if p.maxima_per_rotation == 1 else f"{p.maxima_per_rotation} maxima"
        typer.echo(f"rate {p.rate_deg_s:.4f} ± {p.rate_sigma_deg_s:.4f} deg/s (period {p.period_s:.2f} s, {maxima} per rotation)")
        typer.echo(f"  {p.decision}")
        if truth is not None:
            typer.echo(f"  truth {truth:.4f} deg/s: error {100 * (p.rate_deg_s / truth - 1):+.2f} %")
        if p.npa_suspected:
            typer.echo("  non-principal-axis tumbling suspected: a strong peak is no harmonic of the rotation")
        for c in p.candidates[:5]:
            typer.echo(f"  candidate {c.frequency_hz:.6f} Hz  amplitude {c.amplitude_mag:.3f} mag  FAP {c.false_alarm_probability:.2g}  harmonic {c.harmonic}")
    else:
        typer.echo(p.decision)
    for w in [] if as_json else p.warnings:
        typer.echo(f"  warning: {w}", err=True)
    if record is not None:
        write_lightcurve_recording(record, lc, p)


def register(app: typer.Typer) -> None:
    """Add ``lcnav lightcurve ...`` to the root app."""
    app.add_typer(lightcurve_app, name="lightcurve")
