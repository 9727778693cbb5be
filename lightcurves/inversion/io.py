"""Light curves with geometry for inversion: DAMIT/convexinv text, lcnav ECSV and observers' CSV -> :class:`InversionCurve`.

Pure: functions take a path or text and return records; :func:`damit_text` returns text, it writes nothing.

DAMIT / convexinv light-curve format (Ďurech, Sidorin & Kaasalainen, *DAMIT: a database of asteroid
models*, A&A 513, A46 (2010); the input of Kaasalainen & Torppa's convex inversion, Icarus 153 (2001))::

    2                                  number of light curves
    3 0                                points in curve 1, flag: 0 relative, 1 calibrated
    JD  brightness  xs ys zs  xo yo zo  one line per point
    ...

* ``JD``: Julian date of the light's emission at the object, i.e. the observation time minus the
  light time Δ/c ("light-time corrected"). The format names no time scale; observers give UTC and so
  do we (``time_scale``, default ``"utc"``). Reading adds Δ/c back (``Δ`` = length of the observer
  vector), so :attr:`InversionCurve.t_s` are observation times; writing subtracts it.
* ``brightness``: intensity (linear, not magnitudes). Relative curves: any positive scale per curve.
  Calibrated curves: we take the convention of DAMIT's calibrated (sparse) data, the intensity
  ``10^(−0.4 m_red)`` of the magnitude reduced to unit distances, ``m_red = m − 5 log₁₀(r Δ)``
  (``r``, ``Δ`` in au). So the flux at the observer is ``F = F(m=0) · brightness / (r Δ)²`` with
  ``F(m=0)`` from :func:`lightcurves.render.mag_to_flux` (V, Sun = −26.74 at 1361 W/m²).
* ``xs ys zs``, ``xo yo zo``: vectors from the object to the Sun and to the observer (Earth), in au,
  ecliptic J2000 (:mod:`~lightcurves.inversion.frames`); their lengths are ``r`` and ``Δ``.
* σ is not in the format: each point gets ``sigma_rel`` × brightness (default 1 %, the typical
  photometric accuracy of the data DAMIT holds).

Bad input raises :class:`~lightcurves.samples.BadSeries` (a ``ValueError``) with the message form
``<file or field>: <value>: expected <form>``.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import astropy.units as u
import numpy as np
from astropy.constants import c as _c
from astropy.io.ascii import convert_numpy
from astropy.table import Table
from astropy.time import Time
from erfa import ErfaWarning

from lightcurves.inversion.data import InversionCurve
from lightcurves.inversion.frames import I_to_ecliptic, ecliptic_to_I
from lightcurves.io import _DECIMAL, LightCurve, read_lightcurve
from lightcurves.render import AU_M, mag_to_flux
from lightcurves.samples import BadSeries

__all__ = ["DEFAULT_SIGMA_REL", "read_damit", "damit_text", "from_lightcurve", "read_geometry_csv", "read_inversion_curves"]

#: Relative 1-σ of a brightness when the file gives none (DAMIT text; CSV without errors).
DEFAULT_SIGMA_REL = 0.01
_C_M_S = _c.to_value(u.m / u.s)
_TIME_SCALES = ("utc", "tt", "tdb")
#: σ of a flux from σ of a magnitude: σ_F = 0.4 ln 10 · F · σ_m (first-order propagation of F = F0 10^(−0.4 m)).
_MAG_TO_FLUX_SIGMA = 0.4 * np.log(10.0)
#: Julian dates accepted (1858-11-16 to 2132-08-31): photographic-era photometry to planned nights; ERFA refuses far beyond.
_JD_RANGE = (2_400_000.0, 2_500_000.0)
#: Lengths of the object -> Sun and object -> observer vectors accepted, au (15 cm, a chaser close to its target, to 10⁴ au: no under/overflow in (r Δ)²).
_DISTANCE_AU = (1e-12, 1e4)
#: Suffixes read as DAMIT text by :func:`read_inversion_curves`.
_DAMIT_SUFFIXES = (".txt", ".lcs", ".dat")


def _source(path_or_text) -> tuple[str, str]:
    """(name for messages, text): a ``Path``, or a ``str`` with a line break (text), or a ``str`` path."""
    if isinstance(path_or_text, str) and "\n" in path_or_text:
        return "DAMIT text", path_or_text
    path = Path(path_or_text)
    data = path.read_bytes()
    nul = data.find(b"\x00")
    if nul >= 0:
        raise BadSeries(f"{path.name}: NUL byte at offset {nul}: expected a text file")
    try:
        return path.name, data.decode("utf-8-sig")
    except UnicodeDecodeError as e:
        raise BadSeries(f"{path.name}: byte {e.start} is not UTF-8: expected a text file") from None


_DISTANCE_FORM = f"a vector from the object of length within [{_DISTANCE_AU[0]:g}, {_DISTANCE_AU[1]:g}] au"


def _first_bad_distance(d: np.ndarray) -> int | None:
    """Index of the first distance (au) outside ``_DISTANCE_AU``, or None."""
    bad = (d < _DISTANCE_AU[0]) | (d > _DISTANCE_AU[1])
    return int(np.flatnonzero(bad)[0]) if bad.any() else None


def _record(**fields) -> InversionCurve:
    """An InversionCurve; its own checks (e.g. a calibrated brightness overflowing to inf) raise BadSeries naming the curve."""
    try:
        return InversionCurve(**fields)
    except ValueError as e:
        raise BadSeries(f"{fields.get('name', '')}: {e}") from None


def _check_sigma_rel(sigma_rel: float) -> None:
    if not (np.isfinite(sigma_rel) and 0 < sigma_rel < 1):
        raise BadSeries(f"sigma_rel: {sigma_rel!r}: expected a relative 1-sigma within (0, 1)")


def _check_time_scale(time_scale: str) -> None:
    if time_scale not in _TIME_SCALES:
        raise BadSeries(f"time_scale: {time_scale!r}: expected one of {', '.join(_TIME_SCALES)}")


class _Lines:
    """The non-blank lines of a text with their 1-based line numbers (DAMIT files may separate curves by blank lines)."""

    def __init__(self, where: str, text: str):
        self.where = where
        self.items = [(k + 1, line.split()) for k, line in enumerate(text.splitlines()) if line.strip()]
        self.pos = 0

    def next(self, expected: str) -> tuple[int, list[str]]:
        if self.pos >= len(self.items):
            raise BadSeries(f"{self.where}: end of text after line {self.items[-1][0] if self.items else 0}: expected {expected}")
        self.pos += 1
        return self.items[self.pos - 1]

    def integers(self, n: int, expected: str) -> tuple[int, list[int]]:
        k, words = self.next(expected)
        if len(words) != n or not all(w.isascii() and w.lstrip("+").isdigit() for w in words):
            raise BadSeries(f"{self.where} line {k}: {' '.join(words)[:60]!r}: expected {expected}")
        return k, [int(w) for w in words]


def _rows(lines: _Lines, n: int, curve: int) -> tuple[np.ndarray, list[int]]:
    """``n`` data lines of 8 decimal numbers each, (n, 8), and their line numbers."""
    form = "8 decimal numbers 'JD brightness xs ys zs xo yo zo'"
    out = np.empty((n, 8))
    numbers = []
    for i in range(n):
        k, words = lines.next(f"{n} rows of curve {curve} ({i} found): {form}")
        numbers.append(k)
        if len(words) != 8 or not all(_DECIMAL.match(w) for w in words):
            raise BadSeries(f"{lines.where} line {k}: {' '.join(words)[:80]!r}: expected {form}")
        out[i] = [float(w) for w in words]
        if not np.isfinite(out[i]).all():
            raise BadSeries(f"{lines.where} line {k}: {' '.join(words)[:80]!r}: expected finite numbers")
    return out, numbers


def _curve_from_rows(rows: np.ndarray, calibrated: bool, *, where: str, line: list[int], sigma_rel: float, time_scale: str, name: str) -> InversionCurve:
    """One DAMIT curve (rows ``JD b xs ys zs xo yo zo``) as an InversionCurve (see the module docstring)."""
    sun_E, obs_E = rows[:, 2:5], rows[:, 5:8]
    r_au, delta_au = np.linalg.norm(sun_E, axis=1), np.linalg.norm(obs_E, axis=1)
    for label, d in (("Sun vector", r_au), ("observer vector", delta_au)):
        k = _first_bad_distance(d)
        if k is not None:
            raise BadSeries(f"{where} line {line[k]}: {label} of length {float(d[k]):g} au: expected {_DISTANCE_FORM}")
    b = rows[:, 1]
    if np.any(b <= 0):
        k = int(np.flatnonzero(b <= 0)[0])
        raise BadSeries(f"{where} line {line[k]}: brightness {float(b[k])!r}: expected an intensity > 0")
    jd = rows[:, 0]
    if np.any((jd < _JD_RANGE[0]) | (jd > _JD_RANGE[1])):
        k = int(np.flatnonzero((jd < _JD_RANGE[0]) | (jd > _JD_RANGE[1]))[0])
        raise BadSeries(f"{where} line {line[k]}: JD {float(jd[k])!r}: expected a Julian date within [{_JD_RANGE[0]:.0f}, {_JD_RANGE[1]:.0f}]")
    with warnings.catch_warnings():  # UTC before 1960 is ERFA's "dubious year": such old photometry is read as given
        warnings.simplefilter("ignore", ErfaWarning)
        emitted = Time(jd, format="jd", scale=time_scale)
        observed = (emitted + delta_au * (AU_M / _C_M_S) * u.s).utc  # undo the light-time correction
    epoch = observed[0]
    t_s = (observed - epoch).to_value(u.s)
    if np.any(np.diff(t_s) < 0):
        k = int(np.flatnonzero(np.diff(t_s) < 0)[0]) + 1
        raise BadSeries(f"{where} line {line[k]}: JD {float(rows[k, 0])!r} before the previous row: expected rows in time order")
    with np.errstate(over="ignore"):  # an overflow to inf is refused by the record's checks (_record)
        brightness = mag_to_flux(0.0) * b / (r_au * delta_au) ** 2 if calibrated else b
    return _record(
        t_s=t_s, epoch=epoch, brightness=brightness, sigma=sigma_rel * brightness,
        sun_dir_I=ecliptic_to_I(sun_E / r_au[:, None]), observer_dir_I=ecliptic_to_I(obs_E / delta_au[:, None]),
        sun_distance_m=r_au * AU_M, range_m=delta_au * AU_M, calibrated=calibrated, name=name,
        meta={"source": where, "format": "damit", "time_scale": time_scale, "sigma": f"{sigma_rel:g} x brightness (not in the format)"},
    )  # fmt: skip


def read_damit(path_or_text, *, sigma_rel: float = DEFAULT_SIGMA_REL, time_scale: str = "utc") -> list[InversionCurve]:
    """The light curves of a DAMIT/convexinv ``lcs`` file (a path) or text (a ``str`` holding line breaks).

    Format, units and conventions: see the module docstring. Each point's σ is ``sigma_rel`` ×
    brightness; ``time_scale`` is the scale of the JDs (``"utc"``, ``"tt"`` or ``"tdb"``). Curves are
    named ``<source>#<k>`` (k from 1). Refused with :class:`BadSeries`: a first line other than one
    positive integer, a curve header other than ``N FLAG`` (N ≥ 3, FLAG 0 or 1), fewer rows than
    announced or lines left over, a row other than 8 finite decimal numbers, a zero Sun or observer
    vector, a brightness ≤ 0, rows out of time order.
    """
    _check_sigma_rel(sigma_rel)
    _check_time_scale(time_scale)
    where, text = _source(path_or_text)
    lines = _Lines(where, text)
    _, (n_curves,) = lines.integers(1, "the number of light curves, one integer >= 1")
    if n_curves < 1:
        raise BadSeries(f"{where} line {lines.items[0][0]}: {n_curves}: expected the number of light curves, one integer >= 1")
    curves = []
    for j in range(1, n_curves + 1):
        form = f"the header of curve {j} of {n_curves}: 'N FLAG', N >= 3 points and FLAG 0 (relative) or 1 (calibrated)"
        k, (n, flag) = lines.integers(2, form)
        if n < 3 or flag not in (0, 1):
            raise BadSeries(f"{where} line {k}: '{n} {flag}': expected {form}")
        rows, numbers = _rows(lines, n, j)
        curves.append(_curve_from_rows(rows, bool(flag), where=where, line=numbers, sigma_rel=sigma_rel,
                                       time_scale=time_scale, name=f"{where}#{j}"))  # fmt: skip
    if lines.pos < len(lines.items):
        k, words = lines.items[lines.pos]
        raise BadSeries(f"{where} line {k}: {' '.join(words)[:60]!r} after the {n_curves} announced curve(s): expected the end of the text "
                        "(is the count on the first line right?)")
    return curves


def _damit_rows(curve: InversionCurve, time_scale: str) -> np.ndarray:
    """(N, 8) rows ``JD b xs ys zs xo yo zo`` of a curve (the inverse of :func:`_curve_from_rows`)."""
    r_au, delta_au = curve.sun_distance_m / AU_M, curve.range_m / AU_M
    emitted = getattr(curve.epoch + (curve.t_s - delta_au * (AU_M / _C_M_S)) * u.s, time_scale)
    b = curve.brightness * (r_au * delta_au) ** 2 / mag_to_flux(0.0) if curve.calibrated else curve.brightness
    sun_E = I_to_ecliptic(curve.sun_dir_I) * r_au[:, None]
    obs_E = I_to_ecliptic(curve.observer_dir_I) * delta_au[:, None]
    return np.column_stack([emitted.jd1 + emitted.jd2, b, sun_E, obs_E])


def damit_text(curves, *, time_scale: str = "utc") -> str:
    """DAMIT/convexinv ``lcs`` text of ``curves`` (InversionCurve list): the inverse of :func:`read_damit`.

    JD with 9 decimals (86 µs; a float64 JD resolves 40 µs), brightness and vectors with 10
    significant digits. σ is not written (the format has no place for it).
    """
    curves = list(curves)
    if not curves or not all(isinstance(c, InversionCurve) for c in curves):
        raise BadSeries(f"curves: {len(curves)} item(s): expected a non-empty list of InversionCurve")
    _check_time_scale(time_scale)
    out = [f"{len(curves)}"]
    for curve in curves:
        out.append(f"{len(curve)} {int(curve.calibrated)}")
        out.extend(f"{r[0]:.9f} {r[1]:.10e} {r[2]:.10e} {r[3]:.10e} {r[4]:.10e} {r[5]:.10e} {r[6]:.10e} {r[7]:.10e}"
                   for r in _damit_rows(curve, time_scale))  # fmt: skip
    return "\n".join(out) + "\n"


def _flux(mag: np.ndarray, mag_err: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Flux (W/m²) and its 1-σ from magnitudes: ``F = mag_to_flux(m)``, ``σ_F = 0.4 ln10 F σ_m``."""
    flux = mag_to_flux(mag)
    return flux, _MAG_TO_FLUX_SIGMA * flux * mag_err


