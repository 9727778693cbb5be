"""Fixtures shared by the light-curve tests: the Mitsuba variants that run here."""

import os

# The fits here are small (hundreds × tens); on a shared 2-core machine OpenBLAS's
# worker threads only contend (measured 35× slower). Effective when numpy is not yet loaded.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import pytest  # noqa: E402

from lightcurves import scene  # noqa: E402

VARIANTS = [pytest.param("llvm_ad_rgb", marks=pytest.mark.skipif(scene.libllvm_path() is None, reason="no libLLVM >= 16")), "scalar_rgb"]


@pytest.fixture(params=VARIANTS)
def variant(request):
    """Each Mitsuba variant that can run on this machine (set for the test)."""
    return scene.select_variant(request.param)
