"""Fuzzing the light-curve readers (observer CSV, ECSV) with hypothesis, and the duplicate-time merge.

Property of :func:`lightcurves.io.read_lightcurve` on any file: it either
returns a light curve an analysis can use (finite magnitudes, strictly
increasing finite times, at least ``MIN_SAMPLES`` samples, positive errors or
none) or raises :class:`lightcurves.BadSeries` — never another exception,
never a silently repaired value (an empty cell is not 0, ``0x10`` is not 16).
"""

import math
import warnings

import astropy.units as u
import numpy as np
import pytest
from astropy.time import Time
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from lightcurves import BadSeries
from lightcurves.io import DuplicateTimesWarning, LightCurve, merge_duplicate_times, read_lightcurve, to_timeseries
from lightcurves.samples import MIN_SAMPLES

SETTINGS = settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow], derandomize=True)


def check_usable(lc: LightCurve) -> None:
    t = lc.t_s
    assert len(lc) >= MIN_SAMPLES and np.all(np.isfinite(lc.mag)) and np.all(np.isfinite(t)) and np.all(np.diff(t) > 0)
    assert np.all(np.isnan(lc.mag_err)) or np.all(np.isfinite(lc.mag_err) & (lc.mag_err > 0))


def read_or_bad(path):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DuplicateTimesWarning)
        try:
            lc = read_lightcurve(path)
        except BadSeries as e:
            assert "\n" not in str(e) and "np.str_" not in str(e)
            return None
    check_usable(lc)
    return lc


cells = st.one_of(st.sampled_from(["", " ", "nan", "NaN", "inf", "0x10", "1_0", "1e999", "1e", "abc", "2024-03-21T20:00:00", "\x00", '"7"', "+.5"]),
                  st.floats(-1e4, 1e4).map(lambda x: f"{x:.5g}"), st.integers(0, 10**5).map(str))


@st.composite
def csvs(draw):
    header = draw(st.sampled_from(["time,mag", "time,mag,mag_err", " Time ,MAG", "time,mag,mag", "mag,time", "time;mag", ""]))
    n = draw(st.integers(0, 45))
    width = max(1, header.count(",") + 1)
    mutate = draw(st.integers(0, 3))
    rows = []
    for i in range(n):
        row = [f"{2.0 * i:g}", f"{9 + np.sin(0.7 * i):.4f}", "0.02"][:width]
        if mutate and draw(st.integers(0, 10)) == 0:
            row[draw(st.integers(0, width - 1))] = draw(cells)
        rows.append(",".join(row))
    return header + "\n" + "\n".join(rows) + "\n"


@SETTINGS
@given(text=csvs())
def test_csv_reader_usable_or_badseries(tmp_path, text):
    path = tmp_path / "lc.csv"
    path.write_bytes(text.encode("utf-8", "surrogatepass"))
    lc = read_or_bad(path)
    if lc is not None:  # every accepted magnitude is one written in the file (or, for rows at one time, their mean): none invented
        rows = [line.split(",") for line in text.splitlines()[1:] if line.strip()]
        written = [float(r[1]) for r in rows]
        if len({r[0] for r in rows}) == len(rows):
            assert set(np.round(lc.mag, 9)) <= {round(w, 9) for w in written}
        assert min(written) - 1e-9 <= lc.mag.min() and lc.mag.max() <= max(written) + 1e-9


@SETTINGS
@given(data=st.binary(max_size=300), suffix=st.sampled_from([".csv", ".ecsv"]))
def test_random_bytes_usable_or_badseries(tmp_path, data, suffix):
    path = tmp_path / f"lc{suffix}"
    path.write_bytes(data)
    read_or_bad(path)


def _ecsv_text(n=40) -> str:
    t = np.arange(n) * 2.0
    mag = 9 + 0.5 * np.sin(0.3 * t)
    lc = LightCurve(time=Time("2024-03-21T20:00:00", scale="utc") + t * u.s, mag=mag, mag_err=np.full(n, 0.02), flux_w_m2=np.full(n, 1e-12),
                    phase_angle_rad=np.full(n, 0.5), range_m=np.full(n, 2e7), elevation_rad=np.full(n, 0.9), meta={"seed": 1})
    import io

    buf = io.StringIO()
    to_timeseries(lc).write(buf, format="ascii.ecsv")
    return buf.getvalue()


ECSV = _ecsv_text()


