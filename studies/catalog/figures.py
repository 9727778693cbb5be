"""Figures drawn with matplotlib (Agg), written atomically as PNG: the shared helpers and the chain's figures.

Every study of :mod:`studies.catalog` draws its figures with :func:`pyplot` and
writes them with :func:`save_png`. The figures of the light-curve → prior →
filter chain (``lcnav demo`` and the ``chain`` study) live here too, not in the
simulation (:mod:`studies.sim.chain`):

* :func:`plot_lightcurve` — measured magnitudes (inverted axis) and the noise-free curve;
* :func:`plot_spectrum` — WindowCLEAN's clean and dirty spectra, the chosen rotation
  frequency and the strongest peak;
* :func:`plot_errors` — one run's error per group against time with the filter's ±3σ;
* :func:`plot_prior_comparison` — the error magnitude without and with the prior on
  shared axes, with the thresholds and each run's ``t_conv``.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from studies.engine.io import atomic_path
from studies.sim.metrics import DEFAULT_THRESHOLDS, GROUPS, UNITS, convergence_time, state_errors
from studies.sim.truth import Truth

if TYPE_CHECKING:  # the chain's renderer (Mitsuba) is imported only by the chain's own code
    from studies.sim.chain import RenderedPrior


def pyplot():
    """``matplotlib.pyplot`` on the Agg backend (no display needed), imported on first use."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def save_png(fig, path: Path, dpi: int = 110) -> None:
    """Write ``fig`` to ``path`` as PNG atomically (temporary file, then rename) and close it."""
    with atomic_path(Path(path)) as tmp:
        fig.savefig(tmp, format="png", dpi=dpi)
    pyplot().close(fig)


def plot_lightcurve(rendered: RenderedPrior, path: Path) -> None:
    """The measured magnitudes (with 1-σ) and the noise-free curve against time."""
    from lightcurves.render import flux_to_mag

    plt = pyplot()
    lc = rendered.simulated.lightcurve
    fig, ax = plt.subplots(figsize=(8, 3.4), layout="constrained")
    ax.errorbar(lc.t_s, lc.mag, yerr=lc.mag_err, fmt=".", ms=2, lw=0.5, color="tab:blue", label="measured")
    ax.plot(lc.t_s, flux_to_mag(rendered.simulated.flux_true_w_m2), lw=0.8, color="k", label="noise-free")
    ax.invert_yaxis()
    meta = lc.meta
    ax.set(xlabel="time since first sample (s)", ylabel="magnitude",
           title=f"{meta.get('target')}: {np.degrees(rendered.truth_rate_rad_s):.3f}°/s about T-axis "
                 f"({', '.join(f'{v:.2f}' for v in rendered.axis_T)}), {len(lc)} samples")
    ax.legend(fontsize=8)
    save_png(fig, path)


def plot_spectrum(rendered: RenderedPrior, path: Path) -> None:
    """WindowCLEAN's clean spectrum (and the dirty one), the chosen rotation frequency and strongest peak."""
    plt = pyplot()
    p = rendered.extracted
    spec = p.spectrum
    fig, ax = plt.subplots(figsize=(8, 3.4), layout="constrained")
    ax.plot(spec.frequency_hz * 1e3, 2 * np.abs(spec.dirty), color="0.7", lw=0.7, label="dirty")
    ax.plot(spec.frequency_hz * 1e3, 2 * np.abs(spec.clean), color="tab:blue", lw=1.0, label="clean")
    f_true = rendered.truth_rate_rad_s / (2 * np.pi)
    ax.axvline(f_true * 1e3, color="k", ls=":", lw=1, label=f"truth rotation {f_true * 1e3:.3f} mHz")
    if p.significant:
        ax.axvline(p.frequency_hz * 1e3, color="tab:green", ls="--", lw=1,
                   label=f"chosen rotation {p.frequency_hz * 1e3:.3f} mHz ({p.maxima_per_rotation} maxima/turn)")
        ax.axvline(p.strongest_frequency_hz * 1e3, color="tab:red", ls="-.", lw=1, label=f"strongest peak {p.strongest_frequency_hz * 1e3:.3f} mHz")
    hi = min(spec.frequency_hz[-1], 12 * (p.frequency_hz or f_true))
    ax.set(xlim=(0, hi * 1e3), xlabel="frequency (mHz)", ylabel="semi-amplitude (mag)",
           title=f"spin prior: rate {np.degrees(p.rate_rad_s or np.nan):.4f}°/s (error {100 * rendered.rate_error:+.3f} %)")
    ax.legend(fontsize=8)
    save_png(fig, path)


