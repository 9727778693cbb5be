"""Convex and ellipsoid models against analytic references: Lambert and Lommel–Seeliger spheres, ellipsoid areas."""

import numpy as np
import pytest

from lightcurves.inversion.convex import ConvexModel, EllipsoidModel, ellipsoid_projected_area, ellipsoid_surface_area, fibonacci_sphere
from lightcurves.scene import SUN_IRRADIANCE_W_M2


def _sphere_integral(alpha, lambert_weight, n=20000):
    """∫ S dΩ over the sphere for the phase angle α, by the convex model with equal areas 4π/n (sr)."""
    sun = np.array([[1.0, 0.0, 0.0]])
    obs = np.array([[np.cos(alpha), np.sin(alpha), 0.0]])
    return ConvexModel(n, lambert_weight).basis(sun, obs).sum() * 4 * np.pi / n / (SUN_IRRADIANCE_W_M2 / np.pi)


@pytest.mark.parametrize("alpha", [0.05, 0.5, 1.2, 2.0, 2.8])
def test_sphere_matches_the_lambert_and_lommel_seeliger_phase_laws(alpha):
    # Lommel–Seeliger sphere: π/2 [1 − sin(α/2) tan(α/2) ln cot(α/4)]; Lambert: (2/3)[sin α + (π − α) cos α]
    ls = np.pi / 2 * (1 - np.sin(alpha / 2) * np.tan(alpha / 2) * np.log(1 / np.tan(alpha / 4)))
    lam = 2.0 / 3.0 * (np.sin(alpha) + (np.pi - alpha) * np.cos(alpha))
    assert _sphere_integral(alpha, 0.0) == pytest.approx(ls, rel=2e-3, abs=2e-4)
    assert _sphere_integral(alpha, 1.0) - _sphere_integral(alpha, 0.0) == pytest.approx(lam, rel=2e-3, abs=2e-4)


def test_phase_function_multiplies():
    sun, obs = np.array([[1.0, 0, 0]]), np.array([[0.0, 1.0, 0]])
    plain = ConvexModel(100).basis(sun, obs)
    np.testing.assert_allclose(ConvexModel(100, phase_function=lambda a: 0.5 + 0 * a).basis(sun, obs), 0.5 * plain)


@pytest.mark.parametrize("axes", [(1.0, 1.0, 1.0), (3.0, 2.0, 1.0), (5.0, 1.5, 1.0)])
def test_ellipsoid_facet_areas_give_surface_and_projected_area(axes):
    e = EllipsoidModel(*axes, n_facets=6000)
    assert e.areas_m2.sum() == pytest.approx(ellipsoid_surface_area(*axes), rel=2e-3)
    # Σ A_j max(n_j·d, 0) is the silhouette area seen along d (Cauchy)
    for d in fibonacci_sphere(7)[:5]:
        assert e.areas_m2 @ np.clip(e.convex.normals_T @ d, 0, None) == pytest.approx(ellipsoid_projected_area(d, *axes), rel=2e-3)
    if axes[0] == axes[2]:
        assert ellipsoid_surface_area(*axes) == pytest.approx(4 * np.pi)


def test_ellipsoid_at_opposition_lambert_brightness():
    """α = 0, the Lambert term alone (c = 1 minus c = 0): ∫ μ² dA over the visible hemisphere of a sphere of radius R is
    2πR²/3, whatever the direction (the ellipsoid code path with a = b = c = 2 m)."""
    e = EllipsoidModel(2.0, 2.0, 2.0, n_facets=8000, lambert_weight=1.0)
    d = np.array([[0.0, 0.6, 0.8]])
    ls = EllipsoidModel(2.0, 2.0, 2.0, n_facets=8000, lambert_weight=0.0)
    lambert = (e.basis(d, d) - ls.basis(d, d))[0, 0] / (SUN_IRRADIANCE_W_M2 / np.pi)
    assert lambert == pytest.approx(2 * np.pi / 3 * 4.0, rel=2e-3)


def test_bad_input_names_the_field():
    with pytest.raises(ValueError, match="a_m, b_m, c_m"):
        EllipsoidModel(1.0, 2.0, 3.0)
    with pytest.raises(ValueError, match="lambert_weight"):
        ConvexModel(10, -1.0)
    with pytest.raises(ValueError, match="sun_T"):
        ConvexModel(10).basis(np.zeros((3, 2)), np.zeros((3, 3)))
    with pytest.raises(ValueError, match="n: "):
        fibonacci_sphere(2)
