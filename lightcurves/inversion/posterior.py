"""The posterior of a spin-state inversion: :class:`SpinSolution` (one mode) and :class:`InversionResult` (all of them).

Each mode is a local optimum of the profiled χ² (the shape's linear parameters and the relative curves'
scales solved at every spin state) with its Gauss–Newton covariance ``Σ = (JᵀWJ)⁻¹`` (J the Jacobian of
the whitened, profiled residuals). The pole's uncertainty lives on the tangent plane of the sphere at
the pole, in the basis (e₁, e₂) of :func:`lightcurves.inversion.spin.pole_frame`: a true pole ``p`` is
at the tangent offset ``θ·(e₁·u, e₂·u)`` with θ the angle from the estimate and u the unit direction
of ``p`` seen from it (the logarithmic map of the sphere).

Relative probabilities of modes come from their Laplace evidences (MacKay, *Information Theory,
Inference and Learning Algorithms*, 2003, ch. 28)

    Z_i ∝ exp(−χ²_i / (2 s)) · √det Σ_i · V,

with the prior volume V the same for every mode (uniform in pole direction and period over the searched
ranges) and dropped (a comb of cycle-count aliases made one mode by :func:`lightcurves.inversion.search._comb_moments`
has its teeth's evidences summed: its Z is the lead tooth's times Σ_k W_k there); ``s`` (below) inflates both χ²
and Σ when the residuals carry less information than independent samples of the stated σ would, so a poor model does
not give overconfident odds between modes.

How much information the residuals carry
----------------------------------------
The Gauss–Newton covariance assumes white residuals of unit variance. Under model error (a light curve
rendered by a path tracer, fitted by the facet model: ~2 % rms) the residuals are neither: their variance
``γ(0)`` exceeds 1, and they are smooth in rotational phase, so correlated over many samples within a
night. For least squares with residual covariance V the estimate's covariance is the sandwich
``H⁻¹ JᵀVJ H⁻¹``, H = JᵀJ (White 1980, Econometrica 48, 817; Newey & West 1987, Econometrica 55, 703);
when J's columns vary slowly against the correlation length, ``JᵀVJ ≈ σ²_LR JᵀJ`` with the long-run
variance ``σ²_LR = Σ_ℓ γ(ℓ) = γ(0) τ`` (the residuals' spectral density at zero frequency), so

    Σ = s H⁻¹,        s = max(1, max(1, κ) · χ²_min / dof, φ),                                   (1)

two estimates of the ratio of the sandwich to the Gauss–Newton covariance, the larger kept. The first,
``κ · χ²_min/dof``, has ``χ²_min/dof`` the estimate of γ(0) and κ the residuals' integrated
autocorrelation time, pooled over the curves k (nights; no correlation is assumed between them); κ < 1
(anti-correlated residuals, or the estimator's spread on white ones) is not allowed to sharpen the
posterior below the white-noise scale ``χ²_min/dof``, so s is never below the earlier max(1, χ²_min/dof):

    τ_k = 1 + 2 Σ_{ℓ=1}^{M_k} ρ̂_k(ℓ),    ρ̂_k(ℓ) = γ̂_k(ℓ)/γ̂_k(0),    γ̂_k(ℓ) = (1/n_k) Σ_i r_i r_{i+ℓ},    (2)
    κ = Σ_k τ_k r_kᵀr_k / Σ_k r_kᵀr_k,                                                            (3)

the window M_k the smallest M with M ≥ c τ_k(M), c = 5 (Sokal's automatic windowing: Madras & Sokal 1988,
J. Stat. Phys. 50, 109; Sokal 1997, *Monte Carlo methods in statistical mechanics*, §3), the lags in
sample order within a curve (the cadence is near-uniform; gaps are ignored). γ̂ is not centred: the model
says the residuals have zero mean, so a night-wide offset left by model error is correlated error and is
counted (a constant residual gives τ_k = n_k, one independent datum per night; τ_k is capped there).
``N/κ`` is the effective number of independent residuals, ``κ = 1`` for white ones (its spread there is
``√(2(2M+1)/N)``, Priestley 1981, *Spectral Analysis and Time Series*, §5.3), and for an AR(1) process of
lag-one correlation ρ, ``κ → (1 + ρ)/(1 − ρ)``. The same ``s`` divides the χ² differences between modes:
a log-likelihood of correlated data counted as if independent is ``κ`` times too sharp (the magnitude
adjustment of a composite likelihood, Varin, Reid & Firth 2011, Statistica Sinica 21, 5), which is what
the time-averaging factor ``β² ≈ κ`` of transit photometry corrects (Pont, Zucker & Queloz 2006, MNRAS
373, 231). The floor at 1 keeps the stated σ as a lower bound on the noise.

κ sees correlation over a few samples only (the window stops at M ≈ 5 when it is small). The facet
model's error is also a function of the rotational phase, repeated every turn of a night: a component
small in power but coherent over the whole night, which biases the pole and which the window misses
(SC3 seed 1, three 600-s arcs rendered at 64 px, 3 h apart: κ = 1.01, χ²/dof 1.75, yet the truth at
Mahalanobis² 9.2 from the fit, 2 dof). The second estimate
compares the nights (Liang & Zeger 1986, Biometrika 73, 13: the nights as independent clusters): each
night's share of the gradient at the optimum, ``g_k = J_kᵀ r_k`` (Σ_k g_k = 0), has the covariance
``J_kᵀ V_k J_k`` — the sandwich's middle, whatever the correlation within the night — against
``G_k = J_kᵀ J_k`` for white residuals of unit variance, so

    φ = Σ_k g_kᵀ G_k⁺ g_k / (Σ_k rank G_k − p)                                                   (4)

(p the nonlinear parameters; the expectation of the numerator for white residuals of variance γ(0) is
γ(0)(Σ_k rank G_k − p), one rank p spent by Σ_k g_k = 0): the average, over the parameters' directions,
of how much more the nights disagree than independent samples would let them. The clusters are the
curves: several curves of one night share its error, which makes φ an underestimate. It needs two curves or
more (NaN otherwise) and is a χ² with Σ_k rank − p degrees of freedom over them for white residuals
(3 nights, 6 parameters: a relative spread of 0.41), so on white data s ≈ max(1, χ²₁₂/12): conservative.
When φ sets s, the scale itself is uncertain: a region of χ²_k quantiles then holds the truth a little
less often than stated (ν = 12, k = 2: the 95 % and 68 % regions hold it with the F law's probabilities
P(2 F(2, 12) ≤ 5.99) = 0.91 and 0.65), which the regions here do not correct for.

None of this can list a mode the search never reached: a fit in the wrong basin (χ²/dof in the hundreds
where the truth's is ~2) inflates its own σ (κ and φ grow) but keeps its sense. Nor does it see a model
error common to every night: it biases the pole without correlating the residuals or setting the nights
apart (SC1, chain-study seed 7: κ 1.03, φ 0.51, the truth at Mahalanobis² 33 from a 0.36° error).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from astropy.time import Time
from scipy.signal import correlate
from scipy.stats import chi2 as chi2_dist

from lightcurves.inversion.spin import SpinState, pole_frame

__all__ = ["SpinSolution", "InversionResult", "tangent_offset", "laplace_probabilities", "distinct_modes", "integrated_autocorrelation_time",
           "residual_correlation_time", "night_score_dispersion", "posterior_scale"]

#: Sokal's window constant c of eq. (2): the window M is the smallest lag with M ≥ c τ(M).
SOKAL_WINDOW_C = 5.0


def tangent_offset(pole_I, other_I) -> np.ndarray:
    """Tangent-plane offset (2,) rad of the unit direction ``other_I`` from ``pole_I``, in the basis (e₁, e₂) of the pole frame (log map)."""
    C_IP = pole_frame(np.asarray(pole_I, dtype=float))
    v = C_IP.T @ (np.asarray(other_I, dtype=float) / np.linalg.norm(other_I))
    angle = np.arctan2(np.hypot(v[0], v[1]), v[2])
    rho = np.hypot(v[0], v[1])
    return np.zeros(2) if rho == 0 else angle * v[:2] / rho


def tangent_exp(pole_I, offset) -> np.ndarray:
    """Unit directions (..., 3) at the tangent-plane offsets ``offset`` (..., 2) rad from ``pole_I`` in the basis (e₁, e₂) of
    the pole frame (the exponential map of the sphere, the inverse of :func:`tangent_offset`)."""
    C = pole_frame(np.asarray(pole_I, dtype=float))
    t = np.asarray(offset, dtype=float)
    r = np.linalg.norm(t, axis=-1)[..., None]
    return np.cos(r) * C[:, 2] + np.sin(r) * (t @ C[:, :2].T) / np.where(r > 0, r, 1.0)


@dataclass(frozen=True)
class SpinSolution:
    """One mode of the spin-state posterior.

    state : the fitted :class:`SpinState` (pole, sidereal period, phase at the epoch, body spin axis).
    covariance : (3, 3) covariance of (t₁ rad, t₂ rad, P s): the pole's tangent offset (module docstring)
        and the sidereal period; already inflated by the result's χ² scale.
    phase_sigma_rad : 1-σ of φ₀ (nan when the shape absorbs the phase: unknown-shape fits).
    axis_sigma_deg : 1-σ (major axis) of the body spin axis, deg (nan when the axis is body z by definition).
    chi2 : χ² of the fit (not scaled).
    probability : relative probability among the result's modes (they sum to 1).
    weights : (m,) the shape's linear parameters (facet areas m², or a known shape's scale).
    scales : (K,) the factor each curve's model was multiplied by (1 for calibrated curves).
    """

    state: SpinState
    covariance: np.ndarray
    phase_sigma_rad: float
    axis_sigma_deg: float
    chi2: float
    probability: float
    weights: np.ndarray = field(repr=False)
    scales: np.ndarray = field(repr=False)

    @property
    def pole_I(self) -> np.ndarray:
        return self.state.pole_I

    @property
    def period_s(self) -> float:
        return self.state.period_s

    @property
    def period_sigma_s(self) -> float:
        return float(np.sqrt(self.covariance[2, 2]))

    @property
    def pole_covariance_rad2(self) -> np.ndarray:
        """(2, 2) tangent-plane covariance of the pole, rad²."""
        return self.covariance[:2, :2]

    @property
    def pole_sigma_deg(self) -> float:
        """1-σ of the pole along the major axis of its error ellipse, deg."""
        return float(np.degrees(np.sqrt(np.linalg.eigvalsh(self.pole_covariance_rad2)[-1])))

    @property
    def ecliptic_rad(self) -> tuple[float, float]:
        """Pole (λ, β), rad, J2000 ecliptic."""
        return self.state.ecliptic_rad

    @property
    def radec_rad(self) -> tuple[float, float]:
        """Pole (RA, Dec), rad, J2000 equatorial."""
        return self.state.radec_rad

    def mahalanobis2(self, pole_I, period_s: float | None = None) -> float:
        """Squared Mahalanobis distance of a pole (and, if given, a sidereal period) from this mode."""
        d = tangent_offset(self.pole_I, pole_I)
        if period_s is None:
            return float(d @ np.linalg.solve(self.pole_covariance_rad2, d))
        x = np.append(d, period_s - self.period_s)
        return float(x @ np.linalg.solve(self.covariance, x))

    def contains(self, pole_I, period_s: float | None = None, level: float = 0.95) -> bool:
        """Whether a pole (and period) lies in this mode's ``level`` credible region (χ² with 2, or 3 with the period, dof)."""
        k = 2 if period_s is None else 3
        return self.mahalanobis2(pole_I, period_s) <= chi2_dist.ppf(level, k)


