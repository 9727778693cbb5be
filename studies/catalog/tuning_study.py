"""Study ``tuning``: ``Q_d`` tuning by orders of magnitude (Renis et al. §6.1, Algorithm 1, Tables 2 and 3).

For every ``Q_d`` on the grid (each block of ``q_blocks`` takes every
``10**e``, ``e`` in ``q_exponents``; the other blocks keep ``q_base_tuning``'s
values), every scenario and every filter, ``n_seeds`` runs (the same seeds for
every ``Q_d``: paired comparisons). Per run (:func:`run_score_terms`):

* ``C_t`` = the time from which *every* tracked group (``k`` only in two-axis
  tumbles, where it is estimated) stays below its threshold — the latest of
  the groups' convergence times (§6); the run length if a group never converges;
* ``E_SS`` = the mean over the tracked groups of the group's steady-state
  RMSE divided by its threshold (dimensionless, so radians and metres add up);
  for a group that never converged, its RMSE over the whole run.

Algorithm 1's score, per filter and scenario over the grid: the seed means of
``C_t`` and ``E_SS`` normalised min–max to [0, 1], then
``G = λ C_t + (1 − λ) E_SS`` (lower is better; the paper's "highest score" is
this one's lowest). ``KF_sc`` is the best ``Q_d`` per scenario, ``KF_gen`` the
best on ``general_scenario``. A run where the filter breaks down (``P`` no
longer positive definite, NaN/Inf) is stored as ``diverged`` with the reason,
and its grid point is disqualified (no score, ranked last): the UKF does this
on parts of the grid, as the paper warns. Tables 2 and 3: per filter, group and scenario,
the median convergence time and steady-state RMSE of ``KF_sc`` and, next to
it, of ``KF_gen`` on the same seeds. The selection uses the same runs it
reports (the paper does the same), so ``KF_sc``'s figures are optimistic by
the selection; ``tuning_scores.png`` shows ``G`` over the grid.

A grid point is ``q_base_tuning`` with only its grid blocks' intensities changed: its settling phase, re-linearisation
window and process model are kept, so the grid tunes the filter a user runs (``fixed-lag`` in orbit, beyond the
paper). Where the base carries a matched budget (:class:`estimators.process_noise.MatchedBudget`) the ``w_ST_T``,
``v_ST_T`` and ``k`` blocks set its intensities (the same units, rad²/s³, m²/s³ and 1/s, discretised with their
cross terms, eq. 1 of :mod:`estimators.process_noise`) instead of adding a diagonal ``Q_d``. ``base_point`` adds the
base tuning itself as the last point: what the grid's choice is measured against. Each run also records its NEES/dof
after :data:`studies.sim.metrics.SETTLING_S` (considered states left out): Algorithm 1 scores accuracy only, and
the chosen ``Q_d``'s consistency is reported beside it.
"""

from __future__ import annotations

import dataclasses
import itertools
from pathlib import Path

import numpy as np
import pandas as pd

from estimators.navigation import FILTERS
from estimators.process_noise import DisturbanceBudget
from estimators.state import ERROR_GROUPS, N_ERROR
from estimators.tuning import TUNINGS, Tuning, get_tuning
from studies.catalog.figures import pyplot, save_png
from studies.catalog.filter_common import COMMON_FIELDS, COMMON_RUN_FIELDS, check_common, metric_tables, pose_noise, thresholds
from studies.engine.config import ConfigError, Field, StudyConfig
from studies.sim.metrics import GROUPS, SETTLING_S, nees
from studies.recording.navigation import record_navigation
from studies.sim.navigation import NavigationSetup, considered_states, error_series, navigate, one_axis, run_metrics
from studies.sim.scenarios import SCENARIOS, get_scenario
from studies.engine.sweep import RunSpec, make_specs
from studies.engine.tables import Table
from studies.sim.truth import simulate_truth

TITLE = "Q_d tuning by orders of magnitude (Renis et al. §6.1, Algorithm 1): scenario-specific vs general filter"

#: Grid block name -> metric group / error-state slice.
BLOCKS = {"q_TS": "q", "w_ST_T": "w", "r_ST_T": "r", "v_ST_T": "v", "k": "k"}
#: Grid block -> the :class:`estimators.process_noise.MatchedBudget` intensity it sets when the base tuning has one.
BUDGET_FIELDS = {"w_ST_T": "q_alpha_rad2_s3", "v_ST_T": "q_a_m2_s3", "k": "q_kdot_1_s"}

