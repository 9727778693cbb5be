"""Spin priors from light curves: WindowCLEAN frequencies → rotation rate with a 1-σ uncertainty.

:func:`extract_spin_prior` (``002_…`` §2.3 and §5):

1. check the series; remove a weighted quadratic in time (the slow change of
   phase angle and range over the arc, which is not rotation);
2. :func:`~lightcurves.clean.window_clean` the residual; its significant
   peaks (false-alarm probability ≤ ``false_alarm_level``) are the ranked
   candidates. None significant → ``significant=False`` and no rate;
3. the rotation frequency is the *fundamental* of the light curve's harmonic
   series: the largest ``f₁/n`` (``n = 1 … max_maxima``, ``f₁`` the strongest
   peak) of which every significant peak stronger than ``harmonic_floor`` ×
   the strongest is a harmonic (within a quarter resolution element). A light
   curve with two unequal maxima per turn — the rocket body of ``002_…``
   §5.1, whose two ends reflect differently — has its strongest peak at twice
   the rotation frequency, and its odd harmonics of ``f₁/2`` are what tells
   the two halves of the turn apart; ``maxima_per_rotation = n``. Two *equal*
   maxima per turn cannot be told from one maximum at twice the rate by
   photometry alone; pass ``maxima_per_rotation`` when the shape says so;
4. the fundamental is refined by a non-linear least-squares fit of a Fourier
   series (``K`` harmonics: the highest significant one, at most
   ``max_harmonics``) to all samples; the 1-σ frequency error is from
   the fit's covariance, scaled by the reduced χ² when that exceeds 1.
   ``rate = 2π f_rot``. This is the *synodic* rate: the apparent one, which
   differs from the sidereal rate by the turning rate of the Sun–observer
   bisector about the spin axis;
5. non-principal-axis tumbling is flagged when a significant peak of at least
   ``npa_amplitude_ratio`` of the strongest is no harmonic of the rotation
   frequency (two unrelated frequencies dominate).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import minimize_scalar

from lightcurves.clean import CleanPeak, WindowCleanResult, window_clean
from lightcurves.samples import check_samples

__all__ = ["Candidate", "SpinPrior", "extract_spin_prior"]


@dataclass(frozen=True)
class Candidate:
    """A significant spectral peak, and how it relates to the adopted rotation frequency."""

    frequency_hz: float
    amplitude_mag: float  #: semi-amplitude
    false_alarm_probability: float
    harmonic: int | None  #: n if frequency ≈ n f_rot, else None

    def to_dict(self) -> dict:
        return {"frequency_hz": self.frequency_hz, "period_s": 1.0 / self.frequency_hz, "amplitude_mag": self.amplitude_mag, "false_alarm_probability": self.false_alarm_probability, "harmonic": self.harmonic}


@dataclass(frozen=True)
class SpinPrior:
    """Spin prior from one light curve (rates in rad/s; ``*_deg_s`` properties for people)."""

    significant: bool
    rate_rad_s: float | None  #: synodic rotation rate
    rate_sigma_rad_s: float | None  #: 1-σ
    frequency_hz: float | None  #: rotation frequency
    strongest_frequency_hz: float | None
    maxima_per_rotation: int | None  #: strongest peak / rotation frequency
    decision: str  #: why this many maxima per rotation (or why no period)
    candidates: tuple[Candidate, ...]
    npa_suspected: bool  #: two unrelated frequencies dominate
    false_alarm_level: float
    false_alarm_probability: float  #: of the strongest peak (1.0 if none)
    n_harmonics: int  #: Fourier terms in the refinement fit
    spectrum: WindowCleanResult = field(repr=False)

    @property
    def rate_deg_s(self) -> float | None:
        return None if self.rate_rad_s is None else float(np.degrees(self.rate_rad_s))

    @property
    def rate_sigma_deg_s(self) -> float | None:
        return None if self.rate_sigma_rad_s is None else float(np.degrees(self.rate_sigma_rad_s))

    @property
    def period_s(self) -> float | None:
        return None if self.frequency_hz is None else 1.0 / self.frequency_hz

    def to_dict(self) -> dict:
        """JSON-ready summary (no arrays)."""
        return {
            "significant": self.significant,
            "rate_deg_s": self.rate_deg_s,
            "rate_sigma_deg_s": self.rate_sigma_deg_s,
            "rate_rad_s": self.rate_rad_s,
            "rate_sigma_rad_s": self.rate_sigma_rad_s,
            "frequency_hz": self.frequency_hz,
            "period_s": self.period_s,
            "strongest_frequency_hz": self.strongest_frequency_hz,
            "maxima_per_rotation": self.maxima_per_rotation,
            "decision": self.decision,
            "npa_suspected": self.npa_suspected,
            "false_alarm_level": self.false_alarm_level,
            "false_alarm_probability": self.false_alarm_probability,
            "n_harmonics": self.n_harmonics,
            "candidates": [c.to_dict() for c in self.candidates],
        }


def _design(t: np.ndarray, f: float, harmonics) -> np.ndarray:
    """Columns ``1, cos(2πkft), sin(2πkft)`` for k in ``harmonics``."""
    arg = 2.0 * np.pi * f * np.outer(t, np.asarray(harmonics, dtype=float))
    return np.concatenate([np.ones((t.size, 1)), np.cos(arg), np.sin(arg)], axis=1)


def _chi2(t, y, w, f, harmonics) -> tuple[float, int]:
    X = _design(t, f, harmonics) * w[:, None]
    coef, *_ = np.linalg.lstsq(X, y * w, rcond=None)
    r = y * w - X @ coef
    return float(r @ r), X.shape[1]


def _harmonic_index(f: np.ndarray, f0: float, tol_hz: float) -> np.ndarray:
    """``k`` where ``|f − k f0| ≤ tol_hz`` (k ≥ 1), else 0."""
    k = np.rint(np.asarray(f) / f0).astype(int)
    return np.where((k >= 1) & (np.abs(f - k * f0) <= tol_hz), k, 0)


def _refine(t, y, w, f0, K, bound_hz) -> tuple[float, float]:
    """Least-squares fundamental frequency of a K-harmonic Fourier series, and its 1-σ error.

    Variable projection: the Fourier coefficients are solved linearly for each
    trial ``f``, leaving the profile ``χ²(f)`` to minimise in one dimension;
    ``σ_f² = 2 / χ²''(f̂)`` (the profile's curvature), times the reduced χ²
    when that exceeds 1 (unmodelled structure or underestimated errors).
    """
    h = range(1, K + 1)
    tc = t - t.mean()  # decorrelates frequency from phase

    def chi2(f):
        return _chi2(tc, y, w, f, h)[0]

    res = minimize_scalar(chi2, bounds=(f0 - bound_hz, f0 + bound_hz), method="bounded", options={"xatol": 1e-7 * f0})
    f = float(res.x)
    c0, p = _chi2(tc, y, w, f, h)
    step = 1e-3 / (t[-1] - t[0])
    curv = (chi2(f + step) - 2.0 * c0 + chi2(f - step)) / step**2
    red = c0 / max(t.size - p - 1, 1)
    sigma = np.sqrt(2.0 / curv * max(red, 1.0)) if curv > 0 else bound_hz
    return f, float(sigma)


def extract_spin_prior(
    t,
    mag,
    mag_err=None,
    *,
    false_alarm_level: float = 0.01,
    maxima_per_rotation: int | None = None,
    nu_max: float | None = None,
    max_harmonics: int = 40,
    max_maxima: int = 8,
    harmonic_floor: float = 0.1,
    npa_amplitude_ratio: float = 0.25,
    method: str = "fast",
    **clean_options,
) -> SpinPrior:
    """Spin prior from magnitudes ``mag`` (optionally 1-σ ``mag_err``) at times ``t`` (s).

    Parameters
    ----------
    false_alarm_level : a peak is significant when white noise would beat it
        with at most this probability; also the level of the maxima test.
    maxima_per_rotation : force the number of light-curve maxima per turn
        (1, 2, 4 …) instead of deciding it from the odd harmonics.
    nu_max : highest frequency searched (Hz), default the pseudo-Nyquist.
    max_harmonics : most Fourier terms in the refinement fit.
    max_maxima : largest number of maxima per rotation considered.
    harmonic_floor : peaks weaker than this fraction of the strongest need
        not be harmonics of the rotation frequency.
    npa_amplitude_ratio : a non-harmonic peak this strong (relative to the
        strongest) flags non-principal-axis tumbling.
    method, clean_options : passed to :func:`~lightcurves.clean.window_clean`.
    """
    t, y, dy = check_samples(t, mag, mag_err)
    if maxima_per_rotation is not None and int(maxima_per_rotation) < 1:
        raise ValueError(f"maxima_per_rotation must be a positive integer, got {maxima_per_rotation}")
    w = np.ones_like(y) if dy is None else 1.0 / dy
    # Step 1: remove the slow trend (phase angle, range) by weighted quadratic least squares.
    tc = (t - t.mean()) / (t[-1] - t[0])
    V = np.vander(tc, 3)
    trend, *_ = np.linalg.lstsq(V * w[:, None], y * w, rcond=None)
    y = y - V @ trend
    # Step 2: WindowCLEAN and its significant peaks.
    spec = window_clean(t, y, nu_max=nu_max, false_alarm_level=false_alarm_level, method=method, **clean_options)
    nu_top = spec.frequency_hz[-1]
    T = spec.duration_s
    peaks: list[CleanPeak] = [p for p in spec.peaks() if p.frequency_hz >= 1.0 / T]  # slower is unresolved
    if not peaks:
        best = spec.peaks(false_alarm_level=1.0, max_peaks=1)
        fap = best[0].false_alarm_probability if best else 1.0
        return SpinPrior(False, None, None, None, None, None, f"no significant period: the strongest peak has false-alarm probability {fap:.3g} > {false_alarm_level}", (), False, false_alarm_level, float(fap), 0, spec)
    f1 = peaks[0].frequency_hz
    # Step 3: the fundamental: the largest f1/n of which every strong peak is a harmonic.
    # Peak frequencies of strong peaks are good to a few hundredths of 1/T; a quarter
    # resolution element tells harmonics from unrelated frequencies.
    tol = 0.25 / T
    freqs = np.array([p.frequency_hz for p in peaks])
    amps = np.array([p.amplitude for p in peaks])
    strong = amps >= harmonic_floor * amps[0]
    if maxima_per_rotation is not None:
        n_max = int(maxima_per_rotation)
        decision = f"{n_max} maxima per rotation imposed by the caller"
    else:
        best_n, best_share = 1, -1.0
        for n in range(1, int(max_maxima) + 1):
            if f1 / n < 1.0 / T:  # not one full cycle in the arc
                break
            k = _harmonic_index(freqs[strong], f1 / n, tol)
            share = float((amps[strong][k > 0] ** 2).sum() / (amps[strong] ** 2).sum())
            if share > best_share + 1e-12:
                best_n, best_share = n, share
            if share == 1.0:
                break
        n_max = best_n
        ks = _harmonic_index(freqs[strong], f1 / n_max, tol)
        listed = ", ".join(str(v) for v in sorted(set(ks[ks > 0].tolist())))
        if best_share == 1.0:
            what = "one maximum" if n_max == 1 else f"{n_max} maxima"
            decision = f"{what} per rotation: every peak above {harmonic_floor:.0%} of the strongest is a harmonic ({listed}) of f/{n_max}, the strongest peak being harmonic {n_max}"
        else:
            decision = f"{n_max} maxima per rotation (best): harmonics ({listed}) of f/{n_max} carry only {best_share:.0%} of the strong peaks' power"
    # Step 4: refine the rotation frequency.
    f_rot0 = f1 / n_max
    k_all = _harmonic_index(freqs, f_rot0, tol)
    K = int(max(1, min(max_harmonics, k_all.max(initial=1), nu_top / f_rot0, (t.size - 1) // 6)))
    f_rot, sigma_f = _refine(t, y, w, f_rot0, K, bound_hz=0.5 / (n_max * T))
    # Step 5: candidates, harmonics, non-principal-axis flag.
    k_rot = _harmonic_index(freqs, f_rot, tol)
    cands = [Candidate(p.frequency_hz, p.amplitude, p.false_alarm_probability, int(k) if k else None) for p, k in zip(peaks, k_rot)]
    npa = any(c.harmonic is None and c.amplitude_mag >= npa_amplitude_ratio * peaks[0].amplitude for c in cands)
    return SpinPrior(
        significant=True,
        rate_rad_s=float(2.0 * np.pi * f_rot),
        rate_sigma_rad_s=float(2.0 * np.pi * sigma_f),
        frequency_hz=f_rot,
        strongest_frequency_hz=f1,
        maxima_per_rotation=n_max,
        decision=decision,
        candidates=tuple(cands),
        npa_suspected=bool(npa),
        false_alarm_level=false_alarm_level,
        false_alarm_probability=peaks[0].false_alarm_probability,
        n_harmonics=K,
        spectrum=spec,
    )
