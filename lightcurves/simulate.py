"""Synthetic light curves: orbit and site geometry, torque-free attitude, Mitsuba rendering, photometric noise.

:func:`simulate_lightcurve` composes :mod:`geometry` (where the target, the
Sun and the observer are), :func:`geometry.spin_attitude` (how the target is
turned), :class:`render.UnresolvedRenderer` (how much light it sends the
observer) and :mod:`photometry` (what a telescope measures), and returns the
measured :class:`~lightcurves.io.LightCurve` (with its per-sample geometry:
target -> Sun and target -> observer unit vectors in I, Sun distance) and
the noise-free truth.

The default orbit is a circular 26 560 km, 55° orbit (GPS disposal region,
where Atlas-Centaur upper stages are): the line of sight turns by ≲0.01°/s
there, so the synodic rotation rate a light curve measures equals the
sidereal one to ~0.2 % at 5°/s. In LEO the line of sight sweeps up to
~0.5°/s and the measured (synodic) rate differs from the sidereal one by as
much; the prior reports the synodic rate.
"""

from __future__ import annotations

from dataclasses import dataclass

import astropy.units as u
import numpy as np
from astropy.coordinates import EarthLocation
from astropy.time import Time

from estimators.attitude import quat_to_dcm
from lightcurves.geometry import DEFAULT_SITE, KeplerOrbit, Observation, find_visible_start, observe, pole_quaternion, spin_attitude
from lightcurves.io import LightCurve
from lightcurves.photometry import Telescope, add_noise, sample_times
from lightcurves.render import UnresolvedRenderer, flux_to_mag, mag_to_flux, observed_flux
from lightcurves.samples import MIN_SAMPLES
from lightcurves.targets import Target

__all__ = ["DEFAULT_ORBIT", "DEFAULT_EPOCH", "SimulatedLightCurve", "simulate_lightcurve"]

DEFAULT_ORBIT = KeplerOrbit(a_m=26_560e3, e=0.0, i_rad=np.radians(55.0), raan_rad=np.radians(30.0))
DEFAULT_EPOCH = Time("2024-03-21T18:00:00", scale="utc")


@dataclass(frozen=True)
class SimulatedLightCurve:
    """A synthetic light curve and the truth behind it (arrays over the kept samples)."""

    lightcurve: LightCurve  #: what the telescope measured (noisy, gaps, non-detections removed)
    flux_true_w_m2: np.ndarray  #: noise-free flux at the observer
    observation: Observation  #: geometry at the kept samples
    q_IT: np.ndarray  #: (N, 4) attitude
    w_T: np.ndarray  #: (N, 3) body rate, rad/s
    variant: str  #: Mitsuba variant that rendered it


def _start_phase(phase_rad: float, phase_epoch: Time | None, rate_rad_s: float, arc_start: Time) -> float:
    """The phase at the arc's start: ``phase_rad`` there, or carried from ``phase_epoch`` by ``rate · Δt``.

    :func:`geometry.pole_quaternion`'s phase turns the body about the pole, so a steady spin advances it by
    ``ω Δt`` (Δt in TT seconds, here up to decades: ~1e9 s × ω keeps ~1e-7 rad in double precision).
    """
    if phase_epoch is None:
        return float(phase_rad)
    return float(np.mod(phase_rad + rate_rad_s * (arc_start - phase_epoch).to_value(u.s), 2.0 * np.pi))


