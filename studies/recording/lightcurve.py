"""The light-curve recording: a light curve, its geometry, its WindowCLEAN spectra and the extracted prior.

Entities (``sim_time`` = seconds since the first sample):

=====================================  ==============================================================
``/lightcurve/relative_flux``          flux relative to the median (up = brighter: the viewer cannot
                                       invert a plot axis, so this is the curve a person reads)
``/lightcurve/mag``, ``/mag_err``      the observed magnitudes and their 1-σ errors (up = fainter)
``/lightcurve/mag_true``               the noiseless magnitudes, when known (simulations)
``/lightcurve/geometry/<name>``        phase angle (deg), range (km), elevation (deg)
                                       (each series cleared in the middle of every gap, :func:`gap_times`,
                                       so the viewer breaks its line there instead of drawing across)
``/spectrum/<name>``                   ``dirty``, ``clean``, ``residual`` amplitude spectra and the
                                       ``window``: ``rr.BarChart`` over frequency in mHz, the first three
                                       up to where the power is (:func:`spectrum_top_hz`)
``/spectrum/rotation_frequency``       one bar at the adopted rotation frequency, as tall as the clean
                                       spectrum's peak, drawn over the clean spectrum (a marker)
``/spectrum/summary``                  the extracted prior (JSON as a text document)
=====================================  ==============================================================

The recording carries :func:`studies.recording.blueprint.lightcurve_blueprint`, so the
viewer opens on the curve and, in a second tab, the spectra.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from studies.recording.blueprint import lightcurve_blueprint
from studies.recording.writer import recording, send_scalars, set_sim_time

#: Spectra of a WindowCLEAN result and where they live on it.
SPECTRA = ("dirty", "clean", "residual", "window")
#: A spacing of consecutive samples this many times their median is a gap (between passes or nights): for the uneven
#: sampling of one pass (spacings roughly exponential) a spacing of 10 medians has a chance of e^-6.9 = 0.1 %.
GAP_FACTOR = 10.0


#: The spectra are logged up to this factor times the highest frequency where the clean spectrum reaches
#: :data:`SPECTRUM_LEVEL` of its peak (or the rotation frequency, if higher): the band beyond holds no power.
SPECTRUM_REACH = 1.5
SPECTRUM_LEVEL = 0.05


def spectrum_top_hz(spectrum, rotation_hz: float | None = None) -> float:
    """Upper frequency (Hz) of the logged spectra: where the light curve's power is, not the whole search band.

    ``SPECTRUM_REACH × max(ν_top, rotation_hz)`` with ``ν_top`` the highest frequency
    where ``|clean| ≥ SPECTRUM_LEVEL · max |clean|`` (CLEAN keeps only components
    above the noise), at most the band's end. The README's render example (5°/s, 0.5-s cadence): 0.40 of
    1.0 Hz, holding 99.4 % of the clean and 98.1 % of the dirty spectrum's power.
    """
    f = np.asarray(spectrum.frequency_hz, dtype=float)
    amp = np.abs(np.asarray(spectrum.clean))
    if not amp.size or amp.max() <= 0:
        return float(f[-1])
    top = float(f[np.flatnonzero(amp >= SPECTRUM_LEVEL * amp.max())[-1]])
    return float(min(f[-1], SPECTRUM_REACH * max(top, rotation_hz or 0.0)))


def gap_times(t_s) -> np.ndarray:
    """The middles of the gaps of the sample times ``t_s`` (N,) s: spacings above :data:`GAP_FACTOR` times the median."""
    t = np.asarray(t_s, dtype=float)
    dt = np.diff(t)
    if dt.size < 2:
        return np.zeros(0)
    wide = np.flatnonzero(dt > GAP_FACTOR * np.median(dt))
    return t[wide] + 0.5 * dt[wide]


def _break_at_gaps(rec, entity: str, gaps) -> None:
    """An empty ``Scalars`` at each gap time: the viewer splits a line where a series was cleared."""
    import rerun as rr

    for tg in gaps:
        set_sim_time(rec, tg)
        rec.log(entity, rr.Scalars.cleared())


def _bar_chart(frequency_hz, amplitude, rgb):
    import rerun as rr

    f_mhz = 1e3 * np.asarray(frequency_hz, dtype=float)
    width = float(np.median(np.diff(f_mhz))) if f_mhz.size > 1 else 1.0
    return rr.BarChart(np.asarray(amplitude, dtype=float), abscissa=f_mhz, widths=np.full(f_mhz.size, width), color=rgb)


def write_lightcurve_recording(path: Path, lc, prior, mag_true=None, recording_id: str | None = None) -> None:
    """Log ``lc`` (a :class:`lightcurves.io.LightCurve`), its geometry and ``prior``'s spectra to ``path`` (atomically).

    ``recording_id`` defaults to ``lightcurve-<file stem>``; ``mag_true`` are
    the noiseless magnitudes of a simulation (same length as ``lc``).
    """
    import rerun as rr

    path = Path(path)
    t = lc.t_s
    with recording(path, recording_id=recording_id or f"lightcurve-{path.stem}", blueprint=lightcurve_blueprint(spectra=SPECTRA)) as rec:
        mag = np.asarray(lc.mag, dtype=float)
        series = {"relative_flux": 10.0 ** (-0.4 * (mag - np.median(mag))), "mag": mag, "mag_err": lc.mag_err, "mag_true": mag_true,
                  "geometry/phase_angle_deg": np.degrees(lc.phase_angle_rad), "geometry/range_km": lc.range_m / 1e3,
                  "geometry/elevation_deg": np.degrees(lc.elevation_rad)}
        gaps = gap_times(t)
        for name, values in series.items():
            if values is not None and np.all(np.isfinite(values)):
                send_scalars(rec, f"/lightcurve/{name}", t, values)
                _break_at_gaps(rec, f"/lightcurve/{name}", gaps)
        spec = prior.spectrum
        band = spec.frequency_hz <= spectrum_top_hz(spec, prior.frequency_hz)
        for name, rgb in (("dirty", (150, 150, 150)), ("clean", (30, 120, 220)), ("residual", (220, 80, 40))):
            rec.log(f"/spectrum/{name}", _bar_chart(spec.frequency_hz[band], 2.0 * np.abs(getattr(spec, name))[band], rgb), static=True)
        if prior.frequency_hz is not None:  # the adopted rotation frequency, a bar over the clean spectrum
            bin_mhz = 1e3 * float(spec.frequency_hz[1] - spec.frequency_hz[0])
            rec.log("/spectrum/rotation_frequency", rr.BarChart([2.0 * float(np.abs(spec.clean).max())], abscissa=[1e3 * prior.frequency_hz],
                                                                widths=[bin_mhz], color=(20, 20, 20)), static=True)
        rec.log("/spectrum/window", _bar_chart(spec.window_frequency_hz, np.abs(spec.window), (120, 120, 120)), static=True)
        rec.log("/spectrum/summary", rr.TextDocument("```json\n" + json.dumps(prior.to_dict(), indent=2) + "\n```",
                                                     media_type="text/markdown"), static=True)
