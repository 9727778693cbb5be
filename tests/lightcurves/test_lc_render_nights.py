"""``lcnav lightcurve render --epoch --site``: two nights from a chosen site, their geometry checked against astropy."""

import astropy.units as u
import numpy as np
import pytest
from astropy.coordinates import GCRS, AltAz, CartesianRepresentation, EarthLocation, get_sun
from astropy.time import Time

from lightcurves.inversion.frames import pole_to_ecliptic
from lightcurves.io import read_lightcurve
from studies.cli import main

CALAR_ALTO = (37.2236, -2.5463, 2168.0)  # lat deg, lon deg east, height m
NIGHTS = ("2024-03-21T18:00:00", "2024-03-22T18:00:00")


def _angle_deg(a, b):
    a = a / np.linalg.norm(a, axis=-1, keepdims=True)
    b = b / np.linalg.norm(b, axis=-1, keepdims=True)
    return np.degrees(np.arctan2(np.linalg.norm(np.cross(a, b), axis=-1), np.einsum("ij,ij->i", a, b)))


def _render(tmp_path, epoch):
    out = tmp_path / f"night-{epoch[:10]}.ecsv"
    argv = ["lightcurve", "render", "--target", "sphere", "--albedo", "0.3", "--duration", "40", "--cadence", "1", "--seed", "3", "--variant",
            "scalar_rgb", "--resolution", "8", "--spp", "1", "--epoch", epoch, "--site", ",".join(map(str, CALAR_ALTO)), "--out", str(out)]  # fmt: skip
    assert main(argv) == 0
    return read_lightcurve(out)


def test_two_nights_from_a_site_carry_the_sun_and_topocentric_observer_directions(tmp_path):
    site = EarthLocation.from_geodetic(lon=CALAR_ALTO[1] * u.deg, lat=CALAR_ALTO[0] * u.deg, height=CALAR_ALTO[2] * u.m)
    sun_lon = []
    for epoch in NIGHTS:
        lc = _render(tmp_path, epoch)
        assert lc.meta["epoch"].startswith(epoch) and lc.meta["site"]["lat_deg"] == pytest.approx(CALAR_ALTO[0])
        start = (lc.time[0] - Time(epoch, scale="utc")).to_value(u.h)
        assert 0 <= start < 24  # the arc is in the night after the epoch
        assert np.isfinite(lc.sun_dir_I).all() and np.isfinite(lc.observer_dir_I).all() and np.isfinite(lc.sun_distance_m).all()
        # where the target is, from the site's GCRS position (astropy) and the file's observer vector and range
        pos, _ = site.get_gcrs_posvel(lc.time)
        r_site_I = pos.xyz.to_value(u.m).T
        r_target_I = r_site_I - lc.range_m[:, None] * lc.observer_dir_I
        # the Sun: astropy's get_sun (geocentric) seen from the target, to < 1" (measured 0.01"; the brief asks < 0.01° = 36");
        # seen from the geocentre instead it is 32" off (the target's parallax), so 1" checks where the vector starts
        r_sun_I = get_sun(lc.time).cartesian.xyz.to_value(u.m).T
        assert _angle_deg(lc.sun_dir_I, r_sun_I - r_target_I).max() < 1.0 / 3600
        np.testing.assert_allclose(lc.sun_distance_m, np.linalg.norm(r_sun_I - r_target_I, axis=1), rtol=1e-6)
        # the observer vector is topocentric: the target's altitude in astropy's AltAz frame at the site is the file's elevation
        target = GCRS(CartesianRepresentation(r_target_I.T * u.m), obstime=lc.time).transform_to(AltAz(obstime=lc.time, location=site))
        assert np.abs(target.alt.to_value(u.deg) - np.degrees(lc.elevation_rad)).max() < 5.0 / 3600  # measured 1.4"
        assert _angle_deg(lc.observer_dir_I, -r_target_I).min() > 1.0  # a geocentric vector would be off by the parallax (11° here)
        sun_lon.append((lc.time[0], pole_to_ecliptic(lc.sun_dir_I[0])[0]))
    # the Sun's ecliptic longitude advances by the Earth's orbital motion, 0.99°/day in March, from one night to the next
    (t0, lon0), (t1, lon1) = sun_lon
    rate = np.degrees(lon1 - lon0) / (t1 - t0).to_value(u.day)
    assert rate == pytest.approx(0.99, abs=0.03)


