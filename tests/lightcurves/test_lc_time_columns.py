"""Time units and column names that cannot fool the prior: ``--time-format``, ``--columns``, flux, FITS and VOTable.

Read as seconds, times in days or milliseconds scale the extracted rate by 1/86400
or 1000 with full confidence (issue 30: an MJD file gave 432424.76 deg/s,
``significant: true``). Each test here checks the rate recovered (an analytic
truth: the curve is built at a known rate) or the refusal of an ambiguous column.
"""

import json

import astropy.units as u
import numpy as np
import pytest
from astropy.table import Table
from astropy.time import Time

from lightcurves import BadSeries
from lightcurves.io import (TABLE_FORMATS, AmbiguousTimeUnit, ReaderOptionError, ambiguous_time_unit, read_csv, read_lightcurve,
                            read_table)
from studies.cli import main
from studies.cli.lightcurve import LIGHTCURVE_SUFFIXES

RATE_DEG_S = 4.0
START = Time("2024-03-21T20:00:00", scale="utc")


def curve(n=200, seed=0):
    """``(t_s, mag, mag_err)``: a double-peaked light curve of a body spinning at RATE_DEG_S, 300 s, uneven."""
    rng = np.random.default_rng(seed)
    t = np.sort(rng.uniform(0, 300, n))
    t -= t[0]  # seconds since the first sample, as LightCurve.t_s
    f = RATE_DEG_S / 360.0
    mag = 9 + 0.6 * np.cos(2 * np.pi * 2 * f * t) + 0.2 * np.cos(2 * np.pi * f * t) + rng.normal(0, 0.02, n)
    return t, mag, np.full(n, 0.02)


def write_csv(path, header, rows):
    path.write_text(header + "\n" + "".join(",".join(repr(float(c)) for c in row) + "\n" for row in zip(*rows)))
    return path


def prior_json(capsys, argv):
    assert main(["lightcurve", "prior", *argv, "--json"]) == 0, capsys.readouterr().err
    return json.loads(capsys.readouterr().out)


def refused(capsys, argv) -> str:
    assert main(["lightcurve", "prior", *argv]) == 2
    captured = capsys.readouterr()
    err = captured.err.strip()
    assert err.startswith("lcnav: error:") and "\n" not in err and captured.out == ""
    return err


@pytest.mark.parametrize("values, looks", [
    (60000.0 + np.arange(50) * 1e-4, "MJD"),  # 8.6 s spacing in days
    (2460000.5 + np.arange(50) * 1e-4, "JD"),
    (1.7e9 + np.arange(50) * 0.5, "Unix"),
    (1.7e12 + np.arange(50) * 500.0, "milliseconds since 1970"),  # Unix ms
    (np.arange(50) * 500.0, "milliseconds"),  # relative ms at a 0.5 s cadence
])
def test_ambiguous_units_are_named(values, looks):
    assert looks in ambiguous_time_unit(values)


@pytest.mark.parametrize("values", [np.arange(50) * 0.5, 3600.0 + np.arange(50) * 30.0, np.arange(50) * 2.0 - 40.0])
def test_plain_seconds_are_not_ambiguous(values):
    assert ambiguous_time_unit(values) is None


def test_mjd_file_refused_without_format_and_right_with_it(tmp_path, capsys):
    t, mag, err = curve()
    path = write_csv(tmp_path / "obs.csv", "time,mag,mag_err", (START.mjd + t / 86400.0, mag, err))
    message = refused(capsys, [str(path)])
    assert "column 'time'" in message and "--time-format" in message and "MJD" in message
    d = prior_json(capsys, [str(path), "--time-format", "mjd"])
    # MJD at 60390 as float64 resolves ~1 µs: the rate is that of the seconds file
    assert d["significant"] and d["rate_deg_s"] == pytest.approx(RATE_DEG_S, rel=0.005)
    assert "mjd" in d["time_input"] and "days" in d["time_input"]


def test_renamed_columns_jd_and_a_time_scale(tmp_path, capsys):
    t, mag, err = curve()
    jd_tt = (START + t * u.s).tt.jd  # the same instants written as JD in TT
    path = write_csv(tmp_path / "obs.csv", "JD,Magnitude,err", (jd_tt, mag, err))
    message = refused(capsys, [str(path), "--columns", "time=jd,mag=magnitude,mag_err=err"])
    assert "column 'jd'" in message and "--time-format" in message
    lc = read_csv(path, "jd", time_scale="tt", columns={"time": "JD", "mag": "magnitude", "mag_err": "err"})
    np.testing.assert_allclose(lc.t_s, t, atol=1e-4)  # JD at 2.46e6 resolves 40 µs
    assert abs((lc.time[0] - START).to_value(u.s)) < 1e-3  # TT converted to UTC (69.184 s apart)
    d = prior_json(capsys, [str(path), "--columns", "time=jd,mag=magnitude,mag_err=err", "--time-format", "jd", "--time-scale", "tt"])
    assert d["rate_deg_s"] == pytest.approx(RATE_DEG_S, rel=0.005) and "scale tt" in d["time_input"]


