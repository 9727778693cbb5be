"""The period ranges a study's prior searches (:func:`studies.sim.lightcurve_prior._period_ranges`)."""

from types import SimpleNamespace

import numpy as np
import pytest

from studies.sim.lightcurve_prior import _period_ranges


def _night(period_s: float, sigma_fraction: float = 1e-3) -> SimpleNamespace:
    rate = 2.0 * np.pi / period_s
    return SimpleNamespace(rate_rad_s=rate, rate_sigma_rad_s=sigma_fraction * rate)


def test_one_night_gives_p_and_2p_at_the_larger_of_3_sigma_and_1_percent():
    P = 100.0
    assert _period_ranges([_night(P)]) == [pytest.approx((0.99 * P, 1.01 * P)), pytest.approx((1.98 * P, 2.02 * P))]
    (lo, hi), _ = _period_ranges([_night(P, sigma_fraction=0.01)])
    assert (lo, hi) == pytest.approx((0.97 * P, 1.03 * P))


def test_nights_that_disagree_are_all_searched_and_overlaps_merged():
    """The chain study's quick campaign (seed init-s001): nights at P/6, P/2, P/2 of the true P = 127.6 s. The ranges hold
    P (twice the P/2 nights) and are disjoint and increasing; the two P/2 nights, 0.4 % apart, give one range each at P/2
    and P, not two."""
    P = 127.59
    ranges = _period_ranges([_night(P / 6), _night(P / 2 * 1.002), _night(P / 2 * 0.998)])
    assert len(ranges) == 4
    assert any(lo <= P <= hi for lo, hi in ranges)
    assert all(lo < hi for lo, hi in ranges)
    assert all(a[1] < b[0] for a, b in zip(ranges, ranges[1:]))
    for p in (P / 6, P / 3, P / 2 * 1.002, P / 2 * 0.998, P * 1.002, P * 0.998):  # every night's P and 2P is inside one range
        assert sum(lo <= p <= hi for lo, hi in ranges) == 1, p
