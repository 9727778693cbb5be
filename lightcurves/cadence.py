"""Synthetic cadences, light-curve shapes and noise with known truth, for testing period finders.

Two kinds of sampling:

* :func:`survey_times` — ground-based survey photometry of a fixed star or
  a slowly moving object: observing seasons (the target is up at night part
  of the year; yearly window), nights lost to weather and the Moon, one to a
  few visits per clear night within a few hours of the target's transit
  (daily window). 30–300 points over several seasons, like the sparse
  public variable-star surveys;
* :func:`satellite_times` — a tracking telescope on a satellite: one or a
  few passes of minutes to an hour, 0.1–10 s cadence with timing jitter and
  dropouts.

Shapes (:func:`curve`, magnitude against phase in cycles of the light
curve's fundamental): ``sinusoid``; ``sawtooth`` (Cepheid-like: fast rise,
slow decline); ``eclipsing`` (two unequal minima half a cycle apart — the
strongest harmonic is the second); ``double`` (two unequal maxima per turn,
the rocket body of Renis et al. §5.1). The fundamental of each shape is the
frequency a period finder should return (the published period; the
rotation frequency when ``maxima_per_rotation`` is explained).

:func:`heteroscedastic_noise` draws per-point errors and Gaussian noise
with a fraction of outliers; :func:`red_noise` an Ornstein–Uhlenbeck
(continuous AR(1)) process sampled at uneven times. Times are seconds.
"""

from __future__ import annotations

import numba
import numpy as np

__all__ = ["DAY_S", "YEAR_S", "SHAPES", "survey_times", "satellite_times", "curve", "heteroscedastic_noise", "red_noise", "ou_paths"]

DAY_S = 86_400.0
YEAR_S = 365.25 * DAY_S
SHAPES = ("sinusoid", "sawtooth", "eclipsing", "double")


def survey_times(rng: np.random.Generator, n_points: int, *, n_seasons: int = 3, season_days: float = 200.0, clear_fraction: float = 0.35,
                 night_hours: float = 4.0, max_visits: int = 3) -> np.ndarray:
    """Sorted times (s) of ``n_points`` survey visits over ``n_seasons`` yearly seasons.

    Each season lasts ``season_days`` (start drawn within the year); a night
    is clear with probability ``clear_fraction``; a clear night gets 1 to
    ``max_visits`` visits, at times within ``±night_hours/2`` of the target's
    transit (which drifts by 4 min a day: sidereal against solar time).
    Nights are drawn until ``n_points`` visits exist; the surplus is dropped
    at random so that whole seasons keep their coverage.
    """
    if n_points < 3 or n_seasons < 1 or not (0 < clear_fraction <= 1) or not (0 < season_days <= 365) or max_visits < 1:
        raise ValueError(f"need n_points >= 3, n_seasons >= 1, 0 < clear_fraction <= 1, 0 < season_days <= 365, max_visits >= 1; "
                         f"got {n_points}, {n_seasons}, {clear_fraction}, {season_days}, {max_visits}")
    start_day = rng.uniform(0.0, 365.25 - season_days)
    transit = rng.uniform(-3.0, 3.0)  # hours from local midnight at the season's start
    nights = np.concatenate([start_day + 365.25 * s + np.arange(int(season_days)) for s in range(n_seasons)])
    clear = nights[rng.random(nights.size) < clear_fraction]
    while clear.size * max_visits < n_points:  # too few clear nights for the points asked: observe more of them
        clear = np.union1d(clear, nights[rng.random(nights.size) < clear_fraction])
    visits = rng.integers(1, max_visits + 1, clear.size)
    day = np.repeat(clear, visits)
    hour = (transit - (day - start_day) * 24.0 / 365.25) % 24.0  # transit drifts through the year
    hour = np.where(hour > 12.0, hour - 24.0, hour) + rng.uniform(-0.5, 0.5, day.size) * night_hours
    t = (day + hour / 24.0) * DAY_S
    t = np.sort(rng.choice(t, size=min(n_points, t.size), replace=False))
    return t[np.concatenate([[True], np.diff(t) > 0])]


def satellite_times(rng: np.random.Generator, *, n_passes: int = 1, pass_s: float = 600.0, cadence_s: float = 1.0, pass_gap_s: float = 5400.0,
                    jitter: float = 0.1, dropout: float = 0.05) -> np.ndarray:
    """Sorted times (s) of ``n_passes`` tracking passes of ``pass_s`` each, ``pass_gap_s`` apart (start to start).

    Within a pass: a grid of ``cadence_s`` with ``±jitter/2`` cadences of
    timing jitter, a fraction ``dropout`` of the samples lost in short runs
    (tracking or cloud dropouts of 1–30 samples).
    """
    if not (n_passes >= 1 and 0 < cadence_s < pass_s and pass_gap_s >= pass_s and 0 <= jitter < 1 and 0 <= dropout < 0.5):
        raise ValueError(f"need n_passes >= 1, 0 < cadence_s < pass_s <= pass_gap_s, 0 <= jitter < 1, 0 <= dropout < 0.5; "
                         f"got {n_passes}, {cadence_s}, {pass_s}, {pass_gap_s}, {jitter}, {dropout}")
    out = []
    for k in range(n_passes):
        t = np.arange(0.0, pass_s, cadence_s)
        t = t + rng.uniform(-0.5, 0.5, t.size) * jitter * cadence_s
        keep = np.ones(t.size, bool)
        lost = 0
        while lost < dropout * t.size:
            run = int(rng.integers(1, 31))
            i = int(rng.integers(0, t.size))
            keep[i : i + run] = False
            lost += run
        out.append(k * pass_gap_s + t[keep])
    t = np.sort(np.concatenate(out))
    return t[np.concatenate([[True], np.diff(t) > 0])]


