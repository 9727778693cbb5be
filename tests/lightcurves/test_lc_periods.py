"""Period finding on sparse, aliased and noisy sampling; false alarms; the 1-σ's calibration (issue 13)."""

import numpy as np
import pytest
from scipy import stats
from scipy.optimize import minimize_scalar

from lightcurves import extract_spin_prior
from lightcurves.cadence import DAY_S, curve, heteroscedastic_noise, red_noise, satellite_times, survey_times
from lightcurves.clean_implementations.fast import window
from astropy.timeseries import LombScargle

from lightcurves.prior import _odd_harmonic_test, _prepare, _rank, _trial_frequencies
from lightcurves.samples import check_samples


def test_periodogram_and_residual_periodogram_are_astropys():
    """The written-out periodogram (sums by lightcurves.nufft) is astropy's fast one at its default accuracy; the
    residuals' one, from the data's weight sums less the samples dropped as outliers, is astropy's on the kept samples."""
    rng = np.random.default_rng(4)
    t = satellite_times(rng, n_passes=2, pass_s=600.0, cadence_s=1.0, pass_gap_s=3000.0)
    dy = rng.uniform(0.02, 0.05, t.size)
    y = 8.0 + curve("double", t / 37.0, 0.5, rng) + rng.normal(0, dy)
    s = _prepare(t, y, dy, None, None)
    ls = LombScargle(t, s.yd, dy, normalization="standard")
    assert np.max(np.abs(s.power - ls.power(s.freq, method="fast", assume_regular_frequency=True))) < 1e-10
    for n_drop in (3, 40):
        drop = np.zeros(t.size, bool)
        drop[rng.choice(t.size, n_drop, replace=False)] = True
        sd = s.without(drop)
        r = rng.normal(0, 0.03, sd.n)
        ref = LombScargle(sd.t, r, sd.dy, normalization="standard").power(s.freq[::5], method="fast", assume_regular_frequency=True)
        assert np.max(np.abs(sd.pg.power(r, sd.kept, 5) - ref)) < 1e-10


def test_survey_cadence_has_daily_and_yearly_windows():
    t = survey_times(np.random.default_rng(1), 200, n_seasons=3)
    assert t.size == 200 and np.all(np.diff(t) > 0)
    assert 1.5 * 365.25 * DAY_S < t[-1] - t[0] < 3 * 365.25 * DAY_S
    T = t[-1] - t[0]
    df = 0.2 / T
    W = np.abs(window(t, df, int(2.5 / DAY_S / df)))
    nu = df * np.arange(W.size)
    near = lambda f0: W[np.abs(nu - f0) < 2 / T].max()  # noqa: E731
    assert near(1 / DAY_S) > 0.6  # nightly sampling: a strong 1/day alias
    assert near(1 / (365.25 * DAY_S)) > 0.3  # seasons: a 1/yr alias
    assert np.median(W[(nu > 0.3 / DAY_S) & (nu < 0.7 / DAY_S)]) < 0.2


# Sparse multi-season curves with two unequal minima or maxima per cycle: the strongest periodogram peak is at
# twice the fundamental and the nightly window adds ±1/day aliases. The old ranking (spec.peaks() then "maxima")
# returned an alias or a harmonic for every one of these (checked against main before the change).
SPARSE = [("eclipsing", 1.83, 90, 11), ("sawtooth", 5.37, 60, 12), ("double", 0.61, 120, 13), ("eclipsing", 11.2, 150, 14)]


@pytest.mark.parametrize("shape, period_d, n, seed", SPARSE)
def test_sparse_multiseason_fundamental_recovered(shape, period_d, n, seed):
    rng = np.random.default_rng(seed)
    t = survey_times(rng, n, n_seasons=3)
    P = period_d * DAY_S
    noise, err = heteroscedastic_noise(rng, t.size, 0.03)
    y = 12 + curve(shape, t / P + 0.3, 0.6, rng) + noise
    p = extract_spin_prior(t, y, err, nu_max=1 / (2 * 3600.0))
    assert p.significant
    assert p.frequency_hz * P == pytest.approx(1.0, abs=1e-3)


