"""Convex shape models for inversion: a Gaussian image of facet areas and the triaxial ellipsoid.

A convex body is determined by its Gaussian image: the area per unit solid angle of outward normals
(Minkowski; Kaasalainen & Torppa, Icarus 153, 2001). Discretised on a fixed set of unit normals
``n_j`` with areas ``A_j ≥ 0`` its disk-integrated brightness is linear in the areas

    I(ŝ, ô) = Σ_j A_j · (E☉/π) · S(μ₀ⱼ, μⱼ) · f(α),      μ₀ⱼ = n_j·ŝ, μⱼ = n_j·ô,  both > 0,

with the Lommel–Seeliger + Lambert scattering law ``S = μ₀μ/(μ₀+μ) + c·μ₀μ`` (Kaasalainen, Torppa &
Muinonen, Icarus 153, 2001; c ≈ 0.1) and an optional phase function ``f(α)`` of the phase angle.
A convex body casts no shadow on itself, so the sum is exact for it. ``E☉`` = 1361 W/m² makes the
brightness a radiant intensity in W/sr when the areas are in m² (times a dimensionless reflectance):
the unit of :func:`lightcurves.render.observed_flux` and of calibrated :class:`InversionCurve` data.

:class:`ConvexModel` leaves the areas free (``basis`` is (N, m)); :class:`EllipsoidModel` fixes them
to the ellipsoid's (``basis`` is (N, 1), the one free weight a reflectance), a known shape.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np
from scipy.special import elliprg

from lightcurves.scene import SUN_IRRADIANCE_W_M2

__all__ = ["fibonacci_sphere", "scattering", "ConvexModel", "EllipsoidModel", "ellipsoid_area_density", "ellipsoid_surface_area", "ellipsoid_projected_area"]


def fibonacci_sphere(n: int) -> np.ndarray:
    """``n`` unit vectors (n, 3) of the Fibonacci lattice: near-uniform, each standing for a solid angle 4π/n.

    Points at ``z = 1 − (2k+1)/n`` and longitude ``k·π(3 − √5)`` (González, Math. Geosci. 42, 2010).
    """
    if not (isinstance(n, (int, np.integer)) and n >= 4):
        raise ValueError(f"n: {n!r}: expected an integer >= 4")
    k = np.arange(n)
    z = 1.0 - (2 * k + 1) / n
    lon = k * np.pi * (3.0 - np.sqrt(5.0))
    r = np.sqrt(1.0 - z * z)
    return np.stack([r * np.cos(lon), r * np.sin(lon), z], axis=1)


def scattering(mu0, mu, lambert_weight: float) -> np.ndarray:
    """Lommel–Seeliger + Lambert law ``S = μ₀μ/(μ₀+μ) + c·μ₀μ`` where μ₀, μ > 0, else 0 (same shape as the inputs)."""
    m0 = np.maximum(np.asarray(mu0, dtype=float), 0.0)
    m = np.maximum(np.asarray(mu, dtype=float), 0.0)
    prod = m0 * m  # 0 unless both > 0, so the quotient needs no mask
    return prod * (1.0 / np.maximum(m0 + m, 1e-300) + lambert_weight)


def _directions(name: str, v) -> np.ndarray:
    a = np.asarray(v, dtype=float)
    if a.ndim != 2 or a.shape[1] != 3 or not np.isfinite(a).all():
        raise ValueError(f"{name}: shape {a.shape}: expected finite (N, 3) unit vectors in the body frame T")
    return a


@dataclass(frozen=True)
class ConvexModel:
    """Convex shape with free facet areas on ``n_facets`` Fibonacci normals (module docstring).

    n_facets : number m of normals (the linear parameters).
    lambert_weight : c of the scattering law (dimensionless, ≥ 0).
    phase_function : f(α) of the phase angle α (rad, array) or None for f = 1.
    """

    n_facets: int = 200
    lambert_weight: float = 0.1
    phase_function: Callable[[np.ndarray], np.ndarray] | None = None
    normals_T: np.ndarray = field(init=False, repr=False)

    def __post_init__(self):
        if not (np.isfinite(self.lambert_weight) and self.lambert_weight >= 0):
            raise ValueError(f"lambert_weight: {self.lambert_weight!r}: expected a finite value >= 0")
        object.__setattr__(self, "normals_T", fibonacci_sphere(self.n_facets))

    @property
    def n_params(self) -> int:
        """Number of linear parameters (columns of :meth:`basis`)."""
        return self.n_facets

    def basis(self, sun_T, obs_T) -> np.ndarray:
        """(N, m) intensity (W/sr) per m² of each facet's area for unit directions to the Sun / observer (N, 3) in T."""
        s, o = _directions("sun_T", sun_T), _directions("obs_T", obs_T)
        out = (SUN_IRRADIANCE_W_M2 / np.pi) * scattering(s @ self.normals_T.T, o @ self.normals_T.T, self.lambert_weight)
        if self.phase_function is not None:
            alpha = np.arccos(np.clip(np.einsum("ij,ij->i", s, o), -1.0, 1.0))
            out *= np.asarray(self.phase_function(alpha), dtype=float)[:, None]
        return out

    def with_facets(self, n_facets: int) -> ConvexModel:
        """The same scattering law on ``n_facets`` normals (a coarser or finer model)."""
        return ConvexModel(n_facets, self.lambert_weight, self.phase_function)


