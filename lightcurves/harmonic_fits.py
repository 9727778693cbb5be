"""χ² of weighted least-squares fits of a quadratic trend plus ``k`` harmonics, at many trial frequencies.

:func:`harmonic_chi2` is what the spin prior's ranking spends its time in:
at each trial frequency ``f`` the fits of
``V c + Σ_{j ≤ k} (a_j cos 2πjft + b_j sin 2πjft)`` for ``k = 1 … K`` (``V``:
three trend columns). The normal matrix needs only the weighted
trigonometric sums ``Σ W e^{imθ}`` (``m ≤ 2K``), ``Σ W V e^{ijθ}`` and
``Σ W y e^{ijθ}`` (``j ≤ K``), ``θ = 2πft`` — ``O(N K)`` per frequency
instead of ``O(N K²)``, the same reduction as the multi-term periodogram
of VanderPlas & Ivezić (2015) — and its Cholesky factor, with the columns
ordered by harmonic, gives every nested fit at once:
``χ²_k = yᵀWy − Σ_{p < 3 + 2k} z_p²``, ``L z = Xᵀ W y``.

Compiled (numba): the sums for one frequency are ``2K`` passes over the
samples that the compiler vectorises, the phasors ``e^{iθ}`` come from
:func:`~lightcurves.phasors.cis` (2 ns a sample against 21 ns for ``cos``
and ``sin`` from the C library), and
evenly spaced frequencies (the local grids and stencils of the ranking)
need one phasor per row and products for the rest. A call with 3
frequencies costs ~50 µs instead of the ~0.4 ms numpy's batched linear
algebra spent in overhead.

References
----------
.. [1] VanderPlas & Ivezić, *Periodograms for multiband astronomical time series*, ApJ 812, 18, 2015 (§2: the
   multi-term normal equations from trigonometric sums).
"""

from __future__ import annotations

import numba
import numpy as np

from lightcurves.phasors import cis

__all__ = ["design", "frequency_derivative", "harmonic_chi2", "harmonic_set_chi2", "sinusoids_fit"]

@numba.njit(cache=True, fastmath={"reassoc", "contract"})
def _sums(Er, Ei, W, WV, K, T, Q):
    """``T[m] = Σ W e^{imθ}`` (``m ≤ 2K``) and ``Q[j − 1, c] = Σ WV[c] e^{ijθ}`` (``j ≤ K``; ``WV``: the three weighted
    trend columns and ``W y``), for phasors ``e^{iθ} = Er + i Ei``: one pass over the samples per power (reassociated
    sums, so that they vectorise: ~1e-16 relative)."""
    Pr = Er.copy()
    Pi = Ei.copy()
    T[0] = W.sum()
    w0, w1, w2, w3 = WV[0], WV[1], WV[2], WV[3]
    for m in range(1, 2 * K + 1):
        ar = ai = 0.0
        if m <= K:
            b0r = b0i = b1r = b1i = b2r = b2i = b3r = b3i = 0.0
            for n in range(Er.size):
                pr, pi = Pr[n], Pi[n]
                ar += W[n] * pr
                ai += W[n] * pi
                b0r += w0[n] * pr
                b0i += w0[n] * pi
                b1r += w1[n] * pr
                b1i += w1[n] * pi
                b2r += w2[n] * pr
                b2i += w2[n] * pi
                b3r += w3[n] * pr
                b3i += w3[n] * pi
                Pr[n] = pr * Er[n] - pi * Ei[n]
                Pi[n] = pr * Ei[n] + pi * Er[n]
            Q[m - 1, 0] = complex(b0r, b0i)
            Q[m - 1, 1] = complex(b1r, b1i)
            Q[m - 1, 2] = complex(b2r, b2i)
            Q[m - 1, 3] = complex(b3r, b3i)
        else:
            for n in range(Er.size):
                pr, pi = Pr[n], Pi[n]
                ar += W[n] * pr
                ai += W[n] * pi
                Pr[n] = pr * Er[n] - pi * Ei[n]
                Pi[n] = pr * Ei[n] + pi * Er[n]
        T[m] = complex(ar, ai)


