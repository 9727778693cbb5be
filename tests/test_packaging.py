"""Packaging: each of the four packages ships a PEP 561 ``py.typed`` marker, and the wheel includes it."""

import tomllib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("lightcurves", "perception", "estimators", "studies")


@pytest.mark.parametrize("package", PACKAGES)
def test_py_typed_marker_is_present_and_installed(package):
    assert (ROOT / package / "py.typed").is_file()
    config = tomllib.loads((ROOT / "pyproject.toml").read_text())
    assert "py.typed" in config["tool"]["setuptools"]["package-data"][package]
