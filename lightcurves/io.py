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
from astropy.table import MaskedColumn, Table
from astropy.time import Time
from astropy.timeseries import TimeSeries

from lightcurves.samples import BadSeries, check_samples

__all__ = ["LightCurve", "DuplicateTimesWarning", "to_timeseries", "from_table", "read_lightcurve", "read_csv", "merge_duplicate_times",
           "read_table", "ambiguous_time_unit", "AmbiguousTimeUnit", "ReaderOptionError", "TIME_FORMATS", "TIME_SCALES", "COLUMN_ROLES"]


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
        raise BadSeries(f"light-curve column '{name}' row {int(np.flatnonzero(mask)[0]) + 1}: empty: expected a number in every row")
    try:
        if getattr(col, "unit", None) is not None and unit is not None:
            return np.asarray(u.Quantity(col).to_value(unit), dtype=float)
        return np.asarray(col, dtype=float)
    except (ValueError, TypeError, u.UnitsError) as e:
        raise BadSeries(f"light-curve column '{name}': not numbers ({type(e).__name__}: {str(e).splitlines()[0][:100]}): expected numbers in {unit}") from None


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
        raise BadSeries(f"light-curve table columns {table.colnames}: no 'time' or no 'mag': expected columns 'time' and 'mag'")
    time = table["time"]
    if not isinstance(time, Time):
        raise BadSeries(f"light-curve column 'time': {type(table['time']).__name__}: expected an astropy Time column")
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
        raise BadSeries(f"{where}: column '{name}' row {int(np.flatnonzero(mask)[0]) + 1}: empty: expected a decimal number in every row")
    text = [str(c).strip() for c in np.asarray(column)]
    for i, c in enumerate(text):
        if not _DECIMAL.match(c):
            raise BadSeries(f"{where}: column '{name}' row {i + 1}: {c[:40]!r}: expected a decimal number like 9.75 or 1.2e-3")
    values = np.array([float(c) for c in text])
    if not np.all(np.isfinite(values)):
        k = int(np.flatnonzero(~np.isfinite(values))[0])
        raise BadSeries(f"{where}: column '{name}' row {k + 1}: {text[k][:40]!r} (beyond a finite float): expected a finite number")
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


#: Formats of a numeric time column: ``"seconds"`` and ``"ms"`` (seconds or milliseconds since any origin: only differences
#: are used) and the numeric formats of astropy ``Time`` (days for ``mjd``/``jd``, seconds since 1970 for ``unix``, ...).
NUMERIC_TIME_FORMATS = ("seconds", "ms", "mjd", "jd", "unix", "unix_tai", "gps", "cxcsec", "decimalyear", "jyear", "byear")
#: Formats of a text time column (astropy ``Time`` string formats): ``isot`` 2024-03-21T20:00:00.5, ``iso`` with a space,
#: ``fits``, ``yday`` 2024:081:20:00:00.5.
TEXT_TIME_FORMATS = ("isot", "iso", "fits", "yday")
TIME_FORMATS = NUMERIC_TIME_FORMATS + TEXT_TIME_FORMATS
#: Time scales a file's times may be in (converted to UTC on reading); ``ut1`` is left out (it needs IERS tables from the network).
TIME_SCALES = ("utc", "tai", "tt", "tdb", "tcg", "tcb")
#: What ``columns=`` may name: the file's column holding each quantity.
COLUMN_ROLES = ("time", "mag", "mag_err", "flux", "flux_err")
#: Suffixes of the tables read with astropy ``Table.read``, and their format.
TABLE_FORMATS = {".fits": "fits", ".fit": "fits", ".fts": "fits", ".vot": "votable", ".votable": "votable", ".xml": "votable"}
#: Where relative times are put on an absolute axis (only differences matter to the spectra and the prior).
_RELATIVE_EPOCH = "2000-01-01T12:00:00"
#: Seconds per unit of the relative formats.
_RELATIVE_UNITS_S = {"seconds": 1.0, "ms": 1e-3}
_UNITS = {"mjd": "days (MJD)", "jd": "days (JD)", "unix": "seconds since 1970 (Unix)", "unix_tai": "TAI seconds since 1970",
          "gps": "seconds since 1980-01-06 (GPS)", "cxcsec": "seconds since 1998 (Chandra)", "decimalyear": "years", "jyear": "Julian years",
          "byear": "Besselian years"}


class ReaderOptionError(ValueError):
    """A reader's option (``time_format``, ``time_scale``, ``columns``) is not one it knows."""


class AmbiguousTimeUnit(BadSeries):
    """A numeric time column whose values or spacing make its unit ambiguous, read without a ``time_format``."""


