"""``lcnav perception frames|bench``: outputs, recording, JSON, and bad input handled before writing."""

from __future__ import annotations

import json

import pandas as pd
import pytest

from studies.cli import main
from tests.rerun_cli import assert_rrd_verifies


def test_frames_writes_images_cloud_recording_and_json(tmp_path, capsys):
    out = tmp_path / "f"
    code = main(["perception", "frames", "--target", "box-wing", "--range", "40", "--seed", "1", "--out", str(out), "--resolution", "256", "--spp", "8",
                 "--json"])
    assert code == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["points"] > 30
    assert summary["median_depth_error_fraction"] < 0.02
    for name in ("left.png", "right.png", "cloud.parquet", "cloud.csv", "summary.json", "frames.rrd"):
        assert (out / name).is_file(), name
    table = pd.read_parquet(out / "cloud.parquet")
    assert len(table) == summary["points"] and (table["z_C_m"] < 0).all()
    assert_rrd_verifies(out / "frames.rrd")


@pytest.mark.parametrize(
    "args, message",
    [
        (["--target", "envisat"], "--target 'envisat': expected one of"),
        (["--range", "2"], "--range 2.0: expected a finite number within [5, 1000] m"),
        (["--resolution", "10"], "--resolution 10: expected an integer within [64, 4096]"),
    ],
)
def test_frames_bad_input_is_one_line_and_writes_nothing(tmp_path, capsys, args, message):
    out = tmp_path / "f"
    code = main(["perception", "frames", "--out", str(out), *args])
    assert code == 2
    err = capsys.readouterr().err
    assert err.startswith("lcnav: error:") and message in err and err.count("\n") == 1
    assert not out.exists()


def test_bench_json(capsys):
    assert main(["perception", "bench", "--poses", "3", "--json"]) == 0
    r = json.loads(capsys.readouterr().out)
    for key in ("median_ms", "p99_ms", "median_rotation_error_deg"):
        assert key in r
    assert r["median_rotation_error_deg"] < 2.0
