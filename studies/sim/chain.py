"""Light curve → spin prior → filters: the pieces ``lcnav demo`` and the ``chain`` study share.

The chain of Renis et al. §5–6 end to end:

1. :func:`render_prior` renders several nights of light curves of a rocket body spinning like a
   scenario's target at ``t = 0`` (its initial rate ``ω_T0``, a drawn pole and phase;
   :func:`studies.sim.lightcurve_prior.observe_nights`, the code path of ``lcnav lightcurve render``)
   and builds the spin prior from those light curves and the target's model ONLY
   (:func:`studies.sim.lightcurve_prior.build_prior`: the single-night period bounds a known-shape
   light-curve inversion, whose modes become ``ω_T`` with a full covariance);
2. the truth that rendered the curves scores the prior afterwards (:meth:`RenderedPrior.score`), never
   builds it (``tests/studies/test_no_oracle.py``);
3. :func:`navigate_arm` runs one filter in one *arm* — ``none`` (the general
   tuning, ``ω̂_0 = 0``), ``tuning`` (the scenario-specific tuning the prior
   points to, :func:`estimators.prior.tuning_for_prior`), ``init`` (that
   tuning plus the prior as initial condition, §6.2) or ``proxy`` (that
   tuning, the initial condition and the prior pushed as an ``ω`` measurement
   at every step, §6.3) — through the code path of ``lcnav run``
   (:mod:`studies.cli.run`);
4. :func:`flat_metrics` flattens the metrics of §6 (:func:`studies.sim.metrics.evaluate`)
   into a row; :func:`record_lightcurve` and :func:`record_run` write the
   recordings. The figures are drawn by :mod:`studies.catalog.figures`.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from estimators.prior import BodyRatePrior, tuning_for_prior
from estimators.tuning import get_tuning
from lightcurves.simulate import SimulatedLightCurve
from studies.sim.metrics import GROUPS, evaluate, state_errors
from studies.sim.lightcurve_prior import BuiltPrior, ObservedNights, build_prior, observe_nights, score_prior
from studies.sim.scenarios import Scenario
from studies.sim.truth import Truth

ARMS = ("none", "tuning", "init", "proxy")
#: How each arm uses the prior, for tables and plots.
ARM_LABELS = {"none": "no prior", "tuning": "prior: tuning", "init": "prior: tuning + init", "proxy": "prior: tuning + init + proxy"}
#: Tuning without a prior: the general filter of the tuning study (best on SC4).
GENERAL_TUNING = "general-conservative"


@dataclass(frozen=True)
class RenderedPrior:
    """Rendered nights of light curves, the prior built from them, and the truth behind them (scoring only)."""

    observed: ObservedNights
    built: BuiltPrior

    @property
    def simulated(self) -> SimulatedLightCurve:
        """The longest night's render (figures and recordings)."""
        return max(self.observed.simulated, key=lambda sim: len(sim.lightcurve))

    @property
    def extracted(self):
        """The longest night's rate prior (:class:`lightcurves.prior.SpinPrior`), one of those that bounded the inversion's period search."""
        return self.built.rate_prior

    @property
    def spin(self) -> BodyRatePrior | None:
        """The filters' prior (None when the light curves gave no significant period)."""
        return self.built.spin

    @property
    def truth_rate_rad_s(self) -> float:
        """The rate the light curves were rendered with (scoring only)."""
        return self.observed.truth.rate_rad_s

    @property
    def axis_T(self) -> np.ndarray:
        """The body axis the light curves were rendered about (scoring and captions only)."""
        return self.observed.truth.axis_T

    @property
    def rate_error(self) -> float:
        """Relative error of the prior's sidereal rate (the best inversion mode), ``rate/truth − 1`` (NaN without a prior)."""
        ip = self.built.inversion_prior
        return float("nan") if ip is None else float(ip.rate_rad_s / self.truth_rate_rad_s - 1.0)

    @property
    def mapping(self) -> str:
        """One sentence: how the light curves became an ω vector, and what they leave open."""
        return self.built.description

    def score(self) -> dict:
        """The prior against the truth (:func:`studies.sim.lightcurve_prior.score_prior`)."""
        return score_prior(self.built, self.observed.truth)


def render_prior(
    scenario: Scenario,
    rng: np.random.Generator,
    *,
    target: str = "atlas-centaur",
    nights: int = 3,
    night_spacing_days: float = 2.0,
    duration_s: float = 600.0,
    cadence_s: float = 1.0,
    resolution_px: int = 64,
    spp: int = 4,
    progress=None,
) -> RenderedPrior:
    """Render ``nights`` light curves of ``target`` spinning like ``scenario``'s target and build the prior from them.

    The pole, phase, noise and sampling are drawn from ``rng`` (:func:`~studies.sim.lightcurve_prior.observe_nights`);
    the prior sees the light curves and the target's name only (:func:`~studies.sim.lightcurve_prior.build_prior`).
    ``progress(n_done, n_total)`` counts rendered nights.
    """
    observed = observe_nights(scenario, rng, target=target, nights=nights, night_spacing_days=night_spacing_days, duration_s=duration_s,
                              cadence_s=cadence_s, resolution_px=resolution_px, spp=spp, progress=progress)
    built = build_prior(observed.lightcurves, target, rng=np.random.default_rng(rng.integers(2**63)))
    return RenderedPrior(observed, built)


