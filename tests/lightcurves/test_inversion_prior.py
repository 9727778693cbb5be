"""The filters' spin prior from an inversion: moments of ω_T checked against Monte Carlo draws of what each mode states."""

import numpy as np
import pytest
from astropy.time import Time

from lightcurves.inversion.posterior import InversionResult, SpinSolution
from lightcurves.inversion.prior import SENSE_SETTLED, spin_prior_from_inversion, symmetry_axis
from lightcurves.inversion.spin import SpinState

EPOCH = Time("2024-03-21T18:00:00", scale="utc")


def _solution(axis_T, period_s, period_sigma_s, axis_sigma_deg, probability, pole=(0.0, 0.0, 1.0)) -> SpinSolution:
    state = SpinState(np.asarray(pole, float), period_s, 0.0, EPOCH, np.asarray(axis_T, float))
    cov = np.diag([1e-6, 1e-6, period_sigma_s**2])
    return SpinSolution(state, cov, 0.01, axis_sigma_deg, 100.0, probability, np.ones(1), np.ones(1))


def _result(*solutions) -> InversionResult:
    return InversionResult(tuple(solutions), dof=100, chi2_scale=1.0, model=None, epoch=EPOCH)


def _draws(rng, axis_T, period_s, period_sigma_s, axis_sigma_deg, n, ring_about=None):
    """ω_T draws of one mode: P ~ N(P, σ_P), the axis tilted by N(0, σ_a) on each tangent axis, optionally turned about a ring axis."""
    a = np.asarray(axis_T, float) / np.linalg.norm(axis_T)
    e1 = np.cross(a, [1.0, 0.0, 0.0] if abs(a[0]) < 0.9 else [0.0, 1.0, 0.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(a, e1)
    t = np.radians(axis_sigma_deg) * rng.normal(size=(n, 2))
    axes = a + t[:, :1] * e1 + t[:, 1:] * e2  # small-angle tilt (the linearisation the prior states)
    if ring_about is not None:
        from scipy.spatial.transform import Rotation

        axes = Rotation.from_rotvec(np.outer(rng.uniform(0, 2 * np.pi, n), ring_about)).apply(axes)
    rate = 2 * np.pi / (period_s + period_sigma_s * rng.normal(size=n))
    return rate[:, None] * axes


def test_one_mode_of_an_asymmetric_target_states_the_moments_of_its_draws():
    """box-wing-like inertia (no symmetry): mean ω a and covariance σ_ω² aaᵀ + ω² σ_a² (I − aaᵀ), as Monte Carlo gives."""
    axis = np.array([0.3, -0.5, 0.81])
    axis /= np.linalg.norm(axis)
    rng = np.random.default_rng(11)
    res = _result(_solution(axis, 120.0, 0.5, 2.0, 1.0))
    ip = spin_prior_from_inversion(res, [3441.0, 1137.0, 3024.0])
    assert ip.symmetry_axis_T is None and ip.sense_probability == 1.0
    w = _draws(rng, axis, 120.0, 0.5, 2.0, 200_000)
    np.testing.assert_allclose(ip.prior.w_T_T_rad_s, w.mean(0), atol=3e-6)
    np.testing.assert_allclose(ip.prior.covariance, np.cov(w.T), rtol=0.03, atol=1e-9)


def test_an_axisymmetric_target_averages_the_unobservable_azimuth():
    """Atlas-Centaur-like inertia (A = C): the axis' azimuth about y is averaged out; moments match uniform-azimuth draws."""
    axis = np.array([0.41, 0.3, 0.86])
    axis /= np.linalg.norm(axis)
    rng = np.random.default_rng(12)
    ip = spin_prior_from_inversion(_result(_solution(axis, 127.6, 0.02, 1.0, 1.0)), [22019.0, 2256.8, 22019.0])
    np.testing.assert_array_equal(ip.symmetry_axis_T, [0.0, 1.0, 0.0])
    w = _draws(rng, axis, 127.6, 0.02, 1.0, 400_000, ring_about=np.array([0.0, 1.0, 0.0]))
    np.testing.assert_allclose(ip.prior.w_T_T_rad_s, w.mean(0), atol=2e-4)
    np.testing.assert_allclose(ip.prior.covariance, np.cov(w.T), rtol=0.02, atol=5e-3 * np.cov(w.T).max())  # MC noise ~ 1/sqrt(n)
    assert ip.prior.w_T_T_rad_s[0] == 0.0 and ip.prior.w_T_T_rad_s[2] == 0.0  # nothing known of x and z but their spread


def test_two_modes_of_opposite_sense_leave_the_sense_open():
    """Equal-probability modes about a and −a: mean 0, variance ω² along a — the prior claims no sense."""
    a = np.array([0.0, 0.6, 0.8])
    ip = spin_prior_from_inversion(_result(_solution(a, 100.0, 1e-3, 0.5, 0.5), _solution(-a, 100.0, 1e-3, 0.5, 0.5, pole=(0, 0, -1))),
                                   [3441.0, 1137.0, 3024.0])
    w = 2 * np.pi / 100.0
    np.testing.assert_allclose(ip.prior.w_T_T_rad_s, 0.0, atol=1e-15)
    assert a @ ip.prior.covariance @ a == pytest.approx(w**2, rel=1e-3)
    assert ip.sense_probability == pytest.approx(0.5)
    one = spin_prior_from_inversion(_result(_solution(a, 100.0, 1e-3, 0.5, 0.999), _solution(-a, 100.0, 1e-3, 0.5, 0.001)), [3.0, 1.0, 2.0])
    assert one.sense_probability == pytest.approx(0.999) and one.prior.w_T_T_rad_s @ a > 0.99 * w


@pytest.mark.parametrize("J, axis", [([22019.0, 2256.8, 22019.0], [0, 1, 0]), ([861.8, 861.8, 1113.2], [0, 0, 1]),
                                     ([3441.5, 1137.7, 3024.7], None), ([1674.0, 1674.0, 1674.0], None)])
def test_symmetry_axis_of_the_targets_inertia(J, axis):
    s = symmetry_axis(J)
    assert (s is None) if axis is None else np.array_equal(s, axis)
    with pytest.raises(ValueError, match="expected three positive principal moments"):
        symmetry_axis([1.0, -1.0, 2.0])


@pytest.mark.parametrize("p", [0.8, 0.97])
def test_an_unsettled_sense_shortens_the_mean_and_says_so(p):
    """Modes about a and −a with probabilities p, 1 − p: the mean along a is (2p − 1) ω, its variance 4p(1 − p) ω² (plus the
    modes' own), and the description calls the sense open below SENSE_SETTLED."""
    a = np.array([0.0, 0.6, 0.8])
    ip = spin_prior_from_inversion(_result(_solution(a, 100.0, 1e-3, 0.5, p), _solution(-a, 100.0, 1e-3, 0.5, 1 - p, pole=(0, 0, -1))),
                                   [3441.0, 1137.0, 3024.0])
    w = 2 * np.pi / 100.0
    sigma_w = 2 * np.pi * 1e-3 / 100.0**2
    assert ip.prior.w_T_T_rad_s @ a == pytest.approx((2 * p - 1) * w, rel=1e-9)
    assert a @ ip.prior.covariance @ a == pytest.approx(4 * p * (1 - p) * w**2 + sigma_w**2, rel=1e-6)
    assert ip.sense_settled == (p >= SENSE_SETTLED)
    assert ("NOT settled" in ip.description) == (p < SENSE_SETTLED)
