"""CoMBiNa's two outlier checks before each update (Maestrini et al. §IV.A–B).

1. BCPD's similarity scale ``s`` must lie in ``[0.8, 1.2]``: a registration
   that had to shrink or stretch the model to fit has deformed the body and
   its pose is discarded (text after eq. 8 and before eq. 18).
2. The squared Mahalanobis distance of the innovation (eq. 18) must not exceed
   the 99 % quantile of the chi-square distribution with ``ν`` degrees of
   freedom (eqs 19–20; ``ν = 3`` for a position or an MRP) — the one-sided
   gate of :mod:`estimators.gates`.

Both return a :class:`~estimators.gates.GateDecision`, so every decision can be
recorded, accepted or not.

References
----------
.. [1] Maestrini, De Luca, Di Lizia, *Relative Navigation Strategy About Unknown and Uncooperative
   Targets*, Journal of Guidance, Control, and Dynamics, 2023.
"""

from __future__ import annotations

import numpy as np

from estimators.combina.unscented import Innovation
from estimators.gates import GateDecision, chi_square_gate

SCALE_BOUNDS = (0.8, 1.2)
"""Accepted BCPD scale factors (§IV.A of Maestrini et al.)."""
MAHALANOBIS_CONFIDENCE = 0.99
"""Probability of accepting a correct measurement (eq. 19 of Maestrini et al.)."""

REASON_SCALE = "scale outside bounds"
REASON_NO_REGISTRATION = "no registration (degenerate cloud or target not seen)"


def scale_gate(scale: float, *, t: float, source: str, bounds: tuple[float, float] = SCALE_BOUNDS) -> GateDecision:
    """Accept a BCPD registration whose scale ``s`` lies in ``bounds`` (inclusive); NaN = no registration."""
    s = float(scale)
    lo, hi = bounds
    ok = bool(np.isfinite(s) and lo <= s <= hi)
    reason = "" if ok else (REASON_SCALE if np.isfinite(s) else REASON_NO_REGISTRATION)
    return GateDecision(t=float(t), source=source, e2=float("nan"), lower=lo, upper=hi, accepted=ok, reason=reason)


def mahalanobis_gate(inn: Innovation, *, t: float, source: str, confidence: float = MAHALANOBIS_CONFIDENCE) -> GateDecision:
    """Eq. 18 against the one-sided chi-square bound of eqs 19–20 (``ν = len(y)``)."""
    return chi_square_gate(inn.y, inn.S, t=t, source=source, confidence=confidence, two_sided=False)
