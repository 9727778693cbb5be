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


def code(*paths: str) -> str:
    """Git object ids (short) of the tracked ``paths`` at HEAD, joined by ``.``, with ``+changes`` when any of them differs from
    HEAD in the working tree: what a kept benchmark row measured, unchanged by commits that touch nothing else; ``unknown``
    outside a git checkout."""
    try:
        ids = [subprocess.run(["git", "rev-parse", "--short", f"HEAD:{p}"], cwd=ROOT, capture_output=True, text=True, check=True).stdout.strip()
               for p in paths]
        dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no", "--", *paths],
                               cwd=ROOT, capture_output=True, text=True, check=True).stdout
    except (OSError, subprocess.CalledProcessError):
        return "unknown"
    return ".".join(ids) + ("+changes" if dirty.strip() else "")
