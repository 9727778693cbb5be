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
ranges) and dropped; ``s`` = max(1, χ²_min/dof) inflates both χ² and Σ when the best fit is worse than
the noise says (an under-fitted shape or under-stated σ), so a poor model does not give overconfident
odds between modes.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from astropy.time import Time
from scipy.stats import chi2 as chi2_dist

from lightcurves.inversion.spin import SpinState, pole_frame

__all__ = ["SpinSolution", "InversionResult", "tangent_offset", "laplace_probabilities", "distinct_modes"]


def tangent_offset(pole_I, other_I) -> np.ndarray:
    """Tangent-plane offset (2,) rad of the unit direction ``other_I`` from ``pole_I``, in the basis (e₁, e₂) of the pole frame (log map)."""
    C_IP = pole_frame(np.asarray(pole_I, dtype=float))
    v = C_IP.T @ (np.asarray(other_I, dtype=float) / np.linalg.norm(other_I))
    angle = np.arctan2(np.hypot(v[0], v[1]), v[2])
    rho = np.hypot(v[0], v[1])
    return np.zeros(2) if rho == 0 else angle * v[:2] / rho


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
    chi2_scale : s = max(1, χ²_min/dof), the factor applied to χ² and covariances (module docstring).
    model : the shape model fitted.
    epoch : epoch of every solution's phase.
    pole_grid_I : (n, 3) the searched poles.
    chi2_map : (n,) the grid's best (screening) χ² over periods at each pole, for plotting.
    period_map_s : (n,) the period of that best χ².
    """

    solutions: tuple
    dof: int
    chi2_scale: float
    model: object = field(repr=False)
    epoch: Time = None
    pole_grid_I: np.ndarray = field(default=None, repr=False)
    chi2_map: np.ndarray = field(default=None, repr=False)
    period_map_s: np.ndarray = field(default=None, repr=False)

    @property
    def best(self) -> SpinSolution:
        return self.solutions[0]


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
