"""Light curves as data: the :class:`LightCurve` record, astropy tables, ECSV and observers' CSV.

The ECSV schema (astropy ``TimeSeries``, units in the header):

==================== ======== ==============================================================
column               unit     meaning
==================== ======== ==============================================================
time                 (Time)   UTC sample time
flux                 W / m2   flux at the observer (above the atmosphere)
mag                  mag      apparent magnitude (Sun = −26.74)
mag_err              mag      1-σ magnitude error
phase_angle          deg      Sun–target–observer angle
range                m        observer–target distance
elevation            deg      target elevation at the site
sun_dir_I_x/y/z      —        unit vector target -> Sun in frame I (GCRS ≈ equatorial J2000)
observer_dir_I_x/y/z —        unit vector target -> observer (topocentric) in I
sun_distance         m        target–Sun distance
==================== ======== ==============================================================

The geometry columns (``sun_dir_I_*``, ``observer_dir_I_*``, ``sun_distance``)
are written only when the producer knows them (:func:`~lightcurves.simulate.simulate_lightcurve`
does); a file without them reads back with NaN there, as do older files.

Metadata (``table.meta``): ``target``, ``truth`` (spin axis in T, rate, pole),
``site``, ``cadence_s``, ``seed``, ``variant`` … — whatever the producer knows.
Columns a source does not give (e.g. ``flux`` from an observer's CSV) are NaN.

Reading is here (:func:`read_lightcurve`); writing a file is the caller's
(``studies`` writes ``to_timeseries(lc)`` atomically), so the library stays pure.
"""

from __future__ import annotations

import re
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import astropy.units as u
import numpy as np
from astropy.io.ascii import convert_numpy
from astropy.table import Table
from astropy.time import Time
from astropy.timeseries import TimeSeries

from lightcurves.samples import BadSeries, check_samples

__all__ = ["LightCurve", "DuplicateTimesWarning", "to_timeseries", "from_table", "read_lightcurve", "read_csv", "merge_duplicate_times"]


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
    sun_dir_I: np.ndarray | None = None  #: (N, 3) unit vectors target -> Sun in I; None -> NaN (unknown)
    observer_dir_I: np.ndarray | None = None  #: (N, 3) unit vectors target -> observer in I; None -> NaN
    sun_distance_m: np.ndarray | None = None  #: (N,) target–Sun distance; None -> NaN

    def __post_init__(self):
        n = len(self.mag)
        for name, shape in (("sun_dir_I", (n, 3)), ("observer_dir_I", (n, 3)), ("sun_distance_m", (n,))):
            value = getattr(self, name)
            a = np.full(shape, np.nan) if value is None else np.asarray(value, dtype=float)
            if a.shape != shape:
                raise BadSeries(f"{name}: shape {a.shape}: expected {shape}, one per sample (NaN where unknown)")
            object.__setattr__(self, name, a)

    @property
    def t_s(self) -> np.ndarray:
        """Seconds since the first sample."""
        return (self.time - self.time[0]).to_value(u.s)

    def __len__(self) -> int:
        return len(self.mag)


def _nan(n):
    return np.full(n, np.nan)


#: Per-sample geometry columns of the ECSV: LightCurve field -> (column names, unit).
_GEOMETRY = {
    "sun_dir_I": (("sun_dir_I_x", "sun_dir_I_y", "sun_dir_I_z"), None),
    "observer_dir_I": (("observer_dir_I_x", "observer_dir_I_y", "observer_dir_I_z"), None),
    "sun_distance_m": (("sun_distance",), u.m),
}


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
    for attr, (names, unit) in _GEOMETRY.items():
        value = getattr(lc, attr).reshape(len(lc), len(names))
        if np.isfinite(value).any():  # unknown geometry is not written: files without it stay as they were
            for k, name in enumerate(names):
                ts[name] = value[:, k] if unit is None else value[:, k] * unit
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
    """Column ``name`` in ``unit`` as floats (NaN if absent); BadSeries for missing cells, text or a wrong unit."""
    if name not in table.colnames:
        return _nan(n)
    col = table[name]
    mask = np.ma.getmaskarray(col)
    if mask.any():
        raise BadSeries(f"light-curve column '{name}' row {int(np.flatnonzero(mask)[0]) + 1} is empty; expected a number in every row")
    try:
        if getattr(col, "unit", None) is not None and unit is not None:
            return np.asarray(u.Quantity(col).to_value(unit), dtype=float)
        return np.asarray(col, dtype=float)
    except (ValueError, TypeError, u.UnitsError) as e:
        raise BadSeries(f"light-curve column '{name}' ({type(e).__name__}: {str(e).splitlines()[0][:100]}); expected numbers in {unit}") from None


