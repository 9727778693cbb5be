"""The objects of the inversion benchmark (lcnav issue 28, deliverable 2): how they are drawn, simulated, inverted and scored.

:mod:`benchmarks.bench_inversion` runs them and writes the report; this module is what a kept row measured (its Git
object id and that of ``lightcurves/`` are the rows' code fingerprint, :data:`benchmarks.bench_inversion.CODE_PATHS`). Each object is one of the four targets of
:data:`lightcurves.targets.TARGETS` in a steady principal-axis spin, seen from the default ground site
(:data:`lightcurves.geometry.DEFAULT_SITE`) on 1–5 nights:

* pole isotropic on the sphere (so both senses: the pole is the angular-momentum direction), body spin
  axis the major or the minor principal axis with a random sign (rotation about the intermediate axis
  is not steady: a tumble, which the inversion's principal-axis model does not describe), rate
  log-uniform in 1–10 deg/s, phase uniform;
* orbit: circular, a = 26 560 km (GPS region), inclination 55°, ascending node and argument of
  latitude uniform; first night within a year of :data:`lightcurves.simulate.DEFAULT_EPOCH`;
* nights spread over ``MAX_SPAN_DAYS`` days; each night one arc placed uniformly inside that night's
  visibility window (so the Sun–target–observer phase angle differs from night to night), of
  a size's nominal samples per night (:data:`SIZES`) at a cadence of P/40 clipped to 0.5–2 s, with jitter and gaps
  (:func:`lightcurves.photometry.sample_times`), shot noise, read noise, sky and scintillation
  (:func:`lightcurves.photometry.add_noise`), calibrated fluxes (W/m²).

Each night is rendered by :func:`lightcurves.simulate.simulate_lightcurve` — its orbit, visibility,
torque-free attitude (integrated, not assumed), airmass and noise — with, as the renderer, either

* the **facet** model the inversion itself fits (:class:`KnownShapeModel`): this is the "inverse crime"
  (data made by the model that fits them, no model error), so these rows measure the search and the
  posterior's calibration under a correct model, not the accuracy on real data; or
* **Mitsuba** (:class:`lightcurves.render.UnresolvedRenderer`, a path tracer with its own sampling of
  the BRDF and of the pixels, about 2 % rms from the facet model): the model-mismatch case, the honest
  rows. Rendering costs ~12 ms per sample, hence fewer, shorter objects.

The orbit is re-phased for each night (its true anomaly advanced by n·Δt: exact for a circular
Keplerian orbit), since :func:`simulate_lightcurve` reads the orbit's elements at its ``epoch``; the
rotation phase handed to it at each night is the one the steady spin reaches then. The simulation
renders the attitude at its sample times t; the light of such a sample reaches the observer at t + ρ/c,
and that is the time the curve carries (:func:`arrival_times`), as a real observation would: the
inversion models the light time (it turns the body at t_obs − ρ/c), and without this shift the data
were not the model's (ρ/c changes by up to 0.01 s between nights at GPS range: a phase error of
0.1° at 10 deg/s, which raised the χ² at the truth by 21 on a facet-rendered object, an error the
inverse-crime rows must not have).

The inversion is told a sidereal-period range of ± ``PERIOD_HALF_WIDTH`` around the true *synodic*
period (:func:`lightcurves.geometry.bisector_rate` on the first night) with its centre jittered by
± ``PERIOD_JITTER``: what a user knows from one night's periodogram.

Scored per object: pole error of the best mode and of the closest listed mode, period error, sense
(best pole within 90° of the truth), whether the truth lies in the best mode's 68 / 95 % regions (pole:
2-D; pole and period: 3-D) and in the highest-density region of the whole mixture of listed modes
(:func:`mixture_level`), the profile-likelihood level of the true pole
(:meth:`~lightcurves.inversion.posterior.InversionResult.profile_level`) and the level of the mapped region at the true pole
(:meth:`~lightcurves.inversion.profile.PoleProfileRegion.level_at`: what ``--pole-region`` reports), the number of modes,
whether a second pole ≥ ``ALT_POLE_DEG`` from the best is listed, χ²/dof, and the profiled χ² at the true spin state (:func:`true_state`) minus the best
mode's: a negative value beyond the noise means the search missed the global optimum.

Brute force (:func:`brute_force`): on a few objects a dense grid of the same likelihood
(:func:`lightcurves.inversion.search.profiled_chi2`'s χ² with the known shape's scale solved in closed
form) over the whole sphere of poles × sidereal periods × rotation phases × the six principal body axes.
It evaluates the facet model ~10⁷ times per object, so it runs on one night of the cheapest target
(:data:`BRUTE_TARGETS`); the other objects get the cheaper check of the χ² at the truth.

Objects run in one worker process per core, one thread each (:func:`measure`).

Timing: ``Size.n_timing`` extra facet objects of exactly 3 nights × :data:`TIMING_SAMPLES` samples
(the issue's ≤ 10 s case), from their own random stream, timed wall-clock and CPU (all threads of the process) with the
1-min load average at their start, after one untimed inversion of a small object (:func:`warm_up`: numba compiles the
kernels at their first call when its cache is new, as in a fresh clone or worktree, 4 s of the first timing row of
2026-12-01). Times are measured on a shared machine; nothing here is asserted.
"""