def from_lightcurve(lc: LightCurve, *, calibrated: bool = True, name: str | None = None) -> InversionCurve:
    """An lcnav :class:`~lightcurves.io.LightCurve` with per-sample geometry as an InversionCurve.

    brightness = flux at the observer from ``mag`` (W/m²), σ_F = 0.4 ln10 F σ_m from ``mag_err``;
    ``calibrated=False`` divides both by the mean flux (a relative curve). Times are the light
    curve's (observation times, UTC). Refused (:class:`BadSeries`, naming the columns) when the
    geometry or ``mag_err`` is unknown (NaN) anywhere.
    """
    name = name or str(lc.meta.get("source", lc.meta.get("target", "")))
    where = f"light curve {name!r}"
    needs = {"sun_dir_I_x/y/z": lc.sun_dir_I, "observer_dir_I_x/y/z": lc.observer_dir_I, "sun_distance": lc.sun_distance_m,
             "range": lc.range_m, "mag_err": lc.mag_err}  # fmt: skip
    missing = [col for col, a in needs.items() if not np.isfinite(a).all()]
    if missing:
        raise BadSeries(f"{where}: columns {', '.join(missing)} unknown (NaN): expected per-sample geometry and errors "
                        "(an ECSV from 'lcnav lightcurve render', or a CSV with sun_x..obs_z columns)")
    flux, sigma = _flux(lc.mag, lc.mag_err)
    scale = 1.0 if calibrated else float(np.mean(flux))
    return _record(
        t_s=lc.t_s, epoch=lc.time[0].utc, brightness=flux / scale, sigma=sigma / scale, sun_dir_I=lc.sun_dir_I,
        observer_dir_I=lc.observer_dir_I, sun_distance_m=lc.sun_distance_m, range_m=lc.range_m, calibrated=calibrated,
        name=name, meta={"format": "lcnav", **_plain_meta(lc.meta)},
    )  # fmt: skip


