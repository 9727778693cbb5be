"""Trigonometric sums on a regular frequency grid by a non-uniform FFT (Gaussian gridding).

:func:`trig_sums` returns ``F_j = Σ_n h_n e^{2πi (f0 + j δf) t_n}``,
``j = 0 … n − 1``, for unevenly spaced times ``t`` — the sums every
Lomb–Scargle periodogram, spectral window and noise spectrum of
:mod:`lightcurves.prior` is made of. It is the type-1 non-uniform FFT of
Greengard & Lee (2004, §2, eqs. 3–9) with oversampling ``R = 2``:

1. with ``x_n = 2π δf t_n`` (mod 2π) the sums are the Fourier
   coefficients ``G(k) = Σ_n c_n e^{i k x_n}`` of a sum of spikes of
   strengths ``c_n = h_n e^{2πi (f0 + m δf) t_n}`` (``m = ⌊n/2⌋``:
   the grid centred on mode 0), ``k = j − m``;
2. the spikes are convolved with the periodic Gaussian
   ``g_τ(x) = Σ_l e^{−(x − 2πl)²/4τ}``, ``τ = π M_sp / (M² R (R − ½))``,
   and the result sampled on ``M_r = R M`` points (``M`` modes); each
   sample touches ``2 M_sp`` grid points, whose weights come from two
   exponentials and a table (Greengard & Lee's "fast Gaussian gridding",
   eqs. 10–11);
3. one FFT of the grid gives ``G_τ(k) = √(4πτ)/(2π) e^{−k²τ} G(k)``, so
   ``G(k) = √(π/τ) e^{k²τ} G_τ(k)`` (deconvolution).

With ``M_sp = 12`` the error is ~1e-12 of ``Σ|h_n|`` (tests: against the
direct sums), like astropy's default low-rank NUFFT (5e-13), at a
fraction of its time: one spreading pass of ``24 N`` multiplications and
one FFT of ``~4n`` points, against ``K = 13`` FFTs and ``2K`` bin counts.

References
----------
.. [1] Greengard & Lee, *Accelerating the nonuniform fast Fourier transform*, SIAM Review 46, 443, 2004.
.. [2] Dutt & Rokhlin, *Fast Fourier transforms for nonequispaced data*, SIAM J. Sci. Comput. 14, 1368, 1993.
"""

from __future__ import annotations

import numba
import numpy as np
from scipy.fft import ifft, next_fast_len

from lightcurves.phasors import cis

__all__ = ["trig_sums"]

_M_SP = 12  #: grid points spread to on each side of a sample (Greengard & Lee's M_sp): error ~1e-12
_R = 2  #: oversampling of the FFT grid


@numba.njit(cache=True)
def _spread(t: np.ndarray, c: np.ndarray, omega: float, df: float, Mr: int, tau: float, m_sp: int, grid: np.ndarray) -> None:
    """``grid[s] += Σ_n c[s, n] e^{iωt_n} g_τ(ξ_m − x_n)`` over the ``2 M_sp`` grid points ``ξ_m = 2πm/M_r`` nearest
    each ``x_n = 2π df t_n`` (mod 2π): fast Gaussian gridding (Greengard & Lee eqs. 10–11),
    ``e^{−(δ − lh)²/4τ} = e^{−δ²/4τ} (e^{δh/2τ})^l e^{−(lh)²/4τ}``, ``h = 2π/M_r``: two exponentials a sample, and the
    weights of all samples one power of ``l`` at a time (a loop the compiler vectorises). ``grid``: (S, 2 M_r), the
    real and imaginary parts of S complex grids interleaved."""
    N, width = t.size, 2 * m_sp
    h = 2.0 * np.pi / Mr
    E3 = np.empty(width)  # e^{−(lh)²/4τ}, l = 1 − M_sp … M_sp
    for l in range(width):
        E3[l] = np.exp(-(((l - m_sp + 1) * h) ** 2) / (4.0 * tau))
    start = np.empty(N, dtype=np.int64)
    v, e2 = np.empty(N), np.empty(N)
    for n in range(N):
        pos = df * t[n]
        pos = (pos - np.floor(pos)) * Mr  # grid units in [0, M_r)
        m0 = np.floor(pos)
        delta = (pos - m0) * h  # x_n − ξ_{m0} ∈ [0, h)
        e2[n] = np.exp(delta * h / (2.0 * tau))
        v[n] = np.exp(-delta * delta / (4.0 * tau) - (m_sp - 1) * delta * h / (2.0 * tau))  # l = 1 − M_sp
        start[n] = (int(m0) - m_sp + 1) % Mr
    w = np.empty((width, N))
    for l in range(width):
        for n in range(N):
            w[l, n] = v[n] * E3[l]
            v[n] *= e2[n]
    re, im = np.empty(N), np.empty(N)
    cis(omega, t, re, im)
    for s in range(c.shape[0]):
        for n in range(N):
            cr = c[s, n].real * re[n] - c[s, n].imag * im[n]
            ci = c[s, n].real * im[n] + c[s, n].imag * re[n]
            m = start[n]
            for l in range(width):
                grid[s, 2 * m] += cr * w[l, n]
                grid[s, 2 * m + 1] += ci * w[l, n]
                m += 1
                if m == Mr:
                    m = 0


def trig_sums(t, h, f0: float, df: float, n: int) -> np.ndarray:
    """``F_j = Σ_k h_k e^{2πi (f0 + j df) t_k}`` for ``j = 0 … n − 1``: complex, ``C + iS`` in astropy's ``trig_sum`` terms.

    Parameters
    ----------
    t : (N,) times (s). The phases ``2π f t`` are evaluated as they stand (to ~1e-16 ``f |t|``): pass times from an
        origin near the data (``t − t[0]``, lags), as a direct sum would need too.
    h : (N,) or (S, N) real or complex weights; S sets of weights share one spreading pass.
    f0, df : first frequency and spacing (Hz), ``df > 0``.
    n : number of frequencies.

    Returns (n,) or (S, n) complex sums, accurate to ~1e-12 of ``Σ|h|``.
    """
    t = np.asarray(t, dtype=float)
    h = np.asarray(h)
    c = np.atleast_2d(h).astype(complex)
    if not (df > 0 and n >= 1 and c.shape[1] == t.size):
        raise ValueError(f"need df > 0, n >= 1 and one weight per time; got df {df}, n {n}, {c.shape[1]} weights for {t.size} times")
    half = n // 2  # mode 0 of the transform is frequency f0 + half df
    M = 2 * max(n - half, half)  # modes −M/2 … M/2 − 1 hold k = −half … n − 1 − half
    Mr = next_fast_len(_R * M)
    tau = np.pi * _M_SP / (M * M * _R * (_R - 0.5))
    grid = np.zeros((c.shape[0], Mr), dtype=complex)
    _spread(t, c, 2.0 * np.pi * (f0 + half * df), df, Mr, tau, _M_SP, grid.view(np.float64))
    G = ifft(grid, axis=1, overwrite_x=True)  # ifft's 1/M_r: eq. 9's quadrature
    e = np.sqrt(np.pi / tau) * np.exp(np.arange(max(half, n - half) + 1) ** 2 * tau)  # deconvolution e^{k²τ}, even in k
    F = np.empty((c.shape[0], n), dtype=complex)
    F[:, :half] = G[:, Mr - half :] * e[half:0:-1]  # k = −half … −1
    F[:, half:] = G[:, : n - half] * e[: n - half]  # k = 0 … n − 1 − half
    return F if h.ndim == 2 else F[0]
