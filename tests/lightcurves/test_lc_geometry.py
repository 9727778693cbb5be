"""Observation geometry, attitude, photometric noise and sampling."""

import astropy.units as u
import numpy as np
import pytest
from astropy.coordinates import GCRS, AltAz, CartesianRepresentation, get_body
from astropy.time import Time

from estimators.attitude import quat_to_dcm
from estimators.dynamics import integrate_absolute
from lightcurves.geometry import DEFAULT_SITE, KeplerOrbit, find_visible_start, observe, pole_quaternion, site_sun_exact, spin_attitude
from lightcurves.photometry import Telescope, add_noise, sample_times

EPOCH = Time("2024-03-21T18:00:00", scale="utc")


def test_kepler_orbit_matches_numerical_two_body_integration():
    orbit = KeplerOrbit(7.2e6, 0.05, np.radians(51.6), np.radians(40), np.radians(70), np.radians(10))
    t = np.linspace(0, 6000, 7)
    r, v = orbit.state(t)
    y0 = np.concatenate([r[0], v[0], [1, 0, 0, 0], [0, 0, 0]])
    traj = integrate_absolute(y0, t, [1, 1, 1])
    np.testing.assert_allclose(r, traj.r_I, atol=1e-3)  # 1 mm over 1.7 h
    np.testing.assert_allclose(v, traj.v_I, atol=1e-6)


def test_geometry_quantities_are_consistent():
    orbit = KeplerOrbit(26_560e3, 0.0, np.radians(55), np.radians(30))
    ob = observe(orbit, np.arange(0, 86400, 600.0), EPOCH)
    los = ob.r_observer_I - ob.r_target_I
    np.testing.assert_allclose(ob.range_m, np.linalg.norm(los, axis=1))
    # the observer sits on the Earth's surface (GCRS distance ≈ 6371 km ± 22 km)
    assert np.all(np.abs(np.linalg.norm(ob.r_observer_I, axis=1) - 6.37e6) < 3e4)
    # elevation: range is shortest near the zenith; below the horizon the Earth is in between
    assert np.all(ob.range_m[ob.elevation_rad > 0] < 2.7e7)
    assert np.all((ob.phase_angle_rad >= 0) & (ob.phase_angle_rad <= np.pi))
    # visible implies sunlit, high enough and a dark sky
    assert np.all(ob.sunlit[ob.visible]) and np.all(ob.elevation_rad[ob.visible] >= np.radians(15))
    assert np.all(ob.sun_elevation_rad[ob.visible] <= np.radians(-12))
    assert np.all(ob.airmass[ob.elevation_rad > np.radians(30)] < 2.0)


def test_interpolated_site_and_sun_match_astropy_at_every_time():
    """observe() evaluates astropy on 10-min nodes and interpolates: within a metre of astropy at every sample time, and its
    elevations agree with astropy's own AltAz frame (no refraction) to its aberration (measured 2e-5 rad: 4″)."""
    orbit = KeplerOrbit(26_560e3, 0.0, np.radians(55), np.radians(30))
    t = np.sort(np.random.default_rng(3).uniform(0.0, 86400.0, 300))
    ob = observe(orbit, t, EPOCH)
    times = EPOCH + t * u.s
    r_O, up_I, r_S = site_sun_exact(times, DEFAULT_SITE)
    assert np.abs(ob.r_observer_I - r_O).max() < 1.0
    assert np.abs(ob.r_sun_I - r_S).max() < 1.0
    frame = AltAz(obstime=times, location=DEFAULT_SITE)
    target = GCRS(CartesianRepresentation(ob.r_target_I.T * u.m), obstime=times).transform_to(frame)
    np.testing.assert_allclose(ob.elevation_rad, target.alt.to_value(u.rad), atol=5e-5)
    np.testing.assert_allclose(ob.sun_elevation_rad, get_body("sun", times).transform_to(frame).alt.to_value(u.rad), atol=1e-4)