def ellipsoid_area_density(normals, a_m: float, b_m: float, c_m: float) -> np.ndarray:
    """Area per unit solid angle of normals, m²/sr (n,), of the ellipsoid x²/a² + y²/b² + z²/c² = 1.

    The inverse Gaussian curvature at the point with outward normal n: the point is
    ``x = a²n_x h`` (…) with ``h = (a²n_x² + b²n_y² + c²n_z²)^(-1/2)``, and K = 1/((abc)² h⁴), so

        dA/dΩ = 1/K = (abc)² / (a²n_x² + b²n_y² + c²n_z²)².
    """
    n = np.asarray(normals, dtype=float)
    q = (a_m * n[:, 0]) ** 2 + (b_m * n[:, 1]) ** 2 + (c_m * n[:, 2]) ** 2
    return (a_m * b_m * c_m) ** 2 / q**2


def ellipsoid_surface_area(a_m: float, b_m: float, c_m: float) -> float:
    """Surface area (m²) of the triaxial ellipsoid: 4π abc R_G(a⁻², b⁻², c⁻²) (Carlson, DLMF 19.33.2)."""
    return float(4 * np.pi * a_m * b_m * c_m * elliprg(a_m**-2, b_m**-2, c_m**-2))


def ellipsoid_projected_area(direction, a_m: float, b_m: float, c_m: float) -> np.ndarray:
    """Projected (silhouette) area (m²) of the ellipsoid seen along unit directions (..., 3): π √((bc dₓ)² + (ac d_y)² + (ab d_z)²)."""
    d = np.asarray(direction, dtype=float)
    return np.pi * np.sqrt((b_m * c_m * d[..., 0]) ** 2 + (a_m * c_m * d[..., 1]) ** 2 + (a_m * b_m * d[..., 2]) ** 2)


@dataclass(frozen=True)
class EllipsoidModel:
    """Triaxial ellipsoid with semi-axes a ≥ b ≥ c (m) along body x, y, z: a known convex shape.

    Its facet areas are ``(4π/m)·dA/dΩ`` (:func:`ellipsoid_area_density`) on the ``n_facets`` Fibonacci
    normals of a :class:`ConvexModel` with the same scattering law; ``basis`` is the (N, 1) intensity
    (W/sr) for a unit reflectance, the one linear parameter.
    """

    a_m: float
    b_m: float
    c_m: float
    n_facets: int = 2000
    lambert_weight: float = 0.1
    phase_function: Callable[[np.ndarray], np.ndarray] | None = None
    convex: ConvexModel = field(init=False, repr=False)
    areas_m2: np.ndarray = field(init=False, repr=False)

    def __post_init__(self):
        axes = np.array([self.a_m, self.b_m, self.c_m], dtype=float)
        if not (np.isfinite(axes).all() and axes[2] > 0 and axes[0] >= axes[1] >= axes[2]):
            raise ValueError(f"a_m, b_m, c_m: {tuple(axes)}: expected finite semi-axes a >= b >= c > 0 in m")
        convex = ConvexModel(self.n_facets, self.lambert_weight, self.phase_function)
        object.__setattr__(self, "convex", convex)
        object.__setattr__(self, "areas_m2", 4 * np.pi / self.n_facets * ellipsoid_area_density(convex.normals_T, *axes))

    @property
    def n_params(self) -> int:
        return 1

    def coarse(self, max_facets: int) -> EllipsoidModel:
        """The same ellipsoid on at most ``max_facets`` Fibonacci normals: a cheaper model for the search's screen."""
        if int(max_facets) < 1:
            raise ValueError(f"max_facets: {max_facets}: expected an integer >= 1")
        return self if int(max_facets) >= self.n_facets else replace(self, n_facets=int(max_facets))

    def basis(self, sun_T, obs_T) -> np.ndarray:
        """(N, 1) intensity (W/sr) of the ellipsoid with unit reflectance, directions (N, 3) in T."""
        return (self.convex.basis(sun_T, obs_T) @ self.areas_m2)[:, None]
