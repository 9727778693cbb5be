"""The compiled kernels of the period search against direct (slow, obvious) references: phasors, the non-uniform FFT,
nested harmonic fits, lag bins and the Ornstein–Uhlenbeck lag sums."""

import numpy as np
import pytest

from lightcurves.cadence import ou_paths, red_noise, satellite_times, survey_times
from lightcurves.harmonic_fits import design, harmonic_chi2, harmonic_set_chi2, sinusoids_fit
from lightcurves.nufft import trig_sums
from lightcurves.phasors import cis
from astropy.timeseries import LombScargle

from lightcurves.prior import _correlation_fit, _lag_products, _LagBins, _ou_apply, _ou_lags, _red_spectrum, _sinusoid_fits


def test_phasors_are_cos_and_sin_to_the_last_bits():
    """Within 2.3e-16 of numpy's cos and sin, plus the rounding error of θ itself (|θ| 2^-52) beyond |θ| ~ 1e6, where
    the reduction by π/2 is no longer exact — the phases of the period search stay below ~1e6 rad."""
    rng = np.random.default_rng(0)
    for scale in (4.0, 1e3, 1e6, 1e8):
        theta = rng.uniform(-scale, scale, 200_000)
        re, im = np.empty_like(theta), np.empty_like(theta)
        cis(1.0, theta, re, im)
        bound = 2.3e-16 + np.abs(theta) * 2.0**-52
        assert np.all(np.abs(re - np.cos(theta)) <= bound) and np.all(np.abs(im - np.sin(theta)) <= bound)


@pytest.mark.parametrize(
    "n_samples, span_s, n_freq, f0, origin_s",
    [(1500, 2600.0, 2500, 1.9e-4, 0.0), (300, 1.0e8, 12_000, 5e-9, 3e7), (50, 100.0, 1, 0.3, 0.0), (50, 100.0, 7, 0.0, 5.0)],
    ids=["dense-pass", "survey-far-origin", "one-frequency", "seven-from-zero"],
)
def test_trig_sums_equal_the_direct_sums(n_samples, span_s, n_freq, f0, origin_s):
    """Σ h e^{2πi f t} on a regular grid by the Gaussian-gridding NUFFT within 3e-12 of Σ|h| (Greengard & Lee: M_sp = 12,
    R = 2), for one set of weights and for two sharing a spreading pass."""
    rng = np.random.default_rng(1)
    t = origin_s + np.sort(rng.uniform(0.0, span_s, n_samples))
    h = np.stack([rng.uniform(0.5, 2.0, n_samples), rng.normal(size=n_samples)])
    df = 0.2 / span_s
    f = f0 + df * np.arange(n_freq)
    direct = np.stack([np.exp(2j * np.pi * np.outer(f, t)) @ hh for hh in h])
    both = trig_sums(t, h, f0, df, n_freq)
    for k in range(2):
        scale = np.abs(h[k]).sum()
        assert np.max(np.abs(both[k] - direct[k])) < 3e-12 * scale
        assert np.max(np.abs(trig_sums(t, h[k], f0, df, n_freq) - direct[k])) < 3e-12 * scale


def test_trig_sums_refuse_a_bad_grid():
    with pytest.raises(ValueError, match="df > 0"):
        trig_sums(np.arange(5.0), np.ones(5), 0.0, 0.0, 10)


def test_batched_harmonic_chi2_equals_least_squares():
    """The trigonometric-sum normal equations give the χ² of every nested fit exactly."""
    rng = np.random.default_rng(0)
    t = np.sort(rng.uniform(0, 100, 80))
    tc = t - t.mean()
    V = np.vander(tc / 100, 3)
    w = rng.uniform(0.5, 2, t.size)
    y = np.cos(2 * np.pi * 0.13 * t) + 0.3 * np.sin(4 * np.pi * 0.13 * t) + rng.normal(0, 0.1, t.size)
    got = harmonic_chi2(tc, V, y, w**2, np.array([0.1, 0.13, 0.2]), 4)
    for i, f in enumerate([0.1, 0.13, 0.2]):
        for k in range(1, 5):
            X = design(tc, V, f, k) * w[:, None]
            r = y * w - X @ np.linalg.lstsq(X, y * w, rcond=None)[0]
            assert got[i, k - 1] == pytest.approx(r @ r, rel=1e-8)


