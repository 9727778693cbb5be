"""Issue 30's "first hour": the README's own commands, run as a new user would, in an empty folder, with their outcomes.

The commands are read from README.md's ``sh`` blocks (continuation lines joined, comments cut), so the README cannot
drift from what is tested: ``--help``; ``lightcurve render`` then ``lightcurve prior`` on its light curve; the
prior on an observer's MJD file with ``--time-format mjd`` and without it; ``run`` with that prior, which is wrong for
SC3 (5.00 deg/s about an assumed axis; SC3 spins at 2.82 deg/s about another). Each runs as ``python -m studies.cli``
in a fresh process in a temporary folder (the README's relative paths). Only sizes are cut (:func:`with_option`):
the render's cadence 0.5 -> 2 s (175 samples instead of 710; the prior's rate stays 5.004 deg/s), the run's duration
300 -> 40 s (its first four full-information fits), and ``--json`` is added where a number is read.
"""

import json
import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[1]
README = REPO / "README.md"
#: Longest wait for one command (a guard against a hang on a machine loaded 10x over, not a timing), s.
HANG_S = 900.0
#: The one message form of a refusal (README, "The command line").
ONE_FORM = re.compile(r"^lcnav: error: \S.*: expected \S.*$")


def readme_commands() -> list[list[str]]:
    """Every ``lcnav ...`` line of README.md's ``sh`` blocks as its argv after ``lcnav`` (``\\`` continuations joined)."""
    commands = []
    for block in re.findall(r"```sh\n(.*?)```", README.read_text(), flags=re.S):
        for line in re.sub(r"\\\n\s*", " ", block).splitlines():
            argv = shlex.split(line, comments=True)
            if argv[:1] == ["lcnav"]:
                commands.append(argv[1:])
    return commands


def readme_command(*prefix: str, having: tuple[str, ...] = ()) -> list[str]:
    """The first README command that starts with ``prefix`` and holds every token of ``having``."""
    found = [argv for argv in readme_commands() if tuple(argv[: len(prefix)]) == prefix and all(h in argv for h in having)]
    assert found, f"README.md has no `lcnav {' '.join(prefix)} ... {' '.join(having)}` command"
    return list(found[0])


def with_option(argv: list[str], flag: str, value: str | None = None) -> list[str]:
    """``argv`` with ``flag``'s value replaced by ``value`` (or the flag appended); ``value=None``: a flag without a value."""
    argv = list(argv)
    if flag not in argv:
        return argv + [flag] + ([] if value is None else [value])
    if value is not None:
        argv[argv.index(flag) + 1] = value
    return argv


def without_option(argv: list[str], flag: str) -> list[str]:
    """``argv`` without ``flag`` and its value."""
    i = argv.index(flag)
    return argv[:i] + argv[i + 2:]


def lcnav(argv: list[str], cwd: Path) -> subprocess.CompletedProcess:
    """``lcnav ARGV`` in a fresh process in ``cwd``, this checkout first on the path."""
    env = dict(os.environ, RERUN_ANALYTICS="0", MPLBACKEND="Agg")
    env["PYTHONPATH"] = os.pathsep.join([str(REPO), *filter(None, [os.environ.get("PYTHONPATH")])])
    return subprocess.run([sys.executable, "-m", "studies.cli", *argv], cwd=cwd, env=env, capture_output=True, text=True, timeout=HANG_S)


def write_mjd_csv(path: Path, mjd, mag, mag_err) -> None:
    """An observer's CSV: times in MJD (days, 10 decimals: 9 µs), magnitudes and errors under their own names."""
    path.write_text("mjd,magnitude,err\n" + "".join(f"{t:.10f},{m:.5f},{e:.5f}\n" for t, m, e in zip(mjd, mag, mag_err)))


def test_help_lists_every_command_the_readme_uses(tmp_path):
    res = lcnav(["--help"], tmp_path)
    assert res.returncode == 0, res.stderr
    used = {argv[0] for argv in readme_commands()}
    assert {"simulate", "lightcurve", "run", "combina", "study", "inspect"} <= used
    assert all(re.search(rf"^\W*{name}\s", res.stdout, flags=re.M) for name in used), (used, res.stdout)
    assert lcnav(["run", "--help"], tmp_path).returncode == 0