def _plain_meta(meta: dict) -> dict:
    """The light curve's provenance worth keeping (target, site, epoch), without large items.

    Never a ``truth_*`` key: an inversion curve goes where a prior is built, and the truth must not
    (``tests/studies/test_no_oracle.py``).
    """
    return {k: meta[k] for k in ("source", "target", "site", "epoch") if k in meta}


# ---------------------------------------------------------------- observers' CSV with geometry

_VECTORS = {"sun": ("sun_x", "sun_y", "sun_z"), "obs": ("obs_x", "obs_y", "obs_z")}
_FRAMES = ("ecliptic", "equatorial")


def _csv_cells(path: Path) -> Table:
    """The CSV's cells as text, header names stripped and in lower case."""
    _, text = _source(path)
    try:
        table = Table.read(text.splitlines(), format="ascii.csv", guess=False, converters={"*": [convert_numpy(str)]})
    except Exception as e:  # astropy's reader raises several types for malformed text
        raise BadSeries(f"{path.name}: {(str(e).splitlines() or [type(e).__name__])[0][:80]!r}: expected a CSV with a header row") from None
    names = [c.strip().lower() for c in table.colnames]
    if len(set(names)) != len(names):
        raise BadSeries(f"{path.name}: header {names}: expected each column once")
    table.rename_columns(table.colnames, names)
    need = ["time", *_VECTORS["sun"], *_VECTORS["obs"]]
    if [c for c in need if c not in names] or not ({"mag", "flux"} & set(names)):
        raise BadSeries(f"{path.name}: header {names}: expected columns time, mag or flux, {', '.join(need[1:])} "
                        "(optional mag_err or flux_err, curve, calibrated)")
    if len(table) < 3:
        raise BadSeries(f"{path.name}: {len(table)} row(s): expected at least 3 samples")
    return table


