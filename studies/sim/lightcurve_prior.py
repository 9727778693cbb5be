"""Spin priors the way a user gets them: several nights of light curves of a known target, inverted.

Three steps, kept apart so that the truth cannot reach the prior:

1. :func:`observe_nights` — the *simulation* side. It reads the scenario's true spin (rate and body axis at
   ``t = 0``), draws a pole (isotropic) and a rotational phase, and renders one light curve per night
   (:func:`lightcurves.simulate.simulate_lightcurve`, Mitsuba, Cook–Torrance, a ground site, photometric
   noise), the phase carried from night to night by the sidereal rotation. What it hands on is what an
   observer's files hold: :class:`~lightcurves.io.LightCurve` records with the per-sample geometry, their
   metadata stripped of every ``truth_*`` key. The truth it used is returned beside them, for scoring only.
2. :func:`build_prior` — the *user* side. From those light curves and the target's model (its name) only:
   each night's period (:func:`lightcurves.inversion.periods.period_ranges`) bounds the period search; the
   known-shape inversion (:func:`lightcurves.inversion.search.invert`) gives the spin state's modes; and
   :func:`lightcurves.inversion.prior.spin_prior_from_inversion` turns them into the filters' ``ω_T`` prior
   (mean and full covariance; symmetric targets and ambiguous modes handled there).
3. :func:`score_prior` — the truth side again: how far the prior is from the truth, and whether the truth
   lies in its credible region.

``tests/studies/test_no_oracle.py`` fails if :func:`build_prior` (or anything it calls) reads a truth key.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import astropy.units as u
import numpy as np

from estimators.prior import BodyRatePrior
from studies.sim.scenarios import Scenario

__all__ = ["candidate_axes", "spin_axis", "SpinTruth", "ObservedNights", "BuiltPrior", "observe_nights", "build_prior", "score_prior", "OBSERVER_META"]

#: The metadata an observer's light-curve file keeps: provenance and geometry, never the truth.
OBSERVER_META = ("target", "site", "orbit", "epoch", "arc_start_s", "cadence_s", "duration_s", "noise", "renderer", "night")


@dataclass(frozen=True)
class SpinTruth:
    """The spin the light curves were rendered with (for scoring only)."""

    pole_I: np.ndarray  #: unit angular-momentum direction in I
    axis_T: np.ndarray  #: unit body spin axis in T
    rate_rad_s: float  #: sidereal rate

    @property
    def w_T_rad_s(self) -> np.ndarray:
        return self.rate_rad_s * self.axis_T


@dataclass(frozen=True)
class ObservedNights:
    """Light curves as an observer has them, the renders behind them, and the truth (scoring only)."""

    lightcurves: tuple  #: of :class:`~lightcurves.io.LightCurve`, geometry per sample, no truth in their metadata
    simulated: tuple  #: of :class:`~lightcurves.simulate.SimulatedLightCurve` (recordings and figures only)
    truth: SpinTruth
    target: str


@dataclass(frozen=True)
class BuiltPrior:
    """What :func:`build_prior` made: the single-night rate prior, the inversion and the filters' prior.

    ``spin`` is the filters' :class:`~estimators.prior.BodyRatePrior` (None when the light curves gave no
    significant period); ``tuning_spin`` is the best mode's ``rate · axis`` for choosing a tuning (a mean that
    averages opposite senses to ~0 cannot say "slow/fast, one/two axes").
    """

    rate_prior: object  #: :class:`lightcurves.prior.SpinPrior` of the longest night (figures, recordings)
    period_range_s: tuple[float, float] | None  #: the sidereal-period range (s) of the inversion's best mode
    inversion: object | None  #: :class:`lightcurves.inversion.posterior.InversionResult`
    inversion_prior: object | None  #: :class:`lightcurves.inversion.prior.InversionPrior`
    spin: BodyRatePrior | None
    tuning_spin: BodyRatePrior | None
    reason: str  #: why there is no prior, or how it was made

    @property
    def description(self) -> str:
        return self.inversion_prior.description if self.inversion_prior is not None else self.reason


def _isotropic(rng: np.random.Generator) -> np.ndarray:
    v = rng.normal(size=3)
    return v / np.linalg.norm(v)


def spin_axis(scenario: Scenario) -> tuple[np.ndarray, float]:
    """The scenario's initial spin axis ``ω_T0/|ω_T0|`` (target frame) and rate ``|ω_T0|`` (rad/s)."""
    w = np.asarray(scenario.w_T0_T_rad_s, dtype=float)
    rate = float(np.linalg.norm(w))
    if rate == 0.0:
        raise ValueError(f"scenario {scenario.name} has no spin: a light curve cannot give it a rate prior")
    return w / rate, rate