def test_evenly_spaced_grid_of_frequencies_gives_the_same_chi2_as_one_exponential_each():
    """Rows of evenly spaced frequencies (phasors by products along the row) equal the frequencies one by one."""
    rng = np.random.default_rng(3)
    t = np.sort(rng.uniform(0, 2000, 1500))  # ~ 80 cycles of the highest frequency per row: products accumulate no error
    tc = t - t.mean()
    V = np.vander(tc / 2000, 3)
    y = np.cos(2 * np.pi * 0.04 * t) + rng.normal(0, 0.2, t.size)
    W = rng.uniform(0.5, 2, t.size)
    grid = np.array([0.01, 0.0401, 0.07])[:, None] + np.linspace(-1e-4, 1e-4, 9)[None, :]
    one_by_one = np.concatenate([harmonic_chi2(tc, V, y, W, np.array([f]), 5) for f in grid.ravel()])
    assert np.allclose(harmonic_chi2(tc, V, y, W, grid, 5), one_by_one, rtol=1e-10, atol=0.0)


def _series(rng, n=300):
    t = np.sort(rng.uniform(0.0, 600.0, n))
    tc = t - t.mean()
    V = np.vander(tc / 600.0, 3)
    y = np.cos(2 * np.pi * 0.05 * t) + 0.3 * np.sin(2 * np.pi * 0.1 * t) + rng.normal(0, 0.1, n)
    return tc, V, y, rng.uniform(0.5, 2.0, n)


def test_nested_chi2_of_a_magnitude_curve_is_least_squares():
    """A 12 mag curve with 3 mmag errors (yᵀWy ~ 1e9): the weighted mean is taken out before the normal equations, so
    the ridge 1e-10 tr(G)/p no longer weighs the squared offset (5e-6 of χ² before); it weighs the signal's
    coefficients, ~1e-10 (A/σ)² ≈ 5e-7 of χ² here. Any listed set of harmonics (the even ones of f/2, then 1 and 3:
    the P-against-2P test) is least squares too."""
    rng = np.random.default_rng(8)
    t = np.sort(rng.uniform(0, 3e7, 80))
    tc = t - t.mean()
    V = np.vander(tc / 3e7, 3)
    f = 1 / 2.1e5
    y = 12 + 0.2 * np.cos(2 * np.pi * f * t) + 0.05 * np.cos(np.pi * f * t + 0.3) + rng.normal(0, 0.003, t.size)
    W = np.full(t.size, 0.003**-2)

    def lstsq_chi2(harmonics, g):
        X = np.concatenate([V, *(np.column_stack([np.cos(2 * np.pi * h * g * tc), np.sin(2 * np.pi * h * g * tc)]) for h in harmonics)], axis=1)
        Xw, yw = X * np.sqrt(W)[:, None], y * np.sqrt(W)
        r = yw - Xw @ np.linalg.lstsq(Xw, yw, rcond=None)[0]
        return r @ r

    got = harmonic_chi2(tc, V, y, W, [f], 4)[0]
    assert np.allclose(got, [lstsq_chi2(range(1, k + 1), f) for k in range(1, 5)], rtol=1e-6, atol=0.0)
    order = [2, 4, 6, 1, 3]
    got = harmonic_set_chi2(tc, V, y, W, f / 2, order)
    assert np.allclose(got, [lstsq_chi2(order[:k], f / 2) for k in range(1, 6)], rtol=1e-6, atol=0.0)


def test_harmonic_fits_refuse_a_trend_without_a_constant():
    tc = np.linspace(-1.0, 1.0, 30)
    with pytest.raises(ValueError, match="constant"):
        harmonic_chi2(tc, np.column_stack([tc**2, tc, tc**3]), np.cos(tc), np.ones(30), [0.3], 1)
    with pytest.raises(ValueError, match="distinct"):
        harmonic_set_chi2(tc, np.vander(tc, 3), np.cos(tc), np.ones(30), 0.3, [1, 1])


def test_design_columns_are_the_harmonics():
    """Harmonics as powers of one phasor: 12 harmonics equal numpy's cos and sin to within the rounding of the phases
    (up to 1000 rad here: |θ| 2^-52 each)."""
    tc, V, _, _ = _series(np.random.default_rng(2))
    arg = 2 * np.pi * 0.0437 * np.outer(tc, np.arange(1, 13))
    bound = 1e-14 + 2.0 * np.abs(np.concatenate([np.zeros_like(V), arg, arg], axis=1)) * 2.0**-52
    assert np.all(np.abs(design(tc, V, 0.0437, 12) - np.concatenate([V, np.cos(arg), np.sin(arg)], axis=1)) <= bound)


