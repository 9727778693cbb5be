"""The package layout's import rules, read from every module's import statements with ``ast``.

* nothing outside ``studies/cli`` imports ``studies.cli`` (commands import everything; nothing imports a command);
* the libraries ``lightcurves``, ``perception``, ``estimators`` never import ``studies``;
* ``lightcurves`` never imports ``perception``.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


def imported_modules(path: Path) -> set[str]:
    """Absolute names of the modules ``path`` imports (relative imports resolved against its package)."""
    package = ".".join(path.relative_to(ROOT).with_suffix("").parts[:-1])
    names = set()
    for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
        if isinstance(node, ast.Import):
            names.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                parent = package.split(".")[: len(package.split(".")) - node.level + 1]
                base = ".".join([*parent, base] if base else parent)
            names.add(base)
            names.update(f"{base}.{a.name}" for a in node.names)
    return names


def violations(package: str, forbidden: str, *, exempt: str | None = None) -> list[str]:
    out = []
    for path in sorted((ROOT / package).rglob("*.py")):
        if exempt and path.is_relative_to(ROOT / exempt):
            continue
        for name in sorted(imported_modules(path)):
            if name == forbidden or name.startswith(forbidden + "."):
                out.append(f"{path.relative_to(ROOT)} imports {name}")
    return out


@pytest.mark.parametrize("package, forbidden, exempt", [
    ("studies", "studies.cli", "studies/cli"),
    ("lightcurves", "studies", None),
    ("perception", "studies", None),
    ("estimators", "studies", None),
    ("lightcurves", "perception", None),
])
def test_import_rules(package, forbidden, exempt):
    assert (ROOT / package).is_dir()
    assert violations(package, forbidden, exempt=exempt) == []


def test_rules_see_a_violation(tmp_path, monkeypatch):
    """The reader finds a command import in any of its forms (the rule can fail)."""
    pkg = tmp_path / "studies" / "sim"
    pkg.mkdir(parents=True)
    (pkg / "bad.py").write_text("def f():\n    from studies.cli import run\n")
    (pkg / "worse.py").write_text("from ..cli import demo\n")
    (pkg / "fine.py").write_text("import studies.engine.io\n")
    monkeypatch.setitem(globals(), "ROOT", tmp_path)
    assert violations("studies", "studies.cli", exempt="studies/cli") == [
        "studies/sim/bad.py imports studies.cli", "studies/sim/bad.py imports studies.cli.run",
        "studies/sim/worse.py imports studies.cli", "studies/sim/worse.py imports studies.cli.demo",
    ]
