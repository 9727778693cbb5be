"""Extended Kalman filter of ``002_…`` §4.1 (eqs 25–28), on the 14-dimensional error state.

Prediction (eq. 26): ``x̂⁻ = f(x̂)``, ``P⁻ = F P Fᵀ + Q_d`` with the analytic
``F`` of :mod:`estimators.process_model`. Update (eq. 27):
``y = z ⊟ h(x̂⁻)``, ``S = H P⁻ Hᵀ + R_d``, ``K = P⁻ Hᵀ S⁻¹``,
``x̂ = x̂⁻ ⊞ K y``, with the quaternion normalised (eq. 28) inside ``⊞``.

Why the error state and not the 15 states of eq. 17: with the quaternion as
four additive states the 4×4 block of ``P`` is singular along the
quaternion's norm, so ``S`` of a quaternion measurement, the NEES and the
chi-square gate's degrees of freedom (4 numbers for 3 rotational degrees of
freedom) are ill defined; eqs 33–34 describe a 3-D rotation noise. Keeping
the attitude error as three numbers (``⊞`` multiplies the quaternion and
normalises it, which is eq. 28) makes ``P`` 14×14 and positive definite, and
gives the EKF the same error space as the USQUE UKF, so that both expose the
same ``P``, ``y`` and ``S``. On a linear model ``⊞`` is ``+`` and this is the
textbook Kalman filter.

filterpy's ``ExtendedKalmanFilter`` is not used: it keeps ``x`` and ``P`` of
the same size, predicts with ``x = F x`` and updates with ``x += K y``, none of
which holds for a 15-number state with a 14×14 covariance and a
multiplicative attitude update. The update uses the Joseph form, as filterpy does.
"""

from __future__ import annotations

import numpy as np

from estimators.filter import KalmanFilterBase, NonFiniteError, _block_diag


class ExtendedKalmanFilter(KalmanFilterBase):
    """EKF with the interface of :class:`~estimators.filter.KalmanFilterBase`."""

    kind = "ekf"

    def _predict(self, u, dt: float):
        x, F = self.model.propagate_with_jacobian(self.x, u, dt)  # eqs 25-26
        if not (np.all(np.isfinite(x)) and np.all(np.isfinite(F))):
            raise NonFiniteError(f"ekf: propagating over dt={dt} gave NaN or Inf; step refused")
        return x, F @ self.P @ F.T + self.Q

    def _innovate(self, sources, z):
        self._H = np.vstack([src.jacobian(self.x) for src in sources])
        self._R = _block_diag([src.R for src in sources])
        h = np.concatenate([src.h_chart(self.x, self.x) for src in sources])
        self._y = np.concatenate(z) - h
        S = self._H @ self.P @ self._H.T + self._R
        return self._y, 0.5 * (S + S.T)

    def _correct(self, keep: np.ndarray):
        H, R, y = self._H[keep], self._R[np.ix_(keep, keep)], self._y[keep]
        PHt = self.P @ H.T
        S = H @ PHt + R
        try:
            K = np.linalg.solve(S, PHt.T).T  # K = P Hᵀ S⁻¹ (S symmetric)
        except np.linalg.LinAlgError as e:
            raise ValueError("ekf: innovation covariance S is singular") from e
        K[self.consider] = 0.0  # Schmidt-Kalman: considered states are not corrected
        x = self.model.boxplus(self.x, K @ y)
        IKH = np.eye(self.P.shape[0]) - K @ H
        P = IKH @ self.P @ IKH.T + K @ R @ K.T  # Joseph form of P = (I − K H) P⁻, valid for any gain
        return x, P