def test_nested_chi2_with_a_degenerate_column_lowers_nothing():
    """At f = 1/(2Δt) on even sampling one of cos, sin vanishes at every sample: the degenerate column takes no part in
    the fit (L_ii = ∞) and χ² is the least-squares χ² of the rank-deficient design."""
    t = np.arange(0.0, 200.0, 1.0)
    tc = t - t.mean()
    V = np.vander(tc / 200.0, 3)
    y = np.cos(np.pi * t) + np.random.default_rng(3).normal(0, 0.1, t.size)
    got = harmonic_chi2(tc, V, y, np.ones(t.size), [0.5], 1)[0, 0]
    X = np.column_stack([V, np.cos(np.pi * tc), np.sin(np.pi * tc)])
    r = y - X @ np.linalg.lstsq(X, y, rcond=1e-10)[0]
    assert np.isfinite(got) and got == pytest.approx(r @ r, rel=1e-8)


def test_two_sinusoid_fit_is_least_squares():
    """The compiled normal equations of trend + two sinusoids (ridge 1e-12 of the trace) are numpy's to 1e-10, and
    numpy's least squares to what the ridge moves (1e-7)."""
    rng = np.random.default_rng(4)
    tc, V, y, w = _series(rng)
    freqs = np.array([0.0501, 0.0713])
    X = np.concatenate([V, *(np.column_stack([np.cos(2 * np.pi * f * tc), np.sin(2 * np.pi * f * tc)]) for f in freqs)], axis=1) * w[:, None]
    G = X.T @ X
    ridge = np.linalg.solve(G + 1e-12 * np.trace(G) * np.eye(7), X.T @ (y * w))
    r, c = sinusoids_fit(tc, V, y, w, freqs)
    assert np.allclose(c, ridge, rtol=1e-10, atol=0.0) and np.allclose(r, y * w - X @ ridge, rtol=0.0, atol=1e-12)
    assert np.allclose(c, np.linalg.lstsq(X, y * w, rcond=None)[0], rtol=1e-7, atol=0.0)


def _lag_bins_by_logarithm(t, r):
    """The definition: every pair (i, i + k), k ≤ min(N − 1, 200), lag ≤ T/4, binned by the logarithm of its lag into 25
    equal bins from the shortest lag to the longest kept one; pairs, mean lag and Σ r_i r_{i+k} per bin."""
    T = t[-1] - t[0]
    L = min(t.size - 1, 200)
    i, k = np.meshgrid(np.arange(t.size), np.arange(1, L + 1), indexing="ij")
    ok = i + k < t.size
    i, j = i[ok], (i + k)[ok]
    d = t[j] - t[i]
    keep = d <= 0.25 * T
    lo, hi = np.log(d.min() * (1 - 1e-9)), np.log(d[keep].max() * (1 + 1e-9))
    b = np.minimum((np.log(d[keep]) - lo) * 25.0 / (hi - lo), 24.0).astype(int)
    n = np.bincount(b, minlength=25)
    return n, np.bincount(b, d[keep], minlength=25), np.bincount(b, (r[i] * r[j])[keep], minlength=25)


@pytest.mark.parametrize("kind", ["satellite", "survey", "even"])
def test_lag_bins_are_the_logarithmic_bins_of_every_pair(kind):
    """The runs of k found by one pointer per bin edge hold the pairs the logarithm puts in each bin: the same counts,
    the same mean lags, the same lag products (prefix sums, 1e-12)."""
    rng = np.random.default_rng(5)
    t = {"satellite": lambda: satellite_times(rng, n_passes=2, pass_s=600.0, cadence_s=0.7, pass_gap_s=2000.0),
         "survey": lambda: survey_times(rng, 200), "even": lambda: np.arange(0.0, 400.0, 1.0)}[kind]()
    r = rng.normal(size=t.size)
    n_ref, lag_ref, prod_ref = _lag_bins_by_logarithm(t, r)
    lags = _LagBins.of(t)
    assert np.array_equal(lags.nb, n_ref[n_ref > 0]) and np.array_equal(lags.ok, n_ref > 0)
    assert np.allclose(lags.lag, lag_ref[n_ref > 0] / n_ref[n_ref > 0], rtol=1e-12)
    assert np.allclose(_lag_products(r[None, :], lags.bounds)[0, lags.ok], prod_ref[n_ref > 0], rtol=1e-12, atol=1e-12 * np.abs(prod_ref).max())


