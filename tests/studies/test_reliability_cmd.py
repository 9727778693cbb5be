"""Regression tests of issue 14: each cause of a traceback, a hang, a silent acceptance or a half-written folder.

Every bad input gives exit 2 and ONE line ``lcnav: error: <value>: expected <form>``
and leaves nothing behind; an ``--out`` folder is locked against a second
writer, finished by ``.complete.json`` written last, and cleaned of a killed
run's temporary files.
"""

import json
import os
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from studies.engine import io as sio
from studies.engine import sweep
from studies.cli import main
from studies.engine.config import default_config_path


def run_cli(capsys, argv):
    code = main([str(a) for a in argv])
    captured = capsys.readouterr()
    return code, captured.err.strip().splitlines()


def one_error(capsys, argv, *needles):
    code, err = run_cli(capsys, argv)
    assert code == 2 and len(err) == 1 and err[0].startswith("lcnav: error:"), (code, err)
    for n in needles:
        assert n in err[0], err[0]
    return err[0]


def light_curve_csv(path: Path, extra: str = "", n: int = 30) -> Path:
    path.write_text("time,mag\n" + "".join(f"{k},{9 + 0.3 * np.sin(k):.4f}\n" for k in range(n)) + extra)
    return path


# ---------------------------------------------------------------- tracebacks and hangs


def test_header_only_csv(tmp_path, capsys):
    path = tmp_path / "lc.csv"
    path.write_text("time,mag\n")
    one_error(capsys, ["lightcurve", "prior", path], "lc.csv: a header but no rows: expected one row per sample")


def test_garbage_rrd(tmp_path, capsys):
    path = tmp_path / "g.rrd"
    path.write_bytes(b"garbage" * 10)
    one_error(capsys, ["inspect", path], "is not a readable rerun recording", "expected a .rrd written by lcnav")


@pytest.mark.parametrize("case", ["file", "under-file", "nul", "too-long"])
def test_invalid_out(tmp_path, capsys, case):
    blocker = tmp_path / "f"
    blocker.write_text("x")
    out = {"file": blocker, "under-file": blocker / "sub", "nul": f"{tmp_path}/a\x00b", "too-long": tmp_path / ("n" * 300)}[case]
    before = sorted(tmp_path.iterdir())
    one_error(capsys, ["simulate", "--duration", "10", "--out", out], "--out", "null byte" if case == "nul" else "expected")
    assert sorted(tmp_path.iterdir()) == before and blocker.read_text() == "x"


@pytest.mark.skipif(os.geteuid() == 0, reason="root may write into any folder")
def test_unwritable_out(tmp_path, capsys):
    locked = tmp_path / "locked"
    locked.mkdir(mode=0o500)
    one_error(capsys, ["simulate", "--duration", "10", "--out", locked / "out"], "is not writable")


@pytest.mark.parametrize("edit, needle", [
    (("n_seeds = 10 ", "n_seeds = 1000000000000 "), "n_seeds 1000000000000: expected an integer >= 1 and <= 100000"),
    (("duration_s = 300.0", "duration_s = 1e12"), "duration_s 1000000000000.0: expected a number > 0 and <= 1e+06"),
    (("dt_s = 1.0 ", "dt_s = 0.0001 "), "duration_s / dt_s 300 / 0.0001 (3e+06 steps): expected at most 1000000 steps"),
    (("duration_s = 300.0", "duration_s = inf"), "duration_s inf: expected a number > 0 and <= 1e+06"),
])
def test_huge_config_values_are_refused_at_once(tmp_path, capsys, edit, needle):
    text = default_config_path("truth").read_text()
    old, new = edit
    assert old in text
    cfg = tmp_path / "c.toml"
    cfg.write_text(text.replace(old, new, 1))
    one_error(capsys, ["study", "truth", "--config", cfg, "--out", tmp_path / "out"], needle)  # returns: refused, not run (1e12 seeds used to hang)
    assert not (tmp_path / "out").exists()