def _decimals(table: Table, name: str, where: str) -> np.ndarray:
    """A column of text cells as finite floats (plain decimal numbers only)."""
    cells = [str(c).strip() for c in np.asarray(table[name])]
    for i, cell in enumerate(cells):
        if np.ma.getmaskarray(table[name])[i] or not _DECIMAL.match(cell):
            raise BadSeries(f"{where} column '{name}' row {i + 1}: {cell[:40]!r}: expected a decimal number like 0.25 or 1.2e-3")
    values = np.array([float(c) for c in cells])
    if not np.isfinite(values).all():
        k = int(np.flatnonzero(~np.isfinite(values))[0])
        raise BadSeries(f"{where} column '{name}' row {k + 1}: {cells[k][:40]!r}: expected a finite number")
    return values


def _csv_times(table: Table, where: str, time_format: str) -> Time:
    cells = [str(c).strip() for c in np.asarray(table["time"])]
    numeric = all(_DECIMAL.match(c) for c in cells)
    values = _decimals(table, "time", where) if numeric else cells
    form = f"ISO 8601 UTC text or decimal {time_format} in every row, Julian dates within [{_JD_RANGE[0]:.0f}, {_JD_RANGE[1]:.0f}]"
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ErfaWarning)
            times = Time(values, format=time_format if numeric else "isot", scale="utc")
    except ValueError:
        raise BadSeries(f"{where} column 'time': {cells[0][:40]!r}...: expected {form}") from None
    outside = (times.jd < _JD_RANGE[0]) | (times.jd > _JD_RANGE[1])
    if outside.any():
        k = int(np.flatnonzero(outside)[0])
        raise BadSeries(f"{where} column 'time' row {k + 1}: {cells[k][:40]!r}: expected {form}")
    return times


