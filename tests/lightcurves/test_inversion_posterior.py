"""How much information residuals carry (lightcurves.inversion.posterior, eqs. 1–4): white, AR(1), night-coherent error, an inversion.

White residuals must leave the posterior as it is (κ ≈ 1, s ≈ 1); correlated ones must inflate it by their integrated
autocorrelation time, which for an AR(1) process of lag-one correlation ρ is analytic, τ = (1 + ρ)/(1 − ρ); the nights'
score dispersion φ must follow its χ² law on white residuals and measure an error coherent over each night (which κ
misses); and the inflated covariance of least-squares fits must hold the truth at the nominal rate.
"""

import numpy as np
import pytest
from scipy.signal import lfilter
from scipy.stats import binom, chi2, f as f_dist

from lightcurves.inversion.posterior import (SOKAL_WINDOW_C, integrated_autocorrelation_time, night_score_dispersion, posterior_scale,
                                             residual_correlation_time)
from lightcurves.inversion.search import invert
from lightcurves.inversion.spin import SpinState
from lightcurves.inversion.frames import pole_from_radec
from tests.lightcurves.test_inversion_search import ELLIPSOID, EPOCH, FAST, _observe_curves, _passes


def _ar1(rng, rho: float, n: int, size: int = 1) -> np.ndarray:
    """``size`` stationary AR(1) series (size, n) of unit variance: x_i = ρ x_{i−1} + √(1 − ρ²) e_i, x_0 ~ N(0, 1)."""
    e = rng.standard_normal((size, n))
    zi = rho * rng.standard_normal((size, 1))
    return lfilter([np.sqrt(1.0 - rho**2)], [1.0, -rho], e, axis=1, zi=zi)[0]


def _sokal_sd(tau: float, n: int) -> float:
    """1-σ of the windowed estimator, τ √(2(2M + 1)/n) with M = c τ (Priestley 1981, §5.3)."""
    return tau * np.sqrt(2.0 * (2.0 * SOKAL_WINDOW_C * tau + 1.0) / n)


def test_white_residuals_carry_full_information():
    rng = np.random.default_rng(3)
    nights = np.repeat(np.arange(3), 600)
    kappa = np.array([residual_correlation_time(rng.standard_normal(nights.size), nights) for _ in range(200)])
    sd = _sokal_sd(1.0, nights.size)
    # unbiased: the mean of 200 draws within 4 standard errors of 1; every draw within 5σ
    assert abs(kappa.mean() - 1.0) < 4 * sd / np.sqrt(kappa.size)
    assert np.all(np.abs(kappa - 1.0) < 5 * sd)


