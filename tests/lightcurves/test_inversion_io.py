"""Light curves with geometry for inversion: DAMIT text, lcnav ECSV and CSV readers, the ecliptic rotation, pole angles."""

import astropy.units as u
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from astropy.coordinates import BarycentricMeanEcliptic, SkyCoord
from astropy.time import Time

from lightcurves import BadSeries
from lightcurves.geometry import observe
from lightcurves.inversion.frames import ecliptic_to_I_matrix, pole_from_ecliptic, pole_from_radec, pole_to_ecliptic, pole_to_radec
from lightcurves.inversion.io import damit_text, from_lightcurve, read_damit, read_geometry_csv, read_inversion_curves
from lightcurves.io import LightCurve, read_lightcurve, to_timeseries
from lightcurves.render import AU_M, mag_to_flux
from lightcurves.simulate import DEFAULT_EPOCH, DEFAULT_ORBIT

EPS_J2000 = np.radians(84381.406 / 3600.0)  # IAU 2006 obliquity of the ecliptic at J2000
LIGHT_S_PER_AU = AU_M / 299_792_458.0
#: Frame bias between GCRS and the mean equator/equinox of J2000: 1.02e-7 rad at most in the rotation matrix.
BIAS = 1.5e-7

SNIPPET = """2
3 0
2451545.000000 1.00  1.0 0.0 0.0  0.0 0.0 0.5
2451545.010000 1.25  1.0 0.0 0.0  0.0 0.0 0.5
2451545.020000 0.80  1.0 0.0 0.0  0.0 0.0 0.5

4 1
2438882.233275 0.100  -0.9 0.3 0.01  -0.5 0.1 0.02
2438882.237650 0.110  -0.9 0.3 0.01  -0.5 0.1 0.02
2438882.241400 0.120  -0.9 0.3 0.01  -0.5 0.1 0.02
2438882.245817 0.130  -0.9 0.3 0.01  -0.5 0.1 0.02
"""


def test_ecliptic_rotation_is_the_iau2006_obliquity_rotation_up_to_the_frame_bias():
    C_IE = ecliptic_to_I_matrix()
    c, s = np.cos(EPS_J2000), np.sin(EPS_J2000)
    R = np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])  # ecliptic -> equator: rotation by ε about the equinox
    assert np.abs(C_IE - R).max() < BIAS
    assert np.abs(C_IE - R).max() > 1e-9  # the bias is there (astropy's GCRS, not the bare obliquity rotation)
    np.testing.assert_allclose(C_IE @ C_IE.T, np.eye(3), atol=1e-15)
    assert np.linalg.det(C_IE) == pytest.approx(1.0, abs=1e-15)


def test_hand_written_damit_snippet_has_the_known_directions_distances_and_times():
    rel, cal = read_damit(SNIPPET)
    assert not rel.calibrated and cal.calibrated and len(rel) == 3 and len(cal) == 4
    # Sun along ecliptic +x: the vernal equinox, I = (1, 0, 0); observer at the ecliptic north pole: (0, -sin ε, cos ε)
    np.testing.assert_allclose(rel.sun_dir_I, np.tile([1.0, 0.0, 0.0], (3, 1)), atol=BIAS)
    np.testing.assert_allclose(rel.observer_dir_I, np.tile([0.0, -np.sin(EPS_J2000), np.cos(EPS_J2000)], (3, 1)), atol=BIAS)
    np.testing.assert_allclose(rel.sun_distance_m, AU_M, rtol=1e-15)
    np.testing.assert_allclose(rel.range_m, 0.5 * AU_M, rtol=1e-15)
    np.testing.assert_allclose(rel.brightness, [1.0, 1.25, 0.8])
    np.testing.assert_allclose(rel.sigma, 0.01 * rel.brightness)
    # light-time corrected JD: the observation is Δ/c later; JD 2451545.0 UTC is 2000-01-01T12:00:00 UTC
    light_s = 0.5 * LIGHT_S_PER_AU
    assert (rel.epoch - Time("2000-01-01T12:00:00", scale="utc")).to_value(u.s) == pytest.approx(light_s, abs=1e-4)
    np.testing.assert_allclose(rel.t_s, [0.0, 864.0, 1728.0], atol=1e-4)
    # calibrated: intensity of the magnitude reduced to unit distances -> flux at the observer F0 b / (r Δ)^2
    r, d = np.linalg.norm([-0.9, 0.3, 0.01]), np.linalg.norm([-0.5, 0.1, 0.02])
    np.testing.assert_allclose(cal.brightness, mag_to_flux(0.0) * np.array([0.10, 0.11, 0.12, 0.13]) / (r * d) ** 2, rtol=1e-12)
    np.testing.assert_allclose(cal.phase_angle_rad, np.arccos(np.dot([-0.9, 0.3, 0.01], [-0.5, 0.1, 0.02]) / (r * d)), atol=1e-12)


