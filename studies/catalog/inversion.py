"""The run behind ``lcnav lightcurve invert``: light curves with geometry -> spin-state solutions, tables and fitted curves.

The search itself is :func:`lightcurves.inversion.search.invert` (Kaasalainen & Torppa, Icarus 153, 2001;
Kaasalainen, Torppa & Muinonen, Icarus 153, 2001); this module chooses its inputs and reports its output:

* :func:`shape_model` — ``convex`` (unknown shape: a Gaussian image of facet areas), ``ellipsoid:A,B,C``
  (a triaxial ellipsoid of known semi-axes, m) or one of lcnav's targets (the known-shape facet model);
* without a period range from the user, every curve's own period ± max(3σ, 1 %) and, when its maxima per rotation are not
  established, twice it (:func:`lightcurves.inversion.periods.period_ranges`);
* :func:`run_inversion` — one search over every period range (:func:`~lightcurves.inversion.search.invert` weighs their modes
  together);
* :func:`fitted_brightness` — each curve's model brightness at a solution (for the fit figures and the recording);
* :func:`profile_regions` — on request (``--pole-region``), the pole's profile-likelihood region about every mode;
* :func:`result_dict` / :func:`solutions_table` — the JSON of ``--json`` and the table of ``--out``.

Every period here is sidereal; the single-night period is synodic, which the 1 % floor (and the
synodic term of the prior's 1-σ) covers.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
import pandas as pd

from lightcurves.inversion.periods import SECONDS_PER_HOUR, PeriodRange

#: Facets of an ``ellipsoid:A,B,C`` model: measured against 8000 facets for a 3:1.5:1 ellipsoid at phase angles
#: below 110°, 0.12 % rms and 0.74 % max brightness error (2000 facets: 0.05 % / 0.34 %, at twice the cost).
ELLIPSOID_FACETS = 1000


@dataclass(frozen=True)
class InversionRun:
    """What ``invert`` computed: the search over every period range and its solutions (best first)."""

    curves: tuple  #: the InversionCurve inputs, in file order
    shape: str  #: the ``--shape`` value
    known_shape: bool  #: the model has one linear parameter (phase and body axis fitted)
    ranges: tuple[PeriodRange, ...]
    result: object  #: the :class:`~lightcurves.inversion.posterior.InversionResult` of the search
    time_s: float  #: wall time of the search

    @property
    def solutions(self) -> tuple:
        """The :class:`~lightcurves.inversion.posterior.SpinSolution` modes, by decreasing probability."""
        return self.result.solutions

    @property
    def probabilities(self) -> np.ndarray:
        """The modes' probabilities (they sum to 1), in the order of :attr:`solutions`."""
        return np.array([s.probability for s in self.result.solutions])


def shape_model(shape: str):
    """The shape model of a ``--shape`` value (validated by the command): ConvexModel, EllipsoidModel or KnownShapeModel."""
    from lightcurves.inversion.convex import ConvexModel, EllipsoidModel

    if shape == "convex":
        return ConvexModel()
    if shape.startswith("ellipsoid:"):
        a, b, c = (float(x) for x in shape.split(":", 1)[1].split(","))
        return EllipsoidModel(a, b, c, n_facets=ELLIPSOID_FACETS)
    from lightcurves.inversion.known_shape import KnownShapeModel
    from lightcurves.targets import get_target

    return KnownShapeModel.from_target(get_target(shape))


def period_trials(ranges: Sequence[PeriodRange], curves: Sequence, oversampling: float = 1.0) -> int:
    """Number of sidereal rates the search's grid tries over ``ranges`` (:func:`lightcurves.inversion.search.period_grid`)."""
    from lightcurves.inversion.search import period_grid

    t0 = min((c.epoch for c in curves), key=lambda e: e.jd)
    starts = [(c.epoch - t0).to_value("s") + c.t_s[0] for c in curves]
    ends = [(c.epoch - t0).to_value("s") + c.t_s[-1] for c in curves]
    span = max(ends) - min(starts)
    return int(sum(period_grid((r.lo_s, r.hi_s), span, oversampling).size for r in ranges))


def run_inversion(curves: Sequence, shape: str, ranges: Sequence[PeriodRange], *, rng: np.random.Generator,
                  progress: Callable[[int, int], None] | None = None, search_options: dict | None = None) -> InversionRun:
    """One :func:`~lightcurves.inversion.search.invert` over every period range of ``ranges``: each range is screened and
    searched on its own, and the modes of all of them are weighed together by their Laplace probabilities (the ranges share the
    data and the model, so their χ² compare directly)."""
    import time

    from lightcurves.inversion.search import invert

    model = shape_model(shape)
    start = time.perf_counter()
    result = invert(list(curves), model, [(r.lo_s, r.hi_s) for r in ranges], rng=rng, progress=progress, **(search_options or {}))
    elapsed = time.perf_counter() - start
    known = np.asarray(model.basis(np.array([[0.0, 0.0, 1.0]]), np.array([[0.0, 0.0, 1.0]]))).shape[1] == 1
    return InversionRun(tuple(curves), shape, known, tuple(ranges), result, elapsed)


def fitted_brightness(solution, result, curves: Sequence) -> list[np.ndarray]:
    """Model brightness (N_k,) of each curve at ``solution``, in the unit of its data: ``s_k g B(ŝ_T, ô_T) w``.

    ``g = (1 au/d☉)²/ρ²`` (:func:`lightcurves.render.observed_flux`), B the model's basis at the body
    directions of the solution's spin state (:func:`lightcurves.inversion.spin.body_directions`), w the
    solution's linear parameters and s_k its scale of curve k (1 for calibrated curves).
    """
    from lightcurves.inversion.spin import body_directions
    from lightcurves.render import observed_flux

    out = []
    for k, c in enumerate(curves):
        sun_T, obs_T = body_directions(solution.state, c)
        intensity = np.asarray(result.model.basis(sun_T, obs_T)) @ solution.weights
        out.append(solution.scales[k] * observed_flux(intensity, c.range_m, c.sun_distance_m))
    return out


