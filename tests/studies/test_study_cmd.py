"""`lcnav study truth --quick`: runs table, physics of the truth-model check, summary tables, resume."""

import json

import pandas as pd
import pytest

from studies.cli import main
from studies.engine.config import default_config_path, read_toml
from studies.engine.registry import STUDIES, run_study
from studies.engine.sweep import ELAPSED_COLUMN, run_seed


def test_runs_table_has_one_row_per_run_with_derived_seeds(quick_truth):
    runs = pd.read_parquet(quick_truth / "runs.parquet")
    cfg = read_toml(default_config_path("truth"))
    scenarios, n_seeds = cfg["quick"]["scenarios"], cfg["quick"]["n_seeds"]
    expected = [f"{sc}-s{i:03d}" for sc in scenarios for i in range(n_seeds)]
    assert runs["run_id"].tolist() == expected
    assert runs["seed"].tolist() == [run_seed(cfg["seed"], rid) for rid in expected]
    assert len(set(runs["seed"])) == len(runs)
    for col in ["scenario", "duration_s", "rk4_pos_err_max_m", "energy_drift_rel", ELAPSED_COLUMN]:
        assert col in runs.columns
    # the CSV twin holds the same rows
    assert len(pd.read_csv(quick_truth / "runs.csv")) == len(runs)


def test_truth_model_check_physics(quick_truth):
    runs = pd.read_parquet(quick_truth / "runs.parquet")
    # 60 s at 1 s: 61 samples
    assert (runs["n_samples"] == 61).all()
    # RK4 of eq. 21 (0.05 s step) stays within 1 mm of the DOP853 truth over every run
    assert (runs["rk4_pos_err_max_m"] < 1e-3).all() and runs["rk4_within_tolerance"].all()
    assert (runs["rk4_att_err_max_rad"] < 1e-6).all()
    # torque-free target: energy and |H| conserved to integration accuracy
    assert (runs["energy_drift_rel"] < 1e-9).all() and (runs["momentum_drift_rel"] < 1e-9).all()
    assert (runs["quat_norm_err_max"] < 1e-12).all()
    # jittered start about the 50 m along-track offset: ranges of tens of metres, min <= mean <= max
    assert (runs["range_min_m"] <= runs["range_mean_m"]).all() and (runs["range_mean_m"] <= runs["range_max_m"]).all()
    assert runs["range_mean_m"].between(20, 80).all()
    # the random initial attitude differs per run (the seed does something)
    assert runs["range_mean_m"].nunique() == len(runs)


def test_summary_tables(quick_truth):
    runs = pd.read_parquet(quick_truth / "runs.parquet")
    summary = pd.read_parquet(quick_truth / "summary.parquet")
    assert summary["scenario"].tolist() == list(dict.fromkeys(runs["scenario"]))
    assert (summary["runs"] == runs.groupby("scenario", sort=False).size().to_numpy()).all()
    for _, row in summary.iterrows():
        sub = runs[runs["scenario"] == row["scenario"]]
        assert row["mean range (m)"] == pytest.approx(sub["range_mean_m"].mean(), rel=1e-12)
        assert row["range 95% lo"] < row["mean range (m)"] < row["range 95% hi"]
        assert row["worst (mm)"] == pytest.approx(1e3 * sub["rk4_pos_err_max_m"].max(), rel=1e-12)
    md = (quick_truth / "summary.md").read_text()
    assert "Truth-model check" in md and md.count("\n| SC") == len(summary)
    assert (quick_truth / "summary.csv").is_file()
    png = (quick_truth / "rk4_error.png").read_bytes()
    assert png[:8] == b"\x89PNG\r\n\x1a\n" and len(png) > 10_000
    assert json.loads((quick_truth / "study.json").read_text())["quick"] is True


def test_rerun_same_command_skips_every_stored_run(quick_truth, capsys):
    before = pd.read_parquet(quick_truth / "runs.parquet")
    outcome = run_study("truth", quick=True, out=quick_truth, progress=False)
    assert outcome.n_executed == 0 and outcome.n_skipped == len(before)
    pd.testing.assert_frame_equal(outcome.runs, before)


def test_resuming_with_another_config_is_refused(quick_truth, capsys):
    # the full config differs from the quick one stored in study.json
    assert main(["study", "truth", "--out", str(quick_truth)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "another config" in err[0]


def test_every_registered_study_has_a_default_config():
    for name, study in STUDIES.items():
        cfg = study.load(quick=True)
        assert cfg.study == name and study.expand(cfg)
