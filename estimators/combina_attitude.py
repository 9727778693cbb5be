"""CoMBiNa's attitude UKF (``000_…`` §IV.B, eqs 25–32).

State ``x_a = [σ_IT, ω_T, k1, k2]`` (8): the MRP of the target's attitude
``q_IT`` (target frame T to inertial I; the paper's ``σ_T`` of ``C_TI``, see
:func:`estimators.attitude.dcm_to_mrp`), the target's angular velocity in its
own principal axes (rad/s), and the inertia ratios ``k1 = ln(A/B)``,
``k2 = ln(B/C)`` (eqs 26–27). Process model: MRP kinematics (eq. 28,
:func:`estimators.attitude.mrp_derivative`) and torque-free Euler equations
(eq. 29) with ``k̇ = 0``; measurement: the MRP (eq. 30).

Two details the paper leaves implicit:

* **MRP wrap in the innovation.** A measured attitude has two MRPs, ``σ`` and
  its shadow ``−σ/|σ|²``. Near ``|σ| = 1`` the predicted estimate and the
  measurement's ``|σ| ≤ 1`` set can sit on opposite sides, and their
  difference would then be a spurious ~360° error. Eq. 30 is linear, so the
  predicted measurement equals the predicted MRP; the measurement is
  expressed in whichever of its two sets lies closer to it before eq. 23.
* **Shadow switch** (eqs 31–32): after every correction with ``|σ| > 1`` the
  estimate moves to the shadow set and ``P`` is transformed by the Jacobian
  (:func:`estimators.attitude.mrp_shadow_covariance`). The attitude itself is
  unchanged (same rotation), so the attitude error is continuous across it.

Spin priors (``002_…`` §6, used by the studies): ``ω_0`` and its ``P_0`` block
are simply the constructor's arguments; :meth:`rate_proxy_innovation` builds
the proxy measurement of the spin *rate* ``|ω|`` that a light curve gives.
"""

from __future__ import annotations

import numpy as np

from estimators.attitude import mrp_derivative, mrp_shadow, mrp_shadow_covariance, mrp_to_quat, quat_to_mrp
from estimators.combina_unscented import Innovation, UnscentedCore
from estimators.dynamics import euler_rhs

#: Layout of the attitude state.
SIGMA, OMEGA, K = slice(0, 3), slice(3, 6), slice(6, 8)


def attitude_rhs(x: np.ndarray) -> np.ndarray:
    """``ẋ_a`` of eqs 28–29 with ``k̇ = 0`` for a batch ``(..., 8)``."""
    x = np.asarray(x, dtype=float)
    w = x[..., OMEGA]
    J = np.stack([np.exp(x[..., 6]), np.ones_like(x[..., 6]), np.exp(-x[..., 7])], axis=-1)  # eq. 27
    return np.concatenate([mrp_derivative(x[..., SIGMA], w), euler_rhs(w, J), np.zeros_like(x[..., K])], axis=-1)


def nearest_mrp(sigma, reference) -> np.ndarray:
    """The one of ``σ`` and its shadow set that lies closer to ``reference`` (same rotation)."""
    s = np.asarray(sigma, dtype=float)
    ref = np.asarray(reference, dtype=float)
    if np.dot(s, s) == 0.0:
        return s.copy()
    sh = mrp_shadow(s)
    return sh if np.linalg.norm(sh - ref) < np.linalg.norm(s - ref) else s.copy()


