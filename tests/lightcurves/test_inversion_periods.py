"""The sidereal-period ranges searched without a range from the user (:mod:`lightcurves.inversion.periods`)."""

from types import SimpleNamespace

import numpy as np
import pytest

from lightcurves.inversion.periods import PeriodRangeError, period_ranges


def _night(period_s: float, maxima: int = 1, sigma_fraction: float = 1e-3, significant: bool = True) -> SimpleNamespace:
    rate = 2.0 * np.pi / period_s
    return SimpleNamespace(significant=significant, rate_rad_s=rate, rate_sigma_rad_s=sigma_fraction * rate, period_s=period_s,
                           maxima_per_rotation=maxima, decision="test")


def _curves(n: int) -> list[SimpleNamespace]:
    return [SimpleNamespace(name=f"night {k}") for k in range(n)]


def test_one_night_gives_p_and_2p_at_the_larger_of_3_sigma_and_1_percent():
    P = 100.0
    got = [(r.lo_s, r.hi_s) for r in period_ranges(_curves(1), [_night(P)])]
    assert got == [pytest.approx((P / 1.01, P / 0.99)), pytest.approx((2 * P / 1.01, 2 * P / 0.99))]
    got = [(r.lo_s, r.hi_s) for r in period_ranges(_curves(1), [_night(P, maxima=2, sigma_fraction=0.01)])]
    assert got == [pytest.approx((P / 1.03, P / 0.97))]  # two maxima established: P alone, at 3σ


def test_nights_that_disagree_are_all_searched_and_overlaps_merged():
    """The chain study's quick campaign (seed init-s001): nights at P/6, P/2, P/2 (one maximum per cycle each) of the true
    P = 127.6 s. The ranges hold P (twice the P/2 nights), are disjoint and increasing, and the two P/2 nights, 0.4 % apart,
    give one range at P/2 and one at P, each naming both."""
    P = 127.59
    ranges = period_ranges(_curves(3), [_night(P / 6), _night(P / 2 * 1.002), _night(P / 2 * 0.998)])
    assert len(ranges) == 4
    assert sum(r.lo_s <= P <= r.hi_s for r in ranges) == 1
    assert all(a.hi_s < b.lo_s for a, b in zip(ranges, ranges[1:]))
    for p in (P / 6, P / 3, P / 2 * 1.002, P / 2 * 0.998, P * 1.002, P * 0.998):  # every night's P and 2P lies in one range
        assert sum(r.lo_s <= p <= r.hi_s for r in ranges) == 1, p
    assert "night 1" in ranges[-1].source and "night 2" in ranges[-1].source


def test_unusable_nights_are_skipped_and_none_usable_names_every_reason():
    P = 100.0
    ranges = period_ranges(_curves(3), [_night(P, significant=False), _night(P, sigma_fraction=0.2), _night(P, maxima=2)])
    assert [(r.lo_s, r.hi_s) for r in ranges] == [pytest.approx((P / 1.01, P / 0.99))] and "night 2" in ranges[0].source
    with pytest.raises(PeriodRangeError, match=r"night 0: no significant single-night period \(test\); night 1: .*3-sigma of 60 %"):
        period_ranges(_curves(2), [_night(P, significant=False), _night(P, sigma_fraction=0.2)])
