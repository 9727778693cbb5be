"""Unscented Kalman filter in the USQUE form (Crassidis & Markley 2003; Renis et al. §4.2).

The covariance lives on the 14-dimensional error state of
:mod:`estimators.error_state`: the attitude error is a generalised Rodrigues
vector (``a = 1``, ``f = 4``, i.e. four times the MRP; eq. 33 of Crassidis &
Markley) and the quaternion itself is kept outside the sigma points.

Predict:

1. sigma points of the error ``σ_i`` from ``P`` (filterpy's
   ``MerweScaledSigmaPoints``, default ``α = 1, β = 2, κ = 0``: all weights
   non-negative, so the covariance stays positive semi-definite with 14 states;
   measured with the ``settled`` tuning from the default ``P_0``, 30 runs, issue 12:
   a narrower spread is over-confident — ``α = 0.5`` mean NEES/dof 1.28 on SC3,
   1.23 on SC1; ``κ = 3 − n`` 1.56 on SC3 — and a wider one conservative on SC1
   (``κ = 3``: 0.88, ``κ = 6``: 0.83) while it varies with the seeds on SC3
   (``κ = 3``: 0.99 on seeds 1000–1029, 0.87 on 2000–2029), against 0.94
   (SC1) and 1.04 / 0.91 (SC3) with ``κ = 0``);
2. ``χ_i = x̂ ⊞ σ_i`` — quaternion sigma points ``δq(δp_i) ⊗ q̂``;
3. each ``χ_i`` through eq. 21 (the numba RK4, all at once);
4. back to errors about the propagated centre, ``δx_i = χ_i⁺ ⊟ χ_0⁺``
   (attitude: ``δp_i = [q_i ⊗ q_0⁻¹]_MRP``), then mean and covariance with
   filterpy's ``unscented_transform``, ``P⁻ = Σ W_c (δx_i − δx̄)(…)ᵀ + Q_d``, and
   ``x̂⁻ = χ_0⁺ ⊞ δx̄``.

Update: sigma points are drawn again from ``(x̂⁻, P⁻)``, so that ``Q_d``
enters ``P_yy`` and ``P_xy``; each predicts its measurement about the
reference ``x̂⁻`` (for the attitude ``δp_i``), and the innovation is eqs 29–30:
``δp̃ = [ỹ_q ⊗ q̂⁻⁻¹]_MRP``, ``v = δp̃ − ŷ``. Then ``K = P_xy P_yy⁻¹``,
``δx̂ = δx̄ + K v`` (``δx̄ = 0`` about the reference), ``P = P⁻ − K P_yy Kᵀ`` and
``x̂ = x̂⁻ ⊞ δx̂`` (quaternion normalised, eq. 28).

Robustness (issue 31: 8/8 runs on SC3/SC4 with 5 s and 10 s measurement
intervals aborted with "covariance P is not positive definite"):

* the update's ``P`` is the covariance of the sigma points' own errors,
  ``P = Σ W_c (e_i − K f_i)(e_i − K f_i)ᵀ + K R Kᵀ`` with ``e_i = δx_i − δx̄``,
  ``f_i = y_i − ŷ`` — positive semi-definite for any gain (a sum of outer
  products with the non-negative weights of ``α = 1``, formed as such, so also in
  floating point), and equal to
  ``P⁻ − K P_yy Kᵀ`` to rounding when every sigma point's error is taken back
  exactly (``δx_i = σ_i``; always so for a linear model). It differs when it is
  not: with ``P_0``'s 1 rad² attitude, sigma points lie 3.7 rad out, beyond π,
  where ``q ⊟ q̂`` takes the shorter rotation back; ``P⁻ − K P_yy Kᵀ`` then had
  eigenvalues of −0.025 rad² (SC3, 5 s) and the next draw failed;
* the sigma points' square root is the Cholesky factor of ``P`` taken through
  its correlation matrix, ``chol(P) = D chol(C)`` with ``P = D C D``,
  ``D = diag(√P_ii)`` (:func:`scaled_cholesky`): the same factor (Cholesky
  factors are unique) without the rounding of variances that span 20 orders of
  magnitude — on SC4 at 10 s the position's variance reached 1e13–1e23 m²
  between measurements while the attitude's was ~1e-2 rad², and the direct
  factor failed on eigenvalues of −1e7 that were rounding. When ``C`` itself has
  no factor, it is replaced by the nearest matrix with eigenvalues of at least
  :data:`CORRELATION_FLOOR` (each component keeps its variance). Each such use is counted in ``regularizations``, the largest
  eigenvalue raise in ``largest_floor`` (correlation units; 0 when never used).

Two departures from Crassidis & Markley, both so that a linear model gives the
textbook Kalman filter exactly: ``Q_d`` is added once after the transform
(they add half of it before the sigma points are drawn as well), and the
update redraws the sigma points instead of reusing the propagated ones
(filterpy's ``UnscentedKalmanFilter`` reuses them, which leaves ``Q_d`` out of
``P_xy``; that is also why its class is not used here, besides its additive
``x + K y`` update).

References
----------
.. [1] Renis, Price, Hellmich, Battipede, Salzmann, *Leveraging Light-Curve Inversion for Real-Time
   Kinematic State Estimation of Uncooperative Targets*.
.. [2] Crassidis, Markley, *Unscented filtering for spacecraft attitude estimation*, JGCD 26(4), 2003.
"""