from __future__ import annotations

import concurrent.futures
import dataclasses
import functools
import multiprocessing
import os
import time
from dataclasses import dataclass

import astropy.units as u
import numba
import numpy as np
from astropy.time import Time
from scipy import stats

from estimators.attitude import quat_to_dcm
from lightcurves.geometry import DEFAULT_SITE, KeplerOrbit, bisector_rate, find_visible_start, observe
from lightcurves.inversion.io import from_lightcurve
from lightcurves.inversion.convex import fibonacci_sphere
from lightcurves.inversion.known_shape import KnownShapeModel
from lightcurves.inversion.posterior import tangent_exp
from lightcurves.inversion.profile import pole_profile_chi2, pole_profile_region
from lightcurves.inversion.search import invert, period_grid, profiled_chi2
from lightcurves.inversion.spin import C_LIGHT_M_S, SpinState, axis_frame, emission_time_s, pole_frame, unspin
from lightcurves.render import UnresolvedRenderer, observed_flux
from lightcurves.simulate import DEFAULT_EPOCH, simulate_lightcurve
from lightcurves.targets import TARGETS, get_target

REPORT_SEED = 2028


@dataclass(frozen=True)
class Size:
    """How many objects of each kind, and how many samples per night (nominal: gaps and non-detections remove a few %)."""

    n_facet: int  #: facet-rendered objects (known shape)
    n_mitsuba: int  #: Mitsuba-rendered objects (known shape, model mismatch), ``MITSUBA_NIGHTS`` nights each
    n_brute: int  #: objects also searched by the brute-force grid (one night each)
    samples_per_night: int
    mitsuba_samples_per_night: int
    brute_samples: int
    n_timing: int = 0  #: facet objects of 3 nights × TIMING_SAMPLES, timed (the issue's speed case, whatever the size)


SIZES = {
    "full": Size(200, 20, 10, 600, 150, 100, 6),  #: the issue's benchmark
    "reduced": Size(200, 20, 10, 150, 100, 60, 6),  #: the same draws at fewer samples, for a loaded machine (with a budget)
    "smoke": Size(4, 1, 1, 60, 40, 40, 1),  #: a few minutes: does the pipeline run end to end
}
MITSUBA_NIGHTS = 3
BRUTE_TARGETS = ("atlas-centaur",)  #: the cheapest facet model (384 facets, 2 µs per sample): the grid evaluates it ~10⁷ times per object
TIMING_TARGETS = ("atlas-centaur", "box-wing", "vespa")  #: the timing objects cycle over these
TIMING_SEED = 28  #: the timing objects' own stream (drawn and simulated from it: the other kinds' draws do not change with their number)
TIMING_SAMPLES = 600  #: samples per night of the timing objects (3 nights: the issue's ≤ 10 s case)
BRUTE_POLE_STEP_DEG = 8.0  #: spacing of the brute-force pole lattice
BRUTE_PHASE_STEPS = 72  #: rotation phases tabulated per (pole, axis), linearly interpolated (5° steps)
MAX_NIGHTS = 5
MAX_SPAN_DAYS = 4  #: nights fall on distinct days within this many days of the first (the period grid grows with the span)
RATE_DEG_S = (1.0, 10.0)
PERIOD_HALF_WIDTH = 0.02  #: half-width of the period range given to the inversion, relative
PERIOD_JITTER = 0.005  #: its centre is off the true synodic period by up to this, relative
ORBIT_A_M = 26_560e3
ORBIT_I_DEG = 55.0
ALT_POLE_DEG = 20.0  #: a listed mode at least this far from the best one counts as an alternative pole
LEVELS = (0.68, 0.95)
MIXTURE_DRAWS = 4000  #: Monte Carlo draws for the mixture's highest-density level
DCHI2_MISS = 1.0  #: χ² at the truth lower than the best mode's by more than this: the search missed the optimum


