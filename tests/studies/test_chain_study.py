"""``lcnav study chain --quick``: rendered light curves -> inversion prior -> filters, with and without it."""

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from studies.cli import main
from studies.recording.reader import export_series
from tests.rerun_cli import assert_rrd_verifies

ARMS = ("none", "tuning", "init")


@pytest.fixture(scope="module")
def chain_out(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("chain") / "out"
    assert main(["study", "chain", "--quick", "--out", str(out)]) == 0
    return out


def test_tables_figures_recordings_exist(chain_out):
    for name in ("runs.parquet", "runs.csv", "summary.parquet", "summary.csv", "summary.md", "lightcurve.parquet",
                 "rate_error.png", "convergence.png"):
        assert (chain_out / name).is_file(), name
    runs = pd.read_parquet(chain_out / "runs.parquet")
    assert list(runs["run_id"]) == ["init-s000", "init-s001"]
    for rid in runs["run_id"]:
        d = chain_out / "runs" / rid
        for name in ("lightcurve.rrd", "spectrum.png", *(f"ekf_{a}.rrd" for a in ARMS)):
            assert (d / name).is_file(), (rid, name)
    summary = pd.read_parquet(chain_out / "summary.parquet")
    assert set(summary["prior"]) == {"no prior", "prior: tuning", "prior: tuning + init"}
    assert set(summary["group"]) == {"q", "w", "r", "v", "k"} and (summary["runs"] == 2).all()


def test_paired_table_is_the_seedwise_difference_and_the_prior_table_scores_every_prior(chain_out):
    """``paired.parquet``: Δ RMSE and Δ t_conv are the means of the per-seed differences of runs.parquet's columns over the seeds
    where both arms converged; ``prior.parquet``: one row per experiment, every prior scored."""
    runs = pd.read_parquet(chain_out / "runs.parquet")
    paired = pd.read_parquet(chain_out / "paired.parquet")
    for arm, label in (("tuning", "prior: tuning"), ("init", "prior: tuning + init")):
        for g in ("w", "r"):
            d = (runs[f"ekf_{arm}_{g}_rmse"].astype(float) - runs[f"ekf_none_{g}_rmse"].astype(float)).dropna()
            row = paired[(paired["filter"] == "ekf") & (paired["prior"] == label) & (paired["group"] == g)].iloc[0]
            assert row["pairs"] == len(d) and row["Δ RMSE mean"] == pytest.approx(d.mean(), rel=1e-12, abs=1e-15)
    prior = pd.read_parquet(chain_out / "prior.parquet")
    assert list(prior["experiment"]) == ["init"] and prior["priors"].iloc[0] == len(runs)
    assert prior["pole error median (°)"].iloc[0] == pytest.approx(runs["prior_pole_err_deg"].astype(float).median())


def test_every_recording_verifies(chain_out):
    rrds = sorted((chain_out / "runs").glob("*/*.rrd"))
    assert len(rrds) == 2 * 4
    assert_rrd_verifies(*rrds)


def test_inspect_export_has_one_row_per_step(chain_out, tmp_path):
    runs = pd.read_parquet(chain_out / "runs.parquet")
    for rid, n_steps in zip(runs["run_id"], runs["n_steps"]):
        out = tmp_path / f"{rid}.parquet"
        assert main(["inspect", str(chain_out / "runs" / rid / "ekf_init.rrd"), "--export", str(out)]) == 0
        assert len(pd.read_parquet(out)) == n_steps == 121


def test_prior_from_inverted_light_curves_recovers_the_spin_and_states_its_uncertainty(chain_out):
    """Per seed: the sidereal rate of the best inversion mode within 2 % of the rendered truth and the truth inside the
    prior's 99.9 % region (the pole is recorded, not asserted: issue 28's search is not yet reliable); a slow rate picks a
    slow tuning. The rocket body is axisymmetric, so the light
    curves cannot tell SC3's axis from SC1's (both lie in the plane ⟂ its symmetry axis): the one/two-axis choice is not
    scored."""
    from scipy.stats import chi2

    runs = pd.read_parquet(chain_out / "runs.parquet")
    assert runs["prior_significant"].all() and runs["prior_available"].all()
    assert (runs["lc_rate_error_pct"].abs() < 2.0).all(), runs["lc_rate_error_pct"].tolist()
    assert np.allclose(runs["lc_rate_error_pct"], 100 * (runs["lc_rate_deg_s"] / runs["lc_truth_rate_deg_s"] - 1))
    assert np.allclose(runs["lc_truth_rate_deg_s"], np.degrees(np.hypot(0.02, 0.045)))  # SC3's |ω_T0|
    assert np.isfinite(runs["prior_pole_err_deg"]).all()
    assert (runs["prior_w_mahalanobis2"] < chi2.ppf(0.999, 3)).all(), runs["prior_w_mahalanobis2"].tolist()
    assert runs["tuning_chosen"].isin(["sc1-conservative", "sc3-conservative"]).all()
    lc = pd.read_parquet(chain_out / "lightcurve.parquet")
    assert lc["max |error| (%)"].iloc[0] < 2.0


def test_prior_as_initial_condition_starts_within_its_stated_uncertainty(chain_out):
    """ω̂_0 from the prior is within 3σ of the prior's covariance (plus the servicer-rate term); from ω̂_0 = 0 the error
    is the whole rate."""
    runs = pd.read_parquet(chain_out / "runs.parquet")
    rid = runs["run_id"].iloc[0]
    without, _ = export_series(chain_out / "runs" / rid / "ekf_none.rrd", ["/estimate/**"])
    with_prior, _ = export_series(chain_out / "runs" / rid / "ekf_init.rrd", ["/estimate/**"])
    e0 = lambda df, name: np.linalg.norm([df[f"/estimate/{name}/error/w_ST_T/{a}/value"].iloc[0] for a in "xyz"])  # noqa: E731
    sigma = float(np.radians(runs["lc_prior_sigma_norm_deg_s"].iloc[0]))
    assert e0(with_prior, "ekf_init") < 3.0 * sigma + 2.5e-3
    assert e0(without, "ekf_none") > np.radians(2.0)
    rec = json.loads((chain_out / "runs" / rid / "metrics.json").read_text())
    assert rec["params"]["experiment"] == "init"


@pytest.mark.parametrize("edit, message", [
    (("cadence_s = 1.0", "cadence_s = 100.0"), "cadence_s 100.0: expected at least 20 light-curve samples"),
    (('target = "atlas-centaur"', 'target = "saturn-v"'), "target 'saturn-v': expected one of"),
    (("proxy_duration_s = 300.0", "proxy_duration_s = 200.0"), "proxy_duration_s 200.0: expected more than"),
])
def test_bad_config_one_line_before_anything_is_written(tmp_path, capsys, edit, message):
    text = (Path(__file__).resolve().parents[2] / "studies" / "catalog" / "configs" / "chain.toml").read_text()
    assert edit[0] in text
    cfg = tmp_path / "chain.toml"
    cfg.write_text(text.replace(edit[0], edit[1]))
    out = tmp_path / "out"
    assert main(["study", "chain", "--config", str(cfg), "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0], err
    assert not out.exists()


def test_a_filter_breakdown_is_counted_not_fatal(tmp_path):
    """A run whose filter raised (P not positive definite) counts as failed and not converged in the summary."""
    from studies.catalog.chain_study import summarise
    from studies.engine.registry import get_study

    config = get_study("chain").load(quick=True)
    base = {"experiment": "init", "scenario": "SC3", "lc_truth_rate_deg_s": 2.82, "prior_significant": True, "lc_rate_deg_s": 2.83,
            "lc_rate_sigma_deg_s": 1e-3, "lc_rate_error_pct": 0.2, "tuning_chosen": "sc3-conservative", "tuning_correct": True,
            "prior_available": True, "prior_sense_right": True, "prior_w_mahalanobis2": 2.0, "prior_pole_err_deg": 0.5, "prior_n_modes": 1,
            "prior_period_err_pct": 1e-4}
    good = {f"ekf_{a}_{g}_{m}": 1.0 for a in ARMS for g in "qwrvk" for m in ("conv_s", "rmse", "filter_conv_s", "filter_rmse")}
    good |= {f"ekf_{a}_failed": "" for a in ARMS}
    bad = dict(good) | {k: None for k in good if k.startswith("ekf_none_") and not k.endswith("failed")}
    bad["ekf_none_failed"] = "ukf: covariance P is not positive definite"
    runs = pd.DataFrame([{"run_id": "init-s000", "seed": 1, **base, **good}, {"run_id": "init-s001", "seed": 2, **base, **bad}])
    summary = summarise(runs, config, tmp_path)[0].frame
    none = summary[(summary["prior"] == "no prior") & (summary["group"] == "w")].iloc[0]
    init = summary[(summary["prior"] == "prior: tuning + init") & (summary["group"] == "w")].iloc[0]
    assert (none["failed"], none["converged"], none["t_conv mean (s)"]) == (1, 0.5, 1.0)
    assert (init["failed"], init["converged"]) == (0, 1.0)
