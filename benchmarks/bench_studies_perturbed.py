"""The tuning, init and proxy studies (Renis et al. §6.1–§6.3) re-run on the perturbed truth with the default filters (issue 31).

``python -m benchmarks studies_perturbed``. Each study runs from its catalog config
(``studies/catalog/configs/<name>.toml``: the light-curve prior, ``prior_source = "lightcurves"``, so no truth reaches it)
with four keys changed: ``truth = "perturbed"`` (gravity gradient, J2, drag, nutation damping: physics the filters only
partly model), ``tuning`` the perturbed world's default (:func:`estimators.tuning.default_tuning`), ``record = false``
and ``n_seeds`` (``$LCNAV_BENCH_STUDIES_SEEDS``, default 20). Both arms of a seed share the measurements and the initial
guess (the studies' pairing), so the effect of the prior is the per-seed difference *with − without*: its mean with a
95 % Student-t interval over the seeds where both are finite (a convergence time is +∞ when the run never converged;
those seeds are counted, not averaged). §6's steady-state RMSE starts at each run's own convergence time, so an arm that
converges sooner lets more of its transient into it; the second-half RMSE (:func:`studies.sim.metrics.late_rmse`) scores
both arms over the same steps.

The tuning study has no ``tuning`` key: its grid is built on ``q_base_tuning``, set to the default, with the base itself
as the grid's last point (``base_point``) and the grid of :data:`TUNING_GRID` about the default's matched budget
(SC1 and SC3, where that budget was derived). Algorithm 1 picks ``KF_sc`` on the first half of the seeds
(:func:`studies.catalog.tuning_study.scores`), and the choice is compared with the default on the other half, which
it was not chosen on: the paired change *chosen − default*. Nothing here is asserted.
"""

from __future__ import annotations

import os
import re
import tempfile
import time
from pathlib import Path

import pandas as pd

from estimators.tuning import default_tuning
from studies.catalog import tuning_study
from studies.engine.registry import get_study, run_study
from studies.catalog.filter_common import paired_change

CONFIGS = Path(__file__).resolve().parent.parent / "studies" / "catalog" / "configs"
SEEDS_ENV = "LCNAV_BENCH_STUDIES_SEEDS"
#: comma-separated names of :data:`STUDIES` to run (default all): the proxy study is the slow one
ONLY_ENV = "LCNAV_BENCH_STUDIES_ONLY"
#: study → (its arm column, the metrics compared: column, label, scale to the printed unit)
STUDIES = {
    "init": ("prior", [(f"ct_{g}_s", f"convergence time {g} (s)", 1.0) for g in ("q", "w", "r", "v", "k")]
             + [("ess_q", "steady RMSE q (mrad)", 1e3), ("ess_w", "steady RMSE ω (mrad/s)", 1e3), ("ess_r", "steady RMSE r (m)", 1.0),
                ("ess_v", "steady RMSE v (mm/s)", 1e3), ("ess_k", "steady RMSE k (×1e-3)", 1e3)]
             + [("late_rmse_q", "second-half RMSE q (mrad)", 1e3), ("late_rmse_w", "second-half RMSE ω (mrad/s)", 1e3),
                ("late_rmse_r", "second-half RMSE r (m)", 1.0), ("late_rmse_v", "second-half RMSE v (mm/s)", 1e3),
                ("late_rmse_k", "second-half RMSE k (×1e-3)", 1e3)]),
    "tuning": ("chosen", [("C_t_s", "C_t, all groups converged (s)", 1.0), ("E_SS", "E_SS (RMSE / threshold)", 1.0),
                          ("nees_per_dof", "NEES/dof from 60 s", 1.0),
                          ("late_rmse_q", "second-half RMSE q (mrad)", 1e3), ("late_rmse_w", "second-half RMSE ω (mrad/s)", 1e3),
                          ("late_rmse_r", "second-half RMSE r (m)", 1.0), ("late_rmse_v", "second-half RMSE v (mm/s)", 1e3)]),
    "proxy": ("proxy", [("fault_w_err_rms_rad_s", "ω error RMS in the fault (mrad/s)", 1e3), ("fault_q_err_rms_rad", "q error RMS in the fault (mrad)", 1e3),
                        ("fault_r_err_rms_m", "r error RMS in the fault (m)", 1.0), ("ess_q", "steady RMSE q after it (mrad)", 1e3),
                        ("ess_w", "steady RMSE ω after it (mrad/s)", 1e3), ("ess_r", "steady RMSE r after it (m)", 1.0),
                        ("ess_v", "steady RMSE v after it (mm/s)", 1e3)]),
}


