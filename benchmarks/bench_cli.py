"""How fast ``lcnav`` answers before any work: ``--help``, ``--version``, a misspelt option or command, a command's ``--help``.

The goal (issue 30): ``lcnav --help`` and a misspelt option answer in under
1 s on an idle machine. Each row is the median wall time of fresh
``python -m studies.cli ...`` processes, and its ratio against ``python -c pass``
(the interpreter's own start-up) measured in the same run, so that a loaded
machine shows in both. The CPU time (user + system, of the child) is less
sensitive to other jobs than the wall time.
"""

from __future__ import annotations

import os
import resource
import statistics
import subprocess
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
REPEATS = 5
GOAL_S = 1.0
CASES = [
    ("`python -c pass` (baseline)", ["-c", "pass"]),
    ("`lcnav --help`", ["-m", "studies.cli", "--help"]),
    ("`lcnav --version`", ["-m", "studies.cli", "--version"]),
    ("`lcnav --hlep` (misspelt option)", ["-m", "studies.cli", "--hlep"]),
    ("`lcnav rnu` (misspelt command)", ["-m", "studies.cli", "rnu"]),
    ("`lcnav run --durration 5` (misspelt option of a command)", ["-m", "studies.cli", "run", "--durration", "5"]),
    ("`lcnav run --help`", ["-m", "studies.cli", "run", "--help"]),
    ("`lcnav study --help`", ["-m", "studies.cli", "study", "--help"]),
    ("`lcnav simulate --help`", ["-m", "studies.cli", "simulate", "--help"]),
    ("`lcnav combina --help`", ["-m", "studies.cli", "combina", "--help"]),
    ("`lcnav demo --help`", ["-m", "studies.cli", "demo", "--help"]),
    ("`lcnav inspect --help`", ["-m", "studies.cli", "inspect", "--help"]),
]


def _time(args: list[str]) -> tuple[float, float]:
    """Median wall time and median child CPU time (s) of ``python ARGS``, :data:`REPEATS` fresh processes."""
    env = dict(os.environ, PYTHONPATH=str(REPO), RERUN_ANALYTICS="0")
    walls, cpus = [], []
    for _ in range(REPEATS):
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        t0 = time.perf_counter()
        subprocess.run([sys.executable, *args], env=env, capture_output=True, check=False)
        walls.append(time.perf_counter() - t0)
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        cpus.append(after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime)
    return statistics.median(walls), statistics.median(cpus)


def run() -> str:
    rows = [(name, *_time(args)) for name, args in CASES]
    base = rows[0][1]
    lines = [
        "## lcnav start-up: help, version, misspelt input",
        "",
        f"Median of {REPEATS} fresh processes; goal: `lcnav --help` and a misspelt option under {GOAL_S:g} s on an idle machine.",
        "",
        "| command | wall (s) | CPU (s) | wall vs `python -c pass` |",
        "|---|---|---|---|",
        *(f"| {name} | {wall:.2f} | {cpu:.2f} | {wall / base:.1f} |" for name, wall, cpu in rows),
    ]
    return "\n".join(lines)
