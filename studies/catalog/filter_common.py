"""What the filter studies of Renis et al. §6 share (:mod:`studies.catalog.tuning_study`,
:mod:`studies.catalog.init_study`, :mod:`studies.catalog.proxy_study`): config fields, thresholds,
priors, tables, figures. One run of them is :func:`studies.sim.navigation.navigate`.
"""

from __future__ import annotations

import functools
from pathlib import Path

import numpy as np
import pandas as pd

from estimators.measurement import NOISE_MODELS, PoseNoise
from estimators.perturbations import TRUTH_PHYSICS
from estimators.prior import BodyRatePrior
from studies.catalog.figures import pyplot, save_png
from studies.engine.config import ConfigError, Field


#: Config fields common to the filter studies (thresholds of §6, pose noise of §4.4, initial guess, statistics).
#: The truth's physics (every study that simulates a truth): what the filters model, or with unmodelled perturbations.
TRUTH_FIELD = Field("str", "Truth physics: torque-free (Kepler, torque-free: what the filters model) or perturbed (gravity gradient, J2, drag, "
                    "nutation damping; estimators.perturbations).", choices=TRUTH_PHYSICS, default="torque-free")

COMMON_FIELDS: dict[str, Field] = {
    "truth": TRUTH_FIELD,
    "threshold_att_deg": Field("float", "Convergence threshold of the attitude error, deg.", gt=0, default=2.0),
    "threshold_rate_deg_s": Field("float", "Convergence threshold of the rate error, deg/s.", gt=0, default=2.0),
    "threshold_pos_m": Field("float", "Convergence threshold of the position error, m.", gt=0, default=1.0),
    "threshold_vel_m_s": Field("float", "Convergence threshold of the velocity error, m/s.", gt=0, default=0.1),
    "threshold_k": Field("float", "Convergence threshold of the inertia-ratio error.", gt=0, default=0.2),
    "sigma_q_rad": Field("float", "Pose attitude noise amplitude sigma_q, rad (eq. 34 of Renis et al.); the measurements' and the filter's R_d.", gt=0,
                         default=PoseNoise.sigma_q_rad),
    "sigma_r_m": Field("float", "Pose position noise amplitude sigma_r, m; the measurements' and the filter's R_d.", gt=0, default=PoseNoise.sigma_r_m),
    "noise_model": Field("str", "Pose noise distribution (gaussian: N(0, sigma^2/3 I); isotropic: eq. 34 literally, same covariance, not chi-square).",
                         choices=NOISE_MODELS, default=PoseNoise.model),
    "inertia_guess_range": Field("list[float]", "Initial inertia guess J_T * U(lo, hi) per axis: [lo, hi].", gt=0, min_len=2, default=[0.7, 1.3]),
    "gate_confidence": Field("float", "Chi-square validation gate confidence per source (Renis et al. §4.3).", gt=0, le=0.999999, default=0.99),
    "gate_start_s": Field("float", "The gates test measurements from this time on, s.", ge=0, default=10.0),
    "confidence": Field("float", "Confidence level of the intervals in the summary.", gt=0, le=0.999, default=0.95),
    "record": Field("bool", "Write run.rrd (and errors.parquet) for every run.", default=True),
}
#: Where a prior study's prior comes from (``init``, ``proxy``): light curves as a user has them, or the paper's oracle.
PRIOR_FIELDS: dict[str, Field] = {
    "prior_source": Field("str", "lightcurves: rendered arcs inverted with the target's model (studies.sim.lightcurve_prior; no truth "
                          "reaches the prior); truth: Renis et al. §5.3, the true rate off by prior_rate_error (an oracle, on purpose).",
                          choices=("lightcurves", "truth"), default="lightcurves"),
    "lc_target": Field("str", "Rendered target of the light curves (lightcurves/targets.py).", default="atlas-centaur"),
    "lc_nights": Field("int", "Light-curve arcs observed.", ge=1, le=10, default=3),
    "lc_night_spacing_days": Field("float", "Time between the arcs' start times, days.", gt=0, le=60, default=0.125),
    "lc_duration_s": Field("float", "Each arc, s.", gt=0, le=7200, default=600.0),
    "lc_cadence_s": Field("float", "Light-curve sampling interval, s.", gt=0, default=1.0),
    "lc_resolution_px": Field("int", "Film pixels per side of the renders.", ge=4, le=512, default=64),
    "lc_spp": Field("int", "Samples per pixel of the renders.", choices=(1, 4, 16, 64, 256), default=4),
    "lc_seed": Field("int", "Seed of the observation campaign (one set of light curves, so one prior, for every run of the study).", ge=0,
                     default=1),
}
PRIOR_RUN_FIELDS = tuple(PRIOR_FIELDS)


