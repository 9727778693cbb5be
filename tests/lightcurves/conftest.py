"""Fixtures shared by the light-curve tests: the Mitsuba variants that run here."""

import pytest

from lightcurves import scene

VARIANTS = [pytest.param("llvm_ad_rgb", marks=pytest.mark.skipif(scene.libllvm_path() is None, reason="no libLLVM >= 16")), "scalar_rgb"]


@pytest.fixture(params=VARIANTS)
def variant(request):
    """Each Mitsuba variant that can run on this machine (set for the test)."""
    return scene.select_variant(request.param)