def test_strongest_harmonic_above_the_band_still_gives_the_fundamental():
    """A double-peaked 2.6 h curve on survey cadence, searched up to 1/(2 h): its strongest harmonic (1/1.3 h) lies
    above the band. The band bounds the rotation frequency, not its harmonics; with harmonics capped at ``nu_max`` and
    no candidates from above it, 3 of these 10 curves were ranked at an alias (f × 0.39, 1.04, 1.11), one of them
    significant."""
    P = 2.6 * 3600.0
    for seed in range(10):
        rng = np.random.default_rng(seed)
        t = survey_times(rng, 150)
        y = 12 + curve("double", t / P, 0.5, rng) + rng.normal(0, 0.02, t.size)
        p = extract_spin_prior(t, y, np.full(t.size, 0.02), nu_max=1 / 7200.0)
        assert p.best_frequency_hz * P == pytest.approx(1.0, abs=1e-3), seed
        assert not p.significant or p.frequency_hz == p.best_frequency_hz


def test_significance_fits_the_trend_jointly_on_sparse_seasons():
    """40 visits over five seasons of a 3.3 d sinusoid (SNR 2.4 per visit): the quadratic over the seasons is far from
    orthogonal to the sinusoid on these times, and removed first it took part of the periodogram peak (power 0.56
    detrended against 0.71 with the trend fitted jointly). The old significance, from the detrended periodogram
    alone, refused the period (false-alarm probability 0.028); the trend fitted jointly gives 7e-5."""
    rng = np.random.default_rng(735)
    t = survey_times(rng, 40, n_seasons=5)
    P = 3.3 * DAY_S
    err = np.full(t.size, 0.05)
    y = 12.0 + 0.12 * np.cos(2 * np.pi * t / P) + rng.normal(0, 0.05, t.size)
    p = extract_spin_prior(t, y, err, nu_max=1 / 7200.0)
    assert p.significant and p.false_alarm_probability < 1e-3
    assert p.frequency_hz * P == pytest.approx(1.0, abs=1e-3)
    s = _prepare(t, y, err, None, 1 / 7200.0)
    f = s.freq[int(np.argmin(np.abs(s.freq - p.frequency_hz)))]
    trend, *_ = np.linalg.lstsq(s.V * s.w[:, None], s.y * s.w, rcond=None)
    joint = 1.0 - s.chi2([f], 1)[0, 0] / float(s.W @ (s.y - s.V @ trend) ** 2)
    assert joint > 1.2 * float(np.interp(f, s.freq, s.power))


def _false_alarms(make, n_trials, level, rng):
    return sum(extract_spin_prior(*make(rng), false_alarm_level=level).significant for _ in range(n_trials))


@pytest.mark.parametrize(
    "case",
    [
        pytest.param(lambda rng: (np.arange(0.0, 300.0, 1.0), rng.normal(0, 0.02, 300)), id="even-1s"),
        pytest.param(lambda rng: (lambda t: (t, rng.normal(0, 0.05, t.size), np.full(t.size, 0.05)))(survey_times(rng, 60)), id="survey-60"),
    ],
)
def test_white_noise_false_alarm_rate_at_most_the_level(case):
    """Even 1 s sampling included (the Nyquist breakdown gave 100 % false alarms). Baluev's FAP is an upper bound,
    so the count must not exceed the 99.9 % binomial quantile of Bin(n, level)."""
    n, level = 80, 0.05
    k = _false_alarms(case, n, level, np.random.default_rng(7))
    assert k <= stats.binom.ppf(0.999, n, level)


def test_red_noise_false_alarm_rate_below_five_percent():
    """Ornstein–Uhlenbeck noise, τ = 20 s at 1 s cadence (correlated over 20 samples): the white-noise FAP gave
    66–100 % false periods."""
    n = 60
    k = _false_alarms(lambda rng: (lambda t: (t, red_noise(rng, t, 0.03, 20.0)))(np.arange(0.0, 400.0, 1.0)), n, 0.01, np.random.default_rng(8))
    assert k <= stats.binom.ppf(0.999, n, 0.05)


