"""Process noise ``Q_d`` of the 15-state relative filter from a stated disturbance budget (issue 31).

The filters propagate the target torque-free and both orbits Keplerian (eq. 21 of Renis et
al.); what the truth has beyond that — gravity-gradient torque, nutation damping, J2, drag, solar
pressure — is, to the filter, an unmodelled acceleration. :class:`DisturbanceBudget` states its
size: ``sigma_alpha_rad_s2`` (the target's angular acceleration ``ω̇``, RMS per axis),
``sigma_a_m_s2`` (the differential translational acceleration ``a_S − a_T``, RMS per axis),
``sigma_kdot_1_s`` (the drift of the inertia ratios that would mimic the dissipation, see
:func:`kdot_from_dissipation`) and the disturbances' correlation time ``correlation_time_s``.

Derivation
----------
Model each unmodelled acceleration ``a(t)`` (one axis) as a zero-mean stationary process of
variance ``σ²`` and correlation time ``T_c`` (first-order Gauss–Markov,
``E[a(t) a(t+s)] = σ² e^{−|s|/T_c}``). Over times long against ``T_c`` its integral is a
Wiener process of intensity equal to its spectral density at zero frequency,

    q = 2 σ² T_c                                             (white-noise equivalent)

(Bar-Shalom, Li & Kirubarajan 2001, §8.2; Maybeck 1979, §4.10). The error state of one axis of
a quantity driven by it, ``[position-like ξ, rate-like ξ̇]`` with ``ξ̈ = a``, is the continuous
white-noise-acceleration model ``ẋ = A x + G w``, ``A = [[0, 1], [0, 0]]``, ``G = [0, 1]ᵀ``,
``E[w(t) w(s)] = q δ(t − s)``; over a step ``τ`` its discrete covariance is (Van Loan 1978;
Bar-Shalom et al. eq. 6.2.3-8)

    Q_d = ∫₀^τ e^{A s} G q Gᵀ e^{Aᵀ s} ds = q [[τ³/3, τ²/2], [τ²/2, τ]].      (1)

For the attitude error ``δp`` (≈ the rotation vector of ``q̂ ⊗ q⁻¹``, rad) and the relative rate
``δω_ST_T`` (rad/s) the acceleration is ``−ω̇_T`` (the target's unmodelled angular acceleration,
frame T): ``Q_pp = q_α τ³/3``, ``Q_pω = q_α τ²/2``, ``Q_ωω = q_α τ`` per axis, with
``q_α = 2 σ_α² T_c``. The same with ``q_a = 2 σ_a² T_c`` for ``δr_ST_T`` (m) and ``δv_ST_T``
(m/s). The signs of the cross terms are those of ``∂δp/∂δω`` and ``∂δr/∂δv`` in the step's
Jacobian, ``+τ I`` to first order (checked in ``tests/estimators/test_process_noise.py``). The
rotation of the frame T within a step couples the axes at order ``|ω| τ`` (0.2 at SC4's
0.2 rad/s and 1 s) and is left out: the budget's per-axis RMS is taken as isotropic, ``σ²`` per
axis being the RMS of the norm squared over 3. The inertia-ratio block is a random walk,
``Q_kk = 2 σ_k̇² T_c τ`` per ratio (the same white-noise equivalent, one integration).

``T_c``: the torque on a tumbling target varies at its spin harmonics and along the orbit; a
``T_c`` shorter than the filter's step turns the white-noise equivalent into the variance of a
constant acceleration over one step, ``q = σ² τ`` (rate variance ``σ² τ²``), which the module
uses as a floor: ``q = σ² max(2 T_c, τ)``.

Matched intensity
-----------------
A Gauss–Markov ``σ, T_c`` over-states what a tumbling target's torque does to a filter: the gravity-gradient
torque turns with the target, its integral stays bounded, and its spectrum near zero frequency — the only part a
filter with a memory of minutes cannot average out — is far below ``2 σ² T_c`` (measured: the perturbed truth's
``H``-second means carry 0.34, 0.076 and 0.041 of that intensity at ``H`` = 60, 300, 600 s on SC3).
:func:`matched_intensity` states the budget as the white-noise intensity that gives the filter the error variance the
real spectrum gives it. One axis of the double integrator ``ξ̈ = a`` measured as ``y = ξ + v`` (``E[v v] = r δ``,
``r = R τ_s`` for a measurement variance ``R`` every ``τ_s``): with a white ``a`` of intensity ``q`` the steady-state
Kalman–Bucy gains are ``K = [√2 ω_n, ω_n²]``, ``ω_n = (q/r)^{1/4}`` (Bar-Shalom et al. §6.5; Brown & Hwang,
*Introduction to Random Signals and Applied Kalman Filtering*, 4th ed., §8.3), and the estimate's error responds to
the acceleration through

    E_ξ(s) = 1 / (s² + √2 ω_n s + ω_n²),   E_ξ̇(s) = (s + √2 ω_n) / (s² + √2 ω_n s + ω_n²).        (2)

Its rate-error variance from an acceleration of two-sided spectral density ``S(ω)`` is ``(1/2π) ∫ |E_ξ̇(jω)|² S(ω) dω``,
and from the white model ``q`` times the same integral of ``|E_ξ̇|²``. The two agree when

    q = ∫ |E_ξ̇(jω; q)|² S(ω) dω / ∫ |E_ξ̇(jω; q)|² dω,                                           (3)

a weighted mean of the spectrum over the filter's own band — a fixed point, since ``ω_n`` depends on ``q``
(solved by iteration from the spectrum's mean; a contraction: ``ω_n`` moves as ``q^{1/4}``). White ``S = q₀``
gives ``q₀``; a spectrum whose power lies far above ``ω_n`` (a torque at the spin harmonics) gives nearly nothing.

Where the disturbance is absent
-------------------------------
A filter whose ``Q`` covers a disturbance is conservative on a truth without it, by a fixed amount once its ``Q`` has
set its memory. The steady-state filter of eq. (2) has the error covariance ``P = P_w + P_v``, the parts driven by the
acceleration and by the measurement noise: with ``F = A − K C`` (``C = [1, 0]``),
``F P_w + P_w Fᵀ + G q Gᵀ = 0`` and ``F P_v + P_v Fᵀ + K r Kᵀ = 0``. Without the disturbance the error is ``P_v``
alone, and

    E[eᵀ P⁻¹ e] / 2 = tr(P⁻¹ P_v) / 2 = 1/2   for every q/r,                                            (4)

with ``P_v`` carrying 3/4 of ``P``'s position variance and 1/4 of its rate variance (solve the two Lyapunov equations
with ``ω_n = 1``: ``P = [[√2, 1], [1, √2]]``, ``P_v = [[3√2/4, 1/2], [1/2, √2/4]]``; ``q/r`` only rescales them;
``tests/estimators/test_process_noise.py``). A filter with ``Q > 0`` in steady state therefore cannot have its NEES in
the χ² band both on a truth with the disturbance ``Q`` is matched to and on one without it (the band of the mean of 30
runs of 6 states is ``[0.81, 1.22]`` per state); only a ``Q`` too small to matter within the run — memory
``(r/q)^{1/4}`` longer than the run, which the disturbance it leaves out then dominates — is in band without the
disturbance.

:class:`MatchedBudget` holds the three intensities so derived (``studies.sim.matched_noise.matched_budget`` measures
them on a simulated truth) and assembles ``Q_d`` by eq. (1), as :class:`DisturbanceBudget` does from ``σ, T_c``.

Constant accelerations
----------------------
A spectrum weighted over the filter's band (eq. 3) sees a constant acceleration only in its lowest bins, yet a constant is
what differential drag is: along-track in the orbit frame L, ``|ā| ≈ 2.3e-7 m/s²`` on the perturbed truth for the whole
orbit. Over a horizon ``H`` it moves the relative position by ``ā H²/2``, which a white acceleration of intensity ``q``
matches in variance, ``q H³/3`` per axis, at

    q = 3 |ā|² H / 4.                                                                            (5)

The horizon is not the position channel's memory ``(r/q)^{1/4}`` (minutes): for a formation along the track, the pose
measurements in the target frame cannot tell a pitch error of the target frame (about the orbit normal) from a radial offset
of the servicer; only the relative orbit's dynamics separate them (a radial offset drifts along the track at ``−3/2 n x``),
on their own time scale ``H = 1/n`` (15 min at 500 km). Measured (SC3, gravity gradient modelled, 20 runs of one orbit, EKF):
with eq. (3)'s 1.7e-11 m²/s³ the drag's drift went into a pitch bias common to every run (+5 mrad about the orbit normal,
attitude NEES/dof rising to 2.8); with eq. (5) at ``H = 1/n`` (3.6e-11) the attitude block stays at 0.86–1.29
(:func:`constant_acceleration_intensity`).

References
----------
.. [1] Bar-Shalom, Li, Kirubarajan, *Estimation with Applications to Tracking and Navigation*, Wiley, 2001,
   §6.2 (discretised continuous white-noise acceleration model), §8.2.
.. [2] Van Loan, *Computing integrals involving the matrix exponential*, IEEE TAC 23(3), 1978.
.. [3] Maybeck, *Stochastic Models, Estimation, and Control*, vol. 1, Academic Press, 1979, §4.10.
.. [4] Brown, Hwang, *Introduction to Random Signals and Applied Kalman Filtering*, 4th ed., Wiley, 2012, §8.3
   (steady-state Kalman–Bucy filter of the double integrator).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from estimators.state import DK, DR_ST_T, DTHETA, DV_ST_T, DW_ST_T, N_ERROR


def white_noise_acceleration(q: float, tau_s: float) -> np.ndarray:
    """Eq. (1): ``q [[τ³/3, τ²/2], [τ²/2, τ]]`` (2, 2), the discrete covariance of ``[ξ, ξ̇]`` under ``ξ̈ = w``, ``E[w w] = q δ``.

    ``q``: spectral density of the white acceleration (unit² of ξ per s³); ``tau_s``: step, s.
    """
    q, tau = float(q), float(tau_s)
    if not (np.isfinite(q) and q >= 0):
        raise ValueError(f"q: {q!r}: expected a finite spectral density >= 0")
    if not (np.isfinite(tau) and tau > 0):
        raise ValueError(f"tau_s: {tau!r}: expected a finite step > 0 s")
    return q * np.array([[tau**3 / 3.0, tau**2 / 2.0], [tau**2 / 2.0, tau]])


def constant_acceleration_intensity(a_mean, horizon_s: float) -> float:
    """Eq. (5): ``3 |ā|² H / 4``, the white-noise intensity (unit²/s³) whose position variance over ``horizon_s`` matches the
    displacement of the constant acceleration ``a_mean`` (its vector, unit/s², or its norm), on every axis."""
    a = np.atleast_1d(np.asarray(a_mean, dtype=float))
    H = float(horizon_s)
    if a.ndim != 1 or not np.all(np.isfinite(a)):
        raise ValueError(f"a_mean: {a_mean!r}: expected a finite acceleration vector or norm")
    if not (np.isfinite(H) and H > 0):
        raise ValueError(f"horizon_s: {horizon_s!r}: expected a finite horizon > 0 s")
    return 0.75 * float(a @ a) * H


def kdot_from_dissipation(alpha_dissipation_rad_s2: float, spin_rad_s: float) -> float:
    """Drift rate (1/s) of ``k1, k2`` that changes ``ω̇`` by the dissipation's angular acceleration.

    Euler's equations with ``k = ln`` of inertia ratios give ``∂ω̇/∂k ~ |ω|²`` (the gyroscopic terms
    ``(B − C)/A ω_y ω_z`` scale with ``e^k``), so an unmodelled ``α_d`` (rad/s²) is what a ``k``
    drifting at ``α_d / |ω|²`` per second would produce. An order-of-magnitude map, stated as such.
    """
    a, w = float(alpha_dissipation_rad_s2), float(spin_rad_s)
    if not (np.isfinite(a) and a >= 0):
        raise ValueError(f"alpha_dissipation_rad_s2: {a!r}: expected a finite angular acceleration >= 0")
    if not (np.isfinite(w) and w > 0):
        raise ValueError(f"spin_rad_s: {w!r}: expected a finite spin rate > 0")
    return a / w**2


@dataclass(frozen=True)
class DisturbanceBudget:
    """RMS unmodelled accelerations per axis and their correlation time (see the module docstring).

    ``sigma_alpha_rad_s2``: target angular acceleration, rad/s²; ``sigma_a_m_s2``: differential
    translational acceleration, m/s²; ``sigma_kdot_1_s``: inertia-ratio drift, 1/s;
    ``correlation_time_s``: ``T_c``, s. ``source``: where the numbers come from.
    """

    sigma_alpha_rad_s2: float
    sigma_a_m_s2: float
    sigma_kdot_1_s: float = 0.0
    correlation_time_s: float = 0.0
    source: str = ""

    def __post_init__(self):
        for name in ("sigma_alpha_rad_s2", "sigma_a_m_s2", "sigma_kdot_1_s", "correlation_time_s"):
            v = getattr(self, name)
            if not (isinstance(v, int | float | np.floating) and np.isfinite(v) and v >= 0):
                raise ValueError(f"DisturbanceBudget.{name}: {v!r}: expected a finite number >= 0")

    def intensity(self, sigma: float, tau_s: float) -> float:
        """White-noise equivalent ``q = σ² max(2 T_c, τ)`` of an acceleration of RMS ``σ`` (module docstring)."""
        return float(sigma) ** 2 * max(2.0 * self.correlation_time_s, float(tau_s))

    def Q_d(self, tau_s: float) -> np.ndarray:
        """``Q_d`` (14, 14) over the error state ``[δp, δω, δr, δv, δk]`` for a step of ``tau_s`` s (eq. 1 per axis)."""
        return relative_Q_d(self.intensity(self.sigma_alpha_rad_s2, tau_s), self.intensity(self.sigma_a_m_s2, tau_s),
                            self.intensity(self.sigma_kdot_1_s, tau_s), tau_s)


def relative_Q_d(q_alpha: float, q_a: float, q_kdot: float, tau_s: float) -> np.ndarray:
    """``Q_d`` (14, 14) over ``[δp, δω, δr, δv, δk]`` for a step of ``tau_s`` s: eq. (1) per axis with the angular (``q_alpha``,
    rad²/s³) and the translational (``q_a``, m²/s³) intensities, a random walk of intensity ``q_kdot`` (1/s) on each ``k``."""
    Q = np.zeros((N_ERROR, N_ERROR))
    eye = np.eye(3)
    for (pos, rate), q in (((DTHETA, DW_ST_T), q_alpha), ((DR_ST_T, DV_ST_T), q_a)):
        b = white_noise_acceleration(q, tau_s)
        Q[pos, pos] = b[0, 0] * eye
        Q[pos, rate] = Q[rate, pos] = b[0, 1] * eye
        Q[rate, rate] = b[1, 1] * eye
    Q[DK, DK] = float(q_kdot) * float(tau_s) * np.eye(2)
    return Q


def rate_error_response(omega_rad_s, q: float, r: float) -> np.ndarray:
    """``|E_ξ̇(jω)|²`` of eq. (2) (s²) at angular frequencies ``omega_rad_s`` for intensities ``q`` (acceleration) and ``r`` (measurement)."""
    wn = (float(q) / float(r)) ** 0.25
    s = 1j * np.asarray(omega_rad_s, dtype=float)
    return np.abs((s + np.sqrt(2.0) * wn) / (s * s + np.sqrt(2.0) * wn * s + wn * wn)) ** 2


def matched_intensity(freq_hz, psd_one_sided, r: float, *, rtol: float = 1e-10, max_iter: int = 500) -> float:
    """Eq. (3): the white-noise intensity ``q`` that gives a steady-state filter the rate-error variance the spectrum gives it.

    ``freq_hz (n,)``: frequencies ≥ 0, Hz, evenly spaced from 0 (a periodogram's); ``psd_one_sided (n,)``: the acceleration's
    one-sided spectral density there (unit²/Hz; white noise of intensity ``q`` has ``2 q``), e.g. ``scipy.signal.periodogram``'s;
    ``r``: the measurement's noise intensity ``R τ_s`` (unit² s). Returns ``q`` (unit²/s³ for an acceleration in unit/s²).
    """
    f = np.asarray(freq_hz, dtype=float)
    G = np.asarray(psd_one_sided, dtype=float)
    if f.ndim != 1 or f.shape != G.shape or f.size < 2 or not (np.all(np.isfinite(f)) and np.all(np.isfinite(G))):
        raise ValueError(f"freq_hz, psd_one_sided: shapes {f.shape}, {G.shape}: expected two finite 1-D arrays of the same length >= 2")
    if f[0] != 0.0 or np.any(np.diff(f) <= 0) or np.any(G < 0):
        raise ValueError("freq_hz, psd_one_sided: expected increasing frequencies from 0 Hz and a non-negative density")
    if not (np.isfinite(r) and r > 0):
        raise ValueError(f"r: {r!r}: expected a finite measurement noise intensity > 0")
    S = G / 2.0  # two-sided, per the q convention of eq. (1)
    q = float(np.mean(S))
    if q == 0.0:
        return 0.0
    omega = 2.0 * np.pi * f
    for _ in range(max_iter):
        W = rate_error_response(omega, q, r)
        q_new = float(np.sum(W * S) / np.sum(W))
        if abs(q_new - q) <= rtol * q:
            return q_new
        q = q_new
    raise RuntimeError(f"matched_intensity: no fixed point after {max_iter} iterations (last q {q:.3g})")


@dataclass(frozen=True)
class MatchedBudget:
    """Matched intensities (eq. 3) of the unmodelled accelerations: ``q_alpha_rad2_s3`` (the target's ``ω̇``, per axis),
    ``q_a_m2_s3`` (the differential translational acceleration, per axis), ``q_kdot_1_s`` (random walk of each ``k``).
    ``source``: where they were measured. ``Q_d`` as :class:`DisturbanceBudget`'s (eq. 1)."""

    q_alpha_rad2_s3: float
    q_a_m2_s3: float
    q_kdot_1_s: float = 0.0
    source: str = ""

    def __post_init__(self):
        for name in ("q_alpha_rad2_s3", "q_a_m2_s3", "q_kdot_1_s"):
            v = getattr(self, name)
            if not (isinstance(v, int | float | np.floating) and np.isfinite(v) and v >= 0):
                raise ValueError(f"MatchedBudget.{name}: {v!r}: expected a finite intensity >= 0")

    def Q_d(self, tau_s: float) -> np.ndarray:
        """``Q_d`` (14, 14) for a step of ``tau_s`` s (:func:`relative_Q_d`)."""
        return relative_Q_d(self.q_alpha_rad2_s3, self.q_a_m2_s3, self.q_kdot_1_s, tau_s)