def observe_nights(scenario: Scenario, rng: np.random.Generator, *, target: str = "atlas-centaur", nights: int = 3,
                   night_spacing_days: float = 2.0, duration_s: float = 600.0, cadence_s: float = 1.0, resolution_px: int = 64,
                   spp: int = 4, progress=None) -> ObservedNights:
    """Render ``nights`` light curves of ``target`` spinning like ``scenario``'s target at ``t = 0`` (module docstring).

    Night ``k`` starts at the first arc visible from the default site after ``DEFAULT_EPOCH + k · night_spacing_days``;
    the pole is drawn isotropically and the phase uniformly from ``rng``. ``progress(n_done, n_total)`` counts nights.
    """
    from lightcurves.render import UnresolvedRenderer
    from lightcurves.simulate import DEFAULT_EPOCH, simulate_lightcurve
    from lightcurves.targets import get_target

    if int(nights) < 1:
        raise ValueError(f"nights: {nights}: expected at least 1")
    axis_T, rate = spin_axis(scenario)
    tgt = get_target(target)
    renderer = UnresolvedRenderer(tgt, resolution=resolution_px, spp=spp)
    pole_I = _isotropic(rng)
    phase0 = float(rng.uniform(0.0, 2.0 * np.pi))
    sims, lcs = [], []
    for k in range(int(nights)):
        epoch = DEFAULT_EPOCH + k * night_spacing_days * u.day
        # one steady spin through every night: the phase is the one at DEFAULT_EPOCH, carried by ω Δt to each arc
        sim = simulate_lightcurve(tgt, axis_T=axis_T, rate_rad_s=rate, duration_s=duration_s, cadence_s=cadence_s, rng=rng, epoch=epoch,
                                  pole_I=pole_I, phase_rad=phase0, phase_epoch=DEFAULT_EPOCH, renderer=renderer, meta={"night": k})
        lc = sim.lightcurve
        sims.append(sim)
        lcs.append(dataclasses.replace(lc, meta={key: lc.meta[key] for key in OBSERVER_META if key in lc.meta}))
        if progress is not None:
            progress(k + 1, int(nights))
    return ObservedNights(tuple(lcs), tuple(sims), SpinTruth(pole_I, axis_T, rate), target)


#: Most facets of the model the inversion searches with (a coarser copy of a finer target).
SEARCH_FACETS = 128


def candidate_axes(J_T_diag) -> np.ndarray:
    """Body spin axes the known-shape search starts from: the principal axes ±x, ±y, ±z; for a target symmetric about ``s``,
    ``±s`` and one axis ⟂ ``s`` (the others ⟂ ``s`` give the same light curves: turning the body about ``s`` leaves it alike)."""
    from lightcurves.inversion.prior import symmetry_axis

    s = symmetry_axis(J_T_diag)
    if s is None:
        return np.vstack([np.eye(3), -np.eye(3)])
    return np.vstack([s, -s, np.roll(s, 1)])


