"""The light-curve recording: a light curve, its geometry, its WindowCLEAN spectra and the extracted prior.

Entities (``sim_time`` = seconds since the first sample):

=====================================  ==============================================================
``/lightcurve/relative_flux``          flux relative to the median (up = brighter: the viewer cannot
                                       invert a plot axis, so this is the curve a person reads)
``/lightcurve/mag``, ``/mag_err``      the observed magnitudes and their 1-σ errors (up = fainter)
``/lightcurve/mag_true``               the noiseless magnitudes, when known (simulations)
``/lightcurve/geometry/<name>``        phase angle (deg), range (km), elevation (deg)
``/spectrum/<name>``                   ``dirty``, ``clean``, ``residual`` amplitude spectra and the
                                       ``window``: ``rr.BarChart`` over frequency in mHz
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
from studies.recording.writer import recording, send_scalars

#: Spectra of a WindowCLEAN result and where they live on it.
SPECTRA = ("dirty", "clean", "residual", "window")


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
        send_scalars(rec, "/lightcurve/relative_flux", t, 10.0 ** (-0.4 * (mag - np.median(mag))))
        send_scalars(rec, "/lightcurve/mag", t, mag)
        if np.all(np.isfinite(lc.mag_err)):
            send_scalars(rec, "/lightcurve/mag_err", t, lc.mag_err)
        if mag_true is not None:
            send_scalars(rec, "/lightcurve/mag_true", t, mag_true)
        for name, values in (("phase_angle_deg", np.degrees(lc.phase_angle_rad)), ("range_km", lc.range_m / 1e3),
                             ("elevation_deg", np.degrees(lc.elevation_rad))):
            if np.all(np.isfinite(values)):
                send_scalars(rec, f"/lightcurve/geometry/{name}", t, values)
        spec = prior.spectrum
        for name, rgb in (("dirty", (150, 150, 150)), ("clean", (30, 120, 220)), ("residual", (220, 80, 40))):
            rec.log(f"/spectrum/{name}", _bar_chart(spec.frequency_hz, 2.0 * np.abs(getattr(spec, name)), rgb), static=True)
        rec.log("/spectrum/window", _bar_chart(spec.window_frequency_hz, np.abs(spec.window), (120, 120, 120)), static=True)
        rec.log("/spectrum/summary", rr.TextDocument("```json\n" + json.dumps(prior.to_dict(), indent=2) + "\n```",
                                                     media_type="text/markdown"), static=True)
