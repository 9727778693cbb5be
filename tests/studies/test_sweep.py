"""Sweeps: per-run seeds, a real Dask cluster on loopback gives the local table, a killed sweep resumes."""

import json
import os
import re
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from studies.cli import main
from studies.recording.reader import export_series
from studies.engine.sweep import ELAPSED_COLUMN, RESULT_FILE, dask_client, make_specs, run_seed

DASK = Path(sys.executable).with_name("dask")


def test_run_seeds_depend_on_study_seed_and_run_id_only():
    ids = [f"SC{i}-s{j:03d}" for i in range(1, 5) for j in range(50)]
    seeds = [run_seed(7, r) for r in ids]
    assert len(set(seeds)) == len(ids)  # no collisions
    assert all(0 <= s < 2**63 for s in seeds)
    assert [run_seed(7, r) for r in reversed(ids)] == seeds[::-1]  # order does not matter
    assert run_seed(8, ids[0]) != seeds[0]
    # streams of neighbouring runs are uncorrelated: |corr| of 10 000 normals below 5 sigma
    a = np.random.default_rng(seeds[0]).standard_normal(10_000)
    b = np.random.default_rng(seeds[1]).standard_normal(10_000)
    assert abs(np.corrcoef(a, b)[0, 1]) < 5 / np.sqrt(10_000)


def test_paired_runs_share_their_seed():
    specs = make_specs(3, [("SC3-prior-s000", {"prior": True}, "SC3-s000"), ("SC3-none-s000", {"prior": False}, "SC3-s000"),
                           ("SC3-prior-s001", {"prior": True}, "SC3-s001"), ("solo", {})])
    assert specs[0].seed == specs[1].seed == run_seed(3, "SC3-s000") != specs[2].seed
    assert specs[3].seed == run_seed(3, "solo")


@pytest.mark.parametrize("runs, message", [
    ([("a", {}), ("a", {})], "appears twice"),
    ([("../x", {})], "must be 1-128 letters"),
    ([("ok", {"p": object()})], "not JSON serializable"),
])
def test_make_specs_refuses_bad_runs(runs, message):
    with pytest.raises((ValueError, TypeError), match=message):
        make_specs(1, runs)


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_unreachable_scheduler_is_a_clear_error():
    address = f"tcp://127.0.0.1:{_free_port()}"  # nothing listens there
    with pytest.raises(ValueError, match=f"--scheduler {address}: no Dask scheduler answered within 1 s"):
        with dask_client(address, connect_timeout_s=1.0):
            pass


@pytest.fixture
def loopback_cluster(lcnav_env):
    """A real `dask scheduler` and a `dask worker` (2 processes) on 127.0.0.1."""
    from distributed import Client

    port = _free_port()
    address = f"tcp://127.0.0.1:{port}"
    env = lcnav_env
    procs = [subprocess.Popen([str(DASK), "scheduler", "--host", "127.0.0.1", "--port", str(port), "--no-dashboard"],
                              env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)]
    try:
        procs.append(subprocess.Popen([str(DASK), "worker", address, "--nworkers", "2", "--nthreads", "1", "--host", "127.0.0.1",
                                       "--no-dashboard"], env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
        with Client(address, timeout="30s") as c:
            c.wait_for_workers(2, timeout=60)
        yield address
    finally:
        for p in reversed(procs):
            p.terminate()
        for p in procs:
            try:
                p.wait(timeout=20)
            except subprocess.TimeoutExpired:
                p.kill()


def test_scheduler_cluster_gives_the_local_table(quick_truth, loopback_cluster, tmp_path, capsys):
    out = tmp_path / "remote"
    assert main(["study", "truth", "--quick", "--scheduler", loopback_cluster, "--out", str(out)]) == 0
    local = pd.read_parquet(quick_truth / "runs.parquet").drop(columns=ELAPSED_COLUMN)
    remote = pd.read_parquet(out / "runs.parquet").drop(columns=ELAPSED_COLUMN)
    pd.testing.assert_frame_equal(remote, local, check_exact=True)
    pd.testing.assert_frame_equal(pd.read_parquet(out / "summary.parquet"), pd.read_parquet(quick_truth / "summary.parquet"),
                                  check_exact=True)
    # the recordings made on the cluster hold the same series
    rid = local["run_id"].iloc[-1]
    a, _ = export_series(quick_truth / "runs" / rid / "run.rrd")
    b, _ = export_series(out / "runs" / rid / "run.rrd")
    pd.testing.assert_frame_equal(a, b, check_exact=True)


def test_killed_sweep_resumes_with_every_run_exactly_once(tmp_path, lcnav_env):
    # slow enough runs (600 s at 0.01 s RK4 steps) on one worker, so the kill lands mid-sweep
    cfg = tmp_path / "slow.toml"
    cfg.write_text('study = "truth"\nseed = 5\nscenarios = ["SC3", "SC4"]\nn_seeds = 4\nduration_s = 600.0\n'
                   'dt_s = 1.0\nrk4_dt_s = 0.01\nrecord = true\n')
    out = tmp_path / "out"
    cmd = [sys.executable, "-m", "studies.cli", "study", "truth", "--config", str(cfg), "--out", str(out), "--workers", "1"]
    proc = subprocess.Popen(cmd, env=lcnav_env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
    try:
        # no wall-time bound: the sweep either writes a result or ends (8 finite runs), so the wait ends either way
        while not list(out.glob(f"runs/*/{RESULT_FILE}")):
            assert proc.poll() is None, "the sweep ended before writing a result"
            time.sleep(0.05)
    finally:
        os.killpg(proc.pid, signal.SIGKILL)  # the command and its local Dask cluster
        proc.wait()
    done = {p.parent.name: p.stat().st_mtime_ns for p in out.glob(f"runs/*/{RESULT_FILE}")}
    assert 1 <= len(done) < 8, f"the kill should land mid-sweep, {len(done)} of 8 runs were done"
    assert not (out / "runs.parquet").exists()

    res = subprocess.run(cmd, env=lcnav_env, capture_output=True, text=True, timeout=300)
    assert res.returncode == 0, res.stderr
    m = re.search(r"(\d+) runs executed, (\d+) already stored", res.stdout)
    assert m and (int(m.group(1)), int(m.group(2))) == (8 - len(done), len(done))
    runs = pd.read_parquet(out / "runs.parquet")
    expected = [f"{sc}-s{i:03d}" for sc in ("SC3", "SC4") for i in range(4)]
    assert runs["run_id"].tolist() == expected  # every run, once, in order
    # the runs stored before the kill were not executed again
    assert {rid: (out / "runs" / rid / RESULT_FILE).stat().st_mtime_ns for rid in done} == done
    for rid in expected:
        rec = json.loads((out / "runs" / rid / RESULT_FILE).read_text())
        assert rec["run_id"] == rid and (out / "runs" / rid / "run.rrd").is_file()
    assert (runs["rk4_pos_err_max_m"] < 1e-3).all()