def build_prior(lightcurves, target: str, *, rng: np.random.Generator, progress=None) -> BuiltPrior:
    """The filters' ``ω_T`` prior from ``lightcurves`` of ``target`` (its model known), and nothing else (module docstring).

    Every night's period is found on its own, and the period ranges about them
    (:func:`lightcurves.inversion.periods.period_ranges`: P, and 2P where one maximum per cycle) are searched by one
    inversion, which weighs their modes together (:func:`lightcurves.inversion.search.invert`); ``period_range_s`` is
    the range of the best mode.
    """
    from lightcurves.inversion.io import from_lightcurve
    from lightcurves.inversion.periods import PeriodRangeError, curve_periods, period_ranges
    from lightcurves.inversion.known_shape import KnownShapeModel
    from lightcurves.inversion.prior import spin_prior_from_inversion
    from lightcurves.inversion.search import invert
    from lightcurves.targets import get_target

    if not lightcurves:
        raise ValueError("lightcurves: none given: expected at least one night")
    curves = [from_lightcurve(lc, calibrated=True, name=f"night {k}") for k, lc in enumerate(lightcurves)]
    rate_priors = curve_periods(curves)
    longest = rate_priors[int(np.argmax([np.ptp(c.t_s) for c in curves]))]
    try:
        ranges = [(r.lo_s, r.hi_s) for r in period_ranges(curves, rate_priors)]
    except PeriodRangeError as e:
        return BuiltPrior(longest, None, None, None, None, None, f"no usable period in any night ({e}): no prior")
    tgt = get_target(target)
    model = KnownShapeModel.from_target(tgt)
    if model.n_facets > SEARCH_FACETS:  # the search evaluates the model ~10⁵ times: a coarse model within ~1 % (bench_inversion_forward)
        model = model.coarse(SEARCH_FACETS)
    result = invert(curves, model, ranges, rng=rng, progress=progress, axes_T=candidate_axes(tgt.J_diag), n_candidates=4, n_periods_per_pole=2)
    period_range = min(ranges, key=lambda r: abs(np.log(result.best.period_s / np.sqrt(r[0] * r[1]))))  # the range of the best mode
    ip = spin_prior_from_inversion(result, tgt.J_diag, source=f"inversion of {len(curves)} night(s) of {target}")
    tuning_spin = BodyRatePrior.from_rate(ip.rate_rad_s, ip.rate_sigma_rad_s, ip.axis_T, source="best inversion mode")
    return BuiltPrior(longest, period_range, result, ip, ip.prior, tuning_spin, ip.description)


def score_prior(built: BuiltPrior, truth: SpinTruth) -> dict:
    """How the prior compares with the truth: ω error, its Mahalanobis distance (χ²₃ if calibrated), axis, sense, pole, period."""
    nan = float("nan")
    out = {"prior_available": built.spin is not None}
    if built.spin is None:
        return out | {k: nan for k in ("prior_w_err_rad_s", "prior_w_mahalanobis2", "prior_axis_err_deg", "prior_pole_err_deg", "prior_period_err_pct",
                                       "prior_sense_probability")} | {"prior_sense_right": False, "prior_n_modes": 0}
    w_true = truth.w_T_rad_s
    d = built.spin.w_T_T_rad_s - w_true
    best = built.inversion.best
    cos = lambda a, b: float(np.clip(np.dot(a, b) / (np.linalg.norm(a) * np.linalg.norm(b)), -1.0, 1.0))  # noqa: E731
    ip = built.inversion_prior
    return out | {
        "prior_w_err_rad_s": float(np.linalg.norm(d)),
        "prior_w_mahalanobis2": float(d @ np.linalg.solve(built.spin.covariance, d)),
        "prior_axis_err_deg": float(np.degrees(np.arccos(cos(ip.axis_T, truth.axis_T)))),
        "prior_pole_err_deg": float(np.degrees(np.arccos(cos(best.pole_I, truth.pole_I)))),
        "prior_period_err_pct": float(100.0 * (best.period_s * truth.rate_rad_s / (2.0 * np.pi) - 1.0)),
        "prior_sense_probability": float(ip.sense_probability),
        "prior_sense_right": bool(cos(best.pole_I, truth.pole_I) > 0.0),
        "prior_n_modes": int(ip.n_modes),
    }