def test_earth_shadow_of_a_low_orbit():
    """A LEO target spends roughly (1/π) asin(R/r) of each orbit in the Earth's (cylindrical) shadow
    when the Sun lies in its orbital plane."""
    sun_ra = np.radians(0.0)  # at the March equinox the Sun is near RA 0, Dec 0
    orbit = KeplerOrbit(7.0e6, 0.0, 0.0, sun_ra)  # equatorial: Sun close to the orbital plane
    period = 2 * np.pi / orbit.mean_motion
    ob = observe(orbit, np.linspace(0, period, 2000, endpoint=False), EPOCH)
    expected = np.arcsin(6378137.0 / 7.0e6) / np.pi
    assert (~ob.sunlit).mean() == pytest.approx(expected, abs=0.02)


def test_visible_arc_is_visible_throughout():
    orbit = KeplerOrbit(26_560e3, 0.0, np.radians(55), np.radians(30))
    t0 = find_visible_start(orbit, EPOCH, 400.0)
    assert observe(orbit, t0 + np.linspace(0, 400, 41), EPOCH).visible.all()
    with pytest.raises(ValueError, match="never visible"):
        find_visible_start(orbit, EPOCH, 400.0, DEFAULT_SITE, search_s=600.0, min_elevation_deg=89.9)


def test_spin_about_a_principal_axis_is_a_steady_rotation():
    J = np.array([4.33, 1.0, 4.0])
    q0 = pole_quaternion([0, 0, 1], [0.3, -0.2, 0.93], 0.4)
    C0 = quat_to_dcm(q0)
    np.testing.assert_allclose(C0 @ [0, 0, 1], np.array([0.3, -0.2, 0.93]) / np.linalg.norm([0.3, -0.2, 0.93]), atol=1e-12)
    t = np.linspace(0, 100, 11)
    w = np.radians(5.0)
    q, w_T = spin_attitude(q0, [0, 0, w], J, t)
    np.testing.assert_allclose(w_T, np.tile([0, 0, w], (t.size, 1)), atol=1e-12)
    c, s = np.cos(w * t[-1]), np.sin(w * t[-1])
    np.testing.assert_allclose(quat_to_dcm(q[-1]), C0 @ np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]]), atol=1e-9)
    # off-principal spin tumbles: the body rate changes, |H| and energy are conserved
    q, w_T = spin_attitude(q0, [0.02, 0.05, 0.08], J, np.linspace(0, 300, 31))
    H = np.linalg.norm(w_T * J, axis=1)
    E = np.sum(J * w_T**2, axis=1)
    assert np.ptp(w_T[:, 0]) > 1e-3
    np.testing.assert_allclose(H, H[0], rtol=1e-9)
    np.testing.assert_allclose(E, E[0], rtol=1e-9)


def test_reported_magnitude_errors_match_the_scatter():
    rng = np.random.default_rng(0)
    m_true = np.full(20000, 11.0)
    phot = add_noise(m_true, 0.5, np.full(m_true.size, 1.3), Telescope(), rng)
    assert phot.detected.all()
    pull = (phot.mag - m_true) / phot.mag_err
    assert abs(pull.mean()) < 0.03
    assert pull.std() == pytest.approx(1.0, abs=0.03)
    # fainter targets are noisier; far below the sky they are not detected
    faint = add_noise(np.array([14.0, 24.0]), 0.5, np.array([1.3, 1.3]), Telescope(), rng)
    assert faint.mag_err[0] > np.median(phot.mag_err) and not faint.detected[1]


def test_uneven_sampling_has_jitter_and_gaps():
    rng = np.random.default_rng(1)
    t = sample_times(400.0, 0.5, rng, jitter=0.2, n_gaps=2, gap_fraction=0.1)
    assert np.all(np.diff(t) > 0) and t[0] >= 0 and t[-1] <= 400
    assert t.size == pytest.approx(801 * 0.9, rel=0.02)
    assert np.diff(t).max() > 10.0  # a gap
    assert np.std(np.diff(t)[np.diff(t) < 1.0]) > 0.01  # jitter