@dataclass(frozen=True)
class InversionResult:
    """All modes the data cannot tell apart, best first, and the search's map.

    solutions : tuple of :class:`SpinSolution`, by decreasing probability.
    dof : degrees of freedom of the best fit (samples − linear − nonlinear parameters).
    chi2_scale : s = max(1, max(1, κ) χ²_min/dof, φ), the factor applied to χ² and covariances (module docstring, eq. 1).
    model : the shape model fitted.
    epoch : epoch of every solution's phase.
    pole_grid_I : (n, 3) the searched poles.
    chi2_map : (n,) the grid's best (screening) χ² over periods at each pole, for plotting.
    period_map_s : (n,) the period of that best χ².
    correlation_time : κ of the best fit's residuals (eq. 3): samples per independent residual (1 for white residuals).
    night_dispersion : φ of the best fit (eq. 4): how much more the nights disagree than white residuals allow (NaN: one night).
    """

    solutions: tuple
    dof: int
    chi2_scale: float
    model: object = field(repr=False)
    epoch: Time = None
    pole_grid_I: np.ndarray = field(default=None, repr=False)
    chi2_map: np.ndarray = field(default=None, repr=False)
    period_map_s: np.ndarray = field(default=None, repr=False)
    correlation_time: float = 1.0
    night_dispersion: float = float("nan")

    @property
    def best(self) -> SpinSolution:
        return self.solutions[0]

    def profile_level(self, chi2_at_pole: float) -> float:
        """The smallest level of the profile-likelihood region that holds a pole whose profile χ² is ``chi2_at_pole``
        (:func:`lightcurves.inversion.profile.pole_profile_chi2`): F_χ²₂((χ²(p) − χ²_min)/s), Wilks' law for the pole's
        two degrees of freedom with the χ² differences scaled by s as the modes' (eq. 1). The region of level α holds the
        poles with a level ≤ α: it follows a ridge of the likelihood that the modes' Gaussians cut short. NaN when the
        pole's χ² is below the best mode's by more than 1: the search missed an optimum, and no region of this result
        describes that pole."""
        chi2_min = min(s.chi2 for s in self.solutions)
        if not np.isfinite(chi2_at_pole) or chi2_at_pole < chi2_min - 1.0:
            return float("nan")
        return float(chi2_dist.cdf(max(chi2_at_pole - chi2_min, 0.0) / self.chi2_scale, 2))