def test_three_cycles_of_a_sinusoid_give_the_rate_not_a_third_of_it():
    """Issue 13: 60 s period (6 deg/s), 3.4 cycles — the old maxima decision returned 2.03 deg/s."""
    rng = np.random.default_rng(1)
    t = np.arange(0.0, 204.0, 1.0)
    p = extract_spin_prior(t, 10 + 0.3 * np.cos(2 * np.pi * t / 60) + rng.normal(0, 0.02, t.size))
    assert p.significant and p.maxima_per_rotation == 1
    assert p.rate_deg_s == pytest.approx(6.0, rel=0.005)


def test_the_synodic_term_enters_the_sigma_only_with_geometry_and_its_absence_is_said():
    """The 1-σ adds the bisector's turning rate in quadrature; without geometry it says it cannot."""
    rng = np.random.default_rng(4)
    t = np.arange(0.0, 600.0, 1.0)
    y = 10 + 0.3 * np.cos(2 * np.pi * t / 60) + rng.normal(0, 0.02, t.size)
    bare = extract_spin_prior(t, y)
    assert bare.rate_sigma_synodic_rad_s == 0.0 and any("no viewing geometry" in w for w in bare.warnings)
    # the bisector of a Sun fixed along x and an observer turning at 1e-4 rad/s in the x-y plane turns at 5e-5 rad/s
    sun = np.tile([1.0, 0.0, 0.0], (t.size, 1))
    obs = np.column_stack([np.cos(1e-4 * t + 0.5), np.sin(1e-4 * t + 0.5), np.zeros(t.size)])
    geo = extract_spin_prior(t, y, sun_dir=sun, observer_dir=obs)
    assert geo.rate_sigma_synodic_rad_s == pytest.approx(5e-5, rel=1e-6)
    assert geo.rate_sigma_rad_s == pytest.approx(np.hypot(geo.rate_sigma_statistical_rad_s, 5e-5), rel=1e-9)
    assert not any("no viewing geometry" in w for w in geo.warnings)


def test_less_than_one_turn_is_refused_with_a_warning():
    """Issue 13: a 300 s arc at 1 deg/s (0.83 turn) returned 1.997 deg/s with no warning."""
    rng = np.random.default_rng(2)
    t = np.arange(0.0, 300.0, 1.0)
    p = extract_spin_prior(t, 10 + 0.3 * np.cos(2 * np.pi * t / 360 + 0.3) + rng.normal(0, 0.02, t.size))
    assert not p.significant and p.rate_deg_s is None
    assert any("cycles in the" in w for w in p.warnings) and p.n_cycles < 1 and p.to_dict()["warnings"]


def _calibration_z(n_sims, seed):
    rng = np.random.default_rng(seed)
    z = []
    for i in range(n_sims):
        t = satellite_times(rng, pass_s=rng.uniform(300, 800), cadence_s=rng.uniform(0.8, 2.0))
        P = rng.uniform(20.0, 60.0)
        amp = rng.uniform(0.3, 1.0)
        noise, err = heteroscedastic_noise(rng, t.size, amp / rng.uniform(5, 20), spread=0.2, outlier_fraction=0.0)
        if i % 2:
            noise = noise + red_noise(rng, t, np.median(err), rng.uniform(3.0, 15.0))
        y = 8 + curve(("sawtooth", "double", "eclipsing")[i % 3], t / P + rng.uniform(), amp, rng) + noise
        p = extract_spin_prior(t, y, err)
        assert p.significant
        z.append((p.frequency_hz - 1 / P) * 2 * np.pi / p.rate_sigma_rad_s)
    return np.abs(np.array(z))


def test_rate_sigma_is_calibrated():
    """|z| = |error|/σ over 100 simulations (non-sinusoidal shapes — the K-harmonic model leaves structure — and
    half with red noise): the fractions within 1 and 2 σ lie in the 99.9 % binomial bands around 68.3 % and 95.4 %.
    The white-noise σ was 26–35× too small."""
    z = _calibration_z(100, 21)
    n = z.size
    lo1, hi1 = stats.binom.ppf([0.0005, 0.9995], n, 0.683)
    lo2, hi2 = stats.binom.ppf([0.0005, 0.9995], n, 0.954)
    assert lo1 <= np.sum(z < 1) <= hi1
    assert lo2 <= np.sum(z < 2) <= hi2