def test_int_of_inf_is_a_bound_not_an_overflow(tmp_path, capsys):
    # duration / cadence = inf used to reach int(inf): OverflowError
    one_error(capsys, ["lightcurve", "render", "--duration", "1e5", "--cadence", "1e-300", "--out", tmp_path / "lc.ecsv"],
              "--duration/--cadence", "20 to 100000 samples")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("content, needle", [
    ('{"rate_rad_s": "0.1", "rate_sigma_rad_s": 0.01}', "rate_rad_s '0.1': expected a finite number within [0, 6.28319] rad/s"),
    ('{"rate_rad_s": 0.1}', "rate_sigma_rad_s None: expected a finite number"),
    ('{"rate_rad_s": [1], "rate_sigma_rad_s": 0.01}', "rate_rad_s [1]: expected a finite number"),
    ('{"rate_rad_s": 0.1, "rate_sigma_rad_s": true}', "rate_sigma_rad_s True: expected a finite number"),
    ('{"rate_rad_s": 1e308, "rate_sigma_rad_s": 0.01}', "rate_rad_s 1e+308: expected"),
    ('[0.1, 0.01]', "holds a JSON list: expected an object with rate_rad_s and rate_sigma_rad_s"),
    ('[' * 100000 + ']' * 100000, "not JSON (RecursionError"),
    ('{"rate_rad_s": NaN, "rate_sigma_rad_s": 0.01}', "rate_rad_s nan: expected a finite number"),
])
def test_prior_json_of_wrong_types(tmp_path, capsys, content, needle):
    path = tmp_path / "prior.json"
    path.write_text(content)
    one_error(capsys, ["run", "--duration", "30", "--prior", "init", "--prior-json", path, "--out", tmp_path / "out"], needle)
    assert not (tmp_path / "out").exists()


def test_nul_bytes(tmp_path, capsys):
    one_error(capsys, ["run", "--scenario", "SC3\x00", "--out", tmp_path / "o"], "--scenario 'SC3\\x00': expected text of at most 1000 printable characters")
    path = tmp_path / "lc.csv"
    path.write_bytes(b"time,mag\n0,1\x00\n")
    one_error(capsys, ["lightcurve", "prior", path], "NUL byte at offset 12")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["lc.csv"]


def test_rate_1e308_is_refused(tmp_path, capsys):
    one_error(capsys, ["lightcurve", "render", "--rate-deg-s", "1e308", "--out", tmp_path / "lc.ecsv"],
              "--rate-deg-s 1e+308: expected a finite number within (0, 360] deg/s")


def test_combina_rate_1e6_is_refused_at_once(tmp_path, capsys):
    one_error(capsys, ["combina", "--rate-hz", "1e6", "--out", tmp_path / "o"], "--rate-hz 1000000.0: expected a finite number within (0, 10] Hz")
    one_error(capsys, ["combina", "--rate-hz", "10", "--duration-tu", "100", "--out", tmp_path / "o"], "at most 100000 measurements")
    assert not (tmp_path / "o").exists()  # refused before anything ran


# ---------------------------------------------------------------- wrongly accepted


def test_empty_magnitude_cell_and_hex_are_refused(tmp_path, capsys):
    one_error(capsys, ["lightcurve", "prior", light_curve_csv(tmp_path / "a.csv", "30,\n")], "column 'mag' row 31: empty: expected")
    one_error(capsys, ["lightcurve", "prior", light_curve_csv(tmp_path / "b.csv", "30,0x10\n")], "row 31: '0x10': expected a decimal number")


def test_values_are_quoted_plainly(tmp_path, capsys):
    path = tmp_path / "lc.csv"
    path.write_text("time,mag\n" + "".join(f"{k},10\n" for k in range(29)) + "29,ten\n")
    err = one_error(capsys, ["lightcurve", "prior", path], "row 30: 'ten': expected")
    assert "np.str_" not in err


