"""Known-shape facet forward model: the brightness of a target mesh thousands of times faster than Mitsuba.

:class:`KnownShapeModel` turns a :class:`~lightcurves.targets.Target` into facets (area ``A_f``,
outward geometric normal ``n_f``, shading normal ``m_f``, centroid, material) and evaluates the
radiant intensity toward the observer, with the same meaning and unit as
:meth:`lightcurves.render.UnresolvedRenderer.intensity` (W/sr under ``E = 1361 W/m²`` sunlight)::

    I(s, o) = E Σ_f A_f (n_f·o)₊ f_r(m_f; s, o) (m_f·s)₊ vis_f(s, o)                       (1)

with ``s``, ``o`` the unit directions from the target to the Sun and to the observer in T. This is
the single-scattering integral Mitsuba's ``direct`` integrator estimates with a directional Sun and
an orthographic sensor: a pixel sees the projected area ``A (n·o)`` (geometric normal) and the
BSDF is evaluated, with its Sun cosine, in the shading frame (``m_f`` = the interpolated vertex
normal of smooth parts, ``n_f`` for flat ones). For the smooth 20 480-facet sphere, the
interpolated normal at the centroid and the flat normal give the same intensity to 3e-4 of
I(α) up to α = 170°, both converging as edge² to the Lambert law, so one sample per facet
suffices. ``vis_f(s, o)`` is the fraction of the facet lit by the Sun *and* seen by the
observer (self-shadowing and self-occlusion).

The BRDF is :func:`lightcurves.scene.cook_torrance_brdf`, ``f_r = d/π + s F D G₁(i) G₁(o)/(4 cos θ_i
cos θ_o)``, rearranged so that both cosines cancel in the specular term (no 0/0 at grazing):
``f_r (m·s) = d/π (m·s) + s F(s·h) D(m·h) G₁(m·s) G₁(m·o) / (4 (m·o))``. The Fresnel factor
depends on ``s·h`` only, so it is computed once per sample and material. ``G₁`` is Walter et
al.'s rational approximation of Beckmann–Smith masking (EGSR 2007, eq. 27) — what Mitsuba 3's
``roughconductor`` evaluates, measured here to agree with Mitsuba's ``bsdf.eval`` to 3e-6
(the exact Smith form of ``cook_torrance_brdf`` differs from it by up to 0.6 % at grazing).

Self-shadowing: each facet is covered by ``16`` sample points (the centroids of its
two-fold midpoint subdivision); from each point a ray is cast once per model, with Mitsuba's
``Scene.ray_test``, toward each of ``n_directions`` Fibonacci-sphere directions in the facet's
front hemisphere. The table stores one 16-bit mask per (facet, direction): the points that see
that direction. At run time the Sun and the observer directions are each located in the
spherical Delaunay triangle of table directions that holds them (barycentric weights ``w``), and
``vis_f = Σ_ab w_a(s) w_b(o) popcount(mask_a & mask_b) / 16`` — the fraction of points both lit
and seen, so a shadow and an occlusion of the same corner are not counted twice. Barycentric
interpolation instead of the nearest direction cut the box-wing error against a 256-px Mitsuba
reference from 1.2 to 0.3 % rms (2048 directions) and vespa's from 2.4 to 0.4 % (1024). Only
facets that another part of the mesh can hide (some vertex above the facet's plane) carry a
table; the others (every facet of a convex body) are always visible in their front hemisphere.

Large triangles are first bisected along their longest edge until no edge exceeds
``max_edge_m`` so that shadow boundaries are resolved (box-wing panels are metres long).
:meth:`KnownShapeModel.coarse` merges facets by part, material and normal for a cheap search
model. The sum runs over blocks of facets with similar normals; a block whose normal cone
faces away from the Sun or the observer is skipped whole. Within a block, facets with the same
normals and material (the bisected triangles of one face, a lathe band's segments) share one
evaluation of the BRDF, and only their visible fractions are summed one by one: the same sum,
re-associated (vespa: 7680 facets, 196 distinct; see ``benchmarks/bench_inversion_forward.py``).

References: Kaasalainen & Torppa, Icarus 153 (2001) §2 (the facet brightness sum); Cook &
Torrance, ACM TOG 1 (1982); Walter, Marschner, Li & Torrance, EGSR 2007.
"""

from __future__ import annotations

import functools
import threading
from dataclasses import dataclass, field, replace

import numba
import numpy as np
from scipy.spatial import ConvexHull, cKDTree

from lightcurves import scene as S
from lightcurves.targets import Material, Target

__all__ = ["KnownShapeModel", "KnownShapeError", "fibonacci_sphere"]

_SUB_LEVEL_POINTS = 16  # sample points per facet for the shadow table (one bit each of a uint16)
_HORIZON_LIFT = 1e-3  # rad: directions at or below a facet's horizon are traced this far above it
_D_CUTOFF = 60.0  # exp(-60) ≈ 1e-26: the Beckmann lobe is zero beyond
# cos θ (s·h) nodes of each material's Fresnel table, read linearly: F is smooth in cos θ, so the error is ≤ Δ²/8 max|F''|
# (measured ≤ 3e-7 absolute for the targets' materials, at grazing); the complex square roots per sample took 15 % of a known-shape inversion
_FRESNEL_COS = np.linspace(0.0, 1.0, 4097)


class KnownShapeError(ValueError):
    """Bad input to the known-shape model (names the field and the expected form)."""


def fibonacci_sphere(n: int) -> np.ndarray:
    """``n`` nearly uniform unit vectors (n, 3) on the sphere: the Fibonacci lattice (González 2010, Math. Geosci. 42)."""
    if int(n) < 1:
        raise KnownShapeError(f"n_directions: {n}: expected an integer >= 1")
    k = np.arange(int(n)) + 0.5
    z = 1.0 - 2.0 * k / n
    phi = np.pi * (3.0 - np.sqrt(5.0)) * k
    r = np.sqrt(1.0 - z * z)
    return np.stack([r * np.cos(phi), r * np.sin(phi), z], 1)


#: Polar-angle rows and azimuth columns of the cell grid of :func:`_cell_candidates` (cells ≤ 0.7° × 0.7°).
_CELL_ROWS, _CELL_COLS = 256, 512


@functools.lru_cache(maxsize=8)
def _cell_candidates(directions_bytes: bytes) -> tuple[np.ndarray, np.ndarray]:
    """For each cell of a (polar angle × azimuth) grid, the directions that can be the nearest one to a unit query in it, as
    (offsets (n_cells + 1,), indices): every direction within ``d_c + 2 r`` of the cell's centre c, with d_c the distance from
    c to its nearest direction and r the cell's radius (its farthest corner). Exact: for q in the cell, the nearest direction
    v* has |q − v*| ≤ |q − v_c| ≤ r + d_c, so |c − v*| ≤ 2 r + d_c (chords; the triangle inequality).

    Cached by the directions' bytes: a model and its :meth:`KnownShapeModel.coarse` copies share one table (0.3 s to build).
    """
    directions = np.frombuffer(directions_bytes).reshape(-1, 3)
    theta = np.linspace(0.0, np.pi, _CELL_ROWS + 1)
    phi = np.linspace(-np.pi, np.pi, _CELL_COLS + 1)

    def unit(t, p):
        return np.stack([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)], -1)

    tc, pc = np.meshgrid(0.5 * (theta[1:] + theta[:-1]), 0.5 * (phi[1:] + phi[:-1]), indexing="ij")
    centre = unit(tc, pc).reshape(-1, 3)
    radius = np.zeros(len(centre))
    for dt in (0, 1):
        for dp in (0, 1):
            corner = unit(*np.meshgrid(theta[dt:_CELL_ROWS + dt], phi[dp:_CELL_COLS + dp], indexing="ij")).reshape(-1, 3)
            radius = np.maximum(radius, np.linalg.norm(corner - centre, axis=1))
    tree = cKDTree(directions)
    d_c = tree.query(centre)[0]
    lists = tree.query_ball_point(centre, d_c + 2.0 * radius * (1.0 + 1e-9) + 1e-12)
    offsets = np.concatenate([[0], np.cumsum([len(c) for c in lists])]).astype(np.int64)
    return offsets, np.concatenate(lists).astype(np.int64)