def inversion_summary(result) -> dict:
    """The inversion's modes as JSON-ready numbers (best first): probability, pole (ecliptic, equatorial, σ), period, axis; and the
    posterior's scale with its two parts, κ and φ (:mod:`lightcurves.inversion.posterior`, eqs. 1–4; φ None with one night)."""
    rows = []
    for s in result.solutions:
        lam, beta = np.degrees(s.ecliptic_rad)
        ra, dec = np.degrees(s.radec_rad)
        rows.append({"probability": float(s.probability), "pole_ecliptic_lon_deg": float(lam), "pole_ecliptic_lat_deg": float(beta),
                     "pole_ra_deg": float(ra), "pole_dec_deg": float(dec), "pole_sigma_deg": float(s.pole_sigma_deg),
                     "sidereal_period_s": float(s.period_s), "sidereal_period_sigma_s": float(s.period_sigma_s),
                     "body_spin_axis_T": np.asarray(s.state.axis_T).tolist(), "chi2": float(s.chi2)})
    phi = float(result.night_dispersion)
    return {"solutions": rows, "dof": int(result.dof), "chi2_scale": float(result.chi2_scale),
            "residual_correlation_time": float(result.correlation_time), "night_dispersion": None if np.isnan(phi) else phi}


def arm_tuning(arm: str, spin: BodyRatePrior | None) -> str:
    """The tuning name an arm uses: ``general-conservative`` without a prior, else the one the prior points to.

    ``spin`` is the prior the tuning is chosen from: for an inversion, its best mode's ``rate · axis``
    (:attr:`studies.sim.lightcurve_prior.BuiltPrior.tuning_spin`), not the moment-matched mean.
    """
    if arm not in ARMS:
        raise ValueError(f"arm must be one of {ARMS}, got {arm!r}")
    if arm == "none":
        return GENERAL_TUNING
    if spin is None:
        raise ValueError(f"arm {arm!r} needs a spin prior; the light curves gave no significant period")
    return tuning_for_prior(spin)


def navigate_arm(truth: Truth, filter_name: str, arm: str, spin: BodyRatePrior | None, measurement_seed: int, *,
                 tuning_spin: BodyRatePrior | None = None, faults=(), gate_confidence: float = 0.99, gate_start_s: float = 10.0):
    """One filter run in one arm: ``(NavigationRun, measurements, tuning name)``.

    The measurements and the initial inertia guess are drawn from
    ``default_rng(measurement_seed)``, so every arm and filter given the same
    seed sees the same data (paired comparisons). One-axis scenarios
    consider ``k1, k2`` instead of estimating them (as ``lcnav run``).
    """
    from estimators.measurement import PoseNoise
    from studies.sim.navigation import NavigationSetup, considered_states, navigate

    tuning_name = arm_tuning(arm, tuning_spin if tuning_spin is not None else spin)
    consider = considered_states(truth.scenario, truth.physics)
    use = {"none": "none", "tuning": "none", "init": "init", "proxy": "proxy"}[arm]
    setup = NavigationSetup(filter_name, get_tuning(tuning_name), prior=spin, prior_use=use, proxy_mode="always", faults=faults,
                            pose_noise=PoseNoise(model="isotropic"), gate_confidence=gate_confidence, gate_start_s=gate_start_s, consider=consider)
    run, meas = navigate(truth, setup, np.random.default_rng(measurement_seed))
    return run, meas, tuning_name


def flat_metrics(truth: Truth, run, prefix: str, *, rmse_from_s: float | None = None) -> dict:
    """``{prefix}_{group}_conv_s`` / ``_rmse`` (state based) and ``_filter_conv_s`` / ``_filter_rmse`` (filter based).

    With ``rmse_from_s``, also ``{prefix}_{group}_rmse_after``: the RMSE of the
    state error from that time on (the post-fault window of Renis et al. Table 6).
    """
    m = evaluate(truth.t, run.x, run.P, truth.x)
    out = {}
    for g in GROUPS:
        out[f"{prefix}_{g}_conv_s"] = m["state"][g].convergence_time_s
        out[f"{prefix}_{g}_rmse"] = m["state"][g].steady_state_rmse
        out[f"{prefix}_{g}_filter_conv_s"] = m["filter"][g].convergence_time_s
        out[f"{prefix}_{g}_filter_rmse"] = m["filter"][g].steady_state_rmse
    if rmse_from_s is not None:
        sel = (truth.t - truth.t[0]) >= rmse_from_s
        for g, e in state_errors(run.x, truth.x).items():
            out[f"{prefix}_{g}_rmse_after"] = float(np.sqrt(np.mean(e[sel] ** 2))) if sel.any() else float("nan")
    return out


# ---------------------------------------------------------------- recordings


def record_lightcurve(path: Path, rendered: RenderedPrior, recording_id: str) -> None:
    """``/lightcurve/...`` and ``/spectrum/...`` of ``lcnav lightcurve render --record`` at ``path``."""
    from lightcurves.render import flux_to_mag
    from studies.recording.lightcurve import write_lightcurve_recording

    write_lightcurve_recording(path, rendered.simulated.lightcurve, rendered.extracted, mag_true=flux_to_mag(rendered.simulated.flux_true_w_m2),
            recording_id=recording_id)


def record_run(path: Path, truth: Truth, run, meas, seed: int, name: str) -> None:
    """The ``lcnav run`` recording of one filter run, its estimates under ``/estimate/<name>/...``.

    ``name`` (e.g. ``ekf_prior``) tells apart runs of one filter in different
    arms, in the entity paths and in the recording id.
    """
    from studies.recording.navigation import record_navigation

    record_navigation(path, truth, dataclasses.replace(run, filter=name), meas, recording_id=f"{name}-seed{seed}")