def ambiguous_time_unit(values) -> str | None:
    """What a numeric time column looks like if seconds are not its obvious unit; ``None`` if it reads plainly as seconds.

    Read as seconds, a column in days or milliseconds gives a spin rate wrong by
    86400× or 1000×, with full confidence. So without a stated format a column
    is refused when (``dt``: the median spacing of consecutive distinct values):

    1. any value exceeds 1e10 in magnitude (317 years of seconds: milliseconds or
       nanoseconds since 1970, or some other unit);
    2. every value lies within [2.2e6, 2.6e6]: Julian Dates (years 1311–2406);
    3. every value lies within [3e4, 1e5] and ``dt < 1``: Modified Julian Dates
       (years 1941–2132) with sub-day spacing, or seconds from an origin 8–28 h
       back with sub-second spacing — it cannot tell which;
    4. every value lies within [3e8, 4.2e9]: Unix seconds (years 1979–2103) or
       another epoch's seconds; the rate would come out right, but the epoch is a guess;
    5. ``dt >= 100``: a tumbling object's light curve is sampled every 0.01–30 s,
       so a spacing of 100 or more looks like milliseconds (1e3× a second).

    ``values``: (N,) finite floats. Returns e.g. ``"looks like MJD (days)"``.
    """
    v = np.asarray(values, dtype=float)
    steps = np.diff(np.unique(v))
    dt = float(np.median(steps)) if steps.size else 0.0
    lo, hi = float(v.min()), float(v.max())
    if max(abs(lo), abs(hi)) > 1e10:
        return f"reaches {max(abs(lo), abs(hi)):.6g}: looks like milliseconds since 1970 or another unit than seconds"
    if 2.2e6 <= lo and hi <= 2.6e6:
        return f"holds {lo:.10g} to {hi:.10g}: looks like JD (days)"
    if 3e4 <= lo and hi <= 1e5 and dt < 1.0:
        return f"holds {lo:.10g} to {hi:.10g} spaced {dt:.3g}: looks like MJD (days)"
    if 3e8 <= lo and hi <= 4.2e9:
        return f"holds {lo:.10g} to {hi:.10g}: looks like Unix time (seconds since 1970) or another epoch"
    if dt >= 100.0:
        return f"is spaced {dt:.6g} (median): looks like milliseconds"
    return None


def _reader_options(time_format, time_scale, columns) -> dict[str, str]:
    """Check ``time_format``/``time_scale``; ``columns`` (role -> the file's column name) completed with the default names."""
    if time_format is not None and time_format not in TIME_FORMATS:
        raise ReaderOptionError(f"time_format: {time_format!r}: expected one of {', '.join(TIME_FORMATS)}")
    if time_scale not in TIME_SCALES:
        raise ReaderOptionError(f"time_scale: {time_scale!r}: expected one of {', '.join(TIME_SCALES)}")
    columns = dict(columns or {})
    bad = [k for k, name in columns.items() if k not in COLUMN_ROLES or not isinstance(name, str) or not name.strip()]
    if bad:
        raise ReaderOptionError(f"columns: {columns!r}: expected a mapping of {', '.join(COLUMN_ROLES)} to column names")
    if "mag" in columns and "flux" in columns:
        raise ReaderOptionError(f"columns: {columns!r}: expected one of mag= or flux=, not both")
    return {role: columns.get(role, role).strip().lower() for role in COLUMN_ROLES} | {"_named": ",".join(sorted(columns))}


def _photometry_roles(table: Table, names: dict, where: str) -> tuple[str, str]:
    """``("mag", "mag_err")`` or ``("flux", "flux_err")``: which brightness the table gives (the mapped one, else mag, else flux)."""
    named = names["_named"].split(",")
    use_flux = "flux" in named or ("mag" not in named and names["mag"] not in table.colnames and names["flux"] in table.colnames)
    value, error = ("flux", "flux_err") if use_flux else ("mag", "mag_err")
    needed = [names["time"], names[value]] + ([names[error]] if error in named else [])
    missing = [c for c in needed if c not in table.colnames]
    if missing:
        hint = "" if "time" in named else "; or name yours, e.g. --columns time=mjd,mag=magnitude,mag_err=err (columns=)"
        raise BadSeries(f"{where}: column(s) {', '.join(repr(c) for c in missing)}: missing (the table has {table.colnames}): "
                        f"expected columns 'time' and 'mag' (optionally 'mag_err'), or 'flux' (optionally 'flux_err'){hint}")
    return value, error


