"""Figures of ``lcnav lightcurve invert``: the pole's posterior on the sky and the fit of each night.

* :func:`plot_pole_posterior` — a Mollweide map in ecliptic J2000 (λ, β) of exp(−Δχ²/(2 s)) from the
  search's screening map (best χ² over periods at each grid pole, s the result's χ² scale), with each
  solution's 68 % and 95 % ellipse (the χ²₂ contours of its tangent-plane covariance, mapped onto the
  sphere by the exponential map) and its probability; mirror solutions show as separate islands; with the pole's
  profile-likelihood regions (``--pole-region``) their mapped poles inside 68 % (filled) and 95 % (open circles);
* :func:`plot_night_fit` — one curve's observed brightness (with 1-σ bars) and the fitted model against
  time, and the normalised residuals (observed − fitted)/σ below.
"""

from __future__ import annotations

from pathlib import Path

import astropy.units as u
import numpy as np
from scipy.spatial import cKDTree
from scipy.stats import chi2 as chi2_dist

from studies.catalog.figures import pyplot, save_png

#: Credible levels drawn around each solution.
LEVELS = (0.68, 0.95)
#: Colour of the profile-likelihood region's poles (seen on the dark map and on the legend's white).
REGION_COLOR = "#ff4fd8"
#: Solutions below this probability are marked (grey ×) but not labelled or given ellipses (the best always is).
MIN_LABELLED_PROBABILITY = 1e-3


def _lonlat_deg(v_I) -> tuple[np.ndarray, np.ndarray]:
    """Ecliptic J2000 longitude in (−180, 180] and latitude, deg, of unit vectors (..., 3) in I."""
    from lightcurves.inversion.frames import pole_to_ecliptic

    lon, lat = pole_to_ecliptic(np.asarray(v_I, dtype=float))
    lon = np.degrees(lon)
    return np.where(lon > 180.0, lon - 360.0, lon), np.degrees(lat)


def ellipse_I(solution, level: float, n: int = 120) -> np.ndarray:
    """(n, 3) unit vectors on the ``level`` credible contour of a solution's pole (tangent covariance, exponential map).

    A tangent offset x = √(χ²₂(level)) L (cos t, sin t), L Lᵀ = Σ_pole, in the basis (e₁, e₂) of the
    pole frame, is the direction p cos|x| + (x₁e₁ + x₂e₂) sin|x|/|x| (posterior module of the search).
    """
    from lightcurves.inversion.posterior import tangent_exp

    L = np.linalg.cholesky(solution.pole_covariance_rad2 + 1e-18 * np.eye(2))
    t = np.linspace(0.0, 2.0 * np.pi, n)
    x = np.sqrt(chi2_dist.ppf(level, 2)) * (L @ np.stack([np.cos(t), np.sin(t)]))  # (2, n)
    return tangent_exp(solution.pole_I, x.T)