def read_geometry_csv(path, *, frame: str = "ecliptic", time_format: str = "jd", calibrated: bool = False,
                      sigma_rel: float = DEFAULT_SIGMA_REL) -> list[InversionCurve]:  # fmt: skip
    """An observer's CSV with geometry columns, one InversionCurve per ``curve`` value (in order of appearance).

    Columns (header names, any case):

    ============================== ==========================================================
    ``time``                       observation time (not light-time corrected), UTC: ISO 8601
                                   text or decimal numbers in ``time_format`` (``"jd"``, ``"mjd"``…)
    ``mag`` or ``flux``            apparent magnitude, or flux (W/m² if calibrated, else any scale)
    ``mag_err`` / ``flux_err``     optional 1-σ (else ``sigma_rel`` × flux)
    ``sun_x, sun_y, sun_z``        vector object -> Sun, in au, axes of ``frame``
    ``obs_x, obs_y, obs_z``        vector object -> observer, in au, axes of ``frame``
    ``curve``                      optional curve label (several curves in one file)
    ``calibrated``                 optional 0/1 per row (constant within a curve; else the option)
    ============================== ==========================================================

    ``frame``: ``"ecliptic"`` (J2000, as DAMIT) or ``"equatorial"`` (J2000 = I). The vectors'
    lengths are the Sun and observer distances.
    """
    path = Path(path)
    if frame not in _FRAMES:
        raise BadSeries(f"frame: {frame!r}: expected one of {', '.join(_FRAMES)}")
    _check_sigma_rel(sigma_rel)
    table, where = _csv_cells(path), path.name
    times = _csv_times(table, where, time_format)
    vec = {key: np.column_stack([_decimals(table, c, where) for c in cols]) for key, cols in _VECTORS.items()}
    if "mag" in table.colnames:
        mag = _decimals(table, "mag", where)
        err = _decimals(table, "mag_err", where) if "mag_err" in table.colnames else np.full(len(mag), np.nan)
        flux, sigma = _flux(mag, err)
    else:
        flux = _decimals(table, "flux", where)
        sigma = _decimals(table, "flux_err", where) if "flux_err" in table.colnames else np.full(len(flux), np.nan)
    sigma = np.where(np.isnan(sigma), sigma_rel * flux, sigma)
    flags = _decimals(table, "calibrated", where) if "calibrated" in table.colnames else np.full(len(flux), float(calibrated))
    labels = [str(c).strip() for c in np.asarray(table["curve"])] if "curve" in table.colnames else [""] * len(flux)
    curves = []
    for label in dict.fromkeys(labels):
        rows = np.flatnonzero(np.array(labels) == label)
        curves.append(_csv_curve(rows, times, flux, sigma, vec, flags, frame=frame, where=where, label=label))
    return curves


