"""The runnable Examples in the main entry points' docstrings give what they say they give."""

import doctest
import importlib

import pytest

#: Modules whose public entry points carry an ``Examples`` section.
MODULES = ["lightcurves.clean", "lightcurves.prior", "perception.bcpd", "estimators.filter"]


@pytest.mark.parametrize("name", MODULES)
def test_docstring_examples_run(name):
    module = importlib.import_module(name)
    result = doctest.testmod(module, optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE, verbose=False)
    assert result.attempted > 0, f"{name} has no docstring example"
    assert result.failed == 0, f"{result.failed} of {result.attempted} docstring examples of {name} failed"
