"""`lcnav combina`: files, recording, and refusal of bad input."""

import json

import pandas as pd
import pytest

from studies.cli import main
from tests.rerun_cli import assert_rrd_verifies



def test_combina_quick_writes_metrics_states_and_recording(tmp_path):
    out = tmp_path / "run"
    assert main(["combina", "--target", "atlas-centaur", "--pose-source", "simulated", "--duration-tu", "2", "--quick", "--seed", "3",
                 "--truth", "perturbed", "--out", str(out)]) == 0
    m = json.loads((out / "metrics.json").read_text())
    assert m["truth"] == "perturbed"
    assert m["symmetry_detected"] and m["mode"] == "axisymmetric"
    for name in ("r", "v", "sigma", "w", "k", "phi", "delta", "gamma_over_a"):
        assert set(m["components"][name]) >= {"converged", "final_error", "fraction_within_3sigma"}
    assert set(m["gate_counts"]) >= {"accepted", "rejected_scale", "rejected_mahalanobis"}
    df = pd.read_parquet(out / "states.parquet")
    assert len(df) == 1 + int(0.25 * 963.65 * 0.33)
    assert {"t_s", "mode", "est_r_L_m_x", "sd_r_L_m_x", "true_r_L_m_x", "meas_scale", "accepted_translation"} <= set(df.columns)
    assert_rrd_verifies(out / "combina.rrd")


@pytest.mark.parametrize(
    "args, message",
    [
        (["--target", "cube"], "--target 'cube': expected a body: box-wing or atlas-centaur"),
        (["--target", "symmetric"], "--target 'symmetric': expected a body: box-wing or atlas-centaur (renamed: --target symmetric is now "
         "--target atlas-centaur)"),
        (["--measurements", "rendered"], "--measurements 'rendered': expected --pose-source simulated|rendered (renamed;"),
        (["--rate-hz", "0"], "--rate-hz 0.0: expected a finite number within (0, 10] Hz"),
        (["--rate-hz", "-1"], "--rate-hz -1.0: expected a finite number within (0, 10] Hz"),
        (["--duration-tu", "0"], "--duration-tu 0.0: expected a finite number within (0, 100] TU"),
        (["--duration-tu", "-2"], "--duration-tu -2.0: expected a finite number"),
        (["--prior", "maybe"], "prior must be one of none|init|proxy"),
        (["--prior-error", "2"], "--prior-error 2.0: expected a finite number within (0, 1)"),
        (["--truth", "gravity"], "--truth 'gravity': expected torque-free or perturbed"),
    ],
)
def test_bad_input_one_line_nonzero_nothing_written(tmp_path, capsys, args, message):
    out = tmp_path / "run"
    assert main(["combina", *args, "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert message in err and len(err.splitlines()) == 1
    assert not out.exists()


def test_rendered_quick_runs_the_whole_chain(tmp_path):
    """Mitsuba stereo -> OpenCV cloud -> BCPD (eqs 3-8) -> both UKFs: at least one measurement accepted."""
    out = tmp_path / "rendered"
    assert main(["combina", "--target", "box-wing", "--pose-source", "rendered", "--quick", "--seed", "1", "--out", str(out)]) == 0
    m = json.loads((out / "metrics.json").read_text())
    assert m["gate_counts"]["by_filter"]["translation"]["accepted"] >= 1
    assert m["gate_counts"]["by_filter"]["attitude"]["accepted"] >= 1
    df = pd.read_parquet(out / "states.parquet")
    rendered = df[df["meas_kind"] == "rendered"]
    assert len(rendered) >= 1
    # registered positions within 1 m of the truth (the filter's 1-sigma at start is ~3.8 m)
    err = (rendered[[f"meas_r_L_m_{a}" for a in "xyz"]].to_numpy() - rendered[[f"true_r_L_m_{a}" for a in "xyz"]].to_numpy())
    assert (abs(err).max(axis=1) < 1.0).mean() >= 0.9
    assert_rrd_verifies(out / "combina.rrd")
