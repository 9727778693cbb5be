"""Shared truth for the filter tests: the lead's scenarios and truth simulator (cached per module run)."""

import functools

import numpy as np
import pytest

from studies.sim.scenarios import get_scenario
from studies.sim.truth import simulate_truth


@functools.lru_cache(maxsize=8)
def _truth(name: str, duration_s: float, dt_s: float = 1.0):
    return simulate_truth(get_scenario(name), duration_s, dt_s)


@pytest.fixture(scope="session")
def truth():
    """``truth(name, duration_s, dt_s=1.0)`` -> :class:`studies.sim.truth.Truth`, cached."""
    return _truth


@pytest.fixture
def rng():
    return np.random.default_rng(20261122)