def integrated_autocorrelation_time(r, c: float = SOKAL_WINDOW_C) -> float:
    """Integrated autocorrelation time τ (samples) of one residual series ``r`` (n,), Sokal's windowed estimator (eq. 2).

    The autocovariance is not centred (module docstring); τ lies in [1/n, n]: n for a constant series.
    """
    r = np.asarray(r, dtype=float).reshape(-1)
    n = r.size
    if n < 2 or not np.isfinite(r).all():
        raise ValueError(f"r: {n} values{'' if np.isfinite(r).all() else ' with non-finite ones'}: expected at least 2 finite residuals")
    if not (np.isfinite(c) and c > 0):
        raise ValueError(f"c: {c!r}: expected a positive window constant")
    gamma = correlate(r, r, mode="full", method="fft")[n - 1:] / n  # γ̂(ℓ), ℓ = 0 … n − 1 (FFT: O(n log n))
    if gamma[0] <= 0.0:
        return 1.0  # all residuals zero: nothing to correlate, no inflation
    tau = 1.0 + 2.0 * np.cumsum(gamma[1:] / gamma[0])  # τ(M), M = 1 … n − 1
    ok = np.flatnonzero(np.arange(1, n) >= c * tau)
    t = tau[ok[0]] if ok.size else tau[-1]
    return float(np.clip(t, 1.0 / n, n))


