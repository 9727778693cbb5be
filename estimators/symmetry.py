"""Symmetry detection from consecutive attitude measurements (``000_…`` §IV.C).

Two estimates of the principal angle turned between two measurement epochs:

* measured, eq. 33 as it should read: ``Φ = arccos((Tr(C_{k+1} C_kᵀ) − 1)/2)``
  (:func:`estimators.attitude.dcm_angle`);
* predicted from the filter's rate, eq. 34: ``Φ̂ = |ω̂(k|k)| Δt``.

For an asymmetric target the two agree up to the measurement noise. For a
symmetric one BCPD settles on any roll about the symmetry axis, so ``Φ``
jumps about while ``Φ̂`` stays smooth. The detector keeps the last ``window``
discrepancies and declares symmetry when their median exceeds
``threshold_rad`` — a discrepancy sustained over at least half the window.
Once declared it stays declared.

Robustness (not in the paper): a single bad registration of an asymmetric
target makes *two* consecutive pairs disagree (into and out of it), so a few
outliers close together could fill half a window. Each new measurement is
therefore also compared with the one before the previous (eq. 34 with its
``Δt``) when the consecutive discrepancy exceeds the threshold, and the smaller
discrepancy is kept: an isolated outlier then counts once, while for a
symmetric target both comparisons are large (the roll is random each time).
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass

import numpy as np

from estimators.attitude import dcm_angle


@dataclass(frozen=True)
class SymmetryCheck:
    """One comparison of eq. 33 with eq. 34."""

    t: float  #: s, epoch of the newer measurement
    phi_measured_rad: float  #: eq. 33
    phi_predicted_rad: float  #: eq. 34
    discrepancy_rad: float  #: ``|Φ − Φ̂|``
    window_median_rad: float  #: median over the window (nan until it is full)
    detected: bool  #: symmetry declared (at this or an earlier check)


class SymmetryDetector:
    """Sustained eq. 33 / eq. 34 discrepancy over a window of measurement pairs.

    Parameters
    ----------
    window : int
        number of consecutive discrepancies examined.
    threshold_rad : float
        median discrepancy above which symmetry is declared.
    """

    def __init__(self, window: int = 20, threshold_rad: float = np.deg2rad(20.0)):
        if int(window) != window or window < 1:
            raise ValueError(f"window must be a positive integer, got {window!r}")
        if not (np.isfinite(threshold_rad) and threshold_rad > 0):
            raise ValueError(f"threshold_rad must be positive and finite, got {threshold_rad!r}")
        self.window = int(window)
        self.threshold_rad = float(threshold_rad)
        self._d: deque[float] = deque(maxlen=self.window)
        self._last: deque[tuple[float, np.ndarray]] = deque(maxlen=2)
        self.detected = False
        self.detected_at: float | None = None

    def add(self, t: float, C_TI, w_hat_rad_s) -> SymmetryCheck | None:
        """Feed a measured ``C_TI`` at ``t`` with the filter's current ``ω̂`` (rad/s).

        Returns ``None`` for the first measurement, else the check against the
        previous ones (the reported ``Φ``, ``Φ̂`` are those of the kept comparison).
        ``w_hat_rad_s`` is ``ω̂(k|k)``, the estimate at the previous measurement epoch.
        """
        C = np.asarray(C_TI, dtype=float)
        t = float(t)
        rate = float(np.linalg.norm(w_hat_rad_s))
        prev = list(self._last)
        self._last.append((t, C))
        if not prev:
            return None
        checks = []
        for t0, C0 in reversed(prev):  # the consecutive pair first
            phi = float(dcm_angle(C0, C))  # eq. 33 (corrected)
            phi_hat = rate * (t - t0)  # eq. 34
            checks.append((phi, phi_hat, abs(phi - phi_hat)))
        best = checks[0]
        if best[2] > self.threshold_rad:  # only then does the two-back comparison matter
            best = min(checks, key=lambda c: c[2])
        phi, phi_hat, d = best
        self._d.append(d)
        med = float(np.median(self._d)) if len(self._d) == self.window else float("nan")
        if not self.detected and med > self.threshold_rad:
            self.detected = True
            self.detected_at = t
        return SymmetryCheck(t=t, phi_measured_rad=phi, phi_predicted_rad=phi_hat, discrepancy_rad=d, window_median_rad=med, detected=self.detected)