def _csv_curve(rows, times: Time, flux, sigma, vec: dict, flags, *, frame: str, where: str, label: str) -> InversionCurve:
    """One curve (the CSV rows ``rows``) as an InversionCurve, with row-numbered messages."""
    name = f"{where}#{label}" if label else where
    if len(rows) < 3:
        raise BadSeries(f"{where} curve {label!r}: {len(rows)} row(s): expected at least 3 samples per curve")
    if np.ptp(flags[rows]) != 0 or flags[rows[0]] not in (0.0, 1.0):
        raise BadSeries(f"{where} column 'calibrated' curve {label!r}: {sorted(set(flags[rows].tolist()))}: expected one value, 0 or 1, per curve")
    for key, what in (("sun", "sun_x..sun_z"), ("obs", "obs_x..obs_z")):
        norm = np.linalg.norm(vec[key][rows], axis=1)
        k = _first_bad_distance(norm)
        if k is not None:
            raise BadSeries(f"{where} columns {what} row {rows[k] + 1}: length {float(norm[k]):g} au: expected {_DISTANCE_FORM}")
    for name_, a in (("flux", flux), ("flux_err or mag_err", sigma)):
        if np.any(a[rows] <= 0):
            k = rows[np.flatnonzero(a[rows] <= 0)[0]]
            raise BadSeries(f"{where} column {name_} row {k + 1}: {float(a[k])!r}: expected a value > 0")
    t = times[rows]
    t_s = (t - t[0]).to_value(u.s)
    if np.any(np.diff(t_s) < 0):
        k = rows[np.flatnonzero(np.diff(t_s) < 0)[0] + 1]
        raise BadSeries(f"{where} column 'time' row {k + 1}: before the previous row of curve {label!r}: expected rows in time order")
    to_I = ecliptic_to_I if frame == "ecliptic" else np.asarray
    sun_I, obs_I = to_I(vec["sun"][rows]), to_I(vec["obs"][rows])
    r, d = np.linalg.norm(sun_I, axis=1), np.linalg.norm(obs_I, axis=1)
    return _record(
        t_s=t_s, epoch=t[0], brightness=flux[rows], sigma=sigma[rows], sun_dir_I=sun_I / r[:, None], observer_dir_I=obs_I / d[:, None],
        sun_distance_m=r * AU_M, range_m=d * AU_M, calibrated=bool(flags[rows[0]]), name=name, meta={"source": where, "format": "csv", "frame": frame},
    )  # fmt: skip


