"""Which code a benchmark measured: the commit, marked when tracked source files differ from it."""

from __future__ import annotations

import subprocess
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
RESULT_FILES = ("benchmarks/RESULTS.md", "benchmarks/*.json", "benchmarks/*.png")  #: a benchmark's own outputs: they do not make the code differ


def commit() -> str:
    """The code's short commit (``+changes`` when tracked files other than :data:`RESULT_FILES` differ from it), or
    ``unknown`` outside a git checkout."""
    try:
        head = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True, text=True, check=True).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no", "--", ".", *(f":!{p}" for p in RESULT_FILES)],
                               cwd=ROOT, capture_output=True, text=True, check=True).stdout
    except (OSError, subprocess.CalledProcessError):
        return "unknown"
    return head + ("+changes" if dirty.strip() else "")
