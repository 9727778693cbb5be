"""Spin kinematics of lightcurves.inversion.spin: the rotation it describes, its sense, synodic vs sidereal, light time."""

from types import SimpleNamespace

import numpy as np
import pytest
from astropy.time import Time
from scipy.spatial.transform import Rotation

from lightcurves.geometry import bisector_rate
from lightcurves.inversion.convex import EllipsoidModel
from lightcurves.inversion.data import InversionCurve
from lightcurves.inversion.frames import pole_from_ecliptic, pole_from_radec
from lightcurves.inversion.spin import C_LIGHT_M_S, C_TI, SpinState, body_directions, rotation_phase

EPOCH = Time("2026-03-01T00:00:00", scale="utc")


def _curve(t, sun, obs, range_m=1e6):
    n = len(t)
    return InversionCurve(np.asarray(t, float), EPOCH, np.ones(n), np.ones(n), sun, obs, np.full(n, 1.5e11), np.full(n, range_m))


def _fixed_curve(n=50, span=100.0, range_m=1e6):
    t = np.linspace(0, span, n)
    return _curve(t, np.tile([1.0, 0, 0], (n, 1)), np.tile([0, 1.0, 0], (n, 1)), range_m)


@pytest.mark.parametrize("axis_T", [[0, 0, 1], [1, 0, 0], [0.3, -0.4, 0.866]])
def test_attitude_is_a_uniform_rotation_about_the_pole(axis_T):
    pole = pole_from_radec(2.0, -0.4)
    state = SpinState(pole, 37.0, 1.1, EPOCH, axis_T)
    curve = _fixed_curve()
    C = C_TI(state, curve)
    a = np.asarray(axis_T, float) / np.linalg.norm(axis_T)
    # the body spin axis points along the pole at every time
    np.testing.assert_allclose(np.einsum("nij,j->ni", np.transpose(C, (0, 2, 1)), a), np.tile(pole, (len(curve), 1)), atol=1e-12)
    # C_IT(t_k) C_IT(t_0)ᵀ is the right-handed rotation by ω(t_k − t_0) about the pole
    rel = Rotation.from_matrix(np.transpose(C, (0, 2, 1)) @ C[0])
    expected = Rotation.from_rotvec(np.outer(state.rate_rad_s * (curve.t_s - curve.t_s[0]), pole))
    assert np.max((rel * expected.inv()).magnitude()) < 1e-10
    # proper rotations
    np.testing.assert_allclose(np.linalg.det(C), 1.0, atol=1e-12)


def test_reversed_pole_reverses_the_rotation():
    pole = pole_from_radec(0.5, 0.9)
    curve = _fixed_curve()
    fwd = SpinState(pole, 20.0, 0.0, EPOCH)
    rev = SpinState(-pole, 20.0, 0.0, EPOCH)
    for state, sign in ((fwd, 1.0), (rev, -1.0)):
        C = C_TI(state, curve)
        rotvec = Rotation.from_matrix(C[1].T @ C[0]).as_rotvec()  # inertial rotation from t0 to t1
        np.testing.assert_allclose(rotvec, sign * state.rate_rad_s * (curve.t_s[1] - curve.t_s[0]) * pole, atol=1e-12)


def test_light_curve_repeats_with_the_synodic_period():
    """Sun and observer turning at Ω about the pole: the light curve repeats after 2π/(ω − Ω), the synodic period, and Ω is
    the bisector rate of lightcurves.geometry."""
    pole = np.array([0.0, 0.0, 1.0])
    P, Omega = 30.0, 2 * np.pi / 400.0
    t = np.linspace(0.0, 200.0, 400)
    sun = np.stack([np.cos(Omega * t), np.sin(Omega * t), np.zeros_like(t)], 1)
    obs0 = np.array([np.cos(0.6), 0.3, np.sin(0.6)])
    obs0 /= np.linalg.norm(obs0)
    obs = Rotation.from_rotvec(np.outer(Omega * t, pole)).apply(obs0)
    assert bisector_rate(SimpleNamespace(t_s=t, sun_dir_I=sun, observer_dir_I=obs), pole) == pytest.approx(Omega, rel=1e-9)
    state = SpinState(pole, P, 0.2, EPOCH, [0.3, 0.2, 0.93])
    model = EllipsoidModel(3.0, 2.0, 1.0, n_facets=400)
    curve = _curve(t, sun, obs, range_m=1.0)  # negligible light time
    P_syn = 2 * np.pi / (state.rate_rad_s - Omega)

    def brightness(shift):
        c = _curve(t + shift, Rotation.from_rotvec(np.outer(Omega * shift, pole)).apply(sun),
                   Rotation.from_rotvec(np.outer(Omega * shift, pole)).apply(obs), range_m=1.0)
        return model.basis(*body_directions(state, c))[:, 0]

    b0 = model.basis(*body_directions(state, curve))[:, 0]
    np.testing.assert_allclose(brightness(P_syn), b0, rtol=1e-9, atol=1e-9 * b0.max())
    assert np.max(np.abs(brightness(P) - b0)) > 0.05 * np.ptp(b0)  # not after one sidereal period


def test_light_time_delays_the_phase():
    state = SpinState([0, 0, 1.0], 10.0, 0.0, EPOCH)
    near, far = _fixed_curve(range_m=1.0), _fixed_curve(range_m=3e8)
    np.testing.assert_allclose(rotation_phase(state, near) - rotation_phase(state, far), state.rate_rad_s * (3e8 - 1.0) / C_LIGHT_M_S, rtol=1e-12)


def test_pole_angles_come_from_the_frames_module():
    state = SpinState(pole_from_ecliptic(4.0, -0.7), 10.0, 0.0, EPOCH)
    np.testing.assert_allclose(state.ecliptic_rad, (4.0, -0.7), atol=1e-12)
    np.testing.assert_allclose(pole_from_radec(*state.radec_rad), state.pole_I, atol=1e-12)


def test_bad_input_names_the_field():
    with pytest.raises(ValueError, match="pole_I"):
        SpinState([0, 0, 0], 10.0, 0.0, EPOCH)
    with pytest.raises(ValueError, match="period_s"):
        SpinState([0, 0, 1], -1.0, 0.0, EPOCH)
    with pytest.raises(ValueError, match="epoch"):
        SpinState([0, 0, 1], 1.0, 0.0, 0.0)