def residual_correlation_time(residuals, groups) -> float:
    """κ (eq. 3): the integrated autocorrelation time of whitened residuals (N,) pooled over their curves.

    groups : (N,) the curve (night) of each residual; each curve's residuals in time order. A curve's τ is
        weighted by its residuals' sum of squares, so κ is the ratio of the summed long-run variances to the summed variances.
    """
    r = np.asarray(residuals, dtype=float).reshape(-1)
    g = np.asarray(groups).reshape(-1)
    if g.shape != r.shape:
        raise ValueError(f"groups: {g.size} values: expected {r.size}, one per residual")
    num = den = 0.0
    for k in np.unique(g):
        rk = r[g == k]
        ss = float(rk @ rk)
        num += (integrated_autocorrelation_time(rk) if rk.size > 1 else 1.0) * ss  # a lone sample has no lag: τ = 1
        den += ss
    return num / den if den > 0 else 1.0


def night_score_dispersion(jacobian, residuals, groups, rtol: float = 1e-10) -> tuple[float, int]:
    """φ (eq. 4) and its degrees of freedom Σ_k rank G_k − p from the whitened residuals (N,), their Jacobian (N, p) and curves (N,).

    rank G_k counts the eigenvalues above ``rtol`` times the largest of H = JᵀJ (a night alone may not see every
    parameter). Returns (NaN, dof) when dof < 1 (one night, or nights that together see no more than the whole fit).
    """
    J = np.asarray(jacobian, dtype=float)
    r = np.asarray(residuals, dtype=float).reshape(-1)
    g = np.asarray(groups).reshape(-1)
    if J.ndim != 2 or J.shape[0] != r.size or g.shape != r.shape:
        raise ValueError(f"jacobian: shape {J.shape} with {r.size} residuals and {g.size} groups: expected (N, p), N residuals and N groups")
    if not (np.isfinite(J).all() and np.isfinite(r).all()):
        raise ValueError("jacobian, residuals: non-finite values: expected finite whitened residuals and their derivatives")
    floor = rtol * max(float(np.linalg.eigvalsh(J.T @ J)[-1]), np.finfo(float).tiny)
    q, dof = 0.0, -J.shape[1]
    for k in np.unique(g):
        i = g == k
        w, V = np.linalg.eigh(J[i].T @ J[i])
        keep = w > floor
        q += float(np.sum((V[:, keep].T @ (J[i].T @ r[i])) ** 2 / w[keep]))
        dof += int(keep.sum())
    return (q / dof if dof >= 1 else float("nan")), dof


