"""Period finding on realistic cadences: lcnav against astropy LombScargle; false alarms; calibration of the 1-σ.

``python -m benchmarks periods``. Curves come from :mod:`lightcurves.cadence`
with known truth (the fundamental of the light curve: the published period
of a variable star, the rotation frequency of a satellite):

* survey: 30–300 points over 2–5 seasons (daily and yearly windows), periods
  3 h – 300 d (at least 8 cycles in the span), searched up to 1/(2 h), shapes sinusoid, Cepheid-like
  sawtooth, eclipsing binary with unequal minima, double-peaked; log-normal
  heteroscedastic errors, 2 % outliers;
* satellite: 1–3 passes of 2–40 min, 0.1–10 s cadence with jitter and
  dropouts, rotation periods 2 s – pass/4, double-peaked, sawtooth and
  sinusoidal shapes.

Every method searches the same band; a LombScargle peak is refined on a
grid 20× finer around the coarse maximum (as a user would). "Right" is
``|f/f_true − 1| < 1e-3``; wrong answers are sorted into aliases. lcnav
answers only when it finds a significant period (its "no period" is
counted separately, never as right).

Seeds: the method's fixed choices (number of peaks and aliases, BIC, trial
multiples) were set while looking at seeds 1–3 of this generator, the
outlier cut, the odd-harmonic F-test level and the refinement at seeds 11
and 12; this report uses seed ``REPORT_SEED`` (never used while tuning).

Times: LombScargle runs with astropy's defaults (its low-rank NUFFT to
5e-13); lcnav's trigonometric sums are accurate to ~1e-12
(:mod:`lightcurves.nufft`). Each curve is timed for both methods in turn,
the shortest of ``TIME_REPEATS`` runs each, so that the other jobs on a
shared machine weigh on neither.
"""

from __future__ import annotations

import os
import time

import numpy as np
from astropy.timeseries import LombScargle
from scipy import special, stats

from lightcurves import extract_spin_prior
from lightcurves.cadence import DAY_S, SHAPES, YEAR_S, curve, heteroscedastic_noise, red_noise, satellite_times, survey_times
from lightcurves.harmonic_fits import design, frequency_derivative, harmonic_chi2

REPORT_SEED = 2026
N_SURVEY = 350
N_SATELLITE = 150
MULTITERM_EVERY = 10  #: LombScargle nterms=3 runs on every 10th curve only (astropy fastchi2: seconds per survey curve)
N_CALIBRATION = 600  #: synthetic passes for the σ calibration, half with red noise (≥ 200 scored per kind)
N_RENDERED_ARCS = 200  #: arcs cut from the rendered light curves for the σ calibration
RENDER_CADENCE_S = 2.0  #: sampling of the renders and of the arcs cut from them
N_RENDERS = 100  #: rendered light curves (spin poles) the arcs are cut from, N_RENDERED_ARCS / N_RENDERS from each: the synodic
#: offset is one per pole, so the poles, not the arcs, are the independent draws of the σ's largest term
TIME_REPEATS = 3  #: lcnav and LombScargle nterms=1 are timed as the shortest of this many runs per curve
METHODS = ("lcnav", "lcnav best-ranked (significant or not)", "LS nterms=1", "LS nterms=3")
POINT_BINS = (30, 45, 60, 90, 150, 301)  #: edges of the survey curves' number-of-points classes


def _survey_case(rng):
    n = int(np.exp(rng.uniform(np.log(30), np.log(300))))
    t = survey_times(rng, n, n_seasons=int(rng.integers(2, 6)))
    T = t[-1] - t[0]
    P = np.exp(rng.uniform(np.log(0.125 * DAY_S), np.log(min(300 * DAY_S, T / 8))))
    shape = ("sinusoid", "sawtooth", "eclipsing", "double")[int(rng.integers(4))]
    amp = rng.uniform(0.1, 1.0)
    noise, err = heteroscedastic_noise(rng, t.size, amp / rng.uniform(3.0, 20.0))
    y = 12.0 + curve(shape, t / P + rng.uniform(), amp, rng) + noise
    return dict(t=t, y=y, err=err, f_true=1.0 / P, shape=shape, nu_min=0.5 / T, nu_max=1.0 / (2.0 * 3600.0), windows=(1 / DAY_S, 2 / DAY_S, 1 / YEAR_S))


