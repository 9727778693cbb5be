"""Ecliptic and equatorial J2000 directions: the rotation between the ecliptic frame E and I, and pole angles.

Frame I is the GCRS (axes of the ICRS: equatorial J2000 to within the frame bias, ~23 mas).
Frame E is the mean ecliptic and equinox of J2000 (astropy ``GeocentricMeanEcliptic`` at equinox
J2000): the frame of DAMIT/convexinv light-curve files and of asteroid poles (λ, β). The rotation
``C_IE`` (``v_I = C_IE @ v_E``) is taken from astropy (ERFA ``ecm06``: the IAU 2006 obliquity
ε0 = 84381.406″ about the x axis, composed with the frame bias), so it differs from the bare
rotation R_x(−ε0) by the frame bias only (≤ 1.1e-7 rad). JPL Horizons' "ecliptic J2000" uses the
IAU 1976 obliquity 84381.448″: 2.0e-7 rad (0.04″) away, far below what light curves resolve.

Angles are radians; longitudes (λ, RA) in [0, 2π), latitudes (β, Dec) in [−π/2, π/2].
"""

from __future__ import annotations

import functools

import astropy.units as u
import numpy as np
from astropy.coordinates import GCRS, CartesianRepresentation, GeocentricMeanEcliptic, UnitSphericalRepresentation
from astropy.time import Time

__all__ = ["ecliptic_to_I_matrix", "ecliptic_to_I", "I_to_ecliptic", "pole_to_ecliptic", "pole_from_ecliptic", "pole_to_radec", "pole_from_radec"]


@functools.lru_cache(maxsize=1)
def ecliptic_to_I_matrix() -> np.ndarray:
    """``C_IE`` (3, 3): ecliptic-J2000 components to I components, ``v_I = C_IE @ v_E`` (read-only).

    Its columns are astropy's images in GCRS of the ecliptic basis vectors (same obstime, so a pure
    rotation: no aberration or parallax enters for directions). Computed once: one rotation applied
    to every sample is a matrix product, far cheaper than a per-sample astropy transform.
    """
    j2000 = Time("J2000", scale="tt")
    basis = CartesianRepresentation(np.eye(3) * u.one)
    gcrs = GeocentricMeanEcliptic(basis, equinox=j2000, obstime=j2000).transform_to(GCRS(obstime=j2000))
    C_IE = np.asarray(gcrs.cartesian.xyz.to_value(u.one), dtype=float)  # column k: image of e_k
    C_IE.setflags(write=False)
    return C_IE


def ecliptic_to_I(v_E) -> np.ndarray:
    """Vectors (..., 3) from ecliptic J2000 components to I components (lengths kept)."""
    return np.asarray(v_E, dtype=float) @ ecliptic_to_I_matrix().T


def I_to_ecliptic(v_I) -> np.ndarray:
    """Vectors (..., 3) from I components to ecliptic J2000 components (lengths kept)."""
    return np.asarray(v_I, dtype=float) @ ecliptic_to_I_matrix()


def _unit(name: str, v) -> np.ndarray:
    a = np.asarray(v, dtype=float)
    if a.shape[-1:] != (3,):
        raise ValueError(f"{name}: shape {a.shape}: expected (..., 3) vectors")
    norm = np.linalg.norm(a, axis=-1, keepdims=True)
    if not (np.isfinite(a).all() and np.all(norm > 0)):
        raise ValueError(f"{name}: {a.tolist() if a.size <= 12 else 'array'}: expected finite, non-zero vectors")
    return a / norm


def _angles(v) -> tuple[np.ndarray, np.ndarray]:
    """Longitude in [0, 2π) and latitude of unit vectors (..., 3), through astropy's representations."""
    sph = CartesianRepresentation(np.moveaxis(v, -1, 0) * u.one).represent_as(UnitSphericalRepresentation)
    return sph.lon.to_value(u.rad), sph.lat.to_value(u.rad)


def _vector(lon_rad, lat_rad, name: str) -> np.ndarray:
    lon, lat = np.asarray(lon_rad, dtype=float), np.asarray(lat_rad, dtype=float)
    if not (np.isfinite(lon).all() and np.isfinite(lat).all()):
        raise ValueError(f"{name}: non-finite angle: expected finite radians")
    if np.any(np.abs(lat) > np.pi / 2 + 1e-12):
        raise ValueError(f"{name}: latitude {np.max(np.abs(lat)):.6g} rad: expected within [-pi/2, pi/2]")
    xyz = UnitSphericalRepresentation(lon * u.rad, np.clip(lat, -np.pi / 2, np.pi / 2) * u.rad).to_cartesian().xyz.to_value(u.one)
    return np.moveaxis(xyz, 0, -1)


def pole_to_ecliptic(pole_I) -> tuple[np.ndarray, np.ndarray]:
    """Ecliptic J2000 longitude λ and latitude β (rad) of spin-axis directions ``pole_I`` (..., 3) in I (any length)."""
    return _angles(I_to_ecliptic(_unit("pole_I", pole_I)))


def pole_from_ecliptic(lon_rad, lat_rad) -> np.ndarray:
    """Unit spin-axis directions (..., 3) in I from ecliptic J2000 longitude λ and latitude β (rad)."""
    return ecliptic_to_I(_vector(lon_rad, lat_rad, "pole (lambda, beta)"))


def pole_to_radec(pole_I) -> tuple[np.ndarray, np.ndarray]:
    """Right ascension and declination (rad, equatorial J2000 = I axes) of spin-axis directions ``pole_I`` (..., 3)."""
    return _angles(_unit("pole_I", pole_I))


def pole_from_radec(ra_rad, dec_rad) -> np.ndarray:
    """Unit spin-axis directions (..., 3) in I from right ascension and declination (rad)."""
    return _vector(ra_rad, dec_rad, "pole (RA, Dec)")