@pytest.mark.parametrize("flag, value, needle", [
    ("--gate-start", "nan", "--gate-start nan: expected a finite number within [0, 1e+06] s"),
    ("--gate-confidence", "1", "--gate-confidence 1.0: expected a finite number within [0, 1)"),
    ("--runs", "1000000", "--runs 1000000: expected an integer within [1, 1000]"),
    ("--prior-rate-deg-s", "1e308,0,0", "--prior-rate-deg-s (prior rate) '1e308,0,0': expected 3 comma-separated finite numbers within [-360, 360]"),
    ("--fault", "10,inf", "--fault '10,inf': expected 2 comma-separated finite numbers"),
])
def test_run_option_bounds(tmp_path, capsys, flag, value, needle):
    one_error(capsys, ["run", "--duration", "30", flag, value, "--out", tmp_path / "o"], needle)
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("content, needle", [
    ("t_s,q_TS_0,q_TS_1,q_TS_2,q_TS_3,r_ST_T_x_m,r_ST_T_y_m,r_ST_T_z_m\n", "holds 0 row(s): expected at least 2 measurements"),
    ("t_s,q_TS_0,q_TS_1,q_TS_2,q_TS_3,r_ST_T_x_m,r_ST_T_y_m,r_ST_T_z_m\n0,1,0,0,0,1,2,3\n1,1,0,0,0,1,2,\n", "row 1 has a NaN, Inf or empty cell"),
    ("t_s,q_TS_0,q_TS_1,q_TS_2,q_TS_3,r_ST_T_x_m,r_ST_T_y_m,r_ST_T_z_m\n0,1,0,0,0,1,2,3\n1,1,0,0,0,1,2,0x10\n",
     "column r_ST_T_z_m holds '0x10': expected decimal numbers"),
    ("t_s,q_TS_0,q_TS_1,q_TS_2,q_TS_3,r_ST_T_x_m,r_ST_T_y_m,r_ST_T_z_m\n5,1,0,0,0,1,2,3\n5,1,0,0,0,1,2,3\n", "expected strictly increasing times"),
    ("t_s,q_TS_0,q_TS_1,q_TS_2,q_TS_3,r_ST_T_x_m,r_ST_T_y_m,r_ST_T_z_m\n500,1,0,0,0,1,2,3\n501,1,0,0,0,1,2,3\n",
     "expected measurements within the run, 0 to 30 s"),
])
def test_measurements_file_is_checked(tmp_path, capsys, content, needle):
    path = tmp_path / "m.csv"
    path.write_text(content)
    one_error(capsys, ["run", "--duration", "30", "--measurements", path, "--out", tmp_path / "o"], needle)
    assert not (tmp_path / "o").exists()


def test_maxima_per_rotation_is_bounded(tmp_path, capsys):
    one_error(capsys, ["lightcurve", "prior", light_curve_csv(tmp_path / "lc.csv"), "--maxima-per-rotation", "100000000000000000000000"],
              "--maxima-per-rotation 100000000000000000000000: expected an integer within [1, 16]")