def _tokens(text):
    return [np.array(line.split(), dtype=float) for line in text.splitlines() if line.strip()]


def test_damit_round_trip_is_exact_to_the_printed_precision():
    first = read_damit(SNIPPET)
    text = damit_text(first)
    again = read_damit(text)
    for a, b in zip(first, again):
        assert a.calibrated == b.calibrated and len(a) == len(b)
        assert abs((a.epoch - b.epoch).to_value(u.s)) < 1e-4  # JD printed with 9 decimals: 86 µs
        np.testing.assert_allclose(a.t_s, b.t_s, atol=1e-4)
        np.testing.assert_allclose(a.brightness, b.brightness, rtol=1e-10)
        np.testing.assert_allclose(a.sun_dir_I, b.sun_dir_I, atol=1e-10)
        np.testing.assert_allclose(a.observer_dir_I, b.observer_dir_I, atol=1e-10)
        np.testing.assert_allclose(a.sun_distance_m, b.sun_distance_m, rtol=1e-10)
        np.testing.assert_allclose(a.range_m, b.range_m, rtol=1e-10)
    # and the numbers written are the numbers read (JD to 1e-9 d, the rest to 1e-10 of each vector)
    for orig, written in zip(_tokens(SNIPPET), _tokens(text)):
        assert orig.shape == written.shape
        if orig.size == 8:
            assert abs(orig[0] - written[0]) < 1e-9
            np.testing.assert_allclose(written[1], orig[1], rtol=1e-10)
            for sl in (slice(2, 5), slice(5, 8)):
                assert np.abs(written[sl] - orig[sl]).max() < 1e-10 * np.linalg.norm(orig[sl])
        else:
            np.testing.assert_array_equal(orig, written)
    assert damit_text(again).splitlines()[:2] == ["2", "3 0"]


def _rendered_geometry_lc(n=40, seed=0):
    """A light curve over a visible GPS-orbit arc with the geometry lcnav computes (the orbit of ``simulate``)."""
    rng = np.random.default_rng(seed)
    t = 7800.0 + np.arange(n) * 2.0  # a visible arc from the default site after the default epoch
    obs = observe(DEFAULT_ORBIT, t, DEFAULT_EPOCH)
    mag = 9.0 + 0.3 * np.sin(0.2 * t) + rng.normal(0, 0.01, n)
    lc = LightCurve(
        time=DEFAULT_EPOCH + t * u.s, mag=mag, mag_err=np.full(n, 0.02), flux_w_m2=mag_to_flux(mag), phase_angle_rad=obs.phase_angle_rad,
        range_m=obs.range_m, elevation_rad=obs.elevation_rad, meta={"target": "synthetic", "seed": seed},
        sun_dir_I=obs.sun_dir_I, observer_dir_I=obs.observer_dir_I, sun_distance_m=obs.sun_distance_m,
    )  # fmt: skip
    return lc, obs


