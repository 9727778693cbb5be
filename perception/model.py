"""Coarse target model of CoMBiNa's preliminary phase, §III.B of Maestrini et al.

The chaser flies one inspection orbit (the inclined football orbit of eq. 46)
and accumulates stereo clouds. A SLAM system would estimate the camera poses;
here they are taken as known in a target-fixed map frame M, optionally with
noise standing in for SLAM drift. The accumulated cloud is then cleaned as the
paper describes:

1. a k-nearest-neighbour density test (points whose mean distance to their
   ``k`` neighbours is far above the map's typical value are outliers);
2. visibility carving in the spirit of the probabilistic space carving the
   paper uses: the points are tetrahedralised (Delaunay) and every
   observation — the segment from the camera to the point it saw — votes
   "free space" for the tetrahedra it crosses before reaching its point
   (minus a noise margin). A tetrahedron crossed by a ray is carved; a point
   at least half (``carve_fraction``) of whose incident tetrahedra are carved
   lies in seen-through space and is removed. A point on the true surface
   keeps the tetrahedra behind it (inside the body), which no ray reaches;
3. voxel downsampling to a few thousand points;
4. principal axes by PCA on the points closest to the centroid (avoiding the
   bias of appendages, as the paper does), giving the model frame P (axes by
   decreasing variance, right-handed).

The paper reports < 10° between the PCA frame and the true principal axes;
:func:`axis_errors_deg` measures it (axes compared up to sign and order).
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import permutations

import numpy as np
from scipy.spatial import Delaunay, cKDTree

from estimators.attitude import quat_to_dcm, rotvec_to_quat
from estimators.dynamics import cw_propagate

__all__ = [
    "CoarseModel",
    "football_orbit_L",
    "accumulate_clouds",
    "knn_outlier_mask",
    "carve_mask",
    "voxel_downsample",
    "principal_axes",
    "build_coarse_model",
    "axis_errors_deg",
    "mesh_surface_points",
]


@dataclass(frozen=True)
class CoarseModel:
    """The coarse model and how it was made.

    ``points_P``: (N, 3) model points in the PCA frame P (origin at their centroid), m.
    ``C_PM``: (3, 3) DCM map frame → P; ``centre_M``: (3,) origin of P in M, m
    (``p_P = C_PM (p_M − centre_M)``).
    ``n_raw``, ``n_after_knn``, ``n_after_carving``: points at each stage.
    """

    points_P: np.ndarray
    C_PM: np.ndarray
    centre_M: np.ndarray
    n_raw: int
    n_after_knn: int
    n_after_carving: int


def football_orbit_L(n_views: int, *, lu_m: float = 12.0, mean_motion_rad_s: float = 1.0 / 963.65) -> tuple[np.ndarray, np.ndarray]:
    """Times (s) and target positions relative to the chaser in LVLH (m) over one period of eq. 46.

    ``r(0) = [2, 0, 0.2] LU``, ``v(0) = [0, −4, 0] LU/TU`` with ``TU = 1/n``: the
    Clohessy–Wiltshire football orbit (2:1 ellipse, 2 LU radial, 4 LU along-track).
    """
    if n_views < 1:
        raise ValueError(f"n_views must be >= 1, got {n_views}")
    n = mean_motion_rad_s
    x0 = np.array([2.0 * lu_m, 0.0, 0.2 * lu_m, 0.0, -4.0 * lu_m * n, 0.0])
    t = np.arange(n_views) * (2.0 * np.pi / n) / n_views
    return t, cw_propagate(x0, n, t)[:, :3]


def accumulate_clouds(clouds_C, C_MC, o_M, *, rng: np.random.Generator | None = None, pose_noise_rad: float = 0.0, pose_noise_m: float = 0.0):
    """Clouds in camera frames → one map-frame cloud with the camera origin of each point.

    ``clouds_C``: list of (M_i, 3) clouds in C; ``C_MC``: (V, 3, 3) camera → map
    DCMs; ``o_M``: (V, 3) camera origins in M. Pose noise (a random rotation
    of ``pose_noise_rad`` RMS per axis and an offset of ``pose_noise_m`` per
    axis per view, both drawn from ``rng``) stands in for SLAM drift.
    Returns ``(points_M (N, 3), origins_M (N, 3))``.
    """
    if len(clouds_C) != len(C_MC) or len(clouds_C) != len(o_M):
        raise ValueError("clouds_C, C_MC and o_M must have one entry per view")
    if (pose_noise_rad > 0 or pose_noise_m > 0) and rng is None:
        raise ValueError("pose noise needs an rng (numpy Generator)")
    pts, origins = [], []
    for cloud, C, o in zip(clouds_C, C_MC, o_M):
        C = np.asarray(C, dtype=float)
        o = np.asarray(o, dtype=float)
        if pose_noise_rad > 0:
            C = quat_to_dcm(rotvec_to_quat(rng.normal(scale=pose_noise_rad, size=3))) @ C
        if pose_noise_m > 0:
            o = o + rng.normal(scale=pose_noise_m, size=3)
        cloud = np.asarray(cloud, dtype=float).reshape(-1, 3)
        pts.append(cloud @ C.T + o)
        origins.append(np.broadcast_to(o, cloud.shape))
    return np.concatenate(pts), np.concatenate(origins)


def knn_outlier_mask(points, k: int = 8, n_sigma: float = 2.0) -> np.ndarray:
    """True for inliers: mean distance to the ``k`` nearest neighbours below median + ``n_sigma`` · 1.4826 MAD."""
    p = np.asarray(points, dtype=float)
    if len(p) <= k:
        return np.ones(len(p), bool)
    d, _ = cKDTree(p).query(p, k=k + 1)
    mean_d = d[:, 1:].mean(axis=1)
    med = np.median(mean_d)
    mad = 1.4826 * np.median(np.abs(mean_d - med))
    return mean_d <= med + n_sigma * max(mad, 1e-12)


def carve_mask(points, origins, *, margin_m: float = 0.15, step_m: float = 0.1, min_votes: int = 1, carve_fraction: float = 0.5, max_rays: int = 20000,
               rng: np.random.Generator | None = None) -> np.ndarray:
    """True for points that survive Delaunay free-space carving (module docstring, step 2).

    Each ray from ``origins[i]`` to ``points[i]`` is sampled every ``step_m``
    inside the cloud's bounding sphere up to ``margin_m`` before the point;
    the tetrahedra holding the samples get a vote. At most ``max_rays`` rays
    (a random subset drawn with ``rng``) vote.
    """
    p = np.asarray(points, dtype=float)
    o = np.asarray(origins, dtype=float)
    if len(p) < 5:
        return np.ones(len(p), bool)
    tri = Delaunay(p)
    rng = np.random.default_rng(0) if rng is None else rng
    ids = np.arange(len(p)) if len(p) <= max_rays else rng.choice(len(p), max_rays, replace=False)
    centre = np.median(p, axis=0)
    radius = np.quantile(np.linalg.norm(p - centre, axis=1), 0.99)  # stray far points do not stretch the rays
    d = p[ids] - o[ids]
    length = np.linalg.norm(d, axis=1)
    d = d / length[:, None]
    # entry of each ray into the cloud's bounding sphere (cameras are outside it)
    b = np.einsum("ij,ij->i", d, o[ids] - centre)
    disc = b * b - (np.sum((o[ids] - centre) ** 2, axis=1) - radius**2)
    s0 = np.maximum(-b - np.sqrt(np.maximum(disc, 0.0)), 0.0)
    s1 = length - margin_m
    n_steps = int(np.ceil(2.0 * radius / step_m)) + 1
    s = s0[:, None] + step_m * np.arange(n_steps)[None, :]  # (rays, steps)
    valid = s < s1[:, None]
    ray = np.repeat(np.arange(len(ids)), n_steps).reshape(len(ids), n_steps)[valid]
    samples = o[ids][ray] + s[valid][:, None] * d[ray]
    simplex = tri.find_simplex(samples)
    hit = simplex >= 0
    # one vote per (ray, tetrahedron)
    pairs = np.unique(np.stack([ray[hit], simplex[hit]], axis=1), axis=0)
    votes = np.bincount(pairs[:, 1], minlength=tri.nsimplex)
    carved = votes >= min_votes
    # fraction of each point's incident tetrahedra that are carved
    inc = np.zeros(len(p))
    cnt = np.zeros(len(p))
    np.add.at(inc, tri.simplices.ravel(), np.repeat(carved, 4).astype(float))
    np.add.at(cnt, tri.simplices.ravel(), 1.0)
    frac = np.divide(inc, cnt, out=np.zeros_like(inc), where=cnt > 0)
    return frac < carve_fraction


def voxel_downsample(points, n_target: int) -> np.ndarray:
    """Centroids of occupied voxels, voxel size chosen by bisection so that about ``n_target`` remain."""
    p = np.asarray(points, dtype=float)
    if len(p) <= n_target:
        return p.copy()

    def cells(size):
        ijk = np.floor((p - p.min(axis=0)) / size).astype(np.int64)
        dims = ijk.max(axis=0) + 1
        keys = (ijk[:, 0] * dims[1] + ijk[:, 1]) * dims[2] + ijk[:, 2]  # one integer per voxel
        _, inv, counts = np.unique(keys, return_inverse=True, return_counts=True)
        return inv.reshape(-1), counts

    lo, hi = 1e-4 * float(np.ptp(p, axis=0).max()), float(np.ptp(p, axis=0).max())
    for _ in range(40):
        mid = np.sqrt(lo * hi)
        if len(cells(mid)[1]) > n_target:
            lo = mid
        else:
            hi = mid
    inv, counts = cells(hi)
    out = np.zeros((len(counts), 3))
    np.add.at(out, inv, p)
    return out / counts[:, None]


def principal_axes(points, central_fraction: float = 0.75) -> tuple[np.ndarray, np.ndarray]:
    """``(centre, C_PM)``: PCA on the ``central_fraction`` of points closest to the centroid.

    Rows of ``C_PM`` are the principal directions by decreasing variance; the
    third is the cross product of the first two (right-handed); the signs of
    the first two point towards the larger third moment (the heavier side), a
    deterministic choice the caller may override.
    """
    p = np.asarray(points, dtype=float)
    c = p.mean(axis=0)
    r = np.linalg.norm(p - c, axis=1)
    central = p[r <= np.quantile(r, central_fraction)]
    c = central.mean(axis=0)
    w, V = np.linalg.eigh(np.cov((central - c).T))
    axes = V[:, ::-1].T
    for i in range(2):
        if np.sum(((p - c) @ axes[i]) ** 3) < 0:
            axes[i] = -axes[i]
    axes[2] = np.cross(axes[0], axes[1])
    return c, axes


def build_coarse_model(
    points_M,
    origins_M,
    *,
    n_target: int = 3000,
    knn_k: int = 8,
    knn_sigma: float = 2.0,
    carve: bool = True,
    central_fraction: float = 0.75,
    rng: np.random.Generator | None = None,
    **carve_kwargs,
) -> CoarseModel:
    """The preliminary phase's model from an accumulated map cloud (module docstring, steps 1–4)."""
    p = np.asarray(points_M, dtype=float)
    o = np.asarray(origins_M, dtype=float)
    if p.ndim != 2 or p.shape[1] != 3 or o.shape != p.shape:
        raise ValueError(f"points_M and origins_M must be matching (N, 3) arrays, got {p.shape}, {o.shape}")
    if len(p) < 20:
        raise ValueError(f"a coarse model needs at least 20 points, got {len(p)}")
    keep = knn_outlier_mask(p, knn_k, knn_sigma)
    p1, o1 = p[keep], o[keep]
    p2 = p1[carve_mask(p1, o1, rng=rng, **carve_kwargs)] if carve else p1
    p3 = voxel_downsample(p2, n_target)
    c, C_PM = principal_axes(p3, central_fraction)
    return CoarseModel((p3 - c) @ C_PM.T, C_PM, c, len(p), len(p1), len(p2))