def posterior_scale(residuals, groups, dof: int, jacobian=None) -> tuple[float, float, float]:
    """(s, κ, φ) of eqs. (1), (3), (4) from the best fit's whitened residuals (N,), their curves (N,), the fit's degrees of freedom and,
    if given, its Jacobian (N, p) (without it, or with one night, φ is NaN and s = max(1, max(1, κ) χ²/dof))."""
    if int(dof) < 1:
        raise ValueError(f"dof: {dof!r}: expected a positive number of degrees of freedom")
    r = np.asarray(residuals, dtype=float).reshape(-1)
    kappa = residual_correlation_time(r, groups)
    phi = float("nan") if jacobian is None else night_score_dispersion(jacobian, r, groups)[0]
    return max(1.0, max(1.0, kappa) * float(r @ r) / int(dof), 0.0 if np.isnan(phi) else phi), kappa, phi


def laplace_probabilities(chi2, logdet_cov, scale: float) -> np.ndarray:
    """Relative probabilities (n,) from χ² (n,) and log det Σ (n,) of each mode, χ² divided by ``scale`` (module docstring)."""
    log_z = -0.5 * np.asarray(chi2, dtype=float) / scale + 0.5 * np.asarray(logdet_cov, dtype=float)
    w = np.exp(log_z - log_z.max())
    return w / w.sum()


def distinct_modes(poles_I, periods_s, chi2, covariances, *, n_sigma: float = 3.0, min_separation_rad: float = np.radians(2.0)) -> list[int]:
    """Indices of distinct modes, best χ² first: a mode is dropped when a better one is within ``n_sigma`` (or
    ``min_separation_rad``) in pole and within ``n_sigma`` σ in period — the same optimum reached twice.
    Mirror poles, far apart, stay separate."""
    order = np.argsort(chi2)
    kept: list[int] = []
    for i in order:
        same = False
        for j in kept:
            d = tangent_offset(poles_I[j], poles_I[i])
            sig = np.sqrt(max(np.linalg.eigvalsh(covariances[j][:2, :2])[-1], np.linalg.eigvalsh(covariances[i][:2, :2])[-1]))
            sig_p = np.sqrt(max(covariances[j][2, 2], covariances[i][2, 2]))
            if np.linalg.norm(d) <= max(n_sigma * sig, min_separation_rad) and abs(periods_s[i] - periods_s[j]) <= n_sigma * sig_p:
                same = True
                break
        if not same:
            kept.append(int(i))
    return kept