def _first_bad_time(cells: list[str], time_format: str | None, time_scale: str) -> str:
    """Which cell of a time column failed to parse (for the message), e.g. ``row 3: 'nan'``."""
    for i, c in enumerate(cells):
        try:
            if time_format in TEXT_TIME_FORMATS or (time_format is None and not _DECIMAL.match(c)):
                Time(c, format=time_format or "isot", scale=time_scale)
            elif time_format is not None and time_format not in _RELATIVE_UNITS_S:
                Time(float(c), format=time_format, scale=time_scale)
            else:
                float(c)
        except (ValueError, TypeError):
            return f"row {i + 1}: {c[:40]!r}"
    return "mixes ISO 8601 text and numbers"


def _csv_table(path: Path) -> Table:
    """The CSV's cells as text, columns named in lower case: checked for NUL bytes, UTF-8, one header, rows."""
    data = path.read_bytes()
    nul = data.find(b"\x00")
    if nul >= 0:
        raise BadSeries(f"{path.name}: NUL byte at offset {nul}: expected a text CSV with a header 'time,mag[,mag_err]'")
    try:
        text = data.decode("utf-8-sig")
    except UnicodeDecodeError as e:
        raise BadSeries(f"{path.name}: byte {e.start}: not UTF-8: expected a text CSV with a header 'time,mag[,mag_err]'") from None
    try:
        table = Table.read(text.splitlines(), format="ascii.csv", guess=False, converters={"*": [convert_numpy(str)]})
    except Exception as e:  # astropy's reader raises several types for malformed text
        first = (str(e).splitlines() or [type(e).__name__])[0]
        raise BadSeries(f"{path.name}: malformed CSV ({first}): expected a header 'time,mag[,mag_err]' and one row per sample") from None
    cols = [c.strip().lower() for c in table.colnames]
    if len(set(cols)) != len(cols):
        raise BadSeries(f"{path.name}: CSV header {cols}: a column repeats: expected 'time,mag[,mag_err]' once each")
    table.rename_columns(table.colnames, cols)
    return table


def _text_table(table: Table, where: str) -> tuple[Table, set[str]]:
    """A FITS/VOTable table as the CSV reader sees one: every 1-D column as text cells (masks kept), names in lower case.

    Numbers become their shortest round-trip text (``str`` of a float64 reads
    back to the same float), so a table's values reach the checks of the CSV
    cells unchanged; an astropy ``Time`` column becomes ISO 8601 UTC text with
    ns digits. Returns the table and the names of the ``Time`` columns.
    """
    cols = [c.strip().lower() for c in table.colnames]
    if len(set(cols)) != len(cols):
        raise BadSeries(f"{where}: columns {cols}: a name repeats: expected each name once")
    out, times = Table(), set()
    for name, col in zip(cols, table.columns.values()):
        if isinstance(col, Time):
            cells = [str(c) for c in Time(col, precision=9).utc.isot]
            times.add(name)
        elif getattr(col, "ndim", 1) == 1:
            cells = [c.decode("utf-8", "replace") if isinstance(c, bytes) else str(c) for c in np.asarray(col).tolist()]
        else:
            continue  # a vector per row is no light-curve column
        out[name] = MaskedColumn(cells, mask=np.ma.getmaskarray(col), dtype=str) if len(cells) else MaskedColumn(np.zeros(0, dtype=str))
    return out, times


def _relative_times(values: np.ndarray, meta: dict, unit: str, how: str) -> Time:
    """Times ``values`` in ``unit`` (``seconds``/``ms``) since an unknown origin, put on an arbitrary UTC epoch."""
    meta["time_origin"] = "relative seconds (no absolute epoch in the file)"
    meta["time_input"] = f"{unit} since an arbitrary origin ({how})"
    return Time(_RELATIVE_EPOCH, scale="utc") + values * _RELATIVE_UNITS_S[unit] * u.s