class AttitudeUKF:
    """UKF on ``[σ_IT, ω_T (rad/s), k1, k2]`` (eqs 28–32 of ``000_…``), SI units.

    Parameters
    ----------
    x0 : (8,)
        initial estimate; ``|σ| ≤ 1`` is not required.
    P0 : (8, 8)
        its covariance (MRP², rad²/s², 1).
    max_step_s : float
        longest RK4 step of the propagation.
    Q : (8, 8), optional
        additive process noise per prediction.
    """

    def __init__(self, x0, P0, *, max_step_s: float = 5.0, Q=None, alpha: float = 1.0, beta: float = 2.0, kappa: float = 0.0):
        if np.asarray(x0).shape != (8,):
            raise ValueError(f"x0 must have shape (8,) [sigma, w, k1, k2], got {np.asarray(x0).shape}")
        if not (np.isfinite(max_step_s) and max_step_s > 0):
            raise ValueError(f"max_step_s must be positive and finite, got {max_step_s!r}")
        self.core = UnscentedCore(x0, P0, alpha=alpha, beta=beta, kappa=kappa)
        self.max_step_s = float(max_step_s)
        self.Q = None if Q is None else np.asarray(Q, dtype=float)
        self.n_shadow_switches = 0

    @property
    def x(self) -> np.ndarray:
        return self.core.x

    @property
    def P(self) -> np.ndarray:
        return self.core.P

    @property
    def q_IT(self) -> np.ndarray:
        """Estimated attitude as a scalar-first quaternion (T to I)."""
        return mrp_to_quat(self.core.x[SIGMA])

    def _propagate(self, X: np.ndarray, dt: float) -> np.ndarray:
        n_sub = max(1, int(np.ceil(dt / self.max_step_s)))
        h = dt / n_sub
        for _ in range(n_sub):
            k1 = attitude_rhs(X)
            k2 = attitude_rhs(X + 0.5 * h * k1)
            k3 = attitude_rhs(X + 0.5 * h * k2)
            k4 = attitude_rhs(X + h * k3)
            X = X + h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
        return X

    def predict(self, dt_s: float) -> None:
        """Eqs 10–13 with the process model of eqs 28–29 over ``dt_s`` seconds."""
        if not (np.isfinite(dt_s) and dt_s > 0):
            raise ValueError(f"dt_s must be positive and finite, got {dt_s!r}")
        self.core.predict(lambda X: self._propagate(X, dt_s), Q=self.Q)

    def innovation(self, q_IT_meas, R) -> Innovation:
        """Eqs 30, 15–17, 23 for a measured attitude (quaternion T to I) with MRP covariance ``R`` (3×3).

        The measured MRP is taken on the predicted set's side (see the module docstring).
        """
        z = nearest_mrp(quat_to_mrp(q_IT_meas), self.core.x[SIGMA])
        return self.core.innovation(z, R, lambda X: X[:, SIGMA])  # eq. 30

    def rate_proxy_innovation(self, rate_rad_s: float, var_rad2_s2: float) -> Innovation:
        """A proxy measurement of the spin rate ``|ω|`` (a light-curve prior), ``h(x) = |ω|``."""
        if not (np.isfinite(rate_rad_s) and rate_rad_s > 0 and np.isfinite(var_rad2_s2) and var_rad2_s2 > 0):
            raise ValueError("the proxy rate and its variance must be positive and finite")
        return self.core.innovation([rate_rad_s], [[var_rad2_s2]], lambda X: np.linalg.norm(X[:, OMEGA], axis=1, keepdims=True))

    def correct(self, inn: Innovation) -> bool:
        """Eqs 21–22, 24, then the shadow-set switch of eqs 31–32 if ``|σ| > 1``.

        Returns whether the switch happened.
        """
        self.core.correct(inn)
        return self.switch_to_shadow_if_needed()

    def switch_to_shadow_if_needed(self) -> bool:
        """Eqs 31–32: move ``σ`` with ``|σ| > 1`` to its shadow set, transforming ``P``."""
        s = self.core.x[SIGMA]
        if float(np.dot(s, s)) <= 1.0:
            return False
        sigma_s, P_s = mrp_shadow_covariance(s, self.core.P, n_mrp=0)
        x = self.core.x.copy()
        x[SIGMA] = sigma_s
        self.core.x = x
        self.core.P = 0.5 * (P_s + P_s.T)
        self.core.sigmas = self.core.points.sigma_points(self.core.x, self.core.P)
        self.n_shadow_switches += 1
        return True