def _red_sinusoid(rng, tau_s, spread):
    """A 600 s pass at 1 s: a 47 s sinusoid, white noise with error bars spread by ``spread`` in ln, and OU noise in
    magnitudes of the same median size and correlation time ``tau_s``."""
    t = np.arange(0.0, 600.0, 1.0)
    noise, err = heteroscedastic_noise(rng, t.size, 0.05, spread=spread, outlier_fraction=0.0)
    y = 8 + 0.4 * np.cos(2 * np.pi * t / 47.0 + rng.uniform(0, 2 * np.pi)) + noise + red_noise(rng, t, 0.05, tau_s)
    return t, y, err


def test_correlation_time_is_corrected_for_what_the_fit_removes():
    """The residuals of a fit have lost the noise's slow part, so their correlation time is short (median 0.7 of the
    truth before the bootstrap correction); corrected, the median over 40 passes is within 15 % of the true 10 s."""
    rng = np.random.default_rng(5)
    taus = [extract_spin_prior(*_red_sinusoid(rng, 10.0, 0.0)).noise_correlation_time_s for _ in range(40)]
    assert 0.85 < np.median(taus) / 10.0 < 1.15


def test_red_noise_neither_halves_the_rate_nor_shrinks_its_sigma_under_uneven_error_bars():
    """A sinusoid plus OU noise in magnitudes under error bars spread by 50 % (ln), 60 passes. BIC, blind to the red
    power at low frequencies, ranked ``f/2`` or ``f/3`` first in about half of them; the sub-harmonic must now earn its
    extra harmonics against the fitted noise, and at most 10 % stay there. The fit weighs samples by 1/err², the
    red noise does not shrink with them: over the passes at the right frequency Σ z² lies in the 99.9 % band of χ²(n)."""
    rng = np.random.default_rng(9)
    z, wrong = [], 0
    for _ in range(60):
        t, y, err = _red_sinusoid(rng, rng.uniform(3.0, 20.0), 0.5)
        p = extract_spin_prior(t, y, err)
        if abs(p.frequency_hz * 47.0 - 1.0) > 0.5 * 47.0 / 600.0:
            wrong += 1
            continue
        z.append((p.frequency_hz - 1 / 47.0) * 2 * np.pi / p.rate_sigma_rad_s)
    assert wrong <= 6
    assert stats.chi2.ppf(0.0005, len(z)) < np.sum(np.square(z)) < stats.chi2.ppf(0.9995, len(z))


def _eclipsing_survey(seed, n=80, period_d=2.37):
    """Unequal eclipses (secondary depth 0.3–0.8 of the primary) on ``n`` visits over 3 seasons, 0.05 mag noise."""
    rng = np.random.default_rng(seed)
    t = survey_times(rng, n, n_seasons=3)
    P = period_d * DAY_S
    noise, err = heteroscedastic_noise(rng, t.size, 0.05, outlier_fraction=0.0)
    return t, 12 + curve("eclipsing", t / P + 0.1, 0.5, rng) + noise, err, P


def test_odd_harmonics_of_half_the_frequency_tell_p_from_2p():
    """Two eclipses of different depth on 80 sparse points: BIC ranks 2 f_true first (the odd harmonics cost ln N
    each); the F-test of the odd harmonics 1 and 3 of f/2 finds them and the period comes out right."""
    t, y, err, P = _eclipsing_survey(23)
    s = _prepare(*check_samples(t, y, err), None, 1 / 7200.0)
    s, f_bic, K, _, _ = _rank(s, _trial_frequencies(s)[0], 12)
    assert f_bic * P == pytest.approx(2.0, abs=1e-3)
    assert _odd_harmonic_test(s, f_bic, K) < 1e-4
    prior = extract_spin_prior(t, y, err, nu_max=1 / 7200.0)
    assert prior.significant and "odd harmonics" in prior.decision
    assert prior.frequency_hz * P == pytest.approx(1.0, abs=1e-3)