class FacetRenderer:
    """The inversion's facet model behind :class:`UnresolvedRenderer`'s interface (``intensity``, ``variant``, ``half_size_m``),
    so :func:`simulate_lightcurve` renders with it (the inverse crime of the module docstring)."""

    variant = "facet"
    half_size_m = float("nan")

    def __init__(self, model: KnownShapeModel):
        self.model = model

    def intensity(self, sun_T, obs_T, seed: int | None = None) -> np.ndarray:
        """Radiant intensity (N,) W/sr for unit directions (N, 3) in T; ``seed`` unused (the facet sum is deterministic)."""
        return self.model.intensity(sun_T, obs_T)


@dataclass(frozen=True)
class Case:
    """The truth and observing plan of one simulated object (module docstring)."""

    target: str
    pole_I: np.ndarray  #: (3,) unit angular-momentum direction in I
    axis_T: np.ndarray  #: (3,) unit body spin axis in T (a principal axis)
    rate_rad_s: float  #: sidereal rate
    phase_rad: float  #: phase handed to the first night's simulation
    orbit: KeplerOrbit  #: elements at ``epoch``
    epoch: Time  #: first night's search start
    night_days: tuple[int, ...]  #: day offsets of the nights from ``epoch``
    cadence_s: float
    samples_per_night: int


def steady_axes(J_diag) -> list[np.ndarray]:
    """Body axes (unit, in T) of steady spin: the major and minor principal axes (all three for a sphere-like inertia)."""
    J = np.asarray(J_diag, dtype=float)
    eye = np.eye(3)
    if np.ptp(J) <= 1e-6 * J.max():
        return [eye[0], eye[1], eye[2]]
    return [eye[int(np.argmax(J))], eye[int(np.argmin(J))]]


def axis_kind(J_diag, axis_T) -> str:
    """"major" or "minor" principal axis of the inertia ``J_diag`` for the body axis ``axis_T`` ("any" for a spherical inertia)."""
    J = np.asarray(J_diag, dtype=float)
    if np.ptp(J) <= 1e-6 * J.max():
        return "any"
    return "major" if J[int(np.argmax(np.abs(axis_T)))] >= J.max() * (1 - 1e-6) else "minor"


def draw_case(rng: np.random.Generator, target: str, n_nights: int, samples_per_night: int, max_tries: int = 20) -> Case:
    """One object (module docstring for the distributions); orbit and first epoch redrawn (up to ``max_tries``) until every night
    has a visibility window at the default site (a GPS-like orbit can stay in daylight for weeks)."""
    pole = rng.normal(size=3)
    axes = steady_axes(get_target(target).J_diag)
    axis = axes[int(rng.integers(len(axes)))] * rng.choice([-1.0, 1.0])
    rate = np.radians(np.exp(rng.uniform(*np.log(RATE_DEG_S))))
    days = np.sort(rng.choice(np.arange(1, MAX_SPAN_DAYS + 1), size=n_nights - 1, replace=False)) if n_nights > 1 else np.zeros(0, int)
    cadence = float(np.clip(2 * np.pi / rate / 40.0, 0.5, 2.0))
    for _ in range(max_tries):
        orbit = KeplerOrbit(a_m=ORBIT_A_M, e=0.0, i_rad=np.radians(ORBIT_I_DEG), raan_rad=rng.uniform(0, 2 * np.pi), nu0_rad=rng.uniform(0, 2 * np.pi))
        case = Case(target, pole / np.linalg.norm(pole), axis, float(rate), float(rng.uniform(0, 2 * np.pi)), orbit,
                    DEFAULT_EPOCH + rng.uniform(0.0, 365.0) * u.day, (0, *map(int, days)), cadence, int(samples_per_night))
        if all(_window_start(case, day, _duration(case)) is not None for day in case.night_days):
            return case
    raise ValueError(f"orbit: no observable draw in {max_tries} tries: expected a GPS-like orbit visible from the site on every night")


def _duration(case: Case) -> float:
    """Arc length, s, that gives the nominal samples per night (:func:`sample_times` removes 6 % in gaps)."""
    return case.samples_per_night * case.cadence_s / 0.94


def _window_start(case: Case, day: int, duration_s: float) -> float | None:
    """Start (s after the night's epoch) of the first arc of ``duration_s`` visible within 3 days of ``day``, or None."""
    night = case.epoch + day * u.day
    try:
        return find_visible_start(_rephased(case.orbit, (night - case.epoch).to_value("s")), night, duration_s, DEFAULT_SITE, search_s=3 * 86400.0)
    except ValueError:
        return None


def _rephased(orbit: KeplerOrbit, dt_s: float) -> KeplerOrbit:
    """The same circular orbit with its elements read ``dt_s`` later (true anomaly advanced by n·dt)."""
    return dataclasses.replace(orbit, nu0_rad=float((orbit.nu0_rad + orbit.mean_motion * dt_s) % (2 * np.pi)))