FIELDS: dict[str, Field] = {
    "filters": Field("list[str]", "Filters to tune.", choices=tuple(FILTERS)),
    "scenarios": Field("list[str]", "Scenarios of Algorithm 1.", choices=tuple(s for s in SCENARIOS if s.startswith("SC"))),
    "general_scenario": Field("str", "KF_gen = best Q_d on this scenario (Renis et al. §6.1: SC4).", choices=tuple(s for s in SCENARIOS if s.startswith("SC"))),
    "n_seeds": Field("int", "Seeds per (filter, scenario, Q_d), shared by every Q_d.", ge=1),
    "duration_s": Field("float", "Simulated time per run, s.", gt=0),
    "dt_s": Field("float", "Filter step = measurement period tau_s, s.", gt=0),
    "q_blocks": Field("list[str]", "Q_d blocks on the grid.", choices=tuple(BLOCKS)),
    "q_exponents": Field("list[int]", "Each grid block's variance rate takes 10**exponent for these exponents."),
    "q_base_tuning": Field("str", "Named tuning giving the blocks off the grid, P_0 and R_d.", choices=tuple(TUNINGS), default="general-conservative"),
    "score_weight": Field("float", "lambda of G = lambda*C_t + (1 - lambda)*E_SS.", ge=0, le=1, default=0.5),
    "base_point": Field("bool", "Also run q_base_tuning itself as the grid's last point (what the grid's choice is measured against).",
                        default=False),
    **COMMON_FIELDS,
}
_RUN_FIELDS = ("duration_s", "dt_s", "q_base_tuning", *COMMON_RUN_FIELDS)


def check(params: dict) -> None:
    """Distinct blocks and exponents; the general scenario is among the scenarios; a step fits the run."""
    for name in ("q_blocks", "q_exponents", "scenarios", "filters"):
        if len(set(params[name])) != len(params[name]):
            raise ConfigError(f"{name} {params[name]}: expected no repeated item")
    if params["general_scenario"] not in params["scenarios"]:
        raise ConfigError(f"general_scenario {params['general_scenario']!r}: expected one of scenarios {params['scenarios']}")
    if not all(-20 <= e <= 5 for e in params["q_exponents"]):
        raise ConfigError(f"q_exponents {params['q_exponents']}: expected integers in [-20, 5]")
    if isinstance(get_tuning(params["q_base_tuning"]).budget, DisturbanceBudget):
        raise ConfigError(f"q_base_tuning {params['q_base_tuning']!r}: its Q_d is a disturbance σ budget, not intensities a grid can set; "
                          "expected a tuning with a matched budget or none")
    if params["dt_s"] > params["duration_s"] / 2:
        raise ConfigError(f"dt_s {params['dt_s']}: expected at most half of duration_s = {params['duration_s']} s")
    check_common(params)


def grid(config) -> list[dict[str, int]]:
    """The Q_d grid: one ``{block: exponent}`` per point, the product over ``q_blocks``; with ``base_point``, an empty
    dict last (the base tuning unchanged)."""
    points = [dict(zip(config["q_blocks"], e)) for e in itertools.product(config["q_exponents"], repeat=len(config["q_blocks"]))]
    return points + [{}] if config["base_point"] else points


def expand(config: StudyConfig) -> list[RunSpec]:
    """Filters × scenarios × grid × seeds; run ids ``<filter>-<scenario>-q<index>-s<index>``, seeded per (scenario, seed).
    The base point's exponents are NaN."""
    common = {k: config[k] for k in _RUN_FIELDS}
    points = grid(config)
    return make_specs(config.seed, (
        (f"{f}-{sc}-q{j:03d}-s{i:03d}",
         {"filter": f, "scenario": sc, "q_index": j, **{f"q_exp_{b}": float(pt.get(b, np.nan)) for b in config["q_blocks"]}, "seed_index": i,
          **common},
         f"{sc}-s{i:03d}")
        for f in config["filters"] for sc in config["scenarios"] for j, pt in enumerate(points) for i in range(config["n_seeds"])
    ))