@pytest.mark.parametrize(
    "extra, message",
    [
        (["--epoch", "tomorrow"], "--epoch 'tomorrow': expected an ISO 8601 UTC time like 2024-03-21T18:00:00, years 1962 to 2100"),
        (["--epoch", "2024-02-30T00:00:00"], "--epoch '2024-02-30T00:00:00': expected an ISO 8601 UTC time"),
        (["--epoch", "1850-01-01T00:00:00"], "--epoch '1850-01-01T00:00:00': expected"),
        (["--site", "91,0,0"], "--site '91,0,0': expected 'LAT,LON,HEIGHT_M' like 28.2995,-16.5097,2393: latitude within [-90, 90] deg"),
        (["--site", "28,-16"], "--site '28,-16': expected 'LAT,LON,HEIGHT_M'"),
        (["--site", "28,-16,20000"], "height within [-500, 9000] m"),
        (["--site", "28,nan,0"], "--site '28,nan,0': expected"),
    ],
)
def test_bad_epoch_or_site_is_one_line_and_writes_nothing(tmp_path, capsys, extra, message):
    out = tmp_path / "lc.ecsv"
    assert main(["lightcurve", "render", "--out", str(out), *extra]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("lcnav: error:") and message in err and "\n" not in err
    assert list(tmp_path.iterdir()) == []


def test_nights_rendered_apart_are_one_continuous_rotation():
    """Two arcs a day apart, rendered separately with one pole, phase and phase epoch: the attitude at the second arc's
    start is the first arc's turned by ω Δt about the pole (a steady spin), to 1e-9 rad."""
    from scipy.spatial.transform import Rotation

    from lightcurves.render import UnresolvedRenderer
    from lightcurves.simulate import DEFAULT_EPOCH, simulate_lightcurve
    from lightcurves.targets import get_target

    tgt = get_target("atlas-centaur")
    renderer = UnresolvedRenderer(tgt, resolution=4, spp=1)
    pole = np.array([0.3, -0.5, 0.81]) / np.linalg.norm([0.3, -0.5, 0.81])
    rate = 0.05
    ref = Time("2000-01-01T12:00:00", scale="tt")
    arcs = [simulate_lightcurve(tgt, axis_T=[1.0, 0.0, 0.0], rate_rad_s=rate, duration_s=60.0, cadence_s=2.0, rng=np.random.default_rng(k),
                                epoch=DEFAULT_EPOCH + k * u.day, pole_I=pole, phase_rad=0.7, phase_epoch=ref, noise=False, uneven=False,
                                renderer=renderer) for k in (0, 1)]
    t0 = [a.lightcurve.time[0] for a in arcs]
    q = [a.q_IT[0] for a in arcs]
    dt = (t0[1] - t0[0]).to_value(u.s)
    turn = Rotation.from_rotvec(rate * dt * pole)
    C_expected = turn.as_matrix() @ Rotation.from_quat(np.roll(q[0], -1)).as_matrix()
    C_second = Rotation.from_quat(np.roll(q[1], -1)).as_matrix()
    assert np.degrees(Rotation.from_matrix(C_expected.T @ C_second).magnitude()) < np.degrees(1e-9) * 1e3  # 1e-6 deg
    # and a different phase epoch breaks it: the check can fail
    other = simulate_lightcurve(tgt, axis_T=[1.0, 0.0, 0.0], rate_rad_s=rate, duration_s=60.0, cadence_s=2.0, rng=np.random.default_rng(1),
                                epoch=DEFAULT_EPOCH + 1 * u.day, pole_I=pole, phase_rad=0.7, noise=False, uneven=False, renderer=renderer)
    assert Rotation.from_matrix(C_expected.T @ Rotation.from_quat(np.roll(other.q_IT[0], -1)).as_matrix()).magnitude() > 1e-3
