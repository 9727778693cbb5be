"""Light curve → spin prior → filters: the pieces ``lcnav demo`` and the ``chain`` study share.

The chain of Renis et al. §5–6 end to end:

1. :func:`render_prior` renders a light curve of a rocket body tumbling like
   a scenario's target (its initial rate ``ω_T0`` about the same body axis,
   :func:`lightcurves.simulate.simulate_lightcurve`, the code path of
   ``lcnav lightcurve render``) and extracts the spin prior
   (:func:`lightcurves.extract_spin_prior`, Renis et al. §2.3);
2. the light curve gives a *rate* and its 1-σ, not an axis: the prior vector
   is ``ω_prior = rate · â`` with 1-σ ``σ_rate`` on every axis
   (:meth:`lightcurves.prior.SpinPrior.body_rate_prior`), where ``â`` is an **assumed**
   spin axis in the target frame — here the scenario's true initial spin axis
   ``ω_T0/|ω_T0|`` (for a two-axis tumble such as SC3 this is the assumption
   that the axis is known from elsewhere, e.g. resolved imaging; the light
   curve itself cannot tell it, nor the sense of rotation);
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
from studies.sim.scenarios import Scenario
from studies.sim.truth import Truth

ARMS = ("none", "tuning", "init", "proxy")
#: How each arm uses the prior, for tables and plots.
ARM_LABELS = {"none": "no prior", "tuning": "prior: tuning", "init": "prior: tuning + init", "proxy": "prior: tuning + init + proxy"}
#: Tuning without a prior: the general filter of the tuning study (best on SC4).
GENERAL_TUNING = "general-conservative"


@dataclass(frozen=True)
class RenderedPrior:
    """A rendered light curve, the spin prior extracted from it, and that prior as an ω vector."""

    simulated: SimulatedLightCurve
    extracted: object  #: :class:`lightcurves.prior.SpinPrior` (rate, 1-σ, spectrum, candidates)
    truth_rate_rad_s: float  #: the rate the light curve was rendered with
    axis_T: np.ndarray  #: the assumed spin axis (unit, target frame)
    spin: BodyRatePrior | None  #: the filters' prior; None when the light curve gave no significant period

    @property
    def rate_error(self) -> float:
        """Relative error of the extracted rate, ``rate/truth − 1`` (NaN without a period)."""
        r = self.extracted.rate_rad_s
        return float("nan") if r is None else float(r / self.truth_rate_rad_s - 1.0)

    @property
    def mapping(self) -> str:
        """One sentence: how the rate became an ω vector, and what was assumed."""
        a = ", ".join(f"{v:+.3f}" for v in self.axis_T)
        return (f"prior ω_T = rate × â with â = ({a}) in the target frame T, 1-σ = σ_rate on each axis "
                f"(lightcurves.SpinPrior.body_rate_prior). The light curve gives the rate only: the axis â (and the sense of "
                f"rotation) is an ASSUMPTION — here the scenario's true initial spin axis ω_T0/|ω_T0|.")


def spin_axis(scenario: Scenario) -> tuple[np.ndarray, float]:
    """The scenario's initial spin axis ``ω_T0/|ω_T0|`` (target frame) and rate ``|ω_T0|`` (rad/s)."""
    w = np.asarray(scenario.w_T0_T_rad_s, dtype=float)
    rate = float(np.linalg.norm(w))
    if rate == 0.0:
        raise ValueError(f"scenario {scenario.name} has no spin: a light curve cannot give it a rate prior")
    return w / rate, rate


def render_prior(
    scenario: Scenario,
    rng: np.random.Generator,
    *,
    target: str = "atlas-centaur",
    duration_s: float = 600.0,
    cadence_s: float = 1.0,
    resolution_px: int = 64,
    spp: int = 4,
    false_alarm_level: float = 0.01,
    progress=None,
) -> RenderedPrior:
    """Render a light curve of ``target`` spinning like ``scenario``'s target at ``t = 0`` and extract its prior.

    The noise, sampling and rotation phase are drawn from ``rng``. ``progress``
    is passed to :func:`~lightcurves.simulate.simulate_lightcurve`.
    """
    from lightcurves import extract_spin_prior
    from lightcurves.render import UnresolvedRenderer
    from lightcurves.simulate import simulate_lightcurve
    from lightcurves.targets import get_target

    axis_T, rate = spin_axis(scenario)
    tgt = get_target(target)
    renderer = UnresolvedRenderer(tgt, resolution=resolution_px, spp=spp)
    sim = simulate_lightcurve(tgt, axis_T=axis_T, rate_rad_s=rate, duration_s=duration_s, cadence_s=cadence_s, rng=rng,
                              renderer=renderer, meta={"scenario": scenario.name, "resolution": resolution_px, "spp": spp},
                              progress=progress)
    lc = sim.lightcurve
    # the Sun and observer directions give the 1-σ its synodic term (the apparent rate's offset from the sidereal one)
    extracted = extract_spin_prior(lc.t_s, lc.mag, lc.mag_err if np.all(np.isfinite(lc.mag_err)) else None,
                                   false_alarm_level=false_alarm_level, sun_dir=sim.observation.sun_dir_I,
                                   observer_dir=sim.observation.observer_dir_I)
    spin = None
    if extracted.significant:
        spin = extracted.body_rate_prior(axis_T, source=f"light curve of {target}")
    return RenderedPrior(sim, extracted, rate, axis_T, spin)


def arm_tuning(arm: str, spin: BodyRatePrior | None) -> str:
    """The tuning name an arm uses: ``general-conservative`` without a prior, else the one the prior points to."""
    if arm not in ARMS:
        raise ValueError(f"arm must be one of {ARMS}, got {arm!r}")
    if arm == "none":
        return GENERAL_TUNING
    if spin is None:
        raise ValueError(f"arm {arm!r} needs a spin prior; the light curve gave no significant period")
    return tuning_for_prior(spin)


def navigate_arm(truth: Truth, filter_name: str, arm: str, spin: BodyRatePrior | None, measurement_seed: int, *,
                 faults=(), gate_confidence: float = 0.99, gate_start_s: float = 10.0):
    """One filter run in one arm: ``(NavigationRun, measurements, tuning name)``.

    The measurements and the initial inertia guess are drawn from
    ``default_rng(measurement_seed)``, so every arm and filter given the same
    seed sees the same data (paired comparisons). One-axis scenarios
    consider ``k1, k2`` instead of estimating them (as ``lcnav run``).
    """
    from estimators.measurement import PoseNoise
    from estimators.state import K_STATES
    from studies.sim.navigation import NavigationSetup, navigate, one_axis

    tuning_name = arm_tuning(arm, spin)
    consider = K_STATES if one_axis(truth.scenario.w_T0_T_rad_s) else ()
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
