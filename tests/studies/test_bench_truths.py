"""``python -m benchmarks truths`` keeps its rows as they finish: a row that raises is reported, the others are kept."""

import json

import numpy as np

from benchmarks import bench_truths


def _fake_row(case):
    if case[0] == "SC1":
        raise np.linalg.LinAlgError("Matrix is not positive definite")
    return {"scenario": case[0], "runs": np.int64(case[4]), "nees_per_dof": np.float64(0.98)}


def test_a_failing_row_is_reported_and_the_others_are_kept(tmp_path, monkeypatch):
    monkeypatch.setattr(bench_truths, "ROWS_FILE", tmp_path / "rows.json")
    monkeypatch.setattr(bench_truths, "_row", _fake_row)  # the workers are forked: they see the patched module
    cases = [("SC1", "torque-free", "ekf", 5700.0, 4, 1.0), ("SC3", "perturbed", "ekf", 5700.0, 4, 1.0)]
    kept = {}
    bench_truths._measure(cases, kept)
    on_disk = json.loads((tmp_path / "rows.json").read_text())
    assert on_disk == kept
    sc1, sc3 = (kept[bench_truths._key(c)] for c in cases)
    assert sc1["error"] == "LinAlgError: Matrix is not positive definite" and "nees_per_dof" not in sc1
    assert sc3["nees_per_dof"] == 0.98 and sc3["runs"] == 4 and sc3["commit"] and sc3["date"]
    # measured again: the failed row and one asked with more runs than kept; not the finished one, nor one asked with fewer
    assert bench_truths._missing(cases[0], kept) and not bench_truths._missing(cases[1], kept)
    assert bench_truths._missing(("SC3", "perturbed", "ekf", 5700.0, 30, 1.0), kept)
    assert not bench_truths._missing(("SC3", "perturbed", "ekf", 5700.0, 2, 1.0), kept)
    kept[bench_truths._key(cases[1])]["diverged"] = 26  # 4 runs kept and 26 diverged: 30 asked, 30 run
    assert not bench_truths._missing(("SC3", "perturbed", "ekf", 5700.0, 30, 1.0), kept)
