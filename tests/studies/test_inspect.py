"""`lcnav inspect`: every recording verifies, the listing is right, and the export returns the run's data."""


import numpy as np
import pandas as pd
import pytest

from estimators.state import R_ST_T, W_ST_T
from studies.cli import main
from studies.recording.reader import TIME_COLUMN, export_series, summarize_recording
from studies.sim.truth import simulate_truth
from studies.catalog.truth_study import perturbed_scenario
from tests.rerun_cli import assert_rrd_verifies



def test_every_recording_passes_rerun_verify(quick_truth):
    rrds = sorted(quick_truth.glob("runs/*/run.rrd"))
    assert len(rrds) == len(pd.read_parquet(quick_truth / "runs.parquet"))
    assert_rrd_verifies(*rrds)


def test_export_returns_one_row_per_step_with_the_run_data(quick_truth, tmp_path, capsys):
    runs = pd.read_parquet(quick_truth / "runs.parquet")
    row = runs.iloc[-1]
    out = tmp_path / "series.parquet"
    assert main(["inspect", str(quick_truth / "runs" / row["run_id"]), "--export", str(out)]) == 0
    text = capsys.readouterr().out
    assert f"run {row['run_id']!r}" in text and "rk4_pos_err_max_m" in text and "/truth/range_m" in text
    df = pd.read_parquet(out)
    assert len(df) == row["n_samples"] == 61
    np.testing.assert_allclose(df[TIME_COLUMN], np.arange(61.0))
    # the recorded series are the run's: rebuild its truth from the seed and compare
    rng = np.random.default_rng(int(row["seed"]))
    sc = perturbed_scenario(row["scenario"], rng, bool(row["random_attitude"]), float(row["position_jitter_m"]))
    truth = simulate_truth(sc, row["duration_s"], row["dt_s"])
    np.testing.assert_allclose(df["/truth/range_m"], np.linalg.norm(truth.x[:, R_ST_T], axis=1), rtol=1e-12)
    np.testing.assert_allclose(df[[f"/truth/w_ST_T/{a}" for a in "xyz"]], truth.x[:, W_ST_T], rtol=1e-12)
    assert df["/truth/range_m"].mean() == pytest.approx(row["range_mean_m"], rel=1e-12)
    # the RK4 errors in the recording are the metrics of the run
    err = df[[f"/estimate/rk4/error/r_ST_T/{a}/value" for a in "xyz"]].to_numpy()
    assert np.linalg.norm(err, axis=1).max() == pytest.approx(row["rk4_pos_err_max_m"], rel=1e-9)
    # vectors are split per element: the pose translation has 3 float32 columns
    assert {"/truth/target:Transform3D:translation[0]", "/truth/target:Transform3D:translation[2]"} <= set(df.columns)


def test_summary_lists_entities_counts_and_time_range(quick_truth):
    rrd = sorted(quick_truth.glob("runs/*/run.rrd"))[0]
    s = summarize_recording(rrd)
    assert s.recording_id.startswith("truth-") and s.n_blueprints == 1
    assert (s.n_steps, s.t_min_s, s.t_max_s) == (61, 0.0, 60.0)
    by = {(c.entity_path, c.component): c for c in s.columns}
    assert by[("/truth/range_m", "Scalars:scalars")].rows == 61
    assert by[("/truth/target", "Boxes3D:half_sizes")].static


def test_contents_selects_series(quick_truth):
    rrd = sorted(quick_truth.glob("runs/*/run.rrd"))[0]
    df, skipped = export_series(rrd, ["/truth/w_ST_T/**"])
    assert list(df.columns) == [TIME_COLUMN, "/truth/w_ST_T/x", "/truth/w_ST_T/y", "/truth/w_ST_T/z"] and not skipped


def test_inspect_study_folder_lists_runs_and_summary(quick_truth, capsys):
    assert main(["inspect", str(quick_truth)]) == 0
    text = capsys.readouterr().out
    runs = pd.read_parquet(quick_truth / "runs.parquet")
    assert f"{len(runs)} runs" in text and all(rid in text for rid in runs["run_id"]) and "Truth-model check" in text
    assert main(["inspect", str(quick_truth), "--export", "x.parquet"]) == 2
    assert "is a study folder" in capsys.readouterr().err


def test_inspect_simulate_output_folder(tmp_path, capsys):
    out = tmp_path / "sim"
    assert main(["simulate", "--scenario", "SC1", "--duration", "10", "--dt", "0.5", "--out", str(out)]) == 0
    exp = tmp_path / "e.parquet"
    assert main(["inspect", str(out), "--export", str(exp)]) == 0
    assert len(pd.read_parquet(exp)) == len(pd.read_parquet(out / "truth.parquet")) == 21


@pytest.mark.parametrize("args, message", [
    (["/nonexistent/run"], "does not exist"),
    (["{tmp}/x.txt"], "must be a .rrd file or a run folder"),
    (["{tmp}"], "holds no .rrd recording"),
    (["{rrd}", "--export", "{tmp}/x.csv"], "expected a .parquet file name"),
])
def test_inspect_bad_input(quick_truth, tmp_path, capsys, args, message):
    (tmp_path / "x.txt").write_text("x")
    rrd = sorted(quick_truth.glob("runs/*/run.rrd"))[0]
    args = [a.format(tmp=tmp_path, rrd=rrd) for a in args]
    assert main(["inspect", *args]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0], err