def _is_damit(path: Path) -> bool:
    """Sniff: the first non-blank line is one integer (a DAMIT curve count)."""
    with path.open("rb") as f:
        for raw in f:
            if raw.strip():
                return raw.strip().isdigit()
    return False


def read_inversion_curves(path, *, sigma_rel: float = DEFAULT_SIGMA_REL, frame: str = "ecliptic", time_format: str = "jd",
                          calibrated: bool = False, time_scale: str = "utc") -> list[InversionCurve]:  # fmt: skip
    """Light curves with geometry from a file, by kind: ``.ecsv`` (lcnav, calibrated), DAMIT text
    (``.txt``/``.lcs``/``.dat``, or any file whose first line is one integer), ``.csv`` with geometry
    columns (:func:`read_geometry_csv`; ``frame``, ``time_format``, ``calibrated``). ``sigma_rel``
    and ``time_scale`` apply to DAMIT text (:func:`read_damit`), ``sigma_rel`` also to CSV without errors.
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"light-curve file not found: {path}")
    suffix = path.suffix.lower()
    if suffix == ".ecsv":
        return [from_lightcurve(read_lightcurve(path), calibrated=True, name=path.name)]
    if suffix == ".csv":
        return read_geometry_csv(path, frame=frame, time_format=time_format, calibrated=calibrated, sigma_rel=sigma_rel)
    if suffix in _DAMIT_SUFFIXES or _is_damit(path):
        return read_damit(path, sigma_rel=sigma_rel, time_scale=time_scale)
    raise BadSeries(f"{path.name}: suffix {suffix!r}: expected .ecsv (lcnav), .csv with geometry columns, or DAMIT text (.txt, .lcs, .dat)")