@numba.njit(cache=True)
def _nested_chi2(T, Q, VWV, VWy, yWy, harm, out):
    """``out[k − 1] = χ²`` of the fit with the first ``k`` harmonics of ``harm`` (their numbers, in column order), from
    the sums of :func:`_sums` (``K ≥ max(harm)``): the normal matrix ``G`` with columns (trend, cos h₁θ, sin h₁θ,
    cos h₂θ, …), ``G += 1e-10 tr(G)/p I``, its Cholesky factor ``L`` and ``L z = Xᵀ W y``.

    Products of harmonics from the sums: ``Σ W cos jθ cos kθ = ½(C_{|j−k|} + C_{j+k})``,
    ``Σ W sin jθ sin kθ = ½(C_{|j−k|} − C_{j+k})``, ``Σ W cos jθ sin kθ = ½(S_{j+k} − sgn(j − k) S_{|j−k|})``
    (``C_m + i S_m = T[m]``). A column in the span of the previous ones (a pivot ≤ 0) gets ``L_ii = ∞``: it
    takes no part in the fit and lowers χ² by nothing, as it should.
    """
    q = VWV.shape[0]
    p = q + 2 * harm.size
    G = np.zeros((p, p))
    b = np.empty(p)
    G[:q, :q] = VWV
    b[:q] = VWy
    for jj in range(harm.size):
        j, cj, sj = harm[jj], q + 2 * jj, q + 2 * jj + 1
        for a in range(q):
            G[a, cj] = G[cj, a] = Q[j - 1, a].real
            G[a, sj] = G[sj, a] = Q[j - 1, a].imag
        b[cj], b[sj] = Q[j - 1, q].real, Q[j - 1, q].imag
        for kk in range(harm.size):
            k, ck, sk = harm[kk], q + 2 * kk, q + 2 * kk + 1
            d = abs(j - k)
            sgn = 1.0 if j > k else (-1.0 if j < k else 0.0)
            G[cj, ck] = 0.5 * (T[d].real + T[j + k].real)
            G[sj, sk] = 0.5 * (T[d].real - T[j + k].real)
            G[cj, sk] = G[sk, cj] = 0.5 * (T[j + k].imag - sgn * T[d].imag)
    ridge = 1e-10 * np.trace(G) / p
    L = np.zeros((p, p))
    z = np.empty(p)
    for i in range(p):
        for j in range(i + 1):
            s = G[i, j] + (ridge if i == j else 0.0)
            for k in range(j):
                s -= L[i, k] * L[j, k]
            if i == j:
                L[i, i] = np.sqrt(s) if s > 0.0 else np.inf
            else:
                L[i, j] = s / L[j, j]
        s = b[i]
        for k in range(i):
            s -= L[i, k] * z[k]
        z[i] = s / L[i, i]
    acc = 0.0
    for i in range(q):
        acc += z[i] * z[i]
    for k in range(harm.size):
        acc += z[q + 2 * k] ** 2 + z[q + 2 * k + 1] ** 2
        out[k] = max(yWy - acc, 0.0)


@numba.njit(cache=True)
def _weighted_columns(V, y, W):
    """``(WV, VᵀWV, VᵀWy, yᵀWy)``: the weighted trend columns and ``W y``, one row each (contiguous for the sums), with
    ``y`` less its weighted mean. The trend holds the constant, so no χ² changes; but the normal equations no longer
    carry the magnitude offset, whose square the ridge of :func:`_nested_chi2` would weigh (5e-4 of χ² on a 12 mag
    survey curve with 31 points) and which cancels in ``yᵀWy − Σ z²``."""
    N, q = V.shape
    yc = y - (W @ y) / W.sum()
    WV = np.empty((q + 1, N))
    for n in range(N):
        for c in range(q):
            WV[c, n] = W[n] * V[n, c]
        WV[q, n] = W[n] * yc[n]
    return WV, WV[:q] @ V, WV[:q] @ yc, WV[q] @ yc