def _csv_times(raw, where: str, time_format: str | None, meta: dict, *, time_scale: str = "utc", name: str = "time") -> Time:
    """The time column (text cells) as UTC times; what was assumed is written to ``meta["time_input"]``.

    Text cells are read in ``time_format`` (default ``isot``, ISO 8601); numbers in
    ``time_format`` (:data:`NUMERIC_TIME_FORMATS`), or, without one, as seconds
    since an arbitrary origin unless :func:`ambiguous_time_unit` finds them ambiguous
    (:class:`AmbiguousTimeUnit`). ``time_scale``: the scale the file's times are in.
    """
    mask = np.ma.getmaskarray(raw)
    if mask.any():
        raise BadSeries(f"{where}: column '{name}' row {int(np.flatnonzero(mask)[0]) + 1}: empty: expected a time in every row")
    cells = [str(c).strip() for c in np.asarray(raw)]
    numeric = all(_DECIMAL.match(c) for c in cells)
    try:
        if time_format in TEXT_TIME_FORMATS or (time_format is None and not numeric):
            fmt = time_format or "isot"
            meta["time_input"] = f"column '{name}': {fmt} text, scale {time_scale}"
            return Time(cells, format=fmt, scale=time_scale).utc
        values = _numbers(name, raw, where)
        if time_format is None:
            looks = ambiguous_time_unit(values)
            if looks is not None:
                raise AmbiguousTimeUnit(f"{where}: column '{name}' {looks}: expected its unit named with --time-format (time_format=): "
                                        f"seconds, mjd, jd, unix, ...")
            return _relative_times(values, meta, "seconds", "assumed: no time format given")
        if time_format in _RELATIVE_UNITS_S:
            return _relative_times(values, meta, time_format, f"time format {time_format!r}")
        meta["time_input"] = f"column '{name}': {time_format}, {_UNITS[time_format]}, scale {time_scale}"
        return Time(values, format=time_format, scale=time_scale).utc
    except (ValueError, TypeError) as e:
        if isinstance(e, BadSeries):
            raise
        raise BadSeries(f"{where}: column '{name}' {_first_bad_time(cells, time_format, time_scale)}: expected ISO 8601 like "
                        f"2024-03-21T20:00:00.5 or decimal {time_format or 'seconds'} in every row") from None


def _magnitudes(table: Table, names: dict, where: str, value: str, error: str, meta: dict) -> tuple[np.ndarray, np.ndarray | None]:
    """``(mag, mag_err)`` from the table's magnitudes, or from its fluxes as instrumental magnitudes ``−2.5 log10 F``.

    A flux ``F`` of any unit gives ``m = −2.5 log10 F`` (the zero point is
    unknown and irrelevant to a period) and ``σ_m = (2.5 / ln 10) σ_F / F``
    (first order). A flux ``F ≤ 0`` has no magnitude: refused, naming the row.
    """
    y = _numbers(names[value], table[names[value]], where)
    dy = _numbers(names[error], table[names[error]], where) if names[error] in table.colnames else None
    if value == "mag":
        return y, dy
    if np.any(y <= 0):
        k = int(np.flatnonzero(y <= 0)[0])
        raise BadSeries(f"{where}: column '{names['flux']}' row {k + 1}: {y[k]:g}: expected a flux > 0 (a magnitude is −2.5 log10 of it)")
    meta["mag_from_flux"] = f"instrumental magnitudes -2.5 log10({names['flux']}) (zero point unknown)"
    return -2.5 * np.log10(y), None if dy is None else (2.5 / np.log(10.0)) * dy / y


def _lightcurve_from_cells(table: Table, where: str, time_format, time_scale: str, columns, time_columns=frozenset()) -> LightCurve:
    """The light curve of a table of text cells (:func:`_csv_table`, :func:`_text_table`): checked, converted, duplicates merged."""
    names = _reader_options(time_format, time_scale, columns)
    if len(table) == 0:
        raise BadSeries(f"{where}: a header but no rows: expected one row per sample")
    value, error = _photometry_roles(table, names, where)
    if names["time"] in time_columns:  # already absolute times (ISO text in UTC): a format would contradict them
        if time_format is not None:
            raise ReaderOptionError(f"time_format: {time_format!r}: expected none, column '{names['time']}' of {where} is a time column already")
        time_format, time_scale = "isot", "utc"
    meta = dict(table.meta)
    mag, mag_err = _magnitudes(table, names, where, value, error, meta)
    time = _csv_times(table[names["time"]], where, time_format, meta, time_scale=time_scale, name=names["time"])
    t_s = (time - time[0]).to_value(u.s)
    if np.any(np.diff(t_s) < 0):
        k = int(np.flatnonzero(np.diff(t_s) < 0)[0])
        raise BadSeries(f"{where}: time of row {k + 2}: before row {k + 1}'s, not increasing: expected rows in time order")
    _, mag, mag_err, n_merged = merge_duplicate_times(t_s, mag, mag_err)
    if n_merged:
        time = time[np.concatenate([[True], np.diff(t_s) > 0])]
        weighting = "inverse-variance weights 1/mag_err^2" if mag_err is not None and np.all(np.isfinite(mag_err)) else "equal weights (no mag_err)"
        warnings.warn(f"{where}: {n_merged} row(s) share a time with another row; merged each group into one sample, "
                      f"the weighted mean in magnitudes ({weighting})", DuplicateTimesWarning, stacklevel=3)
    out = Table({"time": time, "mag": mag}, meta=meta)
    if mag_err is not None:
        out["mag_err"] = mag_err
    out.meta["source"] = where
    return from_table(out)


