"""No test depends on wall time: read from every test module with ``ast``, and from hypothesis' loaded profile.

A correct result must not fail because the machine is busy (issue 30: three
hypothesis deadlines, 1569 ms against 200 ms, failed ``make test`` at load
7-15 on 2 cores). So, in every file under ``tests/``:

* a hypothesis ``settings(...)`` or ``settings.register_profile(...)`` that names
  ``deadline`` sets it to ``None``, and one that names ``suppress_health_check``
  includes ``HealthCheck.too_slow`` (it replaces the profile's list);
* no ``assert`` compares a clock: its test reads none of ``time.time``,
  ``time.monotonic``, ``time.perf_counter``, ``time.process_time`` (or their
  ``_ns`` forms), directly or through a name assigned from one in the same
  function (``t0 = time.perf_counter(); ...; assert time.perf_counter() - t0 < 5``).

Speed is measured in ``benchmarks/``, as ratios within one run.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest
from hypothesis import HealthCheck, settings

TESTS = Path(__file__).resolve().parent
CLOCKS = {"time", "monotonic", "perf_counter", "process_time", "time_ns", "monotonic_ns", "perf_counter_ns", "process_time_ns"}


def _reads_clock(node: ast.AST, tainted: set[str]) -> bool:
    """Whether the expression ``node`` calls a clock of :mod:`time` or reads a name holding one's value."""
    for sub in ast.walk(node):
        if isinstance(sub, ast.Call):
            f = sub.func
            if isinstance(f, ast.Attribute) and f.attr in CLOCKS and isinstance(f.value, ast.Name) and f.value.id == "time":
                return True
            if isinstance(f, ast.Name) and f.id in CLOCKS - {"time"}:  # from time import perf_counter
                return True
        if isinstance(sub, ast.Name) and sub.id in tainted:
            return True
    return False


def _timed_asserts(tree: ast.AST) -> list[int]:
    """Lines of the asserts that read a clock, function by function (names assigned from a clock propagate to a fixed point)."""
    lines = []
    scopes = [n for n in ast.walk(tree) if isinstance(n, ast.FunctionDef | ast.AsyncFunctionDef)] or [tree]
    for scope in scopes:
        tainted: set[str] = set()
        while True:
            grown = set(tainted)
            for node in ast.walk(scope):
                if isinstance(node, ast.Assign | ast.AugAssign | ast.AnnAssign) and node.value is not None and _reads_clock(node.value, tainted):
                    targets = node.targets if isinstance(node, ast.Assign) else [node.target]
                    grown.update(t.id for target in targets for t in ast.walk(target) if isinstance(t, ast.Name))
            if grown == tainted:
                break
            tainted = grown
        lines += [n.lineno for n in ast.walk(scope) if isinstance(n, ast.Assert) and _reads_clock(n.test, tainted)]
    return sorted(set(lines))


def _is_settings_call(node: ast.Call) -> bool:
    f = node.func
    name = f.attr if isinstance(f, ast.Attribute) else f.id if isinstance(f, ast.Name) else ""
    owner = f.value.id if isinstance(f, ast.Attribute) and isinstance(f.value, ast.Name) else ""
    return name == "settings" or (name == "register_profile" and owner == "settings")


def _settings_problems(tree: ast.AST) -> list[str]:
    """``line: what`` for each hypothesis settings call that sets a deadline or drops the too_slow suppression."""
    out = []
    for node in ast.walk(tree):
        if not (isinstance(node, ast.Call) and _is_settings_call(node)):
            continue
        for kw in node.keywords:
            if kw.arg == "deadline" and not (isinstance(kw.value, ast.Constant) and kw.value.value is None):
                out.append(f"{node.lineno}: deadline={ast.unparse(kw.value)}")
            if kw.arg == "suppress_health_check" and "too_slow" not in ast.unparse(kw.value):
                out.append(f"{node.lineno}: suppress_health_check={ast.unparse(kw.value)} without HealthCheck.too_slow")
    return out


def wall_time_problems(source: str, name: str = "<test>") -> list[str]:
    """Every dependence on wall time in one test module's source (see the module docstring)."""
    tree = ast.parse(source, filename=name)
    return _settings_problems(tree) + [f"{line}: assert reads a clock" for line in _timed_asserts(tree)]


TEST_FILES = sorted(p for p in TESTS.rglob("*.py") if p.name != Path(__file__).name)


@pytest.mark.parametrize("path", TEST_FILES, ids=[str(p.relative_to(TESTS)) for p in TEST_FILES])
def test_no_test_depends_on_wall_time(path):
    assert wall_time_problems(path.read_text(), str(path)) == []


@pytest.mark.parametrize("source, expected", [
    ("@settings(max_examples=5, deadline=200)\ndef test_a(): pass\n", ["1: deadline=200"]),
    ("S = settings(deadline=timedelta(seconds=1))\n", ["1: deadline=timedelta(seconds=1)"]),
    ("settings.register_profile('ci', suppress_health_check=[HealthCheck.data_too_large])\n",
     ["1: suppress_health_check=[HealthCheck.data_too_large] without HealthCheck.too_slow"]),
    ("def test_b():\n    t0 = time.perf_counter()\n    run()\n    elapsed = time.perf_counter() - t0\n    assert elapsed < 5\n",
     ["5: assert reads a clock"]),
    ("def test_c():\n    deadline = time.monotonic() + 120\n    while True:\n        assert time.monotonic() < deadline\n",
     ["4: assert reads a clock"]),
    ("from time import perf_counter\ndef test_d():\n    assert perf_counter() > 0\n", ["3: assert reads a clock"]),
    # allowed: no deadline, too_slow suppressed, a clock read that no assert compares, a timeout argument
    ("@settings(deadline=None, suppress_health_check=[HealthCheck.too_slow])\ndef test_e():\n    t0 = time.time()\n"
     "    subprocess.run(cmd, timeout=300)\n    assert ok\n", []),
])
def test_the_checker_finds_each_kind(source, expected):
    assert wall_time_problems(source) == expected


def test_loaded_profile_has_no_deadline_and_no_too_slow_check():
    assert settings.default.deadline is None
    assert HealthCheck.too_slow in settings.default.suppress_health_check