@SETTINGS
@given(edits=st.lists(st.tuples(st.integers(0, len(ECSV) - 1), st.integers(0, 20),
                                st.sampled_from(["", "x", "nan", "-", "\n", "0x10", " ", "string", "1e999", "#"])),
                      min_size=1, max_size=4))
def test_ecsv_mutations_usable_or_badseries(tmp_path, edits):
    text = ECSV
    for pos, length, new in edits:
        text = text[:pos] + new + text[pos + length:]
    path = tmp_path / "lc.ecsv"
    path.write_text(text)
    read_or_bad(path)


def test_empty_cell_is_refused_not_zero(tmp_path):
    path = tmp_path / "lc.csv"
    path.write_text("time,mag\n" + "".join(f"{k},{9 + np.sin(k):.3f}\n" for k in range(30)) + "30,\n")
    with pytest.raises(BadSeries, match=r"column 'mag' row 31: empty: expected"):
        read_lightcurve(path)


@pytest.mark.parametrize("cell", ["0x10", "1_0", "nan", "inf", "ten"])
def test_non_decimal_cell_is_refused(tmp_path, cell):
    path = tmp_path / "lc.csv"
    path.write_text("time,mag\n" + "".join(f"{k},{9 + np.sin(k):.3f}\n" for k in range(30)) + f"30,{cell}\n")
    with pytest.raises(BadSeries, match=rf": '{cell}': expected a decimal number"):
        read_lightcurve(path)


def test_header_only_and_nul_are_refused(tmp_path):
    path = tmp_path / "lc.csv"
    path.write_text("time,mag\n")
    with pytest.raises(BadSeries, match="a header but no rows"):
        read_lightcurve(path)
    path.write_bytes(b"time,mag\n0,1\x00\n")
    with pytest.raises(BadSeries, match="NUL byte at offset 12"):
        read_lightcurve(path)


def test_duplicate_times_merge_inverse_variance_analytically(tmp_path):
    """Two rows at t = 10 s with (m1, s1), (m2, s2) become m = (m1/s1² + m2/s2²)/(1/s1² + 1/s2²), s = (1/s1² + 1/s2²)^-1/2."""
    m1, s1, m2, s2 = 9.30, 0.02, 9.50, 0.04
    rows = [(k, 9 + 0.4 * math.sin(k), 0.03) for k in range(30) if k != 10] + [(10, m1, s1), (10, m2, s2)]
    rows.sort(key=lambda r: r[0])
    path = tmp_path / "lc.csv"
    path.write_text("time,mag,mag_err\n" + "".join(f"{t},{m!r},{s!r}\n" for t, m, s in rows))
    with pytest.warns(DuplicateTimesWarning, match=r"1 row\(s\) share a time") as record:
        lc = read_lightcurve(path)
    assert len(record) == 1
    w1, w2 = s1**-2, s2**-2
    k = int(np.flatnonzero(np.isclose(lc.t_s, 10.0))[0])
    assert len(lc) == 30
    assert lc.mag[k] == pytest.approx((w1 * m1 + w2 * m2) / (w1 + w2), rel=1e-12)  # 9.34
    assert lc.mag_err[k] == pytest.approx((w1 + w2) ** -0.5, rel=1e-12)  # 0.01789
    assert lc.mag[k] == pytest.approx(9.34, abs=1e-12)


def test_duplicate_times_without_errors_take_the_plain_mean():
    t, m, e, n = merge_duplicate_times([0.0, 1.0, 1.0, 1.0, 2.0], [1.0, 2.0, 3.0, 7.0, 5.0])
    np.testing.assert_array_equal(t, [0.0, 1.0, 2.0])
    np.testing.assert_allclose(m, [1.0, 4.0, 5.0])
    assert e is None and n == 2


@SETTINGS
@given(sig=st.lists(st.floats(1e-3, 1.0), min_size=2, max_size=6), mags=st.lists(st.floats(5, 15), min_size=6, max_size=6))
def test_merge_is_the_minimum_variance_unbiased_combination(sig, mags):
    """For any group: the merged error is below the smallest input error, and the mean lies within the inputs' range."""
    k = len(sig)
    t, m, e, n = merge_duplicate_times(np.zeros(k), mags[:k], sig)
    w = 1.0 / np.asarray(sig) ** 2
    assert n == k - 1 and m[0] == pytest.approx(np.sum(w * mags[:k]) / w.sum(), rel=1e-12)
    assert e[0] <= min(sig) + 1e-15 and e[0] == pytest.approx(w.sum() ** -0.5, rel=1e-12)
    assert min(mags[:k]) - 1e-9 <= m[0] <= max(mags[:k]) + 1e-9