def _broken(lon: np.ndarray, lat: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The polyline with NaN inserted where it jumps across λ = ±180° (so the map draws no stray line)."""
    jump = np.flatnonzero(np.abs(np.diff(lon)) > 180.0) + 1
    return np.insert(lon, jump, np.nan), np.insert(lat, jump, np.nan)


def _plot_regions(ax, regions) -> None:
    """The mapped poles of the profile-likelihood ``regions`` inside 95 % (open) and 68 % (filled), in REGION_COLOR."""
    for level, face, name in ((0.95, "none", "95 %"), (0.68, REGION_COLOR, "68 %")):
        inside = [r.poles_I[r.inside(level)] for r in regions]
        pts = np.concatenate(inside) if inside else np.zeros((0, 3))
        if pts.size:
            lo, la = _lonlat_deg(pts)
            ax.scatter(np.radians(lo), np.radians(la), s=10, facecolors=face, edgecolors=REGION_COLOR, linewidths=0.8, zorder=3,
                       label=f"profile-likelihood region {name} ({pts.shape[0]} poles mapped inside)")


def plot_pole_posterior(run, path: Path, regions: tuple = ()) -> None:
    """Pole posterior on the ecliptic sky (module docstring), written to ``path`` (PNG); ``regions``: the pole's
    profile-likelihood regions (:func:`studies.catalog.inversion.profile_regions`), drawn when given."""
    plt = pyplot()
    scale, poles, chi2 = run.result.chi2_scale, run.result.pole_grid_I, run.result.chi2_map
    # the screened poles of every period range: each pixel takes its nearest searched pole
    post = np.exp(-(chi2 - chi2.min()) / (2.0 * scale))
    lon_g, lat_g = np.meshgrid(np.linspace(-180, 180, 361), np.linspace(-90, 90, 181))
    lam, bet = np.radians(lon_g), np.radians(lat_g)
    from lightcurves.inversion.frames import pole_from_ecliptic

    pix_I = pole_from_ecliptic(lam.ravel(), bet.ravel())
    _, nearest = cKDTree(poles).query(pix_I)
    image = post[nearest].reshape(lon_g.shape)

    fig = plt.figure(figsize=(13, 6))
    ax = fig.add_subplot(111, projection="mollweide")
    mesh = ax.pcolormesh(lam, bet, image, cmap="magma", vmin=0.0, vmax=1.0, shading="auto", rasterized=True)
    colors = ["#2ec4ff", "#7CFC00", "#ffd166", "#ff6b6b", "#c77dff", "#f4f1de"]
    shown = [k for k, p in enumerate(run.probabilities) if k == 0 or p >= MIN_LABELLED_PROBABILITY]
    for k in shown:
        sol, p = run.solutions[k], run.probabilities[k]
        col = colors[k % len(colors)]
        for level, style in zip(LEVELS, ("-", "--")):
            lo, la = _broken(*_lonlat_deg(ellipse_I(sol, level)))
            ax.plot(np.radians(lo), np.radians(la), style, color=col, lw=1.4)
        lo, la = _lonlat_deg(sol.pole_I)
        ax.plot(np.radians(lo), np.radians(la), "+", color=col, ms=12, mew=2,
                label=f"#{k + 1}  p = {p:.3g}   λ {lo % 360:.1f}°  β {la:+.1f}°  ±{sol.pole_sigma_deg:.2g}°   P = {sol.period_s / 3600:.8g} h")
        ax.annotate(f"{k + 1}", (np.radians(lo), np.radians(la)), xytext=(6, 4 + 9 * (k % 3)), textcoords="offset points", color=col,
                    fontsize=9, fontweight="bold")
    _plot_regions(ax, regions)
    rest = [k for k in range(len(run.solutions)) if k not in shown]
    if rest:
        lo, la = _lonlat_deg(np.array([run.solutions[k].pole_I for k in rest]))
        ax.plot(np.radians(lo), np.radians(la), "x", color="0.6", ms=5, ls="none",
                label=f"{len(rest)} more with p < {MIN_LABELLED_PROBABILITY:g} (inversion.json)")
    ax.legend(loc="upper left", bbox_to_anchor=(1.02, 1.0), fontsize=8, title="solutions (best first)", title_fontsize=9, frameon=False)
    ax.grid(True, color="0.6", lw=0.4, alpha=0.6)
    ax.set_xlabel("ecliptic longitude λ (J2000)")
    ax.set_ylabel("ecliptic latitude β")
    ax.tick_params(axis="x", colors="0.85", labelsize=8)
    cb = fig.colorbar(mesh, ax=ax, orientation="horizontal", fraction=0.05, pad=0.08, shrink=0.5)
    screen = "coarse copy of the shape, best period, axis and phase" if run.known_shape else "coarse convex model, best period"
    cb.set_label(f"exp(−Δχ²/2s) of the screening grid ({screen} per pole), s = {scale:.3g}")
    fig.subplots_adjust(left=0.07, right=0.68, top=0.9, bottom=0.08)
    ax.set_title(f"Pole posterior — {run.shape}, {len(run.curves)} curves; ellipses 68 % (solid) and 95 % (dashed)", fontsize=11)
    save_png(fig, path)


def _gaps_broken(t: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The line (t, y) with NaN at gaps longer than 10 median steps (a fitted line is not drawn across a gap)."""
    if t.size < 3:
        return t, y
    gap = np.flatnonzero(np.diff(t) > 10.0 * np.median(np.diff(t))) + 1
    return np.insert(t, gap, np.nan), np.insert(y, gap, np.nan)


def plot_night_fit(curve, fitted: np.ndarray, path: Path, title: str) -> None:
    """Observed vs fitted brightness of one curve and the residuals in σ (module docstring), written to ``path``.

    Both are divided by the median observed brightness, so relative and calibrated curves read alike.
    """
    plt = pyplot()
    t_min = (curve.t_s - curve.t_s[0]) / 60.0
    ref = float(np.median(curve.brightness))
    fig, (ax, axr) = plt.subplots(2, 1, figsize=(10, 5.5), sharex=True, gridspec_kw={"height_ratios": [3, 1]})
    ax.errorbar(t_min, curve.brightness / ref, yerr=curve.sigma / ref, fmt=".", ms=3, color="0.25", ecolor="0.7", lw=0.6, label="observed")
    ax.plot(*_gaps_broken(t_min, fitted / ref), ".-", color="tab:red", lw=1.0, ms=2.5, label="fitted (at the samples)")
    ax.set_ylabel("brightness / median")
    r = (curve.brightness - fitted) / curve.sigma
    ax.legend(loc="upper right", fontsize=9)
    ax.set_title(f"{title}   χ²/N = {float(r @ r) / r.size:.2f}", fontsize=11)
    axr.axhline(0.0, color="0.5", lw=0.8)
    axr.plot(t_min, r, ".", ms=3, color="tab:blue")
    lim = max(3.5, float(np.percentile(np.abs(r), 99.5)) * 1.1)
    axr.set_ylim(-lim, lim)
    axr.set_ylabel("(obs − fit)/σ")
    start = (curve.epoch + curve.t_s[0] * u.s).utc.isot[:19]
    axr.set_xlabel(f"minutes since {start} UTC")
    fig.tight_layout()
    save_png(fig, path)
