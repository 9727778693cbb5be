"""Direct (term-by-term) DFT of unevenly sampled data: eqs 2–3 of Roberts, Lehár & Dreher (1987)."""

from __future__ import annotations

import numpy as np


def _dft(t: np.ndarray, h: np.ndarray, df: float, n: int, chunk: int = 2048) -> np.ndarray:
    """``(1/N) Σ_r h_r e^{−2πi j df t_r}`` for ``j = 0 … n−1``, in frequency chunks to bound memory."""
    out = np.empty(n, dtype=complex)
    for j0 in range(0, n, chunk):
        f = df * np.arange(j0, min(j0 + chunk, n))
        out[j0 : j0 + f.size] = np.exp(-2j * np.pi * np.outer(f, t)) @ h
    return out / t.size


def dirty_and_window(t: np.ndarray, y: np.ndarray, df: float, n_freq: int) -> tuple[np.ndarray, np.ndarray]:
    """Dirty spectrum on ``n_freq`` points and window on ``2 n_freq − 1`` points (spacing ``df``)."""
    t = t - t[0]  # a time shift only changes phases; keeps the exponent arguments small
    return _dft(t, y, df, n_freq), _dft(t, np.ones_like(t), df, 2 * n_freq - 1)
