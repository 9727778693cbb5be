"""What the EKF and the UKF share: the interface, gating per source, and the refusal of NaN/Inf.

Notation follows filterpy and eqs 25–31 of Renis et al.: ``x`` (the full state,
15 numbers for the relative-navigation model), ``P`` (covariance of the error
state, 14×14), ``Q`` (``Q_d``), ``y`` and ``S`` (the last innovation and its
covariance). Two verbs:

* ``predict(u, dt)`` — propagate over ``dt`` seconds; ``u`` is the control input
  of the process model (the servicer's absolute state from its AODS);
* ``update(parts, t=...)`` — ``parts`` is a sequence of ``(source, z)`` pairs
  (:mod:`estimators.measurement`), any subset of the sources of eq. 24 plus
  an optional prior proxy. Each gated source is tested on its own with the
  one-sided chi-square gate (:func:`estimators.gates.chi_square_gate`; why not
  the two-sided one of §4.3: :mod:`estimators.gates`),
  every decision is appended to ``gate_decisions``, and one update is made
  with the accepted parts only (``R_d`` restricted to them).

A step whose result would hold NaN or Inf is refused with
:class:`NonFiniteError` and the filter is left as it was; so is a
measurement with NaN/Inf in it.

References
----------
.. [1] Renis, Price, Hellmich, Battipede, Salzmann, *Leveraging Light-Curve Inversion for Real-Time
   Kinematic State Estimation of Uncooperative Targets*.
.. [2] Bar-Shalom, Li, Kirubarajan, *Estimation with Applications to Tracking and Navigation*, Wiley,
   2001, §5.4 (NEES and NIS tests).
"""

from __future__ import annotations

import numpy as np

from estimators.gates import GateDecision, chi_square_gate
from estimators.state import N_STATE, Q_TS


class DivergenceError(ValueError):
    """The filter's numbers broke down (a covariance not positive definite, a step not finite): the run has diverged."""


class NonFiniteError(DivergenceError):
    """A filter step would put NaN or Inf into the state or covariance (refused)."""


def _check_covariance(P, n: int, name: str, *, definite: bool) -> np.ndarray:
    P = np.array(P, dtype=float)
    if P.ndim == 1:
        P = np.diag(P)
    if P.shape != (n, n):
        raise ValueError(f"{name} must be {n}x{n} (or a length-{n} diagonal), got shape {P.shape}")
    if not np.all(np.isfinite(P)):
        raise ValueError(f"{name} contains NaN or Inf")
    if not np.allclose(P, P.T, rtol=1e-10, atol=1e-14):
        raise ValueError(f"{name} must be symmetric")
    ev = np.linalg.eigvalsh(P)
    if definite and ev.min() <= 0:
        raise ValueError(f"{name} must be positive definite (smallest eigenvalue {ev.min():.3g})")
    if not definite and ev.min() < -1e-12 * max(1.0, ev.max()):
        raise ValueError(f"{name} must be positive semi-definite (smallest eigenvalue {ev.min():.3g})")
    return 0.5 * (P + P.T)


def _block_diag(blocks) -> np.ndarray:
    """Block-diagonal matrix of square blocks (scipy's ``block_diag`` costs ~10× more at these sizes)."""
    n = sum(b.shape[0] for b in blocks)
    out = np.zeros((n, n))
    i = 0
    for b in blocks:
        m = b.shape[0]
        out[i : i + m, i : i + m] = b
        i += m
    return out


