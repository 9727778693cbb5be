"""CoMBiNa's axisymmetric mode (Maestrini et al. §V, eqs 35–45).

For a target with ``A = C ≠ B`` (symmetry axis = body ``y``), the direction
``J`` of the symmetry axis precesses about the constant angular momentum ``Γ``
(eqs 35–40). The filter estimates ``x_a = [φ, δ, Γ/A]``: azimuth and elevation
of ``J`` in the inertial frame ``I_Γ`` whose ``j`` axis is along ``Γ``
(:func:`estimators.dynamics.axis_from_spherical`), and the precession rate
``Γ/A`` (rad/s), propagated by :func:`estimators.dynamics.axisymmetric_rhs`.

The measurement (§V.B) is the second row of the measured ``C_TI`` — ``J`` in
the inertial frame ``I`` — as azimuth and elevation in ``I``. Eq. 41's ``h``
turns each sigma point's ``(φ, δ)`` into a unit vector, rotates it from
``I_Γ`` to ``I`` and back to spherical coordinates. Two variants:

* ``C_GammaI`` known (the paper's dashed line in Fig. 16): 3 states;
* ``C_GammaI`` estimated: the state grows by the MRP ``σ_IΓ`` of the frame
  rotation (``R(σ_IΓ) = C_IΓ = C_ΓIᵀ``), constant in time — 6 states. The
  paper notes this loses observability (a rotation of ``I_Γ`` about ``j``
  trades against ``φ``); it still converges, more slowly.

Angles: the azimuths are wrapped in every residual and averaged about a
reference sigma point. The measured azimuth's noise grows as ``1/cos δ``
(a direction with isotropic angular noise ``s`` has ``s_φ = s / cos δ``), so
``R = diag(s²/cos²δ̂, s²)`` with ``δ̂`` the predicted elevation — derived here,
the paper gives ``R`` as a constant.

Post-processing (eqs 42–45): ``e = (Γ/A)√(1 − sin²φ cos²δ)`` and
``(ω_y/A)² = (Γ/A)² − e² = (Γ/A)² sin²φ cos²δ`` with ``B = 1``, and their
covariance ``J_F P J_Fᵀ`` with the analytic Jacobian.

References
----------
.. [1] Maestrini, De Luca, Di Lizia, *Relative Navigation Strategy About Unknown and Uncooperative
   Targets*, Journal of Guidance, Control, and Dynamics, 2023.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from estimators.attitude import dcm_to_mrp, mrp_to_dcm
from estimators.combina.unscented import Innovation, UnscentedCore
from estimators.dynamics import axis_from_spherical, axisymmetric_rhs, spherical_from_axis
from estimators.process_noise import MatchedBudget


def axisymmetric_process_noise(dt_s: float, budget: MatchedBudget, gamma_over_a_rad_s: float, n_states: int = 3) -> np.ndarray:
    """``Q`` (n_states × n_states) of one prediction over ``dt_s`` for ``[φ, δ, Γ/A(, σ_IΓ)]`` from the disturbance budget.

    Eqs 35–40 hold ``Γ`` constant; an unmodelled torque (gravity gradient: an angular acceleration ``α = τ/A`` of matched
    intensity ``q = budget.q_alpha_rad2_s3`` per axis, :mod:`estimators.process_noise` eq. 3) changes ``Γ/A`` at ``α`` along
    ``Γ`` and turns ``Γ`` at ``α/(Γ/A)`` across it, which tilts the precession cone of ``J`` about the fixed ``I_Γ`` by as
    much. Both enter as random walks: ``Q_ΓΓ = q τ`` and ``Q_φφ = Q_δδ = q τ / (Γ/A)²`` — an order-of-magnitude map of the
    cone's tilt onto the two angles (``φ``'s own ``1/cos δ`` is left out), stated as such. ``σ_IΓ`` is a constant of the
    model: no noise.
    """
    if not (np.isfinite(dt_s) and dt_s > 0):
        raise ValueError(f"dt_s: {dt_s!r}: expected a positive, finite step in s")
    if not (np.isfinite(gamma_over_a_rad_s) and gamma_over_a_rad_s > 0):
        raise ValueError(f"gamma_over_a_rad_s: {gamma_over_a_rad_s!r}: expected a positive, finite precession rate in rad/s")
    if n_states not in (3, 6):
        raise ValueError(f"n_states: {n_states!r}: expected 3 (I_Γ known) or 6 (I_Γ estimated)")
    qt = budget.q_alpha_rad2_s3 * dt_s
    Q = np.zeros((n_states, n_states))
    Q[0, 0] = Q[1, 1] = qt / gamma_over_a_rad_s**2
    Q[2, 2] = qt
    return Q


def wrap_pi(a):
    """Angle(s) wrapped to ``[-π, π)``."""
    return (np.asarray(a, dtype=float) + np.pi) % (2.0 * np.pi) - np.pi


def chart_difference(phi_a, delta_a, phi_b, delta_b) -> tuple[np.ndarray, np.ndarray]:
    """``(φ_a − φ_b, δ_a − δ_b)`` to the representative of ``b``'s direction nearest to ``a`` (rad).

    :func:`estimators.dynamics.axis_from_spherical` is 2π-periodic in both angles and gives the same direction at
    ``(φ + π, π − δ)``: the filter's ``δ`` is not confined to ``[−π/2, π/2]`` (eq. 40's ``δ̇ = −(Γ/A) cos φ`` carries it over
    the pole ``δ = ±π/2``), so an estimate past the pole and a truth in the principal range describe the same axis with
    angles that differ by up to π. Of the two branches, each wrapped to ``[−π, π)``, the one with the smaller
    ``Δφ² + Δδ²`` is returned.
    """
    d1 = wrap_pi(np.subtract(phi_a, phi_b)), wrap_pi(np.subtract(delta_a, delta_b))
    d2 = wrap_pi(np.subtract(phi_a, phi_b) - np.pi), wrap_pi(np.subtract(delta_a, np.pi) + delta_b)
    second = d2[0] ** 2 + d2[1] ** 2 < d1[0] ** 2 + d1[1] ** 2
    return np.where(second, d2[0], d1[0]), np.where(second, d2[1], d1[1])


def gamma_frame_dcm(Gamma_I, J_I=None) -> np.ndarray:
    """``C_ΓI``: rows ``i, j, k`` of ``I_Γ`` in ``I``, with ``j`` along ``Γ``.

    ``k`` is taken along ``Γ × J`` when a symmetry axis ``J_I`` is given (so
    ``J`` starts in the ``i``–``j`` plane, ``δ = 0``, far from the ``±k``
    singularity of the azimuth), else along ``Γ ×`` the inertial axis least
    aligned with ``Γ``.
    """
    j = np.asarray(Gamma_I, dtype=float)
    if not (np.all(np.isfinite(j)) and np.linalg.norm(j) > 0):
        raise ValueError("Gamma_I must be a finite non-zero vector")
    j = j / np.linalg.norm(j)
    ref = None if J_I is None else np.asarray(J_I, dtype=float)
    if ref is None or np.linalg.norm(np.cross(j, ref)) < 1e-6 * np.linalg.norm(ref):
        ref = np.eye(3)[int(np.argmin(np.abs(j)))]
    k = np.cross(j, ref)
    k /= np.linalg.norm(k)
    i = np.cross(j, k)
    return np.stack([i, j, k])


@dataclass(frozen=True)
class SpinQuantities:
    """Eqs 42–45: ``x_e = [e, (ω_y/A)²]`` (rad/s, rad²/s²) and its covariance."""

    x_e: np.ndarray  #: (2,)
    P_e: np.ndarray  #: (2, 2)


def spin_quantities(x, P) -> SpinQuantities:
    """``e``, ``(ω_y/A)²`` of an axisymmetric estimate and their covariance by the Jacobian (eqs 42–45)."""
    x = np.asarray(x, dtype=float)
    P = np.asarray(P, dtype=float)
    phi, delta, g = x[0], x[1], x[2]
    sp, cp, sd, cd = np.sin(phi), np.cos(phi), np.sin(delta), np.cos(delta)
    u = max(1.0 - sp**2 * cd**2, 0.0)  # 1 − J_y², clipped against round-off
    ru = np.sqrt(u)
    e = g * ru  # eq. 42
    wy2 = g**2 * sp**2 * cd**2  # eq. 43: (Γ/A)² − e²
    JF = np.zeros((2, x.shape[0]))  # eq. 45
    JF[1, :3] = [2 * g**2 * sp * cp * cd**2, -2 * g**2 * sp**2 * cd * sd, 2 * g * sp**2 * cd**2]
    if ru > 0.0:
        JF[0, :3] = [-g * sp * cp * cd**2 / ru, g * sp**2 * cd * sd / ru, ru]
        P_e = JF @ P @ JF.T  # eq. 44
    else:
        # symmetry axis along Γ (pure spin, e = 0): e = (Γ/A)·√u has a cone point
        # there and no first-order covariance; say so with NaN rather than divide by 0
        P_e = JF @ P @ JF.T
        P_e[0, :] = P_e[:, 0] = np.nan
    return SpinQuantities(x_e=np.array([e, wy2]), P_e=P_e)


def _residual_azimuth_first(a, b):
    """``a − b`` with the first component (an azimuth) wrapped to ``[-π, π)``."""
    d = np.subtract(a, b)
    d[..., 0] = wrap_pi(d[..., 0])
    return d


def _mean_azimuth_first(X, Wm):
    """Weighted mean with the first column an azimuth, averaged about the central point."""
    ref = X[0, 0]
    m = Wm @ X
    m[0] = wrap_pi(ref + Wm @ wrap_pi(X[:, 0] - ref))
    return m


class AxisymmetricUKF:
    """UKF on ``[φ, δ, Γ/A]`` (+ ``σ_IΓ`` when the frame is estimated), SI units.

    Parameters
    ----------
    x0, P0
        initial estimate and covariance: 3 states with ``C_GammaI`` given,
        6 states (``[φ, δ, Γ/A, σ_IΓ]``) without.
    C_GammaI : (3, 3), optional
        the known rotation from ``I`` to ``I_Γ``.
    """

    def __init__(self, x0, P0, *, C_GammaI=None, max_step_s: float = 5.0, Q=None, alpha: float = 1.0, beta: float = 2.0, kappa: float = 0.0):
        x0 = np.asarray(x0, dtype=float)
        n = 3 if C_GammaI is not None else 6
        if x0.shape != (n,):
            layout = "[phi, delta, gamma_over_a]" if n == 3 else "[phi, delta, gamma_over_a, sigma_IGamma]"
            raise ValueError(f"x0 must have shape ({n},) {layout}, got {x0.shape}")
        if not (np.isfinite(max_step_s) and max_step_s > 0):
            raise ValueError(f"max_step_s must be positive and finite, got {max_step_s!r}")
        self.C_GammaI = None if C_GammaI is None else np.asarray(C_GammaI, dtype=float)
        self.core = UnscentedCore(x0, P0, alpha=alpha, beta=beta, kappa=kappa, residual_x=_residual_azimuth_first)
        self.max_step_s = float(max_step_s)
        self.Q = Q if Q is None or callable(Q) else np.asarray(Q, dtype=float)

    @property
    def x(self) -> np.ndarray:
        return self.core.x

    @property
    def P(self) -> np.ndarray:
        return self.core.P

    def frame_dcm(self, x=None) -> np.ndarray:
        """``C_ΓI`` (known, or from the estimated ``σ_IΓ``)."""
        if self.C_GammaI is not None:
            return self.C_GammaI
        x = self.core.x if x is None else x
        return np.swapaxes(mrp_to_dcm(x[..., 3:6]), -1, -2)

    def axis_I(self) -> np.ndarray:
        """Estimated symmetry axis ``J`` in ``I``."""
        return self.frame_dcm().T @ axis_from_spherical(self.core.x[0], self.core.x[1])

    def _rhs(self, X):
        d = axisymmetric_rhs(0.0, X[:, :3])  # eqs 39–40 in spherical form
        return d if X.shape[1] == 3 else np.concatenate([d, np.zeros((X.shape[0], 3))], axis=1)

    def _propagate(self, X, dt):
        n_sub = max(1, int(np.ceil(dt / self.max_step_s)))
        h = dt / n_sub
        for _ in range(n_sub):
            k1 = self._rhs(X)
            k2 = self._rhs(X + 0.5 * h * k1)
            k3 = self._rhs(X + 0.5 * h * k2)
            k4 = self._rhs(X + h * k3)
            X = X + h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
        X[:, 0] = wrap_pi(X[:, 0])
        return X

    def predict(self, dt_s: float) -> None:
        """Eqs 10–13 with the precession model over ``dt_s`` seconds."""
        if not (np.isfinite(dt_s) and dt_s > 0):
            raise ValueError(f"dt_s must be positive and finite, got {dt_s!r}")
        Q = self.Q(dt_s) if callable(self.Q) else self.Q
        self.core.predict(lambda X: self._propagate(X, dt_s), Q=Q, mean_fn=_mean_azimuth_first)

    def h(self, X) -> np.ndarray:
        """Eq. 41: sigma points to the azimuth and elevation of ``J`` in ``I``."""
        J_G = axis_from_spherical(X[:, 0], X[:, 1])
        if self.C_GammaI is not None:
            J_I = J_G @ self.C_GammaI  # C_IΓ J_Γ, row-wise
        else:
            J_I = np.einsum("nij,nj->ni", mrp_to_dcm(X[:, 3:6]), J_G)
        phi_I, delta_I = spherical_from_axis(J_I)
        return np.stack([phi_I, delta_I], axis=1)

    def innovation(self, J_I_meas, var_rad2: float) -> Innovation:
        """Eqs 41, 15–17, 23 for a measured symmetry axis ``J_I_meas`` (second row of ``C_TI``).

        ``var_rad2`` is the angular noise variance of the measured direction.
        """
        if not (np.isfinite(var_rad2) and var_rad2 > 0):
            raise ValueError(f"var_rad2 must be positive and finite, got {var_rad2!r}")
        phi_m, delta_m = spherical_from_axis(np.asarray(J_I_meas, dtype=float))
        z_pred = _mean_azimuth_first(self.h(self.core.sigmas), self.core.points.Wm)
        cd = max(np.cos(z_pred[1]), 1e-3)
        R = np.diag([var_rad2 / cd**2, var_rad2])
        return self.core.innovation([float(phi_m), float(delta_m)], R, self.h, residual_z=_residual_azimuth_first, mean_z=_mean_azimuth_first)

    def correct(self, inn: Innovation) -> None:
        """Eqs 21–22, 24; the azimuth is wrapped afterwards."""
        self.core.correct(inn)
        self.core.x[0] = float(wrap_pi(self.core.x[0]))

    def spin_quantities(self) -> SpinQuantities:
        """Eqs 42–45 for the current estimate."""
        return spin_quantities(self.core.x, self.core.P)


def frame_mrp(C_GammaI) -> np.ndarray:
    """``σ_IΓ`` with ``R(σ_IΓ) = C_IΓ = C_ΓIᵀ`` (initial value of the estimated-frame variant)."""
    return dcm_to_mrp(np.asarray(C_GammaI, dtype=float).T)