@pytest.fixture(scope="module")
def truth_run(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("sim") / "out"
    assert main(["simulate", "--duration", "10", "--dt", "1", "--out", str(out)]) == 0
    return out


def test_export_with_contents_matching_nothing_fails_and_writes_nothing(truth_run, tmp_path, capsys):
    export = tmp_path / "x.parquet"
    one_error(capsys, ["inspect", truth_run / "truth.rrd", "--export", export, "--contents", "/nothing/**"], "matches no time series")
    assert not export.exists()
    assert main(["inspect", str(truth_run / "truth.rrd"), "--export", str(export), "--contents", "/truth/range_m"]) == 0
    assert list(pd.read_parquet(export).columns) == ["sim_time_s", "/truth/range_m"]


def test_inspect_folder_says_what_is_wrong(tmp_path, capsys):
    pd.DataFrame({"a": [1]}).to_parquet(tmp_path / "runs.parquet")
    one_error(capsys, ["inspect", tmp_path], "runs.parquet' has columns ['a'] without 'run_id'")
    (tmp_path / "runs.parquet").write_bytes(b"not parquet")
    one_error(capsys, ["inspect", tmp_path], "is not a readable Parquet table")


# ---------------------------------------------------------------- nothing written before validation, nothing partial after a failure


def test_study_json_not_written_before_unreachable_scheduler(tmp_path, capsys, monkeypatch):
    import socket

    monkeypatch.setattr(sweep, "CONNECT_TIMEOUT_S", 1.0)
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    out = tmp_path / "out"
    one_error(capsys, ["study", "truth", "--quick", "--scheduler", f"tcp://127.0.0.1:{port}", "--out", out], "no Dask scheduler answered within 1 s")
    assert not out.exists()


def test_render_leaves_no_ecsv_when_the_recording_fails(tmp_path, capsys, monkeypatch):
    from studies.cli import lightcurve as lightcurve_cmd

    def broken(*args, **kwargs):
        raise OSError(28, "No space left on device", str(tmp_path / "lc.rrd"))

    monkeypatch.setattr(lightcurve_cmd, "write_lightcurve_recording", broken)
    out, rrd = tmp_path / "lc.ecsv", tmp_path / "lc.rrd"
    code, err = run_cli(capsys, ["lightcurve", "render", "--target", "sphere", "--duration", "40", "--cadence", "2", "--resolution", "4",
                                 "--variant", "scalar_rgb", "--out", out, "--record", rrd])
    # after the renderer's progress lines; the folder named (issue 29)
    assert code == 2 and err[-1] == f"lcnav: error: {tmp_path}: no space left on device: expected a folder on a file system with free space"
    assert list(tmp_path.iterdir()) == []  # neither the light curve nor a temporary file


def test_failure_while_writing_keeps_the_old_folder_whole(tmp_path, capsys, monkeypatch):
    from studies.cli import simulate as simulate_cmd

    out = tmp_path / "out"
    assert main(["simulate", "--duration", "10", "--out", str(out)]) == 0
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    assert set(before) == {"truth.parquet", "truth.rrd", ".complete.json"}

    def broken(*args, **kwargs):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(simulate_cmd, "record_truth", broken)
    one_error(capsys, ["simulate", "--duration", "20", "--out", out], f"{out}: no space left on device")
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before  # old result intact, still marked complete; no staging left
    new = tmp_path / "new"
    one_error(capsys, ["simulate", "--duration", "20", "--out", new], f"{new}: no space left on device")
    assert not new.exists()  # a folder the failed command created is removed again


# ---------------------------------------------------------------- lock, completion marker, stale temporary files


def test_completion_marker_is_written_last(truth_run):
    rec = json.loads((truth_run / ".complete.json").read_text())
    assert rec["command"] == "simulate" and rec["files"] == ["truth.parquet", "truth.rrd"] and rec["lcnav_version"]
    marker_ns = (truth_run / ".complete.json").stat().st_mtime_ns
    assert all(p.stat().st_mtime_ns <= marker_ns for p in truth_run.iterdir())
    assert not (truth_run / sio.LOCK_FILE).exists()  # released


def test_second_writer_is_refused_naming_the_holder(tmp_path, capsys):
    out = tmp_path / "out"
    out.mkdir()
    with sio.folder_lock(out):
        assert (out / sio.LOCK_FILE).read_text().strip() == str(os.getpid())
        one_error(capsys, ["run", "--duration", "20", "--out", out], f"another lcnav is writing to it (pid {os.getpid()})")
        one_error(capsys, ["study", "truth", "--quick", "--out", out], f"another lcnav is writing to it (pid {os.getpid()})")
        assert sorted(p.name for p in out.iterdir()) == [sio.LOCK_FILE]
    assert list(out.iterdir()) == []
    with sio.folder_lock(out):  # free again
        pass


def test_stale_temporary_files_are_cleaned(tmp_path, capsys):
    out = tmp_path / "out"
    (out / "runs" / "r1").mkdir(parents=True)
    stale = [out / ".truth.parquet.abcd1234.tmp", out / "runs" / "r1" / ".metrics.json.x_y9Z012.tmp"]
    for p in stale:
        p.write_text("half")
    (out / ".lcnav-stage-killed").mkdir()
    (out / ".lcnav-stage-killed" / "truth.rrd").write_text("half")
    keep = out / ".notes.tmp"  # not a name lcnav makes: left alone
    keep.write_text("mine")
    assert main(["simulate", "--duration", "10", "--out", str(out)]) == 0
    assert not any(p.exists() for p in stale) and not (out / ".lcnav-stage-killed").exists() and keep.exists()


def test_killed_study_folder_is_incomplete_and_resumes(quick_truth, tmp_path, capsys):
    import shutil

    out = tmp_path / "study"
    shutil.copytree(quick_truth, out)
    assert sio.is_complete(out)["command"] == "study"
    # what a SIGKILL in the middle leaves: no marker, a half-written temporary file, one run missing
    (out / ".complete.json").unlink()
    run_dirs = sorted((out / "runs").iterdir())
    shutil.rmtree(run_dirs[0])
    (run_dirs[1] / ".run.rrd.k1LL3d00.tmp").write_bytes(b"half")
    assert main(["inspect", str(out)]) == 0
    assert "INCOMPLETE" in capsys.readouterr().out
    assert main(["study", "truth", "--quick", "--workers", "1", "--out", str(out)]) == 0
    assert "1 runs executed" in capsys.readouterr().out
    assert sio.is_complete(out) and not (run_dirs[1] / ".run.rrd.k1LL3d00.tmp").exists()


def test_duplicate_times_merge_with_one_warning_line(tmp_path, capsys):
    path = light_curve_csv(tmp_path / "lc.csv", "29,9.5\n29,9.7\n")
    for _ in range(2):  # said on every run, not only the first of the process
        code, err = run_cli(capsys, ["lightcurve", "prior", path])
        merged = [line for line in err if "share a time" in line]
        assert code == 0 and merged == ["lcnav: warning: lc.csv: 2 row(s) share a time with another row; merged each group into one sample, "
                                        "the weighted mean in magnitudes (equal weights (no mag_err))"]
        # the only other line: this CSV has no viewing geometry, so the prior's 1-σ leaves out the synodic offset
        assert [line for line in err if line not in merged] == [line for line in err if "no viewing geometry" in line]
        assert all(line.startswith("lcnav: warning: ") for line in err)


def test_lock_holds_across_processes(tmp_path, capsys, lcnav_env):
    """Another process holding OUT's lock (as a running `lcnav run` does) makes this one refuse, naming its pid."""
    import subprocess
    import sys

    out = tmp_path / "out"
    out.mkdir()
    holder = subprocess.Popen([sys.executable, "-c", "import sys, time; from pathlib import Path; from studies.engine.io import folder_lock\n"
                               "with folder_lock(Path(sys.argv[1])):\n    print('locked', flush=True); time.sleep(60)", str(out)],
                              stdout=subprocess.PIPE, text=True, env=lcnav_env)
    try:
        assert holder.stdout.readline().strip() == "locked"
        one_error(capsys, ["run", "--duration", "20", "--out", out], f"another lcnav is writing to it (pid {holder.pid})")
        assert sorted(p.name for p in out.iterdir()) == [sio.LOCK_FILE]
    finally:
        holder.kill()
        holder.wait()
    assert main(["run", "--duration", "20", "--out", str(out)]) == 0  # the kill released the lock (flock dies with its process)
    assert sio.is_complete(out)["command"] == "run"