@functools.lru_cache(maxsize=4)
def _campaign(scenario: str, target: str, nights: int, spacing_days: float, duration_s: float, cadence_s: float, px: int, spp: int, seed: int):
    """One observation campaign and the prior built from it (cached: every run of a study, per worker process, shares it)."""
    from studies.sim.chain import render_prior
    from studies.sim.scenarios import get_scenario

    return render_prior(get_scenario(scenario), np.random.default_rng(seed), target=target, nights=nights, night_spacing_days=spacing_days,
                        duration_s=duration_s, cadence_s=cadence_s, resolution_px=px, spp=spp)


def study_prior(p: dict, scenario: str, w_T_true, rng: np.random.Generator) -> tuple[BodyRatePrior | None, dict]:
    """The prior of one run of a prior study, and how it scores against the truth (``prior_*`` columns).

    ``prior_source = "lightcurves"``: built from one rendered observation campaign (``lc_*`` fields) by
    :func:`studies.sim.lightcurve_prior.build_prior`, which sees the light curves and the target's name only; the
    truth ``w_T_true`` only scores it. ``"truth"``: the paper's oracle (:func:`draw_prior`), said in the tables.
    """
    if p["prior_source"] == "truth":
        prior = draw_prior(w_T_true, p["prior_rate_error"], p["prior_error_direction"], rng)
        return prior, {"prior_w_err_rad_s": float(np.linalg.norm(prior.w_T_T_rad_s - w_T_true))}
    rendered = _campaign(scenario, p["lc_target"], p["lc_nights"], p["lc_night_spacing_days"], p["lc_duration_s"], p["lc_cadence_s"],
                         p["lc_resolution_px"], p["lc_spp"], p["lc_seed"])
    return rendered.spin, rendered.score()


#: The per-run parameters among :data:`COMMON_FIELDS` (``confidence`` is summary-only).
COMMON_RUN_FIELDS = tuple(k for k in COMMON_FIELDS if k != "confidence")
GROUP_LABELS = {"q": "q_TS", "w": "ω_ST", "r": "r_ST", "v": "v_ST", "k": "J_T^k"}


def check_common(params: dict) -> None:
    """``inertia_guess_range`` is ``[lo, hi]`` with ``lo <= hi``."""
    lo_hi = params["inertia_guess_range"]
    if len(lo_hi) != 2 or lo_hi[0] > lo_hi[1]:
        raise ConfigError(f"inertia_guess_range {lo_hi}: expected [lo, hi] with 0 < lo <= hi")


def pose_noise(params) -> PoseNoise:
    """The pose noise of a config/run (the measurements' and the filter's)."""
    return PoseNoise(params["sigma_q_rad"], params["sigma_r_m"], params["noise_model"])


def thresholds(params) -> dict:
    """The convergence thresholds of a config/run, in SI units per group."""
    return {"q": float(np.radians(params["threshold_att_deg"])), "w": float(np.radians(params["threshold_rate_deg_s"])),
            "r": float(params["threshold_pos_m"]), "v": float(params["threshold_vel_m_s"]), "k": float(params["threshold_k"])}


def draw_prior(w_T_T_true, error_fraction: float, direction: str, rng: np.random.Generator) -> BodyRatePrior:
    """A prior off the true rate by ``error_fraction`` of its magnitude (§5.3).

    ``direction="along"``: ``(1 + e) ω`` (a light curve's period error);
    ``"random"``: ``ω + e |ω| u`` with ``u`` uniform on the unit sphere (always drawn, so the stream
    of ``rng`` does not depend on the choice). 1-σ per axis ``e |ω|``.
    """
    u = rng.normal(size=3)
    u /= np.linalg.norm(u)
    w = np.asarray(w_T_T_true, dtype=float)
    if direction == "along":
        return BodyRatePrior.from_truth(w, error_fraction)
    n = float(np.linalg.norm(w))
    return BodyRatePrior(w + error_fraction * n * u, np.full(3, error_fraction * max(n, 1e-6)), source=f"truth ± {100 * error_fraction:.1f}% random direction")


