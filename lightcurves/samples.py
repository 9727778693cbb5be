"""Validation of sampled series (times and values) shared by the spectra, the prior and the readers.

Bad input raises :class:`BadSeries` (a ``ValueError``) with a message that
names the field and says what is expected.
"""

from __future__ import annotations

import numpy as np

__all__ = ["BadSeries", "MIN_SAMPLES", "check_samples"]

MIN_SAMPLES = 20
"""Fewest samples a spectrum or a spin prior is computed from."""


class BadSeries(ValueError):
    """A time series that cannot be analysed (with the reason)."""


def check_samples(t, y, dy=None, *, name: str = "mag", min_samples: int = MIN_SAMPLES) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """Return ``t, y, dy`` as float arrays after checking them.

    Checks: 1-D and equal lengths; no NaN/inf; times strictly increasing (no
    duplicates); at least ``min_samples``; ``y`` not constant; ``dy > 0``.
    """
    t = np.asarray(t, dtype=float)
    y = np.asarray(y, dtype=float)
    if t.ndim != 1 or y.ndim != 1 or t.size != y.size:
        raise BadSeries(f"time and {name} of shapes {t.shape} and {y.shape}: expected 1-D arrays of equal length")
    if not np.all(np.isfinite(t)):
        raise BadSeries(f"time with {np.count_nonzero(~np.isfinite(t))} NaN/inf value(s): expected finite times")
    if not np.all(np.isfinite(y)):
        raise BadSeries(f"{name} with {np.count_nonzero(~np.isfinite(y))} NaN/inf value(s): expected finite values")
    if t.size < min_samples:
        raise BadSeries(f"{name} of {t.size} sample(s): expected at least {min_samples} samples")
    d = np.diff(t)
    if np.any(d == 0):
        k = int(np.flatnonzero(d == 0)[0])
        raise BadSeries(f"time {float(t[k]):g} at samples {k} and {k + 1}, a duplicate: expected strictly increasing times")
    if np.any(d < 0):
        k = int(np.flatnonzero(d < 0)[0])
        raise BadSeries(f"time {float(t[k + 1]):g} (sample {k + 1}) after {float(t[k]):g} (sample {k}), not increasing: expected strictly increasing times")
    if np.ptp(y) <= 1e-12 * max(1.0, np.abs(y).max()):
        raise BadSeries(f"{name} constant at {float(y[0]):g} over all {y.size} samples (zero variance): expected a varying {name}")
    if dy is not None:
        dy = np.broadcast_to(np.asarray(dy, dtype=float), y.shape).copy()
        if not np.all(np.isfinite(dy) & (dy > 0)):
            k = int(np.flatnonzero(~(np.isfinite(dy) & (dy > 0)))[0])
            raise BadSeries(f"{name}_err {float(dy[k]):g} (sample {k}): expected finite values > 0 for every sample")
    return t, y, dy