def test_millisecond_file_refused_without_format_and_right_with_it(tmp_path, capsys):
    t, mag, err = curve()
    path = write_csv(tmp_path / "ms.csv", "time,mag,mag_err", (1000.0 * t, mag, err))
    message = refused(capsys, [str(path)])
    assert "column 'time'" in message and "milliseconds" in message and "--time-format" in message
    d = prior_json(capsys, [str(path), "--time-format", "ms"])
    assert d["rate_deg_s"] == pytest.approx(RATE_DEG_S, rel=0.005) and d["time_input"].startswith("ms since an arbitrary origin")
    # the text output says the unit too
    assert main(["lightcurve", "prior", str(path), "--time-format", "ms"]) == 0
    assert "time: ms since an arbitrary origin" in capsys.readouterr().out


def test_relative_seconds_say_they_were_assumed(tmp_path, capsys):
    t, mag, err = curve()
    path = write_csv(tmp_path / "rel.csv", "time,mag,mag_err", (t, mag, err))
    d = prior_json(capsys, [str(path)])
    assert d["rate_deg_s"] == pytest.approx(RATE_DEG_S, rel=0.005) and "assumed" in d["time_input"]


def test_flux_column_becomes_magnitudes(tmp_path, capsys):
    t, mag, err = curve()
    flux = 1e5 * 10 ** (-0.4 * mag)  # counts: instrumental magnitudes are mag − 12.5
    flux_err = flux * err * np.log(10) / 2.5
    path = write_csv(tmp_path / "flux.csv", "time,flux,flux_err", (t, flux, flux_err))
    lc = read_lightcurve(path)
    np.testing.assert_allclose(lc.mag, mag - 12.5, atol=1e-9)
    np.testing.assert_allclose(lc.mag_err, err, rtol=1e-9)
    assert "instrumental" in lc.meta["mag_from_flux"]
    d = prior_json(capsys, [str(path), "--columns", "flux=flux,flux_err=flux_err"])
    assert d["rate_deg_s"] == pytest.approx(RATE_DEG_S, rel=0.005)
    bad = write_csv(tmp_path / "neg.csv", "time,flux", (t, np.where(np.arange(t.size) == 7, -1.0, flux)))
    with pytest.raises(BadSeries, match="column 'flux' row 8: -1: expected a flux > 0"):
        read_lightcurve(bad)


def test_fits_round_trip_with_a_time_column(tmp_path, capsys):
    t, mag, err = curve()
    path = tmp_path / "lc.fits"
    Table({"time": START + t * u.s, "mag": mag * u.mag, "mag_err": err * u.mag}).write(path)
    lc = read_table(path)
    np.testing.assert_allclose(lc.t_s, t, atol=1e-6)
    np.testing.assert_array_equal(lc.mag, mag)  # float64 cells: exact
    assert abs((lc.time[0] - START).to_value(u.s)) < 1e-6
    with pytest.raises(ReaderOptionError, match="time_format: 'mjd': expected none"):
        read_table(path, "mjd")
    assert prior_json(capsys, [str(path)])["rate_deg_s"] == pytest.approx(RATE_DEG_S, rel=0.005)


def test_votable_round_trip_with_mjd_numbers(tmp_path, capsys):
    t, mag, err = curve()
    path = tmp_path / "lc.vot"
    Table({"MJD": START.mjd + t / 86400.0, "mag": mag, "mag_err": err}).write(path, format="votable")
    with pytest.raises(AmbiguousTimeUnit, match="column 'mjd'.*MJD"):
        read_lightcurve(path, columns={"time": "MJD"})
    lc = read_lightcurve(path, "mjd", columns={"time": "MJD"})
    np.testing.assert_allclose(lc.t_s, t, atol=2e-6)
    np.testing.assert_array_equal(lc.mag, mag)
    d = prior_json(capsys, [str(path), "--time-format", "mjd", "--columns", "time=MJD"])
    assert d["rate_deg_s"] == pytest.approx(RATE_DEG_S, rel=0.005)


def test_iso_text_and_missing_columns(tmp_path):
    t, mag, _ = curve()
    path = tmp_path / "iso.csv"
    path.write_text("date,mag\n" + "".join(f"{(START + s * u.s).iso},{float(m)!r}\n" for s, m in zip(t, mag)))
    with pytest.raises(BadSeries, match=r"column\(s\) 'time'.*: missing .*--columns time=mjd"):
        read_lightcurve(path)
    lc = read_lightcurve(path, "iso", columns={"time": "date"})
    np.testing.assert_allclose(lc.t_s, t, atol=1e-3)  # ISO text keeps ms


@pytest.mark.parametrize("argv, message", [
    (["--time-format", "fortnights"], "--time-format 'fortnights': expected one of seconds, ms, mjd"),
    (["--time-scale", "ut1"], "--time-scale 'ut1': expected one of utc, tai"),
    (["--columns", "tim=mjd"], "--columns 'tim=mjd': expected ROLE=NAME pairs"),
    (["--columns", "mag=a,flux=b"], "expected mag= or flux=, not both"),
])
def test_bad_options_one_line(tmp_path, capsys, argv, message):
    t, mag, err = curve()
    path = write_csv(tmp_path / "rel.csv", "time,mag,mag_err", (t, mag, err))
    assert message in refused(capsys, [str(path), *argv])


def test_help_names_the_time_unit_and_the_suffixes_match(capsys):
    assert main(["lightcurve", "prior", "--help"]) == 0
    text = " ".join(capsys.readouterr().out.split())
    assert "--time-format" in text and "read as seconds" in text and "--columns" in text
    assert set(LIGHTCURVE_SUFFIXES) == {".ecsv", ".csv", *TABLE_FORMATS}
