"""Study configs: every default config parses; bad configs give one line naming the field and exit non-zero."""

import subprocess
import sys

import pytest

from studies.cli import main
from studies.engine.config import CONFIG_DIR, COMMON_FIELDS, ConfigError, Field, validate_config
from studies.engine.registry import STUDIES

GOOD = """study = "truth"
seed = 3
scenarios = ["SC1"]
n_seeds = 2
duration_s = 20.0
dt_s = 1.0
rk4_dt_s = 0.05

[quick]
n_seeds = 1
"""

PAPER_STUDIES = ["tuning", "init", "proxy", "chain", "combina", "coverage", "timing"]


def test_quick_overrides_and_defaults():
    fields = STUDIES["truth"].fields
    import tomllib

    raw = tomllib.loads(GOOD)
    full = validate_config(raw, "truth", fields)
    quick = validate_config(raw, "truth", fields, quick=True)
    assert full["n_seeds"] == 2 and quick["n_seeds"] == 1
    assert full["rk4_tolerance_m"] == 1e-3 and full["record"] is True  # defaults filled in
    assert full.identity() != quick.identity()


@pytest.mark.parametrize("name", ["truth", *PAPER_STUDIES])
def test_default_configs_exist_and_name_their_study(name):
    import tomllib

    raw = tomllib.loads((CONFIG_DIR / f"{name}.toml").read_text())
    assert raw["study"] == name
    assert COMMON_FIELDS["seed"].check(raw["seed"], "seed", name) >= 0
    assert isinstance(raw.get("quick", {}), dict) and raw["quick"], f"{name}.toml needs a [quick] table"


@pytest.mark.parametrize(
    "edit, message",
    [
        (("n_seeds = 2", "n_seeds = -3"), "n_seeds -3: expected an integer >= 1 and <= 100000"),
        (("n_seeds = 2", "n_seeds = 2.5"), "n_seeds 2.5: expected an integer >= 1 and <= 100000"),
        (("n_seeds = 2", 'n_seeds = "two"'), "n_seeds 'two': expected an integer"),
        (('scenarios = ["SC1"]', 'scenarios = ["SC9"]'), "scenarios ['SC9']: expected a list of 1 to 10000 item(s), each one of 'SC1'"),
        (('scenarios = ["SC1"]', "scenarios = []"), "scenarios []: expected a list"),
        (("duration_s = 20.0", "duration_s = 0"), "duration_s 0: expected a number > 0 and <= 1e+06"),
        (("seed = 3", "seed = -1"), "seed -1: expected an integer >= 0"),
        (("seed = 3\n", ""), "seed missing: expected an integer"),
        (("dt_s = 1.0", "dt_s = 1.0\nspeed = 3"), "unknown field 'speed': expected one of"),
        (('study = "truth"', 'study = "tuning"'), "study 'tuning': expected 'truth'"),
        (("rk4_dt_s = 0.05", "rk4_dt_s = 0.3"), "rk4_dt_s 0.3: expected a divisor of dt_s"),
        (("n_seeds = 1\n", "n_seeds = 0\n"), "quick.n_seeds 0: expected an integer >= 1"),
        (("[quick]\n", "[quick\n"), "not valid TOML"),
        (("dt_s = 1.0", "dt_s = true"), "dt_s True: expected a number > 0 and <= 1e+06"),
    ],
)
def test_bad_config_one_line_naming_the_field(tmp_path, capsys, edit, message):
    old, new = edit
    assert old in GOOD
    cfg = tmp_path / "bad.toml"
    cfg.write_text(GOOD.replace(old, new, 1))
    out = tmp_path / "out"
    assert main(["study", "truth", "--config", str(cfg), "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0] and "bad.toml" in err[0], err
    assert not out.exists()  # validated before anything is written


@pytest.mark.parametrize(
    "args, message",
    [
        (["nosuch"], "unknown study 'nosuch': expected one of the known studies: truth"),
        (["truth", "--workers", "0"], "--workers 0: expected an integer within [1, "),
        (["truth", "--scheduler", "localhost:8786"], "--scheduler 'localhost:8786': expected the form tcp://HOST:PORT"),
        (["truth", "--config", "/nonexistent/x.toml"], "--config '/nonexistent/x.toml': no such file"),
        (["truth", "--workers", "2", "--scheduler", "tcp://127.0.0.1:8786"], "cannot be combined with --scheduler"),
    ],
)
def test_bad_command_line(tmp_path, capsys, args, message):
    out = tmp_path / "out"
    assert main(["study", *args, "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0], err
    assert not out.exists()


def test_cli_process_prints_one_line_and_no_traceback(tmp_path, lcnav_env):
    cfg = tmp_path / "bad.toml"
    cfg.write_text(GOOD.replace("n_seeds = 2", "n_seeds = -3"))
    res = subprocess.run([sys.executable, "-m", "studies.cli", "study", "truth", "--config", str(cfg), "--out", str(tmp_path / "o")],
                         capture_output=True, text=True, env=lcnav_env)
    assert res.returncode != 0
    assert res.stderr.strip().splitlines() == ["lcnav: error: bad.toml: n_seeds -3: expected an integer >= 1 and <= 100000"]


def test_field_declarations():
    with pytest.raises(TypeError):
        Field("complex", "not a kind")
    f = Field("float", "x", ge=0, le=1)
    assert f.check(1, "x", "w") == 1.0 and isinstance(f.check(1, "x", "w"), float)
    for bad in [True, -0.1, 1.5, float("nan"), "0.5", None]:
        with pytest.raises(ConfigError, match=r"x .*: expected a number >= 0 and <= 1"):
            f.check(bad, "x", "w")
