"""Photometric noise and sampling of a ground telescope, so synthetic curves look like real ones.

* :class:`Telescope` — aperture, throughput, read noise, sky brightness,
  photometric aperture, extinction, site altitude.
* :func:`add_noise` — atmospheric extinction, then photon (shot) noise of the
  target and the sky background, read noise and scintillation, all drawn from
  a ``numpy.random.Generator``; samples whose measured signal is not positive
  are non-detections and are dropped by the caller (mask ``detected``).
* :func:`sample_times` — uneven sampling: a nominal cadence with timing
  jitter, and gaps (clouds, re-pointing, readout stalls).

Photon counts (V band): ``N = Φ₀ 10^(−0.4 m) A η t`` with
``Φ₀ ≈ 8.8·10⁹ photons s⁻¹ m⁻²`` for ``V = 0`` (Bessell 1998: 3640 Jy over
Δλ/λ ≈ 0.16). Scintillation, Young (1967) as in Osborn et al. (2015, eq. 7):
``σ_I/I = 0.09 D^(−2/3) X^1.75 e^(−h/8000 m) (2 t)^(−1/2)`` with ``D`` in cm.
The magnitude error is ``1.0857 σ_N/N`` (Howell, *Handbook of CCD Astronomy*, §4.4).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["Telescope", "NoisyPhotometry", "add_noise", "sample_times"]

V0_PHOTONS_S_M2 = 8.8e9
"""Photon rate of a V = 0 star above the atmosphere, photons s⁻¹ m⁻² (V band)."""


@dataclass(frozen=True)
class Telescope:
    """A small debris-tracking telescope with a CCD/CMOS camera (defaults: 0.5 m, dark site)."""

    aperture_m: float = 0.5
    throughput: float = 0.4  #: optics × filter × quantum efficiency
    read_noise_e: float = 8.0
    sky_mag_arcsec2: float = 20.5  #: V-band sky brightness
    aperture_radius_arcsec: float = 3.0  #: photometric aperture radius
    extinction_mag_per_airmass: float = 0.2  #: V band
    altitude_m: float = 2393.0  #: site altitude (scintillation scale height 8 km)

    def __post_init__(self):
        if not (self.aperture_m > 0 and 0 < self.throughput <= 1 and self.read_noise_e >= 0 and self.aperture_radius_arcsec > 0
                and self.extinction_mag_per_airmass >= 0):
            raise ValueError(f"telescope parameters out of range: {self}")

    @property
    def collecting_area_m2(self) -> float:
        return float(np.pi * (self.aperture_m / 2.0) ** 2)


@dataclass(frozen=True)
class NoisyPhotometry:
    """Measured magnitudes, their 1-σ errors, and which samples were detected."""

    mag: np.ndarray
    mag_err: np.ndarray
    detected: np.ndarray  #: bool


def add_noise(mag_true, exposure_s, airmass, telescope: Telescope, rng: np.random.Generator) -> NoisyPhotometry:
    """Noisy apparent magnitudes (above the atmosphere) of true magnitudes ``mag_true``.

    ``exposure_s`` scalar or per sample; ``airmass`` per sample (finite). The
    measured magnitude is corrected for the mean extinction, as an observer's
    reduction would, but keeps all the noise the atmosphere added.
    """
    m = np.asarray(mag_true, dtype=float)
    t = np.broadcast_to(np.asarray(exposure_s, dtype=float), m.shape)
    X = np.broadcast_to(np.asarray(airmass, dtype=float), m.shape)
    if np.any(t <= 0) or np.any(~np.isfinite(X)) or np.any(X < 1.0 - 1e-9):
        raise ValueError("exposure_s must be > 0 and airmass finite and >= 1")
    tel = telescope
    gain = V0_PHOTONS_S_M2 * tel.collecting_area_m2 * tel.throughput * t
    with np.errstate(over="ignore"):
        n_obj = gain * 10.0 ** (-0.4 * (m + tel.extinction_mag_per_airmass * X))  # inf mag -> 0 photons
    n_sky = gain * 10.0 ** (-0.4 * tel.sky_mag_arcsec2) * np.pi * tel.aperture_radius_arcsec**2
    scint = 0.09 * (100.0 * tel.aperture_m) ** (-2.0 / 3.0) * X**1.75 * np.exp(-tel.altitude_m / 8000.0) / np.sqrt(2.0 * t)
    # Shot noise of target + sky (Poisson), read noise (Gaussian), multiplicative scintillation.
    counts = rng.poisson(n_obj + n_sky).astype(float) + rng.normal(0.0, tel.read_noise_e, m.shape)
    counts += n_obj * scint * rng.normal(size=m.shape)
    measured = counts - n_sky  # background subtracted with a well-sampled sky annulus
    sigma = np.sqrt(n_obj + n_sky + tel.read_noise_e**2 + (scint * n_obj) ** 2)
    detected = measured > 3.0 * np.sqrt(n_sky + tel.read_noise_e**2)
    with np.errstate(divide="ignore", invalid="ignore"):
        mag = np.where(detected, -2.5 * np.log10(measured / gain) - tel.extinction_mag_per_airmass * X, np.nan)
        mag_err = np.where(detected, 2.5 / np.log(10.0) * sigma / measured, np.nan)
    return NoisyPhotometry(mag, mag_err, detected)


def sample_times(duration_s: float, cadence_s: float, rng: np.random.Generator, *, jitter: float = 0.1, n_gaps: int = 2,
                 gap_fraction: float = 0.06) -> np.ndarray:
    """Uneven sample times in ``[0, duration_s]``.

    A nominal grid of step ``cadence_s`` with uniform timing jitter of
    ``±jitter·cadence/2``, minus ``n_gaps`` gaps at random places that together
    remove ``gap_fraction`` of the arc. Strictly increasing.
    """
    if not (duration_s > 0 and cadence_s > 0 and cadence_s < duration_s):
        raise ValueError(f"need 0 < cadence_s < duration_s, got cadence_s={cadence_s}, duration_s={duration_s}")
    if not (0 <= jitter < 1 and n_gaps >= 0 and 0 <= gap_fraction < 0.5):
        raise ValueError(f"need 0 <= jitter < 1, n_gaps >= 0, 0 <= gap_fraction < 0.5, got {jitter}, {n_gaps}, {gap_fraction}")
    t = np.arange(0.0, duration_s + 1e-9, cadence_s)
    t = t + rng.uniform(-0.5, 0.5, t.size) * jitter * cadence_s
    t = np.clip(t, 0.0, duration_s)
    keep = np.ones(t.size, bool)
    if n_gaps and gap_fraction > 0:
        lengths = rng.dirichlet(np.ones(n_gaps)) * gap_fraction * duration_s
        for L in lengths:
            start = rng.uniform(0.05 * duration_s, 0.95 * duration_s - L)
            keep &= ~((t >= start) & (t < start + L))
    t = t[keep]
    return t[np.concatenate([[True], np.diff(t) > 0])]
