"""The rerun command line of the running interpreter, found from ``sys.executable`` (never a fixed path)."""

import subprocess
import sys
from pathlib import Path


def rerun_executable() -> Path:
    """``rerun`` installed beside this interpreter (the venv's ``bin/``)."""
    exe = Path(sys.executable).with_name("rerun")
    if not exe.is_file():
        raise FileNotFoundError(f"rerun not found beside {sys.executable}: install rerun-sdk into this environment")
    return exe


def rerun(*args: str, timeout: float = 120) -> subprocess.CompletedProcess:
    """Run ``rerun ARGS...`` and return the finished process (text output captured)."""
    return subprocess.run([str(rerun_executable()), *map(str, args)], capture_output=True, text=True, timeout=timeout)


def assert_rrd_verifies(*paths) -> None:
    """``rerun rrd verify`` accepts every file in ``paths``."""
    assert paths, "no .rrd file to verify"
    res = rerun("rrd", "verify", *paths)
    assert res.returncode == 0, res.stderr


def blueprint_views(path) -> tuple[set, set]:
    """The (space origins, content queries) of the views in the one blueprint stored in the ``.rrd`` at ``path``."""
    from rerun.chunk import RrdReader

    reader = RrdReader(path)
    assert len(reader.blueprints()) == 1, f"{path} holds {len(reader.blueprints())} blueprints, expected 1"
    origins, queries = set(), set()
    for chunk in reader.stream(store=reader.blueprints()[0]):
        cols = chunk.to_record_batch().to_pydict()
        for o in cols.get("ViewBlueprint:space_origin", []):
            origins.update(o)
        for q in cols.get("ViewContents:query", []):
            queries.update(q)
    return origins, queries
