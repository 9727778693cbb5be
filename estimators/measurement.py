"""Measurement models: the pose measurement of eq. 24 of Renis et al. and the spin-prior proxy.

A measurement *source* is one independently gated part of the measurement
vector (§4.3 of Renis et al.): the attitude ``q_TS``, the position ``r_ST_T``, or
the fictitious rate measurement of a spin prior (§6.3). Each source knows,
in the coordinates of the filters' error state (:mod:`estimators.error_state`),

* ``z_chart(z, x_ref)``: the measured value as a vector about a reference state;
* ``h_chart(X, x_ref)``: the predicted value of state(s) ``X`` about the same reference;
* ``jacobian(x)``: ``H = ∂h/∂δx`` (m × 14), for the EKF (eq. 25);
* ``R``: its noise covariance (part of ``R_d``).

The attitude innovation is the MRP form of eqs 29–30: ``δp̃ = [ỹ_q ⊗ q̂⁻¹]_MRP``
(scaled to ≈ the rotation vector, see :mod:`estimators.error_state`), so that
for the EKF ``y = δp̃`` with ``H = [I₃ 0 …]``, and for the UKF each sigma point
predicts its own ``δp`` about the reference. The position part is linear:
``h = r_ST_T``, ``H = [0 0 I₃ 0 0]``.

:class:`PoseNoise` is the one description of the pose estimator's noise: the
simulator (:func:`perception.simulated_pose.simulate_pose_measurements`)
draws from it and the filters take their ``R_d`` from it
(:meth:`PoseNoise.sources`), so editing a configuration's noise changes both.
A study that mis-models on purpose passes the filter a different
``PoseNoise`` and says so.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from estimators.attitude import quat_to_dcm, skew
from estimators.error_state import attitude_error
from estimators.state import DR_ST_T, DTHETA, DW_ST_T, N_ERROR, Q_TS, R_ST_T, W_ST_T


def _cov(R, m: int, name: str) -> np.ndarray:
    R = np.atleast_2d(np.asarray(R, dtype=float))
    if R.shape == (1, 1) and m > 1:
        R = R[0, 0] * np.eye(m)
    if R.shape != (m, m) or not np.all(np.isfinite(R)) or not np.allclose(R, R.T):
        raise ValueError(f"{name}: R must be a finite symmetric {m}x{m} matrix, got shape {R.shape}")
    if np.any(np.linalg.eigvalsh(R) <= 0):
        raise ValueError(f"{name}: R must be positive definite")
    return R


def _finite(z, shape, name: str) -> np.ndarray:
    z = np.asarray(z, dtype=float)
    if z.shape != shape:
        raise ValueError(f"measurement {name} must have shape {shape}, got {z.shape}")
    if not np.isfinite(z).all():
        raise ValueError(f"measurement {name} contains NaN or Inf: {z!r}")
    return z


#: Noise distributions of the pose estimator (Renis et al. §4.4). ``"gaussian"``: the rotation vector and the
#: position error are ``N(0, σ²/3 I)``. ``"isotropic"``: eq. 34 read literally, a Gaussian *amplitude*
#: ``N(0, σ²)`` along a uniform direction — the same covariance, but ``|noise|² = σ² χ²₁`` rather than
#: ``σ²/3 χ²₃``, so the filters' NIS is not chi-square and a 99 % gate rejects ~4 % of good measurements.
NOISE_MODELS = ("gaussian", "isotropic")


@dataclass(frozen=True)
class PoseNoise:
    """The pose estimator's noise: amplitudes ``σ_q`` (rad), ``σ_r`` (m) and distribution (Renis et al. §4.4, eqs 33–34).

    An isotropic error of amplitude σ has per-axis variance ``σ²/3``, so
    ``R_d = blockdiag(σ_q²/3 I₃, σ_r²/3 I₃)`` (the paper's 0.12 rad and 0.37 m
    at 50 m by default). The paper calls σ a variance; it can only be the
    amplitude's standard deviation.
    """

    sigma_q_rad: float = 0.12
    sigma_r_m: float = 0.37
    model: str = "gaussian"

    def __post_init__(self):
        for name in ("sigma_q_rad", "sigma_r_m"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float, np.floating)) and np.isfinite(v) and v > 0):
                raise ValueError(f"pose noise {name} must be a positive finite number, got {v!r}")
            object.__setattr__(self, name, float(v))
        if self.model not in NOISE_MODELS:
            raise ValueError(f"pose noise model must be one of {NOISE_MODELS}, got {self.model!r}")

    @property
    def R_attitude(self) -> np.ndarray:
        """rad², ``σ_q²/3 I₃``."""
        return np.eye(3) * self.sigma_q_rad**2 / 3.0

    @property
    def R_position(self) -> np.ndarray:
        """m², ``σ_r²/3 I₃``."""
        return np.eye(3) * self.sigma_r_m**2 / 3.0

    def sources(self) -> tuple["AttitudeMeasurement", "PositionMeasurement"]:
        """The two gated sources of eq. 24 with this noise as their ``R_d``."""
        return AttitudeMeasurement(R=self.R_attitude), PositionMeasurement(R=self.R_position)


def _selection(block: slice) -> np.ndarray:
    """``H = [0 … I₃ … 0]`` (3 × 14) picking the error states ``block``; read-only, built once."""
    H = np.zeros((3, N_ERROR))
    H[:, block] = np.eye(3)
    H.setflags(write=False)
    return H


_H_ATTITUDE = _selection(DTHETA)
_H_POSITION = _selection(DR_ST_T)


@dataclass(frozen=True)
class AttitudeMeasurement:
    """Relative attitude ``q_TS`` from the pose estimator (first block of eq. 24)."""

    R: np.ndarray  #: (3, 3) rad², covariance of the attitude error (≈ rotation vector)
    name: str = "attitude"
    dim: int = 3
    gated: bool = True

    def __post_init__(self):
        object.__setattr__(self, "R", _cov(self.R, 3, self.name))

    def z_chart(self, z, x_ref) -> np.ndarray:
        q = _finite(z, (4,), "q_TS")
        if abs(np.linalg.norm(q) - 1.0) > 1e-6:
            raise ValueError(f"measurement q_TS must be a unit quaternion, |q| = {np.linalg.norm(q)!r}")
        return attitude_error(q, np.asarray(x_ref)[Q_TS])

    def h_chart(self, X, x_ref) -> np.ndarray:
        return attitude_error(np.asarray(X)[..., Q_TS], np.asarray(x_ref)[Q_TS])

    def jacobian(self, x) -> np.ndarray:
        return _H_ATTITUDE

    def residual(self, Z, X) -> np.ndarray:
        """``z ⊟ h(x)`` row by row for measurements ``Z (n, 4)`` at states ``X (n, 15)``: the attitude error ``δp`` (n, 3)."""
        return attitude_error(np.asarray(Z, dtype=float), np.asarray(X)[..., Q_TS])

    def jacobians(self, X) -> np.ndarray:
        """``H`` at each of the states ``X (n, 15)``: (n, 3, 14)."""
        return np.broadcast_to(_H_ATTITUDE, (len(X),) + _H_ATTITUDE.shape)


@dataclass(frozen=True)
class PositionMeasurement:
    """Relative position ``r_ST_T`` (m) from the pose estimator (second block of eq. 24)."""

    R: np.ndarray  #: (3, 3) m²
    name: str = "position"
    dim: int = 3
    gated: bool = True

    def __post_init__(self):
        object.__setattr__(self, "R", _cov(self.R, 3, self.name))

    def z_chart(self, z, x_ref) -> np.ndarray:
        return _finite(z, (3,), "r_ST_T")

    def h_chart(self, X, x_ref) -> np.ndarray:
        return np.asarray(X)[..., R_ST_T]

    def jacobian(self, x) -> np.ndarray:
        return _H_POSITION

    def residual(self, Z, X) -> np.ndarray:
        """``z − h(x)`` row by row for measurements ``Z (n, 3)`` at states ``X (n, 15)`` (m)."""
        return np.asarray(Z, dtype=float) - np.asarray(X)[..., R_ST_T]

    def jacobians(self, X) -> np.ndarray:
        """``H`` at each of the states ``X (n, 15)``: (n, 3, 14)."""
        return np.broadcast_to(_H_POSITION, (len(X),) + _H_POSITION.shape)


@dataclass(frozen=True)
class TargetRateMeasurement:
    """A spin prior pushed as a fictitious measurement of the target's rate (§6.3 of Renis et al.).

    The prior is the target's own spin ``ω_T_T`` (what a light curve gives),
    not the state's relative rate, so ``h(x) = R(q_TS) ω_S_S − ω_ST_T`` (eq. 1
    solved for ``ω_T_T``) with the servicer's rate ``ω_S_S`` from its AODS, and
    ``H = [−[(R̂ ω_S)×], −I₃, 0, 0, 0]``. Not gated: it is the fallback when the
    camera's measurements are.
    """

    w_S_S: np.ndarray  #: (3,) rad/s, the servicer's rate at this step
    R: np.ndarray  #: (3, 3) (rad/s)²; ``R_ω = 1e-3 I`` in §6.3
    name: str = "rate_prior"
    dim: int = 3
    gated: bool = False

    def __post_init__(self):
        object.__setattr__(self, "w_S_S", _finite(self.w_S_S, (3,), "w_S_S"))
        object.__setattr__(self, "R", _cov(self.R, 3, self.name))

    def z_chart(self, z, x_ref) -> np.ndarray:
        return _finite(z, (3,), "w_T_T (prior)")

    def h_chart(self, X, x_ref) -> np.ndarray:
        X = np.asarray(X)
        return np.einsum("...ij,j->...i", quat_to_dcm(X[..., Q_TS]), self.w_S_S) - X[..., W_ST_T]

    def jacobian(self, x) -> np.ndarray:
        H = np.zeros((3, N_ERROR))
        H[:, DTHETA] = -skew(quat_to_dcm(np.asarray(x)[Q_TS]) @ self.w_S_S)
        H[:, DW_ST_T] = -np.eye(3)
        return H

    def residual(self, Z, X) -> np.ndarray:
        """``z − h(x)`` row by row for rate measurements ``Z (n, 3)`` at states ``X (n, 15)`` (rad/s)."""
        return np.asarray(Z, dtype=float) - self.h_chart(X, None)

    def jacobians(self, X) -> np.ndarray:
        """``H`` at each of the states ``X (n, 15)``: (n, 3, 14)."""
        return np.stack([self.jacobian(x) for x in np.asarray(X)])


@dataclass(frozen=True)
class LinearMeasurement:
    """``z = H x + noise`` on a vector state (used with :class:`~estimators.process_model.LinearProcessModel`)."""

    H: np.ndarray
    R: np.ndarray
    name: str = "linear"
    gated: bool = True

    def __post_init__(self):
        H = np.atleast_2d(np.asarray(self.H, dtype=float))
        object.__setattr__(self, "H", H)
        object.__setattr__(self, "R", _cov(self.R, H.shape[0], self.name))

    @property
    def dim(self) -> int:
        return self.H.shape[0]

    def z_chart(self, z, x_ref) -> np.ndarray:
        return _finite(np.atleast_1d(z), (self.dim,), self.name)

    def h_chart(self, X, x_ref) -> np.ndarray:
        return np.asarray(X) @ self.H.T

    def jacobian(self, x) -> np.ndarray:
        return self.H

    def residual(self, Z, X) -> np.ndarray:
        """``z − H x`` row by row (n, m)."""
        return np.asarray(Z, dtype=float).reshape(len(X), -1) - self.h_chart(X, None)

    def jacobians(self, X) -> np.ndarray:
        """``H`` for each of the ``n`` states: (n, m, n_state)."""
        return np.broadcast_to(self.H, (len(X),) + self.H.shape)
