"""The relative motion about the chaser's own orbit (CoMBiNa's translational model in orbit, issue 31)."""

import numpy as np
import pytest

from estimators.combina.own_orbit import ChaserOrbit, gravity_I
from estimators.combina.translation import TranslationalUKF
from estimators.dynamics import MU_EARTH, R_EARTH, integrate_truth, lvlh_dcm, nerm_rhs, rk4_step

R_T = R_EARTH + 800e3
N = float(np.sqrt(MU_EARTH / R_T**3))
INC = np.deg2rad(98.6)
X_L = np.array([[24.0, 0.5, 2.4, 0.001, -0.05, 0.002], [-30.0, 12.0, -4.0, -0.02, 0.03, 0.0]])


def _circular(u: float) -> np.ndarray:
    """[R, V] in I of a circular orbit of radius R_T, inclination INC, argument of latitude u (node on x)."""
    c, s = np.cos(u), np.sin(u)
    r = R_T * np.array([c, s * np.cos(INC), s * np.sin(INC)])
    v = N * R_T * np.array([-s, c * np.cos(INC), c * np.sin(INC)])
    return np.concatenate([r, v])


def _relative_L(chaser, target) -> np.ndarray:
    """lcnav's convention: r_L = C_LI ρ, v_L = C_LI ρ̇ − (n e_z) × r_L."""
    C = lvlh_dcm(chaser[..., :3], chaser[..., 3:6])
    r = np.einsum("...ij,...j->...i", C, target[..., :3] - chaser[..., :3])
    v = np.einsum("...ij,...j->...i", C, target[..., 3:6] - chaser[..., 3:6]) - np.cross([0.0, 0.0, N], r)
    return np.concatenate([r, v], axis=-1)


def _absolute(chaser, x_L) -> np.ndarray:
    C = lvlh_dcm(chaser[:3], chaser[3:6])
    return np.concatenate([chaser[:3] + C.T @ x_L[:3], chaser[3:6] + C.T @ (x_L[3:] + np.cross([0.0, 0.0, N], x_L[:3]))])


def _kepler_j2(t, y, j2):
    return np.concatenate([y[3:6], gravity_I(y[:3], MU_EARTH, j2)])


def test_two_body_about_a_circular_orbit_is_eq_9():
    """On a circular Keplerian chaser with two-body gravity the propagation is eq. 9's (the same RK4 step): the relative
    motion about the actual orbit and eq. 9 about the reference circle are the same equations in two frames."""
    orbit = ChaserOrbit(np.array([0.0]), _circular(0.3)[None, :], N, j2=False)
    ours = orbit.propagate_relative(X_L, 0.0, 3.03)
    ref = rk4_step(nerm_rhs, 0.0, X_L, 3.03, N, R_T, MU_EARTH)
    np.testing.assert_allclose(ours[:, :3], ref[:, :3], atol=1e-7)
    np.testing.assert_allclose(ours[:, 3:], ref[:, 3:], atol=1e-9)


@pytest.mark.parametrize("j2", [False, True])
def test_propagation_matches_two_bodies_integrated_apart(j2):
    """Over 60 s in 10-s steps the relative state equals that of the chaser and the target integrated separately in I
    (DOP853, 1e-12) with the same gravity, to 1e-6 m and 1e-9 m/s; J2 moves it by far more than that."""
    chaser0 = _circular(1.1)
    t = np.arange(0.0, 61.0, 10.0)
    chaser = integrate_truth(_kepler_j2, t, chaser0, j2, rtol=1e-13, atol=1e-9)
    target = np.array([integrate_truth(_kepler_j2, t, _absolute(chaser0, x), j2, rtol=1e-13, atol=1e-9) for x in X_L])
    orbit = ChaserOrbit(t, chaser, N, j2=j2)
    x = X_L.copy()
    for k in range(t.size - 1):
        x = orbit.propagate_relative(x, t[k], t[k + 1] - t[k])
    truth = _relative_L(chaser[-1], target[:, -1])
    np.testing.assert_allclose(x[:, :3], truth[:, :3], atol=1e-6)
    np.testing.assert_allclose(x[:, 3:], truth[:, 3:], atol=1e-9)
    if j2:
        without = ChaserOrbit(t, chaser, N, j2=False).propagate_relative(X_L, 0.0, 60.0)
        assert np.max(np.abs(without[:, :3] - truth[:, :3])) > 1e-4


def test_state_between_samples_is_propagated():
    """Between samples the chaser's state is the last sample's carried by the orbit's gravity; before the first, an error."""
    t = np.array([0.0, 100.0])
    chaser = integrate_truth(_kepler_j2, np.array([0.0, 37.0, 100.0]), _circular(0.2), True, rtol=1e-13, atol=1e-9)
    orbit = ChaserOrbit(t, chaser[[0, 2]], N)
    np.testing.assert_allclose(orbit.state_at(37.0), chaser[1], atol=1e-6)
    np.testing.assert_array_equal(orbit.state_at(100.0), chaser[2])
    with pytest.raises(ValueError, match="t_s: -1.0"):
        orbit.state_at(-1.0)


@pytest.mark.parametrize("kw, match", [({"t_s": np.array([0.0, 0.0])}, "strictly increasing"),
                                       ({"state_I": np.zeros((2, 5))}, r"expected \(2, 6\)"),
                                       ({"state_I": np.full((2, 6), np.nan)}, "finite"),
                                       ({"n_rad_s": 0.0}, "n_rad_s")])
def test_bad_orbit_is_refused(kw, match):
    args = {"t_s": np.array([0.0, 1.0]), "state_I": np.stack([_circular(0.0), _circular(N)]), "n_rad_s": N} | kw
    with pytest.raises(ValueError, match=match):
        ChaserOrbit(**args)


def test_filter_with_an_orbit_propagates_about_it_and_keeps_its_clock():
    """A near-certain estimate follows :meth:`ChaserOrbit.propagate_relative` from the filter's own time, which each
    prediction advances (a restarted filter starts at its own ``t0_s``)."""
    t = np.arange(0.0, 31.0, 3.0)
    chaser = integrate_truth(_kepler_j2, t, _circular(0.7), True, rtol=1e-13, atol=1e-9)
    orbit = ChaserOrbit(t, chaser, N)
    f = TranslationalUKF(X_L[0], 1e-12 * np.eye(6), n_rad_s=N, R_t_m=R_T, orbit=orbit, t0_s=9.0)
    for _ in range(3):
        f.predict(3.0)
    assert f.t_s == pytest.approx(18.0)
    expected = X_L[0]
    for k in (9.0, 12.0, 15.0):
        expected = orbit.propagate_relative(expected, k, 3.0)
    np.testing.assert_allclose(f.x, expected, atol=1e-9)