def _satellite_case(rng):
    n_pass = int(rng.integers(1, 4))
    pass_s = rng.uniform(120.0, 2400.0)
    cadence = float(np.clip(np.exp(rng.uniform(np.log(0.1), np.log(10.0))), pass_s / 2000, pass_s / 60))
    gap = pass_s + rng.uniform(600.0, 6000.0)
    t = satellite_times(rng, n_passes=n_pass, pass_s=pass_s, cadence_s=cadence, pass_gap_s=gap)
    P = np.exp(rng.uniform(np.log(max(2.0, 8 * cadence)), np.log(pass_s / 4)))
    shape = ("sinusoid", "sawtooth", "double", "double")[int(rng.integers(4))]
    amp = rng.uniform(0.2, 2.0)
    noise, err = heteroscedastic_noise(rng, t.size, amp / rng.uniform(4.0, 20.0), spread=0.2, outlier_fraction=0.01)
    y = 8.0 + curve(shape, t / P + rng.uniform(), amp, rng) + noise
    return dict(t=t, y=y, err=err, f_true=1.0 / P, shape=shape, nu_min=0.5 / (t[-1] - t[0]), nu_max=0.5 / np.median(np.diff(t)),
                windows=(1.0 / gap,) if n_pass > 1 else ())


def _ls_peak(t, y, err, nu_min, nu_max, nterms):
    T = t[-1] - t[0]
    ls = LombScargle(t, y, err, nterms=nterms)
    df = 0.2 / T
    f = nu_min + df * np.arange(int((nu_max - nu_min) / df) + 1)
    method = "fast" if nterms == 1 else "fastchi2"
    p = ls.power(f, method=method, assume_regular_frequency=True) if nterms == 1 else ls.power(f, method=method)
    f0 = f[int(np.argmax(p))]
    fine = np.linspace(f0 - df, f0 + df, 41)
    return float(fine[int(np.argmax(ls.power(fine, method="cython" if nterms == 1 else "fastchi2")))])


def _classify(f, f_true, T, windows) -> str:
    if f is None:
        return "no period"
    if abs(f / f_true - 1) < 1e-3:
        return "right"
    tol = 1e-3 * f_true + 0.5 / T
    if abs(f - f_true) < tol:
        return "imprecise"
    for k, name in ((2, "×2"), (0.5, "×½"), (3, "×3"), (1 / 3, "×⅓")):
        if abs(f - k * f_true) < k * tol:
            return name
    for w in windows:
        for k in (1, 2):
            if abs(abs(f - f_true) - k * w) < tol or abs(f + f_true - k * w) < tol:
                return "window alias"
    return "other"


def _lcnav(c):
    """lcnav's answer: ``(frequency or None when no significant period, best-ranked frequency, 1-σ of the frequency)``."""
    p = extract_spin_prior(c["t"], c["y"], c["err"], nu_min=c["nu_min"], nu_max=c["nu_max"])
    if not p.significant:
        return None, p.best_frequency_hz, None
    return p.frequency_hz, p.best_frequency_hz, p.rate_sigma_rad_s / (2 * np.pi)


def _timed(fn, c, repeats: int):
    """``(result, shortest of repeats times)``: the minimum is the cost of the computation, free of the other jobs that
    share the machine."""
    best = np.inf
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = fn(c)
        best = min(best, time.perf_counter() - t0)
    return out, best