def axis_errors_deg(C_PM, C_TM) -> np.ndarray:
    """Angle (deg) between each estimated axis and its true counterpart, up to sign and order.

    ``C_PM``, ``C_TM``: rows are the estimated and true axes in the same frame M;
    the pairing that minimises the largest angle is used.
    """
    cos = np.abs(np.asarray(C_PM, dtype=float) @ np.asarray(C_TM, dtype=float).T)
    best = None
    for perm in permutations(range(3)):
        ang = np.rad2deg(np.arccos(np.clip(cos[np.arange(3), list(perm)], -1.0, 1.0)))
        if best is None or ang.max() < best.max():
            best = ang
    return best


def mesh_surface_points(target, n: int, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """``n`` points uniform over a target's mesh surface and their outward face normals, in T.

    The ideal coarse model (what a perfect preliminary phase would give) and
    a source of synthetic measurements; ``target`` is a
    :class:`lightcurves.targets.Target`.
    """
    if n < 1:
        raise ValueError(f"n must be >= 1, got {n}")
    tris = np.concatenate([p.vertices_T[p.faces] for p in target.parts])
    cross = np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0])
    area = 0.5 * np.linalg.norm(cross, axis=1)
    idx = rng.choice(len(tris), size=n, p=area / area.sum())
    a, b = rng.random((2, n))
    flip = a + b > 1.0
    a[flip], b[flip] = 1.0 - a[flip], 1.0 - b[flip]
    T = tris[idx]
    points = T[:, 0] + a[:, None] * (T[:, 1] - T[:, 0]) + b[:, None] * (T[:, 2] - T[:, 0])
    return points, cross[idx] / (2.0 * area[idx, None])