@numba.njit(cache=True)
def _chi2_rows(tc, V, y, W, freqs, K, even):
    R, M = freqs.shape
    N = tc.size
    WV, VWV, VWy, yWy = _weighted_columns(V, y, W)
    harm = np.arange(1, K + 1)
    out = np.empty((R * M, K))
    T = np.empty(2 * K + 1, dtype=np.complex128)
    Q = np.empty((K, V.shape[1] + 1), dtype=np.complex128)
    Er, Ei, Sr, Si = np.empty(N), np.empty(N), np.empty(N), np.empty(N)
    if even and M > 1:  # e^{2πiδt}, δ the columns' spacing (the same in every row)
        cis(2.0 * np.pi * (freqs[0, 1] - freqs[0, 0]), tc, Sr, Si)
    for r in range(R):
        for j in range(M):
            if j == 0 or not even:
                cis(2.0 * np.pi * freqs[r, j], tc, Er, Ei)
            else:
                for n in range(N):
                    er = Er[n] * Sr[n] - Ei[n] * Si[n]
                    Ei[n] = Er[n] * Si[n] + Ei[n] * Sr[n]
                    Er[n] = er
            _sums(Er, Ei, W, WV, K, T, Q)
            _nested_chi2(T, Q, VWV, VWy, yWy, harm, out[r * M + j])
    return out


@numba.njit(cache=True)
def _chi2_set(tc, V, y, W, f, harm):
    N = tc.size
    K = harm.max()
    WV, VWV, VWy, yWy = _weighted_columns(V, y, W)
    T = np.empty(2 * K + 1, dtype=np.complex128)
    Q = np.empty((K, V.shape[1] + 1), dtype=np.complex128)
    Er, Ei = np.empty(N), np.empty(N)
    cis(2.0 * np.pi * f, tc, Er, Ei)
    _sums(Er, Ei, W, WV, K, T, Q)
    out = np.empty(harm.size)
    _nested_chi2(T, Q, VWV, VWy, yWy, harm, out)
    return out


def _contiguous(*arrays):
    return tuple(np.ascontiguousarray(a, dtype=float) for a in arrays)


def _check_trend(tc: np.ndarray, V: np.ndarray) -> None:
    if V.shape != (tc.size, 3) or np.ptp(V[:, 2]) != 0.0 or V[0, 2] == 0.0:
        raise ValueError(f"the trend V must have shape (N, 3) = ({tc.size}, 3) with a constant last column (np.vander), got {V.shape}")


def harmonic_chi2(tc: np.ndarray, V: np.ndarray, y: np.ndarray, W: np.ndarray, freqs, K: int) -> np.ndarray:
    """``χ²_k(f)`` of the weighted fits of ``V`` (an (N, 3) trend whose last column is constant) plus ``cos(2πjft), sin(2πjft)``, ``j ≤ k``, for
    ``k = 1 … K``: shape (freqs.size, K), frequencies in ``freqs``' row-major order.

    ``tc``: times (s) from a centre near the data's middle (the phases are evaluated as they stand); ``W``: the
    weights ``1/σ²``. A 2-D ``freqs`` whose columns are evenly spaced, by the same step in every row, costs one
    phasor per row (the others are products: ``M − 1`` products lose ~1e-15 in the phase). The trend is fitted
    jointly: removed beforehand, it takes the part of a few-cycle sinusoid that projects on it.
    """
    freqs = np.atleast_2d(np.asarray(freqs, dtype=float))
    _check_trend(tc, V)
    steps = np.diff(freqs, axis=1)
    even = freqs.shape[1] > 1 and bool(np.max(np.abs(steps - steps[0, 0])) <= 1e-9 * abs(steps[0, 0]))
    return _chi2_rows(*_contiguous(tc, V, y, W), freqs, int(K), even)