def _arc_epoch(case: Case, day: int, duration_s: float, rng: np.random.Generator) -> Time:
    """Start of one night's arc: uniform inside the first visibility window found from ``day`` days after the case's epoch."""
    night = case.epoch + day * u.day
    orbit = _rephased(case.orbit, (night - case.epoch).to_value("s"))
    start = _window_start(case, day, duration_s)
    t = start + np.arange(0.0, 12 * 3600.0, 60.0)
    visible = observe(orbit, t, night, DEFAULT_SITE).visible
    n_vis = int(np.argmin(visible)) if not visible.all() else visible.size
    slack = max(0.0, (n_vis - 1) * 60.0 - duration_s - 60.0)
    return night + (start + rng.uniform(0.0, slack)) * u.s


def arrival_times(curve):
    """The curve with each sample's time moved from the simulated attitude's time t to t + ρ/c, when its light arrives
    (module docstring); the geometry stays that of t (the target moves ~300 m in 0.09 s: 1e-5 rad at GPS range)."""
    return dataclasses.replace(curve, t_s=curve.t_s + curve.range_m / C_LIGHT_M_S)


def true_state(sim, case: Case, epoch: Time) -> SpinState:
    """The truth as a :class:`SpinState` in the inversion's conventions, read from a simulated night's first attitude.

    ``C_IT = C_IP R_z(φ) C_AT`` (:mod:`lightcurves.inversion.spin`) gives φ = atan2(R₂₁, R₁₁) of
    ``R = C_IPᵀ C_IT C_TA``; its epoch is that attitude's time ``epoch``, the emission time of the first sample
    (:func:`arrival_times`). Raises ``ValueError`` if R is not a rotation about z: the simulated spin is not the one modelled.
    """
    R = pole_frame(case.pole_I).T @ quat_to_dcm(sim.q_IT[0]) @ axis_frame(case.axis_T)
    if abs(R[2, 2] - 1.0) > 1e-6:
        raise ValueError(f"simulated attitude: R_zz = {R[2, 2]:.9f}: expected a rotation about the pole (1)")
    return SpinState(case.pole_I, 2 * np.pi / case.rate_rad_s, float(np.arctan2(R[1, 0], R[0, 0])), epoch, case.axis_T)


def simulate_case(case: Case, renderer, rng: np.random.Generator) -> tuple[list, SpinState, float]:
    """The object's nights as calibrated :class:`InversionCurve` s, its true :class:`SpinState` and its synodic period (s) on the first night."""
    target = get_target(case.target)
    duration = _duration(case)
    curves, truth, synodic, first = [], None, float("nan"), None
    for day in case.night_days:
        epoch = _arc_epoch(case, day, duration, rng)
        orbit = _rephased(case.orbit, (epoch - case.epoch).to_value("s"))
        start = find_visible_start(orbit, epoch, duration, DEFAULT_SITE)  # what simulate_lightcurve finds (cached)
        first = epoch + start * u.s if first is None else first
        phase = case.phase_rad + case.rate_rad_s * (epoch + start * u.s - first).to_value("s")
        sim = simulate_lightcurve(target, axis_T=case.axis_T, rate_rad_s=case.rate_rad_s, duration_s=duration, cadence_s=case.cadence_s, rng=rng,
                                  orbit=orbit, epoch=epoch, pole_I=case.pole_I, phase_rad=phase, renderer=renderer)
        curves.append(arrival_times(from_lightcurve(sim.lightcurve, calibrated=True, name=f"{case.target} night {day}")))
        if truth is None:
            truth = true_state(sim, case, sim.lightcurve.time[0])
            synodic = 2 * np.pi / (case.rate_rad_s - bisector_rate(sim.observation, case.pole_I))
    return curves, truth, synodic


def _angle_deg(a, b) -> float:
    return float(np.degrees(np.arccos(np.clip(np.dot(a, b), -1.0, 1.0))))


