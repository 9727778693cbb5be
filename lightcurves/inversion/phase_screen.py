"""Known-shape screening of the spin state: χ² over pole × body axis × sidereal rate × phase, from per-curve phase tables.

For a known shape the light curve depends on the whole attitude, so a screen that ignores the phase and the body axis
(a convex stand-in that absorbs both) ranks poles by the wrong likelihood: on the SC3 seed-1 campaign (three 300-s arcs of
atlas-centaur) the convex screen led the refinement to a basin 119° off with χ² = 1.98e5, while the truth's χ² is 5.85e4.
This module screens with the known shape itself, cheaply, by separating the two time scales of the problem:

* within one curve (an arc of half-length h) a rate error δω turns the phase by at most δω·h at the ends. The rate range is
  cut into nodes ω_n so that |ω − ω_n|·h ≤ ``drift_tol_rad`` for every searched ω; at each pole p and body axis a, each
  sample's brightness is tabulated once over the rotation phase (:func:`_curve_tables`) and read, for every node and every
  phase φ_j of a uniform grid of ``n_phases`` at the curve's mid-time t̄_k, at φ(t_i) = φ_j + ω_n (t_i − t̄_k). Kept per
  (p, a, n, j): the sufficient statistics of the curve's linear fit, S_yB = Σ g y B / σ² and S_BB = Σ (g B / σ)² (g the
  distance factor of :func:`lightcurves.render.observed_flux`);
* across curves only the phase at each mid-time matters: φ_k = φ₀ + ω t̄_k. For every (ω, φ₀) of the search grid the
  statistics are read at φ_k (cubic interpolation between grid phases, :func:`_fractional_tables`), and the χ² follows in
  closed form: one non-negative scale w shared by the calibrated curves, χ² = Σ S_yy − max(Σ S_yB, 0)² / Σ S_BB, plus, for
  each relative curve, its own scale, χ²_k = S_yy,k − max(S_yB,k, 0)² / S_BB,k (the profiled likelihood of :mod:`.search`).

The cost is n_pole × n_axis × n_table × n_sample model evaluations (n_table = n_phases), independent of the number of rates
and nodes; the combination over (ω, φ₀) is n_pole × n_ω × n_axis × n_curve rows of n_phases table values, each a contiguous
slice (:func:`_combine`; a read per (phase, curve) with a modulo cost 3.9–5.5× as much, 12–16 % of the screen's CPU time on
3-night × 600-sample objects of ``benchmarks/bench_inversion.py``). The same idea — tabulate a curve's brightness against
phase once, then slide the tables against each other across rate trials — is the phase-dispersion principle of period searches
(Stellingwerf, ApJ 224, 1978), here with the known shape's predicted curve in place of the data's own.
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np

from lightcurves.inversion.spin import axis_frame, pole_frame, unspin

__all__ = ["PhaseScreen", "screen_phases", "rate_nodes"]


@dataclass(frozen=True)
class PhaseScreen:
    """The screen's result over poles (n_p) and rates (n_ω).

    chi2 : (n_p, n_ω) the smallest χ² over body axes and phases at each pole and rate.
    axis_index : (n_p, n_ω) index into the searched axes of that minimum.
    phase_rad : (n_p, n_ω) φ₀ (rad, at the data's epoch) of that minimum.
    """

    chi2: np.ndarray
    axis_index: np.ndarray
    phase_rad: np.ndarray


def rate_nodes(omegas: np.ndarray, half_span_s: float, drift_tol_rad: float) -> tuple[np.ndarray, np.ndarray]:
    """Rate nodes (n_node,) rad/s and the node of each rate (n_ω,) so that |ω − ω_node|·half_span ≤ drift_tol (module docstring)."""
    lo, hi = float(omegas.min()), float(omegas.max())
    width = 2.0 * drift_tol_rad / max(half_span_s, 1e-9)
    n = max(1, int(np.ceil((hi - lo) / width)))
    nodes = lo + (np.arange(n) + 0.5) * (hi - lo) / n if hi > lo else np.array([lo])
    return nodes, np.clip(np.round((omegas - lo) / (hi - lo) * n - 0.5).astype(int), 0, n - 1) if hi > lo else np.zeros(omegas.size, int)


def _curve_tables(model, sun_I, obs_I, t_c, weight_y, weight_B, C_IP, C_TA, nodes, phases, n_table) -> tuple[np.ndarray, np.ndarray]:
    """(S_yB, S_BB), each (n_a, n_p, n_node, M), of one curve for a batch of pole frames C_IP (n_p, 3, 3) (module docstring).

    The model is evaluated once per sample on a table of ``n_table`` phases ψ_l + ω̄ t_i (ω̄ the middle node); every (node,
    grid phase) then reads it (:func:`_node_sums`), so the cost in model evaluations does not grow with the number of nodes.
    With one node and ``n_table`` = M every read falls on the table: the sums are exact.
    """
    s_P = np.einsum("ni,pij->pnj", sun_I, C_IP)
    o_P = np.einsum("ni,pij->pnj", obs_I, C_IP)
    n_a, n_p, M = C_TA.shape[0], C_IP.shape[0], phases.size
    omega_ref = nodes[nodes.size // 2]
    psi = omega_ref * t_c[:, None] + np.arange(n_table)[None, :] * (2 * np.pi / n_table)  # (N, L)
    # phase the fastest index: consecutive directions are one table step (2π/L) apart, which the shadow table's look-up walks
    # in a step or two (:func:`lightcurves.inversion.known_shape._locate`)
    shape = (n_p,) + psi.shape + (3,)
    s = unspin(psi, np.broadcast_to(s_P[:, :, None], shape))  # (n_p, N, L, 3)
    o = unspin(psi, np.broadcast_to(o_P[:, :, None], shape))
    S_yB = np.empty((n_a, n_p, nodes.size, M))
    S_BB = np.empty_like(S_yB)
    for a in range(n_a):
        B = model.basis((s @ C_TA[a].T).reshape(-1, 3), (o @ C_TA[a].T).reshape(-1, 3))[:, 0].reshape(n_p, -1, n_table)
        _node_sums(B, phases, nodes - omega_ref, t_c, weight_y, weight_B, S_yB[a], S_BB[a])
    return S_yB, S_BB


@numba.njit(cache=True, parallel=True)
def _node_sums(table, phases, offsets, t_c, weight_y, weight_B, S_yB, S_BB):  # pragma: no cover - compiled
    """S_yB[p, n, j] = Σ_i wy_i b_i(φ_j + ω_n t_i), S_BB likewise with wB_i b_i², b_i read from ``table`` (n_p, N, L) of the
    brightness at the L uniform phases ψ_l + ω̄ t_i (``offsets`` = ω_n − ω̄) by the Catmull–Rom cubic
    (error O(Δψ³) for a smooth curve; Keys, IEEE TASSP 29, 1981).

    Numba, the poles shared among the cores: (n_node × M × N) reads per pole, which numpy would gather as (n_p, n_node, M, N) arrays.
    """
    n_p, N, L = table.shape
    step = L / (2.0 * np.pi)
    for p in numba.prange(n_p):
        for n in range(offsets.size):
            for j in range(phases.size):
                yb, bb = 0.0, 0.0
                for i in range(N):
                    x = (phases[j] + offsets[n] * t_c[i]) * step
                    k = np.floor(x)
                    f = x - k
                    k0 = int(k) % L
                    b = (0.5 * f * (f * (2.0 - f) - 1.0) * table[p, i, (k0 - 1) % L] + 0.5 * (f * f * (3.0 * f - 5.0) + 2.0) * table[p, i, k0]
                         + 0.5 * f * (f * (4.0 - 3.0 * f) + 1.0) * table[p, i, (k0 + 1) % L] + 0.5 * f * f * (f - 1.0) * table[p, i, (k0 + 2) % L])
                    yb += weight_y[i] * b
                    bb += weight_B[i] * b * b
                S_yB[p, n, j] = yb
                S_BB[p, n, j] = bb


#: sub-steps of a grid phase at which the curves' statistics are pre-interpolated (:func:`_fractional_tables`): each curve's
#: mid-time phase is read at the nearest 1/N_FRAC of a step, an error ≤ 2π/(2 · N_FRAC · n_phases) (0.47° at 48 phases)
N_FRAC = 8


@numba.njit(cache=True, parallel=True)
def _fractional_tables(S_yB, S_BB, S_yy, n_frac):  # pragma: no cover - compiled
    """Y, Q (K, n_a, n_p, n_node, n_frac, 2M): S_yB and S_BB at the phases i + q/n_frac grid steps, q = 0 … n_frac − 1, each
    row written twice over (index i and i + M: :func:`_combine` reads M consecutive phases from any start without a modulo).

    Catmull–Rom cubic through the four nearest grid phases (linear interpolation doubled the screen's χ² at the truth).
    Exact statistics obey Cauchy–Schwarz, S_yB² ≤ S_yy S_BB (so χ² ≥ 0). The cubic can undershoot S_BB next to a glint
    (a sharp peak of S_BB in phase) and break it: S_yB²/S_BB then exceeds S_yy by orders of magnitude (measured χ² down to
    −2.7e10 on a 3-night atlas-centaur case, which led the search 42° off). There the two nearest grid phases are
    interpolated linearly instead: a convex combination keeps the inequality (√ is concave).
    """
    K, n_a, n_p, n_node, M = S_yB.shape
    Y = np.empty((K, n_a, n_p, n_node, n_frac, 2 * M))
    Q = np.empty_like(Y)
    for p in numba.prange(n_p):
        for k in range(K):
            for a in range(n_a):
                for n in range(n_node):
                    for q in range(n_frac):
                        f = q / n_frac
                        c0, c1 = 0.5 * f * (f * (2.0 - f) - 1.0), 0.5 * (f * f * (3.0 * f - 5.0) + 2.0)
                        c2, c3 = 0.5 * f * (f * (4.0 - 3.0 * f) + 1.0), 0.5 * f * f * (f - 1.0)
                        for i in range(M):
                            im, i1, i2 = (i - 1) % M, (i + 1) % M, (i + 2) % M
                            yb = c0 * S_yB[k, a, p, n, im] + c1 * S_yB[k, a, p, n, i] + c2 * S_yB[k, a, p, n, i1] + c3 * S_yB[k, a, p, n, i2]
                            bb = c0 * S_BB[k, a, p, n, im] + c1 * S_BB[k, a, p, n, i] + c2 * S_BB[k, a, p, n, i1] + c3 * S_BB[k, a, p, n, i2]
                            if bb <= 0.0 or yb * yb > S_yy[k] * bb:
                                yb = (1.0 - f) * S_yB[k, a, p, n, i] + f * S_yB[k, a, p, n, i1]
                                bb = (1.0 - f) * S_BB[k, a, p, n, i] + f * S_BB[k, a, p, n, i1]
                            Y[k, a, p, n, q, i] = Y[k, a, p, n, q, i + M] = yb
                            Q[k, a, p, n, q, i] = Q[k, a, p, n, q, i + M] = bb
    return Y, Q


@numba.njit(cache=True, parallel=True)
def _combine(S_yB, S_BB, S_yy, relative, node_of, shift, chi2, best):  # pragma: no cover - compiled
    """Min over (axis, φ₀) of the χ² of the module docstring, for every (pole, rate) of one batch.

    S_yB, S_BB : (K, n_a, n_p, n_node, M) the curves' tables; S_yy (K,); relative (K,) bool; node_of (K, n_ω) the node of
    each rate; shift (K, n_ω) the curve's mid-time phase ω t̄_k in grid steps, in [0, M), read at the nearest 1/N_FRAC step
    (:func:`_fractional_tables`). Out: chi2 (n_p, n_ω) and best (n_p, n_ω) = axis · M + phase index. Numba, the poles shared
    among the cores (``prange``); at each (pole, rate, axis) the M phases are summed as contiguous rows (vectorised) before
    the ratios (a read per (phase, curve) with a modulo cost 3.9–5.5× as much on tables of the screen's sizes).
    """
    K, n_a, n_p, _, M = S_yB.shape
    n_w = node_of.shape[1]
    Y, Q = _fractional_tables(S_yB, S_BB, S_yy, N_FRAC)
    cal_yy = 0.0
    for k in range(K):
        if not relative[k]:
            cal_yy += S_yy[k]
    base = np.empty((n_w, K), np.int64)
    sub = np.empty((n_w, K), np.int64)
    for w in range(n_w):
        for k in range(K):
            x = int(np.round(shift[k, w] * N_FRAC))
            base[w, k] = (x // N_FRAC) % M
            sub[w, k] = x % N_FRAC
    for p in numba.prange(n_p):
        yb_c, bb_c, c2 = np.empty(M), np.empty(M), np.empty(M)
        for w in range(n_w):
            lowest, arg = np.inf, -1
            for a in range(n_a):
                _phase_row(Y, Q, S_yy, relative, cal_yy, node_of[:, w], base[w], sub[w], a, p, yb_c, bb_c, c2)
                for j in range(M):
                    if c2[j] < lowest:
                        lowest, arg = c2[j], a * M + j
            chi2[p, w] = lowest
            best[p, w] = arg


@numba.njit(cache=True, inline="always")
def _phase_row(Y, Q, S_yy, relative, cal_yy, node, base, sub, a, p, yb_c, bb_c, c2):  # pragma: no cover - compiled
    """c2 (M,) ← the χ² (module docstring) at axis a, pole p and the M grid phases j, curve k's statistics read from ``Y``, ``Q``
    (:func:`_fractional_tables`) at node ``node[k]``, sub-step ``sub[k]`` and grid phases ``base[k] + j`` (a contiguous row);
    yb_c, bb_c (M,) scratch for the calibrated curves' sums."""
    M = c2.size
    yb_c[:] = 0.0
    bb_c[:] = 0.0
    c2[:] = cal_yy
    for k in range(Y.shape[0]):
        y_row = Y[k, a, p, node[k], sub[k], base[k]:base[k] + M]
        b_row = Q[k, a, p, node[k], sub[k], base[k]:base[k] + M]
        if relative[k]:  # its own scale: χ²_k = S_yy,k − max(S_yB,k, 0)² / S_BB,k
            for j in range(M):
                t = y_row[j] if y_row[j] > 0.0 and b_row[j] > 0.0 else 0.0
                c2[j] += S_yy[k] - t * t / (b_row[j] if b_row[j] > 0.0 else 1.0)
        else:
            for j in range(M):
                yb_c[j] += y_row[j]
                bb_c[j] += b_row[j]
    for j in range(M):  # branch-free, so that it vectorises
        t = yb_c[j] if yb_c[j] > 0.0 and bb_c[j] > 0.0 else 0.0
        c2[j] -= t * t / (bb_c[j] if bb_c[j] > 0.0 else 1.0)


def screen_phases(data, model, poles_I: np.ndarray, axes_T: np.ndarray, omegas: np.ndarray, *, n_phases: int = 48,
                  drift_tol_rad: float = 0.1, n_table: int | None = None, batch: int = 16, progress=None) -> PhaseScreen:
    """Screening χ² of a known shape (``model.basis`` with one column) over poles × axes × rates × phases (module docstring).

    data : the stacked curves of :mod:`.search` (``t_s``, ``sun_I``, ``obs_I``, ``y``, ``sigma``, ``g``, ``curve``, ``relative``).
    poles_I : (n_p, 3) unit poles; axes_T : (n_a, 3) unit body spin axes; omegas : (n_ω,) sidereal rates, rad/s (their step
    should turn the phase at the curves' mid-times by at most one phase step, 2π/n_phases: the screen is read there only).
    n_table : phases of each sample's brightness table (:func:`_curve_tables`; default n_phases: exact for a curve with one rate
    node; with several, read by the cubic between table phases. Twice n_phases, the former default for several nodes, cost
    1.6–1.9× as much and moved the screen's χ² by a median 0.5 % on a 3-night vespa object of ``benchmarks/bench_inversion.py``,
    the truth's pole first among 41 with both).
    progress : called as ``progress(n_done, n_total)`` over pole batches.
    """
    if int(n_phases) < 4:
        raise ValueError(f"n_phases: {n_phases}: expected an integer >= 4")
    M = int(n_phases)
    if n_table is not None and int(n_table) < 4:
        raise ValueError(f"n_table: {n_table}: expected an integer >= 4")
    phases = np.arange(M) * 2 * np.pi / M
    C_TA = np.stack([axis_frame(a) for a in np.atleast_2d(axes_T)])
    K = data.relative.size
    curves, node_of, shift, S_yy = [], np.empty((K, omegas.size), np.int64), np.empty((K, omegas.size)), np.empty(K)
    for k in range(K):
        i = np.flatnonzero(data.curve == k)
        t = data.t_s[i]
        t_mid = 0.5 * (t.min() + t.max())
        nodes, node_of[k] = rate_nodes(omegas, 0.5 * np.ptp(t), drift_tol_rad)
        shift[k] = np.mod(omegas * t_mid, 2 * np.pi) * (M / (2 * np.pi))
        w = data.g[i] / data.sigma[i] ** 2
        S_yy[k] = float(np.sum((data.y[i] / data.sigma[i]) ** 2))
        curves.append((i, t - t_mid, nodes, w * data.y[i], w * data.g[i]))
    n_nodes = max(c[2].size for c in curves)
    n_p = poles_I.shape[0]
    chi2 = np.empty((n_p, omegas.size))
    best = np.empty((n_p, omegas.size), np.int64)
    for lo in range(0, n_p, batch):
        C_IP = pole_frame(poles_I[lo:lo + batch])
        S_yB = np.zeros((K, C_TA.shape[0], C_IP.shape[0], n_nodes, M))
        S_BB = np.ones_like(S_yB)
        for k, (i, t_c, nodes, wy, wB) in enumerate(curves):
            L = M if n_table is None else int(n_table)
            S_yB[k, :, :, :nodes.size], S_BB[k, :, :, :nodes.size] = _curve_tables(model, data.sun_I[i], data.obs_I[i], t_c, wy, wB, C_IP,
                                                                                   C_TA, nodes, phases, L)
        _combine(S_yB, S_BB, S_yy, data.relative, node_of, shift, chi2[lo:lo + batch], best[lo:lo + batch])
        if progress is not None:
            progress(min(lo + batch, n_p), n_p)
    axis_index, phase_index = np.divmod(best, M)
    return PhaseScreen(chi2, axis_index, phases[phase_index])
