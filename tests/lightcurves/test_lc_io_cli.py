"""Light-curve files and the ``lcnav lightcurve`` commands, including every kind of bad input."""

import json

import astropy.units as u
import numpy as np
import pytest
from astropy.time import Time

from lightcurves import BadSeries
from lightcurves.io import LightCurve, read_lightcurve, to_timeseries
from studies.cli import main
from tests.rerun_cli import assert_rrd_verifies


def make_lc(n=200, rate_deg_s=4.0, seed=0):
    rng = np.random.default_rng(seed)
    t = np.sort(rng.uniform(0, 300, n))
    f = rate_deg_s / 360.0
    mag = 9 + 0.6 * np.cos(2 * np.pi * 2 * f * t) + 0.2 * np.cos(2 * np.pi * f * t) + rng.normal(0, 0.02, n)
    return LightCurve(
        time=Time("2024-03-21T20:00:00", scale="utc") + t * u.s,
        mag=mag, mag_err=np.full(n, 0.02), flux_w_m2=1361 * 10 ** (-0.4 * (mag + 26.74)),
        phase_angle_rad=np.full(n, 0.5), range_m=np.full(n, 2e7), elevation_rad=np.full(n, 0.9),
        meta={"target": "synthetic", "truth_rate_deg_s": rate_deg_s, "seed": seed},
    )  # fmt: skip


def test_ecsv_round_trip_keeps_units_columns_and_metadata(tmp_path):
    lc = make_lc()
    path = tmp_path / "lc.ecsv"
    to_timeseries(lc).write(path, format="ascii.ecsv")
    text = path.read_text()
    for col, unit in (("flux", "W / m2"), ("mag", "mag"), ("phase_angle", "deg"), ("range", "m"), ("elevation", "deg")):
        assert f"name: {col}, unit: {unit}" in text
    back = read_lightcurve(path)
    np.testing.assert_allclose(back.mag, lc.mag)
    np.testing.assert_allclose(back.t_s, lc.t_s, atol=1e-6)
    np.testing.assert_allclose(back.phase_angle_rad, lc.phase_angle_rad)
    assert back.meta["truth_rate_deg_s"] == 4.0 and back.meta["target"] == "synthetic"


def test_observer_csv_import(tmp_path):
    lc = make_lc()
    iso = lc.time.isot
    p = tmp_path / "obs.csv"
    p.write_text("time,mag,mag_err\n" + "".join(f"{a},{m},{e}\n" for a, m, e in zip(iso, lc.mag, lc.mag_err)))
    back = read_lightcurve(p)
    np.testing.assert_allclose(back.t_s, lc.t_s, atol=1e-3)
    assert np.isnan(back.flux_w_m2).all()
    q = tmp_path / "rel.csv"
    q.write_text("time,mag\n" + "".join(f"{t},{m}\n" for t, m in zip(lc.t_s, lc.mag)))
    assert np.isnan(read_lightcurve(q).mag_err).all()


def test_prior_command_json(tmp_path, capsys):
    path = tmp_path / "lc.ecsv"
    to_timeseries(make_lc()).write(path, format="ascii.ecsv")
    assert main(["lightcurve", "prior", str(path), "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    for key in ("rate_deg_s", "rate_sigma_deg_s", "frequency_hz", "maxima_per_rotation", "candidates", "significant"):
        assert key in d
    assert d["significant"] and d["maxima_per_rotation"] == 2
    assert d["rate_deg_s"] == pytest.approx(4.0, rel=0.005)


def test_render_command_writes_ecsv_and_recording(tmp_path, capsys):

    out, rrd = tmp_path / "s.ecsv", tmp_path / "s.rrd"
    argv = ["lightcurve", "render", "--target", "sphere", "--albedo", "0.3", "--axis", "0,0,1", "--rate-deg-s", "5", "--duration", "40", "--cadence", "1",
            "--seed", "2", "--out", str(out), "--record", str(rrd), "--variant", "scalar_rgb", "--resolution", "16"]
    assert main(argv) == 0
    lc = read_lightcurve(out)
    assert len(lc) >= 20 and lc.meta["seed"] == 2 and lc.meta["renderer"]["variant"] == "scalar_rgb"
    # a sphere has no light curve beyond noise and the slow phase-angle trend
    assert np.std(lc.mag - np.polyval(np.polyfit(lc.t_s, lc.mag, 2), lc.t_s)) < 5 * np.median(lc.mag_err)
    assert_rrd_verifies(rrd)


def _csv(path, rows):
    path.write_text("time,mag\n" + "".join(f"{t},{m}\n" for t, m in rows))
    return path


BAD = {
    "not increasing": lambda p: _csv(p, [(t, np.sin(t)) for t in list(range(15)) + list(range(5, 0, -1))] + [(20 + k, 1.0 * k) for k in range(10)]),
    "nan": lambda p: _csv(p, [(t, np.sin(t) if t != 7 else "nan") for t in range(30)]),
    "at least 20": lambda p: _csv(p, [(t, np.sin(t)) for t in range(10)]),
    "zero variance": lambda p: _csv(p, [(t, 8.0) for t in range(30)]),
    "malformed CSV": lambda p: p.write_text("time,mag\n1,2\n3,4,5,6\n7\n"),
    "decimal number": lambda p: p.write_text("time,mag\n" + "".join(f"{k},bright\n" for k in range(30))),
    "'time', 'mag': missing": lambda p: p.write_text("t,brightness\n1,2\n"),
}


@pytest.mark.parametrize("reason", sorted(BAD))
def test_bad_light_curves_give_one_line_and_exit_2(tmp_path, capsys, reason):
    path = tmp_path / "bad.csv"
    BAD[reason](path)
    assert main(["lightcurve", "prior", str(path)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("lcnav: error:") and "\n" not in err and reason.split()[0] in err
    with pytest.raises(BadSeries):
        read_lightcurve(path)


@pytest.mark.parametrize(
    "extra, message",
    [
        (["--target", "saturn-v"], "--target 'saturn-v': expected one of atlas-centaur, box-wing, sphere, vespa"),
        (["--axis", "1,2"], "--axis"),
        (["--rate-deg-s", "-1"], "--rate-deg-s"),
        (["--duration", "5", "--cadence", "1"], "20 to 100000 samples"),
        (["--albedo", "0.3"], "expected --albedo with --target sphere only"),
        (["--spp", "8"], "--spp"),
    ],
)
def test_bad_render_input_writes_nothing(tmp_path, capsys, extra, message):
    out = tmp_path / "lc.ecsv"
    assert main(["lightcurve", "render", "--out", str(out), *extra]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("lcnav: error:") and message in err and "\n" not in err
    assert list(tmp_path.iterdir()) == []  # no partial .ecsv, no temporary file
