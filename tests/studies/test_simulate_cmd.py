"""`lcnav simulate`: files, columns, recording, and refusal of bad input."""

import subprocess
import sys

import numpy as np
import pandas as pd
import pytest

from studies.cli import main
from studies.recording.truth import equivalent_box_half_sizes
from tests.rerun_cli import assert_rrd_verifies



def test_simulate_writes_truth_table_and_recording(tmp_path):
    out = tmp_path / "run"
    assert main(["simulate", "--scenario", "SC3", "--duration", "20", "--dt", "0.5", "--seed", "1", "--out", str(out)]) == 0
    df = pd.read_parquet(out / "truth.parquet")
    assert len(df) == 41
    for col in ["t_s", "q_TS_0", "q_TS_3", "w_ST_T_x_rad_s", "r_ST_T_z_m", "v_ST_T_y_m_s", "k1", "k2", "r_S_I_x_m", "q_IS_0"]:
        assert col in df.columns
    q = df[[f"q_TS_{i}" for i in range(4)]].to_numpy()
    np.testing.assert_allclose(np.linalg.norm(q, axis=1), 1.0, atol=1e-12)
    # the servicer starts 50 m behind the target: range 50 m
    r = df[[f"r_ST_T_{a}_m" for a in "xyz"]].to_numpy()
    assert np.linalg.norm(r[0]) == pytest.approx(50.0, rel=1e-9)
    assert_rrd_verifies(out / "truth.rrd")


@pytest.mark.parametrize(
    "args, message",
    [
        (["--scenario", "SC9"], "known scenarios: SC1, SC2, SC3, SC4, SC1-NEAR-AXIS, COMBINA"),
        (["--duration", "-5"], "--duration -5.0: expected a finite number within (0, 1e+06] s"),
        (["--duration", "inf"], "--duration inf: expected a finite number"),
        (["--dt", "0"], "--dt 0.0: expected a finite number within (0, 3600] s"),
        (["--dt", "nan"], "--dt nan: expected a finite number"),
        (["--seed", "-1"], "--seed -1: expected an integer within [0, "),
    ],
)
def test_bad_input_one_line_no_output(tmp_path, args, message):
    out = tmp_path / "bad"
    res = subprocess.run(
        [sys.executable, "-m", "studies.cli", "simulate", *args, "--out", str(out)], capture_output=True, text=True
    )
    assert res.returncode != 0
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and message in lines[0] and "Traceback" not in res.stderr
    assert not out.exists()


def test_list_names_every_scenario(capsys):
    assert main(["simulate", "--list"]) == 0
    text = capsys.readouterr().out
    for name in ["SC1", "SC2", "SC3", "SC4", "SC1-NEAR-AXIS", "COMBINA"]:
        assert name in text


def test_equivalent_box_has_the_inertia_ratios():
    J = np.array([4.33, 1.0, 4.22])
    a, b, c = equivalent_box_half_sizes(J)
    I = np.array([b * b + c * c, a * a + c * c, a * a + b * b])
    np.testing.assert_allclose(I / I[1], J / J[1], rtol=1e-12)