def _noisy_sinusoid(rng, n_points: int):
    """``(t, mag, f)``: a 0.2 mag sinusoid of random frequency 0.02–0.05 Hz at ``n_points`` random instants in
    1000 s, white noise 0.05 mag."""
    t = np.sort(rng.uniform(0.0, 1000.0, n_points))
    f = rng.uniform(0.02, 0.05)
    return t, 10 + 0.2 * np.cos(2 * np.pi * f * t + rng.uniform(0, 2 * np.pi)) + rng.normal(0, 0.05, t.size), f


def test_odd_harmonic_f_test_is_uniform_under_the_null():
    """A pure sinusoid in white noise has no odd harmonics of f/2: the F-test's p is uniform, so p < 0.05 for a
    Bin(n, 0.05) count of n realisations (99.9 % band)."""
    rng = np.random.default_rng(31)
    n, hits = 300, 0
    for _ in range(n):
        t, y, f = _noisy_sinusoid(rng, 120)
        s = _prepare(t, y, np.full(t.size, 0.05), None, 0.2)
        hits += _odd_harmonic_test(s, s.refine(f, 1, 0.1 / s.T), 1) < 0.05
    lo, hi = stats.binom.ppf([0.0005, 0.9995], n, 0.05)
    assert lo <= hits <= hi


def test_a_sinusoid_is_not_doubled():
    """extract_spin_prior on sparse noisy sinusoids: the F-test acts at p < 0.01 and only with white residuals, so
    at most a Bin(n, 0.01) count (99.9 % quantile) of n sinusoids may come out at half their frequency."""
    rng = np.random.default_rng(32)
    n, halved = 60, 0
    for _ in range(n):
        t, y, f = _noisy_sinusoid(rng, 60)
        p = extract_spin_prior(t, y, np.full(t.size, 0.05), nu_max=0.2)
        assert p.significant
        halved += abs(p.frequency_hz / f - 0.5) < 1e-3
    assert halved <= stats.binom.ppf(0.999, n, 0.01)


def test_outliers_are_left_out_of_the_fit():
    """Three 8-σ outliers on a sparse sinusoid: the frequency is the one found without them (they are dropped at
    3.5 robust σ), and it is right."""
    rng = np.random.default_rng(3)
    t = survey_times(rng, 70, n_seasons=3)
    P = 10.08 * DAY_S
    err = np.full(t.size, 0.04)
    y = 12 + 0.2 * np.cos(2 * np.pi * t / P + 0.4) + rng.normal(0, 0.04, t.size)
    bad = np.array([5, 30, 55])
    dirty = y.copy()
    dirty[bad] += np.array([8.0, -8.0, 8.0]) * 0.04
    keep = np.setdiff1d(np.arange(t.size), bad)
    with_outliers = extract_spin_prior(t, dirty, err, nu_max=1 / 7200.0)
    without = extract_spin_prior(t[keep], y[keep], err[keep], nu_max=1 / 7200.0)
    assert with_outliers.frequency_hz == pytest.approx(without.frequency_hz, rel=1e-9)
    assert with_outliers.frequency_hz * P == pytest.approx(1.0, abs=1e-3)


def test_parabolic_refinement_finds_the_chi2_minimum():
    """The batched parabolic stencils reach the minimum of χ²_K that a bounded Brent search finds (to 1e-4/T)."""
    rng = np.random.default_rng(9)
    for K in (1, 3, 6):
        t = np.sort(rng.uniform(0.0, 600.0, 300))
        y = 10 + curve("double", t / 37.0, 0.8, rng) + rng.normal(0, 0.05, t.size)
        s = _prepare(t, y, np.full(t.size, 0.05), None, 0.5)
        f0 = 1 / 37.0 + 0.04 / s.T
        got = s.refine(f0, K, 0.1 / s.T)
        ref = minimize_scalar(lambda f: s.chi2([f], K)[0, -1], bounds=(f0 - 0.1 / s.T, f0 + 0.1 / s.T), method="bounded", options={"xatol": 1e-7 / s.T}).x
        assert abs(got - ref) * s.T < 1e-4