def test_an_mjd_file_without_its_time_format_is_refused(tmp_path):
    """Without ``--time-format``, MJD times (days since 1858) would give a rate 86400x too high: refused in one line."""
    t_s = np.arange(0.0, 400.0, 2.0)
    mag = 14.0 + 0.5 * np.cos(2 * np.radians(5.0) * t_s)
    write_mjd_csv(tmp_path / "obs.csv", 60390.84 + t_s / 86400.0, mag, np.full_like(t_s, 0.05))
    argv = without_option(readme_command("lightcurve", "prior", "obs.csv", having=("--time-format",)), "--time-format")
    res = lcnav(argv, tmp_path)
    err = res.stderr.strip().splitlines()
    assert res.returncode == 2 and len(err) == 1 and ONE_FORM.match(err[0]), (res.returncode, err)
    assert "obs.csv: column 'mjd'" in err[0] and "looks like MJD (days)" in err[0] and "--time-format" in err[0], err
    assert res.stdout == "" and sorted(p.name for p in tmp_path.iterdir()) == ["obs.csv"]


@pytest.mark.slow
def test_render_prior_mjd_and_a_wrong_prior_run_as_the_readme_says(tmp_path):
    # render: the light curve and its recording
    render = with_option(readme_command("lightcurve", "render", having=("--record",)), "--cadence", "2")
    res = lcnav(render, tmp_path)
    assert res.returncode == 0, res.stderr
    ecsv, rrd = (tmp_path / render[render.index(flag) + 1] for flag in ("--out", "--record"))
    assert ecsv.is_file() and rrd.is_file()
    rate_deg_s = float(render[render.index("--rate-deg-s") + 1])

    # the prior of the rendered curve: the rendered rate within 1 % and within its own 3 sigma
    res = lcnav(readme_command("lightcurve", "prior", ecsv.name, having=("--json",)), tmp_path)
    assert res.returncode == 0, res.stderr
    prior = json.loads(res.stdout)
    assert prior["significant"] and abs(prior["rate_deg_s"] - rate_deg_s) < max(3 * prior["rate_sigma_deg_s"], 0.01 * rate_deg_s), prior
    (tmp_path / "prior.json").write_text(res.stdout)

    # the same light curve as an observer's MJD file: with --time-format mjd, the same rate (the times agree to 9 µs)
    from astropy.table import Table
    from astropy.time import Time

    table = Table.read(ecsv)
    write_mjd_csv(tmp_path / "obs.csv", Time(table["time"]).utc.mjd, table["mag"], table["mag_err"])
    mjd_cmd = readme_command("lightcurve", "prior", "obs.csv", having=("--time-format",))
    res = lcnav(with_option(mjd_cmd, "--json"), tmp_path)
    assert res.returncode == 0, res.stderr
    from_mjd = json.loads(res.stdout)
    assert abs(from_mjd["rate_deg_s"] - prior["rate_deg_s"]) < 0.1 * prior["rate_sigma_deg_s"], (from_mjd["rate_deg_s"], prior)
    assert "mjd" in from_mjd["time_input"].lower()
    assert lcnav(without_option(mjd_cmd, "--time-format"), tmp_path).returncode == 2

    # run with that prior on SC3, where it is wrong: exit 0 with one warning, not exit 2 (issue 30's crash)
    run = with_option(readme_command("run", having=("--prior-json",)), "--duration", "40")
    out = tmp_path / "run-out"
    run = [str(out) if a == "DIR" else a for a in run]
    res = lcnav(run, tmp_path)
    assert res.returncode == 0, res.stderr
    warnings = [line for line in res.stderr.splitlines() if line.startswith("lcnav: warning: the spin prior contradicts the measurements")]
    assert len(warnings) == 1, res.stderr
    assert "lcnav: error" not in res.stderr
    metrics = json.loads((out / "metrics.json").read_text())
    assert metrics["prior_contradicted_s"] and metrics["config"]["prior"] == "init"