def test_ecsv_with_geometry_round_trips_and_the_phase_angle_follows_from_the_vectors(tmp_path):
    lc, obs = _rendered_geometry_lc()
    path = tmp_path / "lc.ecsv"
    to_timeseries(lc).write(path, format="ascii.ecsv")
    text = path.read_text()
    assert "name: sun_distance, unit: m" in text and "name: sun_dir_I_x" in text and "name: observer_dir_I_z" in text
    back = read_lightcurve(path)
    np.testing.assert_allclose(back.sun_dir_I, lc.sun_dir_I, rtol=0, atol=1e-15)
    np.testing.assert_allclose(back.observer_dir_I, lc.observer_dir_I, rtol=0, atol=1e-15)
    np.testing.assert_allclose(back.sun_distance_m, lc.sun_distance_m, rtol=1e-15)
    # the file's phase angle (from positions, in degrees) equals the angle between the two unit vectors
    cos_phase = np.einsum("ij,ij->i", back.sun_dir_I, back.observer_dir_I)
    np.testing.assert_allclose(np.arccos(cos_phase), back.phase_angle_rad, atol=1e-9)
    assert np.ptp(back.phase_angle_rad) > 1e-4  # the geometry changes along the arc (a real check, not a constant)
    # inversion record: flux from mag, σ_F = 0.4 ln10 F σ_m
    curve = read_inversion_curves(path)[0]
    assert curve.calibrated and len(curve) == len(lc)
    np.testing.assert_allclose(curve.brightness, mag_to_flux(lc.mag), rtol=1e-12)
    np.testing.assert_allclose(curve.sigma, 0.4 * np.log(10) * curve.brightness * 0.02, rtol=1e-12)
    np.testing.assert_allclose(curve.phase_angle_rad, obs.phase_angle_rad, atol=1e-9)
    relative = from_lightcurve(back, calibrated=False)
    assert np.mean(relative.brightness) == pytest.approx(1.0) and not relative.calibrated


def test_old_ecsv_without_geometry_reads_as_nan_and_is_refused_for_inversion(tmp_path):
    lc, _ = _rendered_geometry_lc()
    ts = to_timeseries(lc)
    ts.remove_columns([c for c in ts.colnames if c.startswith(("sun_", "observer_"))])
    path = tmp_path / "old.ecsv"
    ts.write(path, format="ascii.ecsv")
    back = read_lightcurve(path)
    assert np.isnan(back.sun_dir_I).all() and back.sun_dir_I.shape == (len(lc), 3) and np.isnan(back.sun_distance_m).all()
    with pytest.raises(BadSeries, match=r"sun_dir_I_x/y/z, observer_dir_I_x/y/z, sun_distance unknown \(NaN\): expected"):
        from_lightcurve(back)
    half = to_timeseries(lc)
    half.remove_column("sun_dir_I_y")
    with pytest.raises(BadSeries, match="expected all or none"):
        from_lightcurve(_read(tmp_path / "half.ecsv", half))
    bad = to_timeseries(lc)
    bad["observer_dir_I_x"][3] *= 2.0
    with pytest.raises(BadSeries, match=r"observer_dir_I_x row 4: .*: expected unit vectors"):
        _read(tmp_path / "bad.ecsv", bad)


def _read(path, ts):
    ts.write(path, format="ascii.ecsv")
    return read_lightcurve(path)


def test_damit_text_of_an_lcnav_render_round_trips_the_small_geocentric_distances():
    lc, _ = _rendered_geometry_lc()
    curve = from_lightcurve(lc)
    back = read_damit(damit_text([curve]))[0]
    assert back.calibrated
    np.testing.assert_allclose(back.range_m, curve.range_m, rtol=1e-10)  # ~2e7 m, 1.3e-4 au: 10 significant digits kept
    np.testing.assert_allclose(back.brightness, curve.brightness, rtol=1e-9)
    np.testing.assert_allclose(back.observer_dir_I, curve.observer_dir_I, atol=1e-9)
    np.testing.assert_allclose(back.t_s, curve.t_s, atol=1e-4)
    assert abs((back.epoch - curve.epoch).to_value(u.s)) < 1e-4  # the light time (~0.07 s) removed and added back