def _geometry(table: Table, n: int) -> dict:
    """The geometry columns of ``table`` as LightCurve fields (NaN if absent); BadSeries for half a vector or a non-unit one."""
    out = {}
    for attr, (names, unit) in _GEOMETRY.items():
        present = [c in table.colnames for c in names]
        if any(present) and not all(present):
            raise BadSeries(f"light-curve columns {', '.join(names)}: only {[c for c, p in zip(names, present) if p]}: expected all or none")
        value = np.stack([_column(table, c, unit, n) for c in names], axis=-1)
        known = np.isfinite(value)
        if np.any(known.any(axis=-1) != known.all(axis=-1)):
            k = int(np.flatnonzero(known.any(axis=-1) != known.all(axis=-1))[0])
            raise BadSeries(f"light-curve columns {', '.join(names)} row {k + 1}: {value[k].tolist()}: expected all numbers or all NaN")
        rows = known.all(axis=-1)
        size = np.linalg.norm(value[rows], axis=-1) if len(names) == 3 else value[rows, 0]
        bad = np.abs(size - 1.0) > 1e-6 if len(names) == 3 else ~(size > 0)
        if bad.any():
            k = int(np.flatnonzero(rows)[np.flatnonzero(bad)[0]])
            expected = "unit vectors (norm 1 within 1e-6)" if len(names) == 3 else "distances > 0"
            raise BadSeries(f"light-curve column {names[0]} row {k + 1}: {float(size[bad][0]):.9g}: expected {expected}")
        out[attr] = value if len(names) == 3 else value[:, 0]
    return out


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
        **_geometry(table, n),
    )


#: A decimal number as observers write it: optional sign, digits with an optional point, optional exponent.
#: Python's ``float`` also takes ``0x10``-like, ``1_000``, ``nan`` and ``inf`` text; a light curve must not.
_DECIMAL = re.compile(r"^[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?$")


class DuplicateTimesWarning(UserWarning):
    """Rows of an observer's CSV at the same time were merged into one sample."""


def _numbers(name: str, column, where: str) -> np.ndarray:
    """A CSV column of text cells as floats: every cell a decimal number (no empty cell, no hex, no NaN/inf)."""
    mask = np.ma.getmaskarray(column)
    if mask.any():
        raise BadSeries(f"{where}: column '{name}' row {int(np.flatnonzero(mask)[0]) + 1} is empty; expected a decimal number in every row")
    text = [str(c).strip() for c in np.asarray(column)]
    for i, c in enumerate(text):
        if not _DECIMAL.match(c):
            raise BadSeries(f"{where}: column '{name}' row {i + 1} holds {c[:40]!r}; expected a decimal number like 9.75 or 1.2e-3")
    values = np.array([float(c) for c in text])
    if not np.all(np.isfinite(values)):
        k = int(np.flatnonzero(~np.isfinite(values))[0])
        raise BadSeries(f"{where}: column '{name}' row {k + 1} holds {text[k][:40]!r}, beyond a finite float; expected a finite number")
    return values


def merge_duplicate_times(t, mag, mag_err=None):
    """Merge samples at equal times (``t`` sorted) into one: the inverse-variance weighted mean, in magnitudes.

    The mean is taken directly in magnitudes with weights ``w_i = 1/σ_i²``
    (``σ_i`` = ``mag_err``): ``m = Σ w_i m_i / Σ w_i``, ``σ = (Σ w_i)^(-1/2)``.
    Over a group of equal times the brightness varies little, so the mean in
    magnitudes and the magnitude of the mean flux agree to second order in the
    scatter. Without errors (``mag_err`` None or NaN) the weights are equal
    (the plain mean) and the error stays unknown (NaN). Returns ``(t, mag,
    mag_err, n_merged)`` with ``n_merged`` the number of rows removed.
    """
    t = np.asarray(t, float)
    mag = np.asarray(mag, float)
    err = np.full_like(mag, np.nan) if mag_err is None else np.asarray(mag_err, float)
    keys, counts = np.unique(t, return_counts=True)
    if keys.size == t.size:
        return t, mag, (None if mag_err is None else err), 0
    known = np.all(np.isfinite(err) & (err > 0))
    w = 1.0 / err**2 if known else np.ones_like(mag)
    group = np.repeat(np.arange(keys.size), counts)  # t is sorted: groups are runs of equal times
    wsum = np.bincount(group, weights=w)
    m = np.bincount(group, weights=w * mag) / wsum
    e = wsum**-0.5 if known else np.full(keys.size, np.nan)
    return keys, m, (None if mag_err is None else e), int(t.size - keys.size)


def _first_bad_time(cells: list[str], time_format: str | None) -> str:
    """Which cell of a time column failed to parse (for the message), e.g. ``row 3 holds 'nan'``."""
    for i, c in enumerate(cells):
        try:
            if _DECIMAL.match(c):
                Time(float(c), format=time_format or "unix", scale="utc")
            else:
                Time(c, format="isot", scale="utc")
        except (ValueError, TypeError):
            return f"row {i + 1} holds {c[:40]!r}"
    return "mixes ISO 8601 text and numbers"