def grid_tuning(params) -> Tuning:
    """The tuning of a grid point: ``q_base_tuning`` with the grid blocks' intensities set to ``10**exponent`` — in its
    matched budget where it has one and the block is one of :data:`BUDGET_FIELDS`, else in its diagonal rate — and
    everything else (``P_0``, settling phase, window, process model) kept. A point without exponents is the base itself."""
    base = get_tuning(params["q_base_tuning"])
    exps = {b: params[f"q_exp_{b}"] for b in BLOCKS if params.get(f"q_exp_{b}") is not None and np.isfinite(params[f"q_exp_{b}"])}
    if not exps:
        return base
    if isinstance(base.budget, DisturbanceBudget):
        raise ValueError(f"tuning {base.name!r}: a σ disturbance budget has no intensities for the grid to set")
    q = base.q_rate.copy()
    budget = {}
    for block, e in exps.items():
        if base.budget is not None and block in BUDGET_FIELDS:
            budget[BUDGET_FIELDS[block]] = 10.0 ** e
        else:
            q[ERROR_GROUPS[BLOCKS[block]]] = 10.0 ** e
    return dataclasses.replace(base, name=f"grid-{params.get('q_index', 0)}", q_rate=q,
                               budget=dataclasses.replace(base.budget, **budget) if budget else base.budget)


def tracked_groups(scenario: str) -> list[str]:
    """The groups a filter estimates on ``scenario``: all but ``k`` in one-axis tumbles (considered there)."""
    return [g for g in GROUPS if not (g == "k" and one_axis(get_scenario(scenario).w_T0_T_rad_s))]


def run_score_terms(errors: pd.DataFrame, metrics: dict, groups, th: dict, duration_s: float) -> dict:
    """``C_t`` (s) and ``E_SS`` (dimensionless) of one run, as defined in the module docstring."""
    cts = [metrics[f"ct_{g}_s"] for g in groups]
    converged = all(np.isfinite(cts))
    ess = [(metrics[f"ess_{g}"] if np.isfinite(metrics[f"ess_{g}"]) else float(np.sqrt(np.mean(errors[f"err_{g}"] ** 2)))) / th[g] for g in groups]
    return {"C_t_s": float(max(cts)) if converged else float(duration_s), "E_SS": float(np.mean(ess)), "converged_all": bool(converged)}


def execute(spec: RunSpec, workdir: Path) -> dict:
    """One filter run with the grid point's Q_d."""
    p = spec.params
    rng = np.random.default_rng(spec.seed)
    sc = get_scenario(p["scenario"])
    tr = simulate_truth(sc, p["duration_s"], p["dt_s"], p["truth"])
    setup = NavigationSetup(p["filter"], grid_tuning(p), pose_noise=pose_noise(p), gate_confidence=p["gate_confidence"],
                            gate_start_s=p["gate_start_s"], consider=considered_states(sc, p["truth"]),
                            inertia_range=tuple(p["inertia_guess_range"]))
    try:
        run, meas = navigate(tr, setup, rng)
    except ValueError as e:  # the filter broke down on this Q_d (P not positive definite, NaN/Inf): a result of the grid
        return {"n_steps": len(tr.t), "diverged": True, "failure": str(e)}
    th = thresholds(p)
    metrics = run_metrics(tr, run, th)
    errors = error_series(tr, run)
    if p["record"]:
        record_navigation(workdir / "run.rrd", tr, run, meas, recording_id=f"tuning-{spec.run_id}")
    return {"n_steps": len(tr.t), "diverged": False, "failure": "", **metrics, "nees_per_dof": settled_nees_per_dof(tr, run, setup.consider),
            **run_score_terms(errors, metrics, tracked_groups(p["scenario"]), th, p["duration_s"])}


def settled_nees_per_dof(tr, run, consider) -> float:
    """The run's mean NEES per degree of freedom over the steps from :data:`SETTLING_S` on, the ``consider``-ed states left out."""
    states = np.setdiff1d(np.arange(N_ERROR), consider)
    sel = (tr.t - tr.t[0]) >= SETTLING_S
    return float(np.mean(nees(run.x[sel], run.P[sel], tr.x[sel], states)) / len(states))