def test_csv_with_geometry_columns_gives_one_curve_per_label_in_either_frame(tmp_path):
    rel, cal = read_damit(SNIPPET)
    C_IE = ecliptic_to_I_matrix()

    def write(path, frame_matrix):
        rows = ["curve,time,flux,flux_err,calibrated,sun_x,sun_y,sun_z,obs_x,obs_y,obs_z"]
        for label, c in (("a", rel), ("b", cal)):
            times = (c.epoch + c.t_s * u.s).utc.isot
            for k in range(len(c)):
                s = frame_matrix @ c.sun_dir_I[k] * c.sun_distance_m[k] / AU_M
                o = frame_matrix @ c.observer_dir_I[k] * c.range_m[k] / AU_M
                cells = [c.brightness[k], c.sigma[k], *s, *o]
                rows.append(",".join([label, times[k], *(repr(float(x)) for x in cells[:2]), str(int(c.calibrated)), *(repr(float(x)) for x in cells[2:])]))
        path.write_text("\n".join(rows) + "\n")
        return path

    for frame, matrix in (("ecliptic", C_IE.T), ("equatorial", np.eye(3))):
        curves = read_geometry_csv(write(tmp_path / f"{frame}.csv", matrix), frame=frame)
        assert [c.name.split("#")[1] for c in curves] == ["a", "b"] and [c.calibrated for c in curves] == [False, True]
        for got, want in zip(curves, (rel, cal)):
            np.testing.assert_allclose(got.sun_dir_I, want.sun_dir_I, atol=1e-14)
            np.testing.assert_allclose(got.observer_dir_I, want.observer_dir_I, atol=1e-14)
            np.testing.assert_allclose(got.range_m, want.range_m, rtol=1e-14)
            np.testing.assert_allclose(got.t_s, want.t_s, atol=1e-3)  # ISO text in ms
    mags = tmp_path / "mag.csv"
    mags.write_text("time,mag,mag_err,sun_x,sun_y,sun_z,obs_x,obs_y,obs_z\n"
                    + "".join(f"{2460000.5 + k / 100},{10 + k / 10},0.05,1,0,0,0,1,0\n" for k in range(4)))  # fmt: skip
    (c,) = read_inversion_curves(mags)
    np.testing.assert_allclose(c.brightness, mag_to_flux(10 + np.arange(4) / 10))
    np.testing.assert_allclose(c.sigma, 0.4 * np.log(10) * 0.05 * c.brightness)
    assert not c.calibrated and c.phase_angle_rad == pytest.approx(np.full(4, np.pi / 2))


BAD_DAMIT = {
    "count not an integer": ("two\n3 0\n" + "2451545.0 1 1 0 0 0 0 1\n" * 3, "line 1: 'two': expected the number of light curves"),
    "count too large": ("2\n3 0\n" + "2451545.0 1 1 0 0 0 0 1\n" * 3, "end of text after line 5: expected the header of curve 2 of 2"),
    "count too small": ("1\n3 0\n" + "2451545.0 1 1 0 0 0 0 1\n" * 3 + "3 0\n", "line 6: '3 0' after the 1 announced curve(s): expected the end"),
    "too few rows": ("1\n4 0\n" + "2451545.0 1 1 0 0 0 0 1\n" * 3, "expected 4 rows of curve 1 (3 found)"),
    "non-numeric": ("1\n3 0\n" + "2451545.0 1 1 0 0 0 0 1\n" * 2 + "2451545.1 bright 1 0 0 0 0 1\n", "line 5: '2451545.1 bright 1 0 0 0 0 1': expected 8"),
    "nan": ("1\n3 0\n" + "2451545.0 nan 1 0 0 0 0 1\n" * 3, "line 3: '2451545.0 nan 1 0 0 0 0 1': expected 8 decimal"),
    "seven columns": ("1\n3 0\n" + "2451545.0 1 1 0 0 0 0\n" * 3, "line 3: '2451545.0 1 1 0 0 0 0': expected 8 decimal"),
    "zero sun vector": ("1\n3 0\n2451545.0 1 0 0 0 0 0 1\n" + "2451545.1 1 1 0 0 0 0 1\n" * 2,
                        "line 3: Sun vector of length 0 au: expected a vector from the object of length within [1e-12"),
    "zero observer vector": ("1\n3 0\n" + "2451545.0 1 1 0 0 0 0 1\n" * 2 + "2451545.1 1 1 0 0 0 0 0\n", "line 5: observer vector of length 0 au: expected"),
    "N = 0": ("1\n0 0\n", "line 2: '0 0': expected the header of curve 1 of 1: 'N FLAG', N >= 3"),
    "flag 2": ("1\n3 2\n" + "2451545.0 1 1 0 0 0 0 1\n" * 3, "line 2: '3 2': expected the header"),
    "negative brightness": ("1\n3 0\n" + "2451545.0 -1 1 0 0 0 0 1\n" * 3, "line 3: brightness -1.0: expected an intensity > 0"),
    "time order": ("1\n3 0\n2451545.2 1 1 0 0 0 0 1\n2451545.1 1 1 0 0 0 0 1\n2451545.3 1 1 0 0 0 0 1\n", "line 4: JD 2451545.1 before the previous"),
    "empty": ("\n\n", "end of text after line 0: expected the number of light curves"),
    "tiny vectors": ("1\n3 1\n" + "2451545.0 1 1e-13 0 0 0 0 1\n" * 3, "line 3: Sun vector of length 1e-13 au: expected"),
    "unicode digit": ("1\n3 \u00b2\n" + "2451545.0 1 1 0 0 0 0 1\n" * 3, "line 2: '3 \u00b2': expected the header"),
    "JD beyond ERFA": ("1\n3 0\n" + "99999999999 1 1 0 0 0 0 1\n" * 3, "line 3: JD 99999999999.0: expected a Julian date within [2400000, 2500000]"),
}


