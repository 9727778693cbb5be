"""The filters' spin prior from a light-curve inversion: ``ω_T`` (mean and covariance), no truth anywhere.

A known-shape inversion (:func:`lightcurves.inversion.search.invert` with a
:class:`~lightcurves.inversion.known_shape.KnownShapeModel`) gives, per mode of its posterior, the body
axis ``a_T`` the target spins about (right-handed about the pole, the angular-momentum direction, so
it carries the sense) and the sidereal period ``P``. The filters of Renis et al. estimate the rate in
the target frame, so the prior is

    ω_T = (2π / P) a_T,        Σ_i = σ_ω² a aᵀ + ω² σ_a² (I − a aᵀ),        σ_ω = 2π σ_P / P²,

with ``σ_a`` the axis' 1-σ (rad; the major axis of its error ellipse, applied to both tangent
directions: conservative). Two things a single Gaussian must still absorb:

* **Symmetry.** For a target whose inertia has two equal moments (an axisymmetric rocket body, a
  cylinder), turning the body about its symmetry axis ``s`` leaves its shape and its light curve
  unchanged, so the azimuth of ``a_T`` about ``s`` is not observable. Each mode is replaced by the
  moments of its ring: ``ω`` along ``s`` is kept, the part ⟂ ``s`` averages to zero with variance
  ``ω² (1 − (a·s)²) / 2`` on each of the two axes ⟂ ``s``.
* **Ambiguity.** Modes the data cannot tell apart (mirror poles, a reversed sense) are combined by
  moment matching of the mixture: ``μ = Σ pᵢ μᵢ``, ``Σ = Σ pᵢ (Σᵢ + (μᵢ − μ)(μᵢ − μ)ᵀ)``. Two modes of
  opposite sense and equal weight give ``μ ≈ 0`` with the rate's spread along the axis: the prior then
  says what the light curves know (the axis line and the rate), not a guessed sense. With sense
  probability p the mean along the axis is shortened to ``(2p − 1) ω`` and its variance grows by
  ``4 p (1 − p) ω²``: at p = 0.95 a σ of 0.44 ω. Below :data:`SENSE_SETTLED` the description says the
  sense is open. The modes' probabilities are only as honest as the posterior's χ² scale
  (:mod:`lightcurves.inversion.posterior`, eq. 1), and a mode the search never reached is not among them.

Everything here reads only the inversion result and the shape's inertia: nothing a user would not
have. The caller scores the prior against a truth afterwards, if it has one.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from estimators.prior import BodyRatePrior

__all__ = ["InversionPrior", "spin_prior_from_inversion", "symmetry_axis", "SENSE_SETTLED"]

#: Relative difference under which two principal moments count as equal (an axisymmetric body).
SYMMETRY_RTOL = 1e-3
#: Sense probability from which a prior's description calls the sense settled.
SENSE_SETTLED = 0.95


def symmetry_axis(J_T_diag, rtol: float = SYMMETRY_RTOL) -> np.ndarray | None:
    """The unit axis of T about which the inertia ``diag(J_T_diag)`` is symmetric, or None.

    Two principal moments within ``rtol`` of each other make the third axis the symmetry axis;
    three equal moments (a sphere) give no single axis either (None: every direction is alike).
    """
    J = np.asarray(J_T_diag, dtype=float).reshape(3)
    if not (np.all(np.isfinite(J)) and np.all(J > 0)):
        raise ValueError(f"J_T_diag: {J.tolist()}: expected three positive principal moments")
    equal = [abs(J[i] - J[j]) <= rtol * max(J[i], J[j]) for i, j in ((1, 2), (0, 2), (0, 1))]
    if sum(equal) != 1:
        return None
    return np.eye(3)[int(np.argmax(equal))]


def _mode_moments(rate: float, rate_sigma: float, a: np.ndarray, axis_sigma_rad: float, s: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
    """Mean and covariance of ``ω_T`` for one mode (module docstring), averaged over the azimuth about ``s`` if given."""
    if s is None:
        aa = np.outer(a, a)
        return rate * a, rate_sigma**2 * aa + rate**2 * axis_sigma_rad**2 * (np.eye(3) - aa)
    c = float(a @ s)
    ss = np.outer(s, s)
    E_aa = c**2 * ss + 0.5 * (1.0 - c**2) * (np.eye(3) - ss)  # E[a aᵀ] over the ring of axes about s
    mean = rate * c * s
    # E[ω ωᵀ] − mean meanᵀ with ω = rate·a, rate and a independent, plus the axis noise about each ring point
    second = (rate**2 + rate_sigma**2) * E_aa + rate**2 * axis_sigma_rad**2 * (np.eye(3) - E_aa)
    return mean, second - np.outer(mean, mean)


@dataclass(frozen=True)
class InversionPrior:
    """A spin prior built from an inversion, with what went into it.

    prior : the filters' :class:`~estimators.prior.BodyRatePrior` (moment-matched mean and full covariance).
    rate_rad_s, rate_sigma_rad_s : the most probable mode's sidereal rate 2π/P and its 1-σ.
    axis_T : that mode's body spin axis (unit, T).
    sense_probability : the total probability of the modes whose axis lies in the same hemisphere as ``axis_T``
        (1: the sense is settled; ~0.5: the light curves cannot tell it).
    symmetry_axis_T : the target's symmetry axis (unit, T) when its azimuth was averaged out, else None.
    n_modes : how many modes were combined.
    """

    prior: BodyRatePrior
    rate_rad_s: float
    rate_sigma_rad_s: float
    axis_T: np.ndarray
    sense_probability: float
    symmetry_axis_T: np.ndarray | None
    n_modes: int

    @property
    def description(self) -> str:
        """One sentence for printouts: where ω_T came from and what it leaves open."""
        a = ", ".join(f"{v:+.3f}" for v in self.axis_T)
        sym = (f"; the target is symmetric about ({', '.join(f'{v:+.0f}' for v in self.symmetry_axis_T)}), so the axis' azimuth about it is "
               "not observable and is averaged out") if self.symmetry_axis_T is not None else ""
        sense = (f"sense probability {self.sense_probability:.2f}" if self.sense_settled else
                 f"sense NOT settled (probability {self.sense_probability:.2f}): the mean is shortened and the covariance spans both senses")
        return (f"prior ω_T from a light-curve inversion ({self.n_modes} mode(s)): rate {np.degrees(self.rate_rad_s):.4f} ± "
                f"{np.degrees(self.rate_sigma_rad_s):.4f} °/s about ({a}) in T, {sense}{sym}")

    @property
    def sense_settled(self) -> bool:
        """Whether the modes of the other sense hold less than 1 − :data:`SENSE_SETTLED` of the probability."""
        return self.sense_probability >= SENSE_SETTLED


def spin_prior_from_inversion(result, J_T_diag, *, source: str = "light-curve inversion", min_probability: float = 1e-3) -> InversionPrior:
    """``ω_T`` prior (mean, full covariance) from a known-shape inversion result (module docstring).

    result : an :class:`~lightcurves.inversion.posterior.InversionResult` of a KNOWN shape (its solutions' ``state.axis_T``
        are axes of the target frame T; an unknown shape's body frame is not the filters' T, so it cannot give ``ω_T``).
    J_T_diag : the target model's principal moments (for its symmetry), in T's axis order.
    min_probability : modes below this relative probability are left out (renormalised).
    """
    sols = [s for s in result.solutions if s.probability >= min_probability]
    if not sols:
        raise ValueError(f"inversion result: no mode with probability >= {min_probability}: expected at least one solution")
    s_T = symmetry_axis(J_T_diag)
    p = np.array([s.probability for s in sols], dtype=float)
    p /= p.sum()
    means, covs = [], []
    for sol in sols:
        P, sP = sol.period_s, sol.period_sigma_s
        rate = 2.0 * np.pi / P
        rate_sigma = 2.0 * np.pi * sP / P**2
        axis_sigma = np.radians(sol.axis_sigma_deg) if np.isfinite(sol.axis_sigma_deg) else 0.0
        m, C = _mode_moments(rate, rate_sigma, np.asarray(sol.state.axis_T, dtype=float), axis_sigma, s_T)
        means.append(m)
        covs.append(C)
    means, covs = np.array(means), np.array(covs)
    mu = p @ means
    dev = means - mu
    cov = np.einsum("k,kij->ij", p, covs) + np.einsum("k,ki,kj->ij", p, dev, dev)
    cov = 0.5 * (cov + cov.T)
    # a floor for directions the modes say nothing about (an axis exactly along s, a zero axis σ): 1e-9 of ω², so
    # P_0 stays positive definite without pretending to knowledge
    best = sols[0]
    rate_best = 2.0 * np.pi / best.period_s
    cov += (1e-9 * rate_best) ** 2 * np.eye(3)
    a_best = np.asarray(best.state.axis_T, dtype=float)
    same = np.array([float(np.asarray(s.state.axis_T) @ a_best) >= 0.0 for s in sols])
    prior = BodyRatePrior(mu, np.sqrt(np.diag(cov)), source=source, covariance_rad2_s2=cov)
    return InversionPrior(prior=prior, rate_rad_s=rate_best, rate_sigma_rad_s=float(2.0 * np.pi * best.period_sigma_s / best.period_s**2),
                          axis_T=a_best, sense_probability=float(p[same].sum()), symmetry_axis_T=s_T, n_modes=len(sols))