def median_interval(x, confidence: float = 0.95) -> tuple[float, float, float]:
    """Median and its distribution-free order-statistic interval; NaN values count as +∞ (did not converge).

    Censored values (a run that never converged) have no number but a rank, so
    the binomial interval of the median (``scipy.stats.binom``) is used rather
    than a bootstrap; infinite results are returned as NaN.
    """
    from scipy.stats import binom

    v = np.sort(np.where(np.isfinite(np.asarray(x, dtype=float)), np.asarray(x, dtype=float), np.inf))
    n = v.size
    if n == 0:
        return (np.nan, np.nan, np.nan)
    med = float(np.median(v)) if np.isfinite(np.median(v)) else np.inf
    a = 0.5 * (1.0 - confidence)
    j = int(binom.ppf(a, n, 0.5))  # P(B <= j-1) < a: v[j-1] is the lower bound (1-based j)
    k = n - j
    lo = float(v[j - 1]) if j >= 1 else -np.inf
    hi = float(v[k]) if k < n else np.inf
    fin = lambda z: z if np.isfinite(z) else np.nan  # noqa: E731
    return fin(med), fin(lo), fin(hi)


def paired_change(runs: pd.DataFrame, arm: str, column: str, confidence: float = 0.95) -> list[dict]:
    """Per filter: the paired effect of ``arm`` (a boolean column) on ``column``, the arms matched by ``seed_index``.

    Returns one dict per filter: ``without``/``with`` (medians over the seeds both arms ran; a metric never reached, +∞,
    counts), ``finite_without``/``finite_with``, and the change *with − without* over the seeds where both are finite:
    ``mean`` with its Student-t interval ``lo``/``hi`` (:func:`studies.engine.stats.t_interval`), ``seeds`` and ``lower`` (the
    seeds where the arm lowered the metric).
    """
    from studies.engine.stats import t_interval

    rows = []
    for f in dict.fromkeys(runs["filter"]):
        mine = runs[runs["filter"] == f]
        off = mine[~mine[arm].astype(bool)].set_index("seed_index")[column].astype(float)
        on = mine[mine[arm].astype(bool)].set_index("seed_index")[column].astype(float)
        both = off.index.intersection(on.index)
        a, b = off.loc[both], on.loc[both]
        ok = np.isfinite(a) & np.isfinite(b)
        d = (b - a)[ok].to_numpy()
        iv = t_interval(d, confidence)
        rows.append({"filter": f, "without": float(np.median(a)) if len(a) else np.nan, "with": float(np.median(b)) if len(b) else np.nan,
                     "finite_without": int(np.isfinite(a).sum()), "finite_with": int(np.isfinite(b).sum()),
                     "mean": iv.estimate, "lo": iv.lo, "hi": iv.hi, "seeds": int(ok.sum()), "lower": int(np.sum(d < 0))})
    return rows


def metric_tables(runs: pd.DataFrame, arms: list[tuple[str, str]], groups, *, confidence: float, scale_ess: float = 1e3):
    """Paper-layout tables of §6: median convergence time and steady-state RMSE per (basis, group) × arm.

    ``arms``: ``[(column label, query on runs)]``, e.g. ``("EKF +prior", "filter == 'ekf' and prior")``.
    Returns ``(convergence, steady_state, stats)``: the first two with one column per arm (medians;
    a non-converged run counts as +∞, so a median of NaN means most runs did not converge);
    ``stats`` long: every (basis, group, arm) with runs converged, mean, sd, t interval of the mean
    over the converged runs, median and its order-statistic interval.
    """
    from studies.engine.stats import t_interval

    conv, ess, stats_rows = [], [], []
    for basis, prefix in (("state", ""), ("filter", "f_")):
        for g in groups:
            crow, erow = {"basis": basis, "component": GROUP_LABELS[g]}, {"basis": basis, "component": GROUP_LABELS[g]}
            for label, query in arms:
                sub = runs.query(query)
                for metric, row, scale in ((f"ct_{prefix}{g}_s", crow, 1.0), (f"ess_{prefix}{g}", erow, scale_ess)):
                    vals = pd.to_numeric(sub[metric], errors="coerce").to_numpy(dtype=float) * scale
                    med, mlo, mhi = median_interval(vals, confidence)
                    row[label] = med
                    iv = t_interval(vals, confidence)
                    fin = vals[np.isfinite(vals)]
                    stats_rows.append({"basis": basis, "component": GROUP_LABELS[g], "arm": label,
                                       "metric": "convergence time (s)" if scale == 1.0 else f"steady-state RMSE (x1e-{int(np.log10(scale_ess))})",
                                       "runs": len(vals), "converged": int(fin.size), "mean": iv.estimate,
                                       "sd": float(fin.std(ddof=1)) if fin.size > 1 else np.nan, "mean lo": iv.lo, "mean hi": iv.hi,
                                       "median": med, "median lo": mlo, "median hi": mhi})
            conv.append(crow)
            ess.append(erow)
    return pd.DataFrame(conv), pd.DataFrame(ess), pd.DataFrame(stats_rows)


