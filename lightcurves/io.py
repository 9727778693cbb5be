"""Light curves as data: the :class:`LightCurve` record, astropy tables, ECSV and observers' CSV.

The ECSV schema (astropy ``TimeSeries``, units in the header):

========== ======== =====================================================
column     unit     meaning
========== ======== =====================================================
time       (Time)   UTC sample time
flux       W / m2   flux at the observer (above the atmosphere)
mag        mag      apparent magnitude (Sun = −26.74)
mag_err    mag      1-σ magnitude error
phase_angle deg     Sun–target–observer angle
range      m        observer–target distance
elevation  deg      target elevation at the site
========== ======== =====================================================

Metadata (``table.meta``): ``target``, ``truth`` (spin axis in T, rate, pole),
``site``, ``cadence_s``, ``seed``, ``variant`` … — whatever the producer knows.
Columns a source does not give (e.g. ``flux`` from an observer's CSV) are NaN.

Reading is here (:func:`read_lightcurve`); writing a file is the caller's
(``studies`` writes ``to_timeseries(lc)`` atomically), so the library stays pure.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import astropy.units as u
import numpy as np
from astropy.table import Table
from astropy.time import Time
from astropy.timeseries import TimeSeries

from lightcurves.samples import BadSeries, check_samples

__all__ = ["LightCurve", "to_timeseries", "from_table", "read_lightcurve", "read_csv"]


@dataclass(frozen=True)
class LightCurve:
    """A light curve: times and magnitudes, with what is known of the geometry (NaN otherwise)."""

    time: Time  #: (N,) UTC
    mag: np.ndarray  #: (N,)
    mag_err: np.ndarray  #: (N,) 1-σ, NaN if unknown
    flux_w_m2: np.ndarray  #: (N,)
    phase_angle_rad: np.ndarray  #: (N,)
    range_m: np.ndarray  #: (N,)
    elevation_rad: np.ndarray  #: (N,)
    meta: dict = field(default_factory=dict)

    @property
    def t_s(self) -> np.ndarray:
        """Seconds since the first sample."""
        return (self.time - self.time[0]).to_value(u.s)

    def __len__(self) -> int:
        return len(self.mag)


def _nan(n):
    return np.full(n, np.nan)


def to_timeseries(lc: LightCurve) -> TimeSeries:
    """The light curve as an astropy ``TimeSeries`` with units and metadata (ready for ECSV)."""
    ts = TimeSeries(
        time=lc.time,
        data={
            "flux": lc.flux_w_m2 * (u.W / u.m**2),
            "mag": lc.mag * u.mag,
            "mag_err": lc.mag_err * u.mag,
            "phase_angle": np.degrees(lc.phase_angle_rad) * u.deg,
            "range": lc.range_m * u.m,
            "elevation": np.degrees(lc.elevation_rad) * u.deg,
        },
    )
    ts.time.precision = 9  # ISO text keeps ns (the default, ms, would round sample times)
    ts.meta.update(_plain(lc.meta))
    return ts


def _plain(obj):
    """Metadata as YAML-friendly builtins (ECSV headers are YAML)."""
    if isinstance(obj, dict):
        return {str(k): _plain(v) for k, v in obj.items()}
    if isinstance(obj, np.ndarray):
        return _plain(obj.tolist())
    if isinstance(obj, (list, tuple)):
        return [_plain(v) for v in obj]
    if isinstance(obj, np.generic):
        return obj.item()
    return obj


def _column(table: Table, name: str, unit, n: int) -> np.ndarray:
    if name not in table.colnames:
        return _nan(n)
    col = table[name]
    if getattr(col, "unit", None) is not None and unit is not None:
        return np.asarray(u.Quantity(col).to_value(unit), dtype=float)
    return np.asarray(col, dtype=float)


def from_table(table: Table) -> LightCurve:
    """A :class:`LightCurve` from a table with a ``time`` (Time) column and ``mag`` (validated)."""
    if "time" not in table.colnames or "mag" not in table.colnames:
        raise BadSeries(f"light-curve table needs columns 'time' and 'mag', got {table.colnames}")
    time = table["time"]
    if not isinstance(time, Time):
        raise BadSeries("light-curve column 'time' must be an astropy Time column")
    n = len(table)
    mag = _column(table, "mag", u.mag, n)
    mag_err = _column(table, "mag_err", u.mag, n)
    t_s = (time - time[0]).to_value(u.s)
    check_samples(t_s, mag, None if np.all(np.isnan(mag_err)) else mag_err)
    return LightCurve(
        time=Time(time),
        mag=mag,
        mag_err=mag_err,
        flux_w_m2=_column(table, "flux", u.W / u.m**2, n),
        phase_angle_rad=np.radians(_column(table, "phase_angle", u.deg, n)),
        range_m=_column(table, "range", u.m, n),
        elevation_rad=np.radians(_column(table, "elevation", u.deg, n)),
        meta=dict(table.meta),
    )


def read_csv(path, time_format: str | None = None) -> LightCurve:
    """An observer's CSV with a header ``time, mag[, mag_err]``.

    ``time`` is ISO 8601 UTC text, or numbers: seconds from the first sample
    (``time_format=None``) or ``"mjd"``, ``"jd"``, ``"unix"``.
    """
    path = Path(path)
    try:
        table = Table.read(path, format="ascii.csv", guess=False)
    except Exception as e:  # astropy's reader raises several types for malformed text
        raise BadSeries(f"{path.name}: malformed CSV ({str(e).splitlines()[0]}); expected a header 'time,mag[,mag_err]' and one row per sample") from None
    cols = [c.strip().lower() for c in table.colnames]
    table.rename_columns(table.colnames, cols)
    if "time" not in cols or "mag" not in cols:
        raise BadSeries(f"{path.name}: CSV header must contain 'time' and 'mag' (optionally 'mag_err'), got {cols}")
    for c in ("mag", "mag_err"):
        if c in cols and table[c].dtype.kind not in "fiu":
            raise BadSeries(f"{path.name}: column '{c}' must be numeric, got values like {table[c][0]!r}")
    raw = table["time"]
    try:
        if raw.dtype.kind in "fiu":
            if time_format is None:
                time = Time("2000-01-01T12:00:00", scale="utc") + np.asarray(raw, float) * u.s
                table.meta["time_origin"] = "relative seconds (no absolute epoch in the CSV)"
            else:
                time = Time(np.asarray(raw, float), format=time_format, scale="utc")
        else:
            time = Time([str(v) for v in raw], format="isot", scale="utc")
    except (ValueError, TypeError) as e:
        raise BadSeries(f"{path.name}: column 'time' is not ISO 8601 UTC or numeric ({e})") from None
    out = Table({"time": time, "mag": np.asarray(table["mag"], float)}, meta=dict(table.meta))
    if "mag_err" in cols:
        out["mag_err"] = np.asarray(table["mag_err"], float)
    out.meta["source"] = str(path.name)
    return from_table(out)


def read_lightcurve(path) -> LightCurve:
    """Read an ECSV light curve (as written from :func:`to_timeseries`) or an observer's CSV."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"light-curve file not found: {path}")
    suffix = path.suffix.lower()
    if suffix == ".csv":
        return read_csv(path)
    if suffix != ".ecsv":
        raise BadSeries(f"light-curve file must be .ecsv or .csv, got {path.name}")
    try:
        ts = TimeSeries.read(path, format="ascii.ecsv")
    except Exception as e:  # malformed header/body
        raise BadSeries(f"{path.name}: not a readable ECSV light curve ({str(e).splitlines()[0]})") from None
    return from_table(ts)