@pytest.mark.parametrize("case", sorted(BAD_DAMIT))
def test_malformed_damit_text_is_refused_with_line_value_and_expected_form(case):
    text, message = BAD_DAMIT[case]
    with pytest.raises(BadSeries) as err:
        read_damit(text)
    assert message in str(err.value) and str(err.value).startswith("DAMIT text") and "\n" not in str(err.value)


def test_damit_files_are_read_by_suffix_or_by_their_first_line_and_other_files_refused(tmp_path):
    for name in ("a.lcs", "b.txt", "c.dat", "d.in"):
        (tmp_path / name).write_text(SNIPPET)
        curves = read_inversion_curves(tmp_path / name)
        assert len(curves) == 2 and curves[1].name == f"{name}#2"
    (tmp_path / "e.json").write_text('{"curves": []}\n')
    with pytest.raises(BadSeries, match=r"e.json: suffix '.json': expected .ecsv"):
        read_inversion_curves(tmp_path / "e.json")
    (tmp_path / "f.lcs").write_bytes(b"1\n3 0\n\x00")
    with pytest.raises(BadSeries, match="f.lcs: NUL byte at offset 6: expected a text file"):
        read_damit(tmp_path / "f.lcs")
    with pytest.raises(BadSeries, match="sigma_rel: 0.0: expected"):
        read_damit(SNIPPET, sigma_rel=0.0)


def test_pole_angles_round_trip_and_agree_with_astropy_ecliptic_coordinates():
    rng = np.random.default_rng(28)
    poles = rng.normal(size=(200, 3))
    poles /= np.linalg.norm(poles, axis=1, keepdims=True)
    lon, lat = pole_to_ecliptic(poles)
    np.testing.assert_allclose(pole_from_ecliptic(lon, lat), poles, atol=1e-14)
    ra, dec = pole_to_radec(poles)
    np.testing.assert_allclose(pole_from_radec(ra, dec), poles, atol=1e-14)
    assert np.all((lon >= 0) & (lon < 2 * np.pi) & (np.abs(lat) <= np.pi / 2))
    # independent path: astropy's ICRS -> mean ecliptic of J2000 on the same RA/Dec
    ecl = SkyCoord(ra=ra * u.rad, dec=dec * u.rad, frame="icrs").transform_to(BarycentricMeanEcliptic(equinox=Time("J2000", scale="tt")))
    dlon = np.angle(np.exp(1j * (ecl.lon.to_value(u.rad) - lon)))
    assert np.abs(dlon * np.cos(lat)).max() < 1e-10 and np.abs(ecl.lat.to_value(u.rad) - lat).max() < 1e-10
    # the ecliptic north pole is at RA 270°, Dec 90° − ε; the celestial north pole at λ = 90°, β = 90° − ε
    ra0, dec0 = pole_to_radec(pole_from_ecliptic(0.0, np.pi / 2))
    assert np.degrees(ra0) == pytest.approx(270.0, abs=1e-4) and dec0 == pytest.approx(np.pi / 2 - EPS_J2000, abs=BIAS)
    lam, beta = pole_to_ecliptic([0.0, 0.0, 3.0])
    assert np.degrees(lam) == pytest.approx(90.0, abs=1e-4) and beta == pytest.approx(np.pi / 2 - EPS_J2000, abs=BIAS)
    with pytest.raises(ValueError, match=r"pole_I: \[0.0, 0.0, 0.0\]: expected finite, non-zero vectors"):
        pole_to_ecliptic([0.0, 0.0, 0.0])
    with pytest.raises(ValueError, match="latitude 2 rad: expected within"):
        pole_from_ecliptic(0.0, 2.0)