def read_error_series(out_dir: Path, run_ids) -> dict[str, pd.DataFrame]:
    """``errors.parquet`` of each run that wrote one (``DIR/runs/<run_id>/errors.parquet``)."""
    from studies.engine.sweep import run_dir

    out = {}
    for rid in run_ids:
        p = run_dir(out_dir, rid) / "errors.parquet"
        if p.is_file():
            out[rid] = pd.read_parquet(p)
    return out


def plot_error_bands(ax, series: list[pd.DataFrame], column: str, scale: float, label: str, color: str) -> None:
    """Median over runs of ``column`` (× ``scale``) against time with the 25–75 % band."""
    if not series:
        return
    t = series[0]["t_s"].to_numpy()
    n = min(len(s) for s in series)
    m = np.array([s[column].to_numpy()[:n] for s in series]) * scale
    ax.plot(t[:n], np.median(m, axis=0), color=color, lw=1.2, label=f"{label} (median of {len(series)})")
    ax.fill_between(t[:n], np.percentile(m, 25, axis=0), np.percentile(m, 75, axis=0), color=color, alpha=0.25, lw=0)


def paired_error_figure(runs: pd.DataFrame, path: Path, *, arm: str, labels: tuple[str, str], rows, scenario: str,
                        shade: tuple[float, float] | None = None) -> None:
    """Errors against time, one column per filter, the two arms of a paired study overlaid.

    ``arm`` is the boolean column of ``runs`` that tells the arms apart (``prior``,
    ``proxy``), ``labels`` their legend names (False, True); ``rows`` are
    ``(group, scale, y label, threshold or None)``; ``shade`` an interval to grey
    out (a fault window). Median and inter-quartile band over seeds
    (:func:`plot_error_bands`), log scale; written atomically as PNG.
    """
    plt = pyplot()

    series = read_error_series(path.parent, runs["run_id"])
    filters = list(dict.fromkeys(runs["filter"]))
    fig, axes = plt.subplots(len(rows), len(filters), figsize=(4.8 * len(filters), 1.8 * len(rows) + 1.8),
                             layout="constrained", sharex=True, squeeze=False)
    for j, f in enumerate(filters):
        for i, (g, scale, label, thr) in enumerate(rows):
            ax = axes[i, j]
            if shade is not None:
                ax.axvspan(*shade, color="0.85", label="fault window")
            for value, color in ((False, "tab:blue"), (True, "tab:orange")):
                ids = runs.query(f"filter == '{f}' and {arm} == {value}")["run_id"]
                plot_error_bands(ax, [series[r] for r in ids if r in series], f"err_{g}", scale, labels[value], color)
            if thr is not None:
                ax.axhline(thr, color="k", ls="--", lw=0.8, label="threshold")
            ax.set_yscale("log")
            ax.set_ylabel(label)
            if i == 0:
                ax.set_title(f"{f.upper()} — {scenario}")
            if i == len(rows) - 1:
                ax.set_xlabel("time (s)")
            if i == 0 and j == 0:
                ax.legend(fontsize=7)
    save_png(fig, path)


def record_arm(path: Path, tr, run, meas, params: dict, arm: str, *, recording_id: str, extra_scalars: dict | None = None) -> None:
    """``run.rrd`` of one run of a paired study, its estimates named by what differs between the arms.

    ``/estimate/<filter>_<arm>/...`` with the arm, ``/estimate/<filter>_no_<arm>/...``
    without (e.g. ``ekf_prior`` and ``ekf_no_prior``), so that recordings of both
    arms opened together are told apart (:func:`studies.recording.navigation.record_navigation`).
    """
    import dataclasses

    from studies.recording.navigation import record_navigation

    name = f"{params['filter']}_{'' if params[arm] else 'no_'}{arm}"
    record_navigation(path, tr, dataclasses.replace(run, filter=name), meas, recording_id=recording_id, extra_scalars=extra_scalars)


def paired_specs(config, arm: str, run_fields) -> list:
    """Filters × {without, with ``arm``} × seeds, run ids ``<filter>-<none|arm>-s<index>``.

    Both arms of one seed index share a seed key, so they see the same
    measurements and initial guess (paired comparisons); ``run_fields`` are the
    config fields copied into every run's parameters.
    """
    from studies.engine.sweep import make_specs

    common = {k: config[k] for k in run_fields}
    return make_specs(config.seed, (
        (f"{f}-{arm if on else 'none'}-s{i:03d}", {"filter": f, arm: on, "seed_index": i, **common}, f"s{i:03d}")
        for f in config["filters"] for on in (False, True) for i in range(config["n_seeds"])
    ))