#: The tuning study's keys besides ``truth``, ``record`` and ``n_seeds``: the grid about the default's matched budget (rate
#: 8.05e-13 rad²/s³, translation 3.85e-11 m²/s³: each block from a hundredth of it to a hundred times it).
TUNING_GRID = {"q_base_tuning": f'"{default_tuning("perturbed")}"', "base_point": "true", "scenarios": '["SC1", "SC3"]',
               "general_scenario": '"SC3"', "q_blocks": '["w_ST_T", "v_ST_T"]', "q_exponents": "[-14, -12, -10]"}


def changed_keys(name: str, n_seeds: int) -> dict[str, str]:
    """The top-level keys of study ``name``'s catalog config that this benchmark changes, with their TOML values."""
    world = {"q_base_tuning": TUNING_GRID["q_base_tuning"]} if name == "tuning" else {"tuning": f'"{default_tuning("perturbed")}"'}
    return {"truth": '"perturbed"', **world, "record": "false", "n_seeds": str(n_seeds), **(TUNING_GRID if name == "tuning" else {})}


def perturbed_config(name: str, n_seeds: int) -> str:
    """The catalog config of study ``name`` as TOML text with the keys of :func:`changed_keys` changed (its comments kept)."""
    text = (CONFIGS / f"{name}.toml").read_text()
    head, sep, quick = text.partition("\n[quick]")
    for key, value in changed_keys(name, n_seeds).items():
        head, n = re.subn(rf"^{key} = [^#\n]*?(\s*#.*)?$", lambda m, k=key, v=value: f"{k} = {v}{m.group(1) or ''}", head, count=1, flags=re.M)
        if n != 1:
            raise RuntimeError(f"{name}.toml: no top-level line '{key} = …' to change")
    return head + sep + quick


def paired_rows(runs: pd.DataFrame, arm: str, metrics) -> list[str]:
    """Markdown rows: per filter and metric, the medians of both arms and the paired change (with − without), mean and 95 % t interval."""
    by_metric = [(label, scale, {r["filter"]: r for r in paired_change(runs, arm, col)}) for col, label, scale in metrics]
    return [f"| {f.upper()} | {label} | {scale * r['without']:.3g} | {scale * r['with']:.3g} | {r['finite_without']} / {r['finite_with']} | "
            f"{scale * r['mean']:+.3g} [{scale * r['lo']:+.3g}, {scale * r['hi']:+.3g}] | {r['seeds']} | {r['lower']} |"
            for f in dict.fromkeys(runs["filter"]) for label, scale, rows in by_metric for r in [rows[f]]]


def prior_line(runs: pd.DataFrame) -> str:
    """How the study's prior (one campaign, shared by every run: the first run with one) scores against the truth; empty without one."""
    cols = ("prior_pole_err_deg", "prior_period_err_pct", "prior_sense_right", "prior_sense_probability", "prior_n_modes",
            "prior_w_err_rad_s", "prior_axis_err_deg", "prior_w_mahalanobis2")
    if not set(cols) <= set(runs.columns) or not (ok := runs["prior_n_modes"].fillna(0) > 0).any():
        return ""
    r = runs[ok].iloc[0]
    return (f"The prior (one rendered campaign, shared by every run): pole {r.prior_pole_err_deg:.2f}° off, period "
            f"{r.prior_period_err_pct:+.1e} % off, sense {'right' if r.prior_sense_right else 'wrong'} (probability "
            f"{r.prior_sense_probability:.2f}), {int(r.prior_n_modes)} mode(s); as `ω_T` {1e3 * r.prior_w_err_rad_s:.1f} mrad/s off "
            f"(body axis {r.prior_axis_err_deg:.1f}° off), Mahalanobis² {r.prior_w_mahalanobis2:.2f} against its covariance.")


