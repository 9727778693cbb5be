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

References
----------
.. [1] Bar-Shalom, Li, Kirubarajan, *Estimation with Applications to Tracking and Navigation*, Wiley, 2001,
   §6.2 (discretised continuous white-noise acceleration model), §8.2.
.. [2] Van Loan, *Computing integrals involving the matrix exponential*, IEEE TAC 23(3), 1978.
.. [3] Maybeck, *Stochastic Models, Estimation, and Control*, vol. 1, Academic Press, 1979, §4.10.
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
    #: longest time over which the white-noise equivalent has to match the disturbance's integral, s (see :meth:`intensity`)
    horizon_s: float = np.inf
    source: str = ""

    def __post_init__(self):
        for name in ("sigma_alpha_rad_s2", "sigma_a_m_s2", "sigma_kdot_1_s", "correlation_time_s"):
            v = getattr(self, name)
            if not (isinstance(v, int | float | np.floating) and np.isfinite(v) and v >= 0):
                raise ValueError(f"DisturbanceBudget.{name}: {v!r}: expected a finite number >= 0")
        if not (isinstance(self.horizon_s, int | float | np.floating) and self.horizon_s > 0):
            raise ValueError(f"DisturbanceBudget.horizon_s: {self.horizon_s!r}: expected a number of seconds > 0 (inf: none)")

    def intensity(self, sigma: float, tau_s: float) -> float:
        """White-noise equivalent ``q = σ² max(min(2 T_c, H), τ)`` of an acceleration of RMS ``σ`` (module docstring).

        ``H`` (``horizon_s``): the random walk ``q t`` matches the integrated disturbance's variance ``2 σ² T_c t`` only for
        ``t ≫ T_c``; over ``t ≪ T_c`` the disturbance is a constant, variance ``σ² t²``, which ``q = σ² t`` matches at ``t``.
        A filter whose data outweigh a disturbance's history after ``H`` seconds needs the match at ``H``, not beyond.
        """
        return float(sigma) ** 2 * max(min(2.0 * self.correlation_time_s, self.horizon_s), float(tau_s))

    def axis_block(self, sigma: float, tau_s: float) -> np.ndarray:
        """Eq. (1) for one axis driven by an acceleration of RMS ``sigma``: ``[[Q_ξξ, Q_ξξ̇], [Q_ξξ̇, Q_ξ̇ξ̇]]`` (2, 2) over ``tau_s`` s."""
        return white_noise_acceleration(self.intensity(sigma, tau_s), tau_s)

    def Q_d(self, tau_s: float) -> np.ndarray:
        """``Q_d`` (14, 14) over the error state ``[δp, δω, δr, δv, δk]`` for a step of ``tau_s`` s (eq. 1 per axis)."""
        Q = np.zeros((N_ERROR, N_ERROR))
        for (pos, rate), sigma in (((DTHETA, DW_ST_T), self.sigma_alpha_rad_s2), ((DR_ST_T, DV_ST_T), self.sigma_a_m_s2)):
            b = self.axis_block(sigma, tau_s)
            eye = np.eye(3)
            Q[pos, pos] = b[0, 0] * eye
            Q[pos, rate] = Q[rate, pos] = b[0, 1] * eye
            Q[rate, rate] = b[1, 1] * eye
        Q[DK, DK] = self.intensity(self.sigma_kdot_1_s, tau_s) * float(tau_s) * np.eye(2)
        return Q