def _answers(cases):
    """Every method's answer and time on every curve. The methods take turns on each curve (min of ``TIME_REPEATS``
    runs; LombScargle nterms=3 once, on every ``MULTITERM_EVERY``-th curve), so that a change of load on the shared
    machine hits them alike."""
    out = {name: [] for name in METHODS}
    z, misses = [], [0, 0]  #: lcnav's (f − f_true)/σ where it found the right peak (within half a resolution element); (no period, another peak)
    for i, c in enumerate(cases):
        (f_sig, f_best, sigma_hz), dt = _timed(_lcnav, c, TIME_REPEATS)
        out["lcnav"].append((c, f_sig, dt))
        if f_sig is None:
            misses[0] += 1
        elif abs(f_sig - c["f_true"]) > 0.5 / (c["t"][-1] - c["t"][0]):
            misses[1] += 1
        else:
            z.append((f_sig - c["f_true"]) / sigma_hz)
        out["lcnav best-ranked (significant or not)"].append((c, f_best, None))
        out["LS nterms=1"].append((c, *_timed(lambda c: _ls_peak(c["t"], c["y"], c["err"], c["nu_min"], c["nu_max"], 1), c, TIME_REPEATS)))
        if i % MULTITERM_EVERY == 0:  # astropy's fastchi2: seconds per survey curve
            out["LS nterms=3"].append((c, *_timed(lambda c: _ls_peak(c["t"], c["y"], c["err"], c["nu_min"], c["nu_max"], 3), c, 1)))
    return out, (z, misses)


def _score(cases, answers_by_method, label):
    rows, times, shape_rows = [], {}, []
    kinds = ["right", "×2", "×½", "×3", "×⅓", "window alias", "imprecise", "other", "no period"]
    for name, answers in answers_by_method.items():
        counts = dict.fromkeys(kinds, 0)
        by_shape = {sh: [0, 0] for sh in SHAPES}
        for c, f, _ in answers:
            kind = _classify(f, c["f_true"], c["t"][-1] - c["t"][0], c["windows"])
            counts[kind] += 1
            by_shape[c["shape"]][0] += kind == "right"
            by_shape[c["shape"]][1] += 1
        n = len(answers)
        lo, hi = stats.binomtest(counts["right"], n).proportion_ci(0.95, method="wilson")
        subset = f" (every {MULTITERM_EVERY}th curve, n = {n})" if n < len(cases) else ""
        if answers[0][2] is None:
            timing = " | (same fit as lcnav) |"
        else:
            times[name] = float(np.median([dt for _, _, dt in answers]))
            timing = f" | {1e3 * times[name]:.1f} |"
        rows.append(f"| {label} | {name}{subset} | {100 * counts['right'] / n:.1f} ({100 * lo:.0f}–{100 * hi:.0f}) | "
                    + " | ".join(f"{100 * counts[k] / n:.1f}" for k in kinds[1:]) + timing)
        shape_rows.append(f"| {label} | {name} | " + " | ".join(f"{100 * k / m:.0f} ({m})" if m else "—" for k, m in by_shape.values()) + " |")
    return rows, times["lcnav"] / times["LS nterms=1"], shape_rows


