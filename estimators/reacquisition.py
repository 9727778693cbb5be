"""Re-opening a gate that has locked a filter out: track re-acquisition from consistent rejections.

A chi-square gate (§4.3 of Renis et al.) cannot tell an outlier from a filter
that has lost the target: after a long camera blackout the prediction has
drifted further than ``P`` admits, every good measurement is rejected, and
nothing ever corrects ``x̂`` again (measured: the UKF's position after the
120 s blackout of §6.3, 23–170 m off 60 s after the fault). Renis et al. has no
rule for this; lcnav adds the one radar trackers use to re-initiate a track
(Bar-Shalom, Li & Kirubarajan, *Estimation with Applications to Tracking and
Navigation*, 2001, §3.7: least-squares initiation from the last few
measurements):

1. Keep, per camera source, the innovations ``y_k`` (about the prediction
   ``x̂⁻_k``) of the last ``window`` measurements *in a row* that its gate
   rejected; an accepted one empties the buffer.
2. With ``window`` of them, fit ``y(t) = b + d (t − t_K)`` per axis by least
   squares with the source's ``R``. Outliers (a fault, a wrong pose) scatter
   around any line; a filter that is merely lost sees its measurements drift
   smoothly away. The line fits if the weighted residual
   ``χ² = Σ (y_k − b − d Δt_k)ᵀ R⁻¹ (…)`` is at most
   ``χ²_{(K−2)m}(confidence)`` (scipy's ``chi2.ppf``).
3. If it fits, the fitted offset ``b`` is the error of the source's own
   state block and the drift ``d`` that of its rate (attitude: ``δp`` and
   ``δω``; position: ``δr`` and ``δv``). The filter admits it was that
   wrong: each of the two blocks of ``P`` is scaled by the smallest
   ``λ ≥ 1`` for which the fitted error is of its expected size,
   ``cᵀ (λ P_cc + C_cc)⁻¹ c ≤ m`` (``c = b`` or ``d``, ``C`` the fit's
   covariance), as ``P ← D P D`` with ``D = √λ`` on the block and 1 elsewhere
   (a congruence: ``P`` stays positive definite, correlations are kept); a
   drift that is only fit noise leaves its block as it was. Then the offset,
   ``x_fix = x̂⁻_K ⊞ b``, is applied ungated as a measurement of the block
   (``fix_components`` of the filter, covariance ``C_bb``). The
   drift is not applied: from 5 attitude samples of ``σ_q = 0.12`` rad its
   noise is 0.02 rad/s per axis, and applying it doubled the rate error
   after re-acquisition in one of ten EKF runs of the blackout (SC1, seeds
   1–10); the inflated rate block is corrected by the next measurements,
   which now pass the gate.

A fit of ``window = 5`` samples at ``τ_s = 1`` s takes 5 s; the false-alarm
path needs ``window`` rejections in a row of measurements whose
innovations lie on a line within their noise, which nominal gating at 99 %
gives once in ``10¹⁰`` and heavy fault noise never.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import brentq
from scipy.stats import chi2

from estimators.state import ERROR_GROUPS, N_ERROR

#: Error-state blocks a camera source observes: its own and its rate.
SOURCE_BLOCKS = {"attitude": ("q", "w"), "position": ("r", "v")}


@dataclass(frozen=True)
class LineFit:
    """Least-squares line ``y(t) = b + d (t − t_K)`` through ``K`` innovations of one source."""

    b: np.ndarray  #: (m,) offset at the last sample
    d: np.ndarray  #: (m,) drift per second
    C: np.ndarray  #: (2m, 2m) covariance of ``[b; d]``
    residual_chi2: float  #: weighted residual ``Σ rᵀ R⁻¹ r``
    dof: int  #: ``(K − 2) m``


def fit_line(t, Y, R) -> LineFit:
    """Fit ``Y`` (K, m) at times ``t`` (K,) s with noise ``R`` (m, m) on every sample; ``K ≥ 3``.

    With ``A = [1, t − t_K]`` the fit is ``(AᵀA)⁻¹AᵀY`` per axis and its
    covariance ``(AᵀA)⁻¹ ⊗ R`` (the axes share ``A``, so ``R`` does not change the fit).
    """
    t = np.asarray(t, dtype=float)
    Y = np.asarray(Y, dtype=float)
    if t.ndim != 1 or Y.shape[0] != t.size or t.size < 3:
        raise ValueError(f"need K >= 3 samples with t (K,) and Y (K, m), got {t.shape} and {Y.shape}")
    A = np.stack([np.ones_like(t), t - t[-1]], axis=1)
    coef, *_ = np.linalg.lstsq(A, Y, rcond=None)
    res = Y - A @ coef
    chi = float(np.einsum("ki,ki->", res, np.linalg.solve(R, res.T).T))
    C = np.kron(np.linalg.inv(A.T @ A), R)
    return LineFit(b=coef[0], d=coef[1], C=C, residual_chi2=chi, dof=(t.size - 2) * Y.shape[1])


def inflation(c, P, C) -> float:
    """Smallest ``λ ≥ 1`` with ``cᵀ (λ P + C)⁻¹ c ≤ len(c)`` (1 if ``λ = 1`` already does)."""
    m = len(c)

    def excess(log_lam: float) -> float:
        return float(c @ np.linalg.solve(np.exp(log_lam) * P + C, c)) - m

    if excess(0.0) <= 0.0:
        return 1.0
    hi = 1.0
    while excess(hi) > 0.0:  # c is finite and P positive definite, so this ends
        hi *= 2.0
    return float(np.exp(brentq(excess, 0.0, hi)))


@dataclass
class Reacquisition:
    """Per-source re-acquisition of a filter that its gates have locked out (module docstring).

    ``window``: rejected measurements in a row needed for a fit (≥ 3);
    ``confidence``: probability that a lost-but-correct line of innovations passes the fit test.
    ``events`` lists ``(t, source)`` of every re-acquisition.
    """

    window: int = 5
    confidence: float = 0.999
    events: list = field(default_factory=list)

    def __post_init__(self):
        if int(self.window) < 3:
            raise ValueError(f"window must be at least 3 measurements, got {self.window!r}")
        if not (0.0 < self.confidence < 1.0):
            raise ValueError(f"confidence must lie in (0, 1), got {self.confidence!r}")
        self._buffers: dict[str, list] = {}

    def step(self, filt, source, accepted: bool, t: float, y, x_prior) -> bool:
        """Record one gate decision of ``source``; re-acquire ``filt`` and return True if due.

        ``y``: the source's innovation at ``t``, about ``x_prior``, the filter's
        state before this step's update.
        """
        if source.name not in SOURCE_BLOCKS:
            return False
        buf = self._buffers.setdefault(source.name, [])
        if accepted:
            buf.clear()
            return False
        buf.append((float(t), np.array(y, dtype=float), np.array(x_prior, dtype=float)))
        del buf[: -int(self.window)]
        if len(buf) < self.window:
            return False
        fit = fit_line([b[0] for b in buf], np.array([b[1] for b in buf]), source.R)
        if fit.residual_chi2 > chi2.ppf(self.confidence, fit.dof):
            return False
        own, rate = (np.arange(N_ERROR)[ERROR_GROUPS[g]] for g in SOURCE_BLOCKS[source.name])
        m = own.size
        scale = np.ones(N_ERROR)
        scale[own] = np.sqrt(inflation(fit.b, filt.P[np.ix_(own, own)], fit.C[:m, :m]))
        scale[rate] = np.sqrt(inflation(fit.d, filt.P[np.ix_(rate, rate)], fit.C[m:, m:]))
        dx = np.zeros(N_ERROR)
        dx[own] = fit.b
        x_fix = filt.model.boxplus(buf[-1][2], dx)
        filt.rescale(scale)
        filt.fix_components(own, x_fix, fit.C[:m, :m])
        self.events.append((float(t), source.name))
        buf.clear()
        return True