def _csv_table(path: Path) -> Table:
    """The CSV's cells as text, columns named in lower case: checked for NUL bytes, UTF-8, one header with 'time' and 'mag', rows."""
    data = path.read_bytes()
    nul = data.find(b"\x00")
    if nul >= 0:
        raise BadSeries(f"{path.name}: NUL byte at offset {nul}; expected a text CSV with a header 'time,mag[,mag_err]'")
    try:
        text = data.decode("utf-8-sig")
    except UnicodeDecodeError as e:
        raise BadSeries(f"{path.name}: not UTF-8 text (byte {e.start}); expected a text CSV with a header 'time,mag[,mag_err]'") from None
    try:
        table = Table.read(text.splitlines(), format="ascii.csv", guess=False, converters={"*": [convert_numpy(str)]})
    except Exception as e:  # astropy's reader raises several types for malformed text
        first = (str(e).splitlines() or [type(e).__name__])[0]
        raise BadSeries(f"{path.name}: malformed CSV ({first}); expected a header 'time,mag[,mag_err]' and one row per sample") from None
    cols = [c.strip().lower() for c in table.colnames]
    if len(set(cols)) != len(cols):
        raise BadSeries(f"{path.name}: CSV header repeats a column ({cols}); expected 'time,mag[,mag_err]' once each")
    table.rename_columns(table.colnames, cols)
    if "time" not in cols or "mag" not in cols:
        raise BadSeries(f"{path.name}: CSV header must contain 'time' and 'mag' (optionally 'mag_err'), got {cols}")
    if len(table) == 0:
        raise BadSeries(f"{path.name}: CSV has a header but no rows; expected one row per sample")
    return table


def _csv_times(raw, where: str, time_format: str | None, meta: dict) -> Time:
    """The CSV's time column as UTC times: ISO 8601 text, or numbers in ``time_format`` (``None``: relative seconds, noted in ``meta``)."""
    if np.ma.getmaskarray(raw).any():
        raise BadSeries(f"{where}: column 'time' row {int(np.flatnonzero(np.ma.getmaskarray(raw))[0]) + 1} is empty; expected a time in every row")
    cells = [str(c).strip() for c in np.asarray(raw)]
    try:
        if not all(_DECIMAL.match(c) for c in cells):
            return Time(cells, format="isot", scale="utc")
        values = _numbers("time", raw, where)
        if time_format is not None:
            return Time(values, format=time_format, scale="utc")
        if np.abs(values).max() > 1e10:
            raise BadSeries(f"{where}: column 'time' reaches {np.abs(values).max():g} s; expected relative seconds within 1e10")
        meta["time_origin"] = "relative seconds (no absolute epoch in the CSV)"
        return Time("2000-01-01T12:00:00", scale="utc") + values * u.s
    except (ValueError, TypeError) as e:
        if isinstance(e, BadSeries):
            raise
        raise BadSeries(f"{where}: column 'time' {_first_bad_time(cells, time_format)}; expected ISO 8601 UTC like "
                        f"2024-03-21T20:00:00.5 or decimal {time_format or 'seconds'} in every row") from None


def read_csv(path, time_format: str | None = None) -> LightCurve:
    """An observer's CSV with a header ``time, mag[, mag_err]``.

    ``time`` is ISO 8601 UTC text, or numbers: seconds from the first sample
    (``time_format=None``) or ``"mjd"``, ``"jd"``, ``"unix"``. Every cell must
    be given (an empty cell is an error, not 0) and be a plain decimal number
    (no ``0x10``, ``nan``, ``inf``). Rows at the same time are merged by
    :func:`merge_duplicate_times` with one :class:`DuplicateTimesWarning`.
    """
    path = Path(path)
    table = _csv_table(path)
    mag = _numbers("mag", table["mag"], path.name)
    mag_err = _numbers("mag_err", table["mag_err"], path.name) if "mag_err" in table.colnames else None
    meta = dict(table.meta)
    time = _csv_times(table["time"], path.name, time_format, meta)
    t_s = (time - time[0]).to_value(u.s)
    if np.any(np.diff(t_s) < 0):
        k = int(np.flatnonzero(np.diff(t_s) < 0)[0])
        raise BadSeries(f"{path.name}: time is not increasing (row {k + 2} comes before row {k + 1}); expected rows in time order")
    _, mag, mag_err, n_merged = merge_duplicate_times(t_s, mag, mag_err)
    if n_merged:
        keep = np.concatenate([[True], np.diff(t_s) > 0])
        time = time[keep]
        weighting = "inverse-variance weights 1/mag_err^2" if mag_err is not None and np.all(np.isfinite(mag_err)) else "equal weights (no mag_err)"
        warnings.warn(f"{path.name}: {n_merged} row(s) share a time with another row; merged each group into one sample, "
                      f"the weighted mean in magnitudes ({weighting})", DuplicateTimesWarning, stacklevel=2)
    out = Table({"time": time, "mag": mag}, meta=meta)
    if mag_err is not None:
        out["mag_err"] = mag_err
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