def read_csv(path, time_format: str | None = None, *, time_scale: str = "utc", columns: dict[str, str] | None = None) -> LightCurve:
    """An observer's CSV with a header ``time, mag[, mag_err]`` (or ``flux[, flux_err]``, or the names ``columns`` maps).

    ``time`` is text in a :data:`TEXT_TIME_FORMATS` format (default ISO 8601
    ``isot``), or numbers in ``time_format`` (:data:`NUMERIC_TIME_FORMATS`:
    ``"seconds"`` or ``"ms"`` since any origin, ``"mjd"``/``"jd"`` days, ``"unix"`` seconds
    since 1970, ...), in ``time_scale`` (:data:`TIME_SCALES`, converted to UTC).
    Numbers without a ``time_format`` are seconds since an arbitrary origin
    unless :func:`ambiguous_time_unit` says their values or spacing look like
    another unit (MJD, JD, Unix time, milliseconds): then :class:`AmbiguousTimeUnit`.
    ``columns``: ``{"time": "mjd", "mag": "magnitude", "mag_err": "err"}``, names
    case-insensitive; a ``flux`` column (any unit, > 0) becomes instrumental
    magnitudes ``−2.5 log10 flux``. Every cell must be given (an empty cell is an
    error, not 0) and be a plain decimal number (no ``0x10``, ``nan``, ``inf``).
    Rows at the same time are merged by :func:`merge_duplicate_times` with one
    :class:`DuplicateTimesWarning`. ``meta["time_input"]`` says how the times were read.
    """
    path = Path(path)
    return _lightcurve_from_cells(_csv_table(path), path.name, time_format, time_scale, columns)


def read_table(path, time_format: str | None = None, *, time_scale: str = "utc", columns: dict[str, str] | None = None) -> LightCurve:
    """A FITS (``.fits``, ``.fit``, ``.fts``) or VOTable (``.vot``, ``.votable``, ``.xml``) light curve, read with astropy ``Table.read``.

    The first table of the file, with the columns and options of :func:`read_csv`;
    a time column stored as an astropy ``Time`` (FITS time columns) is read as such
    (then ``time_format`` must be ``None``), a numeric one as in :func:`read_csv`.
    """
    path = Path(path)
    fmt = TABLE_FORMATS.get(path.suffix.lower())
    if fmt is None:
        raise BadSeries(f"{path.name}: not a table file: expected a name ending in {', '.join(TABLE_FORMATS)}")
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # astropy's notes on unknown units or extra HDUs; the columns are checked below
            table = Table.read(path, format=fmt, **({"astropy_native": True} if fmt == "fits" else {}))  # FITS time columns as Time
    except Exception as e:  # astropy's FITS/VOTable readers raise many types for malformed files
        first = (str(e).splitlines() or [type(e).__name__])[0]
        raise BadSeries(f"{path.name}: not a readable {fmt} table ({first[:120]}): expected a table with columns time and mag") from None
    cells, time_columns = _text_table(table, path.name)
    return _lightcurve_from_cells(cells, path.name, time_format, time_scale, columns, frozenset(time_columns))


def read_lightcurve(path, time_format: str | None = None, *, time_scale: str = "utc", columns: dict[str, str] | None = None) -> LightCurve:
    """Read an ECSV light curve (as written from :func:`to_timeseries`), an observer's CSV, or a FITS/VOTable table.

    ``time_format``, ``time_scale``, ``columns``: as in :func:`read_csv`, for CSV
    and table files; an ECSV light curve carries its own time column and units.
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"light-curve file not found: {path}")
    suffix = path.suffix.lower()
    if suffix == ".csv":
        return read_csv(path, time_format, time_scale=time_scale, columns=columns)
    if suffix in TABLE_FORMATS:
        return read_table(path, time_format, time_scale=time_scale, columns=columns)
    if suffix != ".ecsv":
        raise BadSeries(f"{path.name}: not a light-curve file: expected a name ending in .ecsv, .csv, {', '.join(TABLE_FORMATS)}")
    if time_format is not None or columns:
        raise ReaderOptionError(f"time_format/columns: {time_format!r}/{columns!r}: expected none for an ECSV light curve "
                                f"({path.name} carries its own time column and units)")
    try:
        ts = TimeSeries.read(path, format="ascii.ecsv")
    except Exception as e:  # malformed header/body
        raise BadSeries(f"{path.name}: not a readable ECSV light curve ({str(e).splitlines()[0]})") from None
    lc = from_table(ts)
    lc.meta.setdefault("time_input", "ECSV time column (astropy Time), UTC")
    return lc