def test_correlation_fit_recovers_an_ornstein_uhlenbeck_fraction_and_time():
    rng = np.random.default_rng(5)
    t = np.cumsum(rng.uniform(0.5, 1.5, 800))
    r = red_noise(rng, t, 1.0, 10.0) + rng.normal(0, 0.5, t.size)
    assert _correlation_fit(t, r, _LagBins.of(t)) == _correlation_fit(t, r)
    a, tau = _correlation_fit(t, r)
    assert 0.5 < a < 0.95 and 5.0 < tau < 20.0  # OU variance fraction 0.8, τ = 10 s


@pytest.mark.parametrize("tau_s, cadence_s, pass_s, binned", [(3.0, 3.0, 600.0, False), (20.0, 0.8, 1500.0, True)])
def test_red_spectrum_is_the_sum_over_every_pair(tau_s, cadence_s, pass_s, binned):
    """E P(f)/σ² = 1 + (2a/N) Σ_{j<k, Δ<5τ} e^{−Δ/τ} cos 2πfΔ over every pair: exact (1e-9) with the lags as they are,
    within 1e-5 of the spectrum's peak when dense lags are binned to 1e-3/f_max (weighted mean lag per bin)."""
    rng = np.random.default_rng(6)
    t = satellite_times(rng, pass_s=pass_s, cadence_s=cadence_s)
    T = t[-1] - t[0]
    freq = 0.5 / T + 0.2 / T * np.arange(int(0.5 / cadence_s * 5 * T))
    D = t[None, :] - t[:, None]
    lag = D[(D > 0) & (D < 5 * tau_s)]
    assert (_ou_lags(t, tau_s, 1e-3 / freq[-1])[0].size < lag.size) == binned
    f = freq[::40]
    direct = np.maximum(1 + 2 * 0.7 * (np.cos(2 * np.pi * np.outer(f, lag)) @ np.exp(-lag / tau_s)) / t.size, 0.05)
    got = _red_spectrum(t, 0.7, tau_s, freq)[::40]
    assert np.max(np.abs(got - direct)) < (1e-5 * direct.max() if binned else 1e-9)


@pytest.mark.parametrize("errors", [True, False])
def test_batched_sinusoid_fits_are_astropys(errors):
    """Power (standard normalisation) and semi-amplitude at a few frequencies equal LombScargle's exact power and model
    parameters, for a sparse 12 mag survey curve with errors and a dense one without."""
    rng = np.random.default_rng(9)
    t = survey_times(rng, 80) if errors else np.sort(rng.uniform(0.0, 600.0, 300))
    period = 3.3 * 86400.0 if errors else 37.0
    dy = rng.uniform(0.02, 0.05, t.size) if errors else None
    y = 12 + 0.3 * np.cos(2 * np.pi * t / period) + rng.normal(0, 0.03, t.size)
    f = rng.uniform(0.5, 2.0, 6) / period
    ls = LombScargle(t, y, dy)
    power, amplitude = _sinusoid_fits(t, y, dy, f)
    assert np.allclose(power, ls.power(f, method="cython"), rtol=0.0, atol=1e-12)
    assert np.allclose(amplitude, [np.hypot(*ls.model_parameters(x)[1:]) for x in f], rtol=1e-10, atol=0.0)


def test_ou_kernel_product_is_the_dense_matrix_product():
    """``_ou_apply`` (two recursions along sorted times) equals ``K U`` with the dense ``K_ij = e^{−|t_i − t_j|/τ}``,
    and an OU path of ``ou_paths`` has the kernel's lag-one correlation."""
    rng = np.random.default_rng(4)
    t = np.sort(rng.uniform(0.0, 300.0, 400))
    U = rng.normal(size=(t.size, 3))
    K = np.exp(-np.abs(t[:, None] - t[None, :]) / 7.0)
    np.testing.assert_allclose(_ou_apply(t, U, 7.0), K @ U, rtol=1e-10, atol=1e-10)
    te = np.arange(0.0, 20000.0, 1.0)
    x = ou_paths(te, 5.0, rng.standard_normal((1, te.size)))[0]
    assert abs(np.mean(x[1:] * x[:-1]) - np.exp(-1 / 5.0)) < 0.03 and abs(np.var(x) - 1.0) < 0.08
