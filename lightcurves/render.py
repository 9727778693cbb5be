"""Unresolved rendering: the sunlight a target reflects toward an observer, with Mitsuba.

For each sample an orthographic sensor looks at the target along the line of
sight; its square film, ``2h × 2h`` metres with ``h`` slightly more than the
target's bounding radius, catches every reflected ray. The mean pixel
radiance ``L̄`` (W m⁻² sr⁻¹) times the film area is the radiant intensity
``I = L̄ (2h)²`` (W/sr) toward the observer; self-shadowing comes from the
renderer's shadow rays. The flux at the observer is ``F = I (1 au/d_sun)² / ρ²``
(``ρ`` the range) and the apparent magnitude ``m = −26.74 − 2.5 log₁₀(F / 1361)``
(the Sun's apparent magnitude and irradiance at 1 au).

One scene is loaded per :class:`UnresolvedRenderer`; the target stays fixed
in its own frame T while the Sun and the sensor move (``mi.traverse``), so
nothing is reloaded or recompiled per sample.
"""

from __future__ import annotations

import numpy as np

from lightcurves import scene as S
from lightcurves.targets import Target

__all__ = ["AU_M", "SUN_MAG", "UnresolvedRenderer", "flux_to_mag", "mag_to_flux", "observed_flux"]

AU_M = 1.495978707e11
"""Astronomical unit, m (IAU 2012)."""
SUN_MAG = -26.74
"""Apparent V magnitude of the Sun at 1 au."""


def flux_to_mag(flux_w_m2) -> np.ndarray:
    """Apparent magnitude of a flux (W/m²) relative to the Sun's 1361 W/m² at −26.74; inf for zero flux."""
    f = np.asarray(flux_w_m2, dtype=float)
    with np.errstate(divide="ignore"):
        return SUN_MAG - 2.5 * np.log10(f / S.SUN_IRRADIANCE_W_M2)


def mag_to_flux(mag) -> np.ndarray:
    """Inverse of :func:`flux_to_mag`, W/m²."""
    return S.SUN_IRRADIANCE_W_M2 * 10.0 ** (-0.4 * (np.asarray(mag, dtype=float) - SUN_MAG))


def observed_flux(intensity_w_sr, range_m, sun_distance_m=AU_M) -> np.ndarray:
    """Flux at the observer (W/m²) from the intensity rendered under 1361 W/m² sunlight."""
    scale = (AU_M / np.asarray(sun_distance_m, dtype=float)) ** 2
    return np.asarray(intensity_w_sr, dtype=float) * scale / np.asarray(range_m, dtype=float) ** 2


class UnresolvedRenderer:
    """Radiant intensity of a target toward an observer, for Sun/observer directions in T.

    Parameters
    ----------
    target : the target (meshes in its frame T).
    resolution : film width = height, pixels.
    spp : samples per pixel (a power of 4: Mitsuba's low-discrepancy sampler,
        which integrates the film far better than independent samples).
    variant : Mitsuba variant, or None for the best available (:func:`scene.select_variant`).
    margin : film half-size over the target's bounding radius.
    """

    def __init__(self, target: Target, resolution: int = 64, spp: int = 4, variant: str | None = None, margin: float = 1.02):
        if int(resolution) < 1:
            raise ValueError(f"resolution must be >= 1 pixel, got {resolution}")
        if int(spp) not in (1, 4, 16, 64, 256):
            raise ValueError(f"spp must be a power of 4 (1, 4, 16, 64 or 256) for the low-discrepancy sampler, got {spp}")
        self.variant = S.select_variant(variant)
        import mitsuba as mi

        self._mi = mi
        self.target = target
        self.half_size_m = float(margin * target.radius_m)
        self.distance_m = 4.0 * target.radius_m
        sensor = {
            "type": "orthographic",
            "to_world": mi.ScalarTransform4f(self._sensor_matrix(np.array([0.0, 0.0, 1.0]))),
            "far_clip": 10.0 * self.distance_m,
            "film": {"type": "hdrfilm", "width": int(resolution), "height": int(resolution), "rfilter": {"type": "box"}, "pixel_format": "rgb"},
            "sampler": {"type": "ldsampler", "sample_count": int(spp)},
        }
        self.scene = mi.load_dict(S.scene_dict(target, [0.0, 0.0, 1.0], sensors={"observer": sensor}))
        self.poser = S.ScenePoser(self.scene, target)

    def _sensor_matrix(self, obs_T: np.ndarray) -> np.ndarray:
        up = np.array([0.0, 0.0, 1.0]) if abs(obs_T[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
        h = self.half_size_m
        return S.look_at_matrix(self.distance_m * obs_T, np.zeros(3), up) @ np.diag([h, h, 1.0, 1.0])

    def intensity(self, sun_T, obs_T, seed: int = 0) -> np.ndarray:
        """Radiant intensity (W/sr) toward unit directions ``obs_T`` under 1361 W/m² from ``sun_T``.

        ``sun_T``, ``obs_T``: (N, 3) unit vectors from the target to the Sun and
        to the observer, in T. Returns (N,).
        """
        sun_T = np.atleast_2d(np.asarray(sun_T, dtype=float))
        obs_T = np.atleast_2d(np.asarray(obs_T, dtype=float))
        if sun_T.shape != obs_T.shape or sun_T.shape[1] != 3:
            raise ValueError(f"sun_T and obs_T must both be (N, 3), got {sun_T.shape}, {obs_T.shape}")
        area = (2.0 * self.half_size_m) ** 2
        out = np.empty(len(sun_T))
        p = self.poser.params
        for k, (s, o) in enumerate(zip(sun_T, obs_T)):
            o = o / np.linalg.norm(o)
            p["sun.to_world"] = self._mi.Transform4f(S.frame_from_z(-s / np.linalg.norm(s)))
            p["observer.to_world"] = self._mi.Transform4f(self._sensor_matrix(o))
            p.update()
            img = self._mi.render(self.scene, seed=seed + k)
            out[k] = float(np.mean(np.asarray(img)[..., :3])) * area
        return out