@numba.njit(cache=True)
def _nearest_one(qx, qy, qz, directions, offsets, indices, n_rows, n_cols):  # pragma: no cover - compiled
    """Index of the nearest of ``directions`` to the unit query (qx, qy, qz): the largest dot product among its cell's
    candidates (:func:`_cell_candidates`)."""
    z = min(max(qz, -1.0), 1.0)
    row = min(int(np.arccos(z) * n_rows / np.pi), n_rows - 1)
    col = min(int((np.arctan2(qy, qx) + np.pi) * n_cols / (2.0 * np.pi)), n_cols - 1)
    cell = row * n_cols + col
    best, best_dot = -1, -np.inf
    for j in range(offsets[cell], offsets[cell + 1]):
        v = indices[j]
        d = directions[v, 0] * qx + directions[v, 1] * qy + directions[v, 2] * qz
        if d > best_dot:
            best, best_dot = v, d
    return best


@numba.njit(cache=True)
def _nearest_directions(q, directions, offsets, indices, n_rows, n_cols, out):  # pragma: no cover - compiled
    for i in range(q.shape[0]):
        out[i] = _nearest_one(q[i, 0], q[i, 1], q[i, 2], directions, offsets, indices, n_rows, n_cols)


class _SphereInterpolator:
    """Barycentric interpolation over a triangulated set of unit directions (the spherical Delaunay triangulation).

    The convex hull of points on the unit sphere is their spherical Delaunay triangulation
    (Brown 1979, IPL 9). A query ``q`` is located by a walk from the previous query's triangle, or among the triangles
    around its nearest direction (:func:`_locate`); its weights are the barycentric coordinates of the central projection
    of ``q`` onto that triangle's plane (``b = M⁻¹ q / Σ``), all ≥ 0 (clipped at 0 should a walk not end).
    """

    def __init__(self, directions: np.ndarray):
        self.directions = np.ascontiguousarray(directions, dtype=float)
        self.cells = _cell_candidates(self.directions.tobytes())
        hull = ConvexHull(directions)
        tri = hull.simplices  # (T, 3)
        self.tri = tri
        self.neighbours = np.ascontiguousarray(hull.neighbors, dtype=np.int64)  # [t, r]: the triangle across the edge opposite corner r
        self.inv = np.linalg.inv(directions[tri].transpose(0, 2, 1))  # columns = corners: b = inv @ q
        order = np.argsort(tri.ravel(), kind="stable")
        owner = order // 3
        counts = np.bincount(tri.ravel(), minlength=len(directions))
        self.around = np.full((len(directions), counts.max()), -1, np.int64)
        start = np.concatenate([[0], np.cumsum(counts)[:-1]])
        vertex = tri.ravel()[order]
        self.around[vertex, np.arange(len(order)) - start[vertex]] = owner

    def nearest(self, q: np.ndarray) -> np.ndarray:
        """Index (N,) of the nearest direction to each unit query ``q`` (N, 3)."""
        out = np.empty(len(q), np.int64)
        _nearest_directions(np.ascontiguousarray(q, dtype=float), self.directions, *self.cells, _CELL_ROWS, _CELL_COLS, out)
        return out

    def __call__(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Indices (N, 3) of the corner directions, weights (N, 3) summing to 1, and the weights' gradients (N, 3, 3) with
        respect to a small rotation ρ of the queries (q → q + ρ × q), for unit queries ``q`` (N, 3)."""
        idx, w, dw = np.empty((len(q), 3), np.int64), np.empty((len(q), 3)), np.empty((len(q), 3, 3))
        kernel = _locate_parallel if _on_all_cores(len(q), _PARALLEL_QUERIES) else _locate_serial
        kernel(np.ascontiguousarray(q, dtype=float), self.directions, *self.cells, _CELL_ROWS, _CELL_COLS, self.around, self.inv, self.tri,
               self.neighbours, idx, w, dw)
        return idx, w, dw


@numba.njit(cache=True, inline="always")
def _barycentric(inv, c, qx, qy, qz):  # pragma: no cover - compiled
    """Unnormalised barycentric coordinates (b₀, b₁, b₂) = inv_c q of a query in triangle ``c``'s cone."""
    return (inv[c, 0, 0] * qx + inv[c, 0, 1] * qy + inv[c, 0, 2] * qz, inv[c, 1, 0] * qx + inv[c, 1, 1] * qy + inv[c, 1, 2] * qz,
            inv[c, 2, 0] * qx + inv[c, 2, 1] * qy + inv[c, 2, 2] * qz)


@numba.njit(cache=True, inline="always")
def _walk(inv, neighbours, cur, qx, qy, qz):  # pragma: no cover - compiled
    """The triangle whose cone holds the query, walked to from triangle ``cur`` (:func:`_locate`), or -1 after
    :data:`_WALK_STEPS` steps."""
    for _ in range(_WALK_STEPS):
        b0, b1, b2 = _barycentric(inv, cur, qx, qy, qz)
        if b0 >= 0.0 and b1 >= 0.0 and b2 >= 0.0:
            return cur
        cur = neighbours[cur, 0] if b0 <= b1 and b0 <= b2 else (neighbours[cur, 1] if b1 <= b2 else neighbours[cur, 2])
    return -1


@numba.njit(cache=True, inline="always")
def _around_nearest(inv, candidates, qx, qy, qz):  # pragma: no cover - compiled
    """Of the triangles ``candidates`` around the query's nearest direction (-1 padded), the one with the largest smallest
    barycentric coordinate."""
    best, best_score = -1, -np.inf
    for c in candidates:
        if c < 0:
            continue
        b0, b1, b2 = _barycentric(inv, c, qx, qy, qz)
        score = min(b0, b1, b2) / (b0 + b1 + b2)
        if score > best_score:
            best, best_score = c, score
    return best


#: queries per run of :func:`_locate`'s walk (each run starts from a cell lookup; the runs are shared among the cores)
_WALK_RUN = 256
#: steps after which a walk gives up and the query is located by its nearest direction
_WALK_STEPS = 8


def _locate(q, directions, offsets, indices, n_rows, n_cols, around, inv, tri, neighbours, idx, w, dw):  # pragma: no cover - compiled
    """For each query: the triangle whose cone holds it, its clipped weights, and their gradients ``dw[i, r]`` with respect to a
    rotation ρ of the query: b_r = inv_r·q moves by inv_r·(ρ × q) = ρ·(q × inv_r) (0 where b_r is clipped), and
    w_r = b_r / Σb by (∇b_r − w_r Σ∇b) / Σb.

    The triangle is found by a walk from the previous query's (consecutive queries are a curve's consecutive samples, a few
    degrees apart at most): while some b_r < 0, step to the neighbour across the edge opposite corner r, the most negative
    first (a visibility walk, which terminates on a Delaunay triangulation: Devillers, Pion & Teillaud, IJFCS 13, 2002). A
    run of :data:`_WALK_RUN` queries starts, and a walk longer than :data:`_WALK_STEPS` restarts, at the candidate triangle
    around the query's nearest direction (:func:`_nearest_one`) with the largest smallest barycentric coordinate, and walks
    from there (the nearest vertex of a Delaunay triangulation need not belong to the containing triangle: before
    2026-12-01 that candidate was kept, its weights clipped at 0), so the triangle found does not depend on the queries'
    order. The walk replaced the nearest-direction look-up for most queries (~100 ns each with its arccos and arctan2: 45 %
    of a box-wing inversion's CPU, in the screen's shadow-table reads).

    Numba (compiled twice below, serial and parallel over the runs); the numpy form (an (N, deg, 3, 3) gather and einsum)
    took 30 ms for 1800 queries.
    """
    n_runs = (q.shape[0] + _WALK_RUN - 1) // _WALK_RUN
    for run in numba.prange(n_runs):
        cur = -1
        for i in range(run * _WALK_RUN, min((run + 1) * _WALK_RUN, q.shape[0])):
            qx, qy, qz = q[i, 0], q[i, 1], q[i, 2]
            best = _walk(inv, neighbours, cur, qx, qy, qz) if cur >= 0 else -1
            if best < 0:
                near = _around_nearest(inv, around[_nearest_one(qx, qy, qz, directions, offsets, indices, n_rows, n_cols)], qx, qy, qz)
                best = _walk(inv, neighbours, near, qx, qy, qz)
                best = near if best < 0 else best
            cur = best
            total, g0, g1, g2 = 0.0, 0.0, 0.0, 0.0
            for r in range(3):
                raw = inv[best, r, 0] * qx + inv[best, r, 1] * qy + inv[best, r, 2] * qz
                w[i, r] = max(raw, 0.0)  # b_r until normalised below
                total += w[i, r]
                d0, d1, d2 = 0.0, 0.0, 0.0
                if raw > 0.0:  # q × inv_r
                    d0 = qy * inv[best, r, 2] - qz * inv[best, r, 1]
                    d1 = qz * inv[best, r, 0] - qx * inv[best, r, 2]
                    d2 = qx * inv[best, r, 1] - qy * inv[best, r, 0]
                dw[i, r, 0], dw[i, r, 1], dw[i, r, 2] = d0, d1, d2
                g0, g1, g2 = g0 + d0, g1 + d1, g2 + d2
            for r in range(3):
                idx[i, r] = tri[best, r]
                w[i, r] /= total
                dw[i, r, 0] = (dw[i, r, 0] - w[i, r] * g0) / total
                dw[i, r, 1] = (dw[i, r, 1] - w[i, r] * g1) / total
                dw[i, r, 2] = (dw[i, r, 2] - w[i, r] * g2) / total


_locate_serial = numba.njit(cache=True, nogil=True)(_locate)
_locate_parallel = numba.njit(cache=True, parallel=True)(_locate)
_PARALLEL_QUERIES = 8192  #: batches at least this large are located on all cores


def _on_all_cores(n: int, threshold: int) -> bool:
    """Whether a batch of ``n`` runs the parallel kernel: large enough, and called from the main thread. Called from another
    thread (:func:`lightcurves.inversion.search.invert` fits several starts at once), the serial kernel releases the GIL
    (``nogil``) and runs beside the others; numba's parallel kernels are not to be launched from several threads at once."""
    return n >= threshold and threading.current_thread() is threading.main_thread()


# ---------------------------------------------------------------- facets


def _bisect_long_edges(V: np.ndarray, N: np.ndarray, max_edge: float) -> tuple[np.ndarray, np.ndarray]:
    """Split triangles (T, 3, 3) along their longest edge until every edge is <= ``max_edge``.

    ``N`` (T, 3, 3) are the per-corner shading normals, interpolated linearly at each new corner
    (barycentric interpolation, as a renderer does), not normalised.
    """
    done_V, done_N = [], []
    while len(V):
        e = np.stack([np.linalg.norm(V[:, (i + 1) % 3] - V[:, i], axis=1) for i in range(3)], 1)
        long = e.max(axis=1) > max_edge
        done_V.append(V[~long])
        done_N.append(N[~long])
        V, N, e = V[long], N[long], e[long]
        if not len(V):
            break
        i = e.argmax(axis=1)
        j, k = (i + 1) % 3, (i + 2) % 3
        r = np.arange(len(V))
        mV = 0.5 * (V[r, i] + V[r, j])
        mN = 0.5 * (N[r, i] + N[r, j])
        a = np.stack([V[r, i], mV, V[r, k]], 1), np.stack([mV, V[r, j], V[r, k]], 1)
        b = np.stack([N[r, i], mN, N[r, k]], 1), np.stack([mN, N[r, j], N[r, k]], 1)
        V, N = np.concatenate(a), np.concatenate(b)
    return np.concatenate(done_V), np.concatenate(done_N)


def _sub_barycentrics() -> np.ndarray:
    """Barycentric coordinates (16, 3) of the centroids of a triangle's two-fold midpoint subdivision (equal areas)."""
    out = []
    for i in range(4):
        for j in range(4 - i):
            out.append([(i + 1 / 3), (j + 1 / 3), 4 - i - j - 2 / 3])  # upward sub-triangles
            if i + j < 3:
                out.append([(i + 2 / 3), (j + 2 / 3), 4 - i - j - 4 / 3])  # downward ones
    b = np.array(out) / 4.0
    assert b.shape == (_SUB_LEVEL_POINTS, 3)
    return b


def _facets(target: Target, max_edge: float | None):
    """Per-facet arrays of all parts: area, geometric normal, shading normal, centroid, corners, material, part, occludable.

    With ``max_edge`` (m), the occludable triangles (:func:`_occludable`) are bisected down to it;
    the others are never shadowed and keep their size.
    """
    cols: dict[str, list] = {k: [] for k in ("area", "n", "m", "c", "corners", "mat", "part", "hidden")}
    materials: list[Material] = []
    all_v = np.concatenate([p.vertices_T for p in target.parts])
    tol = 1e-6 * target.radius_m
    for ip, p in enumerate(target.parts):
        V = np.asarray(p.vertices_T, dtype=float)[np.asarray(p.faces)]
        N = (np.asarray(p.normals_T, dtype=float)[np.asarray(p.faces)] if p.normals_T is not None else None)
        cross = np.cross(V[:, 1] - V[:, 0], V[:, 2] - V[:, 0])
        keep = np.linalg.norm(cross, axis=1) > 1e-12
        V = V[keep]
        n_g = cross[keep] / np.linalg.norm(cross[keep], axis=1, keepdims=True)
        N = np.repeat(n_g[:, None], 3, 1) if N is None else N[keep]
        hidden = _occludable(n_g, V, all_v, tol) if max_edge is not None else np.zeros(len(V), bool)
        if hidden.any():
            Vh, Nh = _bisect_long_edges(V[hidden], N[hidden], max_edge)
            V, N = np.concatenate([V[~hidden], Vh]), np.concatenate([N[~hidden], Nh])
            hidden = np.arange(len(V)) >= int((~hidden).sum())
        cross = np.cross(V[:, 1] - V[:, 0], V[:, 2] - V[:, 0])
        twice_area = np.linalg.norm(cross, axis=1)
        m = N.mean(axis=1)  # the interpolated shading normal at the centroid
        m /= np.linalg.norm(m, axis=1, keepdims=True)
        if p.material not in materials:
            materials.append(p.material)
        cols["area"].append(0.5 * twice_area)
        cols["n"].append(cross / twice_area[:, None])
        cols["m"].append(m)
        cols["c"].append(V.mean(axis=1))
        cols["corners"].append(V)
        cols["mat"].append(np.full(len(V), materials.index(p.material)))
        cols["part"].append(np.full(len(V), ip))
        cols["hidden"].append(hidden)
    return {k: np.concatenate(v) for k, v in cols.items()}, tuple(materials)


@numba.njit(cache=True)
def _occludable(normal, corners, all_vertices, tol):  # pragma: no cover - compiled
    """Facets (bool (F,)) that some vertex of the mesh lies above (by > ``tol`` m): only these can be shadowed.

    A loop with an early exit (numba): a convex body costs one full pass, F × V dot products;
    the BLAS product it replaces ran 13 s for the 20 480-facet sphere on the shared machine.
    """
    out = np.zeros(normal.shape[0], np.bool_)
    for f in range(normal.shape[0]):
        nx, ny, nz = normal[f, 0], normal[f, 1], normal[f, 2]
        offset = nx * corners[f, 0, 0] + ny * corners[f, 0, 1] + nz * corners[f, 0, 2] + tol
        for v in range(all_vertices.shape[0]):
            if nx * all_vertices[v, 0] + ny * all_vertices[v, 1] + nz * all_vertices[v, 2] > offset:
                out[f] = True
                break
    return out


def _shadow_masks(target: Target, normal, corners, directions, eps: float, variant: str | None) -> np.ndarray:
    """uint16 masks (F, K): bit b set when sub-point b of facet f sees direction k (Mitsuba ``ray_test``).

    Directions in the front hemisphere are traced as they are. So that the barycentric
    interpolation near the horizon does not mix in unlit corners, directions up to two table
    spacings below the horizon get the visibility of their projection onto the horizon, lifted by
    ``_HORIZON_LIFT`` rad (a grazing Sun on the box-wing's wing back lost 80 % of its light without).
    """
    import mitsuba as mi

    S.select_variant(variant)
    if not mi.variant().startswith("llvm"):
        raise KnownShapeError(f"variant: {mi.variant()}: expected an LLVM variant (vectorised ray casting) for the shadow table; "
                              "install libLLVM >= 16 or build the model with shadows=False")
    scene = mi.load_dict(S.scene_dict(target, [0.0, 0.0, 1.0]))
    bary = _sub_barycentrics()
    points = np.einsum("bi,fik->fbk", bary, corners) + eps * normal[:, None, :]  # (F, 16, 3)
    cos_d = normal @ directions.T  # (F, K)
    band = 2.0 * np.sqrt(4.0 * np.pi / len(directions))
    masks = np.zeros(cos_d.shape, np.uint16)
    fi, ki = np.nonzero(cos_d > -band)
    chunk = max(1, 2_000_000 // _SUB_LEVEL_POINTS)
    for lo in range(0, len(fi), chunk):
        f, k = fi[lo:lo + chunk], ki[lo:lo + chunk]
        o = points[f].reshape(-1, 3).astype(np.float32)
        d = directions[k] + np.maximum(_HORIZON_LIFT - cos_d[f, k], 0.0)[:, None] * normal[f]
        d = np.repeat(d / np.linalg.norm(d, axis=1, keepdims=True), _SUB_LEVEL_POINTS, axis=0).astype(np.float32)
        ray = mi.Ray3f(mi.Point3f(*(mi.Float(o[:, i]) for i in range(3))), mi.Vector3f(*(mi.Float(d[:, i]) for i in range(3))))
        free = ~np.asarray(scene.ray_test(ray), dtype=bool).reshape(-1, _SUB_LEVEL_POINTS)
        masks[f, k] = (free.astype(np.uint16) << np.arange(_SUB_LEVEL_POINTS, dtype=np.uint16)).sum(axis=1, dtype=np.uint16)
    return masks


def _split_spatially(labels: np.ndarray, area: np.ndarray, centroid: np.ndarray, max_clusters: int) -> np.ndarray:
    """Split clusters until there are ``max_clusters``: always the largest-area one, at its area median along its widest axis.

    Deterministic; a cluster of one facet is never split. Returns new labels 0..C-1.
    """
    labels = labels.copy()
    n = int(labels.max()) + 1
    totals = np.bincount(labels, area, n)
    counts = np.bincount(labels, minlength=n)
    while n < max_clusters:
        splittable = np.nonzero(counts > 1)[0]
        if not len(splittable):
            break
        c = splittable[np.argmax(totals[splittable])]
        members = np.nonzero(labels == c)[0]
        x = centroid[members]
        coord = x[:, np.argmax(np.ptp(x, axis=0))]
        order = np.argsort(coord, kind="stable")
        cum = np.cumsum(area[members[order]])
        cut = int(np.clip(np.searchsorted(cum, 0.5 * cum[-1]) + 1, 1, len(members) - 1))
        moved = members[order[cut:]]
        labels[moved] = n
        totals = np.append(totals, area[moved].sum())
        totals[c] -= totals[-1]
        counts = np.append(counts, len(moved))
        counts[c] -= len(moved)
        n += 1
    return labels


# ---------------------------------------------------------------- the kernel

_POPCOUNT16 = np.array([bin(i).count("1") for i in range(1 << 16)], dtype=np.uint8)


@numba.njit(cache=True, fastmath=True, inline="always")
def _table_sums(masks, popcount, r, ks, ws, ko, wo):  # pragma: no cover - compiled
    """The shadow-table sums of facet row ``r``: ``R_a = Σ_b w_b(o) c_ab`` and ``C_b = Σ_a w_a(s) c_ab`` (a, b = 0, 1, 2), with
    ``c_ab = popcount(mask_a(s) & mask_b(o))`` the facet's points that see both table directions (module docstring).

    ``vis_f = Σ_a w_a(s) R_a / 16``, and its gradient under a rotation of both directions is
    ``Σ_ab (∇w_a(s) w_b(o) + w_a(s) ∇w_b(o)) c_ab / 16 = (Σ_a ∇w_a(s) R_a + Σ_b ∇w_b(o) C_b) / 16``: both are linear in (R, C), so
    a group of facets sums ``A_f R`` and ``A_f C`` and applies the weights once (:func:`_intensity_sum`; per facet 18 products
    instead of the 117 of the weights applied pair by pair)."""
    m0, m1, m2 = masks[ks[0], r], masks[ks[1], r], masks[ks[2], r]
    n0, n1, n2 = masks[ko[0], r], masks[ko[1], r], masks[ko[2], r]
    if m0 & m1 & m2 & n0 & n1 & n2 == 0xFFFF:  # every point sees all six directions (most lit facets): c_ab = 16, Σ w = 1
        return 16.0, 16.0, 16.0, 16.0, 16.0, 16.0
    if (m0 | m1 | m2) == 0 or (n0 | n1 | n2) == 0:  # in shadow, or hidden, from all three
        return 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    c00, c01, c02 = popcount[m0 & n0], popcount[m0 & n1], popcount[m0 & n2]
    c10, c11, c12 = popcount[m1 & n0], popcount[m1 & n1], popcount[m1 & n2]
    c20, c21, c22 = popcount[m2 & n0], popcount[m2 & n1], popcount[m2 & n2]
    return (wo[0] * c00 + wo[1] * c01 + wo[2] * c02, wo[0] * c10 + wo[1] * c11 + wo[2] * c12, wo[0] * c20 + wo[1] * c21 + wo[2] * c22,
            ws[0] * c00 + ws[1] * c10 + ws[2] * c20, ws[0] * c01 + ws[1] * c11 + ws[2] * c21, ws[0] * c02 + ws[1] * c12 + ws[2] * c22)


@numba.njit(cache=True, fastmath=True, inline="always")
def _g1_walter(c, inv_alpha):  # pragma: no cover - compiled
    """Beckmann–Smith ``G₁(cos θ)`` in Walter et al.'s rational form (EGSR 2007, eq. 27), as Mitsuba 3 evaluates it, and
    dG₁/d(cos θ) (a = cos θ / (α sin θ), da/dcos θ = 1 / (α sin³θ))."""
    s2 = 1.0 - c * c
    if s2 <= 0.0:
        return 1.0, 0.0
    a = c * inv_alpha / np.sqrt(s2)
    if a >= 1.6:
        return 1.0, 0.0
    num, den = 3.535 * a + 2.181 * a * a, 1.0 + 2.276 * a + 2.577 * a * a
    dg_da = ((3.535 + 4.362 * a) * den - num * (2.276 + 5.154 * a)) / (den * den)
    return num / den, dg_da * inv_alpha / (s2 * np.sqrt(s2))


@numba.njit(cache=True, fastmath=True, inline="always")
def _beckmann_lobe(ch, cs, co, inv_a2, d_norm, inv_alpha):  # pragma: no cover - compiled
    """``L = D(m·h) G₁(m·s) G₁(m·o) / (4 m·o)`` (1/sr), zero beyond ``exp(-60)`` of the peak, and its partial derivatives
    (∂L/∂(m·h), ∂L/∂(m·s), ∂L/∂(m·o)); ``D = exp(−(1/ch² − 1)/α²) / (π α² ch⁴)`` so ∂ln D/∂ch = 2/(α² ch³) − 4/ch."""
    if ch <= 0.0:
        return 0.0, 0.0, 0.0, 0.0
    ch2 = ch * ch
    x = (1.0 - ch2) / ch2 * inv_a2
    if x >= _D_CUTOFF:
        return 0.0, 0.0, 0.0, 0.0
    D = d_norm * np.exp(-x) / (ch2 * ch2)
    gs, dgs = _g1_walter(cs, inv_alpha)
    go, dgo = _g1_walter(co, inv_alpha)
    q = 0.25 / co
    lobe = D * gs * go * q
    return lobe, lobe * (2.0 * inv_a2 / (ch2 * ch) - 4.0 / ch), D * dgs * go * q, D * gs * (dgo * q - go * q / co)


def _intensity_sum(sun, obs, half, ks, ws, ko, wo, dws, dwo, starts, axis, sin_half, n, m, mat, members, area, vis_row, materials,
                   fresnel, masks, popcount, out, torque, grad):  # pragma: no cover - compiled
    """Eq. (1) for each sample, ``out[j] = Σ_f``, over blocks of facets with similar normals (compiled twice below: serial, and
    with the samples shared among the cores for large batches).

    A block whose normal cone (``axis``, half-angle θ) faces away from the Sun or the observer
    (``axis·s <= -sin θ``) is skipped whole: at moderate phase about three blocks in four.
    Block ``b`` holds the groups ``starts[b]:starts[b + 1]``; group ``g`` (normals ``n[g]``, ``m[g]``, material ``mat[g]``)
    the facets ``members[g]:members[g + 1]`` (``area``, ``vis_row``): its BRDF term is evaluated once and multiplied by
    Σ_f A_f vis_f. ``materials`` (Q, 5): d/π, s, 1/α², 1/(πα²), 1/α per material.

    With ``grad``, ``torque[j]`` (3,) is the gradient of ``out[j]`` with respect to a small rotation ρ of both directions in T
    (s → s + ρ × s, o → o + ρ × o; eq. 2 of :meth:`KnownShapeModel.intensity_gradient`): a dot product u·v of a fixed body
    vector u and a turned direction v moves by ρ·(v × u), so ∇(n·o) = o × n, ∇(m·s) = s × m, ∇(m·o) = o × m, ∇(m·h) = h × m, and
    s·h (the Fresnel factor's argument) does not move; the visible fraction moves with its table weights (:func:`_table_sums`).
    """
    for j in numba.prange(sun.shape[0]):
        sx, sy, sz = sun[j, 0], sun[j, 1], sun[j, 2]
        ox, oy, oz = obs[j, 0], obs[j, 1], obs[j, 2]
        hx, hy, hz = half[j, 0], half[j, 1], half[j, 2]
        acc, t0, t1, t2 = 0.0, 0.0, 0.0, 0.0
        for b in range(axis.shape[0]):
            if (axis[b, 0] * sx + axis[b, 1] * sy + axis[b, 2] * sz <= -sin_half[b]
                    or axis[b, 0] * ox + axis[b, 1] * oy + axis[b, 2] * oz <= -sin_half[b]):
                continue
            for g in range(starts[b], starts[b + 1]):
                nx, ny, nz, mx, my, mz = n[g, 0], n[g, 1], n[g, 2], m[g, 0], m[g, 1], m[g, 2]
                cg = nx * ox + ny * oy + nz * oz
                cs = mx * sx + my * sy + mz * sz
                co = mx * ox + my * oy + mz * oz
                if cg <= 0.0 or cs <= 0.0 or co <= 0.0:
                    continue
                # Σ_f A_f vis_f and its gradient over the group's facets, from Σ_f A_f (R, C) of the shadowed ones (:func:`_table_sums`)
                free, r0, r1, r2, c0, c1, c2 = 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
                for f in range(members[g], members[g + 1]):
                    if vis_row[f] >= 0:
                        a0, a1, a2, b0, b1, b2 = _table_sums(masks, popcount, vis_row[f], ks[j], ws[j], ko[j], wo[j])
                        r0, r1, r2 = r0 + area[f] * a0, r1 + area[f] * a1, r2 + area[f] * a2
                        c0, c1, c2 = c0 + area[f] * b0, c1 + area[f] * b1, c2 + area[f] * b2
                    else:
                        free += area[f]
                seen = free + (ws[j, 0] * r0 + ws[j, 1] * r1 + ws[j, 2] * r2) / 16.0
                s0, s1, s2 = 0.0, 0.0, 0.0
                if grad:
                    s0 = (dws[j, 0, 0] * r0 + dws[j, 1, 0] * r1 + dws[j, 2, 0] * r2 + dwo[j, 0, 0] * c0 + dwo[j, 1, 0] * c1 + dwo[j, 2, 0] * c2) / 16.0
                    s1 = (dws[j, 0, 1] * r0 + dws[j, 1, 1] * r1 + dws[j, 2, 1] * r2 + dwo[j, 0, 1] * c0 + dwo[j, 1, 1] * c1 + dwo[j, 2, 1] * c2) / 16.0
                    s2 = (dws[j, 0, 2] * r0 + dws[j, 1, 2] * r1 + dws[j, 2, 2] * r2 + dwo[j, 0, 2] * c0 + dwo[j, 1, 2] * c1 + dwo[j, 2, 2] * c2) / 16.0
                q = mat[g]
                term = materials[q, 0] * cs
                d_ch, d_cs, d_co = 0.0, materials[q, 0], 0.0
                if materials[q, 1] > 0.0:
                    ch = mx * hx + my * hy + mz * hz
                    lobe, l_ch, l_cs, l_co = _beckmann_lobe(ch, cs, co, materials[q, 2], materials[q, 3], materials[q, 4])
                    k = materials[q, 1] * fresnel[j, q]
                    term += k * lobe
                    d_ch, d_cs, d_co = k * l_ch, d_cs + k * l_cs, k * l_co
                acc += seen * cg * term
                if grad:  # ∇(Σ A vis · cg term), each ∇(u·v) = v × u
                    a_t, a_g, a_v = seen * term, seen * cg, cg * term
                    t0 += a_t * (oy * nz - oz * ny) + a_g * (d_cs * (sy * mz - sz * my) + d_co * (oy * mz - oz * my) + d_ch * (hy * mz - hz * my)) + a_v * s0
                    t1 += a_t * (oz * nx - ox * nz) + a_g * (d_cs * (sz * mx - sx * mz) + d_co * (oz * mx - ox * mz) + d_ch * (hz * mx - hx * mz)) + a_v * s1
                    t2 += a_t * (ox * ny - oy * nx) + a_g * (d_cs * (sx * my - sy * mx) + d_co * (ox * my - oy * mx) + d_ch * (hx * my - hy * mx)) + a_v * s2
        out[j] = acc
        if grad:
            torque[j, 0], torque[j, 1], torque[j, 2] = t0, t1, t2


# One core for the ~10⁴ calls per inversion on a few hundred samples (the fits), where OpenMP threads cost more than they save
# (measured 2.2× the CPU time of the serial kernel on a 3 × 600 inversion on the shared machine); the cores for the phase
# screen's tables (~10⁵ samples a call), where each sample's sum is the same serial loop (the same result to the bit).
_intensity_kernel = numba.njit(cache=True, fastmath=True, nogil=True)(_intensity_sum)
_intensity_kernel_parallel = numba.njit(cache=True, fastmath=True, parallel=True)(_intensity_sum)
_PARALLEL_SAMPLES = 8192  #: batches at least this large run on all cores


SAME_NORMAL = 1e-12  #: normals equal to this share one BRDF evaluation (:func:`_normal_blocks`)


def _normal_blocks(n: np.ndarray, m: np.ndarray, mat: np.ndarray) -> tuple[np.ndarray, ...]:
    """The facet layout of :func:`_intensity_kernel`: a facet order (F,), block starts into the groups (B+1,), cone axes (B, 3),
    sin of the cone half-angles (B,), and the groups' starts into the ordered facets (G+1,).

    Facets are binned by the nearest of ``F/24`` Fibonacci directions to their shading normal; a
    block is a bin. The cone holds both normals of every facet; half-angles above 90° never cull.
    Within a block, facets with the same material ``mat`` and normals ``n``, ``m`` equal to :data:`SAME_NORMAL` (a face's
    bisected triangles differ by ~1e-14 of rounding) are consecutive: a group, evaluated with its first facet's normals.
    """
    k = max(1, len(n) // 24)
    label = cKDTree(fibonacci_sphere(k)).query(m)[1]
    key = np.column_stack([label, mat, np.round(n / SAME_NORMAL), np.round(m / SAME_NORMAL)])
    _, group = np.unique(key, axis=0, return_inverse=True)  # np.unique sorts by label first: groups never straddle blocks
    group = group.reshape(-1)
    order = np.argsort(group, kind="stable")
    group, label = group[order], label[order]
    members = np.concatenate([[0], np.nonzero(np.diff(group))[0] + 1, [len(n)]]).astype(np.int64)
    glabel = label[members[:-1]]
    starts = np.concatenate([[0], np.nonzero(np.diff(glabel))[0] + 1, [len(glabel)]]).astype(np.int64)
    fstarts = members[starts]  # the blocks' starts in facets
    nn, mm = n[order], m[order]
    axis = np.add.reduceat(nn + mm, fstarts[:-1], axis=0)
    axis /= np.maximum(np.linalg.norm(axis, axis=1, keepdims=True), 1e-300)
    cos_min = np.minimum(np.minimum.reduceat(np.einsum("fk,fk->f", nn, np.repeat(axis, np.diff(fstarts), axis=0)), fstarts[:-1]),
                         np.minimum.reduceat(np.einsum("fk,fk->f", mm, np.repeat(axis, np.diff(fstarts), axis=0)), fstarts[:-1]))
    sin_half = np.where(cos_min > 0.0, np.sqrt(np.maximum(1.0 - cos_min**2, 0.0)) + 1e-9, 2.0)
    return order, starts, axis, sin_half, members


# ---------------------------------------------------------------- the model


def _directions(name: str, v) -> np.ndarray:
    a = np.atleast_2d(np.asarray(v, dtype=float))
    if a.ndim != 2 or a.shape[1] != 3:
        raise KnownShapeError(f"{name}: shape {np.shape(v)}: expected (N, 3) unit vectors in T")
    if not np.isfinite(a).all():
        raise KnownShapeError(f"{name}: non-finite values: expected finite unit vectors")
    norm = np.sqrt(np.einsum("ij,ij->i", a, a))
    if not np.all(np.abs(norm - 1.0) < 1e-6):
        raise KnownShapeError(f"{name}: norms from {norm.min():.6g} to {norm.max():.6g}: expected unit vectors")
    return np.ascontiguousarray(a)


@dataclass(frozen=True, eq=False)
class KnownShapeModel:
    """Facet model of a known target (eq. 1 of the module docstring); build it with :meth:`from_target`.

    Arrays are per facet (``F`` facets): ``area_m2`` (F,) m², ``normal_T`` (F, 3) outward
    geometric unit normals, ``shading_normal_T`` (F, 3) unit normals the BRDF is evaluated
    with, ``centroid_T`` (F, 3) m, ``material_index`` (F,) into ``materials``, ``part_index``
    (F,) into ``part_names``. The shadow table: ``directions_T`` (K, 3) unit, ``vis_row`` (F,)
    column of ``vis_masks`` or -1 (never hidden), ``vis_masks`` (K, R) uint16 (bit b: sample point
    b of the facet sees that direction; direction-major so one sample reads one row).
    """

    area_m2: np.ndarray
    normal_T: np.ndarray
    shading_normal_T: np.ndarray
    centroid_T: np.ndarray
    material_index: np.ndarray
    part_index: np.ndarray
    materials: tuple[Material, ...]
    part_names: tuple[str, ...]
    directions_T: np.ndarray
    vis_row: np.ndarray
    vis_masks: np.ndarray
    irradiance_w_m2: float = S.SUN_IRRADIANCE_W_M2
    _lookup: _SphereInterpolator | None = field(init=False, repr=False)
    _packed: tuple = field(init=False, repr=False)
    _packed_masks: np.ndarray = field(init=False, repr=False)
    _fresnel_table: np.ndarray = field(init=False, repr=False)

    def __post_init__(self):
        self._validate()
        lookup = _SphereInterpolator(self.directions_T) if len(self.directions_T) else None
        materials = np.array([[mt.diffuse_albedo / np.pi, mt.specular_albedo, mt.roughness**-2, 1.0 / (np.pi * mt.roughness**2),
                                1.0 / mt.roughness] for mt in self.materials])
        order, starts, axis, sin_half, members = _normal_blocks(self.normal_T, self.shading_normal_T, self.material_index)
        first = order[members[:-1]]  # a group's normals and material: those of its first facet
        # the shadow table's columns in the kernel's facet order, so that a group's facets read consecutive columns of each
        # direction's row (in the model's own order they lie ~128 columns apart, a cache line each: vespa's intensity took
        # 1.24 times as long on 450 samples, one core); the same values, summed in the same order
        rows = self.vis_row[order]
        shadowed = rows >= 0
        packed_rows = np.full(rows.shape, -1, np.int32)
        packed_rows[shadowed] = np.arange(int(shadowed.sum()), dtype=np.int32)
        masks = np.ascontiguousarray(self.vis_masks[:, rows[shadowed]]) if shadowed.any() else np.zeros((1, 1), np.uint16)
        packed = (starts, axis, sin_half, *(np.ascontiguousarray(a[first]) for a in (self.normal_T, self.shading_normal_T, self.material_index)),
                  members, np.ascontiguousarray(self.area_m2[order]), packed_rows, materials)
        object.__setattr__(self, "_lookup", lookup)
        object.__setattr__(self, "_packed", packed)
        object.__setattr__(self, "_packed_masks", masks)
        object.__setattr__(self, "_fresnel_table", np.stack([S._fresnel_conductor(_FRESNEL_COS, mt.eta, mt.k) for mt in self.materials]))

    def _validate(self) -> None:
        F = len(np.atleast_1d(self.area_m2))
        if not (F >= 1 and np.shape(self.area_m2) == (F,) and np.all(np.isfinite(self.area_m2)) and np.all(self.area_m2 >= 0)):
            raise KnownShapeError(f"area_m2: shape {np.shape(self.area_m2)}: expected (F,) finite areas >= 0 in m², F >= 1")
        for name in ("normal_T", "shading_normal_T", "centroid_T"):
            a = getattr(self, name)
            if np.shape(a) != (F, 3) or not np.all(np.isfinite(a)):
                raise KnownShapeError(f"{name}: shape {np.shape(a)}: expected ({F}, 3) finite values")
        for name in ("normal_T", "shading_normal_T"):
            norm = np.linalg.norm(getattr(self, name), axis=1)
            if not np.all(np.abs(norm - 1.0) < 1e-6):
                raise KnownShapeError(f"{name}: norms from {norm.min():.6g} to {norm.max():.6g}: expected unit vectors")
        index = np.asarray(self.material_index)
        if index.shape != (F,) or index.min() < 0 or index.max() >= len(self.materials):
            raise KnownShapeError(f"material_index: shape {index.shape}: expected ({F},) indices into the {len(self.materials)} materials")
        rows = np.asarray(self.vis_row)
        n_rows = self.vis_masks.shape[1] if self.vis_masks.ndim == 2 else 0
        if rows.shape != (F,) or rows.max() >= n_rows or (n_rows and self.vis_masks.shape[0] != len(self.directions_T)):
            raise KnownShapeError(f"vis_row: shape {rows.shape}, max {rows.max()}: expected ({F},) columns of vis_masks "
                                  f"(K = len(directions_T), {n_rows}) or -1")

    # ------------------------------------------------------------ construction

    @classmethod
    def from_target(cls, target: Target, *, max_edge_m: float | None = None, shadows: bool = True, n_directions: int = 2048,
                    variant: str | None = None) -> KnownShapeModel:
        """Facets of every part of ``target``, with (``shadows=True``) the self-shadowing table.

        ``max_edge_m`` (default ``target.radius_m / 4``): triangles that can be shadowed are bisected
        until no edge is longer, so a shadow boundary is resolved to about a quarter of that (16 sample points
        per facet). ``n_directions``: Fibonacci directions of the shadow table (nearest-neighbour
        spacing ≈ ``sqrt(4π/n)`` rad, 4.5° at 2048). ``variant``: the Mitsuba variant used for
        the ray casting (an LLVM one; see :func:`lightcurves.scene.select_variant`).
        """
        if not isinstance(target, Target):
            raise KnownShapeError(f"target: {type(target).__name__}: expected a lightcurves.targets.Target")
        max_edge = target.radius_m / 4.0 if max_edge_m is None else float(max_edge_m)
        if not (np.isfinite(max_edge) and max_edge > 0):
            raise KnownShapeError(f"max_edge_m: {max_edge_m}: expected a length > 0 in metres")
        cols, materials = _facets(target, max_edge if shadows else None)
        n_facets = len(cols["area"])
        directions = np.zeros((0, 3))
        vis_row = np.full(n_facets, -1, np.int32)
        masks = np.zeros((0, 0), np.uint16)
        if shadows:
            hidden = cols["hidden"]
            if hidden.any():
                directions = fibonacci_sphere(n_directions)
                idx = np.nonzero(hidden)[0]
                m = _shadow_masks(target, cols["n"][idx], cols["corners"][idx], directions, 1e-4 * target.radius_m, variant)
                front = cols["n"][idx] @ directions.T > 0.0
                full = np.uint16((1 << _SUB_LEVEL_POINTS) - 1)
                shadowed = ((m != full) & front).any(axis=1)  # drop rows that are never hidden in practice
                masks = np.ascontiguousarray(m[shadowed].T)
                vis_row[idx[shadowed]] = np.arange(int(shadowed.sum()), dtype=np.int32)
                if not shadowed.any():
                    directions = np.zeros((0, 3))
        return cls(
            area_m2=cols["area"], normal_T=cols["n"], shading_normal_T=cols["m"], centroid_T=cols["c"],
            material_index=cols["mat"].astype(np.int32), part_index=cols["part"].astype(np.int32), materials=materials,
            part_names=tuple(p.name for p in target.parts), directions_T=directions, vis_row=vis_row, vis_masks=masks,
        )

    @property
    def n_facets(self) -> int:
        """Number of facets ``F``."""
        return len(self.area_m2)

    @property
    def n_normal_groups(self) -> int:
        """Number of groups of facets that share normals and material, hence one BRDF evaluation per sample (:func:`_normal_blocks`)."""
        return len(self._packed[3])

    def unshadowed(self) -> KnownShapeModel:
        """The same facets with every facet visible in its front hemisphere (no shadow table)."""
        return replace(self, directions_T=np.zeros((0, 3)), vis_row=np.full(self.n_facets, -1, np.int32), vis_masks=np.zeros((0, 0), np.uint16))

    def coarse(self, max_facets: int) -> KnownShapeModel:
        """A cheaper model of at most ``max_facets`` facets (but one per part and material at least), merged by normal.

        Within each (part, material) group, facets are binned by their nearest direction of a
        Fibonacci sphere of ``k`` directions (the largest ``k`` that keeps the total within
        ``max_facets``). Flat faces saturate that (box-wing: 18 distinct part-normal pairs), so the
        remaining budget splits the largest clusters in space (:func:`_split_spatially`). A merged
        facet keeps the total area, the area-weighted mean normals and centroid, and 16 of its
        members' shadow sample points chosen in proportion to area.
        """
        if int(max_facets) < 1:
            raise KnownShapeError(f"max_facets: {max_facets}: expected an integer >= 1")
        max_facets = int(max_facets)
        if max_facets >= self.n_facets:
            return self
        group = self.part_index.astype(np.int64) * len(self.materials) + self.material_index
        lo, hi, best = 1, 4 * max_facets + 1, None
        while lo <= hi:  # bisection on the number of normal bins
            k = (lo + hi) // 2
            bins = cKDTree(fibonacci_sphere(k)).query(self.shading_normal_T)[1]
            labels = np.unique(group * k + bins, return_inverse=True)[1].reshape(-1)
            if labels.max() + 1 <= max_facets:
                best, lo = labels, k + 1
            else:
                hi = k - 1
        if best is None:  # fewer facets than (part, material) groups: merge by group only
            best = np.unique(group, return_inverse=True)[1].reshape(-1)
        return self._merged(_split_spatially(best, self.area_m2, self.centroid_T, max_facets))

    def _merged(self, labels: np.ndarray) -> KnownShapeModel:
        n_new = int(labels.max()) + 1
        A = self.area_m2
        area = np.bincount(labels, A, n_new)

        def wmean(x):
            return np.stack([np.bincount(labels, A * x[:, i], n_new) for i in range(3)], 1) / area[:, None]

        def unit(x):
            return x / np.linalg.norm(x, axis=1, keepdims=True)

        first = np.zeros(n_new, np.int64)
        first[labels[::-1]] = np.arange(len(labels))[::-1]
        vis_row = np.full(n_new, -1, np.int32)
        masks = []
        if len(self.vis_masks):
            for c in np.unique(labels[self.vis_row >= 0]):
                members = np.nonzero(labels == c)[0]
                # 16 (member, bit) picks stratified in cumulative area: an area-weighted subsample of the points
                cum = np.cumsum(A[members]) / A[members].sum()
                u = (np.arange(_SUB_LEVEL_POINTS) + 0.5) / _SUB_LEVEL_POINTS
                pick = np.minimum(np.searchsorted(cum, u), len(members) - 1)
                rows = self.vis_row[members[pick]]
                bits = np.array([self.vis_masks[:, r] >> np.uint16(b) & np.uint16(1) if r >= 0 else np.ones(len(self.directions_T), np.uint16)
                                 for b, r in enumerate(rows)])
                masks.append((bits << np.arange(_SUB_LEVEL_POINTS, dtype=np.uint16)[:, None]).sum(axis=0, dtype=np.uint16))
                vis_row[c] = len(masks) - 1
        return replace(
            self, area_m2=area, normal_T=unit(wmean(self.normal_T)), shading_normal_T=unit(wmean(self.shading_normal_T)),
            centroid_T=wmean(self.centroid_T), material_index=self.material_index[first], part_index=self.part_index[first],
            vis_row=vis_row, vis_masks=np.ascontiguousarray(np.array(masks, np.uint16).T) if masks else np.zeros((0, 0), np.uint16),
            directions_T=self.directions_T if masks else np.zeros((0, 3)),
        )

    # ------------------------------------------------------------ evaluation

    def intensity(self, sun_T, obs_T) -> np.ndarray:
        """Radiant intensity (W/sr), eq. (1), toward ``obs_T`` under ``irradiance_w_m2`` sunlight from ``sun_T``.

        ``sun_T``, ``obs_T``: (N, 3) unit vectors from the target to the Sun and to the observer in
        T (as :meth:`lightcurves.render.UnresolvedRenderer.intensity`). Returns (N,).
        """
        return self._evaluate(sun_T, obs_T, False)[0]

    def intensity_gradient(self, sun_T, obs_T) -> tuple[np.ndarray, np.ndarray]:
        """The intensity (N,) W/sr of :meth:`intensity` and its gradient (N, 3) W/sr/rad with respect to a small rotation ρ
        of both directions in T::

            I(s + ρ × s, o + ρ × o) = I(s, o) + ρ · ∇I + O(ρ²)                                   (2)

        (equivalently, minus the rotation of the body under fixed directions). Exact for eq. (1) as evaluated, wherever no facet
        crosses a horizon and no direction crosses a shadow-table triangle edge (there the intensity has kinks); one pass of
        the kernel, about 1.5 times the cost of :meth:`intensity`.
        """
        return self._evaluate(sun_T, obs_T, True)

    def _evaluate(self, sun_T, obs_T, grad: bool) -> tuple[np.ndarray, np.ndarray]:
        sun = _directions("sun_T", sun_T)
        obs = _directions("obs_T", obs_T)
        if sun.shape != obs.shape:
            raise KnownShapeError(f"obs_T: shape {obs.shape}: expected the shape of sun_T {sun.shape}")
        half = sun + obs
        norm = np.sqrt(np.einsum("ij,ij->i", half, half))[:, None]
        half = np.divide(half, norm, out=np.zeros_like(half), where=norm > 1e-12)  # opposition-free: s = -o has no half vector
        s_dot_h = np.einsum("ij,ij->i", sun, half)
        fresnel = np.stack([np.interp(s_dot_h, _FRESNEL_COS, row) for row in self._fresnel_table], 1)
        if self._lookup is not None:
            ks, ws, dws = self._lookup(sun)
            ko, wo, dwo = self._lookup(obs)
        else:
            ks = ko = np.zeros((len(sun), 3), np.int64)
            ws = wo = np.full((len(sun), 3), 1.0 / 3.0)
            dws = dwo = np.zeros((len(sun), 3, 3))
        out = np.empty(len(sun))
        torque = np.zeros((len(sun), 3)) if grad else np.zeros((1, 3))
        kernel = _intensity_kernel_parallel if _on_all_cores(len(sun), _PARALLEL_SAMPLES) else _intensity_kernel
        kernel(sun, obs, half, ks, ws, ko, wo, dws, dwo, *self._packed, np.ascontiguousarray(fresnel), self._packed_masks, _POPCOUNT16, out, torque,
               grad)
        return out * self.irradiance_w_m2, torque * self.irradiance_w_m2

    def basis(self, sun_T, obs_T) -> np.ndarray:
        """The brightness as one linear basis column (N, 1), W/sr: ``brightness = basis @ [1]``.

        The contract shared with the convex models (``basis(sun_T, obs_T) -> (N, m)``, brightness
        ``basis @ w`` with ``w >= 0``): a fitted weight is then the scale of a relative curve.
        """
        return self.intensity(sun_T, obs_T)[:, None]

    def basis_gradient(self, sun_T, obs_T) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`basis` (N, 1) and its gradient (N, 1, 3) with respect to a rotation of both directions (eq. 2)."""
        value, torque = self.intensity_gradient(sun_T, obs_T)
        return value[:, None], torque[:, None, :]
