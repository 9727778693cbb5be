"""Fast DFT of unevenly sampled data by extirpolation (Press & Rybicki 1989, ApJ 338, 277).

The weighted sums ``Σ h cos(2πνt)`` and ``Σ h sin(2πνt)`` come from astropy's
``trig_sum`` (the engine of ``LombScargle(method="fast")``): each sample is
spread onto a regular grid with Lagrange weights and one FFT gives every
frequency. Accuracy with oversampling 10 and 8-point Lagrange weights is far below the
noise of any light curve (measured: ~2e-6 of the peak for 800 samples; see tests).
"""

from __future__ import annotations

import numpy as np
from astropy.timeseries.periodograms.lombscargle.implementations.utils import trig_sum


def _dft(t: np.ndarray, h: np.ndarray, df: float, n: int) -> np.ndarray:
    S, C = trig_sum(t, h, df, n, f0=0.0, use_fft=True, oversampling=10, Mfft=8)
    return (C - 1j * S) / t.size


def dirty_and_window(t: np.ndarray, y: np.ndarray, df: float, n_freq: int) -> tuple[np.ndarray, np.ndarray]:
    """Dirty spectrum on ``n_freq`` points and window on ``2 n_freq − 1`` points (spacing ``df``)."""
    t = t - t[0]
    return _dft(t, y, df, n_freq), _dft(t, np.ones_like(t), df, 2 * n_freq - 1)


def window(t: np.ndarray, df: float, n_freq: int) -> np.ndarray:
    """The spectral window ``W(j df)``, ``j = 0 … n_freq − 1``, alone."""
    return _dft(t - t[0], np.ones_like(t), df, n_freq)