def _log_map(pole_I: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Tangent offsets (M, 2) rad of unit vectors ``x`` (M, 3) from ``pole_I`` (vectorised ``tangent_offset``)."""
    v = x @ pole_frame(pole_I)
    rho = np.hypot(v[:, 0], v[:, 1])
    angle = np.arctan2(rho, v[:, 2])
    return v[:, :2] * (angle / np.where(rho > 0, rho, 1.0))[:, None]


def _mixture_logpdf(solutions, x_I: np.ndarray, period_s: np.ndarray | None) -> np.ndarray:
    """log density (M,) of the Gaussian mixture of the modes at poles ``x_I`` (M, 3) (and periods (M,)), each mode in its tangent plane."""
    terms = []
    for s in solutions:
        cov = s.covariance if period_s is not None else s.covariance[:2, :2]
        d = _log_map(s.pole_I, x_I)
        if period_s is not None:
            d = np.hstack([d, (period_s - s.period_s)[:, None]])
        logpdf = stats.multivariate_normal(np.zeros(d.shape[1]), cov, allow_singular=True).logpdf(d)
        terms.append(np.log(s.probability) + np.atleast_1d(logpdf))  # scipy returns a scalar for one point
    return np.logaddexp.reduce(np.array(terms), axis=0)


def mixture_level(solutions, pole_I, period_s: float | None, rng: np.random.Generator, n_draws: int = MIXTURE_DRAWS) -> float:
    """Credible level of the smallest highest-density region of the modes' mixture that holds the truth.

    The posterior is the mixture Σⱼ pⱼ N(μⱼ, Σⱼ) (each mode Gaussian in its pole's tangent plane, and in
    the period if ``period_s`` is given); the level is P(f(X) > f(truth)) for X drawn from it (Monte Carlo,
    ``n_draws``). The truth is inside the mixture's L region when the level ≤ L (Box & Tiao 1973, §2.8, HPD).
    """
    probs = np.array([s.probability for s in solutions])
    counts = rng.multinomial(n_draws, probs / probs.sum())
    xs, ps = [], []
    for s, n in zip(solutions, counts):
        if n == 0:
            continue
        cov = s.covariance if period_s is not None else s.covariance[:2, :2]
        z = rng.multivariate_normal(np.zeros(cov.shape[0]), cov, size=n, method="eigh")
        xs.append(tangent_exp(s.pole_I, z[:, :2]))
        ps.append(s.period_s + z[:, 2] if period_s is not None else None)
    x = np.concatenate(xs)
    p = np.concatenate(ps) if period_s is not None else None
    f_draws = _mixture_logpdf(solutions, x, p)
    f_truth = _mixture_logpdf(solutions, np.asarray(pole_I, dtype=float)[None], None if period_s is None else np.array([period_s]))[0]
    return float(np.mean(f_draws > f_truth))


def score(result, truth: SpinState, curves, model, rng: np.random.Generator, workers: int | None = None) -> dict:
    """The per-object figures of the module docstring (the profile's fits on ``workers`` threads)."""
    best = result.best
    sols = result.solutions
    errs = [_angle_deg(s.pole_I, truth.pole_I) for s in sols]
    chi2_truth = profiled_chi2(curves, model, truth)[0]
    row = {
        "pole_err_deg": errs[0], "closest_pole_err_deg": min(errs), "period_rel_err": best.period_s / truth.period_s - 1.0,
        "sense_right": errs[0] < 90.0, "n_modes": len(sols), "pole_sigma_deg": best.pole_sigma_deg,
        "alt_pole_listed": any(_angle_deg(s.pole_I, best.pole_I) >= ALT_POLE_DEG for s in sols[1:]),
        "axis_right": bool(np.dot(best.state.axis_T, truth.axis_T) > np.cos(np.radians(10.0))),
        "chi2_dof": best.chi2 / result.dof, "dchi2_truth": chi2_truth - best.chi2, "chi2_scale": result.chi2_scale,
    }
    for level in LEVELS:
        pct = int(round(100 * level))
        row[f"in{pct}_pole"] = best.contains(truth.pole_I, None, level)
        row[f"in{pct}_3d"] = best.contains(truth.pole_I, truth.period_s, level)
    row["mix_level_pole"] = mixture_level(sols, truth.pole_I, None, rng)
    row["mix_level_3d"] = mixture_level(sols, truth.pole_I, truth.period_s, rng)
    row["profile_level_pole"] = result.profile_level(pole_profile_chi2(curves, model, result, truth.pole_I, workers=workers)[0])
    region = pole_profile_region(curves, model, result, workers=workers)
    row["region_level_pole"] = region.level_at(truth.pole_I)
    row["region_area95_deg2"] = region.solid_angle_deg2(0.95)
    return row


def _period_range(synodic_s: float, rng: np.random.Generator) -> tuple[float, float]:
    centre = synodic_s * (1.0 + rng.uniform(-PERIOD_JITTER, PERIOD_JITTER))
    return centre * (1.0 - PERIOD_HALF_WIDTH), centre * (1.0 + PERIOD_HALF_WIDTH)


def run_object(case: Case, model: KnownShapeModel, renderer, rng: np.random.Generator, workers: int | None = None) -> dict:
    """Simulate, invert (known shape, fits on ``workers`` threads) and score one object; the row also has the geometry and the
    inversion's time."""
    curves, truth, synodic = simulate_case(case, renderer, rng)
    period_range = _period_range(synodic, rng)
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    t0, c0 = time.perf_counter(), time.process_time()
    result = invert(curves, model, period_range, rng=rng, workers=workers)
    elapsed, cpu = time.perf_counter() - t0, time.process_time() - c0
    alpha = np.concatenate([c.phase_angle_rad for c in curves])
    row = {"target": case.target, "axis_kind": axis_kind(get_target(case.target).J_diag, case.axis_T), "nights": len(curves),
           "samples": int(sum(len(c) for c in curves)),
           "span_deg": float(np.degrees(np.ptp(alpha))), "time_s": elapsed, "cpu_s": cpu, "load": load,
           "truth_in_range": period_range[0] <= truth.period_s <= period_range[1]}
    row.update(score(result, truth, curves, model, rng, workers))
    J = get_target(case.target).J_diag
    moment = [float(a**2 @ J) for a in (result.best.state.axis_T, truth.axis_T)]  # aᵀ diag(J) a, kg m²
    row["axis_moment_right"] = abs(moment[0] / moment[1] - 1.0) < 0.01  # same principal moment: equivalent for a symmetric body
    return row


# ---------------------------------------------------------------- brute force


def _calibrated_stack(curves):
    """Emission times (N,) s from the first curve's epoch, unit directions (N, 3), y/σ (N,) and g/σ (N,) of calibrated curves."""
    epoch = min((c.epoch for c in curves), key=lambda e: e.jd)
    t = np.concatenate([emission_time_s(c, epoch) for c in curves])
    sun = np.concatenate([c.sun_dir_I for c in curves])
    obs = np.concatenate([c.observer_dir_I for c in curves])
    y = np.concatenate([c.brightness / c.sigma for c in curves])
    g = np.concatenate([observed_flux(1.0, c.range_m, c.sun_distance_m) / c.sigma for c in curves])
    return epoch, t, sun, obs, y, g


def brute_force(curves, model: KnownShapeModel, period_range_s, *, pole_step_deg: float = BRUTE_POLE_STEP_DEG,
                n_phases: int = BRUTE_PHASE_STEPS, axes_T=None) -> tuple[SpinState, float, int]:
    """Global minimum of the known-shape profiled χ² on a dense grid: (state, χ², number of grid states).

    Grid: Fibonacci poles over the whole sphere at ``pole_step_deg``, sidereal rates at half the
    inversion's screening step (:func:`period_grid` with oversampling 2), phases φ₀ at 2π/``n_phases``,
    body axes ±x, ±y, ±z. For each (pole, axis) the brightness of every sample is tabulated over the
    rotation phase (``n_phases`` points, linear interpolation); every (rate, φ₀) then reads the table at
    φᵢ = φ₀ + ω tᵢ. With calibrated curves and one linear parameter w ≥ 0 the profiled χ² is closed form,
    χ² = Σ(y/σ)² − max(0, Σ bᵢyᵢ/σᵢ²)² / Σ(bᵢ/σᵢ)² with bᵢ = gᵢ Bᵢ (Golub & Pereyra 1973); the grid
    minimum is then re-evaluated exactly with :func:`profiled_chi2`.
    """
    if not all(c.calibrated for c in curves):
        raise ValueError("curves: relative curves: expected calibrated curves (the brute force solves one scale in closed form)")
    epoch, t, sun, obs, y, g = _calibrated_stack(curves)
    poles = fibonacci_sphere(int(np.ceil(4 * np.pi / np.radians(pole_step_deg) ** 2)))
    omegas = period_grid(period_range_s, np.ptp(t), 2.0)
    axes = np.vstack([np.eye(3), -np.eye(3)]) if axes_T is None else np.asarray(axes_T, dtype=float)
    grid = 2 * np.pi * np.arange(n_phases) / n_phases
    phi0 = grid.copy()
    yy = float(y @ y)
    best = (np.inf, None)
    for pole in poles:
        C_IP = pole_frame(pole)
        s_P, o_P = sun @ C_IP, obs @ C_IP
        for axis in axes:
            C_TA = axis_frame(axis)
            s_T = unspin(grid[:, None], np.broadcast_to(s_P, (n_phases,) + s_P.shape)) @ C_TA.T
            o_T = unspin(grid[:, None], np.broadcast_to(o_P, (n_phases,) + o_P.shape)) @ C_TA.T
            table = model.intensity(s_T.reshape(-1, 3), o_T.reshape(-1, 3)).reshape(n_phases, -1) * g  # (phase, sample)
            table = np.vstack([table, table[:1]])
            for omega in omegas:
                pos = ((phi0[:, None] + omega * t[None, :]) % (2 * np.pi)) / (2 * np.pi) * n_phases  # (φ₀, sample)
                k = pos.astype(int)
                f = pos - k
                cols = np.arange(t.size)
                b = (1 - f) * table[k, cols] + f * table[k + 1, cols]
                num = np.maximum(b @ y, 0.0)
                chi2 = yy - num**2 / np.maximum(np.einsum("ij,ij->i", b, b), 1e-300)
                j = int(np.argmin(chi2))
                if chi2[j] < best[0]:
                    best = (float(chi2[j]), (pole, omega, phi0[j], axis))
    pole, omega, phase, axis = best[1]
    state = SpinState(pole, 2 * np.pi / omega, phase, epoch, axis)
    return state, profiled_chi2(curves, model, state)[0], poles.shape[0] * axes.shape[0] * omegas.size * phi0.size


def run_brute(case: Case, model: KnownShapeModel, rng: np.random.Generator, workers: int | None = None) -> dict:
    """Invert one (small) object and search the same likelihood by :func:`brute_force`; compare optima and times."""
    curves, truth, synodic = simulate_case(case, FacetRenderer(model), rng)
    period_range = _period_range(synodic, rng)
    t0 = time.perf_counter()
    result = invert(curves, model, period_range, rng=rng, workers=workers)
    t_invert = time.perf_counter() - t0
    t0 = time.perf_counter()
    state, chi2_grid, n_states = brute_force(curves, model, period_range)
    t_grid = time.perf_counter() - t0
    return {"target": case.target, "samples": int(sum(len(c) for c in curves)), "chi2_invert": result.best.chi2, "chi2_grid": chi2_grid,
            "chi2_truth": profiled_chi2(curves, model, truth)[0], "grid_to_best_deg": _angle_deg(state.pole_I, result.best.pole_I),
            "grid_to_mode_deg": min(_angle_deg(state.pole_I, s.pole_I) for s in result.solutions), "n_states": n_states,
            "t_invert_s": t_invert, "t_grid_s": t_grid, "best_pole_err_deg": _angle_deg(result.best.pole_I, truth.pole_I)}


# ---------------------------------------------------------------- the run


def _drawn_objects(rng: np.random.Generator, n: int, names, nights: int | None, samples: int) -> list[Case]:
    """``n`` cases cycling over the target ``names``; ``nights`` a fixed count or None (uniform 1..MAX_NIGHTS)."""
    out = []
    for i in range(n):
        k = int(rng.integers(1, MAX_NIGHTS + 1)) if nights is None else int(nights)
        out.append(draw_case(rng, names[i % len(names)], k, samples))
    return out


def schedule(rng: np.random.Generator, size: Size) -> list[tuple[str, Case]]:
    """All objects as (kind, case), kinds interleaved in proportion so that a run stopped by its budget keeps every kind."""
    shaped = tuple(n for n in TARGETS if n != "sphere")  # the sphere's spin is invisible: one object in ten, facet rows only
    jobs = {"facet": _drawn_objects(rng, size.n_facet, shaped * 3 + ("sphere",), None, size.samples_per_night),
            "mitsuba": _drawn_objects(rng, size.n_mitsuba, shaped, MITSUBA_NIGHTS, size.mitsuba_samples_per_night),
            "brute": [dataclasses.replace(c, night_days=(0,)) for c in _drawn_objects(rng, size.n_brute, BRUTE_TARGETS, 1, size.brute_samples)],
            "timing": _drawn_objects(np.random.default_rng(TIMING_SEED), size.n_timing, TIMING_TARGETS, 3, TIMING_SAMPLES)}
    order = {kind: j for j, kind in enumerate(jobs)}
    keyed = [(i / len(cases), order[kind], kind, case) for kind, cases in jobs.items() for i, case in enumerate(cases)]
    return [(kind, case) for _, _, kind, case in sorted(keyed, key=lambda k: k[:2])]


def measure(rng: np.random.Generator, size: Size, *, budget_s: float = np.inf, processes: int | None = None, log=print,
            kept: dict[int, dict] | None = None, on_row=None) -> tuple[dict, int]:
    """Rows ``facet``, ``mitsuba``, ``timing`` (:func:`run_object`) and ``brute`` (:func:`run_brute`), and the number of scheduled
    objects not run because the wall-clock ``budget_s`` ran out.

    The objects but the timing ones run in ``processes`` worker processes (default: the machine's cores), one object each at a
    time on one thread: an object's fits are largely Python, which threads do not share (``invert(..., workers=)``), so two
    processes measure twice the objects in the same time. Each object draws its noise from its own seed
    (``SeedSequence(REPORT_SEED)`` spawned in schedule order), so a row does not depend on the number of processes or on
    which objects ran before it. The timing objects run first, alone, on all cores (what a user's single inversion gets);
    the budget counts from after them and does not stop them.

    ``kept`` maps schedule indices to rows measured earlier by the same code (:func:`benchmarks.bench_inversion.run`): those objects are not run again.
    ``on_row(j, kind, row)`` is called as each new row finishes (the run keeps it on disk).
    """
    jobs = schedule(rng, size)
    seeds = np.random.SeedSequence(REPORT_SEED).spawn(len(jobs))
    kept = kept or {}
    rows = {"facet": [], "mitsuba": [], "brute": [], "timing": []}
    for j, row in kept.items():
        rows[jobs[j][0]].append((j, row))
    done = len(kept)

    def keep(j: int, kind: str, row: dict) -> None:
        nonlocal done
        rows[kind].append((j, row))
        done += 1
        if on_row is not None:
            on_row(j, kind, row)
        log(f"[inversion] {done}/{len(jobs)} {kind} {_brief(row)} ({time.perf_counter() - t0:.0f} s)")

    t0 = time.perf_counter()
    if any(kind == "timing" and j not in kept for j, (kind, _) in enumerate(jobs)):
        warm_up()
    for j, (kind, case) in enumerate(jobs):
        if kind == "timing" and j not in kept:
            keep(j, kind, _job(kind, case, seeds[j], None))
    queue = [(j, kind, case) for j, (kind, case) in enumerate(jobs) if kind != "timing" and j not in kept]
    t_pool = time.perf_counter()
    processes = processes or os.cpu_count() or 1
    not_run = 0
    context = multiprocessing.get_context("spawn")  # numba's and Mitsuba's thread pools do not survive a fork
    with concurrent.futures.ProcessPoolExecutor(processes, mp_context=context, initializer=_single_threaded) as pool:
        running = {}
        while queue or running:
            while queue and len(running) < processes:
                if time.perf_counter() - t_pool > budget_s:
                    not_run, queue = len(queue), []
                    break
                j, kind, case = queue.pop(0)
                running[pool.submit(_job, kind, case, seeds[j], 1)] = (j, kind)
            if not running:
                break
            finished, _ = concurrent.futures.wait(running, return_when=concurrent.futures.FIRST_COMPLETED)
            for future in finished:
                keep(*running.pop(future), future.result())
    return {kind: [row for _, row in sorted(kept_rows, key=lambda jr: jr[0])] for kind, kept_rows in rows.items()}, not_run


def warm_up() -> None:
    """One untimed inversion of a one-night, 60-sample box-wing (shadowed facets: every kernel of a timing object's search
    runs, serial and parallel), so that no timing row includes numba's compilation."""
    rng = np.random.default_rng(TIMING_SEED)
    case = draw_case(rng, "box-wing", 1, 60)
    model = _model(case.target)
    curves, _, synodic = simulate_case(case, FacetRenderer(model), rng)
    invert(curves, model, _period_range(synodic, rng), rng=rng)


def _single_threaded() -> None:
    """A worker process's initializer: numba's parallel kernels on one thread (the processes share the cores)."""
    numba.set_num_threads(1)


@functools.cache
def _model(name: str) -> KnownShapeModel:
    return KnownShapeModel.from_target(get_target(name))


def _job(kind: str, case: Case, seed: np.random.SeedSequence, workers: int | None) -> dict:
    """One scheduled object (:func:`measure`): its row, or a row recording its failure."""
    rng = np.random.default_rng(seed)
    model = _model(case.target)
    if kind == "brute":
        return _safe(run_brute, case, model, rng, workers)
    renderer = UnresolvedRenderer(get_target(case.target)) if kind == "mitsuba" else FacetRenderer(model)
    return _safe(run_object, case, model, renderer, rng, workers)


def _safe(fn, case: Case, *args) -> dict:
    """``fn(case, *args)``, or a row recording the failure (a benchmark reports failures, it does not hide them)."""
    try:
        return fn(case, *args)
    except Exception as e:  # noqa: BLE001 - any failure of the library under test is a finding to report
        return {"target": case.target, "nights": len(case.night_days), "error": f"{type(e).__name__}: {e}"[:200]}


def _brief(row: dict) -> str:
    if "error" in row:
        return f"{row['target']} ERROR {row['error']}"
    if "chi2_grid" in row:
        return (f"{row['target']} χ² invert {row['chi2_invert']:.1f} grid {row['chi2_grid']:.1f} truth {row['chi2_truth']:.1f} "
                f"grid pole to best {row['grid_to_best_deg']:.1f}° t {row['t_invert_s']:.0f} / {row['t_grid_s']:.0f} s")
    return (f"{row['target']} nights {row['nights']} span {row['span_deg']:.0f}° pole err {row['pole_err_deg']:.1f}° σ {row['pole_sigma_deg']:.1f}° "
            f"in95 {row['in95_pole']} modes {row['n_modes']} χ²/dof {row['chi2_dof']:.2f} Δχ²_truth {row['dchi2_truth']:.1f} t {row['time_s']:.1f} s")
