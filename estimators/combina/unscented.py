"""The unscented Kalman step shared by CoMBiNa's three filters (Maestrini et al. §IV.B).

Sigma points and weights are those of eqs 10–11 (Van der Merwe's scaled set:
the paper's ``γ`` is filterpy's ``alpha``, ``τ = γ²(l + κ) − l`` its
``lambda_``), taken from :class:`filterpy.kalman.MerweScaledSigmaPoints`.
Prediction is eqs 12–13, the predicted measurement eqs 14–17, the correction
eqs 21–24. Unlike :class:`filterpy.kalman.UnscentedKalmanFilter`, the
correction is split in two verbs, :meth:`UnscentedCore.innovation` and
:meth:`UnscentedCore.correct`, because CoMBiNa gates the innovation (eq. 18)
*between* them and the attitude filter re-expresses the measured MRP on the
predicted set's side before the innovation is formed.

The noise is additive: ``P(k+1|k) = Σ Ω_P (X − x̂)(X − x̂)ᵀ + Q`` (``Q = 0`` in
the paper) and ``P_z = Σ Ω_P (Z − ẑ)(Z − ẑ)ᵀ + R`` (eq. 16).

References
----------
.. [1] Maestrini, De Luca, Di Lizia, *Relative Navigation Strategy About Unknown and Uncooperative
   Targets*, Journal of Guidance, Control, and Dynamics, 2023.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np
from filterpy.kalman import MerweScaledSigmaPoints

#: ``X (2l+1, l) -> X' (2l+1, l)``: a process model applied to every sigma point.
BatchModel = Callable[[np.ndarray], np.ndarray]


@dataclass(frozen=True)
class Innovation:
    """The predicted measurement and its statistics, before the correction (eqs 15–17, 23)."""

    z: np.ndarray  #: the measurement used (possibly re-expressed, e.g. the MRP set)
    z_pred: np.ndarray  #: ``ẑ(k+1|k)`` (eq. 15)
    y: np.ndarray  #: ``y = z − ẑ`` (eq. 23), wrapped by the filter's residual
    S: np.ndarray  #: ``P_z(k+1|k)`` including ``R`` (eq. 16)
    P_xz: np.ndarray  #: state–measurement cross covariance (eq. 17)


class UnscentedCore:
    """Mean ``x``, covariance ``P`` and the unscented predict / innovate / correct steps.

    Parameters
    ----------
    x0, P0
        initial mean ``(l,)`` and covariance ``(l, l)``, in the filter's units.
    alpha, beta, kappa
        the UT parameters of eqs 10–11 (``γ``, ``β``, ``κ``). The default
        ``alpha = 1, kappa = 0`` puts the sigma points at ``±√l`` standard
        deviations with a zero central mean weight.
    residual_x
        ``(a, b) -> a − b`` for states (angles need wrapping); plain subtraction by default.
    """

    def __init__(self, x0, P0, *, alpha: float = 1.0, beta: float = 2.0, kappa: float = 0.0, residual_x=None):
        x0 = np.asarray(x0, dtype=float)
        P0 = np.asarray(P0, dtype=float)
        l = x0.shape[0]
        if x0.ndim != 1 or P0.shape != (l, l):
            raise ValueError(f"x0 must be (l,) and P0 (l, l); got {x0.shape} and {P0.shape}")
        if not (np.all(np.isfinite(x0)) and np.all(np.isfinite(P0))):
            raise ValueError("x0 and P0 must be finite")
        if not np.allclose(P0, P0.T) or np.min(np.linalg.eigvalsh(P0)) <= 0.0:
            raise ValueError("P0 must be symmetric positive definite")
        self.x = x0.copy()
        self.P = P0.copy()
        self.points = MerweScaledSigmaPoints(l, alpha=alpha, beta=beta, kappa=kappa)
        self.residual_x = residual_x or np.subtract
        self.sigmas = self.points.sigma_points(self.x, self.P)

    @property
    def dim(self) -> int:
        return self.x.shape[0]

    def _weighted_cov(self, dA: np.ndarray, dB: np.ndarray) -> np.ndarray:
        return (self.points.Wc[:, None] * dA).T @ dB

    def predict(self, f: BatchModel, Q=None, mean_fn=None) -> None:
        """Eqs 10–13: draw sigma points, push them through ``f``, recombine.

        ``mean_fn(X, Wm)`` overrides the weighted mean (angles). The propagated
        sigma points are kept for the measurement step (eqs 14–17), as in the paper.
        """
        X = self.points.sigma_points(self.x, self.P)  # eq. 10
        X = f(X)
        x = mean_fn(X, self.points.Wm) if mean_fn is not None else self.points.Wm @ X  # eq. 12
        dX = self.residual_x(X, x[None, :])
        P = self._weighted_cov(dX, dX)  # eq. 13
        if Q is not None:
            P = P + np.asarray(Q, dtype=float)
        self.x, self.P, self.sigmas = x, 0.5 * (P + P.T), X

    def innovation(self, z, R, h: BatchModel, *, residual_z=None, mean_z=None) -> Innovation:
        """Eqs 14–17 and 23 for measurement ``z`` with noise covariance ``R``.

        ``h`` maps the sigma points ``(2l+1, l)`` to measurement sigma points
        ``(2l+1, m)``; ``residual_z(a, b)`` and ``mean_z(Z, Wm)`` handle angles.
        """
        z = np.asarray(z, dtype=float)
        sub = residual_z or np.subtract
        Z = h(self.sigmas)  # eq. 14 / 30 / 41
        z_pred = mean_z(Z, self.points.Wm) if mean_z is not None else self.points.Wm @ Z  # eq. 15
        dZ = sub(Z, z_pred[None, :])
        S = self._weighted_cov(dZ, dZ) + np.asarray(R, dtype=float)  # eq. 16
        dX = self.residual_x(self.sigmas, self.x[None, :])
        P_xz = self._weighted_cov(dX, dZ)  # eq. 17
        y = sub(z, z_pred)  # eq. 23
        return Innovation(z=z, z_pred=z_pred, y=y, S=0.5 * (S + S.T), P_xz=P_xz)

    def reset_covariance(self, P) -> None:
        """Replace ``P`` (symmetric positive definite) keeping the mean, and redraw the sigma points about it."""
        P = np.asarray(P, dtype=float)
        if P.shape != self.P.shape or not np.allclose(P, P.T) or np.min(np.linalg.eigvalsh(P)) <= 0.0:
            raise ValueError(f"P must be a symmetric positive definite {self.P.shape} matrix")
        self.P = P.copy()
        self.sigmas = self.points.sigma_points(self.x, self.P)

    def correct(self, inn: Innovation) -> None:
        """Eqs 21, 22 and 24: ``K = P_xz S⁻¹``, ``x += K y``, ``P −= K S Kᵀ``."""
        K = np.linalg.solve(inn.S, inn.P_xz.T).T  # eq. 24 (S symmetric)
        self.x = self.x + K @ inn.y  # eq. 21
        P = self.P - K @ inn.S @ K.T  # eq. 22
        self.P = 0.5 * (P + P.T)
        # The stored sigma points describe the prior; redraw them about the posterior
        # so that a second measurement at the same epoch sees the corrected state.
        self.sigmas = self.points.sigma_points(self.x, self.P)