def harmonic_set_chi2(tc: np.ndarray, V: np.ndarray, y: np.ndarray, W: np.ndarray, f: float, harmonics) -> np.ndarray:
    """χ² of the nested fits of the trend plus the first ``k`` harmonics of ``f`` listed in ``harmonics`` (their numbers,
    in the order they enter; any set, e.g. the even ones then 1 and 3), for ``k = 1 … len(harmonics)``."""
    harm = np.asarray(harmonics, dtype=np.int64)
    _check_trend(tc, V)
    if harm.size == 0 or harm.min() < 1 or np.unique(harm).size != harm.size:
        raise ValueError(f"need distinct harmonic numbers >= 1, got {harm.tolist()}")
    return _chi2_set(*_contiguous(tc, V, y, W), float(f), harm)


@numba.njit(cache=True)
def _design(tc, V, f, K):
    N, q = V.shape
    X = np.empty((N, q + 2 * K))
    X[:, :q] = V
    re, im = np.empty(N), np.empty(N)
    cis(2.0 * np.pi * f, tc, re, im)
    for n in range(N):
        c, s = re[n], im[n]
        for k in range(K):  # e^{i(k+1)θ} = e^{ikθ} e^{iθ}
            X[n, q + k], X[n, q + K + k] = c, s
            c, s = c * re[n] - s * im[n], c * im[n] + s * re[n]
    return X


def design(tc: np.ndarray, V: np.ndarray, f: float, K: int) -> np.ndarray:
    """Columns ``V`` (trend), ``cos(2πkft)`` for k = 1 … K, ``sin(2πkft)`` for k = 1 … K (harmonics as powers of
    one phasor: ``k`` products lose ~k·1e-16)."""
    return _design(*_contiguous(tc, V), float(f), int(K))


def frequency_derivative(tc: np.ndarray, X: np.ndarray, coef: np.ndarray, K: int) -> np.ndarray:
    """``∂m/∂f`` of the model ``m = X coef`` with ``X`` from :func:`design` (trend, then ``cos 2πkft`` and
    ``sin 2πkft`` for k = 1 … K): ``2π t Σ_k k (b_k cos 2πkft − a_k sin 2πkft)`` — the frequency's column of the
    fit's Jacobian."""
    q = X.shape[1] - 2 * K
    k = np.arange(1, K + 1)
    cos_k, sin_k = X[:, q : q + K], X[:, q + K :]
    return 2.0 * np.pi * tc * (sin_k @ (-k * coef[q : q + K]) + cos_k @ (k * coef[q + K :]))


@numba.njit(cache=True)
def sinusoids_fit(tc: np.ndarray, V: np.ndarray, y: np.ndarray, w: np.ndarray, freqs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(weighted residuals, coefficients)`` of the least-squares fit of ``V c + Σ_i (a_i cos 2πf_i t + b_i sin 2πf_i t)``
    with weights ``w = 1/σ`` (coefficients: ``c``, then ``a_i, b_i`` per frequency), by the normal equations with a ridge of
    1e-12 of their trace (well conditioned at distinct frequencies). Compiled: Levenberg–Marquardt on the frequencies
    calls it some twenty times."""
    N, q = V.shape
    X = np.empty((N, q + 2 * freqs.size))
    for n in range(N):
        for c in range(q):
            X[n, c] = V[n, c] * w[n]
    re, im = np.empty(N), np.empty(N)
    for i in range(freqs.size):
        cis(2.0 * np.pi * freqs[i], tc, re, im)
        X[:, q + 2 * i] = re * w
        X[:, q + 2 * i + 1] = im * w
    yw = y * w
    G = X.T @ X
    G += 1e-12 * np.trace(G) * np.eye(G.shape[0])
    coef = np.linalg.solve(G, X.T @ yw)
    return yw - X @ coef, coef