class KalmanFilterBase:
    """Common state and bookkeeping; subclasses implement ``_predict``, ``_innovate``, ``_correct``.

    Parameters
    ----------
    model : process model (:class:`~estimators.process_model.RelativeProcessModel`
        or :class:`~estimators.process_model.LinearProcessModel`): ``propagate``,
        ``boxplus``/``boxminus`` and sizes ``n_state``/``n_error``.
    x0 : (n_state,) initial estimate ``x̂_0``.
    P0 : (n_error, n_error) or its diagonal; initial covariance ``P_0`` (positive definite).
    Q : (n_error, n_error) or its diagonal; ``Q_d`` per step (positive semi-definite).
    gate_confidence : probability of accepting a correct measurement at each gate
        (``None``: no gating; every part is used).
    consider : error-state indices that are *considered*, not estimated (Schmidt–Kalman):
        their gain rows are zero, so their estimate stays put while their
        uncertainty still enters ``P`` and ``S``. Used for ``k1, k2`` in one-axis
        tumbles, where the inertia ratios do not affect the motion and are not
        estimated (§6.1 of Renis et al.); an EKF that estimates them there learns
        them from its own linearisation errors and becomes overconfident.
        The attribute ``consider_directions`` ((d, n_error), orthonormal rows) considers
        directions of the error space besides the axes, e.g. one combination of
        ``k1, k2`` (:func:`estimators.navigation.weak_inertia_direction`); the gain is
        then projected, ``K ← (I − Uᵀ U) K`` with ``U`` spanning both.

    Examples
    --------
    Both filters in the textbook case: a random walk ``x_{k+1} = x_k + w`` (``Q = 1``) seen
    directly with noise of variance ``R = 1``. The posterior variance settles
    at the root of the steady-state Riccati equation, ``(√5 − 1)/2``, and the
    last innovation's covariance at ``P⁻ + R = (√5 + 3)/2``:

    >>> import numpy as np
    >>> from estimators.measurement import LinearMeasurement
    >>> from estimators.process_model import LinearProcessModel
    >>> from estimators.ekf import ExtendedKalmanFilter
    >>> from estimators.ukf import UnscentedKalmanFilter
    >>> walk = LinearProcessModel(lambda dt: np.eye(1))
    >>> camera = LinearMeasurement(H=[[1.0]], R=[[1.0]], name="camera")
    >>> for Filter in (ExtendedKalmanFilter, UnscentedKalmanFilter):
    ...     f = Filter(walk, x0=[0.0], P0=[10.0], Q=[1.0], gate_confidence=None)
    ...     for z in [0.3, -0.2, 0.5, 0.1, 0.4, 0.2, 0.3, 0.0, 0.1, 0.2]:
    ...         f.predict(None, dt=1.0)
    ...         decisions = f.update([(camera, [z])])
    ...     print(Filter.kind, round(float(f.P[0, 0]), 4), round(float(f.S[0, 0]), 4))
    ekf 0.618 2.618
    ukf 0.618 2.618
    >>> round(float(np.sqrt(5) - 1) / 2, 4), round(float(np.sqrt(5) + 3) / 2, 4)
    (0.618, 2.618)

    On the relative-navigation model (:class:`~estimators.process_model.RelativeProcessModel`)
    the same two verbs run the 15-state filter; :func:`estimators.navigation.run_navigation`
    drives them over a measurement sequence.
    """

    kind = "base"
    #: covariance square roots taken with a floor (the UKF's sigma points, :func:`estimators.ukf.scaled_cholesky`); 0 for the EKF
    regularizations = 0

    def __init__(self, model, x0, P0, Q, *, gate_confidence: float | None = 0.99, consider=()):
        self.model = model
        n, m = int(model.n_state), int(model.n_error)
        x0 = np.array(x0, dtype=float)
        if x0.shape != (n,) or not np.all(np.isfinite(x0)):
            raise ValueError(f"x0 must be {n} finite numbers, got shape {x0.shape}")
        if n == N_STATE:
            x0[Q_TS] = x0[Q_TS] / np.linalg.norm(x0[Q_TS])
        self.x = x0
        self.P = _check_covariance(P0, m, "P_0", definite=True)
        self.Q = _check_covariance(Q, m, "Q_d", definite=False)
        if gate_confidence is not None and not (0.0 < gate_confidence < 1.0):
            raise ValueError(f"gate_confidence must lie in (0, 1) or be None, got {gate_confidence!r}")
        self.gate_confidence = gate_confidence
        self.consider = np.asarray(sorted(set(int(i) for i in consider)), dtype=int)
        if self.consider.size and (self.consider.min() < 0 or self.consider.max() >= m):
            raise ValueError(f"consider indices must lie in [0, {m}), got {consider!r}")
        self.consider_directions = np.zeros((0, m))
        self.y = np.zeros(0)
        self.S = np.zeros((0, 0))
        self.innovations: dict[str, tuple[np.ndarray, np.ndarray]] = {}
        self.gate_decisions: list[GateDecision] = []

    # -------------------------------------------------------------- verbs

    def predict(self, u, dt: float) -> None:
        """Propagate ``x`` and ``P`` over ``dt`` seconds (eq. 26); ``u``: the model's input."""
        x, P = self._predict(u, float(dt))
        self._commit(x, P, f"predict over dt={dt}")

    def update(self, parts, *, t: float = float("nan"), gate: bool = True) -> list[GateDecision]:
        """Gate each part on its own, then correct with the accepted ones (eqs 27–31).

        ``gate=False`` uses every part without a test (e.g. while the filter
        acquires from a poor ``x̂_0``, when a gate would lock out every correct
        measurement). Returns the decisions of this update (also appended to
        ``gate_decisions``).
        """
        parts = list(parts)
        if not parts:
            return []
        z = [src.z_chart(zz, self.x) for src, zz in parts]  # validates (NaN, shape) first
        y, S = self._innovate([p[0] for p in parts], z)
        sizes = [src.dim for src, _ in parts]
        edges = np.concatenate([[0], np.cumsum(sizes)])
        decisions = []
        keep = np.zeros(edges[-1], dtype=bool)
        self.innovations = {}
        for j, (src, _) in enumerate(parts):
            sl = slice(edges[j], edges[j + 1])
            self.innovations[src.name] = (y[sl].copy(), S[sl, sl].copy())
            accepted = True
            if gate and src.gated and self.gate_confidence is not None:
                try:
                    d = chi_square_gate(y[sl], S[sl, sl], t=t, source=src.name, confidence=self.gate_confidence)
                except ValueError as e:  # y and S are the filter's own: a breakdown, not bad input
                    raise DivergenceError(f"{self.kind}: {e} at t={t}") from e
                decisions.append(d)
                accepted = d.accepted
            keep[sl] = accepted
        self.y, self.S = y, S
        self.gate_decisions.extend(decisions)
        if keep.any():
            x, P = self._correct(keep)
            self._commit(x, P, f"update at t={t}")
        return decisions

    def reset(self, x, P, what: str = "reset") -> None:
        """Replace the estimate and its covariance (e.g. by a batch posterior, :mod:`estimators.batch`); checked like a step."""
        x = np.asarray(x, dtype=float)
        P = np.asarray(P, dtype=float)
        if x.shape != self.x.shape or P.shape != self.P.shape:
            raise ValueError(f"{self.kind}: reset needs x {self.x.shape} and P {self.P.shape}, got {x.shape} and {P.shape}")
        self._commit(x, P, what)

    def rescale(self, scale) -> None:
        """``P ← D P D`` with ``D = diag(scale)``, ``scale ≥ 1``: inflate some error components, keeping correlations."""
        scale = np.asarray(scale, dtype=float)
        if scale.shape != (self.P.shape[0],) or not np.all(np.isfinite(scale)) or np.any(scale < 1.0):
            raise ValueError(f"scale must be {self.P.shape[0]} finite numbers >= 1")
        self._commit(self.x, scale[:, None] * self.P * scale[None, :], "covariance inflation")

    def fix_components(self, idx, x_fix, C) -> None:
        """Linear update with a direct fix ``x_fix`` (15,) of the error components ``idx`` (covariance ``C``).

        ``h(x) = (x ⊟ x̂)[idx]`` is linear in the error state (``H`` = rows of
        ``I``), so both filters take the same update, in Joseph form
        ``P = (I − KH) P (I − KH)ᵀ + K C Kᵀ``, positive semi-definite for any
        gain even after a large inflation (the UKF's ``P − K P_yy Kᵀ`` lost
        definiteness there: SC3, 120 s fault, λ ~ 1e4).
        """
        idx = np.asarray(idx, dtype=int)
        C = _check_covariance(C, idx.size, "fix covariance", definite=True)
        y = self.model.boxminus(np.asarray(x_fix, dtype=float), self.x)[idx]
        PHt = self.P[:, idx]
        K = np.linalg.solve(self.P[np.ix_(idx, idx)] + C, PHt.T).T
        U = self.consider_basis()
        K -= U.T @ (U @ K)
        IKH = np.eye(self.P.shape[0])
        IKH[:, idx] -= K
        self._commit(self.model.boxplus(self.x, K @ y), IKH @ self.P @ IKH.T + K @ C @ K.T, "re-acquisition fix")

    # -------------------------------------------------------------- helpers

    def consider_basis(self) -> np.ndarray:
        """Orthonormal rows ``U`` spanning the considered error space: the ``consider`` axes and ``consider_directions``."""
        m = self.P.shape[0]
        axes = np.eye(m)[self.consider]
        if not len(self.consider_directions):
            return axes
        U = np.vstack([axes, np.asarray(self.consider_directions, dtype=float).reshape(-1, m)])
        return np.ascontiguousarray(np.linalg.qr(U.T)[0].T)  # Gram-Schmidt of the rows

    def _commit(self, x: np.ndarray, P: np.ndarray, what: str) -> None:
        if not (np.all(np.isfinite(x)) and np.all(np.isfinite(P))):
            raise NonFiniteError(f"{self.kind}: {what} would put NaN or Inf into the state or covariance; step refused")
        self.x = x
        self.P = 0.5 * (P + P.T)

    def _predict(self, u, dt: float):  # pragma: no cover - abstract
        raise NotImplementedError

    def _innovate(self, sources, z):  # pragma: no cover - abstract
        raise NotImplementedError

    def _correct(self, keep: np.ndarray):  # pragma: no cover - abstract
        raise NotImplementedError