def _harmonic_bic(c, freqs) -> tuple[np.ndarray, np.ndarray]:
    """``(BIC, k)`` at each of ``freqs``: ``χ² + (2k + 4) ln N`` of ``k``-harmonic fits with the quadratic trend under
    the stated error bars, lowest over ``k ≤ min(12, (N − 6)/4)``."""
    t = c["t"]
    tc = t - t.mean()
    V = np.vander(tc / (t[-1] - t[0]), 3)
    K = min(12, (t.size - 6) // 4)
    bic = harmonic_chi2(tc, V, c["y"], c["err"] ** -2.0, np.asarray(freqs, dtype=float), K) + (2 * np.arange(1, K + 1) + 4) * np.log(t.size)
    return bic.min(axis=1), bic.argmin(axis=1) + 1


def _likelihood_prefers(c, f_other: float) -> bool:
    """Whether the data's likelihood prefers ``f_other`` to the truth: the lowest BIC (:func:`_harmonic_bic`) within
    ±0.2/T of ``f_other`` is below the lowest within ±0.2/T of ``f_true`` (41 frequencies each)."""
    grid = np.linspace(-0.2, 0.2, 41) / (c["t"][-1] - c["t"][0])
    return bool(np.min(_harmonic_bic(c, f_other + grid)[0]) < np.min(_harmonic_bic(c, c["f_true"] + grid)[0]))


def _by_points(cases, answers_by_method, ceiling: np.ndarray) -> list[str]:
    """Rows of the survey recovery by number of points: right (%) per method, the precision ceiling, and how often the
    likelihood prefers the wrong period lcnav ranked best (another peak, more than half a resolution element off)."""
    n_pts = np.array([c["t"].size for c in cases])
    T = np.array([c["t"][-1] - c["t"][0] for c in cases])
    right = {name: np.array([_classify(f, c["f_true"], span, c["windows"]) == "right" for (c, f, _), span in zip(answers_by_method[name], T, strict=True)])
             for name in ("lcnav", "lcnav best-ranked (significant or not)", "LS nterms=1")}
    best = [f for _, f, _ in answers_by_method["lcnav best-ranked (significant or not)"]]
    wrong_preferred = np.array([abs(b - c["f_true"]) > 0.5 / span and _likelihood_prefers(c, b) for c, b, span in zip(cases, best, T, strict=True)])
    rows = []
    for lo, hi in zip(POINT_BINS[:-1], POINT_BINS[1:], strict=True):
        m = (n_pts >= lo) & (n_pts < hi)
        rows.append(f"| {lo}–{hi - 1} | {m.sum()} | " + " | ".join(f"{100 * np.mean(r[m]):.1f}" for r in right.values())
                    + f" | {100 * np.mean(ceiling[m]):.1f} | {100 * np.mean(wrong_preferred[m]):.1f} |")
    return rows


def _precision_ceiling(c) -> float:
    """Probability that an efficient, unbiased estimator that already knows the right peak is "right"
    (``|f/f_true − 1| < 1e-3``): ``erf(1e-3 f_true / (√2 σ_f))`` with ``σ_f`` the Cramér–Rao bound of a ``K``-harmonic
    fit (with the quadratic trend) at ``f_true`` under the stated error bars, ``K`` chosen by BIC. It says how much
    of the goal the data allow: long periods seen for a few cycles cannot be pinned to 1e-3."""
    t, y, w = c["t"], c["y"], 1.0 / c["err"]
    tc = t - t.mean()
    K = int(_harmonic_bic(c, [c["f_true"]])[1][0])
    X = design(tc, np.vander(tc / (t[-1] - t[0]), 3), c["f_true"], K)
    coef, *_ = np.linalg.lstsq(X * w[:, None], y * w, rcond=None)
    J = np.column_stack([X, frequency_derivative(tc, X, coef, K)]) * w[:, None]
    sigma_f = np.sqrt(np.linalg.pinv(J.T @ J)[-1, -1])
    return float(special.erf(1e-3 * c["f_true"] / (np.sqrt(2) * sigma_f)))


def _recovery_section(rng) -> tuple[str, dict[str, tuple[list[float], list[int]]]]:
    """The recovery tables, and per cadence lcnav's z = (f − f_true)/σ where it found the right peak with its
    (no period, another peak) counts."""
    survey = [_survey_case(rng) for _ in range(N_SURVEY)]
    sat = [_satellite_case(rng) for _ in range(N_SATELLITE)]
    a1, z1 = _answers(survey)
    a2, z2 = _answers(sat)
    r1, q1, s1 = _score(survey, a1, f"survey ({N_SURVEY})")
    r2, q2, s2 = _score(sat, a2, f"satellite ({N_SATELLITE})")
    per_curve = {name: np.array([_precision_ceiling(c) for c in cases]) for name, cases in (("survey", survey), ("satellite", sat))}
    ceiling = {name: 100 * np.mean(p) for name, p in per_curve.items()}
    npts = np.array([c["t"].size for c in survey])
    nsat = np.array([c["t"].size for c in sat])
    text = "\n".join([
        "### Period recovery (fraction of curves, %)",
        "",
        "| cadence | method | right (95 % Wilson) | ×2 | ×½ | ×3 | ×⅓ | window alias | imprecise | other | no period | median time (ms) |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|",
        *r1, *r2,
        "",
        f"Time ratio lcnav / LS nterms=1 (medians of the per-curve times, each the shortest of {TIME_REPEATS} runs, the two methods "
        f"taking turns on each curve): survey {q1:.2f}, satellite {q2:.2f}. Survey curves have "
        f"{npts.min()}–{npts.max()} points (median {np.median(npts):.0f}); satellite curves {nsat.min()}–{nsat.max()} (median {np.median(nsat):.0f}). "
        f"Precision ceiling: an efficient estimator that already knew the right peak would be 'right' on {ceiling['survey']:.1f} % of the "
        f"survey curves and {ceiling['satellite']:.1f} % of the satellite ones (mean of erf(1e-3 f/(√2 σ_f)), σ_f the Cramér–Rao bound "
        "of the BIC-chosen harmonic fit at the true frequency, error bars as stated; detection and aliases not counted). "
        "'right': |f/f_true − 1| < 1e-3 with f_true the fundamental; '×2' etc.: a harmonic or sub-harmonic; 'window alias': "
        "f ± k/day, k/yr or k/(pass spacing); 'imprecise': the right peak, off by more than 1e-3. LombScargle always returns a "
        "peak; lcnav returns none when no period is significant at 1 % (white or red noise) or the period has < 2 cycles.",
        "",
        "Right (%) by shape (number of curves):",
        "",
        "| cadence | method | " + " | ".join(SHAPES) + " |",
        "|---|---|" + "---|" * len(SHAPES),
        *s1, *s2,
        "",
        "Sinusoids and Cepheid-like sawtooths have one maximum per cycle, like the stars of the issue's survey test; "
        "eclipsing and double-peaked curves have their strongest harmonic at twice the fundamental.",
        "",
        "Survey curves by number of points (right, %):",
        "",
        "| points | curves | lcnav | lcnav best-ranked | LS nterms=1 | precision ceiling | likelihood prefers a wrong period |",
        "|---|---|---|---|---|---|---|",
        *_by_points(survey, a1, per_curve["survey"]),
        "",
        "'likelihood prefers a wrong period': lcnav's best-ranked answer is another peak and the data's BIC (stated error "
        "bars, up to 12 harmonics, each frequency refined within ±0.2/T) is lower there than at the truth, so a period "
        "finder that picks the likeliest period is wrong on that curve too (other periods, which lcnav did not rank, "
        "could be likelier still: the column is a lower bound on such curves).",
    ])
    return text, {f"survey curves of the recovery test ({N_SURVEY})": z1, f"satellite curves of the recovery test ({N_SATELLITE})": z2}


def _false_alarm_section(rng) -> str:
    level = 0.01
    n_trials = 1000  #: 10–110 ms a trial: enough that a rate of 1 % is told from 2 %
    cases = {
        "white, survey cadence (60 pts)": lambda: (lambda t: (t, rng.normal(0, 0.05, t.size), np.full(t.size, 0.05)))(survey_times(rng, 60)),
        "white, survey cadence (200 pts)": lambda: (lambda t: (t, rng.normal(0, 0.05, t.size), np.full(t.size, 0.05)))(survey_times(rng, 200)),
        "white, even 1 s, 600 s": lambda: (lambda t: (t, rng.normal(0, 0.02, t.size), np.full(t.size, 0.02)))(np.arange(0.0, 600.0, 1.0)),
        "white, satellite 1 s, dropouts": lambda: (lambda t: (t, rng.normal(0, 0.02, t.size), None))(satellite_times(rng, pass_s=600.0, cadence_s=1.0)),
        "red OU τ = 5 s, 1 s cadence, 600 s": lambda: (lambda t: (t, red_noise(rng, t, 0.02, 5.0), np.full(t.size, 0.02)))(np.arange(0.0, 600.0, 1.0)),
        "red OU τ = 30 s, 1 s cadence, 600 s": lambda: (lambda t: (t, red_noise(rng, t, 0.02, 30.0), np.full(t.size, 0.02)))(np.arange(0.0, 600.0, 1.0)),
        "red OU τ = 100 s, 1 s cadence, 1200 s":
            lambda: (lambda t: (t, red_noise(rng, t, 0.02, 100.0), None))(satellite_times(rng, pass_s=1200.0, cadence_s=1.0)),
        "red OU τ = 2 d + white, survey (150 pts)":
            lambda: (lambda t: (t, red_noise(rng, t, 0.05, 2 * DAY_S) + rng.normal(0, 0.02, t.size), np.full(t.size, 0.02)))(survey_times(rng, 150)),
    }
    rows = []
    for name, make in cases.items():
        det, n = 0, n_trials
        for _ in range(n):
            t, y, e = make()
            det += bool(extract_spin_prior(t, 10 + y, e, false_alarm_level=level).significant)
        lo, hi = stats.binomtest(det, n).proportion_ci(0.95, method="wilson")
        goal = f"≤ {100 * level:.0f} %" if name.startswith("white") else "≤ 5 %"
        rows.append(f"| {name} | {n} | {det} | {100 * det / n:.1f} ({100 * lo:.1f}–{100 * hi:.1f}) | {goal} |")
    return "\n".join([
        "### False detections on noise (false_alarm_level = 1 %)",
        "",
        "| noise and sampling | trials | significant | rate % (95 % Wilson) | goal |",
        "|---|---|---|---|---|",
        *rows,
        "",
        "White noise: the false-alarm probability is Baluev's (2008) upper bound for the periodogram maximum, so the "
        "rate may fall below the level. Red noise: the periodogram is divided by the expected periodogram of an "
        "Ornstein–Uhlenbeck + white process whose correlation is fitted (by moments) to the residuals and, for the "
        "detection, to the data themselves (the null hypothesis), seen through the sampling window; a candidate "
        "with < 2 cycles in the arc is refused.",
    ])


_WHITE, _RED, _RENDERED = "synthetic, white noise", "synthetic, red noise (OU τ = 3–20 s) + white", f"rendered Atlas-Centaur, 2–8 deg/s, {N_RENDERS} poles"


def _calibration_rows(z_sets, misses) -> list[str]:
    rows = []
    for name, z in z_sets.items():
        z = np.abs(np.asarray(z))
        n = z.size
        f1, f2 = np.mean(z < 1), np.mean(z < 2)
        none, other = misses[name]
        rows.append(f"| {name} | {n + none + other} | {none} | {other} | {n} | {100 * f1:.1f} | {100 * f2:.1f} | {np.median(z):.2f} |")
    return rows


def _calibration_section(rng, recovery: dict[str, tuple[list[float], list[int]]]) -> str:
    """The σ calibration on the synthetic and rendered passes, and on ``recovery``'s curves (z, misses per cadence)."""
    z_sets: dict[str, list[float]] = {_WHITE: [], _RED: [], _RENDERED: []}
    misses = {_WHITE: [0, 0], _RED: [0, 0]}  # (no significant period, another peak) per kind
    for i in range(N_CALIBRATION):
        red = i % 2 == 1
        pass_s = rng.uniform(300.0, 1200.0)
        cadence = rng.uniform(0.5, 2.0)
        t = satellite_times(rng, pass_s=pass_s, cadence_s=cadence)
        P = rng.uniform(20.0, pass_s / 5)
        amp = rng.uniform(0.3, 1.5)
        sig = amp / rng.uniform(5.0, 30.0)
        noise, err = heteroscedastic_noise(rng, t.size, sig, spread=0.2, outlier_fraction=0.0)
        if red:
            noise = noise + red_noise(rng, t, sig, rng.uniform(3.0, 20.0))
        y = 8.0 + curve(("sawtooth", "double", "eclipsing")[i % 3], t / P + rng.uniform(), amp, rng) + noise
        p = extract_spin_prior(t, y, err)
        label = _RED if red else _WHITE
        if not p.significant:
            misses[label][0] += 1
        elif abs(p.frequency_hz - 1 / P) > 0.5 / (t[-1] - t[0]):  # another peak (alias, harmonic): a gross error, not σ's business
            misses[label][1] += 1
        else:
            z_sets[label].append((p.frequency_hz - 1 / P) / (p.rate_sigma_rad_s / (2 * np.pi)))
    z_sets[_RENDERED], misses[_RENDERED] = _rendered_z(rng)
    for name, (z, miss) in recovery.items():
        z_sets[name], misses[name] = z, miss
    rows = _calibration_rows(z_sets, misses)
    return "\n".join([
        "### Calibration of the 1-σ: z = (estimate − truth)/σ",
        "",
        "| simulations | runs | no period | another peak | n scored | |z| < 1 (%) | |z| < 2 (%) | median |z| |",
        "|---|---|---|---|---|---|---|---|",
        *rows,
        "",
        "Goal: |z| < 1 in 60–76 %, |z| < 2 in 90–98 %. Synthetic: one satellite pass of 300–1200 s at 0.5–2 s, sawtooth, "
        "double-peaked and eclipsing shapes, 20–P/5 s periods. 'another peak': off by more than half a resolution element "
        "(a harmonic, a sub-harmonic, an alias: a gross error, which no σ describes); runs with no significant period or "
        "another peak are left out of the scores. "
        f"Rendered: {N_RENDERS} noise-free Mitsuba renders (Atlas-Centaur-like body, GPS-like orbit, spin pole drawn isotropically, "
        "2–8 deg/s) cut into arcs of 200–1600 s with gaps and Gaussian noise 0.01–0.1 mag; the truth is the sidereal rate, the "
        "synodic term enters σ from the Sun and observer directions (the bisector's turning rate: for an isotropic pole the "
        "synodic offset is within it in 63 % of cases and within twice it in 93 %; 'another peak' there was twice the rate on a "
        "development seed, 31 of 31: from some poles the two ends look alike, two equal maxima per turn). Survey and satellite "
        "curves: those of the "
        "recovery test above (generated with other settings than the ones σ was developed on; no viewing geometry, so σ is "
        "the statistical term alone).",
    ])


def _rendered_z(rng) -> tuple[list[float], list[int]]:
    """z of arcs cut from ``N_RENDERS`` noise-free renders, each with its own spin pole (isotropic), rate and phase:
    the synodic offset depends on where the pole lies relative to the Sun–observer bisector's motion, which the
    prior does not know (its synodic term, the bisector's turning rate, covers the offset of an isotropic pole
    within 1× in 63 % and 2× in 93 % of cases; tests/lightcurves/test_lc_prior.py)."""
    from lightcurves.photometry import sample_times
    from lightcurves.render import UnresolvedRenderer
    from lightcurves.simulate import simulate_lightcurve
    from lightcurves.targets import get_target

    target = get_target("atlas-centaur")
    renderer = UnresolvedRenderer(target)
    z, none, gross = [], 0, 0
    for _ in range(N_RENDERS):
        pole = rng.normal(size=3)
        rate = np.radians(rng.uniform(2.0, 8.0))
        sim = simulate_lightcurve(target, axis_T=[0, 0, 1], rate_rad_s=rate, duration_s=1700.0, cadence_s=RENDER_CADENCE_S, rng=rng, noise=False, uneven=False,
                                  renderer=renderer, pole_I=pole / np.linalg.norm(pole))
        t_all, m_all = sim.lightcurve.t_s, sim.lightcurve.mag
        s_all, o_all = sim.observation.sun_dir_I, sim.observation.observer_dir_I
        for _ in range(N_RENDERED_ARCS // N_RENDERS):
            arc = rng.uniform(200.0, 1600.0)
            sigma = np.exp(rng.uniform(np.log(0.01), np.log(0.1)))
            start = rng.uniform(0, t_all[-1] - arc)
            idx = np.unique(np.clip(np.searchsorted(t_all, start + sample_times(arc, RENDER_CADENCE_S, rng, jitter=0.0)), 0, t_all.size - 1))
            p = extract_spin_prior(t_all[idx], m_all[idx] + rng.normal(0, sigma, idx.size), np.full(idx.size, sigma), sun_dir=s_all[idx],
                                   observer_dir=o_all[idx])
            if not p.significant:
                none += 1
            elif abs(p.frequency_hz - rate / (2 * np.pi)) > 0.5 / arc:
                gross += 1
            else:
                z.append((p.rate_rad_s - rate) / p.rate_sigma_rad_s)
    return z, [none, gross]


def run() -> str:
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    env = (f"OPENBLAS_NUM_THREADS={os.environ.get('OPENBLAS_NUM_THREADS', 'unset')}, 1-min load average {load:.1f} at start "
           f"(shared machine). Seed {REPORT_SEED}.")
    rng = np.random.default_rng(REPORT_SEED)
    recovery, recovery_z = _recovery_section(rng)
    parts = ["## Periods: lcnav against LombScargle on realistic cadences", "", env, "", recovery, "",
             _false_alarm_section(rng), "", _calibration_section(rng, recovery_z)]
    return "\n".join(parts)