def tuning_comparison(runs: pd.DataFrame, config) -> tuple[list[str], pd.DataFrame]:
    """Algorithm 1's choice on the first half of the seeds against the base point (the default) on the other half.

    Returns a line per filter and scenario naming the choice, and the held-out runs of the choice and the base with the
    column ``chosen`` (True for the choice) and ``filter`` relabelled ``<filter> <scenario>``: :func:`paired_rows`' input.
    """
    runs = runs.assign(diverged=runs["diverged"].astype(bool), converged_all=runs["converged_all"].fillna(False).astype(bool))
    n = int(runs["seed_index"].max()) + 1
    tune, test = runs[runs["seed_index"] < n // 2], runs[runs["seed_index"] >= n // 2]
    scored = tuning_study.scores(tune, config)
    base = int(runs["q_index"].max())
    lines, parts = [], []
    for _, b in scored[scored["rank"] == 1].iterrows():
        f, sc, q = b["filter"], b["scenario"], int(b["q_index"])
        label = tuning_study.q_label(b, config["q_blocks"], config["q_base_tuning"])
        lines.append(f"- {f.upper()} {sc}: chosen on seeds 0–{n // 2 - 1}: {label} (point {q}, G {b['G']:.3g}; the default's G "
                     f"{scored[(scored['filter'] == f) & (scored['scenario'] == sc) & (scored['q_index'] == base)]['G'].item():.3g})")
        mine = test[(test["filter"] == f) & (test["scenario"] == sc)]
        parts.append(pd.concat([mine[mine["q_index"] == base].assign(chosen=False), mine[mine["q_index"] == q].assign(chosen=True)])
                     .assign(filter=f"{f} {sc}"))
    return lines, pd.concat(parts, ignore_index=True)


def chosen_studies() -> list[str]:
    """The studies named by ``$LCNAV_BENCH_STUDIES_ONLY`` (all of :data:`STUDIES` when unset), checked."""
    names = [n.strip() for n in os.environ.get(ONLY_ENV, ",".join(STUDIES)).split(",") if n.strip()]
    if not names or set(names) - set(STUDIES):
        raise SystemExit(f"{ONLY_ENV}={os.environ.get(ONLY_ENV)!r}: expected some of {list(STUDIES)}")
    return names


def earlier_subsections(names: list[str], text: str) -> list[str]:
    """The subsections (``### `study` …``) of this benchmark's section in the RESULTS.md ``text`` for the studies of
    :data:`STUDIES` not in ``names``, each headed by the date line of the run that measured it: a run of some studies keeps
    the others' last results (:data:`ONLY_ENV`)."""
    section = re.search(r"<!-- bench:studies_perturbed -->\n(.*?)<!-- /bench:studies_perturbed -->", text, re.S)
    if section is None:
        return []
    body = section.group(1)
    stamp = re.match(r"(_Measured [^\n]*_)", body)
    out = []
    for name in (n for n in STUDIES if n not in names):
        sub = re.search(rf"^### `{name}` .*?(?=^### |\Z)", body, re.S | re.M)
        if sub is not None:
            head, _, rest = sub.group(0).rstrip().partition("\n\n")
            if stamp is not None and not rest.startswith("_Measured"):
                rest = f"{stamp.group(1)}\n\n{rest}"
            out += ["", f"{head}\n\n{rest}"]
    return out


def run() -> str:
    n_seeds = int(os.environ.get(SEEDS_ENV, "20"))
    names = chosen_studies()
    parts = ["## Tuning, init and proxy studies on the perturbed truth with the default filters (issue 31)", "",
             f"Catalog configs with `truth = \"perturbed\"`, `tuning = \"{default_tuning('perturbed')}\"`, {n_seeds} seeds, the light-curve prior "
             "(no truth reaches it). Medians over seeds (a convergence time never reached is +∞); paired change = with − without on the "
             "same measurements, mean and 95 % t interval over the seeds where both arms are finite; 'lower' counts those seeds where "
             "the arm lowered the metric." + ("" if len(names) == len(STUDIES) else
                                              f" Only {', '.join(f'`{n}`' for n in names)} run this time (`{ONLY_ENV}`); the others' "
                                              "results are those of their last run, with its date.")]
    with tempfile.TemporaryDirectory(prefix="lcnav-bench-studies-perturbed-") as tmp:
        for name in names:
            arm, metrics = STUDIES[name]
            cfg = Path(tmp) / f"{name}.toml"
            cfg.write_text(perturbed_config(name, n_seeds))
            t0 = time.perf_counter()
            res = run_study(name, config_path=cfg, out=Path(tmp) / name, progress=False)
            wall = time.perf_counter() - t0
            parts += ["", f"### `{name}` ({len(res.runs)} runs, {wall:.0f} s wall on {os.cpu_count()} local workers)", ""]
            runs, without, with_ = res.runs, "without", f"with {arm}"
            if name == "tuning":
                lines, runs = tuning_comparison(res.runs, get_study(name).load(cfg, quick=False))
                without, with_ = f"{default_tuning('perturbed')} (default)", "Algorithm 1's choice"
                parts += ["Algorithm 1's choice (`KF_sc`) on the first half of the seeds; every figure below is on the other half "
                          "(paired change = choice − default; 0 where the choice is the default):", "", *lines, ""]
            if line := prior_line(runs):
                parts += [line, ""]
            parts += [f"| filter | metric | median {without} | median {with_} | finite without / with | paired change [95 % CI] | seeds | lower |",
                      "|---|---|---|---|---|---|---|---|", *paired_rows(runs, arm, metrics)]
    results = Path(__file__).resolve().parent / "RESULTS.md"
    return "\n".join(parts + earlier_subsections(names, results.read_text() if results.exists() else ""))