def plot_errors(truth: Truth, run, path: Path, title: str) -> None:
    """Error against time with ±3σ of the filter, per group (attitude as a rotation vector, ω, r, v, k)."""
    from estimators.error_state import boxminus
    from estimators.state import ERROR_GROUPS

    plt = pyplot()
    t = truth.t - truth.t[0]
    err = boxminus(run.x, truth.x)  # error state of the estimate against the truth (14)
    sig3 = 3.0 * np.sqrt(np.diagonal(run.P, axis1=1, axis2=2))
    fig, axes = plt.subplots(len(GROUPS), 1, figsize=(8, 10), sharex=True, layout="constrained")
    colours = ("tab:blue", "tab:orange", "tab:green")
    for ax, g in zip(axes, GROUPS):
        sl = ERROR_GROUPS[g]
        names = ("k1", "k2") if g == "k" else ("x", "y", "z")
        for j, (name, c) in enumerate(zip(names, colours)):
            i = sl.start + j
            ax.plot(t, err[:, i], color=c, lw=0.8, label=f"{name}")
            ax.plot(t, sig3[:, i], color=c, lw=0.6, ls="--")
            ax.plot(t, -sig3[:, i], color=c, lw=0.6, ls="--")
        late = slice(len(t) // 10, None)  # past the acquisition transient
        lim = 1.3 * max(np.nanpercentile(np.abs(err[late, sl]), 99), np.nanmedian(sig3[late, sl])) + 1e-12
        ax.set(ylabel=f"δ{g} ({UNITS[g]})", ylim=(-lim, lim))
        ax.legend(fontsize=7, ncol=3, loc="upper right")
    axes[0].set_title(f"{title}: error (solid) and ±3σ (dashed)")
    axes[-1].set_xlabel("time (s)")
    save_png(fig, path)


def plot_prior_comparison(truth: Truth, runs: dict, path: Path, title: str) -> None:
    """Error magnitude per group of the same filter without and with the prior, on shared axes.

    ``runs`` maps a label ("no prior", "prior: tuning + init") to a
    :class:`estimators.navigation.NavigationRun`. Each panel is one group of
    :mod:`studies.sim.metrics` (state-based magnitude, log scale) with its
    convergence threshold (grey) and each run's convergence time ``t_conv``
    (a vertical line in the run's colour; none when it never converged).
    """
    plt = pyplot()
    t = truth.t - truth.t[0]
    errors = {label: state_errors(run.x, truth.x) for label, run in runs.items()}
    fig, axes = plt.subplots(len(GROUPS), 1, figsize=(8, 10), sharex=True, layout="constrained")
    colours = ("tab:red", "tab:blue", "tab:green", "tab:purple")
    for ax, g in zip(axes, GROUPS):
        thr = DEFAULT_THRESHOLDS[g]
        ax.axhline(thr, color="0.5", lw=1.0, ls="--", label=f"threshold {thr:.3g} {UNITS[g]}")
        for (label, err), c in zip(errors.items(), colours):
            m = np.maximum(err[g], 1e-12)
            ax.semilogy(t, m, color=c, lw=0.9, label=label)
            tc = convergence_time(t, err[g], thr)
            if np.isfinite(tc):
                ax.axvline(tc, color=c, lw=0.8, ls=":", label=f"t_conv {tc:.0f} s")
        ax.set(ylabel=f"|δ{g}| ({UNITS[g]})")
        ax.legend(fontsize=7, ncol=2, loc="upper right")
    axes[0].set_title(f"{title}: error without and with the prior")
    axes[-1].set_xlabel("time (s)")
    save_png(fig, path)
