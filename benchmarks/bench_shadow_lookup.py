"""Shadow-table lookup of the known-shape model: the nearest table direction by the cell grid
(:class:`lightcurves.inversion.known_shape._SphereInterpolator`'s ``nearest``) against scipy's ``cKDTree.query`` on the same
queries, measured in the same run, and the identity of their answers.

Queries: 10⁶ random unit vectors, and the screen's kind (:mod:`lightcurves.inversion.phase_screen`): the Sun's direction in
the body frame of a body spinning about its z axis, 1800 samples × 48 table phases at one pole (consecutive queries close on
the sphere). Times best of 3; the cell lookup runs on one core (``nearest``), as ``cKDTree.query`` (``workers=1``).
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from benchmarks.bench_lightcurves import _best_of
from lightcurves.inversion.known_shape import _SphereInterpolator, fibonacci_sphere

N_DIRECTIONS = 2048  #: the default shadow table (:meth:`KnownShapeModel.from_target`)


def _unit(v):
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def _queries() -> dict[str, np.ndarray]:
    rng = np.random.default_rng(5)
    sun_I = _unit(np.array([1.0, 0.3, 0.2]) + 0.01 * np.cumsum(rng.normal(size=(1800, 3)), axis=0) / 40)  # a slowly moving Sun
    phases = np.arange(48)[:, None] * (2 * np.pi / 48) + 0.05 * np.arange(1800)[None, :]
    c, s = np.cos(phases), np.sin(phases)
    screen = np.stack([c * sun_I[:, 0] + s * sun_I[:, 1], -s * sun_I[:, 0] + c * sun_I[:, 1], np.broadcast_to(sun_I[:, 2], c.shape)], -1)
    return {"random, 10⁶": _unit(rng.normal(size=(1_000_000, 3))), "screen: 48 phases × 1800 samples": screen.reshape(-1, 3)}


def run() -> str:
    directions = fibonacci_sphere(N_DIRECTIONS)
    lookup, tree = _SphereInterpolator(directions), cKDTree(directions)
    rows = []
    for name, q in _queries().items():
        same = int(np.sum(lookup.nearest(q) == tree.query(q)[1]))
        t_cell = _best_of(lambda: lookup.nearest(q), 3)
        t_tree = _best_of(lambda: tree.query(q), 3)
        rows.append(f"| {name} | {len(q)} | {same}/{len(q)} | {1e9 * t_cell / len(q):.0f} | {1e9 * t_tree / len(q):.0f} | {t_tree / t_cell:.1f} |")
    cells = np.diff(lookup.cells[0])
    return "\n".join([
        "## Shadow-table lookup: cell grid against cKDTree", "",
        f"{N_DIRECTIONS} Fibonacci directions; {cells.size} cells, {cells.mean():.2f} candidates per cell on average (max {cells.max()}).", "",
        "| queries | n | same nearest direction | cell grid (ns/query) | cKDTree.query (ns/query) | ratio |", "|---|---|---|---|---|---|", *rows])