def simulate_lightcurve(
    target: Target,
    *,
    axis_T,
    rate_rad_s: float,
    duration_s: float,
    cadence_s: float,
    rng: np.random.Generator,
    orbit: KeplerOrbit = DEFAULT_ORBIT,
    epoch: Time = DEFAULT_EPOCH,
    site: EarthLocation = DEFAULT_SITE,
    pole_I=None,
    phase_rad: float | None = None,
    phase_epoch: Time | None = None,
    telescope: Telescope = Telescope(),
    exposure_s: float | None = None,
    noise: bool = True,
    uneven: bool = True,
    renderer: UnresolvedRenderer | None = None,
    meta: dict | None = None,
    progress=None,
) -> SimulatedLightCurve:
    """Render a light curve of ``target`` spinning at ``rate_rad_s`` about body axis ``axis_T``.

    The arc starts at the first time after ``epoch`` from which the target is
    visible for ``duration_s`` (:func:`geometry.find_visible_start`).
    ``pole_I`` is the inertial direction of the spin axis; by default the
    normal of the Sun–target–observer plane at mid-arc (largest modulation).
    ``phase_rad`` (default: drawn from ``rng``) turns the body about it.
    ``exposure_s`` defaults to 80 % of the cadence. ``noise=False`` and
    ``uneven=False`` give the clean, evenly sampled curve. ``progress`` is an
    optional callable ``progress(n_done, n_total)`` for the caller's progress bar.
    """
    axis_T = np.asarray(axis_T, dtype=float).reshape(3)
    if not (np.isfinite(axis_T).all() and np.linalg.norm(axis_T) > 0):
        raise ValueError(f"axis_T must be a non-zero 3-vector, got {axis_T}")
    axis_T = axis_T / np.linalg.norm(axis_T)
    if not (np.isfinite(rate_rad_s) and rate_rad_s >= 0):
        raise ValueError(f"rate must be finite and >= 0, got {rate_rad_s} rad/s")
    if not (duration_s > 0 and 0 < cadence_s < duration_s):
        raise ValueError(f"need 0 < cadence < duration, got cadence {cadence_s} s, duration {duration_s} s")
    t_rel = sample_times(duration_s, cadence_s, rng) if uneven else np.arange(0.0, duration_s + 1e-9, cadence_s)
    start = find_visible_start(orbit, epoch, duration_s, site)
    obs = observe(orbit, start + t_rel, epoch, site)
    mid = len(t_rel) // 2
    if pole_I is None:
        pole_I = np.cross(obs.sun_dir_I[mid], obs.observer_dir_I[mid])
        if np.linalg.norm(pole_I) < 1e-6:
            pole_I = np.cross(obs.observer_dir_I[mid], [0.0, 0.0, 1.0])
    pole_I = np.asarray(pole_I, dtype=float) / np.linalg.norm(pole_I)
    if phase_rad is None:
        phase_rad = float(rng.uniform(0.0, 2.0 * np.pi))
    q0 = pole_quaternion(axis_T, pole_I, _start_phase(phase_rad, phase_epoch, rate_rad_s, epoch + start * u.s))
    q_IT, w_T = spin_attitude(q0, rate_rad_s * axis_T, target.J_diag, t_rel)
    C_TI = np.swapaxes(quat_to_dcm(q_IT), -1, -2)
    sun_T = np.einsum("nij,nj->ni", C_TI, obs.sun_dir_I)
    obs_T = np.einsum("nij,nj->ni", C_TI, obs.observer_dir_I)

    if renderer is None:
        renderer = UnresolvedRenderer(target)
    intensity = np.zeros(len(t_rel))
    lit = np.flatnonzero(obs.sunlit)
    chunk = 50
    for k in range(0, len(lit), chunk):
        idx = lit[k : k + chunk]
        intensity[idx] = renderer.intensity(sun_T[idx], obs_T[idx], seed=int(idx[0]))
        if progress is not None:
            progress(min(k + chunk, len(lit)), len(lit))
    flux = observed_flux(intensity, obs.range_m, obs.sun_distance_m)
    mag_true = flux_to_mag(flux)

    keep = obs.visible.copy()
    if noise:
        X = np.where(np.isfinite(obs.airmass), obs.airmass, 40.0)
        phot = add_noise(mag_true, exposure_s if exposure_s is not None else 0.8 * cadence_s, X, telescope, rng)
        keep &= phot.detected
        mag, mag_err = phot.mag, phot.mag_err
    else:
        keep &= flux > 0
        mag, mag_err = mag_true, np.full(len(t_rel), np.nan)
    if keep.sum() < MIN_SAMPLES:
        raise ValueError(f"only {int(keep.sum())} of {len(t_rel)} samples are visible and detected; at least {MIN_SAMPLES} are needed")

    times = epoch + (start + t_rel[keep]) * u.s
    info = {
        "target": target.name,
        "target_params": target.params,
        "inertia_kg_m2": target.J_diag.tolist(),
        "k1": target.k[0],
        "k2": target.k[1],
        "truth_spin_axis_T": axis_T.tolist(),
        "truth_rate_rad_s": float(rate_rad_s),
        "truth_rate_deg_s": float(np.degrees(rate_rad_s)),
        "truth_pole_I": pole_I.tolist(),
        "truth_phase_rad": float(phase_rad),
        "truth_phase_epoch": None if phase_epoch is None else phase_epoch.utc.isot,
        "site": {"lat_deg": float(site.lat.deg), "lon_deg": float(site.lon.deg), "height_m": float(site.height.to_value(u.m))},
        "orbit": {"a_m": orbit.a_m, "e": orbit.e, "i_deg": float(np.degrees(orbit.i_rad)), "raan_deg": float(np.degrees(orbit.raan_rad)),
                  "argp_deg": float(np.degrees(orbit.argp_rad)), "nu0_deg": float(np.degrees(orbit.nu0_rad))},
        "epoch": epoch.isot,
        "arc_start_s": float(start),
        "cadence_s": float(cadence_s),
        "duration_s": float(duration_s),
        "noise": bool(noise),
        "renderer": {"variant": renderer.variant, "half_size_m": renderer.half_size_m},
    }
    info.update(meta or {})
    sub = lambda a: a[keep]  # noqa: E731
    kept_obs = Observation(
        t_s=sub(obs.t_s), epoch=epoch, r_target_I=sub(obs.r_target_I), r_observer_I=sub(obs.r_observer_I), r_sun_I=sub(obs.r_sun_I),
        range_m=sub(obs.range_m), elevation_rad=sub(obs.elevation_rad), sun_elevation_rad=sub(obs.sun_elevation_rad),
        phase_angle_rad=sub(obs.phase_angle_rad), sunlit=sub(obs.sunlit), airmass=sub(obs.airmass), visible=sub(obs.visible),
    )  # fmt: skip
    lc = LightCurve(
        time=times, mag=sub(mag), mag_err=sub(mag_err), flux_w_m2=mag_to_flux(sub(mag)), phase_angle_rad=kept_obs.phase_angle_rad,
        range_m=kept_obs.range_m, elevation_rad=kept_obs.elevation_rad, meta=info,
        sun_dir_I=kept_obs.sun_dir_I, observer_dir_I=kept_obs.observer_dir_I, sun_distance_m=kept_obs.sun_distance_m,
    )  # fmt: skip
    return SimulatedLightCurve(lc, sub(flux), kept_obs, sub(q_IT), sub(w_T), renderer.variant)
