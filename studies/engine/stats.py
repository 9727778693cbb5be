"""Statistics of a study's runs: mean, spread and confidence intervals.

The papers report single runs; lcnav runs many seeds and reports, per group
of runs, the mean, the sample standard deviation, a Student-t confidence
interval of the mean and, for skewed metrics (convergence times, errors), a
bootstrap interval of the median (``scipy.stats.bootstrap``, BCa); for
fractions (runs converged, coverage) a Wilson score interval
(``scipy.stats.binomtest``).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
import pandas as pd
from scipy import stats


@dataclass(frozen=True)
class Interval:
    """A point estimate with its confidence interval ``[lo, hi]``."""

    estimate: float
    lo: float
    hi: float
    confidence: float
    method: str


def _clean(x) -> np.ndarray:
    x = np.asarray(x, dtype=float).ravel()
    return x[np.isfinite(x)]


def _check_confidence(confidence: float) -> float:
    if not 0.0 < confidence < 1.0:
        raise ValueError(f"confidence must be in (0, 1), got {confidence!r}")
    return float(confidence)


def t_interval(x, confidence: float = 0.95) -> Interval:
    """Student-t interval of the mean, ``x̄ ± t_{n−1} s/√n`` (non-finite values dropped).

    NaN bounds with fewer than two values; a zero-width interval when all values agree.
    """
    confidence = _check_confidence(confidence)
    x = _clean(x)
    n = x.size
    mean = float(x.mean()) if n else np.nan
    if n < 2:
        return Interval(mean, np.nan, np.nan, confidence, "t")
    sem = float(x.std(ddof=1)) / np.sqrt(n)
    if sem == 0.0:
        return Interval(mean, mean, mean, confidence, "t")
    lo, hi = stats.t.interval(confidence, n - 1, loc=mean, scale=sem)
    return Interval(mean, float(lo), float(hi), confidence, "t")


def bootstrap_interval(
    x,
    statistic: Callable[[np.ndarray], float] = np.median,
    confidence: float = 0.95,
    *,
    rng: np.random.Generator,
    n_resamples: int = 2000,
    method: str = "BCa",
) -> Interval:
    """Bootstrap interval of ``statistic`` (default the median) via ``scipy.stats.bootstrap``.

    NaN bounds with fewer than two values; a zero-width interval when all values agree
    (BCa is undefined there).
    """
    confidence = _check_confidence(confidence)
    x = _clean(x)
    est = float(statistic(x)) if x.size else np.nan
    if x.size < 2:
        return Interval(est, np.nan, np.nan, confidence, f"bootstrap-{method}")
    if np.ptp(x) == 0.0:
        return Interval(est, est, est, confidence, f"bootstrap-{method}")
    res = stats.bootstrap(
        (x,), lambda s, axis: statistic(s, axis=axis), confidence_level=confidence, n_resamples=n_resamples,
        method=method, rng=rng, vectorized=True,
    )
    lo, hi = res.confidence_interval
    return Interval(est, float(lo), float(hi), confidence, f"bootstrap-{method}")


def proportion_interval(k: int, n: int, confidence: float = 0.95) -> Interval:
    """Fraction ``k/n`` (e.g. runs converged) with its Wilson score interval (``scipy.stats.binomtest``)."""
    confidence = _check_confidence(confidence)
    if n < 1 or not 0 <= k <= n:
        raise ValueError(f"proportion_interval needs 0 <= k <= n and n >= 1, got k={k}, n={n}")
    ci = stats.binomtest(int(k), int(n)).proportion_ci(confidence_level=confidence, method="wilson")
    return Interval(k / n, float(ci.low), float(ci.high), confidence, "wilson")


def describe(
    runs: pd.DataFrame,
    by: Sequence[str],
    metrics: Sequence[str],
    *,
    confidence: float = 0.95,
    median_of: Sequence[str] = (),
    rng: np.random.Generator | None = None,
) -> pd.DataFrame:
    """Per group of ``by``: ``n_runs`` and, per metric, ``_mean``, ``_sd``, ``_ci_lo``, ``_ci_hi`` (t interval).

    Metrics in ``median_of`` also get ``_median``, ``_med_lo``, ``_med_hi``
    (bootstrap BCa of the median; needs ``rng``). Groups keep their order of
    first appearance in ``runs``.
    """
    missing = [c for c in [*by, *metrics, *median_of] if c not in runs.columns]
    if missing:
        raise KeyError(f"columns {missing} are not in the runs table (it has {list(runs.columns)})")
    if median_of and rng is None:
        raise ValueError("describe(median_of=...) needs rng, a numpy Generator for the bootstrap")
    rows = []
    for key, group in runs.groupby(list(by), sort=False):
        key = key if isinstance(key, tuple) else (key,)
        row = dict(zip(by, key))
        row["n_runs"] = len(group)
        for m in metrics:
            iv = t_interval(group[m], confidence)
            vals = _clean(group[m])
            row[f"{m}_mean"] = iv.estimate
            row[f"{m}_sd"] = float(vals.std(ddof=1)) if vals.size > 1 else np.nan
            row[f"{m}_ci_lo"], row[f"{m}_ci_hi"] = iv.lo, iv.hi
        for m in median_of:
            iv = bootstrap_interval(group[m], np.median, confidence, rng=rng)
            row[f"{m}_median"], row[f"{m}_med_lo"], row[f"{m}_med_hi"] = iv.estimate, iv.lo, iv.hi
        rows.append(row)
    return pd.DataFrame(rows)
