"""The pole's profile likelihood: at one pole (:func:`pole_profile_chi2`) and over the region it defines (:func:`pole_profile_region`).

The modes of :func:`lightcurves.inversion.search.invert` carry Laplace Gaussians (:mod:`.posterior`). With one or two
nights, or a spin about the minor axis, the pole's likelihood is often a curved ridge or a plateau that those Gaussians
cut short. The profile likelihood answers "could the pole be there?" without them: at a pole ``p`` the rest of the spin
state (rate, phase, and a known shape's body axis; the linear parameters profiled as in the search) is refitted, and

    Λ(p) = (χ²(p) − χ²_min) / s  ~  χ²₂ at the true pole                                        (1)

(Wilks 1938, *Ann. Math. Statist.* 9, 60; the χ² differences scaled by the result's s, eq. 1 of :mod:`.posterior`,
as the modes' are). The region of level α holds the poles with F_χ²₂(Λ) ≤ α (:meth:`InversionResult.profile_level`).
Where the likelihood is quadratic, Λ is the pole's marginal Mahalanobis distance from the mode (the profile of a
Gaussian is its Schur complement), so the region is the mode's ellipse; where it is not, the region follows the data.

:func:`pole_profile_region` maps that region. The modes at one pole (aliases, other body axes) share a grid in the tangent
plane of the most probable of them, along its principal pole directions one σ a step; from the modes' own nodes (and, for a
known shape, the lead turned onto the other principal axes) the map fills outwards, neighbour by neighbour, while Λ stays
within ``max_level``. Each new node's fit starts from the lowest-χ² mapped neighbour of each branch turned onto it: a
continuation along the ridge, one held fit per node and branch, so the cost is the region's area in σ², not the sphere's.
It cannot see an island of the region that no listed mode's branch reaches (the search missed its optimum).

Measured (2026-11-30, 40 calibration objects of the inversion benchmark, seeds 9000 + i, 1–5 nights × 150 samples,
facet-rendered, one thread): the region's level at the true pole (:meth:`PoleProfileRegion.level_at`) holds the truth at
95 % on 29/40 and at 68 % on 19/40; the pointwise profile at the truth (:func:`pole_profile_chi2`, every mode and principal
axis as a start) on 35/40 and 26/40. Of the six it misses that the pointwise profile holds, three are islands no mode's
branch reaches (one or two nights, the truth 112–178° from the best mode), two are maps that restarted on 4 and 16 σ grids
whose cells are too coarse to resolve the truth's level, one is at the boundary (0.958 against 0.946). CPU per map: median
2.9 s, 90th percentile 54 s, at most 712 s (a two-night vespa with 18 modes, stopped at 600 poles on 16 σ grids). On the
benchmark's three timing objects (3 nights × 600 samples, 2 threads): box-wing 65 poles in 0.6 s, atlas-centaur (16 modes)
141 poles in 7.2 s, vespa (14 modes) 239 poles in 211 s.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from astropy.time import Time
from scipy.optimize import least_squares
from scipy.spatial.transform import Rotation
from scipy.stats import chi2 as chi2_dist

from lightcurves.inversion.data import InversionCurve
from lightcurves.inversion.posterior import InversionResult, tangent_exp, tangent_offset
from lightcurves.inversion.search import _PRINCIPAL_AXES, _best_phase, _each, _pole_phase_frame, _Problem, _stack, _subsample, _workers
from lightcurves.inversion.spin import SpinState, axis_frame

__all__ = ["pole_profile_chi2", "pole_profile_region", "PoleProfileRegion"]

#: Most poles :func:`pole_profile_region` maps by default (a Gaussian mode's region to 99 % is ~40 grid nodes with its
#: boundary; a ridge of one night a few hundred).
MAX_REGION_POLES = 600


#: Coarsest grid step of :func:`pole_profile_region`'s restarts, in σ of the lead mode (4⁶: six restarts at most).
MAX_STEP_SIGMAS = 4.0**6


class _FixedPole:
    """A :class:`_Problem` with its pole held: θ without (δ₁, δ₂), the pole-frame turn about the pole (the phase) kept."""

    def __init__(self, problem: _Problem):
        self.problem = problem

    def _theta(self, x) -> np.ndarray:
        return np.concatenate([np.zeros(2), x])

    def residuals(self, x) -> np.ndarray:
        return self.problem.residuals(self._theta(x))

    def jac(self, x) -> np.ndarray:
        return self.problem.jac(self._theta(x))[:, 2:]


def _known(model) -> bool:
    """Whether ``model`` is a known shape (one linear parameter: phase and body axis fitted)."""
    return model.basis(np.array([[0.0, 0.0, 1.0]]), np.array([[0.0, 0.0, 1.0]])).shape[1] == 1


def _turned_onto(state: SpinState, pole_I: np.ndarray, epoch: Time) -> np.ndarray:
    """``C_IP`` of ``state`` at ``epoch`` turned onto the unit ``pole_I`` by the smallest rotation (the antipode: a half turn
    about an axis ⟂ the pole)."""
    C_IP = _pole_phase_frame(state, epoch)
    axis = np.cross(state.pole_I, pole_I)
    if np.linalg.norm(axis) > 1e-12:
        return Rotation.from_rotvec(axis / np.linalg.norm(axis) * np.arctan2(np.linalg.norm(axis), state.pole_I @ pole_I)).as_matrix() @ C_IP
    if state.pole_I @ pole_I < 0:
        return Rotation.from_rotvec(np.pi * C_IP[:, 0]).as_matrix() @ C_IP
    return C_IP


def _held_fit(data, model, known: bool, start, max_nfev: int) -> tuple[float, SpinState]:
    """(χ², state) of the fit with the pole held at ``start``'s (C_IP, rate, C_TA) pole: rate, phase and (known) body axis free.

    A fit whose rate ran through zero (one short night held at a far pole: the benchmark's one-night vespa, 8700 s the other
    way) is no spin state of the search: (inf, the start's state)."""
    problem = _Problem(data, model, start[0], start[1], start[2], known, known)
    held = _FixedPole(problem)
    fit = least_squares(held.residuals, np.zeros(problem.n - 2), jac=held.jac if problem.analytic else "2-point", method="trf",
                        diff_step=1e-6, max_nfev=max_nfev)
    theta = np.concatenate([np.zeros(2), fit.x])
    if not problem.unpack(theta)[1] > 0.0:
        return np.inf, problem.state(np.zeros(problem.n))
    return 2.0 * float(fit.cost), problem.state(theta)


def _unit_pole(pole_I) -> np.ndarray:
    p = np.asarray(pole_I, dtype=float)
    if p.shape != (3,) or not np.all(np.isfinite(p)) or np.linalg.norm(p) == 0:
        raise ValueError(f"pole_I: {pole_I!r}: expected a finite non-zero 3-vector")
    return p / np.linalg.norm(p)


def pole_profile_chi2(curves: Sequence[InversionCurve], model, result: InversionResult, pole_I, *, n_starts: int = 3,
                      max_nfev: int = 60, n_scan_samples: int = 60, workers: int | None = None) -> tuple[float, SpinState]:
    """The profile likelihood of the pole: the smallest χ² at the pole direction ``pole_I`` over the rest of the spin
    state (rate, phase, and a known shape's body axis; the linear parameters profiled as in :func:`invert`), with the
    state reaching it.

    Fitted (``least_squares``, ``max_nfev`` evaluations, the pole held) from every mode of ``result``, each turned onto
    it by the smallest rotation, so a ridge or a plateau of the pole's likelihood between and around the modes is followed
    where their Gaussians stop; for a known shape the ``n_starts`` modes nearest to ``pole_I`` are also started about every
    principal axis ⟂ their own at its best phase (:func:`_best_phase`, on ``n_scan_samples`` per curve): a near-symmetric body (vespa about ±x and ±y) fits
    one night almost as well about either, with poles a σ apart, and a fit never turns the axis that far. Its χ² less the
    best mode's, over the result's scale s, is the profile-likelihood statistic of the pole (eq. 1),
    ~χ²₂ at the true pole (:meth:`InversionResult.profile_level`). The starts' fits run on ``workers`` threads as in :func:`invert`.
    """
    if not (isinstance(n_starts, (int, np.integer)) and n_starts >= 1):
        raise ValueError(f"n_starts: {n_starts!r}: expected an integer >= 1")
    workers = _workers(workers)
    curves = [curves] if isinstance(curves, InversionCurve) else list(curves)
    data = _stack(curves)
    p = _unit_pole(pole_I)
    known = _known(model)
    nearest = sorted(result.solutions, key=lambda sol: -float(sol.pole_I @ p))
    scan = _subsample(data, n_scan_samples)  # the phase scan only picks a start
    starts = []  # (C_IP, rate, C_TA)
    for rank, sol in enumerate(nearest):
        st = sol.state
        C_IP = _turned_onto(st, p, data.epoch)
        starts.append((C_IP, st.rate_rad_s, axis_frame(st.axis_T) if known else np.eye(3)))
        if known and rank < n_starts:
            starts += [(_best_phase(scan, model, C_IP, st.rate_rad_s, axis_frame(a)), st.rate_rad_s, axis_frame(a))
                       for a in _PRINCIPAL_AXES if abs(a @ st.axis_T) < 0.5]

    best = (np.inf, None)
    for chi2, state in _each(lambda start: _held_fit(data, model, known, start, max_nfev), starts, workers):
        if chi2 < best[0]:  # the first of equal ones, whatever the number of threads
            best = (chi2, state)
    return best


@dataclass(frozen=True)
class PoleProfileRegion:
    """The mapped poles of a profile-likelihood region (:func:`pole_profile_region`), mode by mode, in the order mapped.

    poles_I : (n, 3) mapped poles, unit vectors in I; chi2 : (n,) their profile χ² (eq. 1's χ²(p)); states : their fitted
    spin states; level : (n,) F_χ²₂(Λ) (Λ clipped at 0: a pole below the best mode is at level 0, and :attr:`min_chi2` says
    by how much the search missed it); mode : (n,) the index in ``result.solutions`` of the mode whose branch (the fits
    continued from it) gave the pole its χ²;
    cell_deg2 : (n,) the solid angle of its grid cell, deg²; max_level : the level each fill stopped at; complete : False
    when ``max_poles`` stopped a fill before every mapped pole within ``max_level`` had its neighbours mapped.
    """

    poles_I: np.ndarray
    chi2: np.ndarray
    states: tuple
    level: np.ndarray
    mode: np.ndarray
    cell_deg2: np.ndarray
    max_level: float
    complete: bool
    chi2_min: float  #: the best mode's χ² (eq. 1's χ²_min)
    chi2_scale: float  #: the result's s
    step_sigmas: float = 1.0  #: the grids' step in σ of their lead mode (more than 1 when a finer map hit ``max_poles``)
    grids: tuple = ()  #: per group of modes, (lead pole (3,), grid step matrix A (2, 2) rad, {node (i, j): [row, ...]})

    def level_at(self, pole_I) -> float:
        """The region's level at any pole, from the grid that holds it (its tangent offset from a group's lead pole in grid
        units, ``u = A⁻¹ x``): Λ interpolated bilinearly between the four nodes around ``u`` when all four are mapped (each
        node's Λ the lowest over its body axes; its error at most (|∂²Λ/∂u₁²| + |∂²Λ/∂u₂²|)/8, 0.5 on a Gaussian mode's one-σ
        grid), else the level of the node ``u`` rounds to; the lowest over the groups; 1 where no
        mapped cell holds it (beyond ``max_level``, or never reached)."""
        p = _unit_pole(pole_I)
        lam = np.maximum(self.chi2 - self.chi2_min, 0.0) / self.chi2_scale
        levels = [1.0]
        for lead, A, nodes in self.grids:
            if lead @ p < -1.0 + 1e-12:  # the antipode: no single tangent offset
                continue
            u = np.linalg.solve(A, tangent_offset(lead, p))
            i0, j0 = (int(v) for v in np.floor(u))
            corners = [nodes.get((i0 + di, j0 + dj)) for di in (0, 1) for dj in (0, 1)]
            if all(corners):
                fi, fj = u[0] - i0, u[1] - j0
                weights = ((1 - fi) * (1 - fj), (1 - fi) * fj, fi * (1 - fj), fi * fj)
                levels.append(float(chi2_dist.cdf(sum(w * min(lam[r] for r in rows) for w, rows in zip(weights, corners)), 2)))
                continue
            rows = nodes.get(tuple(int(v) for v in np.round(u)), [])
            levels += [float(self.level[r]) for r in rows]
        return min(levels)

    @property
    def min_chi2(self) -> float:
        """The lowest profile χ² mapped (below ``chi2_min`` when the map found what the search missed)."""
        return float(self.chi2.min()) if self.chi2.size else float("nan")

    def inside(self, level: float = 0.95) -> np.ndarray:
        """Mask of the mapped (pole, body-axis branch) rows in the region of ``level`` (F_χ²₂(Λ) ≤ level)."""
        return self.level <= level

    def solid_angle_deg2(self, level: float = 0.95) -> float:
        """The region's area, deg²: the cells of its grid nodes (a node mapped about several body axes counts once; grids
        of two groups that overlap count twice)."""
        return float(sum(self.cell_deg2[rows[0]] for _, _, nodes in self.grids for rows in nodes.values()
                         if min(self.level[r] for r in rows) <= level))


def _check_region_options(max_level, max_poles, max_step_deg) -> None:
    if not (isinstance(max_level, (int, float)) and 0.0 < max_level < 1.0):
        raise ValueError(f"max_level: {max_level!r}: expected a credible level in (0, 1)")
    if not (isinstance(max_poles, (int, np.integer)) and max_poles >= 1):
        raise ValueError(f"max_poles: {max_poles!r}: expected an integer >= 1")
    if not (isinstance(max_step_deg, (int, float)) and 0.0 < max_step_deg <= 20.0):
        raise ValueError(f"max_step_deg: {max_step_deg!r}: expected a grid step in (0, 20] deg")


def _grid_axes(solution, max_step_deg: float, sigmas: float = 1.0) -> np.ndarray:
    """(2, 2) tangent offsets (rad, basis of :func:`~lightcurves.inversion.spin.pole_frame`) of one grid step along i and j:
    the mode's principal pole directions, ``sigmas`` σ each, at most ``max_step_deg``."""
    evals, evecs = np.linalg.eigh(solution.pole_covariance_rad2)
    return evecs * np.minimum(sigmas * np.sqrt(np.maximum(evals, 0.0)), np.radians(max_step_deg))


def _groups(result: InversionResult, included: list[int], max_level: float, max_step_deg: float, sigmas: float) -> list[tuple[int, dict]]:
    """The modes ``included`` grouped onto shared grids: (lead mode, {node: [mode, ...]}). A mode joins the first group whose
    lead's pole Gaussian holds its pole within ``max_level`` (an alias or an axis of the same pole: their profiles meet), at
    the lead's grid node nearest to it; otherwise it leads a group of its own at node (0, 0)."""
    groups: list[tuple[int, dict]] = []
    bound = chi2_dist.ppf(max_level, 2)
    for m in included:
        sol = result.solutions[m]
        for lead, seeds in groups:
            x = tangent_offset(result.solutions[lead].pole_I, sol.pole_I)
            if x @ np.linalg.solve(result.solutions[lead].pole_covariance_rad2, x) <= bound:
                node = tuple(int(v) for v in np.round(np.linalg.solve(_grid_axes(result.solutions[lead], max_step_deg, sigmas), x)))
                seeds.setdefault(node, []).append(m)
                break
        else:
            groups.append((m, {(0, 0): [m]}))
    return groups


def _neighbours(node: tuple[int, int]) -> list[tuple[int, int]]:
    return [(node[0] + di, node[1] + dj) for di in (-1, 0, 1) for dj in (-1, 0, 1) if di or dj]


def _axis_class(axis_T: np.ndarray) -> int:
    """The principal body axis (±x, ±y, ±z: 0–5) nearest to a spin axis: the branches of :func:`_map` that never merge."""
    k = int(np.argmax(np.abs(axis_T)))
    return 2 * k + int(axis_T[k] < 0)


def _next_wave(mapped: dict, grow: list) -> dict:
    """The unmapped neighbours (node, axis class) of the keys ``grow``, each with its starts: per branch of that axis class
    around it, the state of the branch's lowest-χ² mapped neighbour, lowest first (``mapped``: (node, class) -> (χ², state,
    branch))."""
    wave = {}
    for node, cls in sorted({(nb, c) for g, c in grow for nb in _neighbours(g)} - set(mapped)):
        lowest: dict[int, tuple[float, SpinState]] = {}
        for nb in _neighbours(node):
            found = mapped.get((nb, cls))
            if found is not None and (found[2] not in lowest or found[0] < lowest[found[2]][0]):
                lowest[found[2]] = found[:2]
        wave[(node, cls)] = [(st, b) for b, (_, st) in sorted(lowest.items(), key=lambda kv: (kv[1][0], kv[0]))]
    return wave


def _map(fit: Callable, level: Callable, other_axes: Callable, result: InversionResult, max_level: float, max_step_deg: float,
         sigmas: float, max_poles: int, workers: int, progress) -> tuple[list, bool, tuple]:
    """One fill of :func:`pole_profile_region` on grids of ``sigmas`` σ a step: (rows (pole, χ², state, branch, cell deg²),
    complete, grids (:attr:`PoleProfileRegion.grids`)). ``other_axes(m)``: the states about the principal axes ⊥ mode m's
    (known shape; none otherwise), the extra branches seeded at a group's lead."""
    rows, grids = [], []
    complete = True
    included = [m for m, s in enumerate(result.solutions) if level(s.chi2) <= max_level]
    for lead, seeds in _groups(result, included, max_level, max_step_deg, sigmas):
        sol = result.solutions[lead]
        A = _grid_axes(sol, max_step_deg, sigmas)
        cell = float(abs(np.linalg.det(A))) * np.degrees(1.0) ** 2
        mapped: dict = {}  # (node, axis class) -> (χ², state, branch)
        grids.append((sol.pole_I, A, {}))
        wave: dict = {}
        for node, members in seeds.items():
            for m in members:
                wave.setdefault((node, _axis_class(result.solutions[m].state.axis_T)), []).append((result.solutions[m].state, m))
        for st in other_axes(lead):
            wave.setdefault(((0, 0), _axis_class(st.axis_T)), [(st, lead)])
        while wave and complete:
            if len(rows) + len(wave) > max_poles:
                complete = False
                wave = dict(sorted(wave.items())[: max_poles - len(rows)])
            items = sorted(wave.items())
            poles = [tangent_exp(sol.pole_I, A @ np.array(key[0], dtype=float)) for key, _ in items]
            for (key, _), pole, found in zip(items, poles, _each(lambda k: fit(poles[k], items[k][1]), range(len(items)), workers)):
                mapped[key] = found
                grids[-1][2].setdefault(key[0], []).append(len(rows))
                rows.append((pole, found[0], found[1], found[2], cell))
            if progress is not None:
                progress(len(rows), max_poles)
            wave = _next_wave(mapped, [key for key, _ in items if level(mapped[key][0]) <= max_level])
    return rows, complete, tuple(grids)


def pole_profile_region(curves: Sequence[InversionCurve], model, result: InversionResult, *, max_level: float = 0.99,
                        max_poles: int = MAX_REGION_POLES, max_step_deg: float = 5.0, max_nfev: int = 60, n_scan_samples: int = 60,
                        workers: int | None = None, progress: Callable[[int, int], None] | None = None) -> PoleProfileRegion:
    """Map the pole's profile-likelihood region (module docstring) out to the level ``max_level``.

    The modes of ``result`` whose own Λ is within ``max_level`` are grouped (:func:`_groups`: aliases and other body axes
    at one pole share a grid); each group gets a grid in the tangent plane of its lead mode along the lead's principal
    pole directions, one σ a step (at most ``max_step_deg``): a Gaussian mode's 95 % region is then ~19 cells, and a ridge
    is followed for as long as it stays in. For a known shape, the lead is also turned onto each principal axis ⟂ its own at
    its best phase (on ``n_scan_samples`` per curve, as :func:`pole_profile_chi2` starts): the spin about another body axis
    is a branch of its own, which may hold the pole where the modes' axis does not (a one-night box-wing: its mode about x,
    the truth about y at Λ's level 0.73 against 0.99 about x). From the seeds, wave by wave, every node next to (8
    neighbours) a mapped node whose level is ≤ ``max_level`` is fitted, about the same body axis, with the pole held
    (:func:`_held_fit`, ``max_nfev`` evaluations) from the lowest-χ² mapped neighbour of each branch (the mode it descends
    from) around it, and keeps the lowest: where two modes' branches meet, the profile is the lower of them; a node's
    level is the lowest over its body axes. A wave's fits run on ``workers`` threads and are taken in
    grid order, so the map does not depend on their number. A grid ends when no node is left to map. When ``max_poles``
    poles are mapped before every grid ends (a plateau of one night: hundreds of deg² around a sharp mode), the map starts
    again on grids four times as coarse (4, 16, 64 … σ a step, each covering 16 times the area), until it closes, every step
    is at ``max_step_deg`` or the step is :data:`MAX_STEP_SIGMAS` σ; then it returns the last map, ``complete`` False.
    ``progress(n_mapped, max_poles)`` after each wave (from 0 again at each restart).
    """
    _check_region_options(max_level, max_poles, max_step_deg)
    workers = _workers(workers)
    curves = [curves] if isinstance(curves, InversionCurve) else list(curves)
    data = _stack(curves)
    known = _known(model)
    chi2_min = min(s.chi2 for s in result.solutions)

    def level(chi2: float) -> float:
        return float(chi2_dist.cdf(max(chi2 - chi2_min, 0.0) / result.chi2_scale, 2))

    def fit(pole: np.ndarray, starts: list) -> tuple[float, SpinState, int]:
        best = None
        for state, branch in starts:
            chi2, st = _held_fit(data, model, known, (_turned_onto(state, pole, data.epoch), state.rate_rad_s,
                                                      axis_frame(state.axis_T) if known else np.eye(3)), max_nfev)
            if best is None or chi2 < best[0]:
                best = (chi2, st, branch)
        return best

    scan = _subsample(data, n_scan_samples)  # the phase scans only pick a start
    seeded: dict[int, list] = {}

    def other_axes(m: int) -> list:
        """Mode m's pole held and its body turned onto each principal axis ⟂ its own at its best phase, fitted (memoised)."""
        if m not in seeded:
            st = result.solutions[m].state
            C_IP = _pole_phase_frame(st, data.epoch)
            seeded[m] = [_held_fit(data, model, True, (_best_phase(scan, model, C_IP, st.rate_rad_s, axis_frame(a)), st.rate_rad_s,
                                                       axis_frame(a)), max_nfev)[1]
                         for a in _PRINCIPAL_AXES if abs(a @ st.axis_T) < 0.5] if known else []
        return seeded[m]

    smallest_sigma_deg = min(float(np.degrees(np.sqrt(max(np.linalg.eigvalsh(s.pole_covariance_rad2)[0], 0.0)))) for s in result.solutions)
    sigmas = 1.0
    while True:
        rows, complete, grids = _map(fit, level, other_axes, result, max_level, max_step_deg, sigmas, max_poles, workers, progress)
        if complete or sigmas * smallest_sigma_deg >= max_step_deg or sigmas >= MAX_STEP_SIGMAS:
            break
        sigmas *= 4.0
    chi2 = np.array([r[1] for r in rows])
    return PoleProfileRegion(np.array([r[0] for r in rows]).reshape(-1, 3), chi2, tuple(r[2] for r in rows),
                             chi2_dist.cdf(np.maximum(chi2 - chi2_min, 0.0) / result.chi2_scale, 2), np.array([r[3] for r in rows], dtype=int),
                             np.array([r[4] for r in rows]), float(max_level), complete, float(chi2_min), float(result.chi2_scale), sigmas, grids)