def scores(runs: pd.DataFrame, config) -> pd.DataFrame:
    """Algorithm 1: per filter, scenario and grid point, seed means of C_t and E_SS, normalised over the grid, and G."""
    blocks = [f"q_exp_{b}" for b in config["q_blocks"]]
    runs = runs.assign(C_t_s=runs["C_t_s"].astype(float), E_SS=runs["E_SS"].astype(float),
                       nees_per_dof=runs["nees_per_dof"].astype(float) if "nees_per_dof" in runs else np.nan)
    g = runs.groupby(["filter", "scenario", "q_index", *blocks], sort=False, dropna=False).agg(
        runs=("C_t_s", "size"), diverged=("diverged", "sum"), converged=("converged_all", "sum"),
        C_t_s=("C_t_s", "mean"), E_SS=("E_SS", "mean"), nees_per_dof=("nees_per_dof", "mean")).reset_index()
    # a point where the filter broke down on any seed is disqualified: no score, ranked last
    g.loc[g["diverged"] > 0, ["C_t_s", "E_SS"]] = np.nan

    def minmax(x):
        span = x.max() - x.min()
        return (x - x.min()) / span if span > 0 else x * 0.0

    key = g.groupby(["filter", "scenario"], sort=False)
    g["C_t_norm"] = key["C_t_s"].transform(minmax)
    g["E_SS_norm"] = key["E_SS"].transform(minmax)
    lam = config["score_weight"]
    g["G"] = lam * g["C_t_norm"] + (1 - lam) * g["E_SS_norm"]
    g["rank"] = g.groupby(["filter", "scenario"], sort=False)["G"].rank(method="first", na_option="bottom").astype(int)
    return g


def best_points(sc: pd.DataFrame, config) -> pd.DataFrame:
    """Per filter and scenario: the KF_sc grid point (lowest G) and the filter's KF_gen point."""
    best = sc[sc["rank"] == 1].copy()
    gen = best[best["scenario"] == config["general_scenario"]].set_index("filter")["q_index"]
    best["gen_q_index"] = best["filter"].map(gen)
    return best


def q_label(row, blocks, base: str) -> str:
    """A grid point's ``Q_d`` in words: each block's ``1e<exponent>``, or ``<base> (base)`` for the base point."""
    if not any(np.isfinite(row[f"q_exp_{b}"]) for b in blocks):
        return f"{base} (base)"
    return ", ".join(f"{b} 1e{int(row[f'q_exp_{b}'])}" for b in blocks)


