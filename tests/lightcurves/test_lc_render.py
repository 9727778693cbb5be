"""Unresolved rendering against the analytic Lambert-sphere phase law, and flux/magnitude bookkeeping."""

import numpy as np
import pytest

from lightcurves.render import UnresolvedRenderer, flux_to_mag, mag_to_flux, observed_flux
from lightcurves.scene import SUN_IRRADIANCE_W_M2
from lightcurves.targets import get_target

# Film size per variant: the scalar renders are kept small (64 px, 16 spp: ~65k samples per image, 8 images).
SETTINGS = {"llvm_ad_rgb": (128, 16), "scalar_rgb": (64, 16)}


def lambert_phase_law(alpha):
    """I(α)/(ρ E R²) of a Lambertian sphere: (2/3π)[sin α + (π − α) cos α]."""
    return 2.0 / (3.0 * np.pi) * (np.sin(alpha) + (np.pi - alpha) * np.cos(alpha))


def test_lambertian_sphere_follows_the_phase_law(variant):
    """Rendered intensity of a Lambertian sphere within 1 % of the analytic law for 10°–150°."""
    R, albedo = 1.3, 0.4
    res, spp = SETTINGS[variant]
    renderer = UnresolvedRenderer(get_target("sphere", radius_m=R, albedo=albedo), resolution=res, spp=spp, variant=variant)
    assert renderer.variant == variant
    alpha = np.radians(np.arange(10.0, 151.0, 20.0 if variant == "scalar_rgb" else 10.0))
    sun = np.tile([0.0, 0.0, 1.0], (alpha.size, 1))
    obs = np.stack([np.sin(alpha), np.zeros_like(alpha), np.cos(alpha)], 1)
    intensity = renderer.intensity(sun, obs)
    expected = albedo * SUN_IRRADIANCE_W_M2 * R**2 * lambert_phase_law(alpha)
    np.testing.assert_allclose(intensity, expected, rtol=0.01)


def test_magnitude_scale_is_anchored_on_the_sun():
    assert flux_to_mag(SUN_IRRADIANCE_W_M2) == pytest.approx(-26.74)
    assert flux_to_mag(SUN_IRRADIANCE_W_M2 / 100.0) == pytest.approx(-26.74 + 5.0)
    m = np.array([3.0, 8.5, 14.0])
    np.testing.assert_allclose(flux_to_mag(mag_to_flux(m)), m, rtol=1e-12)
    # inverse-square in range, and the Sun's distance
    assert observed_flux(2.0, 1000.0) == pytest.approx(2e-6)
    assert observed_flux(2.0, 1000.0, sun_distance_m=2 * 1.495978707e11) == pytest.approx(0.5e-6)


def test_renderer_rejects_bad_settings():
    t = get_target("sphere", subdivisions=1)
    with pytest.raises(ValueError, match="spp"):
        UnresolvedRenderer(t, spp=8)
    with pytest.raises(ValueError, match="resolution"):
        UnresolvedRenderer(t, resolution=0)
