"""Sidereal-period search ranges from the curves themselves: what a user knows before an inversion.

Each curve's own period comes from :func:`lightcurves.extract_spin_prior` on its magnitudes ``−2.5 log₁₀ F`` (any
zero point) with ``σ_m = (2.5 / ln 10) σ_F / F`` and its Sun and observer directions (so that the 1-σ holds the
synodic–sidereal difference). A curve with a significant period ``P`` gives the interval ``[P/(1 + h), P/(1 − h)]``,
``h = max(3 σ_rate / rate, 1 %)`` (symmetric in rate; the 1 % floor covers the synodic–sidereal difference of one
night), and the same interval at ``2P`` when its maxima per rotation are not established (a double-peaked curve of
equal maxima looks single-peaked at half the rotation period). Every curve's intervals are searched, overlapping
ones merged: one night tells the light curve's period, not always the rotation's. On the chain study's quick
campaign (seed ``init-s001``: SC3's atlas-centaur, 300 s arcs of 2.35 turns at 64 px) the three nights gave P/6, P/2
and P/2 — the glints leave red residuals, and the fundamental's odd harmonics did not pass the period finder's Wald
test against that noise — and only the longest night's ranges were searched before 2026-12-02 (the prior 500 % off).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

__all__ = ["PeriodRange", "PeriodRangeError", "curve_periods", "period_ranges", "MIN_RANGE_FRACTION", "RANGE_SIGMAS"]

#: Fractional half-width floor of a derived period range (a user knows the synodic period to ~1 % from one night).
MIN_RANGE_FRACTION = 0.01
#: Half-width of a derived period range in units of the single-night period's 1-σ.
RANGE_SIGMAS = 3.0
#: 1-σ of a magnitude from the relative 1-σ of a flux: σ_m = (2.5 / ln 10) σ_F / F.
_FLUX_TO_MAG_SIGMA = 2.5 / np.log(10.0)
#: A half-width at or above this fraction makes the interval meaningless (its low end would reach 2/3 of P).
_MAX_RANGE_FRACTION = 0.5
SECONDS_PER_HOUR = 3600.0


class PeriodRangeError(ValueError):
    """No period range can be derived from the light curves (no curve has a usable single-night period)."""


@dataclass(frozen=True)
class PeriodRange:
    """One sidereal-period interval searched, s, and why (``given`` or the single-night periods it came from)."""

    lo_s: float
    hi_s: float
    source: str

    def to_dict(self) -> dict:
        return {"min_h": self.lo_s / SECONDS_PER_HOUR, "max_h": self.hi_s / SECONDS_PER_HOUR, "source": self.source}


def curve_periods(curves: Sequence) -> list:
    """Each :class:`~lightcurves.inversion.data.InversionCurve`'s own :class:`~lightcurves.prior.SpinPrior`, in order."""
    from lightcurves import extract_spin_prior

    return [extract_spin_prior(c.t_s, -2.5 * np.log10(c.brightness), _FLUX_TO_MAG_SIGMA * c.sigma / c.brightness, sun_dir=c.sun_dir_I,
                               observer_dir=c.observer_dir_I) for c in curves]


def period_ranges(curves: Sequence, priors: Sequence | None = None) -> list[PeriodRange]:
    """The merged sidereal-period ranges of every curve with a usable period (module docstring), increasing.

    ``priors``: the curves' :func:`curve_periods`, if already computed. Raises :class:`PeriodRangeError` naming
    each curve's reason when none has a significant period with a 3-σ below 50 %.
    """
    priors = curve_periods(curves) if priors is None else priors
    found, refused = [], []
    for k, (c, p) in enumerate(zip(curves, priors)):
        name = c.name or f"curve {k + 1}"
        if not p.significant:
            refused.append(f"{name}: no significant single-night period ({p.decision})")
            continue
        h = max(RANGE_SIGMAS * p.rate_sigma_rad_s / p.rate_rad_s, MIN_RANGE_FRACTION)
        if h >= _MAX_RANGE_FRACTION:
            refused.append(f"{name}: single-night period {p.period_s / SECONDS_PER_HOUR:.6g} h with a 3-sigma of {100 * h:.0f} %")
            continue
        what = f"{name}: single-night period {p.period_s / SECONDS_PER_HOUR:.6g} h ± {100 * h:.2g} % ({p.maxima_per_rotation} maxima per cycle)"
        found.append(PeriodRange(p.period_s / (1 + h), p.period_s / (1 - h), what))
        if p.maxima_per_rotation == 1:
            doubled = what + ", doubled: one maximum per cycle may be half a double-peaked rotation"
            found.append(PeriodRange(2 * p.period_s / (1 + h), 2 * p.period_s / (1 - h), doubled))
    if not found:
        raise PeriodRangeError("; ".join(refused))
    merged: list[PeriodRange] = []
    for r in sorted(found, key=lambda r: r.lo_s):
        if merged and r.lo_s <= merged[-1].hi_s:
            last = merged[-1]
            merged[-1] = PeriodRange(last.lo_s, max(last.hi_s, r.hi_s), f"{last.source}; {r.source}")
        else:
            merged.append(r)
    return merged
