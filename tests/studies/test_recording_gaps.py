"""The light-curve recording breaks its lines at the gaps between passes (issue 30: the line was drawn across them).

The viewer splits a plotted series where it holds an empty ``Scalars`` (a
clear); each series gets exactly one, in the middle of each gap, and nowhere else.
"""

import astropy.units as u
import numpy as np
from astropy.time import Time
from rerun.chunk import RrdReader

from lightcurves.io import LightCurve
from lightcurves.prior import extract_spin_prior
from studies.recording.lightcurve import GAP_FACTOR, gap_times, write_lightcurve_recording
from studies.recording.reader import export_series


def two_passes(rng):
    """Two 150-s passes sampled unevenly (~1 s), 1000 s apart, of a body spinning at 4 deg/s."""
    t = np.concatenate([np.sort(rng.uniform(0, 150, 150)), 1150 + np.sort(rng.uniform(0, 150, 150))])
    f = 4.0 / 360.0
    mag = 9 + 0.6 * np.cos(4 * np.pi * f * t) + 0.2 * np.cos(2 * np.pi * f * t) + rng.normal(0, 0.02, t.size)
    n = t.size
    return LightCurve(time=Time("2024-03-21T20:00:00", scale="utc") + t * u.s, mag=mag, mag_err=np.full(n, 0.02),
                      flux_w_m2=np.full(n, np.nan), phase_angle_rad=np.full(n, 0.5), range_m=np.full(n, 2e7),
                      elevation_rad=np.full(n, 0.9))


def cleared_times(path, entity: str) -> list[float]:
    """``sim_time`` (s) of the rows of ``entity`` whose scalars are empty."""
    reader = RrdReader(path)
    out = []
    for chunk in reader.stream(store=reader.recordings()[0]):
        if str(chunk.entity_path) != entity:
            continue
        cols = chunk.to_record_batch().to_pydict()
        for t, values in zip(cols.get("sim_time", []), cols.get("Scalars:scalars", [])):
            if values is not None and len(values) == 0:
                out.append(t.total_seconds() if hasattr(t, "total_seconds") else float(t) * 1e-9)
    return sorted(out)


def test_gap_times_find_only_the_gap_between_passes():
    rng = np.random.default_rng(4)
    lc = two_passes(rng)
    t = lc.t_s
    gaps = gap_times(t)
    k = int(np.argmax(np.diff(t)))
    assert gaps.tolist() == [0.5 * (t[k] + t[k + 1])] and np.diff(t)[k] > GAP_FACTOR * np.median(np.diff(t))
    assert gap_times(np.arange(100.0)).size == 0


def test_each_light_curve_series_is_broken_once_at_the_gap(tmp_path):
    lc = two_passes(np.random.default_rng(4))
    path = tmp_path / "lc.rrd"
    write_lightcurve_recording(path, lc, extract_spin_prior(lc.t_s, lc.mag, lc.mag_err))
    (gap,) = gap_times(lc.t_s)
    for entity in ("/lightcurve/mag", "/lightcurve/relative_flux", "/lightcurve/geometry/range_km"):
        assert np.allclose(cleared_times(path, entity), [gap], atol=1e-6), entity
    df, _ = export_series(path)  # the samples read back unchanged, one row each
    assert len(df) == len(lc) and np.allclose(df["/lightcurve/mag"].to_numpy(), lc.mag)
