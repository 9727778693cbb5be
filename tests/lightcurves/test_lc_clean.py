"""WindowCLEAN on unevenly sampled, gapped data; against astropy's LombScargle; direct vs fast."""

import numpy as np
import pytest
from astropy.timeseries import LombScargle

from lightcurves import window_clean
from lightcurves.clean import false_alarm_probability, power_threshold


def gapped_times(rng, T=400.0, n=900):
    t = np.sort(rng.uniform(0.0, T, n))
    return t[((t < 120) | (t > 170)) & ((t < 300) | (t > 330))]  # two gaps (clouds)


@pytest.mark.parametrize("seed", [2, 3, 4])
def test_two_injected_sinusoids_are_recovered(seed):
    """Frequencies within 0.1 resolution element, amplitudes within 5 %."""
    rng = np.random.default_rng(seed)
    t = gapped_times(rng)
    f = np.array([0.0312, 0.0871]) + rng.uniform(0, 0.002, 2)  # off the frequency grid
    A = np.array([0.5, 0.2])
    y = 3.0 + A[0] * np.sin(2 * np.pi * f[0] * t + 0.3) + A[1] * np.cos(2 * np.pi * f[1] * t + 1.0) + rng.normal(0, 0.02, t.size)
    res = window_clean(t, y)
    peaks = res.peaks()
    assert len(peaks) >= 2
    T = t[-1] - t[0]
    for p, fi, Ai in zip(peaks[:2], f, A):
        assert abs(p.frequency_hz - fi) * T < 0.1
        assert p.amplitude == pytest.approx(Ai, rel=0.05)
    # the residual is the injected noise
    assert res.noise_sigma == pytest.approx(0.02, rel=0.15)
    assert res.converged


def test_result_holds_every_spectrum_and_the_clean_beam():
    rng = np.random.default_rng(7)
    t = gapped_times(rng)
    y = np.sin(2 * np.pi * 0.05 * t) + rng.normal(0, 0.05, t.size)
    r = window_clean(t, y)
    m = r.frequency_hz.size
    assert r.dirty.shape == r.clean.shape == r.residual.shape == r.components.shape == r.beam.shape == (m,)
    assert r.window.shape == (2 * m - 1,)
    assert r.window[0] == pytest.approx(1.0)
    assert r.beam[0] == pytest.approx(1.0)
    # the Gaussian beam matches the window's main lobe at its half-power point
    half = np.argmin(np.abs(np.abs(r.window[:20]) - 0.5))
    assert abs(np.abs(r.window[half]) - np.exp(-0.5 * (r.window_frequency_hz[half] / r.beam_sigma_hz) ** 2)) < 0.1
    # the components' model plus the residual series reproduce the data
    np.testing.assert_allclose(r.model(t) + r.residual_series, y, atol=1e-9)
    # cleaning removed the aliases: the dirty spectrum's sidelobes exceed the clean one's off the peak
    off = np.abs(r.frequency_hz - 0.05) > 3.0 / (t[-1] - t[0])
    assert np.abs(r.clean[off]).max() < 0.5 * np.abs(r.dirty[off]).max()


def test_direct_and_fast_implementations_agree():
    rng = np.random.default_rng(5)
    t = gapped_times(rng, n=400)
    y = np.sin(2 * np.pi * 0.04 * t) + 0.3 * np.sin(2 * np.pi * 0.11 * t) + rng.normal(0, 0.1, t.size)
    a = window_clean(t, y, method="direct")
    b = window_clean(t, y, method="fast")
    scale = np.abs(a.dirty).max()
    np.testing.assert_allclose(b.dirty, a.dirty, atol=1e-5 * scale)
    np.testing.assert_allclose(b.window, a.window, atol=1e-5)
    assert [round(p.frequency_hz, 6) for p in a.peaks()[:2]] == [round(p.frequency_hz, 6) for p in b.peaks()[:2]]


def test_strongest_peak_agrees_with_astropy_lombscargle():
    """LombScargle (the baseline) and WindowCLEAN find the same frequency for one sinusoid in noise."""
    rng = np.random.default_rng(11)
    t = gapped_times(rng)
    f0 = 0.0437
    y = 0.3 * np.sin(2 * np.pi * f0 * t) + rng.normal(0, 0.1, t.size)
    r = window_clean(t, y)
    ls = LombScargle(t, y)
    power = ls.power(r.frequency_hz[1:])
    f_ls = r.frequency_hz[1:][np.argmax(power)]
    T = t[-1] - t[0]
    assert abs(r.peaks()[0].frequency_hz - f0) * T < 0.1
    assert abs(f_ls - f0) * T <= 0.125 + 1e-9  # LombScargle on the same grid: within half a grid step


def test_false_alarm_threshold_inverts_the_probability():
    for level, M in [(0.01, 1600), (1e-3, 40000)]:
        z = power_threshold(level, M)
        assert false_alarm_probability(z, M) == pytest.approx(level, rel=1e-9)


def test_pure_noise_has_no_significant_peak_at_the_stated_level():
    """Over 100 white-noise series the fraction with a significant peak is near the 1 % level."""
    rng = np.random.default_rng(0)
    hits = 0
    for _ in range(100):
        t = np.sort(rng.uniform(0, 400, 300))
        hits += bool(window_clean(t, rng.normal(size=t.size), max_iter=5).peaks())
    assert hits <= 5  # binomial(100, 0.01): P(X > 5) < 1e-3


@pytest.mark.parametrize("kwargs, match", [({"gain": 0.0}, "gain"), ({"method": "nufft"}, "method"), ({"false_alarm_level": 1.5}, "false_alarm_level")])
def test_bad_options_raise(kwargs, match):
    t = np.linspace(0, 100, 50)
    with pytest.raises(ValueError, match=match):
        window_clean(t, np.sin(t), **kwargs)
