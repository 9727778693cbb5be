"""``lcnav lightcurve render|prior``: synthetic light curves to ECSV, and spin priors from light curves.

::

    lcnav lightcurve render --target atlas-centaur --axis 0,0,1 --rate-deg-s 5 \\
        --duration 400 --cadence 0.5 --seed 1 --out lc.ecsv [--record lc.rrd]
    lcnav lightcurve prior lc.ecsv [--json] [--record prior.rrd]

Inputs are validated before anything is written; the ECSV and the recording
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


#: Most samples of a rendered light curve (duration / cadence): each one is a Mitsuba render; and of a light curve ``prior`` reads.
MAX_SAMPLES = 10**5
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
) -> None:
    """Render a synthetic light curve and write it as ECSV."""
    from tqdm import tqdm

    from lightcurves import extract_spin_prior
    from lightcurves.io import to_timeseries
    from lightcurves.render import UnresolvedRenderer
    from lightcurves.simulate import simulate_lightcurve
    from lightcurves.targets import get_target

    axis_T, pole_I = _validate_render(target, axis, duration, cadence, albedo, pole_ra_dec)
    if record is not None and record.absolute() == out.absolute():
        v.fail("--record", str(record), "a file other than --out")
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
    path: Path = typer.Argument(..., help="light curve (.ecsv from 'render', or .csv with time,mag[,mag_err])",
                                callback=v.in_file((".ecsv", ".csv"), max_bytes=MAX_PRIOR_BYTES)),
    as_json: bool = typer.Option(False, "--json", help="print the prior as JSON"),
    false_alarm_level: float = typer.Option(0.01, help="significance level of a period", callback=v.number(0, 1, lo_open=True, hi_open=True)),
    maxima_per_rotation: int | None = typer.Option(None, help="impose the number of maxima per rotation (1 to 16)", callback=v.count(1, 16)),
    record: Path | None = typer.Option(None, help="write the light curve and spectra to a rerun recording (.rrd)", callback=v.out_file(".rrd")),
) -> None:
    """Extract a spin prior (rate, 1-σ, candidates, warnings) from a light curve (multi-harmonic fits of the periodogram's peaks)."""
    from lightcurves import extract_spin_prior
    from lightcurves.io import read_lightcurve

    lc = read_lightcurve(path)
    _check_prior_input(path, lc)
    err = lc.mag_err if np.all(np.isfinite(lc.mag_err)) else None
    phase = lc.phase_angle_rad if np.all(np.isfinite(lc.phase_angle_rad)) else None  # a lower bound of the synodic term of the 1-σ
    p = extract_spin_prior(lc.t_s, lc.mag, err, false_alarm_level=false_alarm_level, maxima_per_rotation=maxima_per_rotation,
                           phase_angle_rad=phase)
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
        typer.echo(f"lcnav: warning: {w}", err=True)
    if record is not None:
        write_lightcurve_recording(record, lc, p)


def register(app: typer.Typer) -> None:
    """Add ``lcnav lightcurve ...`` to the root app."""
    app.add_typer(lightcurve_app, name="lightcurve")