from __future__ import annotations

import numpy as np
from filterpy.kalman import MerweScaledSigmaPoints, unscented_transform
from scipy.linalg import cholesky

from estimators.filter import KalmanFilterBase, NonFiniteError, _block_diag


#: Smallest eigenvalue of the correlation matrix the sigma points are drawn from when ``P`` has no Cholesky factor
#: (a condition number of the correlation matrix of at most ~1e10 × the number of states).
CORRELATION_FLOOR = 1e-10


def _correlation(P: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(C, d)`` with ``P = D C D``, ``D = diag(d)``, ``d_i = √P_ii`` (1 where ``P_ii ≤ 0``: that row of ``C`` is ``P``'s)."""
    var = np.diag(P)
    d = np.where(var > 0.0, np.sqrt(np.abs(var)), 1.0)
    return 0.5 * (P + P.T) / np.outer(d, d), d


def scaled_cholesky(A: np.ndarray) -> tuple[np.ndarray, float]:
    """``(U, added)``: upper-triangular ``U`` (n, n) with ``Uᵀ U = A``, via the correlation matrix of ``A``.

    ``A = D C D``, ``C = U_Cᵀ U_C`` → ``U = U_C D`` (= scipy's ``cholesky(A)`` to rounding, which is
    what filterpy's sigma points take by default). If ``C`` has no Cholesky factor, its
    eigenvalues are raised to at least :data:`CORRELATION_FLOOR` (``C_r = V max(Λ, floor) Vᵀ``, the
    nearest such matrix in the Frobenius norm) and ``U = √max(Λ, floor) Vᵀ D`` (then not triangular;
    any ``U`` with ``Uᵀ U = A`` spreads the sigma points right); ``added`` is the largest raise
    (0 when the Cholesky factor existed). On a correlation matrix the floor is relative to each
    component's own variance (an absolute or ``λ_max``-relative floor on ``P`` would add "variance"
    in m² to an attitude in rad²).
    """
    C, d = _correlation(A)
    try:
        return cholesky(C) * d[None, :], 0.0
    except np.linalg.LinAlgError:
        w, V = np.linalg.eigh(C)
    raised = np.maximum(w, CORRELATION_FLOOR)
    # the symmetric square root of the floored C (V max(Λ, floor) Vᵀ = (√Λ Vᵀ)ᵀ(√Λ Vᵀ)): a factor exists even at a
    # condition number where a Cholesky factor of C_r fails in floating point
    return (np.sqrt(raised)[:, None] * V.T) * d[None, :], float(np.max(raised - w))


class UnscentedKalmanFilter(KalmanFilterBase):
    """USQUE UKF with the interface of :class:`~estimators.filter.KalmanFilterBase`.

    Extra parameters: ``alpha``, ``beta``, ``kappa`` of the scaled sigma points.

    Example: :class:`~estimators.filter.KalmanFilterBase`.
    """

    kind = "ukf"

    def __init__(self, model, x0, P0, Q, *, alpha: float = 1.0, beta: float = 2.0, kappa: float = 0.0, **kw):
        super().__init__(model, x0, P0, Q, **kw)
        self.points = MerweScaledSigmaPoints(int(model.n_error), alpha=alpha, beta=beta, kappa=kappa, sqrt_method=self._sqrt)
        self._reduced_points: dict[int, MerweScaledSigmaPoints] = {}  # for _predict_considering, by dimension
        self.regularizations = 0  #: draws of sigma points from :func:`regularized` (``P`` had no Cholesky factor)
        self.largest_floor = 0.0  #: the largest eigenvalue raise of those draws, in correlation units

    def _sqrt(self, A: np.ndarray) -> np.ndarray:
        """The sigma points' square root (:func:`scaled_cholesky`), counting the regularised ones."""
        U, added = scaled_cholesky(A)
        if added > 0.0:
            self.regularizations += 1
            self.largest_floor = max(self.largest_floor, added)
        return U

    def _sigmas(self) -> np.ndarray:
        """``χ_i = x̂ ⊞ σ_i`` (2n+1, n_state)."""
        return self.model.boxplus(self.x[None, :], self.points.sigma_points(np.zeros(self.P.shape[0]), self.P))

    #: take the considered directions linearly in the prediction (:meth:`_predict_considering`); the settling phase of
    #: the tunings turns it off, as it turns on the EKF's linearisation-error covariance (estimators.navigation)
    consider_linearly = True

    def _predict(self, u, dt: float):
        U = self.consider_basis()
        if U.shape[0] and self.consider_linearly:
            return self._predict_considering(U, u, dt)
        X = self._propagate(self._sigmas(), u, dt)
        dX = self.model.boxminus(X, X[0])
        mean, P = unscented_transform(dX, self.points.Wm, self.points.Wc, self.Q)
        return self.model.boxplus(X[0], mean), P

    def _propagate(self, X, u, dt: float) -> np.ndarray:
        X = self.model.propagate_batch(X, u, dt)
        if not np.all(np.isfinite(X)):
            raise NonFiniteError(f"ukf: propagating the sigma points over dt={dt} gave NaN or Inf; step refused")
        return X

    def _predict_considering(self, U: np.ndarray, u, dt: float):
        """Predict with the considered directions ``U`` (d, n) entering linearly, as in the Schmidt–Kalman filter.

        Write the error as ``δ = Bᵀa + Uᵀc`` (``B``: orthonormal complement of ``U``) and split ``a`` into its
        regression on ``c``, ``G c`` with ``G = P_ac P_cc⁻¹``, and the rest ``ã ~ N(0, P_aa − G P_ca)``, independent
        of ``c``. The sigma points spread over ``ã`` only (``c = 0``); ``c`` moves the state along the columns of
        ``D = (Uᵀ + Bᵀ G) L_c`` (``L_c L_cᵀ = P_cc``), each propagated by a central difference of ``1e-3`` of its
        length. ``P⁻ = UT(ã) + Σ_j d_j d_jᵀ + Q_d`` — exact for a linear model, like the full transform. Why
        (issue 12): the full transform puts points ``√n = 3.7`` standard deviations out along a considered ``k``,
        where a tumble near the intermediate axis grows like ``e^{λ(k)t}``; it over-stated the rate's error
        (SC1, 30 runs × 300 s: rate NEES/dof 0.46–0.62 against the EKF's 0.74–0.89, 83 % of the steps in band).
        Not in a tuning's settling phase (:attr:`consider_linearly` off): with rate errors of the size of the spin the
        sigma points' spread along ``k`` is the margin the EKF gets from its linearisation-error covariance; taken
        linearly there, SC3 ``settled`` was over-confident (mean NEES/dof 1.21 at 120 s, worst run 26 at 300 s;
        ``test_settled_tuning_from_the_default_p0``).
        """
        n, d = self.P.shape[0], U.shape[0]
        B = np.linalg.svd(U)[2][d:]
        P_aa, P_ac, P_cc = B @ self.P @ B.T, B @ self.P @ U.T, U @ self.P @ U.T
        w, V = np.linalg.eigh(P_cc)
        L_c = V * np.sqrt(np.clip(w, 0.0, None))  # L_c L_cᵀ = P_cc, also when a direction has no variance
        G = np.linalg.lstsq(P_cc, P_ac.T, rcond=None)[0].T
        points = self._reduced_points.get(n - d)
        if points is None:  # the weights depend only on the dimension: made once per number of considered directions
            points = self._reduced_points[n - d] = MerweScaledSigmaPoints(n - d, alpha=self.points.alpha, beta=self.points.beta, kappa=self.points.kappa,
                                                                          sqrt_method=self._sqrt)
        A = points.sigma_points(np.zeros(n - d), P_aa - G @ P_ac.T)
        D = (U.T + B.T @ G) @ L_c  # (n, d)
        h = 1e-3
        dX = np.vstack([A @ B, h * D.T, -h * D.T])
        X = self._propagate(self.model.boxplus(self.x[None, :], dX), u, dt)
        dX = self.model.boxminus(X, X[0])
        m = 2 * (n - d) + 1
        mean, P = unscented_transform(dX[:m], points.Wm, points.Wc, self.Q)
        cols = (dX[m : m + d] - dX[m + d :]) / (2.0 * h)
        return self.model.boxplus(X[0], mean), P + cols.T @ cols

    def _innovate(self, sources, z):
        X = self._sigmas()
        self._dX = self.model.boxminus(X, self.x)
        Y = np.hstack([src.h_chart(X, self.x) for src in sources])
        R = _block_diag([src.R for src in sources])
        self._R = R
        self._ybar, S = unscented_transform(Y, self.points.Wm, self.points.Wc, R)  # P_yy
        self._dY = Y - self._ybar
        self._y = np.concatenate(z) - self._ybar  # eq. 30
        self._S = 0.5 * (S + S.T)
        return self._y, self._S

    def _correct(self, keep: np.ndarray):
        Wc = self.points.Wc
        dxbar = self.points.Wm @ self._dX
        Pxy = ((self._dX - dxbar) * Wc[:, None]).T @ self._dY[:, keep]
        S = self._S[np.ix_(keep, keep)]
        try:
            K = np.linalg.solve(S, Pxy.T).T  # K = P_xy P_yy⁻¹ (P_yy symmetric)
        except np.linalg.LinAlgError as e:
            raise ValueError("ukf: innovation covariance P_yy is singular") from e
        U = self.consider_basis()
        if U.shape[0]:
            K = K - U.T @ (U @ K)  # Schmidt-Kalman: Pxx − K Pxyᵀ − Pxy Kᵀ + K S Kᵀ holds for any gain
        # P = Σ W_c (e_i − K f_i)(e_i − K f_i)ᵀ + K R Kᵀ = Pxx − K Pxyᵀ − Pxy Kᵀ + K S Kᵀ, formed as a sum of outer products: no
        # cancellation, so its correlation matrix stays positive semi-definite to rounding whatever the spread of the variances
        E = (self._dX - dxbar) - self._dY[:, keep] @ K.T
        P = (E * Wc[:, None]).T @ E + K @ self._R[np.ix_(keep, keep)] @ K.T
        x = self.model.boxplus(self.x, dxbar + K @ self._y[keep])
        return x, P