def curve(shape: str, phase_cycles, amplitude_mag: float, rng: np.random.Generator) -> np.ndarray:
    """Magnitude offsets of a light curve of ``shape`` (see :data:`SHAPES`) at ``phase_cycles`` (cycles of the fundamental).

    ``amplitude_mag`` is the peak-to-peak range. Shape details (asymmetry,
    eclipse depths and widths, the ratio of the two maxima) are drawn from
    ``rng`` so that no two curves are alike.
    """
    x = 2.0 * np.pi * np.asarray(phase_cycles, dtype=float)
    if shape == "sinusoid":
        m = np.cos(x)
    elif shape == "sawtooth":  # Fourier series of a skewed sawtooth, phases locked as in Cepheids
        r = rng.uniform(0.4, 0.7)
        m = sum(r ** (k - 1) / k * np.sin(k * x) for k in range(1, 9))
    elif shape == "eclipsing":  # two Gaussian dips of unequal depth at phases 0 and 0.5
        w = rng.uniform(0.03, 0.08)
        depth2 = rng.uniform(0.3, 0.8)
        ph = np.asarray(phase_cycles, dtype=float) % 1.0
        d1 = np.minimum(ph, 1.0 - ph)
        d2 = np.abs(ph - 0.5)
        m = np.exp(-0.5 * (d1 / w) ** 2) + depth2 * np.exp(-0.5 * (d2 / w) ** 2)  # magnitudes: positive = fainter
    elif shape == "double":  # two unequal maxima per turn plus some higher harmonics (specular glints)
        a1 = rng.uniform(0.25, 0.6)
        m = -(np.cos(2 * x) + a1 * np.cos(x + rng.uniform(0, 2 * np.pi)) + 0.25 * np.cos(4 * x + rng.uniform(0, 2 * np.pi)) + 0.1 * np.cos(3 * x))
    else:
        raise ValueError(f"shape must be one of {SHAPES}, got {shape!r}")
    return amplitude_mag * (m - m.mean()) / max(np.ptp(m), 1e-12)


def heteroscedastic_noise(rng: np.random.Generator, n: int, sigma_mag: float, *, spread: float = 0.4,
                          outlier_fraction: float = 0.02) -> tuple[np.ndarray, np.ndarray]:
    """``(noise, mag_err)``: per-point errors log-normal about ``sigma_mag`` (``spread`` in ln), Gaussian noise with those errors,
    and a fraction ``outlier_fraction`` of points off by 4–10 of their σ (the errors reported for them are not inflated)."""
    err = sigma_mag * np.exp(rng.normal(0.0, spread, n))
    noise = rng.normal(0.0, err)
    bad = rng.random(n) < outlier_fraction
    noise[bad] += rng.choice([-1.0, 1.0], bad.sum()) * rng.uniform(4.0, 10.0, bad.sum()) * err[bad]
    return noise, err


@numba.njit(cache=True)
def ou_paths(t: np.ndarray, tau_s: float, eps: np.ndarray) -> np.ndarray:
    """Unit-variance Ornstein–Uhlenbeck paths of correlation time ``tau_s`` at sorted times ``t``, one per row of the
    standard-normal ``eps`` (paths × N): ``x_{i+1} = φ x_i + sqrt(1 − φ²) ε_{i+1}``, ``φ = exp(−Δt/τ)`` (exact
    discretisation)."""
    x = np.empty_like(eps)
    for m in range(eps.shape[0]):
        x[m, 0] = eps[m, 0]
        for i in range(1, t.size):
            phi = np.exp(-(t[i] - t[i - 1]) / tau_s)
            x[m, i] = phi * x[m, i - 1] + np.sqrt(1.0 - phi * phi) * eps[m, i]
    return x


def red_noise(rng: np.random.Generator, t, sigma_mag: float, tau_s: float) -> np.ndarray:
    """An Ornstein–Uhlenbeck process of standard deviation ``sigma_mag`` and correlation time ``tau_s`` at sorted times
    ``t`` (:func:`ou_paths`)."""
    t = np.asarray(t, dtype=float)
    if not (sigma_mag > 0 and tau_s > 0):
        raise ValueError(f"need sigma_mag > 0 and tau_s > 0, got {sigma_mag}, {tau_s}")
    return sigma_mag * ou_paths(t, float(tau_s), rng.standard_normal((1, t.size)))[0]