def summarise(runs: pd.DataFrame, config: StudyConfig, out_dir: Path) -> list[Table]:
    """Tables 2 and 3 (KF_sc, and KF_gen in brackets as its own column), the chosen Q_d, the grid's scores; the scores figure."""
    runs = runs.assign(diverged=runs["diverged"].astype(bool), converged_all=runs["converged_all"].fillna(False).astype(bool))
    sc_table = scores(runs, config)
    best = best_points(sc_table, config)
    blocks = list(config["q_blocks"])
    conv_parts, ess_parts, stats_parts = [], [], []
    for f in dict.fromkeys(runs["filter"]):
        arms = []
        for _, b in best[best["filter"] == f].iterrows():
            s = b["scenario"]
            arms.append((f"{s} sc", f"filter == '{f}' and scenario == '{s}' and q_index == {int(b['q_index'])}"))
            arms.append((f"{s} (gen)", f"filter == '{f}' and scenario == '{s}' and q_index == {int(b['gen_q_index'])}"))
        groups = [g for g in GROUPS if any(g in tracked_groups(s) for s in config["scenarios"])]
        conv, ess, stats = metric_tables(runs, arms, groups, confidence=config["confidence"])
        for part, lst in ((conv, conv_parts), (ess, ess_parts), (stats, stats_parts)):
            lst.append(part.assign(filter=f.upper())[["filter", *part.columns]])
    base = config["q_base_tuning"]
    gen = sc_table.set_index(["filter", "scenario", "q_index"])
    gen_rows = [gen.loc[(r["filter"], r["scenario"], int(r["gen_q_index"]))] for _, r in best.iterrows()]
    chosen = best.assign(filter=best["filter"].str.upper(), KF_sc=best.apply(lambda r: q_label(r, blocks, base), axis=1),
                         KF_gen=[q_label(r, blocks, base) for r in gen_rows])
    chosen["G of KF_gen"] = [r["G"] for r in gen_rows]
    chosen["NEES/dof of KF_gen"] = [r["nees_per_dof"] for r in gen_rows]
    chosen = chosen[["filter", "scenario", "q_index", "KF_sc", "G", "C_t_s", "E_SS", "nees_per_dof", "converged", "runs", "gen_q_index", "KF_gen",
                     "G of KF_gen", "NEES/dof of KF_gen"]].rename(
        columns={"q_index": "KF_sc point", "G": "G of KF_sc", "C_t_s": "mean C_t (s)", "E_SS": "mean E_SS", "nees_per_dof": "NEES/dof of KF_sc",
                 "gen_q_index": "KF_gen point"})
    n_pts = len(grid(config))
    notes = (f"{n_pts} Q_d points ({', '.join(blocks)} over 1e{config['q_exponents']}; other blocks from '{config['q_base_tuning']}'"
             f"{', and that tuning itself as the last point' if config['base_point'] else ''}), "
             f"{config['n_seeds']} seeds each (the same for every point), {config['duration_s']:g} s at {config['dt_s']:g} s. "
             f"Columns 'SCn sc': the scenario-specific filter KF_sc; 'SCn (gen)': KF_gen (best on {config['general_scenario']}) on the same seeds "
             "(the paper's brackets). Medians over seeds; a run that did not converge counts as +∞ ('–': most runs did not converge). "
             "k is considered, not estimated, in one-axis scenarios (SC1, SC2).")
    plot_scores(sc_table, best, config, out_dir / "tuning_scores.png")
    return [
        Table("summary", "Table 2 analogue: convergence time (s), KF_sc vs KF_gen, median over seeds", pd.concat(conv_parts, ignore_index=True), notes,
              default_format=".1f"),
        Table("table3", "Table 3 analogue: steady-state RMSE (x1e-3), KF_sc vs KF_gen, median over seeds", pd.concat(ess_parts, ignore_index=True), notes,
              default_format=".3g"),
        Table("chosen",
              f"Chosen Q_d per filter and scenario (G = {config['score_weight']:g} C_t + {1 - config['score_weight']:g} E_SS, normalised over the grid)",
              chosen, "Lower G is better; C_t: time all tracked groups converged (run length if never); E_SS: mean over groups of RMSE / threshold; "
              f"NEES/dof: mean over seeds of each run's mean from {SETTLING_S:g} s on (1 when consistent; Algorithm 1 does not score it).",
              default_format=".3g"),
        Table("scores", "Algorithm 1 scores over the grid", sc_table, default_format=".3g"),
        Table("statistics", "Every metric of KF_sc and KF_gen: runs converged, mean with t interval, median with order-statistic interval",
              pd.concat(stats_parts, ignore_index=True), default_format=".4g"),
    ]


def plot_scores(sc_table: pd.DataFrame, best: pd.DataFrame, config, path: Path) -> None:
    """``tuning_scores.png``: G over the grid (points × scenarios) per filter, KF_sc circled, KF_gen's point marked."""
    plt = pyplot()

    filters = list(dict.fromkeys(sc_table["filter"]))
    scen = list(config["scenarios"])
    n_pts = int(sc_table["q_index"].max()) + 1
    fig, axes = plt.subplots(len(filters), 1, figsize=(max(6.0, 0.16 * n_pts + 2.5), 1.0 + 0.55 * len(scen) * len(filters) + 0.8), layout="constrained",
                             squeeze=False)
    for ax, f in zip(axes[:, 0], filters):
        G = np.full((len(scen), n_pts), np.nan)
        for _, r in sc_table[sc_table["filter"] == f].iterrows():
            G[scen.index(r["scenario"]), int(r["q_index"])] = r["G"]
        im = ax.imshow(G, aspect="auto", cmap="viridis_r", vmin=0, vmax=1)
        for _, b in best[best["filter"] == f].iterrows():
            ax.plot(b["q_index"], scen.index(b["scenario"]), "o", mfc="none", mec="r", ms=9, label="KF_sc" if b["scenario"] == scen[0] else None)
            ax.plot(b["gen_q_index"], scen.index(b["scenario"]), "x", color="w", ms=7, label="KF_gen" if b["scenario"] == scen[0] else None)
        ax.set(yticks=range(len(scen)), yticklabels=scen, xlabel="Q_d grid point", title=f"{f.upper()}: score G (lower is better)")
        ax.legend(fontsize=7, loc="upper right")
        fig.colorbar(im, ax=ax, label="G")
    save_png(fig, path)
