"""Pole and period search, then refinement: :func:`invert`.

The model of sample i of curve k is ``F_i = s_k · g_i · (B(ŝ_T, ô_T)_i · w)``: B the shape model's basis
(``model.basis(sun_T, obs_T)``, (N, m), W/sr), w ≥ 0 its linear parameters, ``g_i = (1 au/d☉)²/ρ²``
(:func:`lightcurves.render.observed_flux`) and ``s_k`` = 1 for a calibrated curve, a free positive
scale for a relative one. The body-frame directions follow from the spin state (:mod:`.spin`).

Variable projection (Golub & Pereyra, SIAM J. Numer. Anal. 10, 1973): at each spin state the linear
parameters are solved in closed form and only the spin state is searched. The product ``s_k·w`` is
bilinear; writing ``u_k = 1/s_k`` the residual ``g B w − u_k y`` is linear in (w, u), solved by
non-negative least squares (Lawson & Hanson 1974, scipy ``nnls``); the relative data are then put on
the model's scale and the solve repeated, after which the exact χ² follows with each ``s_k`` in closed
form. With no calibrated curve the first relative curve's ``u`` is fixed to 1 (the overall scale is
the shape's).

1. Screening grid: poles on a Fibonacci lattice of the whole sphere (``pole_step_deg``), sidereal rates
   on a uniform grid over ``period_range_s`` with step ``Δω = π/(2 T)`` (T the data's time span: the
   phase drifts by at most a quarter turn across the span between neighbours, i.e. ΔP ≈ P²/(4T)),
   on at most ``n_grid_samples`` samples per curve.
   * Unknown shape: a coarse convex model (``screen_facets`` normals, unconstrained ridge least squares, batched
     over all poles): a convex model absorbs the rotational phase and the body axis, so the grid has only pole and period.
   * Known shape (``basis`` has one column): the shape itself (a merged copy within :data:`SCREEN_COPY_REL_ERROR` of it,
     :func:`screen_copy`) over
     pole × body axis (``axes_T``) × rate × phase (``n_phases``), from per-curve phase tables (:mod:`.phase_screen`),
     the rate step refined so that the phase at the span's ends moves by at most one phase step; the poles coarse to fine
     (:func:`_known_screen`: a lattice at twice the spacing, then the full lattice around its best minima). A convex stand-in
     ranks poles by another likelihood: on the SC3 seed-1 campaign it led the refinement 119° off (χ² 1.98e5, the
     truth's 5.85e4). The known-shape screening stages (screen, alias and half-turn trials) weigh the grid samples with
     σ² + (ε y)², ε = ``screen_rel_error`` (:func:`_tempered`): their coarse model and grid steps are model error.
2. For a known shape, at each candidate pole: a fit from the screen's (rate, phase, axis), then brief fits along the
   comb of cycle-count aliases between nights (which the screen cannot rank) and at the best rate minima of that pole
   (:func:`_alias_trials`), and the ``n_periods_per_pole`` best of those go on, to a fit with the full model on the
   refinement subsample if within :data:`REFINE_REACH` (scaled Δχ²) of the best of all poles, or at the best one's pole
   (:func:`_trials_to_fit`: the screen's model cannot rank one pole's aliases); each such fit is also started from its
   look-alikes — turned by quarters about the spin axis, turned over, and half an alias off (:func:`_look_alike_fit`). Then
   (:func:`_known_shape_optima`) the best's cycle-count aliases are ranked by the full model and those within
   :data:`COMB_KEEP` kept (:func:`_comb_fits`), and each kept optimum is also turned over (:func:`_half_turned_fits`) and
   tried about the other principal axes and, if it stopped tilted, about its own nearest one (:func:`_other_axis_fits`), on
   untempered grid samples, once more from a new best that these reach. A best optimum whose χ²/dof still exceeds
   :data:`RETRY_CHI2_DOF` (another basin, not noise) goes through those stages again after fits from its frame tilted by
   a few degrees (:func:`_tilted_fits`) and the full model's rescreen of rate, body axis and phase at the (new) best's own
   pole (:func:`_rescreen_fits`); if it still does, the known shape is screened again at
   :data:`RETRY_REL_ERROR` and the search run from that screen's candidates too (:func:`_retried_optima`).
3. Refinement of the best local minima of the pole map with scipy ``least_squares`` (trust-region
   reflective) with the full model, first on ``n_refine_samples`` per curve, then — once per distinct
   optimum within :data:`REFINE_REACH` of the best — on all data, in the rotation-vector increment of the pole frame,
   the rate, and for a known shape the body axis (its Jacobian analytic: :meth:`_Problem.residuals_and_jacobian`);
   covariances from the Gauss–Newton Hessian of the profiled residuals; modes merged and weighted in :mod:`.posterior`.
   The most probable modes' combs of cycle-count aliases are then swept across the searched range, and each comb becomes
   one mode, moment-matched over its teeth, its evidence summed over them (:func:`_comb_moments`): the teeth of one pole
   can fit alike across the whole range, where one tooth's period σ is a thousandth of what the data know.
4. On request, the pole's profile likelihood at any pole or over its region (:mod:`.profile`): where the likelihood is a ridge
   or a plateau that the modes' Gaussians do not hold.

The fits of one stage (the candidate poles' alias trials, the subsample fits, the turned and other-axis trials, the
refinements on all data) are independent: ``workers`` threads run them at once (the facet kernel releases the GIL), and
each stage's results are taken in their order, so the result does not depend on ``workers``.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Iterable, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import astropy.units as u
import numpy as np
from astropy.time import Time
from scipy.optimize import least_squares, nnls
from scipy.spatial import cKDTree
from scipy.spatial.transform import Rotation
from threadpoolctl import threadpool_limits

from lightcurves.inversion.convex import ConvexModel, fibonacci_sphere
from lightcurves.inversion.data import InversionCurve
from lightcurves.inversion.phase_screen import PhaseScreen, screen_phases
from lightcurves.inversion.posterior import InversionResult, SpinSolution, distinct_modes, laplace_probabilities, posterior_scale, tangent_offset
from lightcurves.inversion.spin import SpinState, axis_frame, emission_time_s, pole_frame, unspin
from lightcurves.render import observed_flux

__all__ = ["invert", "profiled_chi2", "period_grid", "default_workers", "screen_copy"]

_PRINCIPAL_AXES = np.array([[0, 0, 1], [0, 0, -1], [1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0]], dtype=float)


@dataclass(frozen=True)
class _Data:
    """All curves stacked: (N,) arrays and (N, 3) directions; ``curve`` the curve index of each sample."""

    t_s: np.ndarray  #: emission times, s from ``epoch``
    sun_I: np.ndarray
    obs_I: np.ndarray
    y: np.ndarray
    sigma: np.ndarray
    g: np.ndarray  #: (1 au/d☉)²/ρ², m⁻²
    curve: np.ndarray
    relative: np.ndarray  #: (K,) bool
    epoch: Time

    def subset(self, idx) -> _Data:
        return _Data(self.t_s[idx], self.sun_I[idx], self.obs_I[idx], self.y[idx], self.sigma[idx], self.g[idx], self.curve[idx], self.relative, self.epoch)


def _stack(curves: Sequence[InversionCurve]) -> _Data:
    first = min((c.epoch for c in curves), key=lambda e: e.jd)
    t = np.concatenate([emission_time_s(c, first) for c in curves])
    mid = 0.5 * (t.min() + t.max())  # the epoch mid-span decorrelates phase and period
    epoch = first + mid * u.s
    g = np.concatenate([observed_flux(1.0, c.range_m, c.sun_distance_m) for c in curves])
    return _Data(t - mid, np.concatenate([c.sun_dir_I for c in curves]), np.concatenate([c.observer_dir_I for c in curves]),
                 np.concatenate([c.brightness for c in curves]), np.concatenate([c.sigma for c in curves]), g,
                 np.concatenate([np.full(len(c), k) for k, c in enumerate(curves)]), np.array([not c.calibrated for c in curves]), epoch)


def _relative_columns(data: _Data) -> tuple[np.ndarray, np.ndarray, int | None]:
    """Columns −y/σ (N, K_rel') of the free relative curves, the rhs y/σ (0 on relative rows), and the fixed curve (or None)."""
    rel_curves = np.flatnonzero(data.relative)
    fixed = None if (~data.relative).any() else int(rel_curves[0])
    free = [k for k in rel_curves if k != fixed]
    ys = data.y / data.sigma
    cols = np.stack([np.where(data.curve == k, -ys, 0.0) for k in free], axis=1) if free else np.zeros((data.y.size, 0))
    rhs = np.where(data.relative[data.curve] & (data.curve != fixed), 0.0, ys)
    return cols, rhs, fixed


def _scale_groups(data: _Data) -> np.ndarray:
    """(N,) the scale each sample shares with a one-column basis: 0 for every calibrated curve (one w), 1 + k for relative curve k."""
    return np.where(data.relative[data.curve], 1 + data.curve, 0)


def _one_column_solve(B: np.ndarray, data: _Data, dB: np.ndarray | None = None):
    """The profile of a one-column basis (a known shape) in closed form: (w (1,), s (K,), residuals (N,)[, Jacobian (N, n)]).

    Every calibrated curve shares w ≥ 0 and each relative curve k has its own product c_k = s_k w ≥ 0; with a = g B/σ and
    b = y/σ each group's scale is c = max(a·b, 0)/(a·a) and r = b − a c (the exact minimum over the scales). With no
    calibrated curve w is the first curve's c (its s = 1). Given dB (N, n), the derivative of the residuals along each
    column (the scale's own change included): dc = (da·b − 2c a·da)/(a·a) where c > 0, dr = −c da − a dc.
    """
    group = _scale_groups(data)
    n_groups = int(data.relative.size) + 1
    a, b = data.g * B[:, 0] / data.sigma, data.y / data.sigma
    ab, aa = np.bincount(group, a * b, n_groups), np.bincount(group, a * a, n_groups)
    c = np.where(aa > 0, np.maximum(ab, 0.0) / np.where(aa > 0, aa, 1.0), 0.0)
    r = b - a * c[group]
    k_w = 0 if (~data.relative).any() else 1 + int(np.flatnonzero(data.relative)[0])
    w = c[k_w]
    s = np.ones(data.relative.size)
    rel = np.flatnonzero(data.relative)
    s[rel] = c[1 + rel] / w if w > 0 else 0.0
    if dB is None:
        return np.array([w]), s, r
    da = (data.g / data.sigma)[:, None] * dB
    active = (c > 0)[:, None] / np.where(aa > 0, aa, 1.0)[:, None]
    dc = np.stack([np.bincount(group, da[:, k] * b, n_groups) - 2 * c * np.bincount(group, da[:, k] * a, n_groups) for k in range(da.shape[1])], 1) * active
    return np.array([w]), s, r, -c[group][:, None] * da - a[:, None] * dc[group]


def _linear_solve(B: np.ndarray, data: _Data) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Linear parameters w ≥ 0 (m,), per-curve scales s (K,) and whitened residuals (N,) for the basis B (N, m) (module docstring;
    one column: :func:`_one_column_solve`)."""
    M = data.g[:, None] * B
    m = B.shape[1]
    if m == 1:
        return _one_column_solve(B, data)
    y, sigma = data.y.copy(), data.sigma.copy()
    for _ in range(2):  # the second pass runs with the relative data on the model's scale
        scaled = _Data(data.t_s, data.sun_I, data.obs_I, y, sigma, data.g, data.curve, data.relative, data.epoch)
        cols, rhs, fixed = _relative_columns(scaled)
        A = np.hstack([M / sigma[:, None], cols])
        norm = np.linalg.norm(A, axis=0)
        norm[norm == 0] = 1.0
        x, _ = nnls(A / norm, rhs, maxiter=50 * A.shape[1])
        x /= norm
        w = x[:m]
        u = np.ones(data.relative.size)
        u[[k for k in np.flatnonzero(data.relative) if k != fixed]] = x[m:]
        if not np.all(u[data.relative] > 0):
            break
        y, sigma = y * u[data.curve], sigma * u[data.curve]
    model = M @ w
    s = np.ones(data.relative.size)
    for k in np.flatnonzero(data.relative):  # each relative curve's scale s: Σ((y − s F)/σ)² minimised in closed form
        i = data.curve == k
        den = np.sum((model[i] / data.sigma[i]) ** 2)
        s[k] = np.sum(data.y[i] * model[i] / data.sigma[i] ** 2) / den if den > 0 else 0.0
    return w, s, (data.y - s[data.curve] * model) / data.sigma


def _hat(v) -> np.ndarray:
    """[v]× (3, 3): the cross-product matrix, [v]× u = v × u."""
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def _exp_so3(v) -> np.ndarray:
    """Exp(v) (3, 3): the rotation by |v| about v (Rodrigues), its Taylor series below |v| = 1e-4 (scipy's ``Rotation`` costs
    ~50 µs a call, which the fits on 60 samples per curve made a tenth of the search)."""
    theta = float(np.sqrt(v[0] ** 2 + v[1] ** 2 + v[2] ** 2))
    K = _hat(v)
    if theta < 1e-4:
        return np.eye(3) + K + 0.5 * K @ K
    return np.eye(3) + np.sin(theta) / theta * K + (1 - np.cos(theta)) / theta**2 * K @ K


def _right_jacobian(v) -> np.ndarray:
    """J_r(v) (3, 3) of SO(3): Exp(v + dv) ≈ Exp(v) Exp(J_r(v) dv); J_r = I − (1 − cos θ)/θ² [v]× + (θ − sin θ)/θ³ [v]×²
    (Barfoot 2017, eq. 7.77a), its Taylor series below θ = 1e-4."""
    theta = float(np.sqrt(v[0] ** 2 + v[1] ** 2 + v[2] ** 2))
    K = _hat(v)
    if theta < 1e-4:
        return np.eye(3) - 0.5 * K + K @ K / 6.0
    return np.eye(3) - (1 - np.cos(theta)) / theta**2 * K + (theta - np.sin(theta)) / theta**3 * K @ K


class _Problem:
    """Whitened, profiled residuals as a function of the nonlinear parameters θ around a reference state.

    θ = (δ₁, δ₂[, δ₃], x_ω[, ε₁, ε₂]): δ the rotation vector (rad) applied to the pole frame C_IP₀ (in its own
    axes: δ₁, δ₂ tilt the pole, δ₃ turns the phase), ω = ω₀ + x_ω/τ (τ the half span, so x_ω is the phase
    drift in rad at the span's ends), ε a rotation of the body axis frame about its first two axes.
    """

    def __init__(self, data: _Data, model, C_IP0: np.ndarray, omega0: float, C_TA0: np.ndarray, fit_phase: bool, fit_axis: bool):
        self.data, self.model, self.C_IP0, self.omega0, self.C_TA0 = data, model, C_IP0, omega0, C_TA0
        self.fit_phase, self.fit_axis = fit_phase, fit_axis
        self.tau = max(np.abs(data.t_s).max(), 1.0)
        self.n = 3 + fit_phase + 2 * fit_axis
        self.analytic = hasattr(model, "basis_gradient")  # a one-column basis (known shape) with its rotation gradient
        self._last = None

    def unpack(self, theta) -> tuple[np.ndarray, float, np.ndarray]:
        theta = np.asarray(theta, dtype=float)
        delta = np.array([theta[0], theta[1], theta[2] if self.fit_phase else 0.0])
        j = 2 + self.fit_phase
        omega = self.omega0 + theta[j] / self.tau
        C_IP = self.C_IP0 @ _exp_so3(delta)
        C_TA = self.C_TA0
        if self.fit_axis:
            C_TA = C_TA @ _exp_so3([theta[j + 1], theta[j + 2], 0.0])
        return C_IP, omega, C_TA

    def directions(self, theta) -> tuple[np.ndarray, np.ndarray]:
        """Sun and observer unit directions (N, 3) in T at θ (:mod:`.spin`: s_T = C_TA R_z(φ)ᵀ C_IPᵀ s_I)."""
        C_IP, omega, C_TA = self.unpack(theta)
        phi = omega * self.data.t_s
        return unspin(phi, self.data.sun_I @ C_IP) @ C_TA.T, unspin(phi, self.data.obs_I @ C_IP) @ C_TA.T

    def solve(self, theta):
        return _linear_solve(self.model.basis(*self.directions(theta)), self.data)

    def residuals(self, theta) -> np.ndarray:
        if self.analytic:  # the value and the Jacobian in one pass of the model; least_squares asks for J at the same θ next
            r, J = self.residuals_and_jacobian(theta)
            self._last = (np.array(theta, dtype=float), J)
            return r
        return self.solve(theta)[2]

    def jac(self, theta) -> np.ndarray:
        """The Jacobian (N, n) for ``least_squares`` (from the last :meth:`residuals` call at the same θ, else computed)."""
        if self._last is not None and np.array_equal(self._last[0], theta):
            return self._last[1]
        return self.jacobian(theta)

    def jacobian(self, theta, step: float = 1e-5) -> np.ndarray:
        """The Jacobian (N, n) of the profiled residuals: analytic in the model (:meth:`residuals_and_jacobian`) when it has
        ``basis_gradient``, else central differences with ``step`` (the linear solve re-done at each point)."""
        if self.analytic:
            return self.residuals_and_jacobian(theta)[1]
        theta = np.asarray(theta, dtype=float)
        cols = []
        for k in range(self.n):
            e = np.zeros(self.n)
            e[k] = step
            cols.append((self.residuals(theta + e) - self.residuals(theta - e)) / (2 * step))
        return np.stack(cols, axis=1)

    def rotation_rates(self, theta) -> np.ndarray:
        """Ω (N, n, 3): the rotation vector in T by which θ_k turns each sample's directions, ∂s_T/∂θ_k = Ω_k × s_T (same for o_T).

        From s_T = C_TA R_z(φ)ᵀ C_IPᵀ s_I with C_IP = C_IP₀ Exp(δ), φ = ω t, ω = ω₀ + x_ω/τ, C_TA = C_TA₀ Exp(ε) and
        d Exp(v) = Exp(v) [J_r(v) dv]× (J_r the right Jacobian of SO(3); Barfoot, *State Estimation for Robotics*, 2017, eq. 7.77a):
        a pole-frame increment turns the directions by −C_TA R_z(φ)ᵀ J_r(δ) e_k, the rate by −a t/τ (a = C_TA e_z, the body spin
        axis) and an axis increment by C_TA J_r(ε) e_k.
        """
        theta = np.asarray(theta, dtype=float)
        C_IP, omega, C_TA = self.unpack(theta)
        delta = np.array([theta[0], theta[1], theta[2] if self.fit_phase else 0.0])
        phi = omega * self.data.t_s
        c, s_ = np.cos(phi), np.sin(phi)
        j = 2 + self.fit_phase
        out = np.empty((phi.size, self.n, 3))
        V = _right_jacobian(delta)[:, :j]  # columns J_r e_k, turned by R_z(φ)ᵀ, then by C_TA
        turned = np.empty((phi.size, j, 3))
        turned[..., 0] = c[:, None] * V[0] + s_[:, None] * V[1]
        turned[..., 1] = -s_[:, None] * V[0] + c[:, None] * V[1]
        turned[..., 2] = V[2]
        out[:, :j] = -turned @ C_TA.T
        out[:, j] = -np.outer(self.data.t_s / self.tau, C_TA[:, 2])
        if self.fit_axis:
            Je = _right_jacobian(np.array([theta[j + 1], theta[j + 2], 0.0]))
            out[:, j + 1:] = (C_TA @ Je[:, :2]).T[None]
        return out

    def residuals_and_jacobian(self, theta) -> tuple[np.ndarray, np.ndarray]:
        """Profiled residuals (N,) and their Jacobian (N, n) at θ from the model's ``basis_gradient``.

        The basis moves by ∂B/∂θ_k = ∇B · Ω_k (:meth:`rotation_rates`; ∇B the model's gradient under a rotation of both
        directions, eq. 2 of :class:`~lightcurves.inversion.known_shape.KnownShapeModel`), and the closed-form profile of
        :func:`_one_column_solve` with it: the full variable-projection derivative (Golub & Pereyra 1973), the scales' own
        change included.
        """
        B, dB_rot = self.model.basis_gradient(*self.directions(theta))
        _, _, r, J = _one_column_solve(B, self.data, np.einsum("ic,ikc->ik", dB_rot[:, 0], self.rotation_rates(theta)))
        return r, J

    def state(self, theta) -> SpinState:
        """The :class:`SpinState` of θ in the conventions of :mod:`.spin` (φ₀ = χ − ψ, see below)."""
        C_IP, omega, C_TA = self.unpack(theta)
        pole, axis = C_IP[:, 2], C_TA[:, 2]
        R = pole_frame(pole).T @ C_IP  # = R_z(χ)
        Q = axis_frame(axis).T @ C_TA  # = R_z(ψ); C_IT = PF R_z(χ + ωt − ψ) AFᵀ
        chi, psi = np.arctan2(R[1, 0], R[0, 0]), np.arctan2(Q[1, 0], Q[0, 0])
        return SpinState(pole, 2 * np.pi / omega, float((chi - psi) % (2 * np.pi)), self.data.epoch, axis)


def _pole_phase_frame(state: SpinState, epoch: Time) -> np.ndarray:
    """``C_IP`` (3, 3) of :class:`_Problem` for ``state`` with its phase carried to the data's ``epoch``: the pole frame turned by φ."""
    phase = state.phase_rad + state.rate_rad_s * (epoch - state.epoch).to_value("s")
    return pole_frame(state.pole_I) @ Rotation.from_rotvec([0.0, 0.0, phase]).as_matrix()


def profiled_chi2(curves: Sequence[InversionCurve], model, state: SpinState) -> tuple[float, np.ndarray, np.ndarray]:
    """χ² of the curves at a given spin state with the shape's linear parameters and the relative scales solved
    (the likelihood :func:`invert` maximises), with those parameters: (χ², w (m,), s (K,))."""
    curves = [curves] if isinstance(curves, InversionCurve) else list(curves)
    data = _stack(curves)
    w, s, r = _Problem(data, model, _pole_phase_frame(state, data.epoch), state.rate_rad_s, axis_frame(state.axis_T), False, False).solve(np.zeros(3))
    return float(r @ r), w, s


def period_grid(period_range_s: tuple[float, float], span_s: float, oversampling: float = 1.0) -> np.ndarray:
    """Sidereal rates (n,) rad/s uniform over ``period_range_s`` with step π/(2·span·oversampling) (module docstring)."""
    lo, hi = period_range_s
    w_lo, w_hi = 2 * np.pi / hi, 2 * np.pi / lo
    step = np.pi / (2 * max(span_s, 1.0) * oversampling)
    n = int(np.ceil((w_hi - w_lo) / step)) + 1
    return np.linspace(w_lo, w_hi, n)


def _subsample(data: _Data, per_curve: int) -> _Data:
    idx = []
    for k in range(data.relative.size):
        i = np.flatnonzero(data.curve == k)
        idx.append(i if i.size <= per_curve else i[np.round(np.linspace(0, i.size - 1, per_curve)).astype(int)])
    return data.subset(np.concatenate(idx))


#: The screening stages' relative model error ε (:func:`_tempered`, ``invert(screen_rel_error=)``): what the screen's node nearest
#: the truth gets wrong. That node is off the truth by the lattice (pole up to ~4° off at 7.5°, median 3°) and the phase
#: grid (±3.75° at 48 phases), and evaluated with the coarse copy. Measured over 4000 random attitudes and Sun/observer pairs
#: (phase angle < 60°), rms of the relative brightness error: atlas-centaur 0.11–0.12, box-wing 0.09–0.11, vespa 0.20–0.28
#: (the coarse copy alone 0.005, 0.03, 0.12; the median error is 0.03–0.06, the rms is the glints'); 0.1, the two
#: shapes' value. The 0.03 used before (the coarse copy's error alone) left that node out-ranked on 2 of 93 objects of
#: ``benchmarks/bench_inversion.py`` whose search then ended 165–170° off (a five-night atlas-centaur, Δχ² −12599 at the
#: truth; a two-night box-wing, −11246): the truth's lattice pole ranked 70th and 59th of ~330 in the screen (79th and 7th
#: with 0.1), and with 0.1 both searches end at the truth's optimum (pole 0.15° and 0.01° off).
SCREEN_REL_ERROR = 0.1


#: the screening copy's largest rms relative brightness error against the full model (:func:`screen_copy`): it adds in
#: quadrature to the screening tolerance :data:`SCREEN_REL_ERROR`, by at most 8 % at 0.04.
SCREEN_COPY_REL_ERROR = 0.04
#: the facet counts :func:`screen_copy` tries, fewest first
SCREEN_COPY_FACETS = (48, 96, 192, 384)


def screen_copy(model, max_facets: int | None = None):
    """The known shape's screening copy: ``model.coarse(max_facets)``, or with ``max_facets`` None the copy of the fewest
    :data:`SCREEN_COPY_FACETS` whose rms relative brightness error against ``model`` is within :data:`SCREEN_COPY_REL_ERROR`
    (else the model itself), over 2000 fixed random Sun and observer directions at phase angles below 60° (samples fainter
    than 5 % of the median left out). A model without ``coarse`` is its own copy.

    Measured (2026-11-30) at 48 / 96 / 192 / 384 facets: atlas-centaur 0.004 / 0.002 / 0.000, box-wing 0.030 / 0.003 / 0.000,
    vespa 0.140 / 0.051 / 0.029 / 0.013 (its 7680 curved facets: a merged facet glints where the shell does not). With 48
    facets vespa's screen ranked the lattice pole nearest the truth 325th and 328th of ~330 on two objects of
    ``benchmarks/bench_inversion.py`` (schedule indices 65, 27) whose search then ended 68° and 90° off; with 192, 72nd and
    57th, and the searches ended at χ² 1.1 below and 25 above the truth's (31 and 202 above before), for the same CPU.
    """
    if not hasattr(model, "coarse"):
        return model
    if max_facets is not None:
        return model.coarse(max_facets)
    rng = np.random.default_rng(0)
    sun, obs = (v / np.linalg.norm(v, axis=1, keepdims=True) for v in rng.normal(size=(2, 4000, 3)))
    near = np.einsum("ij,ij->i", sun, obs) > np.cos(np.radians(60.0))
    sun, obs = sun[near][:2000], obs[near][:2000]
    full = model.basis(sun, obs)[:, 0]
    lit = full > 0.05 * np.median(full)
    for n in SCREEN_COPY_FACETS:
        copy = model.coarse(n)
        if np.sqrt(np.mean(((copy.basis(sun, obs)[:, 0] - full)[lit] / full[lit]) ** 2)) <= SCREEN_COPY_REL_ERROR:
            return copy
    return model


def _tempered(data: _Data, rel_error: float) -> _Data:
    """The data with σ² + (ε y)² for σ²: the search stages that run a coarse model on a coarse grid (the screen, the alias and
    half-turn trials) treat their own model error ε (relative) as noise, so that their χ² ranks basins, not grid offsets."""
    if rel_error == 0:
        return data
    return _Data(data.t_s, data.sun_I, data.obs_I, data.y, np.hypot(data.sigma, rel_error * data.y), data.g, data.curve, data.relative, data.epoch)


def _batched_nnls(G: np.ndarray, h: np.ndarray, iterations: int) -> np.ndarray:
    """min ½xᵀGx − hᵀx, x ≥ 0, for a stack of normal equations G (p, q, q), h (p, q), vectorised over p.

    An active-set iteration in the manner of Lawson & Hanson (1974) without their inner feasibility line
    search: solve on the free set, drop the variables that come out negative, free the bound ones whose
    gradient points inwards; ``iterations`` rounds, then two sweeps of projected Gauss–Seidel. Not exact on
    every problem, which is why it only ranks the screening grid (the refinement uses scipy ``nnls``).
    """
    q = h.shape[1]
    eye = np.eye(q, dtype=bool)
    free = np.ones_like(h, dtype=bool)
    x = np.zeros_like(h)
    for _ in range(iterations):
        mask = free[:, :, None] & free[:, None, :]
        x_new = np.linalg.solve(np.where(mask, G, eye), np.where(free, h, 0.0)[..., None])[..., 0]
        x = np.maximum(x_new, 0.0)
        grad = np.einsum("pij,pj->pi", G, x) - h
        free = (x_new > 0) | ((x == 0) & (grad < -1e-9 * np.abs(h).max(axis=1, keepdims=True)))
    for _ in range(2):
        for j in range(q):
            x[:, j] = np.maximum(0.0, x[:, j] - (np.einsum("pq,pq->p", G[:, j, :], x) - h[:, j]) / G[:, j, j])
    return x


def _screen(data: _Data, model, poles_I: np.ndarray, omegas: np.ndarray, progress, iterations: int = 8) -> np.ndarray:
    """Screening χ² (n_pole, n_ω) of the convex ``model`` with non-negative areas and scales (:func:`_batched_nnls`)."""
    C_IP = pole_frame(poles_I)
    s_P = np.einsum("ni,pij->pnj", data.sun_I, C_IP)
    o_P = np.einsum("ni,pij->pnj", data.obs_I, C_IP)
    # relative curves put on the calibrated curves' median model scale (or 1) so their weights are right
    y, sigma = data.y.copy(), data.sigma.copy()
    cal = ~data.relative[data.curve]
    ref = np.median(data.y[cal] / data.g[cal]) if cal.any() else 1.0
    for k in np.flatnonzero(data.relative):
        i = data.curve == k
        f = ref * np.median(data.g[i]) / np.median(y[i])
        y[i], sigma[i] = y[i] * f, sigma[i] * f
    cols, rhs, _ = _relative_columns(_Data(data.t_s, data.sun_I, data.obs_I, y, sigma, data.g, data.curve, data.relative, data.epoch))
    n_p, n_s = poles_I.shape[0], data.t_s.size
    out = np.empty((n_p, omegas.size))
    for j, omega in enumerate(omegas):
        phi = omega * data.t_s
        B = model.basis(unspin(phi, s_P).reshape(-1, 3), unspin(phi, o_P).reshape(-1, 3)).reshape(n_p, n_s, -1)
        A = np.concatenate([B * (data.g / sigma)[None, :, None], np.broadcast_to(cols, (n_p,) + cols.shape)], axis=2)
        At = A.transpose(0, 2, 1)
        G = np.matmul(At, A)
        d = np.sqrt(np.einsum("pii->pi", G))  # Jacobi scaling: unit diagonal for the coordinate descent
        d[d == 0] = 1.0
        Gs = G / (d[:, :, None] * d[:, None, :])
        p_idx, j_idx = np.nonzero(np.einsum("pii->pi", G) == 0)
        Gs[p_idx, j_idx, j_idx] = 1.0  # facets never lit and seen: zero columns, their areas stay 0
        x = _batched_nnls(Gs, np.matmul(At, rhs) / d, iterations) / d
        out[:, j] = np.sum((np.matmul(A, x[..., None])[..., 0] - rhs) ** 2, axis=1)
        if progress is not None:
            progress(j + 1, omegas.size)
    return out


def _known_screen(grid: _Data, model, poles: np.ndarray, turn: np.ndarray, axes, omegas, n_phases: int, n_seeds: int, progress
                  ) -> tuple[np.ndarray, PhaseScreen]:
    """The known-shape screen (:mod:`.phase_screen`) coarse to fine in pole: (poles (n, 3), their screen).

    First a Fibonacci lattice of a quarter of ``poles`` (twice the spacing, turned by the same ``turn``), then the
    lattice ``poles`` within one coarse spacing of the ``n_seeds`` best local minima of the coarse map; both sets are
    returned. The screen's cost is linear in the number of poles (about 0.4 of the full lattice's at 7.5° and 6 candidates).
    Measured against the full lattice: the same basin on a 3 × 600-sample atlas-centaur object (optima 0.01° apart, Δχ² 1.3
    of 1860) and the same optimum on the SC3 seed-1 campaign (pole 0.89° off, χ² 56186). ``progress(fraction)`` over both stages.
    """
    n_fine = poles.shape[0]
    coarse = fibonacci_sphere(max(n_fine // 4, 12)) @ turn.T
    first = screen_phases(grid, model, coarse, axes, omegas, n_phases=n_phases,
                          progress=None if progress is None else (lambda j, n: progress(0.5 * j / n)))
    spacing = np.sqrt(4 * np.pi / coarse.shape[0])  # rad
    seeds = coarse[_local_minima(coarse, first.chi2.min(axis=1))[:n_seeds]]
    near = cKDTree(poles).query_ball_point(seeds, 2 * np.sin(spacing / 2))
    fine = poles[np.unique(np.concatenate([np.asarray(i, dtype=int) for i in near]))] if len(seeds) else np.zeros((0, 3))
    second = screen_phases(grid, model, fine, axes, omegas, n_phases=n_phases,
                           progress=None if progress is None else (lambda j, n: progress(0.5 + 0.5 * j / n)))
    if progress is not None and not len(fine):
        progress(1.0)
    return np.vstack([coarse, fine]), PhaseScreen(*(np.concatenate([getattr(first, f), getattr(second, f)]) for f in ("chi2", "axis_index", "phase_rad")))


def _local_minima(poles_I: np.ndarray, values: np.ndarray, k: int = 7) -> np.ndarray:
    """Indices of poles whose value is ≤ that of their k − 1 nearest neighbours, by increasing value."""
    _, nb = cKDTree(poles_I).query(poles_I, k=k)
    is_min = np.all(values[:, None] <= values[nb], axis=1)
    idx = np.flatnonzero(is_min)
    return idx[np.argsort(values[idx])]


def _period_minima(row: np.ndarray, n: int) -> np.ndarray:
    """Up to ``n`` indices of local minima of a χ²(ω) row, best first."""
    left = np.r_[np.inf, row[:-1]]
    right = np.r_[row[1:], np.inf]
    idx = np.flatnonzero((row <= left) & (row <= right))
    return idx[np.argsort(row[idx])][:n]


def default_workers() -> int:
    """The cores this process may run on (its CPU affinity), the default ``workers`` of :func:`invert`."""
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1


def _each(fn: Callable, items: Iterable, workers: int) -> Iterable:
    """``fn`` of each item in order, on up to ``workers`` threads (the module docstring), yielded as each becomes available."""
    items = list(items)
    if workers <= 1 or len(items) < 2:
        yield from map(fn, items)
        return
    # one BLAS thread each: the fits' small LAPACK calls (least_squares' SVD of an N × 6 Jacobian) from several threads
    # into a multi-threaded OpenBLAS wait on each other
    with threadpool_limits(limits=1, user_api="blas"), ThreadPoolExecutor(min(workers, len(items))) as pool:
        yield from pool.map(fn, items)


def _fit(problem: _Problem, max_nfev: int) -> tuple[_Problem, float]:
    """Least-squares fit of θ from 0, returned re-centred at the optimum (θ = 0 there) with its χ²."""
    fit = least_squares(problem.residuals, np.zeros(problem.n), jac=problem.jac if problem.analytic else "2-point", method="trf", x_scale=1.0,
                        diff_step=1e-6, max_nfev=max_nfev)
    C_IP, omega, C_TA = problem.unpack(fit.x)
    return _Problem(problem.data, problem.model, C_IP, omega, C_TA, problem.fit_phase, problem.fit_axis), 2.0 * float(fit.cost)


def _same_optimum(a: _Problem, b: _Problem) -> bool:
    """Two re-centred fits at the same optimum: poles within 1°, phase drift between their rates < 0.2 rad, same body axis."""
    return (a.C_IP0[:, 2] @ b.C_IP0[:, 2] > np.cos(np.radians(1.0)) and abs(a.omega0 - b.omega0) * a.tau < 0.2
            and a.C_TA0[:, 2] @ b.C_TA0[:, 2] > np.cos(np.radians(1.0)))


def _mid_times(data: _Data) -> np.ndarray:
    """The mid-times t̄_k (s) of the curves that have samples in ``data``."""
    return np.array([0.5 * (t.min() + t.max()) for t in (data.t_s[data.curve == k] for k in range(data.relative.size)) if t.size])


def _alias_phase_shift(data: _Data, d_omega: float) -> float:
    """The epoch phase change (rad) that keeps a rate change ``d_omega`` from turning the body at the curves' mid-times t̄_k:
    −arg Σ_k n_k exp(i δω t̄_k), n_k the curve's samples (the circular mean; exact for two curves, whose cycle-count
    aliases δω = 2πn/(t̄₂ − t̄₁) turn both by πn about a mid-span epoch: without it every odd alias started half a turn off)."""
    counts = np.bincount(data.curve, minlength=data.relative.size)
    return float(-np.angle(np.sum(counts[counts > 0] * np.exp(1j * d_omega * _mid_times(data)))))


#: the rates the retry of a misfit search (:func:`_retried_optima`) tries between two teeth of :func:`_alias_trials`' comb: at
#: k/SUB_TEETH of a tooth from the first fit, k = 1 … SUB_TEETH − 1
SUB_TEETH = 4


def _alias_trials(grid: _Data, screen_model, pole_I, omegas, row, phase_rad, axes_T, n_periods: int, n_aliases: int, sub_teeth: int = 1
                  ) -> list[tuple[float, _Problem]]:
    """The ``n_periods`` best fits (χ², problem) of the screen's model on its samples ``grid`` at one screened pole of a known
    shape, over its period aliases; :func:`invert` fits those within reach of the best of all poles with the full model.

    The first fit is also tried with the body half-turned (:func:`_half_turns`, 48 evaluations each) and the better goes on: a
    box-wing night whose screen gave the wrong sign of the axis at the candidate pole 7° from the truth ended out of reach
    of the kept optima's own half-turns (χ² 251.8, pole 175° off, against the truth's 153.3).

    Nights days apart leave cycle-count aliases of the rate (ω and ω + 2π n/Δt give the same phase at every night's
    mid-time) that the screen cannot rank: they differ by the phase drift within each night and, through the sidereal–synodic
    difference, by the pole, which a brief fit moves. So: fit from the screen's best (rate, phase, axis) of this pole with the
    screen's model on its samples ``grid``; from that fit's pole, epoch phase (:func:`_alias_phase_shift`) and axis, fit again
    briefly (48 evaluations) on the comb ω₁ + 2π n/Δt (Δt the spread of the curves' mid-times) over the rate range: χ² is
    smooth in n (the pole error that absorbs an alias grows with |n − n_true|), so every stride-th tooth (8 in all), then
    the teeth at half that stride on both sides of the best, and so on down to its neighbours; and at the ``n_aliases`` best
    local minima of the screen's χ²(ω) ``row`` not tried yet, at most 4 (with three nights or more only some teeth keep every
    night's phase, which the screen sees). (SC3 seed 1: one start per pole ended on an alias 0.6 % off with χ² 9.4e4 vs
    5.9e4. A two-night atlas-centaur object of ``benchmarks/bench_inversion.py``, 61 teeth: the screen's row minima at the
    candidate pole left out n = −4 … 4 about the truth, and the search ended on n = 5, χ² 2342 against the truth's 318.5.)
    The comb keeps the nights' relative phase of the first fit, which the screen's model can get wrong. With ``sub_teeth``
    > 1 (the retry of a misfit search, :func:`_retried_optima`), the rates 1/sub_teeth … of a tooth from the first fit
    (relative phases a quarter, a half, three quarters of a turn apart with 4) are fitted briefly too before the comb, and
    the comb walks from the best of them (a two-night box-wing of the benchmark, schedule index 152: the first fit 0.09
    cycles/day, 94° of relative phase, off every tooth of the truth's comb; the search ended 94° off at χ² 12620 against the
    truth's 284). Not on the first search: on a two-night vespa of the development draws (seed 9013) the comb from a
    sub-tooth left out the optimum that the first fit's comb reached (χ² 253.4 against 251.4) and the search took 4× the CPU.
    """
    iw = int(np.argmin(row))
    start = pole_frame(pole_I) @ Rotation.from_rotvec([0.0, 0.0, phase_rad[iw]]).as_matrix()
    first, chi2 = _fit(_Problem(grid, screen_model, start, omegas[iw], axis_frame(axes_T[iw]), True, True), 360)
    trials = [(chi2, first)]
    for C_TA in _half_turns(first.C_TA0):  # the body turned over (:func:`_half_turns`): the comb walks from the better one
        trials.append(_fit(_Problem(grid, screen_model, first.C_IP0, first.omega0, C_TA, True, True), 48)[::-1])
    chi2, first = min(trials, key=lambda t: t[0])
    tried: dict[float, float] = {}

    def trial(omega: float) -> float:
        if not any(abs(omega - o) * first.tau < 0.5 for o in [first.omega0, *tried]):
            start = first.C_IP0 @ Rotation.from_rotvec([0.0, 0.0, _alias_phase_shift(grid, omega - first.omega0)]).as_matrix()
            fit, c = _fit(_Problem(grid, screen_model, start, omega, first.C_TA0, True, True), 48)
            trials.append((c, fit))
            tried[omega] = c
        return tried.get(omega, np.inf)

    mids = _mid_times(grid)
    spacing = 2 * np.pi / max(np.ptp(mids), 1e-9)
    if np.ptp(mids) > 0:
        for q in range(1, sub_teeth):
            trial(first.omega0 + spacing * q / sub_teeth)
        chi2_sub, fit_sub = min(trials, key=lambda t: t[0])
        if chi2_sub < chi2:
            chi2, first = chi2_sub, fit_sub
    n = np.arange(np.ceil((omegas[0] - first.omega0) / spacing), np.floor((omegas[-1] - first.omega0) / spacing) + 1)
    teeth = first.omega0 + spacing * n[n != 0] if np.ptp(mids) > 0 else np.zeros(0)
    if teeth.size:
        stride = max(1, int(np.ceil(teeth.size / 8)))
        best = min(range(stride // 2, teeth.size, stride), key=lambda j: trial(teeth[j]))
        while stride > 1:
            stride = max(1, stride // 2)
            best = min((j for j in (best - stride, best, best + stride) if 0 <= j < teeth.size), key=lambda j: trial(teeth[j]))
        for j in (best - 1, best + 1):
            if 0 <= j < teeth.size:
                trial(teeth[j])
    extra = [omegas[jw] for jw in _period_minima(row, n_aliases)]
    for omega in [o for o in extra if not any(abs(o - t) * first.tau < 0.5 for t in [first.omega0, *tried])][:4]:
        trial(omega)
    return sorted(trials, key=lambda t: t[0])[:n_periods]


#: Δχ² (scaled by max(1, χ²_min/dof)) on the refinement subsample beyond which a fit is not polished on all data: its
#: Laplace weight relative to the best is below e^−25 (:mod:`.posterior`) unless its covariance volume is e^25 times
#: larger, and on all data (more samples) its Δχ² grows. On a 3 × 600-sample atlas-centaur object of
#: ``benchmarks/bench_inversion.py`` 12 of the 13 distinct optima polished without it were beyond it on all data (the
#: nearest at Δχ²/s ≈ 670, probability 0 in :mod:`.posterior`).
REFINE_REACH = 50.0


def _within_reach(coarse: list[tuple[float, _Problem]], n_free: int) -> list[tuple[float, _Problem]]:
    """The (χ², fit) pairs of the subsample fits within :data:`REFINE_REACH` of the best, best first; ``n_free`` the
    subsample's size less its linear parameters (the dof before the fit's own parameters)."""
    ranked = sorted(coarse, key=lambda c: c[0])
    if not ranked:
        return ranked
    chi2_min, best = ranked[0]
    scale = max(1.0, chi2_min / max(n_free - best.n, 1))
    return [c for c in ranked if (c[0] - chi2_min) / scale <= REFINE_REACH]


def _trials_to_fit(per_pole: list[list[tuple[float, _Problem]]], n_free: int) -> list[_Problem]:
    """The alias trials (:func:`_alias_trials`, one list per candidate pole) that go on to a fit with the full model: those
    within :data:`REFINE_REACH` of the best, and every one of the best trial's pole whatever its χ².

    The screen's coarse model cannot rank the cycle-count aliases of one pole: they differ by a phase drift within each night
    that its model error also makes. On a four-night box-wing object of ``benchmarks/bench_inversion.py`` (χ² on the grid
    samples for the teeth n = +1, +2, 0 about the truth: 940, 1009, 1176; reach 4.0 × 50) the truth's tooth was left out by
    236 and the search ended on n = +2 with χ² 8935 on all data against the truth's 465.
    """
    ranked = _within_reach([t for pole in per_pole for t in pole], n_free)
    if not ranked:
        return []
    best_pole = next(pole for pole in per_pole if any(t[1] is ranked[0][1] for t in pole))
    chosen = [fit for _, fit in ranked]
    return chosen + [fit for _, fit in best_pole if not any(fit is c for c in chosen)]


def _look_alike_fit(chi2: float, fit: _Problem) -> tuple[float, _Problem]:
    """(χ², fit), or the fit from the best start among the fit's look-alikes that one evaluation each puts below ``chi2``,
    when that fit ends lower.

    The look-alikes, none of which a fit reaches by itself: the body turned by a quarter, half or three quarters of a turn
    about the spin axis (a near four-fold look), turned over (:func:`_half_turns`: a near two-fold look about an axis ⟂ the
    spin axis), and both, each also at the half cycle-count aliases ω ± π/Δt (Δt the spread of the curves' mid-times, the
    epoch phase kept at them: :func:`_alias_phase_shift`), which turn the last night by half a turn against the first.
    The screen's coarse copy cannot tell these apart: on a four-night box-wing object of ``benchmarks/bench_inversion.py``
    the fit from the truth's alias ended at χ² 11164 on the refinement samples (the truth's 465); a quarter turn of its
    phase gave 5179 unfitted and 454 fitted, 0.09° from the true pole. On a two-night box-wing (spin about −x) the screen's
    best fits at the lattice pole 4.8° from the truth spun about +x half an alias off (χ² 13761 on the refinement samples
    against the truth's 287) and the search ended 162° off.
    """
    mids = _mid_times(fit.data)
    half = np.pi / np.ptp(mids) if np.ptp(mids) > 0 else 0.0
    rates = [0.0, -half, half] if half else [0.0]
    starts = []
    for d_omega in rates:
        C_IP = fit.C_IP0 @ Rotation.from_rotvec([0.0, 0.0, _alias_phase_shift(fit.data, d_omega)]).as_matrix()
        for C_TA in [fit.C_TA0, *_half_turns(fit.C_TA0)]:
            starts += [(C_IP @ Rotation.from_rotvec([0.0, 0.0, 0.5 * np.pi * q]).as_matrix(), fit.omega0 + d_omega, C_TA) for q in range(4)]
    starts = starts[1:]  # the first is the fit itself
    costs = []
    for start in starts:
        r = _Problem(fit.data, fit.model, *start, fit.fit_phase, fit.fit_axis).residuals(np.zeros(fit.n))
        costs.append(float(r @ r))
    j = int(np.argmin(costs))
    if costs[j] >= chi2:
        return chi2, fit
    turned, c = _fit(_Problem(fit.data, fit.model, *starts[j], fit.fit_phase, fit.fit_axis), 360)
    return (c, turned) if c < chi2 else (chi2, fit)


def _distinct(ranked: list[tuple[float, _Problem]]) -> list[tuple[float, _Problem]]:
    """The first (χ², fit) pair of each optimum among ``ranked`` (several starts reach one optimum), in their order."""
    kept: list[tuple[float, _Problem]] = []
    for chi2, fit in ranked:
        if not any(_same_optimum(fit, k) for _, k in kept):
            kept.append((chi2, fit))
    return kept


def _distinct_within_reach(coarse: list[tuple[float, _Problem]], n_free: int) -> list[tuple[float, _Problem]]:
    """The (χ², fit) pairs within :data:`REFINE_REACH` of the best, one per optimum (polish it once), best first."""
    return _distinct(_within_reach(coarse, n_free))


def _half_turns(C_TA: np.ndarray) -> list[np.ndarray]:
    """The body-to-spin frames ``C_TA`` turned half a turn about the two body axes perpendicular to the spin axis.

    Spinning about −a is spinning about a with the body turned by π about an axis b ⟂ a (``C_IT' = C_IT R_b(π)``, so
    ``C_TA' = R_b(π) C_TA``, same pole, phase and rate). A shape with a near two-fold symmetry about b shows the two
    almost alike, closer than the screen's phase and rate steps resolve, and a fit cannot turn the body over by itself.
    On a two-night box-wing object of ``benchmarks/bench_inversion.py`` the search found the pole (0.6° off) with −x
    at χ² 402 while the truth's optimum, with +x, was at 294; the screen at the true pole put ±x at 2682 and 1713
    (2538 and 2631 with four times the phases): the screen cannot rank them, the half-turned start can. For an exact
    symmetry (atlas-centaur about its long axis) the half-turned fit is the same light curve, no lower, and is dropped:
    keeping such twins doubled the optima polished on all data.
    """
    turned = []
    a = C_TA[:, 2]
    for b in np.eye(3):
        b = b - (b @ a) * a
        if np.linalg.norm(b) < 0.5:
            continue
        b /= np.linalg.norm(b)
        turned.append((2.0 * np.outer(b, b) - np.eye(3)) @ C_TA)
    return turned


def _lower_from(fit: _Problem, chi2: float, grid: _Data, starts, margin: float = -1.0, n_best: int | None = None) -> list[tuple[float, _Problem]]:
    """(χ², fit) on the fit's own samples from each start (C_IP, ω, C_TA) that ends below ``chi2`` + ``margin`` (by default
    lower by more than 1); each is first tried briefly on the grid samples (``48`` evaluations, as an alias trial) against
    ``fit`` there with the same margin, and only one that passes goes on (360 evaluations), so a symmetric twin costs a
    brief fit, not a full one. A positive ``margin`` is scaled, on each set of samples, by max(1, χ²/samples) of ``fit``
    there (its model error, as :data:`REFINE_REACH`). With ``n_best`` only that many of the passing brief fits, the lowest,
    go on."""
    on_grid = _Problem(grid, fit.model, fit.C_IP0, fit.omega0, fit.C_TA0, True, True)
    r0 = on_grid.residuals(np.zeros(on_grid.n))
    chi2_grid = float(r0 @ r0)
    grid_bound = chi2_grid + (margin * max(1.0, chi2_grid / grid.y.size) if margin > 0 else margin)
    bound = chi2 + (margin * max(1.0, chi2 / fit.data.y.size) if margin > 0 else margin)
    passed = [(c, brief) for c, brief in (_fit(_Problem(grid, fit.model, *start, True, True), 48)[::-1] for start in starts) if c < grid_bound]
    if n_best is not None:
        passed = sorted(passed, key=lambda p: p[0])[:n_best]
    out = []
    for _, brief in passed:
        full, c_full = _fit(_Problem(fit.data, fit.model, brief.C_IP0, brief.omega0, brief.C_TA0, True, True), 360)
        if c_full < bound:
            out.append((c_full, full))
    return out


def _half_turned_fits(fit: _Problem, chi2: float, grid: _Data) -> list[tuple[float, _Problem]]:
    """(χ², fit) from each of :func:`_half_turns` that ends lower than ``chi2`` (:func:`_lower_from`; the screen's coarse
    model cannot rank the two)."""
    return _lower_from(fit, chi2, grid, [(fit.C_IP0, fit.omega0, C_TA) for C_TA in _half_turns(fit.C_TA0)])


def _best_phase(data: _Data, model, C_IP: np.ndarray, omega: float, C_TA: np.ndarray, n_phases: int = 24) -> np.ndarray:
    """``C_IP`` turned about its pole by the best of ``n_phases`` equally spaced phases (one evaluation each) for the body
    axis frame ``C_TA``: the start of a fit about a body axis no fit has tried."""
    starts = [C_IP @ Rotation.from_rotvec([0.0, 0.0, 2 * np.pi * j / n_phases]).as_matrix() for j in range(n_phases)]
    costs = [float(r @ r) for r in (_Problem(data, model, C, omega, C_TA, True, True).residuals(np.zeros(6)) for C in starts)]
    return starts[int(np.argmin(costs))]


#: angle (deg) between a fit's body axis and the candidate axis nearest it beyond which :func:`_other_axis_fits` also
#: starts a fit from that axis
SNAP_MIN_DEG = 2.0


def _other_axis_fits(fit: _Problem, chi2: float, grid: _Data, axes_T: np.ndarray) -> list[tuple[float, _Problem]]:
    """(χ², fit) on the fit's own samples from each candidate body axis ⟂ the fit's (|a·a_fit| < 0.5, ``axes_T``) at the
    fit's pole and rate that ends lower than ``chi2`` by more than 1.

    The screen keeps one body axis per pole and rate (the best of its coarse copy) and every later fit starts from it: a
    fit turns the body axis by a few degrees, never by a quarter turn. On an object drawn as ``benchmarks/bench_inversion.py``
    draws them (seed 9023: box-wing, five nights) the search found the pole (1.6° off) and the true alias but spun the body
    about a principal axis perpendicular to the truth's, at χ² 49 782 above the truth's. So at each kept optimum every
    other axis is tried: the best phase about it on the grid samples (:func:`_best_phase`), a brief fit there (48
    evaluations) against the kept fit's χ² there, and only one that ends lower is fitted on the fit's own samples
    (:func:`_lower_from`). On the 13 vespa objects of those 40 draws (near-symmetric: ±x and ±y fit alike) this costs 35 %
    more CPU and moves three optima lower (by 2.2, 7.7 and 0.3); gating the full fit on a 5 % gain on the grid saved that CPU but lost those.

    The candidate axis nearest the fit's own is tried too when the fit's axis is more than :data:`SNAP_MIN_DEG` from it: a
    fit that started between two axes of one principal moment (atlas-centaur's transverse x and z, vespa's x and y) can stop
    there, tilted. Schedule index 40 of the benchmark (atlas-centaur, five nights, 2026-11-30): the search ended 7° from z at
    χ² 775.2, the fit from z itself reached 753.1 (the truth's own fit, about x, 758.3).
    """
    own = fit.C_TA0[:, 2]
    frames = [axis_frame(a) for a in axes_T if abs(a @ own) < 0.5]
    nearest = axes_T[int(np.argmax(axes_T @ own))]
    if nearest @ own < np.cos(np.radians(SNAP_MIN_DEG)):
        frames.append(axis_frame(nearest))
    return _lower_from(fit, chi2, grid, [(_best_phase(grid, fit.model, fit.C_IP0, fit.omega0, C_TA), fit.omega0, C_TA) for C_TA in frames])


def _reversed_sense_fits(fit: _Problem, chi2: float, grid: _Data) -> list[tuple[float, _Problem]]:
    """(χ², fit) on the fit's own samples from the fit's spin reversed, if it ends below ``chi2`` + :data:`COMB_KEEP`
    (scaled, :func:`_lower_from`): the pole turned to its antipode and the body axis with it (the axis keeps its direction
    in space, the body turns the other way), at the best phase about it on the grid samples (:func:`_best_phase`) and the
    same rate. A lower one moves the search on; a higher one is the other sense's mode, which the posterior lists.

    The two senses differ only through the body's asymmetry under time reversal and the bisector's drift, so the screen's
    coarse copy cannot rank them, and no fit turns the pole by 180°. On a four-night atlas-centaur of
    ``benchmarks/bench_inversion.py`` (schedule index 194, spin about −y) the search ended at the reversed spin (pole 180.0°
    off, about +y) at χ² 607.7 against the truth's 593.4; reversed (at the best, and again at the new best the
    reversal leads to), the search reaches the truth's optimum (593.9, 0.01°; which later start got there was not traced).
    The reversal moves each night's phase by twice the bisector's azimuth there, so a reversed start can land on a
    cycle-count alias (1.2 % off in period at 603.3 with the reversal at every kept optimum); the comb of the reversed start
    itself, evaluated unfitted, is flat (within 6 over 328 rates) and is not walked.

    Until 2026-12-02 only a reversed fit lower by more than 1 was kept. Which sense a search reaches first depends on the
    rounding of its fits' linear algebra: with OpenBLAS's Haswell kernels (``OPENBLAS_CORETYPE=Haswell``, as on the CI
    machine) the same object's search reached the reversed spin at χ² 593.1 on the grid samples by a half turn, the
    truth's sense reversed from there was not lower by 1, and the search listed only the reversed sense (two modes
    180.0° off, the truth's pole in no region).
    """
    flipped = fit.C_IP0 @ Rotation.from_rotvec([np.pi, 0.0, 0.0]).as_matrix()  # pole → −pole
    C_TA = axis_frame(-fit.C_TA0[:, 2])
    return _lower_from(fit, chi2, grid, [(_best_phase(grid, fit.model, flipped, fit.omega0, C_TA), fit.omega0, C_TA)], COMB_KEEP)


#: teeth of the cycle-count comb at the best optimum fitted briefly (:func:`_comb_fits`), the best-ranked by the full model
COMB_TEETH = 8
#: Δχ² (scaled as :data:`REFINE_REACH`) above the best optimum within which a tooth's fit is kept as an optimum of its own
#: (:func:`_comb_fits`): a mode that far above has a Laplace weight of e^−8 ≈ 3e-4 of the best (:mod:`.posterior`), below
#: what a 95 % region needs, so aliases beyond it may be left out.
COMB_KEEP = 16.0


def _comb_fits(fit: _Problem, chi2: float, plain: _Data, omegas: np.ndarray, n_teeth: int = COMB_TEETH) -> list[tuple[float, _Problem]]:
    """(χ², fit) on the fit's own samples from the cycle-count aliases of ``fit`` that end below ``chi2`` + :data:`COMB_KEEP`
    (scaled): rates ω + 2πn/Δt over the rate range ``omegas`` (Δt the spread of the curves' mid-times), each started with
    the epoch phase kept at the mid-times (:func:`_alias_phase_shift`). Lower ones move the search on; the others are
    modes of the posterior that the data can hardly tell from the best (a two-night box-wing of
    ``benchmarks/bench_inversion.py`` listed the teeth n = −3 … +2 and +5 about the truth's but not the truth's own, whose
    χ² was within 6 of the best: its period lay outside every listed mode's region).

    :func:`_alias_trials` walks the comb with the screen's coarse model on tempered samples, which cannot rank the teeth, and
    only its best few reach the full model. Here every tooth is evaluated once with the full model on the grid samples
    ``plain`` (not tempered: the tempering's model error, :data:`SCREEN_REL_ERROR`, hides what tells the teeth apart), and the ``n_teeth`` lowest
    are tried as :func:`_lower_from` tries a start, against ``fit`` on ``plain``. With three nights or more χ²(n) is not
    smooth: only every k-th tooth keeps every night's phase. On a three-night atlas-centaur object of
    ``benchmarks/bench_inversion.py`` (its first; 73 teeth) the search ended 6 teeth from the truth's (χ² 465.6 against the
    truth's 431.3 on all data; the teeth n = −3, −6, −9 fitted briefly 438, 426, 435); unfitted, the full model put the
    truth's tooth 3rd of the 73. Only the best optimum's comb is walked: on a three-night vespa of the benchmark it took 12 s
    of the inversion's 122 s of CPU.
    """
    mids = _mid_times(plain)
    if np.ptp(mids) <= 0.0:
        return []
    spacing = 2 * np.pi / np.ptp(mids)
    n = np.arange(np.ceil((omegas[0] - fit.omega0) / spacing), np.floor((omegas[-1] - fit.omega0) / spacing) + 1)
    starts, costs = [], []
    for k in n[n != 0]:
        start = (fit.C_IP0 @ Rotation.from_rotvec([0.0, 0.0, _alias_phase_shift(plain, k * spacing)]).as_matrix(), fit.omega0 + k * spacing, fit.C_TA0)
        r = _Problem(plain, fit.model, *start, True, True).residuals(np.zeros(6))
        starts.append(start)
        costs.append(float(r @ r))
    return _lower_from(fit, chi2, plain, [starts[i] for i in np.argsort(costs, kind="stable")[:n_teeth]], COMB_KEEP)


#: the rescreen at the best optimum's pole (:func:`_rescreen_fits`): its rate grid this many times finer than the screen's, its
#: phases this many times as many
RESCREEN_REFINE = (4, 2)


def _rescreen_fits(fit: _Problem, chi2: float, plain: _Data, omegas: np.ndarray, axes_T: np.ndarray, n_phases: int,
                   n_starts: int = 8) -> list[tuple[float, _Problem]]:
    """(χ², fit) on the fit's own samples from the best minima of a screen with the full model at the fit's pole, on the grid
    samples ``plain`` (not tempered), over the whole rate range (:data:`RESCREEN_REFINE` finer than the screen's ``omegas``),
    every body axis ``axes_T`` and twice the phases; the ``n_starts`` best rate minima are tried as :func:`_lower_from` tries
    a start, and kept within :data:`COMB_KEEP`.

    The stages before it start every fit from the coarse screen's body axis, phase and rate at a lattice pole, and each mends
    one kind of look-alike from there (turned, turned over, another axis, another tooth of the comb); a start wrong in two of
    them at once is out of their reach. At the best optimum's own pole (no lattice offset) the full model ranks rate, axis and
    phase together. On a four-night box-wing (seed 9005 of the calibration draws) with the screening tolerance at 0.1, the
    search found the pole (0.0° off) at χ² 7368 above the truth's, every fit on a wrong tooth and axis; the rescreen's minima
    led to the truth's optimum (χ² 9.2 below the truth's, pole 0.1°). With the screen's own rate and phase steps it did not:
    a rate off the grid turns the farthest night by up to a phase step, a glint's worth of χ².

    It runs only for a best optimum whose χ²/dof exceeds :data:`RETRY_CHI2_DOF` (:func:`invert`). Run at every object (commit
    7cfa8ff) it cost 1.12× the CPU (median of 18 shaped facet objects of the benchmark; the three 3 × 600-sample timing objects
    1.2–1.7×) and on objects already fitted to the noise it only moved the best among near-equal modes (95 % regions holding
    the truth: 12 of 18 against 13 without it).
    """
    pole = fit.C_IP0[:, 2]
    rates, phases = RESCREEN_REFINE
    fine = np.linspace(omegas[0], omegas[-1], rates * (omegas.size - 1) + 1)
    scr = screen_phases(plain, fit.model, pole[None, :], axes_T, fine, n_phases=phases * n_phases)
    starts = [(pole_frame(pole) @ Rotation.from_rotvec([0.0, 0.0, scr.phase_rad[0, i]]).as_matrix(), fine[i], axis_frame(axes_T[scr.axis_index[0, i]]))
              for i in _period_minima(scr.chi2[0], n_starts)]
    return _lower_from(fit, chi2, plain, starts, COMB_KEEP)


#: the tilts of :func:`_tilted_fits`: radii (deg) about the best optimum's pole, and directions per radius
TILT_RADII_DEG = (3.0, 6.0)
TILT_AZIMUTHS = 8
#: the tilts of a search still misfit after its retry (:func:`_retried_optima`): radii (deg) about each of the
#: ``WIDE_TILT_OPTIMA`` lowest distinct subsample fits of both screens. On a one-night box-wing of
#: ``benchmarks/bench_inversion.py`` (schedule index 170, spin about the major axis) the best candidates stopped 24–29° from
#: the truth (χ² 646–714 on the refinement samples against the truth's 146: a glint's local minima), out of reach of the
#: best (χ² 380, 158° off), where the truth's basin reaches ≥ 10° in tilt; tilted by 8–24° they reached it (0.6° off).
WIDE_TILT_RADII_DEG = (8.0, 16.0, 24.0)
WIDE_TILT_OPTIMA = 8


def _tilted_fits(fit: _Problem, chi2: float, plain: _Data, radii_deg: tuple = TILT_RADII_DEG) -> list[tuple[float, _Problem]]:
    """(χ², fit) on the fit's own samples from the best of the fit's frame tilted by ``radii_deg`` toward
    :data:`TILT_AZIMUTHS` directions (rate and body axis kept), if it ends lower by more than 1 (:func:`_lower_from`).

    A least-squares fit stops where the χ² surface has a local minimum, and a glinting shape's surface has them a few
    degrees apart: on a four-night box-wing of ``benchmarks/bench_inversion.py`` (schedule index 113) the search ended 3.2°
    from the truth's pole at χ² 1589 against the truth's 389, 3–5° off in attitude on every night, and the rescreen at that
    pole found nothing lower; tilted by 3–6°, the fits reached 0.4° (χ² 539), where the rescreen found the truth's optimum
    (χ² 383.6, pole 0.0°).
    """
    starts = []
    for r in np.radians(radii_deg):
        for a in np.arange(TILT_AZIMUTHS) * 2 * np.pi / TILT_AZIMUTHS:
            u = fit.C_IP0 @ np.array([np.cos(a), np.sin(a), 0.0])
            starts.append((Rotation.from_rotvec(r * u).as_matrix() @ fit.C_IP0, fit.omega0, fit.C_TA0))
    return _lower_from(fit, chi2, plain, starts, n_best=1)


def _known_shape_optima(coarse, kept, plain: _Data, omegas: np.ndarray, axes_T: np.ndarray, n_phases: int, n_free: int,
                        workers: int, rescreen: bool = False) -> list[tuple[float, _Problem]]:
    """Step 2's last stages for a known shape, from the subsample fits ``coarse`` and their distinct optima ``kept``: the
    best optimum tilted (:func:`_tilted_fits`; before 2026-12-01 only on a misfit search's path, and a two-night
    atlas-centaur of the benchmark, schedule index 6, χ²/dof 0.86, ended 6.6° from the truth in a basin 12 above the
    truth's, which the 3–6° tilts reach for 0.3 s of CPU), the rescreen at the best's pole (:func:`_rescreen_fits`) with
    ``rescreen`` or when a tilt moved the best (schedule index 113's tilt reaches 0.4° at χ² 539, χ²/dof 0.91 and no longer
    misfit, and only the rescreen there finds the truth's optimum, 383.6), the cycle-count aliases of the (new) best
    ranked by the full model (:func:`_comb_fits`), then at each optimum the body turned over (a near-symmetric shape's other
    axis sign) and the other principal axes, and at the best (and at a new best) the spin reversed
    (:func:`_reversed_sense_fits`; at every optimum it cost the benchmark's 3 × 600-sample atlas-centaurs with 11 and 25
    modes 38 % and 16 % more time); the distinct optima within reach, best first. Every stage here tries its starts
    on the grid samples ``plain``, not tempered: the screening tolerance (:data:`SCREEN_REL_ERROR`, 0.1) shrinks a χ²
    difference of tens to less than the one :func:`_lower_from` asks for, so with the tempered samples (before
    2026-11-30) the other-axis and half-turned starts of schedule index 40 of the benchmark never passed (the fix found
    χ² 22 lower about x, its axis's twin)."""
    tilted = _tilted_fits(kept[0][1], kept[0][0], plain)
    if tilted:
        coarse = coarse + tilted
        kept = _distinct_within_reach(coarse, n_free)
    if rescreen or tilted:  # a best that moved by a tilt was in the wrong basin: its phase and rate are screened again there
        found = _rescreen_fits(kept[0][1], kept[0][0], plain, omegas, axes_T, n_phases)
        if found:
            coarse = coarse + found
            kept = _distinct_within_reach(coarse, n_free)
    comb = _comb_fits(kept[0][1], kept[0][0], plain, omegas)
    if comb:
        kept = _distinct_within_reach(coarse + comb, n_free)
    def turned(k: tuple[float, _Problem]) -> list[tuple[float, _Problem]]:
        return _half_turned_fits(k[1], k[0], plain) + _other_axis_fits(k[1], k[0], plain, axes_T)

    better = [f for found in _each(turned, kept, workers) for f in found] + _reversed_sense_fits(kept[0][1], kept[0][0], plain)
    new_best = min(better, key=lambda f: f[0], default=None)
    if new_best is not None and new_best[0] < kept[0][0]:  # a new best: its own axis may be tilted, or its twins lower
        better += turned(new_best) + _reversed_sense_fits(new_best[1], new_best[0], plain)
    return _distinct_within_reach(coarse + comb + better, n_free) if better else kept


def _candidate_fits(grid: _Data, sub: _Data, model, screen_model, poles: np.ndarray, chi2_grid: np.ndarray, screen: PhaseScreen | None,
                    omegas: np.ndarray, axes: np.ndarray, counts: tuple[int, int, int], workers: int, step: Callable[[], None],
                    sub_teeth: int = 1) -> list[tuple[float, _Problem]]:
    """Step 2's fits (χ², fit) on the refinement subsample ``sub`` from the best local minima of one screen's pole map
    (``chi2_grid`` (n_pole, n_ω) over ``poles``; ``screen`` its known-shape phases and axes, None for a convex model);
    ``counts`` = (candidates, periods per pole, aliases) of :func:`invert`; ``step()`` after each candidate pole; ``sub_teeth`` of
    :func:`_alias_trials`."""
    n_candidates, n_periods, n_aliases = counts
    chi2_map = chi2_grid.min(axis=1)
    known = screen is not None
    trials = []  # known shape: per candidate pole, (χ², fit) of the screen's model on the grid samples
    coarse = []

    def candidate(ip: int) -> list[tuple[float, _Problem]]:
        if known:
            return _alias_trials(grid, screen_model, poles[ip], omegas, chi2_grid[ip], screen.phase_rad[ip], axes[screen.axis_index[ip]],
                                 n_periods, n_aliases, sub_teeth)
        return [_fit(_Problem(sub, model, pole_frame(poles[ip]), omegas[iw], np.eye(3), False, False), 180)[::-1]
                for iw in _period_minima(chi2_grid[ip], n_periods)]

    for found in _each(candidate, _local_minima(poles, chi2_map)[:n_candidates], workers):
        (trials.append if known else coarse.extend)(found)
        step()
    if not known:
        return coarse

    def full_fit(trial: _Problem) -> tuple[float, _Problem]:
        return _look_alike_fit(*_fit(_Problem(sub, model, trial.C_IP0, trial.omega0, trial.C_TA0, True, True), 360)[::-1])

    return list(_each(full_fit, _trials_to_fit(trials, grid.y.size - 1 - int(grid.relative.sum())), workers))


#: χ² per degree of freedom of a known shape's best optimum on the refinement subsample above which :func:`invert` screens
#: again at :data:`RETRY_REL_ERROR` and searches from that screen's candidates too. Where the search found the truth's optimum
#: the facet objects of ``benchmarks/bench_inversion.py`` end at 1.0–1.27 (86 objects, the largest), the Mitsuba renders
#: (model error) at 1.5–15; the search misses that ended in another basin at 4.7–39.
RETRY_CHI2_DOF = 2.0
#: the retry's screening tolerance ε (:func:`_tempered`): the coarse copy's own model error, :data:`SCREEN_REL_ERROR` before
#: 2026-11-30. Which lattice node the screen ranks first moves erratically with ε (:data:`SCREEN_REL_ERROR`): a two-night
#: box-wing of the benchmark (schedule index 19) ended 14.3° off at 0.1 (χ² 4636 on all data against the truth's 170, every
#: candidate 14° or 117° off) and at the truth's optimum at 0.03, while index 63 needed 0.1; two screens cover both.
RETRY_REL_ERROR = 0.03


def _misfit(kept: list[tuple[float, _Problem]], n_free: int) -> float:
    """χ² per degree of freedom of the best of ``kept`` (χ², fit) on samples with ``n_free`` dof before the fit's own."""
    chi2, best = kept[0]
    return chi2 / max(n_free - best.n, 1)


def _retried_optima(kept: list[tuple[float, _Problem]], plain: _Data, sub: _Data, model, screen_model, lattice_grid: tuple,
                    counts: tuple[int, int, int], n_free: int, workers: int, screen_progress, step, first: tuple) -> list[tuple[float, _Problem]]:
    """The known-shape search again from a screen at :data:`RETRY_REL_ERROR` (:data:`RETRY_CHI2_DOF`): its candidates'
    subsample fits, those of the first screen ``first`` = (its grid samples, poles, χ² (n_pole, n_ω), :class:`PhaseScreen`)
    again, both with the rates between the comb's teeth (:data:`SUB_TEETH`), and ``kept``, together through
    :func:`_known_shape_optima`. ``lattice_grid`` = (pole lattice, its turn, body axes, rates, phases) of :func:`invert`;
    ``screen_progress(fraction)`` over the screen, ``step()`` per candidate pole."""
    lattice, turn, axes, omegas, n_phases = lattice_grid
    grid = _tempered(plain, RETRY_REL_ERROR)
    poles, screen = _known_screen(grid, screen_model, lattice, turn, axes, omegas, n_phases, 2 * counts[0], screen_progress)
    coarse = kept + [c for g, p, chi2_grid, sc in ((grid, poles, screen.chi2, screen), first)
                     for c in _candidate_fits(g, sub, model, screen_model, p, chi2_grid, sc, omegas, axes, counts, workers, step, SUB_TEETH)]
    kept = _known_shape_optima(coarse, _distinct_within_reach(coarse, n_free), plain, omegas, axes, n_phases, n_free, workers, rescreen=True)
    if _misfit(kept, n_free) <= RETRY_CHI2_DOF:
        return kept
    distinct = _distinct(sorted(coarse, key=lambda c: c[0]))[:WIDE_TILT_OPTIMA]
    wide = [f for found in _each(lambda c: _tilted_fits(c[1], c[0], plain, WIDE_TILT_RADII_DEG), distinct, workers) for f in found]
    if not wide or min(f[0] for f in wide) >= kept[0][0]:
        return kept
    coarse += wide
    return _known_shape_optima(coarse, _distinct_within_reach(coarse, n_free), plain, omegas, axes, n_phases, n_free, workers, rescreen=True)


def _refine(problem: _Problem, data: _Data) -> tuple[_Problem, np.ndarray, float, np.ndarray, np.ndarray]:
    """Polish a fit made on a subsample on all ``data``: (problem re-centred at θ = 0, J, χ², w, s)."""
    full = _Problem(data, problem.model, problem.C_IP0, problem.omega0, problem.C_TA0, problem.fit_phase, problem.fit_axis)
    full, _ = _fit(full, 15 * full.n)
    w, s, r = full.solve(np.zeros(full.n))
    return full, full.jacobian(np.zeros(full.n)), float(r @ r), w, s


def _pole_period_map(problem: _Problem, cov_theta: np.ndarray) -> tuple[np.ndarray, float, float]:
    """Covariance (3, 3) of (t₁, t₂, P) and the σ of φ₀ and of the axis from that of θ at θ = 0 (see :class:`_Problem`)."""
    state = problem.state(np.zeros(problem.n))
    R = pole_frame(state.pole_I).T @ problem.C_IP0  # R_z(χ): the pole frame of the refinement vs the conventional one
    G = np.zeros((3, problem.n))
    # a rotation δ of the frame moves the pole by δ × p = δ₂ e₁' − δ₁ e₂' (primed: refinement frame)
    G[:2, :2] = R[:2, :2] @ np.array([[0.0, 1.0], [-1.0, 0.0]])
    j = 2 + problem.fit_phase
    omega = 2 * np.pi / state.period_s
    G[2, j] = -2 * np.pi / omega**2 / problem.tau
    cov = G @ cov_theta @ G.T
    phase_sigma = float(np.sqrt(cov_theta[2, 2])) if problem.fit_phase else float("nan")
    axis_sigma = float(np.degrees(np.sqrt(np.linalg.eigvalsh(cov_theta[j + 1:, j + 1:])[-1]))) if problem.fit_axis else float("nan")
    return cov, phase_sigma, axis_sigma


def _check_options(pole_step_deg: float, screen_rel_error: float, workers: int | None) -> int:
    """:func:`invert`'s search options checked (a named error for a bad one); the number of worker threads."""
    if not (np.isfinite(pole_step_deg) and 0.5 <= pole_step_deg <= 45):
        raise ValueError(f"pole_step_deg: {pole_step_deg!r}: expected a spacing in [0.5, 45] deg")
    if not (np.isfinite(screen_rel_error) and screen_rel_error >= 0):
        raise ValueError(f"screen_rel_error: {screen_rel_error!r}: expected a relative error >= 0")
    return _workers(workers)


def _workers(workers: int | None) -> int:
    """The number of worker threads asked (:func:`default_workers` for None), checked."""
    workers = default_workers() if workers is None else workers
    if not (isinstance(workers, (int, np.integer)) and workers >= 1):
        raise ValueError(f"workers: {workers!r}: expected an integer >= 1")
    return int(workers)


def _validate(curves, period_range_s) -> list[tuple[float, float]]:
    if isinstance(curves, InversionCurve):
        curves = [curves]
    if len(curves) == 0 or not all(isinstance(c, InversionCurve) for c in curves):
        raise ValueError(f"curves: {type(curves).__name__}: expected a non-empty sequence of InversionCurve")
    try:
        ranges = np.asarray(period_range_s, dtype=float)
    except (TypeError, ValueError):
        ranges = np.zeros(0)
    if ranges.shape == (2,):
        ranges = ranges[None, :]
    if ranges.ndim != 2 or ranges.shape[1] != 2 or ranges.shape[0] == 0:
        raise ValueError(f"period_range_s: {period_range_s!r}: expected (min, max) sidereal periods in s, or a sequence of them")
    if not (np.isfinite(ranges).all() and (ranges[:, 0] > 0).all() and (ranges[:, 0] < ranges[:, 1]).all()):
        raise ValueError(f"period_range_s: {period_range_s!r}: expected 0 < min < max, in s")
    return [(float(lo), float(hi)) for lo, hi in ranges]


@dataclass
class _RangeSearch:
    """One period range's screen and its step-2 optima (:func:`invert`)."""

    omegas: np.ndarray  #: the screen's sidereal rates, rad/s
    poles: np.ndarray  #: (n, 3) the screened poles
    chi2_grid: np.ndarray  #: (n, n_ω) their screening χ²
    screen: PhaseScreen | None  #: a known shape's phases and body axes, None for a convex model
    counts: tuple[int, int, int]  #: (candidates, periods per pole, aliases) of :func:`_candidate_fits`
    kept: list  #: (χ², fit) of the distinct optima within reach on the refinement subsample, best first

    def maps(self) -> tuple[np.ndarray, np.ndarray]:
        """The pole map: the best screening χ² over rates at each pole, and the period there (s)."""
        best_w = np.argmin(self.chi2_grid, axis=1)
        return self.chi2_grid[np.arange(self.poles.shape[0]), best_w], 2 * np.pi / self.omegas[best_w]


class _Progress:
    """:func:`invert`'s ``progress(n_done, n_total)``: rates screened and candidate poles fitted; a retry adds to the total."""

    def __init__(self, callback: Callable[[int, int], None] | None, total: int):
        self.callback, self.total, self.done = callback, total, 0

    def advance(self, n: int) -> None:
        self.done += n
        if self.callback is not None:
            self.callback(self.done, max(self.total, self.done))

    def screen(self, n_rates: int) -> Callable[[float], None] | None:
        """``f(fraction)`` over a screen of ``n_rates`` rates that starts now; ``done`` moves past it at once (the stages after
        the screen count on from its end)."""
        base, self.done = self.done, self.done + n_rates
        return None if self.callback is None else (lambda f: self.callback(base + round(f * n_rates), self.total))

    def finish(self) -> None:  # fewer local minima than candidates: the bar still ends full
        if self.callback is not None and self.done < self.total:
            self.callback(self.total, self.total)


@dataclass(frozen=True)
class _Search:
    """What every period range of one :func:`invert` shares: samples, models, pole lattice, body axes and counts."""

    grid: _Data  #: the screen's samples (a known shape's tempered, :func:`_tempered`)
    plain: _Data  #: the same samples, untempered
    sub: _Data  #: the refinement subsample
    model: object
    screen_model: object
    lattice: np.ndarray  #: (n, 3) the pole lattice, turned by ``turn``
    turn: np.ndarray
    axes: np.ndarray  #: a known shape's candidate body axes
    n_phases: int
    n_candidates: int
    n_periods: int
    n_aliases: int
    n_free: int  #: the refinement subsample's size less its linear parameters
    mid_spread_s: float  #: the spread of the curves' mid-times (all samples)
    workers: int
    known: bool

    def range_search(self, omegas: np.ndarray, bar: _Progress) -> _RangeSearch:
        """One range's screen (step 1) and its optima through step 2 (module docstring)."""
        to_screen = bar.screen(omegas.size)
        if self.known:  # the known shape itself, with phase and body axis (:mod:`.phase_screen`)
            poles, screen = _known_screen(self.grid, self.screen_model, self.lattice, self.turn, self.axes, omegas, self.n_phases,
                                          2 * self.n_candidates, to_screen)
            chi2_grid = screen.chi2
        else:
            poles, screen = self.lattice, None
            chi2_grid = _screen(self.grid, self.screen_model, poles, omegas, None if to_screen is None else (lambda j, n: to_screen(j / n)))
        # distinct cycle-count aliases in the range: rates 2π/(spread of the curves' mid-times) apart
        n_aliases = int(np.ceil((omegas[-1] - omegas[0]) * self.mid_spread_s / (2 * np.pi))) + 1
        counts = (self.n_candidates, self.n_periods, min(self.n_aliases, n_aliases))
        coarse = _candidate_fits(self.grid, self.sub, self.model, self.screen_model, poles, chi2_grid, screen, omegas, self.axes, counts,
                                 self.workers, lambda: bar.advance(self.n_periods))
        kept = _distinct_within_reach(coarse, self.n_free)
        if self.known:
            kept = _known_shape_optima(coarse, kept, self.plain, omegas, self.axes, self.n_phases, self.n_free, self.workers)
        return _RangeSearch(omegas, poles, chi2_grid, screen, counts, kept)

    def misfit_stages(self, s: _RangeSearch, retry: bool, bar: _Progress) -> None:
        """A known shape's range whose best is misfit (:data:`RETRY_CHI2_DOF`): the stages of step 2 again with the rescreen,
        then, with ``retry``, the search from a screen at :data:`RETRY_REL_ERROR` (:func:`_retried_optima`)."""
        if _misfit(s.kept, self.n_free) > RETRY_CHI2_DOF:
            s.kept = _known_shape_optima(s.kept, s.kept, self.plain, s.omegas, self.axes, self.n_phases, self.n_free, self.workers, rescreen=True)
        if retry and _misfit(s.kept, self.n_free) > RETRY_CHI2_DOF:
            bar.total += s.omegas.size + 2 * self.n_candidates * self.n_periods
            s.kept = _retried_optima(s.kept, self.plain, self.sub, self.model, self.screen_model,
                                     (self.lattice, self.turn, self.axes, s.omegas, self.n_phases), s.counts, self.n_free, self.workers,
                                     bar.screen(s.omegas.size), lambda: bar.advance(self.n_periods), (self.grid, s.poles, s.chi2_grid, s.screen))


def invert(curves: Sequence[InversionCurve], model, period_range_s, *, rng: np.random.Generator | None = None,
           progress: Callable[[int, int], None] | None = None, pole_step_deg: float = 7.5, period_oversampling: float = 2.0,
           n_grid_samples: int = 60, screen_facets: int = 30, n_candidates: int = 6, n_periods_per_pole: int = 3,
           axes_T=None, n_phases: int = 48, n_refine_samples: int = 150, screen_known_facets: int | None = None, n_aliases: int = 40,
           screen_rel_error: float = SCREEN_REL_ERROR, workers: int | None = None) -> InversionResult:
    """Spin state(s) of one object from its light curves: all modes the data cannot tell apart (module docstring).

    Parameters
    ----------
    curves : the light curves (relative and calibrated may mix), each with its geometry.
    model : shape model with ``basis(sun_T, obs_T) -> (N, m)`` (W/sr): a :class:`ConvexModel` (unknown
        shape, body z the spin axis, phase absorbed) or a known shape (m = 1: phase and axis fitted).
    period_range_s : (min, max) sidereal period searched, s; or a sequence of such ranges (one night's period P and 2P, when
        one night cannot tell a single-peaked rotation from half a double-peaked one). Each range is screened and searched
        through step 2 on its own; a known shape's misfit stages (the rescreen and the retry, :data:`RETRY_CHI2_DOF`) then run
        only for the ranges whose best optimum ends within :data:`REFINE_REACH` of the best of all, and the optima of every
        range within that reach are refined and weighed together. The SC3 seed-1 campaign of ``tests/studies/test_no_oracle.py``
        (atlas-centaur, P and 2P): χ²/dof 133 at P and 8188 at 2P after step 2; searched one range at a time, the two
        retries cost 126 s of the 198 s and moved χ²/dof from 133.26 to 133.26 at P and from 8187.8 to 8187.2 at 2P.
    rng : if given, turns the pole lattice by a random rotation (so repeated studies do not share grid points).
    progress : called as ``progress(n_done, n_total)`` during the grid and the refinements.
    pole_step_deg : pole lattice spacing, deg; period_oversampling : rate-grid density over the quarter-turn rule
        (2 by default: with the quarter-turn step the screening missed the true basin on 3 × 600 samples at 2 % noise).
    n_grid_samples : samples per curve used by the grid; screen_facets : normals of the screening model.
    n_candidates : local minima of the pole map refined (known shape: twice as many minima of the coarse screen get the
        full lattice around them, :func:`_known_screen`); n_periods_per_pole : period minima tried at each (nights days
        apart leave cycle-count aliases ≈ P²/T apart: each is refined and reported with its probability).
    axes_T : (n, 3) candidate body spin axes for a known shape (default the principal axes ±x, ±y, ±z).
    n_phases : phases of a known shape's screen (:mod:`.phase_screen`; the rate step follows, ``period_oversampling``
        at least n_phases/8).
    n_refine_samples : samples per curve of the first refinement; the optimum is then polished on all samples.
    screen_known_facets : facets of the known shape's screening copy (``model.coarse``, when it has one); default: the fewest
        that keep it within :data:`SCREEN_COPY_REL_ERROR` of the model (:func:`screen_copy`).
    screen_rel_error : known shape: relative model error ε the screening stages assume (:func:`_tempered`): σ² + (ε y)² on the grid
        samples. At the data's noise alone (ε = 0) a screen step's offset costs more χ² than a wrong basin: on an atlas-centaur
        night (``benchmarks/bench_inversion.py``, σ/y ≈ 1 %) the lattice pole 4° from the truth screened at χ² 5e4 against 2.7e4
        for a pole 58° off, and the search ended 145° off. Default :data:`SCREEN_REL_ERROR`; a search that ends far from the
        noise screens again at :data:`RETRY_REL_ERROR` (unless it is that already).
    n_aliases : the rate minima of each candidate pole's screen row from which up to 4 untried ones are fitted briefly besides
        the alias comb (step 2 of the module docstring; fewer when the range holds fewer cycle-count aliases).
    workers : threads that run a stage's independent fits at once (default :func:`default_workers`; the result is the same
        for any number). They shorten the wall time at some CPU cost of their own (on 12 calibration objects of 1–3
        nights × 150 samples, the same results and 0.8–1.16× the CPU of earlier single-thread runs): for many objects at
        once, one process per core, pass 1.
    """
    ranges = _validate(curves, period_range_s)
    curves = [curves] if isinstance(curves, InversionCurve) else list(curves)
    workers = _check_options(pole_step_deg, screen_rel_error, workers)
    data = _stack(curves)
    m = np.asarray(model.basis(np.array([[0.0, 0.0, 1.0]]), np.array([[0.0, 0.0, 1.0]]))).shape[1]
    known = m == 1
    turn = Rotation.random(random_state=rng).as_matrix() if rng is not None else np.eye(3)
    lattice = fibonacci_sphere(int(np.ceil(4 * np.pi / np.radians(pole_step_deg) ** 2))) @ turn.T
    # a known shape's χ² is sharp in phase: the rate step then turns the phase at the span's ends by ≤ one phase step 2π/n_phases
    grids = [period_grid(r, np.ptp(data.t_s), max(period_oversampling, n_phases / 8.0) if known else period_oversampling) for r in ranges]
    bar = _Progress(progress, sum(o.size + n_candidates * n_periods_per_pole for o in grids))
    plain = _subsample(data, n_grid_samples)
    sub = _subsample(data, n_refine_samples)
    if known:
        screen_model = screen_copy(model, screen_known_facets)
    else:
        screen_model = model.with_facets(screen_facets) if isinstance(model, ConvexModel) else ConvexModel(screen_facets)
    setup = _Search(_tempered(plain, screen_rel_error) if known else plain, plain, sub, model, screen_model, lattice, turn,
                    _PRINCIPAL_AXES if axes_T is None else np.asarray(axes_T, dtype=float), n_phases, n_candidates, n_periods_per_pole, n_aliases,
                    sub.y.size - m - int(data.relative.sum()), float(np.ptp(_mid_times(data))), workers, known)
    searches = [setup.range_search(omegas, bar) for omegas in grids]
    if known:  # the misfit stages, best range first, for the ranges within reach of the best of all
        lead = _within_reach([s.kept[0] for s in searches], setup.n_free)
        for s in sorted((s for s in searches if any(s.kept[0] is c for c in lead)), key=lambda s: s.kept[0][0]):
            setup.misfit_stages(s, screen_rel_error != RETRY_REL_ERROR, bar)
    kept = [fit for _, fit in _distinct_within_reach([k for s in searches for k in s.kept], setup.n_free)]
    fits = list(_each(lambda k: _refine(k, data), kept, workers))
    bar.finish()
    return _posterior(fits, data, model, *_pooled_maps(searches), ranges, workers)


def _combs(fits, states, covs, chi2, logdets, keep, data: _Data, ranges, scale: float, workers: int) -> tuple[list[int], np.ndarray]:
    """The modes ``keep`` with the :data:`COMB_MAX_FAMILIES` most probable families' combs swept (:func:`_comb_moments`; the
    lists ``fits``, ``states``, ``covs`` and the array ``chi2`` updated in place): a family is a mode and the less probable
    modes on its comb (:func:`_comb_family`), whose fits join the sweep's teeth; a swept family becomes one mode. Returns the
    kept indices and the log comb evidence (n,) of each."""
    mids = _mid_times(data)
    spacing = 2 * np.pi / np.ptp(mids) if np.ptp(mids) > 0 else 0.0
    prob = laplace_probabilities(chi2[keep], np.array(logdets)[keep], scale)
    families: dict[int, list[int]] = {}
    for j in np.argsort(-prob):
        i = keep[j]
        lead = next((k for k in families if _comb_family(states[k], states[i], spacing)), None)
        families.setdefault(i, []) if lead is None else families[lead].append(i)
    log_comb = np.zeros(len(fits))
    out: list[int] = []
    for rank, (i, members) in enumerate(families.items()):
        if rank < COMB_MAX_FAMILIES and prob[keep.index(i)] >= COMB_MIN_PROBABILITY:
            fits[i], covs[i], log_comb[i] = _comb_moments(fits[i], [(chi2[j], fits[j][0]) for j in members], data, spacing, ranges, covs[i],
                                                          scale, workers)
            chi2[i] = fits[i][2]
            states[i] = fits[i][0].state(np.zeros(fits[i][0].n))
            out.append(i)
        else:
            out += [i, *members]
    return out, log_comb


def _pooled_maps(searches: list[_RangeSearch]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The pole map of every range as one: (poles (n, 3), screening χ² (n,), period (n,) s), a pole screened in several ranges
    (the coarse lattice of a known shape's screen, every pole of a convex one) once, at the range where its χ² is lowest."""
    maps = [s.maps() for s in searches]
    poles = np.vstack([s.poles for s in searches])
    chi2 = np.concatenate([c for c, _ in maps])
    period = np.concatenate([p for _, p in maps])
    by_chi2 = np.argsort(chi2, kind="stable")
    _, first = np.unique(poles[by_chi2], axis=0, return_index=True)
    keep = np.sort(by_chi2[first])
    return poles[keep], chi2[keep], period[keep]


#: Most fits one family's comb (:func:`_comb_moments`) may take: its teeth at n = ±1, ±3, ±9, … (a geometric sweep: the
#: envelope of χ² over the teeth is smooth, :func:`_alias_trials`); and the evaluations of each.
COMB_MAX_TEETH = 12
COMB_TOOTH_EVALUATIONS = 20
#: Families (modes of one pole, sense and body axis, :func:`_comb_family`) whose comb is swept, most probable first, and the
#: Laplace probability (before the sweeps) below which a family is not swept.
COMB_MAX_FAMILIES = 4
COMB_MIN_PROBABILITY = 1e-3


def _comb_offsets(n_lo: int, n_hi: int, max_teeth: int = COMB_MAX_TEETH) -> list[int]:
    """The teeth n ≠ 0 of [n_lo, n_hi] that a comb sweep fits: ±1, ±3, ±9, … and each end, nearest first, at most ``max_teeth``."""
    out: set[int] = set()
    step = 1
    while step <= max(-n_lo, n_hi, 0):
        out.update(n for n in (-step, step) if n_lo <= n <= n_hi)
        step *= 3
    out.update(n for n in (n_lo, n_hi) if n != 0)
    return sorted(out, key=lambda n: (abs(n), n))[:max_teeth]


def _comb_cells(n_eval: np.ndarray, chi2_eval: np.ndarray, n_lo: int, n_hi: int, scale: float) -> np.ndarray:
    """The weight (n_eval,) each fitted tooth stands for: every tooth n of [n_lo, n_hi] weighs exp(−(χ²(n) − χ²_min)/(2 s)),
    χ²(n) interpolated linearly in n between the fitted teeth, and counts for the fitted tooth nearest to it."""
    order = np.argsort(n_eval)
    n_eval, chi2_eval = n_eval[order], chi2_eval[order]
    n_all = np.arange(n_lo, n_hi + 1)
    chi2_all = np.interp(n_all, n_eval, chi2_eval)
    w_all = np.exp(-0.5 * (chi2_all - chi2_eval.min()) / scale)
    nearest = np.clip(np.searchsorted(0.5 * (n_eval[1:] + n_eval[:-1]), n_all), 0, n_eval.size - 1)
    cells = np.bincount(nearest, w_all, n_eval.size)
    out = np.empty_like(cells)
    out[order] = cells
    return out


def _comb_moments(fit: tuple, members: list[tuple[float, _Problem]], data: _Data, spacing: float, ranges, cov: np.ndarray, scale: float,
                  workers: int) -> tuple[tuple, np.ndarray, float]:
    """The cycle-count comb of one mode: (its lowest fit, covariance (3, 3) of (t₁, t₂, P) over the comb, log of the comb's
    evidence relative to that tooth's). ``members``: (χ², fit) of other modes on the comb, taken as fitted teeth; ``spacing``
    the teeth's, rad/s (0: one curve's mid-time, no comb).

    Nights days apart leave teeth ω + 2π n/Δt (Δt the spread of the curves' mid-times) that the data tell apart only by
    each night's own phase drift, whose χ² envelope over n can be flat across the whole searched range: on a three-night
    atlas-centaur of ``benchmarks/bench_inversion.py`` (schedule index 147, range −1.8 … +2.2 % of the true period) the 45
    teeth of the truth's pole and sense all lie within χ² 375.4–376.9, yet one tooth's period σ is 1.7e-5 P, and the truth's
    tooth was not among the modes. So the teeth of :func:`_comb_offsets` within the range that holds the mode are fitted
    (``COMB_TOOTH_EVALUATIONS`` each, from the mode's state carried to the tooth as in :func:`_alias_trials`), the
    comb's other teeth get χ² by linear interpolation in n (:func:`_comb_cells`), and the mode becomes the Gaussian
    moment-matched to the comb about its lowest tooth: Σ = Σ_k W_k (Σ_0 + d_k d_kᵀ) / Σ_k W_k, d_k the tooth's (pole
    tangent offset, ΔP), W_k its cell's weight; its Laplace evidence is multiplied by Σ_k W_k (every tooth's covariance
    taken as the mode's own).
    """
    problem, chi2 = fit[0], fit[2]
    if spacing <= 0:
        return fit, cov, 0.0
    period = 2 * np.pi / problem.omega0
    lo, hi = min(ranges, key=lambda r: 0.0 if r[0] <= period <= r[1] else min(abs(period - r[0]), abs(period - r[1])))
    n_lo = int(np.ceil((2 * np.pi / hi - problem.omega0) / spacing))
    n_hi = int(np.floor((2 * np.pi / lo - problem.omega0) / spacing))
    known = {int(round((m.omega0 - problem.omega0) / spacing)): (c, m) for c, m in members}
    offsets = [n for n in _comb_offsets(min(n_lo, 0), max(n_hi, 0)) if n not in known and n != 0]
    if not offsets and not known:
        return fit, cov, 0.0

    def tooth(n: int) -> tuple[float, _Problem]:
        d_omega = n * spacing
        start = problem.C_IP0 @ Rotation.from_rotvec([0.0, 0.0, _alias_phase_shift(data, d_omega)]).as_matrix()
        moved, c = _fit(_Problem(data, problem.model, start, problem.omega0 + d_omega, problem.C_TA0, problem.fit_phase, problem.fit_axis),
                        COMB_TOOTH_EVALUATIONS)
        return c, moved

    known.pop(0, None)  # a member on the mode's own tooth (distinct_modes kept both): the mode's fit stands for it
    teeth = [(chi2, problem)] + list(known.values()) + list(_each(tooth, offsets, workers))
    n_eval = np.array([0, *known, *offsets])
    chi2_eval = np.array([c for c, _ in teeth])
    ok = np.array([t.omega0 > 0 for _, t in teeth])
    n_eval, chi2_eval, teeth = n_eval[ok], chi2_eval[ok], [t for t, keep in zip(teeth, ok) if keep]
    cells = _comb_cells(n_eval, chi2_eval, min(n_lo, 0, *n_eval), max(n_hi, 0, *n_eval), scale)
    lead = int(np.argmin(chi2_eval))
    if lead != 0:  # a tooth lower than the mode's own: the comb is centred there, its covariance taken as the mode's
        moved = teeth[lead][1]
        w, sc, r = moved.solve(np.zeros(moved.n))
        fit = (moved, fit[1], float(r @ r), w, sc)
    centre = teeth[lead][1].state(np.zeros(teeth[lead][1].n))
    d = np.array([np.append(tangent_offset(centre.pole_I, t.state(np.zeros(t.n)).pole_I), 2 * np.pi / t.omega0 - centre.period_s)
                  for _, t in teeth])
    W = cells / cells.sum()
    moments = cov + np.einsum("k,ki,kj->ij", W, d, d)
    return fit, 0.5 * (moments + moments.T), float(np.log(cells.sum()))  # the cells' weights are relative to the lead's


def _comb_family(a: SpinState, b: SpinState, spacing: float) -> bool:
    """Two modes on one comb (:func:`_comb_moments`): poles within 10°, the same body axis within 10°, rates a whole number
    of teeth apart (within a quarter tooth)."""
    if spacing <= 0:
        return False
    k = (b.rate_rad_s - a.rate_rad_s) / spacing
    close = np.cos(np.radians(10.0))
    return bool(a.pole_I @ b.pole_I > close and np.asarray(a.axis_T) @ np.asarray(b.axis_T) > close and abs(k - round(k)) < 0.25)


def _posterior(fits, data: _Data, model, poles, chi2_map, period_map_s, ranges, workers: int) -> InversionResult:
    """Covariances, distinct modes and their probabilities from the refined fits (:mod:`.posterior`); the most probable
    modes' cycle-count combs swept over the searched ``ranges`` and each comb made one mode (:func:`_comb_moments`)."""
    chi2 = np.array([f[2] for f in fits])
    best = int(np.argmin(chi2))
    n_linear = int(np.count_nonzero(fits[best][3])) + int(data.relative.sum()) - int((~data.relative).sum() == 0)
    dof = max(data.y.size - n_linear - fits[best][0].n, 1)
    # s of :mod:`.posterior` eq. (1): the best fit's residuals, night by night, say how much information they carry
    scale, kappa, phi = posterior_scale(fits[best][0].residuals(np.zeros(fits[best][0].n)), data.curve, dof, fits[best][1])
    states, covs, logdets, extras = [], [], [], []
    for problem, J, _, _, _ in fits:
        H = J.T @ J
        cov_theta = scale * np.linalg.pinv(H)
        ev = np.linalg.eigvalsh(cov_theta)
        logdets.append(float(np.sum(np.log(np.clip(ev, 1e-300, None)))))
        cov, phase_sigma, axis_sigma = _pole_period_map(problem, cov_theta)
        states.append(problem.state(np.zeros(problem.n)))
        covs.append(cov)
        extras.append((phase_sigma, axis_sigma))
    keep = distinct_modes([s.pole_I for s in states], [s.period_s for s in states], chi2, covs)
    keep, log_comb = _combs(fits, states, covs, chi2, logdets, keep, data, ranges, scale, workers)
    prob = laplace_probabilities(chi2[keep] - 2.0 * scale * log_comb[keep], np.array(logdets)[keep], scale)
    sols = [SpinSolution(states[i], covs[i], extras[i][0], extras[i][1], float(chi2[i]), float(p), fits[i][3], fits[i][4]) for i, p in zip(keep, prob)]
    sols.sort(key=lambda s: -s.probability)
    return InversionResult(tuple(sols), int(dof), float(scale), model, data.epoch, poles, chi2_map, period_map_s, correlation_time=float(kappa),
                           night_dispersion=float(phi))
