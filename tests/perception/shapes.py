"""Surface samples of simple test shapes (numpy only), for registration and model tests.

These stand in for the shared targets where a test needs point models with
known geometry; sizes in m.
"""

from __future__ import annotations

import numpy as np


def box_surface(rng: np.random.Generator, n: int, size, center=(0.0, 0.0, 0.0)) -> np.ndarray:
    """``n`` points uniform over the surface of an axis-aligned box of edge lengths ``size``."""
    a = np.asarray(size, dtype=float)
    areas = np.array([a[1] * a[2], a[1] * a[2], a[0] * a[2], a[0] * a[2], a[0] * a[1], a[0] * a[1]])
    face = rng.choice(6, size=n, p=areas / areas.sum())
    p = (rng.random((n, 3)) - 0.5) * a
    axis = face // 2
    sign = np.where(face % 2 == 0, 0.5, -0.5)
    p[np.arange(n), axis] = sign * a[axis]
    return p + np.asarray(center)


def cylinder_surface(rng: np.random.Generator, n: int, radius: float, length: float, caps: bool = True) -> np.ndarray:
    """Points uniform over a cylinder about the z axis, centred at the origin."""
    side = 2 * np.pi * radius * length
    cap = np.pi * radius**2 if caps else 0.0
    kind = rng.choice(3, size=n, p=np.array([side, cap, cap]) / (side + 2 * cap))
    phi = rng.uniform(0, 2 * np.pi, n)
    r = np.where(kind == 0, radius, radius * np.sqrt(rng.random(n)))
    z = np.where(kind == 0, rng.uniform(-length / 2, length / 2, n), np.where(kind == 1, length / 2, -length / 2))
    return np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=1)


def box_wing(rng: np.random.Generator, n: int) -> np.ndarray:
    """A non-symmetric satellite: 2 x 1.5 x 1 m bus, one 3 x 1 m wing on +y, a boom on +x."""
    nb, nw = int(0.5 * n), int(0.35 * n)
    bus = box_surface(rng, nb, (2.0, 1.5, 1.0))
    wing = box_surface(rng, nw, (1.0, 3.0, 0.05), center=(0.2, 2.4, 0.0))
    boom = cylinder_surface(rng, n - nb - nw, 0.1, 1.2)[:, [2, 0, 1]] + np.array([1.6, -0.3, 0.3])
    return np.concatenate([bus, wing, boom])


def rocket_body(rng: np.random.Generator, n: int) -> np.ndarray:
    """An axisymmetric rocket body about z: a 1.2 m radius, 6 m long cylinder with a nozzle cone."""
    nc = int(0.8 * n)
    body = cylinder_surface(rng, nc, 1.2, 6.0)
    u = np.sqrt(rng.random(n - nc))  # cone from radius 0.2 at z=-3 to 0.8 at z=-4.5 (open nozzle)
    phi = rng.uniform(0, 2 * np.pi, n - nc)
    r = 0.2 + 0.6 * u
    z = -3.0 - 1.5 * u
    cone = np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=1)
    return np.concatenate([body, cone])


def with_outliers(rng: np.random.Generator, points: np.ndarray, fraction: float) -> np.ndarray:
    """Append uniformly distributed outliers in the bounding box so they make ``fraction`` of the result."""
    n_out = int(round(fraction / (1 - fraction) * len(points)))
    lo, hi = points.min(axis=0), points.max(axis=0)
    return np.concatenate([points, rng.uniform(lo, hi, size=(n_out, 3))])