@pytest.mark.parametrize("rho", [0.5, 0.8])
def test_ar1_integrated_autocorrelation_time_is_analytic(rho):
    rng = np.random.default_rng(int(rho * 10))
    tau = (1.0 + rho) / (1.0 - rho)
    n, m = 20000, 20
    est = np.array([integrated_autocorrelation_time(x) for x in _ar1(rng, rho, n, m)])
    assert abs(est.mean() - tau) < 4 * _sokal_sd(tau, n) / np.sqrt(m)
    # pooled over three nights the same (each its own series: no lag crosses a night)
    nights = np.repeat(np.arange(3), n // 4)
    pooled = residual_correlation_time(_ar1(rng, rho, nights.size)[0], nights)
    assert abs(pooled - tau) < 4 * _sokal_sd(tau, nights.size)


def test_constant_residuals_are_one_datum_per_night():
    nights = np.repeat(np.arange(2), 50)
    r = np.where(nights == 0, 0.3, -0.2)
    assert residual_correlation_time(r, nights) == pytest.approx(50.0)
    s, kappa, phi = posterior_scale(r, nights, dof=98)
    assert s == pytest.approx(kappa * float(r @ r) / 98) and np.isnan(phi)


def test_inflated_covariance_covers_the_truth_under_ar1_noise():
    """y = a + b t + AR(1) noise (ρ = 0.8, unit variance, stated σ = 1) on three nights: the least-squares estimate's Mahalanobis²
    under s H⁻¹ (eq. 1) follows χ²₂ (95 % region holds the truth at a rate within the binomial 99.9 % interval of 0.95);
    under H⁻¹ alone it is τ = 9 times too large."""
    rng = np.random.default_rng(7)
    nights = np.repeat(np.arange(3), 1500)
    t = np.concatenate([np.linspace(0, 1, 1500) + 3 * k for k in range(3)])
    J = np.column_stack([np.ones_like(t), t - t.mean()])
    H_inv = np.linalg.inv(J.T @ J)
    truth = np.array([1.0, 0.2])
    noise = _ar1(rng, 0.8, t.size, 300)
    m2, m2_raw = [], []
    for e in noise:
        x = H_inv @ J.T @ (J @ truth + e)
        r = J @ x - (J @ truth + e)
        s, _, _ = posterior_scale(r, nights, dof=t.size - 2)
        d = x - truth
        m2_raw.append(d @ np.linalg.solve(H_inv, d))
        m2.append(m2_raw[-1] / s)
    inside = int(np.sum(np.array(m2) <= chi2.ppf(0.95, 2)))
    lo, hi = binom.ppf([0.0005, 0.9995], len(m2), 0.95)
    assert lo <= inside <= hi
    assert np.mean(m2_raw) > 5 * 2.0  # the white-noise covariance: mean Mahalanobis² ≈ 2τ, not 2


def _harmonic_fit(rng, n_nights: int, n: int, systematic: float):
    """Least squares of y = a cos ωt + b sin ωt (unit white noise) on ``n_nights`` nights of ``n`` samples, plus, per night, a
    model error ``A_k cos(ωt + ψ_k)`` with A_k ~ N(0, systematic²), ψ_k uniform: coherent over the night, small in power.
    Returns (estimate error (2,), J (N, 2), residuals (N,), nights (N,))."""
    t = np.arange(n) * 1.0
    omega = 2 * np.pi / 97.0
    J = np.tile(np.column_stack([np.cos(omega * t), np.sin(omega * t)]), (n_nights, 1))
    nights = np.repeat(np.arange(n_nights), n)
    A, psi = systematic * rng.standard_normal(n_nights), rng.uniform(0, 2 * np.pi, n_nights)
    e = rng.standard_normal(J.shape[0]) + np.repeat(A, n) * np.cos(omega * np.tile(t, n_nights) + np.repeat(psi, n))
    x = np.linalg.lstsq(J, e, rcond=None)[0]  # truth (0, 0): the estimate is its error
    return x, J, J @ x - e, nights


def test_night_score_dispersion_is_chi2_on_white_residuals():
    rng = np.random.default_rng(5)
    draws = [_harmonic_fit(rng, 4, 300, 0.0) for _ in range(400)]
    out = [night_score_dispersion(J, r, g) for _, J, r, g in draws]
    dof = out[0][1]
    assert dof == 4 * 2 - 2  # Σ rank G_k − p
    phi = np.array([o[0] for o in out])
    assert abs(phi.mean() - 1.0) < 4 * np.sqrt(2.0 / dof / phi.size)  # E φ = 1, var 2/dof
    assert np.mean(phi <= chi2.ppf(0.95, dof) / dof) == pytest.approx(0.95, abs=4 * np.sqrt(0.95 * 0.05 / phi.size))


def test_night_coherent_error_is_measured_by_phi_not_kappa():
    """A model error coherent over each night (amplitude 0.25 per sample: 3 % of the residual power) multiplies the estimate's
    variance by 1 + 0.25² n / 4 ≈ 5.7 (n = 300): κ stays below 2, φ finds it, and with s of eq. (1) the estimate's Mahalanobis²
    over φ follows 2·F(2, dof) (the scale estimated from dof = 10 night-degrees of freedom), so the F-region holds the truth
    at its nominal 95 %."""
    rng = np.random.default_rng(9)
    n, nights = 300, 6
    draws = [_harmonic_fit(rng, nights, n, 0.25) for _ in range(300)]
    H = draws[0][1].T @ draws[0][1]
    dof = nights * 2 - 2
    kappa, phi, inside_f, inside_s = [], [], 0, 0
    for x, J, r, g in draws:
        s, k, p = posterior_scale(r, g, J.shape[0] - 2, J)
        kappa.append(k)
        phi.append(p)
        m2 = x @ H @ x
        inside_f += m2 / p <= 2 * f_dist.ppf(0.95, 2, dof)
        inside_s += m2 / s <= 2 * f_dist.ppf(0.95, 2, dof)
    assert np.mean(kappa) < 2.0  # the window (M ≈ 5 τ) sees a little of the coherent error, not its 5.7×
    assert np.mean(phi) == pytest.approx(1 + 0.25**2 * n / 4, rel=4 * np.sqrt(2.0 / dof / len(draws)))
    lo, hi = binom.ppf([0.0005, 0.9995], len(draws), 0.95)
    assert lo <= inside_f <= hi
    assert inside_s >= lo  # s ≥ φ: never less conservative


def test_inverse_crime_inversion_is_not_inflated():
    """Data from the ellipsoid model itself with white noise: the fit's κ and s stay within a χ²-like bound of 1."""
    rng = np.random.default_rng(11)
    truth = SpinState(pole_from_radec(1.0, 0.6), 60.0, 0.3, EPOCH)
    curves = _observe_curves(truth, ELLIPSOID, _passes(rng), rng)
    res = invert(curves, ELLIPSOID, (59.7, 60.3), **FAST)
    n = sum(len(c) for c in curves)
    assert abs(res.correlation_time - 1.0) < 4 * _sokal_sd(1.0, n)
    # three nights, six parameters: φ is χ²₁₂/12 on white residuals
    assert res.night_dispersion < chi2.ppf(0.999, 12) / 12
    assert 1.0 <= res.chi2_scale <= max(1.0 + 4 * np.hypot(_sokal_sd(1.0, n), np.sqrt(2.0 / res.dof)), res.night_dispersion)


def test_bad_input_names_the_field():
    with pytest.raises(ValueError, match="groups"):
        residual_correlation_time(np.zeros(5), np.zeros(4))
    with pytest.raises(ValueError, match="dof"):
        posterior_scale(np.ones(5), np.zeros(5), 0)
    with pytest.raises(ValueError, match="jacobian"):
        night_score_dispersion(np.zeros((4, 2)), np.zeros(5), np.zeros(5))
    with pytest.raises(ValueError, match="^r: "):
        integrated_autocorrelation_time([1.0, np.nan, 2.0])
