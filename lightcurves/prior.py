"""Spin priors from light curves: the fundamental frequency, a calibrated 1-σ, and an honest "no period".

:func:`extract_spin_prior` (Renis et al. §2.3 and §5, made to hold on sparse,
aliased photometry):

1. check the series; remove a weighted quadratic in time (the slow change of
   phase angle and range over the arc, which is not rotation);
2. the generalised (floating-mean, weighted) Lomb–Scargle periodogram
   (astropy's ``LombScargle``, Zechmeister & Kürster 2009) on
   ``[nu_min, nu_max]``; for evenly sampled data ``nu_max`` stops one
   resolution element short of the Nyquist frequency, where the sine term
   vanishes and a fit breaks down;
3. **candidates**: the strongest periodogram peaks, their aliases through
   the strongest peaks of the spectral window (``f ± δ`` — one day, one
   year, the gap between passes — whatever the sampling makes), and the
   sub-harmonics ``f/2, f/3`` and harmonic ``2f`` of each;
4. **ranking**: each candidate ``c`` is scored by the χ² of a ``k``-harmonic
   Fourier series at ``c`` (``k = 1 … K``, ``K c ≤ nu_max``) refined on a
   local grid, with the Bayesian information criterion
   ``BIC = χ²/s² + (2k + 4) ln N``. A sub-harmonic ``f/n`` wins only when its
   extra (odd) harmonics pay for their parameters — two unequal minima or
   maxima per cycle — not because peaks line up. The winner's frequency is
   refined by minimising χ²; it is the fundamental of the light curve, the
   rotation frequency when ``maxima_per_rotation`` (the strongest harmonic's
   number) is explained by the shape;
5. **significance**: the false-alarm probability of the periodogram maximum
   (Baluev 2008, via ``LombScargle.false_alarm_probability``) after the
   power is divided by the expected periodogram of the noise: the largest
   of (a) an Ornstein–Uhlenbeck + white process whose correlation is fitted
   by moments to the residuals of the winner (white when that fit is no
   better), seen through the sampling window; (b) the same fitted to the
   detrended data themselves — the null hypothesis is that they are noise;
   (c) the residual periodogram's running-median continuum. Red noise raises the periodogram near 0 (and, on nightly
   sampling, near 1/day) by up to ``(1 + ρ)/(1 − ρ)``; without this,
   correlated noise gave confident periods in 66–100 % of trials. A period with fewer than
   ``min_cycles`` cycles in the arc is refused (``significant=False``,
   with a warning): its frequency is not determined by the data;
6. **1-σ**: the frequency variance of the least-squares fit
   ``Var f̂ = uᵀ Σ u``, ``u = J (JᵀJ)⁻¹ e_f`` (sandwich estimator), with
   ``Σ`` the fitted Ornstein–Uhlenbeck + white covariance of the residuals — the
   structure a ``K``-harmonic model leaves on a non-sinusoidal curve and
   correlated noise both make ``Σ`` non-diagonal; the white-noise ``σ`` is
   26–35× too small on renders. ``rate = 2π f_rot`` is the *synodic* rate:
   it differs from the sidereal one by the turning rate of the Sun–observer
   bisector about the spin axis. The axis is unknown, so when the geometry
   is given (``sun_dir``, ``observer_dir``) the bisector's mean angular rate
   over the arc — the largest that offset can be — is added to the 1-σ in
   quadrature (``rate_sigma_synodic_rad_s``); with only ``phase_angle_rad``,
   half the phase angle's rate (the in-plane part, a lower bound);
7. non-principal-axis tumbling is flagged when the residuals of the fit hold
   a significant peak of at least ``npa_amplitude_ratio`` of the strongest
   harmonic that is no harmonic of the rotation frequency.

The WindowCLEAN spectrum (:func:`~lightcurves.clean.window_clean`) of the
detrended series is :attr:`SpinPrior.spectrum`, computed when first asked
for (plots and recordings); the period search does not need it.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import numpy as np
from astropy.timeseries import LombScargle
from astropy.timeseries.periodograms.lombscargle.implementations.utils import trig_sum
from scipy.optimize import minimize, minimize_scalar

from lightcurves.clean import WindowCleanResult, window_clean
from lightcurves.clean_implementations.fast import window as spectral_window
from lightcurves.samples import check_samples

__all__ = ["Candidate", "SpinPrior", "extract_spin_prior"]

_SAMPLES_PER_PEAK = 5  #: periodogram grid points per resolution element 1/T (astropy's default)
_N_PEAKS = 6  #: periodogram peaks taken as candidates
_N_ALIASES = 3  #: spectral-window peaks whose offsets make alias candidates
_N_ALIASED = 3  #: strongest periodogram peaks whose aliases are tried
_PEAK_FLOOR = 0.2  #: periodogram peaks below this fraction of the highest are not candidates
_N_KEEP = 12  #: trial frequencies kept after the cheap 1–2-harmonic pruning
_K_SCORE = 6  #: most harmonics when ranking trial frequencies (the winner's K goes up to max_harmonics)
_WINDOW_FLOOR = 0.2  #: |W| a window peak needs (relative to W(0) = 1) to make aliases
_TRIAL_MULTIPLES = (1.0, 0.5, 1.0 / 3.0, 2.0)  #: each base frequency, its sub-harmonics and harmonic 2
_NUFFT_OVERSAMPLING = 3  #: astropy extirpolation grid (default 5): half the FFT length, same peaks and classifications (seeds 1, 2)
_FAST = {"trig_sum_kwds": {"oversampling": _NUFFT_OVERSAMPLING}}
_BATCH = 400_000  #: complex numbers per batch of the harmonic fits (memory bound)


@dataclass(frozen=True)
class Candidate:
    """A significant periodogram peak, and how it relates to the adopted rotation frequency."""

    frequency_hz: float
    amplitude_mag: float  #: semi-amplitude of a sinusoid there
    false_alarm_probability: float  #: of a periodogram maximum this high (noise spectrum accounted for)
    harmonic: int | None  #: n if frequency ≈ n f_rot, else None

    def to_dict(self) -> dict:
        return {"frequency_hz": self.frequency_hz, "period_s": 1.0 / self.frequency_hz, "amplitude_mag": self.amplitude_mag, "false_alarm_probability": self.false_alarm_probability, "harmonic": self.harmonic}


@dataclass(frozen=True)
class SpinPrior:
    """Spin prior from one light curve (rates in rad/s; ``*_deg_s`` properties for people)."""

    significant: bool
    rate_rad_s: float | None  #: synodic rotation rate
    rate_sigma_rad_s: float | None  #: 1-σ: statistical and synodic terms in quadrature
    frequency_hz: float | None  #: rotation frequency
    strongest_frequency_hz: float | None  #: the strongest harmonic of the fitted curve
    maxima_per_rotation: int | None  #: strongest harmonic's number
    decision: str  #: why this period (or why none)
    candidates: tuple[Candidate, ...]
    npa_suspected: bool  #: a strong residual frequency is no harmonic of the rotation
    false_alarm_level: float
    false_alarm_probability: float  #: of the periodogram maximum (1.0 if none)
    n_harmonics: int  #: Fourier terms of the adopted fit
    warnings: tuple[str, ...] = ()  #: e.g. fewer than ``min_cycles`` cycles in the arc
    n_cycles: float | None = None  #: rotation cycles in the arc, ``T f``
    rate_sigma_statistical_rad_s: float | None = None  #: fit only (correlated residuals included)
    rate_sigma_synodic_rad_s: float | None = None  #: bisector turning rate (0 when no geometry given)
    noise_correlation_time_s: float = 0.0  #: Ornstein–Uhlenbeck τ of the residuals (0: white)
    delta_bic: float | None = None  #: BIC of the runner-up candidate minus the winner's
    best_frequency_hz: float | None = None  #: the best-ranked rotation frequency, also when not significant or refused
    _series: tuple = field(default=(), repr=False, compare=False)  #: (t, detrended y, nu_max, clean options)

    @property
    def rate_deg_s(self) -> float | None:
        return None if self.rate_rad_s is None else float(np.degrees(self.rate_rad_s))

    @property
    def rate_sigma_deg_s(self) -> float | None:
        return None if self.rate_sigma_rad_s is None else float(np.degrees(self.rate_sigma_rad_s))

    @property
    def period_s(self) -> float | None:
        return None if self.frequency_hz is None else 1.0 / self.frequency_hz

    def body_rate_prior(self, axis_T=(0.0, 0.0, 1.0), source: str = "light curve"):
        """The filters' prior, :class:`estimators.prior.BodyRatePrior`: ``ω_T = rate · â`` with 1-σ ``σ_rate`` per axis.

        The light curve gives the rate, not the spin axis or its sense: ``axis_T``
        (a non-zero vector in the target's principal frame, default ``z_T``) is an
        assumption the caller makes. Refused (``ValueError``) without a significant period.
        """
        from estimators.prior import BodyRatePrior  # lightcurves needs the filters only here

        if not self.significant:
            raise ValueError(f"spin prior has no rate (the light curve gave no significant period: {self.decision})")
        return BodyRatePrior.from_rate(self.rate_rad_s, self.rate_sigma_rad_s, axis_T, source=source)

    @cached_property
    def spectrum(self) -> WindowCleanResult:
        """WindowCLEAN spectrum of the detrended series (computed on first use)."""
        t, y, nu_max, options = self._series
        return window_clean(t, y, nu_max=nu_max, false_alarm_level=self.false_alarm_level, **options)

    def to_dict(self) -> dict:
        """JSON-ready summary (no arrays)."""
        deg = lambda v: None if v is None else float(np.degrees(v))  # noqa: E731
        return {
            "significant": self.significant,
            "rate_deg_s": self.rate_deg_s,
            "rate_sigma_deg_s": self.rate_sigma_deg_s,
            "rate_rad_s": self.rate_rad_s,
            "rate_sigma_rad_s": self.rate_sigma_rad_s,
            "rate_sigma_statistical_deg_s": deg(self.rate_sigma_statistical_rad_s),
            "rate_sigma_synodic_deg_s": deg(self.rate_sigma_synodic_rad_s),
            "frequency_hz": self.frequency_hz,
            "period_s": self.period_s,
            "n_cycles": self.n_cycles,
            "strongest_frequency_hz": self.strongest_frequency_hz,
            "maxima_per_rotation": self.maxima_per_rotation,
            "decision": self.decision,
            "warnings": list(self.warnings),
            "npa_suspected": self.npa_suspected,
            "false_alarm_level": self.false_alarm_level,
            "false_alarm_probability": self.false_alarm_probability,
            "noise_correlation_time_s": self.noise_correlation_time_s,
            "delta_bic": self.delta_bic,
            "best_frequency_hz": self.best_frequency_hz,
            "n_harmonics": self.n_harmonics,
            "candidates": [c.to_dict() for c in self.candidates],
        }


# --------------------------------------------------------------------------------------------
# k-harmonic least squares at many trial frequencies


def _harmonic_chi2(tc: np.ndarray, V: np.ndarray, y: np.ndarray, W: np.ndarray, freqs: np.ndarray, K: int) -> np.ndarray:
    """``χ²_k(f)`` of the weighted fits of ``V`` (a quadratic trend) plus ``cos(2πjft), sin(2πjft)``, ``j ≤ k``,
    for ``k = 1 … K``: shape (len(freqs), K).

    The normal matrix needs only the weighted trigonometric sums
    ``Σ W e^{i m θ}`` (``m ≤ 2K``), ``Σ W V e^{i j θ}`` and ``Σ W y e^{i j θ}``
    (``j ≤ K``), ``θ = 2π f t`` — O(N K) per frequency instead of O(N K²).
    Its Cholesky factor, with the columns ordered by harmonic, gives every
    nested fit at once: ``χ²_k = yᵀWy − Σ_{p < q + 2k} z_p²``, ``L z = Xᵀ W y``
    (``q`` trend columns). The trend is fitted jointly: removed beforehand, it
    takes the part of a few-cycle sinusoid that projects on it.
    """
    freqs = np.atleast_1d(np.asarray(freqs, dtype=float))
    q = V.shape[1]
    out = np.empty((freqs.size, K))
    j = np.arange(1, K + 1)
    dif, sm = np.abs(j[:, None] - j[None, :]), j[:, None] + j[None, :]
    sgn = np.sign(j[:, None] - j[None, :])
    order = np.r_[np.arange(q), q + np.ravel(np.column_stack([np.arange(K), K + np.arange(K)]))]  # trend, c1, s1, c2, s2 …
    yWy = float(W @ y**2)
    VWV = V.T @ (W[:, None] * V)
    VWy = V.T @ (W * y)
    rhs_cols = np.concatenate([W[:, None] * V, (W * y)[:, None]], axis=1)  # (N, q+1)
    step = max(1, _BATCH // tc.size)
    for b0 in range(0, freqs.size, step):
        f = freqs[b0 : b0 + step]
        nb = f.size
        E = np.exp(2j * np.pi * f[:, None] * tc[None, :])
        T = np.empty((nb, 2 * K + 1), dtype=complex)  # C_m + i S_m
        T[:, 0] = W.sum()
        Q = np.empty((nb, K, q + 1), dtype=complex)  # Σ W V e^{ijθ}, Σ W y e^{ijθ}
        P = E.copy()  # e^{imθ}, one power at a time (a (B, 2K+1, N) array costs more in memory traffic than it saves)
        for m in range(1, 2 * K + 1):
            if m > 1:
                P *= E
            T[:, m] = P @ W
            if m <= K:
                Q[:, m - 1] = P @ rhs_cols
        C, S = T.real, T.imag
        CC = 0.5 * (C[:, dif] + C[:, sm])
        SS = 0.5 * (C[:, dif] - C[:, sm])
        CS = 0.5 * (S[:, sm] - sgn * S[:, dif])
        XV = np.concatenate([Q[:, :, :q].real, Q[:, :, :q].imag], axis=1)  # (B, 2K, q)
        G = np.block([[np.broadcast_to(VWV, (nb, q, q)), np.swapaxes(XV, 1, 2)], [XV, np.block([[CC, CS], [np.swapaxes(CS, 1, 2), SS]])]])
        G = G[:, order][:, :, order]
        rhs = np.concatenate([np.broadcast_to(VWy, (nb, q)), Q[:, :, q].real, Q[:, :, q].imag], axis=1)[:, order]
        G += 1e-10 * np.trace(G, axis1=1, axis2=2)[:, None, None] / G.shape[1] * np.eye(G.shape[1])
        L = np.linalg.cholesky(G)
        z = np.linalg.solve(L, rhs[:, :, None])[:, :, 0]
        out[b0 : b0 + nb] = yWy - np.cumsum(z**2, axis=1)[:, q + 1 :: 2]
    return np.maximum(out, 0.0)


def _design(tc: np.ndarray, V: np.ndarray, f: float, K: int) -> np.ndarray:
    """Columns ``V`` (trend), ``cos(2πkft)`` for k = 1 … K, ``sin(2πkft)`` for k = 1 … K."""
    arg = 2.0 * np.pi * f * np.outer(tc, np.arange(1, K + 1))
    return np.concatenate([V, np.cos(arg), np.sin(arg)], axis=1)


# --------------------------------------------------------------------------------------------
# noise: an Ornstein–Uhlenbeck process fitted to residuals


def _correlation_fit(t: np.ndarray, r: np.ndarray) -> tuple[float, float]:
    """``(a, τ)`` of the residuals' autocorrelation ``ρ(Δ) = a e^{−Δ/τ}`` (Δ > 0): an Ornstein–Uhlenbeck part of
    variance fraction ``a`` plus white noise (``1 − a``); ``(0, 0)`` when white noise explains the lag products.

    Moments, not maximum likelihood: the products ``r_i r_j`` of pairs up to 200 samples apart are averaged in 25
    log-spaced lag bins and ``a e^{−Δ/τ}`` is fitted by weighted least squares (``a`` linear, ``τ`` on a grid).
    A pure OU likelihood mistakes the white part for fast decorrelation and under-estimates τ; this does not.
    Correlation is accepted when it lowers Σ n_b ρ_b² (χ² of "white", n_b pairs per bin) by more than 20.
    """
    T = t[-1] - t[0]
    lags, prods = [], []
    for k in range(1, min(t.size, 201)):
        d = t[k:] - t[:-k]
        if d.min() > 0.25 * T:
            break
        lags.append(d)
        prods.append(r[k:] * r[:-k])
    d, p = np.concatenate(lags), np.concatenate(prods)
    keep = d <= 0.25 * T
    d, p = d[keep], p[keep] / np.mean(r**2)
    edges = np.geomspace(d.min() * (1 - 1e-9), d.max() * (1 + 1e-9), 26)
    b = np.clip(np.searchsorted(edges, d) - 1, 0, 24)
    nb = np.bincount(b, minlength=25).astype(float)
    ok = nb > 0
    rho = np.bincount(b, p, minlength=25)[ok] / nb[ok]
    lag = np.bincount(b, d, minlength=25)[ok] / nb[ok]
    nb = nb[ok]
    best = (np.sum(nb * rho**2), 0.0, 0.0)
    for tau in np.geomspace(0.3 * d.min(), T, 60):
        e = np.exp(-lag / tau)
        a = float(np.clip(np.sum(nb * e * rho) / np.sum(nb * e * e), 0.0, 1.0))
        sse = float(np.sum(nb * (rho - a * e) ** 2))
        if sse < best[0]:
            best = (sse, a, float(tau))
    white = float(np.sum(nb * rho**2))
    return (best[1], best[2]) if white - best[0] > 20.0 and best[1] > 0 else (0.0, 0.0)


def _ou_quadratic(t: np.ndarray, u: np.ndarray, a: float, tau: float) -> float:
    """``Σ_ij u_i u_j [(1 − a) δ_ij + a exp(−|t_i − t_j|/τ)]`` in O(N) (the exponential kernel factorises along sorted times)."""
    if tau <= 0.0 or a <= 0.0:
        return float(u @ u)
    phi = np.exp(-np.diff(t) / tau)
    F = 0.0
    acc = 0.0
    for i in range(1, u.size):  # F_i = Σ_{k<i} e^{−(t_i − t_k)/τ} u_k
        F = phi[i - 1] * (F + u[i - 1])
        acc += u[i] * F
    return float(u @ u + 2.0 * a * acc)


def _red_spectrum(t: np.ndarray, a: float, tau: float, freq: np.ndarray) -> np.ndarray:
    """Expected periodogram of Ornstein–Uhlenbeck noise sampled at ``t``, relative to white noise of the same variance.

    ``E P(f)/σ² = 1 + (2a/N) Σ_{j<k} e^{−Δ_jk/τ} cos(2πfΔ_jk)``, ``Δ_jk = t_k − t_j``: the noise's spectrum seen
    through the sampling window — red noise on nightly sampling raises the periodogram near 0 *and* near
    1/day, 2/day. Only lags under 5τ count (the rest weigh < e⁻⁵); the sum over lags is a non-uniform FFT
    (astropy's ``trig_sum``) on a regular ``freq`` grid, direct otherwise. Floored at 0.05.
    """
    if tau <= 0.0 or a <= 0.0:
        return np.ones_like(freq)
    lags = []
    for k in range(1, t.size):
        d = t[k:] - t[:-k]
        d = d[d < 5.0 * tau]
        if d.size == 0:
            break
        lags.append(d)
    if not lags:
        return np.ones_like(freq)
    d = np.concatenate(lags)
    h = np.exp(-d / tau)
    if freq.size > 64:
        _, C = trig_sum(d, h, freq[1] - freq[0], freq.size, f0=freq[0], use_fft=True, oversampling=_NUFFT_OVERSAMPLING)
    else:
        C = np.cos(2.0 * np.pi * np.outer(freq, d)) @ h
    return np.maximum(1.0 + 2.0 * a * C / t.size, 0.05)


def _continuum(z: np.ndarray, block: int = 50 * _SAMPLES_PER_PEAK) -> np.ndarray:
    """The periodogram's noise continuum: medians of ``z`` over blocks of 50 resolution elements, divided by ln 2
    (the median of Exp(1)), interpolated between block centres. A peak is a few resolution elements wide and
    does not move a median; red noise the Ornstein–Uhlenbeck fit misses (a white-noise floor under it, other
    spectra) does."""
    nb = max(1, z.size // block)
    med = np.median(z[: nb * block].reshape(nb, -1), axis=1) / np.log(2.0)
    centres = (np.arange(nb) + 0.5) * (z.size / nb)
    return np.interp(np.arange(z.size), centres, med)


# --------------------------------------------------------------------------------------------
# geometry: the synodic term


def _bisector_rate(t, sun_dir, observer_dir, phase_angle_rad) -> float:
    """Mean angular rate (rad/s) of the Sun–observer bisector over the arc; half the phase angle's rate with only that."""
    if sun_dir is not None and observer_dir is not None:
        s = np.asarray(sun_dir, dtype=float).reshape(-1, 3)
        o = np.asarray(observer_dir, dtype=float).reshape(-1, 3)
        if s.shape[0] != t.size or o.shape[0] != t.size or not (np.all(np.isfinite(s)) and np.all(np.isfinite(o))):
            raise ValueError(f"sun_dir and observer_dir must be finite (N, 3) arrays with N = {t.size} (one per sample), got {s.shape} and {o.shape}")
        b = s / np.linalg.norm(s, axis=1, keepdims=True) + o / np.linalg.norm(o, axis=1, keepdims=True)
        b /= np.linalg.norm(b, axis=1, keepdims=True)
        turned = np.sum(np.arccos(np.clip(np.sum(b[1:] * b[:-1], axis=1), -1.0, 1.0)))
        return float(turned / (t[-1] - t[0]))
    if phase_angle_rad is not None:
        a = np.asarray(phase_angle_rad, dtype=float).reshape(-1)
        if a.size != t.size:
            raise ValueError(f"phase_angle_rad must have one value per sample ({t.size}), got {a.size}")
        ok = np.isfinite(a)
        if ok.sum() >= 2:
            return float(0.5 * abs(np.polyfit(t[ok], a[ok], 1)[0]))
    return 0.0


# --------------------------------------------------------------------------------------------


def _regular_nyquist(t: np.ndarray) -> float | None:
    """Nyquist frequency ``1/(2 Δt)`` when every interval is a whole multiple of the smallest ``Δt``, else None."""
    d = np.diff(t)
    q = d / d.min()
    return float(0.5 / d.min()) if np.all(np.abs(q - np.rint(q)) < 1e-3) else None


def _is_harmonic(f: float, f0: float, T: float) -> bool:
    """``f ≈ k f0`` for a whole ``k ≥ 1``, within half a resolution element ``1/T``."""
    k = int(np.rint(f / f0))
    return k >= 1 and abs(f - k * f0) <= 0.5 / T


def _local_maxima(p: np.ndarray, n: int, min_sep: int) -> np.ndarray:
    """Indices of the ``n`` highest local maxima of ``p``, at least ``min_sep`` grid points apart."""
    idx = np.flatnonzero((p[1:-1] > p[:-2]) & (p[1:-1] >= p[2:])) + 1
    idx = idx[np.argsort(p[idx])[::-1]]
    kept: list[int] = []
    for i in idx:
        if all(abs(i - k) >= min_sep for k in kept):
            kept.append(int(i))
            if len(kept) == n:
                break
    return np.array(kept, dtype=int)


def _parabolic(freq: np.ndarray, p: np.ndarray, i: np.ndarray) -> np.ndarray:
    """Peak positions refined by a parabola through three grid points."""
    i = np.clip(i, 1, p.size - 2)
    a, b, c = p[i - 1], p[i], p[i + 1]
    den = a - 2 * b + c
    d = np.where(den < 0, 0.5 * (a - c) / np.where(den < 0, den, -1.0), 0.0)
    return freq[i] + np.clip(d, -0.5, 0.5) * (freq[1] - freq[0])


def extract_spin_prior(
    t,
    mag,
    mag_err=None,
    *,
    false_alarm_level: float = 0.01,
    maxima_per_rotation: int | None = None,
    nu_min: float | None = None,
    nu_max: float | None = None,
    max_harmonics: int = 12,
    min_cycles: float = 2.0,
    npa_amplitude_ratio: float = 0.25,
    sun_dir=None,
    observer_dir=None,
    phase_angle_rad=None,
    **clean_options,
) -> SpinPrior:
    """Spin prior from magnitudes ``mag`` (optionally 1-σ ``mag_err``) at times ``t`` (s).

    Parameters
    ----------
    false_alarm_level : a period is significant when noise (white, or red as
        fitted to the residuals) would give a periodogram maximum this high
        with at most this probability.
    maxima_per_rotation : impose the number of light-curve maxima per turn:
        the rotation frequency is then the strongest harmonic divided by it.
    nu_min, nu_max : frequency band searched (Hz); default ``0.5/T`` (slower
        periods are found so as to be refused, see ``min_cycles``) to the
        (pseudo-)Nyquist frequency ``1/(2 median Δt)`` less ``1/T``.
    max_harmonics : most Fourier terms in a candidate's fit.
    min_cycles : fewest rotation cycles in the arc for a significant prior.
    npa_amplitude_ratio : a residual peak this strong (relative to the
        strongest harmonic) flags non-principal-axis tumbling.
    sun_dir, observer_dir : (N, 3) directions from the target to the Sun and
        to the observer (any inertial frame) — the synodic term of the 1-σ.
    phase_angle_rad : (N,) phase angle, used for that term when the
        directions are not given.
    clean_options : passed to :func:`~lightcurves.clean.window_clean` for
        :attr:`SpinPrior.spectrum`.
    """
    t, y, dy = check_samples(t, mag, mag_err)
    if maxima_per_rotation is not None and int(maxima_per_rotation) < 1:
        raise ValueError(f"maxima_per_rotation must be a positive integer, got {maxima_per_rotation}")
    if not (0.0 < false_alarm_level < 1.0):
        raise ValueError(f"false_alarm_level must be in (0, 1), got {false_alarm_level}")
    if int(max_harmonics) < 1 or not (min_cycles > 0):
        raise ValueError(f"max_harmonics must be >= 1 and min_cycles > 0, got {max_harmonics} and {min_cycles}")
    T = float(t[-1] - t[0])
    n = t.size
    w = np.ones_like(y) if dy is None else 1.0 / dy
    W = w**2
    # Step 1: remove the slow trend (phase angle, range) by weighted quadratic least squares.
    tn = (t - t.mean()) / T
    V = np.vander(tn, 3)
    trend, *_ = np.linalg.lstsq(V * w[:, None], y * w, rcond=None)
    yd = y - V @ trend  # for the periodogram; the fits below refit the trend jointly
    tc = t - t.mean()
    # Step 2: band and periodogram.
    nyq = _regular_nyquist(t)
    top = (nyq if nyq is not None else 0.5 / np.median(np.diff(t))) - 1.0 / T
    nu_max = top if nu_max is None else (min(float(nu_max), top) if nyq is not None else float(nu_max))
    nu_min = 0.5 / T if nu_min is None else float(nu_min)
    if not (0.0 < nu_min < nu_max - 2.0 / T):
        raise ValueError(f"need 0 < nu_min < nu_max − 2/T; got nu_min {nu_min:.4g} Hz, nu_max {nu_max:.4g} Hz, 1/T = {1.0 / T:.4g} Hz")
    series = (t, yd, nu_max, clean_options)
    df = 1.0 / (_SAMPLES_PER_PEAK * T)
    freq = nu_min + df * np.arange(int((nu_max - nu_min) / df) + 1)
    ls = LombScargle(t, yd, dy, normalization="standard")
    power = np.clip(ls.power(freq, method="fast", assume_regular_frequency=True, method_kwds=_FAST), 0.0, 1.0 - 1e-12)
    # Step 3: candidates — periodogram peaks, their window aliases, sub-harmonics and harmonic 2.
    ipk = _local_maxima(power, _N_PEAKS, _SAMPLES_PER_PEAK)
    ipk = ipk[power[ipk] >= _PEAK_FLOOR * power[ipk[0]]]
    peaks = _parabolic(freq, power, ipk)
    m_win = int(np.ceil(min(nu_max, 4.0 / np.median(np.diff(t))) / df)) + 1  # the strong window peaks are at low offsets
    aw = np.abs(spectral_window(t, df, m_win))
    aw[: int(1.5 * _SAMPLES_PER_PEAK)] = 0.0  # the main lobe is no alias
    iw = _local_maxima(aw, _N_ALIASES, _SAMPLES_PER_PEAK)
    deltas = df * iw[aw[iw] >= _WINDOW_FLOOR]
    base = np.concatenate([peaks, *(np.abs(peaks[:_N_ALIASED, None] + s * deltas[None, :]).ravel() for s in (1.0, -1.0))])
    trial = np.unique(np.round(np.outer(base, _TRIAL_MULTIPLES).ravel() / (0.1 * df)) * 0.1 * df)
    trial = trial[(trial >= nu_min) & (trial <= nu_max)]
    # Step 4: rank by BIC of k-harmonic fits on a local grid (±0.2/T) around each trial frequency.
    K_of = lambda f: int(max(1, min(max_harmonics, np.floor(nu_max / f), (n - 6) // 4)))  # noqa: E731
    offsets = np.linspace(-0.2, 0.2, 5) / T
    if trial.size > _N_KEEP:  # prune with 1–2 harmonics first (cheap), then score the rest with up to _K_SCORE
        k2 = min(K_of(trial.min()), 2)
        c2 = _harmonic_chi2(tc, V, y, W, (trial[:, None] + offsets[None, :]).ravel(), k2).reshape(trial.size, offsets.size, k2)
        ok2 = np.arange(1, k2 + 1)[None, None, :] <= np.array([min(K_of(f), 2) for f in trial])[:, None, None]
        c2 = np.where(ok2, c2, np.inf)
        s2a = float(np.min(c2 / (n - 2 * np.arange(1, k2 + 1) - 4)))
        score = np.min(c2 / s2a + 2 * np.arange(1, k2 + 1) * np.log(n), axis=(1, 2))
        trial = trial[np.sort(np.argsort(score)[:_N_KEEP])]
    Kmax = min(K_of(trial.min()), _K_SCORE)
    grid = (trial[:, None] + offsets[None, :]).ravel()
    chi2 = _harmonic_chi2(tc, V, y, W, grid, Kmax).reshape(trial.size, offsets.size, Kmax)
    k_ok = np.arange(1, Kmax + 1)[None, :] <= np.array([min(K_of(f), _K_SCORE) for f in trial])[:, None]  # (trial, k)
    dof = n - 2 * np.arange(1, Kmax + 1) - 4
    penalty = (2 * np.arange(1, int(max_harmonics) + 1) + 4) * np.log(n)  # trend, harmonics, frequency

    def bic(c2, k_mask):
        return np.where(k_mask, c2 / s2 + penalty[: c2.shape[-1]], np.inf)

    # Noise scale: the residual variance of the BIC-best model, found from the 1-harmonic fits' scale (larger, so
    # the first pass does not favour over-fitted models whose residual variance is biased low).
    s2 = float(np.min(chi2[:, :, 0]) / dof[0])
    for _ in range(2):
        B = bic(chi2, k_ok[:, None, :])  # (trial, offset, k)
        i_b, j_b, k_b = np.unravel_index(np.argmin(B), B.shape)
        s2 = float(chi2[i_b, j_b, k_b] / dof[k_b])
    B = bic(chi2, k_ok[:, None, :])
    best_t = np.min(B, axis=(1, 2))
    order = np.argsort(best_t)
    finalists = []
    for i in order[:3]:
        j, k = np.unravel_index(np.argmin(B[i]), B[i].shape)
        f0, k = float(grid.reshape(trial.size, -1)[i, j]), int(k) + 1
        res = minimize_scalar(lambda f: _harmonic_chi2(tc, V, y, W, [f], k)[0, -1], bounds=(f0 - 0.1 / T, f0 + 0.1 / T), method="bounded", options={"xatol": 1e-5 / T})
        c2 = _harmonic_chi2(tc, V, y, W, [res.x], K_of(res.x))[0]
        b = bic(c2, np.arange(1, c2.size + 1) <= K_of(res.x))
        finalists.append((float(np.min(b)), float(res.x), int(np.argmin(b)) + 1))
    finalists.sort()
    bic_best, f_fit, K = finalists[0]
    # a runner-up is a different frequency (not the same peak refined)
    others = [b for b, f, _ in finalists[1:] if abs(f - f_fit) > 0.5 / T]
    runner = others[0] if others else float(np.min(best_t[np.abs(trial - f_fit) > 0.5 / T], initial=np.inf))
    delta_bic = float(runner - bic_best) if np.isfinite(runner) else None
    # Fit at the winner: coefficients, harmonic amplitudes, residuals.
    X = _design(tc, V, f_fit, K)
    coef, *_ = np.linalg.lstsq(X * w[:, None], y * w, rcond=None)
    amps = np.hypot(coef[3 : K + 3], coef[K + 3 :])
    r = y - X @ coef
    k_strong = int(np.argmax(amps)) + 1
    if maxima_per_rotation is not None:
        n_max = int(maxima_per_rotation)
        f_rot = k_strong * f_fit / n_max
        if abs(f_rot - f_fit) > 1e-9 * f_fit:  # refit at the imposed rotation frequency
            K = K_of(f_rot)
            res = minimize_scalar(lambda f: _harmonic_chi2(tc, V, y, W, [f], K)[0, -1], bounds=(f_rot - 0.05 / T, f_rot + 0.05 / T), method="bounded", options={"xatol": 1e-5 / T})
            f_rot = float(res.x)
            X = _design(tc, V, f_rot, K)
            coef, *_ = np.linalg.lstsq(X * w[:, None], y * w, rcond=None)
            amps = np.hypot(coef[3 : K + 3], coef[K + 3 :])
            r = y - X @ coef
        decision = f"{n_max} maxima per rotation imposed by the caller"
    else:
        f_rot, n_max = f_fit, k_strong
        what = "one maximum" if n_max == 1 else f"{n_max} maxima"
        decision = (f"{what} per rotation: a {K}-harmonic fit at the fundamental {f_rot:.6g} Hz has the lowest BIC of {trial.size} trial frequencies "
                    f"(periodogram peaks, their window aliases, f/2, f/3, 2f); runner-up ΔBIC {delta_bic:.1f}" if delta_bic is not None else
                    f"{what} per rotation: a {K}-harmonic fit at {f_rot:.6g} Hz")
    # Step 5: significance against the residuals' noise spectrum.
    a_red, tau = _correlation_fit(t, r * w)
    z_white = -0.5 * (n - 3) * np.log1p(-power)  # Exp(1) at one frequency for white noise
    # The continuum is read off the residuals' periodogram (one point per 1/T), in the data's units (times the
    # fraction of the variance left): a strong signal's window sidelobes would raise the data's own continuum.
    ls_r = LombScargle(t, r, dy, normalization="standard")
    coarse = freq[::_SAMPLES_PER_PEAK]
    z_res = -0.5 * (n - 3) * np.log1p(-np.clip(ls_r.power(coarse, method="fast", assume_regular_frequency=True, method_kwds=_FAST), 0.0, 1.0 - 1e-12))
    left = float(W @ r**2) / float(W @ (yd - np.average(yd, weights=W)) ** 2)
    continuum = left * np.interp(freq, coarse, _continuum(z_res, block=50))
    noise_spec = np.maximum(_red_spectrum(t, a_red, tau, freq), continuum)
    z = z_white / noise_spec  # for the candidates and the NPA test, given that a period exists
    # Whether one exists: under the null hypothesis the data are the noise, so their own correlation (fitted to the
    # detrended data) bounds the noise spectrum too — the residuals of a model fitted to red noise have lost part
    # of their correlation. A real signal looks red as well, which costs a weak one its significance.
    a_null, tau_null = _correlation_fit(t, yd * w)
    z_null = z_white / np.maximum(noise_spec, _red_spectrum(t, a_null, tau_null, freq))
    i_max = int(np.argmax(z_null))
    fap = lambda zz: float(ls.false_alarm_probability(-np.expm1(-2.0 * zz / (n - 3)), method="baluev", minimum_frequency=nu_min, maximum_frequency=nu_max))  # noqa: E731
    fap_max = fap(z_null[i_max])
    cycles = T * f_rot
    warnings: list[str] = []
    if tau > 0.0:
        warnings.append(f"residuals are correlated ({a_red:.0%} of their variance Ornstein–Uhlenbeck, τ = {tau:.3g} s): the false-alarm probability and the 1-σ allow for it")
    cands = []
    for i in ipk:
        if fap(z[i]) <= false_alarm_level:
            a, b_ = ls.model_parameters(freq[i])[1:]
            cands.append(Candidate(float(freq[i]), float(np.hypot(a, b_)), fap(z[i]), int(np.rint(freq[i] / f_rot)) if _is_harmonic(freq[i], f_rot, T) else None))
    if cycles < min_cycles:
        warnings.append(f"the best period {1.0 / f_rot:.4g} s fits only {cycles:.2f} cycles in the {T:.4g} s arc (< {min_cycles:g}): "
                        "its frequency is not determined; observe longer")
    if fap_max > false_alarm_level:
        return SpinPrior(False, None, None, None, None, None, f"no significant period: the periodogram maximum has false-alarm probability {fap_max:.3g} > {false_alarm_level}"
                         + (f" (noise spectrum: Ornstein–Uhlenbeck, τ = {tau:.3g} s)" if tau > 0 else ""), tuple(cands), False, false_alarm_level, fap_max, 0,
                         tuple(warnings), float(cycles), None, None, tau, delta_bic, float(f_rot), series)
    if cycles < min_cycles:
        return SpinPrior(False, None, None, None, None, None, f"refused: {warnings[-1]}", tuple(cands), False, false_alarm_level, fap_max, 0, tuple(warnings), float(cycles), None, None, tau, delta_bic, float(f_rot), series)
    # Step 6: the 1-σ — sandwich estimator with the residuals' Ornstein–Uhlenbeck covariance, plus the synodic term.
    dm_df = 2.0 * np.pi * tc * (np.arange(1, K + 1)[None, :] * (-coef[3 : K + 3] * np.sin(2 * np.pi * f_rot * np.outer(tc, np.arange(1, K + 1)))
                                                               + coef[K + 3 :] * np.cos(2 * np.pi * f_rot * np.outer(tc, np.arange(1, K + 1))))).sum(axis=1)
    J = np.column_stack([X, dm_df]) * w[:, None]
    A_inv = np.linalg.pinv(J.T @ J)
    u = J @ A_inv[:, -1]
    rw = r * w
    s2_res = float(rw @ rw) / max(n - J.shape[1], 1)
    var_f = s2_res * _ou_quadratic(t, u, a_red, tau)
    sigma_stat = 2.0 * np.pi * float(np.sqrt(max(var_f, 0.0)))
    sigma_syn = _bisector_rate(t, sun_dir, observer_dir, phase_angle_rad)
    if sun_dir is None and observer_dir is None and phase_angle_rad is None:
        # without geometry the synodic offset is unknown, and on long arcs it dominates the error
        warnings.append("no viewing geometry given (sun_dir/observer_dir or phase_angle_rad): the 1-σ leaves out the "
                        "synodic offset, which dominates on long arcs (0.1 % of the rate for a GPS-like orbit)")
    # Step 7: non-principal-axis tumbling — (a) a strong residual frequency that is no harmonic of f_rot, or
    # (b) two unrelated sinusoids (the two strongest periodogram peaks, refined) fit better than the harmonic series (BIC).
    p_r = np.clip(ls_r.power(peaks, method="cython"), 0.0, 1.0 - 1e-12)  # a second strong frequency is among the peaks
    zr = -0.5 * (n - 3) * np.log1p(-p_r) / np.interp(peaks, freq, noise_spec)
    j_r = int(np.argmax(zr))
    f_r = float(peaks[j_r])
    amp_r = float(np.hypot(*ls_r.model_parameters(f_r)[1:]))
    npa = bool(fap(zr[j_r]) <= false_alarm_level and amp_r >= npa_amplitude_ratio * amps.max() and not _is_harmonic(f_r, f_rot, T))
    if not npa and peaks.size >= 2 and not (_is_harmonic(peaks[1], peaks[0], T) or _is_harmonic(peaks[0], peaks[1], T)):

        def chi2_two(fs):
            X2 = np.concatenate([V, *(np.column_stack([np.cos(2 * np.pi * f * tc), np.sin(2 * np.pi * f * tc)]) for f in fs)], axis=1) * w[:, None]
            c2 = np.linalg.solve(X2.T @ X2 + 1e-12 * np.trace(X2.T @ X2) * np.eye(7), X2.T @ (y * w))  # normal equations: 7 columns, well conditioned at distinct frequencies; an SVD per step cost 20 % of the run
            e = y * w - X2 @ c2
            return float(e @ e), c2

        res2 = minimize(lambda fs: chi2_two(fs)[0], peaks[:2], method="Nelder-Mead", options={"xatol": 1e-3 / T, "fatol": 1e-9 * float(W @ y**2)})
        c2_two, cf = chi2_two(res2.x)
        a_two = np.hypot(cf[[3, 5]], cf[[4, 6]])
        bic_two = c2_two / s2 + 9 * np.log(n)
        bic_one = float(W @ r**2) / s2 + (2 * K + 4) * np.log(n)
        npa = bool(bic_two < bic_one and a_two.min() >= npa_amplitude_ratio * a_two.max())
    return SpinPrior(
        significant=True,
        rate_rad_s=float(2.0 * np.pi * f_rot),
        rate_sigma_rad_s=float(np.hypot(sigma_stat, sigma_syn)),
        frequency_hz=float(f_rot),
        strongest_frequency_hz=float(k_strong * f_fit),
        maxima_per_rotation=n_max,
        decision=decision,
        candidates=tuple(cands),
        npa_suspected=npa,
        false_alarm_level=false_alarm_level,
        false_alarm_probability=fap_max,
        n_harmonics=K,
        warnings=tuple(warnings),
        n_cycles=float(cycles),
        rate_sigma_statistical_rad_s=sigma_stat,
        rate_sigma_synodic_rad_s=float(sigma_syn),
        noise_correlation_time_s=tau,
        delta_bic=delta_bic,
        best_frequency_hz=float(f_rot),
        _series=series,
    )