def _finite(x: float) -> float | None:
    return float(x) if np.isfinite(x) else None


def solution_dict(solution, known_shape: bool) -> dict:
    """One solution in the JSON form of ``--json`` (angles in degrees, periods in hours, epoch as a UTC Julian date)."""
    lon, lat = np.degrees(solution.ecliptic_rad)
    ra, dec = np.degrees(solution.radec_rad)
    st = solution.state
    d = {
        "probability": float(solution.probability),
        "pole_ecliptic_lon_deg": float(lon),
        "pole_ecliptic_lat_deg": float(lat),
        "pole_ra_deg": float(ra),
        "pole_dec_deg": float(dec),
        "pole_sigma_deg": float(solution.pole_sigma_deg),
        "pole_I": [float(x) for x in st.pole_I],
        "sidereal_period_h": st.period_s / SECONDS_PER_HOUR,
        "sidereal_period_sigma_h": solution.period_sigma_s / SECONDS_PER_HOUR,
        "epoch_jd": float(st.epoch.utc.jd1 + st.epoch.utc.jd2),
        "phase_deg": float(np.degrees(st.phase_rad)),
        "phase_sigma_deg": _finite(np.degrees(solution.phase_sigma_rad)),
        "chi2": float(solution.chi2),
    }
    if known_shape:
        d["body_spin_axis_T"] = [float(x) for x in st.axis_T]
        d["body_spin_axis_sigma_deg"] = _finite(solution.axis_sigma_deg)
    return d


def profile_regions(run: InversionRun, progress: Callable[[int, int], None] | None = None) -> tuple:
    """The pole's profile-likelihood region about every mode of ``run`` (:func:`lightcurves.inversion.profile.pole_profile_region`,
    its defaults: mapped to the 99 % level), as a tuple of one region; ``progress(n_done, n_total)`` over the map."""
    from lightcurves.inversion.profile import pole_profile_region

    return (pole_profile_region(run.curves, run.result.model, run.result, progress=progress),)


def region_dict(region, ranges: Sequence[PeriodRange]) -> dict:
    """One profile-likelihood region in the JSON form of ``--json``: its areas, and every mapped pole within the mapped
    level (ecliptic and equatorial J2000, deg; the level F_χ²₂(Λ) at which it enters the region; the sidereal period and
    body spin axis there: a known shape's pole can be listed once per body axis it was mapped about)."""
    from lightcurves.inversion.frames import pole_to_ecliptic, pole_to_radec

    keep = region.inside(region.max_level)
    poles = []
    for pole, level, state in zip(region.poles_I[keep], region.level[keep], np.asarray(region.states, dtype=object)[keep]):
        lon, lat = np.degrees(pole_to_ecliptic(pole))
        ra, dec = np.degrees(pole_to_radec(pole))
        poles.append({"pole_ecliptic_lon_deg": float(lon), "pole_ecliptic_lat_deg": float(lat), "pole_ra_deg": float(ra),
                      "pole_dec_deg": float(dec), "level": float(level), "sidereal_period_h": state.period_s / SECONDS_PER_HOUR,
                      "body_spin_axis_T": [float(x) for x in state.axis_T]})
    return {"period_ranges": [r.to_dict() for r in ranges], "mapped_to_level": region.max_level, "complete": bool(region.complete),
            "n_poles_mapped": int(region.chi2.size), "solid_angle_68_deg2": region.solid_angle_deg2(0.68),
            "solid_angle_95_deg2": region.solid_angle_deg2(0.95), "chi2_min_mapped": region.min_chi2, "poles": poles}


def result_dict(run: InversionRun, files: Sequence[str], seed: int, regions: Sequence = ()) -> dict:
    """The whole ``--json`` document: solutions best first, fit quality, inputs and the period ranges searched; with
    ``regions`` (:func:`profile_regions`) also ``pole_profile_regions`` (:func:`region_dict`)."""
    best, res = run.result.best, run.result
    n = int(sum(len(c) for c in run.curves))
    doc = {
        "solutions": [solution_dict(s, run.known_shape) for s in run.solutions],
        "fit": {"chi2": float(best.chi2), "dof": int(res.dof), "chi2_per_dof": float(best.chi2 / max(res.dof, 1)),
                "chi2_scale": float(res.chi2_scale), "n_points": n, "n_curves": len(run.curves),
                "n_relative": int(sum(not c.calibrated for c in run.curves)), "n_calibrated": int(sum(c.calibrated for c in run.curves))},
        "shape": run.shape,
        "shape_mode": "known" if run.known_shape else "unknown (convex)",
        "period_ranges": [r.to_dict() for r in run.ranges],
        "epoch_time_scale": "utc (light-time corrected: when the light left the target)",
        "files": [str(f) for f in files],
        "seed": int(seed),
        "time_s": float(run.time_s),
    }
    if regions:
        doc["pole_profile_regions"] = [region_dict(r, run.ranges) for r in regions]
    return doc


def solutions_table(doc: dict) -> pd.DataFrame:
    """One row per solution of :func:`result_dict` (vectors split into ``_x/_y/_z`` columns)."""
    rows = []
    for rank, s in enumerate(doc["solutions"], start=1):
        row = {"rank": rank}
        for key, value in s.items():
            if isinstance(value, list):
                row.update({f"{key}_{a}": v for a, v in zip("xyz", value)})
            else:
                row[key] = value
        rows.append(row)
    return pd.DataFrame(rows)