_WORDS = st.sampled_from(["", "0", "-1", "3", "1 0", "3 1", "0 0", "nan", "inf", "1e999", "0x10", "1_0", "abc", "\t", "2451545.5", "1e-300", "-0.5"])


@st.composite
def damit_texts(draw):
    """DAMIT texts near the valid snippet: lines dropped, repeated or with one word replaced."""
    lines = SNIPPET.splitlines()
    for _ in range(draw(st.integers(0, 3))):
        k = draw(st.integers(0, len(lines) - 1))
        action = draw(st.sampled_from(["drop", "repeat", "word"]))
        if action == "drop":
            del lines[k]
        elif action == "repeat":
            lines.insert(k, lines[k])
        elif lines[k].split():
            words = lines[k].split()
            words[draw(st.integers(0, len(words) - 1))] = draw(_WORDS)
            lines[k] = " ".join(words)
        if not lines:
            break
    return "\n".join(lines) + "\n"


@settings(max_examples=120, deadline=None, derandomize=True)
@given(damit_texts())
def test_damit_reader_returns_usable_curves_or_one_line_bad_series(text):
    """Property: any text gives valid curves (unit vectors, positive values, ordered finite times) or a one-line BadSeries."""
    try:
        curves = read_damit(text)
    except BadSeries as e:
        assert "\n" not in str(e) and ": expected" in str(e) and "np." not in str(e)
        return
    assert 1 <= len(curves) <= 2
    for c in curves:
        assert np.all(np.isfinite(c.t_s)) and np.all(np.diff(c.t_s) >= 0) and np.all(c.brightness > 0) and np.all(c.sigma > 0)
        np.testing.assert_allclose(np.linalg.norm(c.sun_dir_I, axis=1), 1.0, atol=1e-12)
        np.testing.assert_allclose(np.linalg.norm(c.observer_dir_I, axis=1), 1.0, atol=1e-12)


_CSV_HEAD = "time,mag,sun_x,sun_y,sun_z,obs_x,obs_y,obs_z"
_CSV_ROW = "{t},10.0,1,0,0,0,1,0"
BAD_CSV = {
    "no geometry": ("time,mag\n" + "".join(f"{2460000.5 + k},10\n" for k in range(3)), "header ['time', 'mag']: expected columns time, mag or flux, sun_x"),
    "zero vector": (_CSV_HEAD + "\n" + "".join(_CSV_ROW.format(t=2460000.5 + k) + "\n" for k in range(2)) + "2460003.5,10,0,0,0,0,1,0\n",
                    "columns sun_x..sun_z row 3: length 0 au: expected a vector from the object"),
    "text cell": (_CSV_HEAD + "\n" + "".join(_CSV_ROW.format(t=2460000.5 + k) + "\n" for k in range(2)) + "2460003.5,dim,1,0,0,0,1,0\n",
                  "column 'mag' row 3: 'dim': expected a decimal number"),
    "two rows": (_CSV_HEAD + "\n" + "".join(_CSV_ROW.format(t=2460000.5 + k) + "\n" for k in range(2)), "2 row(s): expected at least 3 samples"),
    "mixed flag": ("curve,calibrated," + _CSV_HEAD + "\n" + "".join(f"a,{k % 2}," + _CSV_ROW.format(t=2460000.5 + k) + "\n" for k in range(3)),
                   "column 'calibrated' curve 'a': [0.0, 1.0]: expected one value, 0 or 1, per curve"),
    "time order": (_CSV_HEAD + "\n" + "".join(_CSV_ROW.format(t=t) + "\n" for t in (2460001.5, 2460000.5, 2460002.5)),
                   "column 'time' row 2: before the previous row"),
    "year 1066": (_CSV_HEAD + "\n" + "".join(_CSV_ROW.format(t=2110701.5 + k) + "\n" for k in range(3)), "column 'time' row 1: '2110701.5': expected"),
}


@pytest.mark.parametrize("case", sorted(BAD_CSV))
def test_malformed_geometry_csv_is_refused_with_the_file_value_and_expected_form(tmp_path, case):
    text, message = BAD_CSV[case]
    path = tmp_path / "obs.csv"
    path.write_text(text)
    with pytest.raises(BadSeries) as err:
        read_inversion_curves(path)
    assert message in str(err.value) and str(err.value).startswith("obs.csv") and "\n" not in str(err.value)
