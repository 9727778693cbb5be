"""The inversion recording: each curve observed and fitted, and the pole's posterior on the sphere.

Entities (``sim_time`` = seconds since each curve's first sample, so every night starts at 0):

=========================================  ==============================================================
``/lightcurve/<curve>/observed``           observed brightness / its median (``rr.Scalars``)
``/lightcurve/<curve>/fitted``             the best solution's model brightness, same scale
``/lightcurve/<curve>/residual``           (observed − fitted)/σ
``/inversion/pole_map``                    the searched poles on the unit sphere (``rr.Points3D``), coloured
                                           by exp(−Δχ²/(2 s)) of the search's map (dark: excluded)
``/inversion/solutions/<k>``               solution k's pole (``rr.Arrows3D`` from the centre, labelled
                                           with its probability and period) and its 68 % / 95 % contours
                                           (``rr.LineStrips3D``)
``/inversion/profile_region``              with ``--pole-region``: the mapped poles inside the profile-likelihood
                                           region (``rr.Points3D``; white inside 68 %, yellow inside 95 %)
``/inversion/summary``                     the ``--json`` document (markdown)
=========================================  ==============================================================

Curve names are ``night_<k>`` (k from 1, file order). The blueprint has a *fits* tab (one plot of
observed and fitted, one of the residuals, per curve) and a *pole map* tab (the sphere and the summary).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import rerun.blueprint as rrb

from studies.catalog.inversion_figures import LEVELS, ellipse_I
from studies.recording.blueprint import style_series, whole_run_plot
from studies.recording.writer import recording, send_scalars


def curve_entity(k: int) -> str:
    """Entity name of curve ``k`` (0-based): ``night_<k + 1>``."""
    return f"night_{k + 1}"


def inversion_blueprint(n_curves: int) -> rrb.Blueprint:
    """Tabs: *fits* (per curve, observed + fitted above the residuals) and *pole map* (3-D sphere and summary)."""
    fits = []
    for k in range(n_curves):
        base = f"/lightcurve/{curve_entity(k)}"
        fits.append(rrb.Vertical(
            whole_run_plot(name=f"{curve_entity(k)}: observed and fitted (1; brightness / median)", origin=base,
                           contents=[f"{base}/observed", f"{base}/fitted"]),
            whole_run_plot(name=f"{curve_entity(k)}: residual (σ)", origin=base, contents=[f"{base}/residual"]),
            row_shares=[3, 1]))  # fmt: skip
    pole = rrb.Horizontal(rrb.Spatial3DView(name="pole posterior (unit sphere, I)", origin="/inversion", contents=["/inversion/**"]),
                          rrb.TextDocumentView(name="solutions", origin="/inversion/summary"), column_shares=[3, 2], name="pole map")
    return rrb.Blueprint(rrb.Tabs(rrb.Grid(*fits, name="fits"), pole, active_tab=0),
                         rrb.TimePanel(timeline="sim_time", play_state="paused"), collapse_panels=True)


def _magma(x: np.ndarray) -> np.ndarray:
    import matplotlib

    return (255 * np.asarray(matplotlib.colormaps["magma"](np.clip(x, 0.0, 1.0)))[:, :3]).astype(np.uint8)


def write_inversion_recording(path: Path, run, fitted: list, doc: dict, regions: tuple = ()) -> None:
    """Log ``run`` (:class:`studies.catalog.inversion.InversionRun`), the best solution's ``fitted`` curves, ``doc`` and the
    pole's profile-likelihood ``regions`` (when given) to ``path``."""
    import rerun as rr

    path = Path(path)
    with recording(path, recording_id=f"inversion-{path.stem}", blueprint=inversion_blueprint(len(run.curves))) as rec:
        for k, (c, f) in enumerate(zip(run.curves, fitted)):
            base = f"/lightcurve/{curve_entity(k)}"
            t = c.t_s - c.t_s[0]
            ref = float(np.median(c.brightness))
            send_scalars(rec, f"{base}/observed", t, c.brightness / ref)
            send_scalars(rec, f"{base}/fitted", t, f / ref)
            send_scalars(rec, f"{base}/residual", t, (c.brightness - f) / c.sigma)
            style_series(rec, f"{base}/observed", "observed", (90, 90, 90), width=1.0)
            style_series(rec, f"{base}/fitted", "fitted", (215, 50, 45), width=2.0)
            style_series(rec, f"{base}/residual", "residual", (40, 90, 215), width=1.0)
        scale, poles, chi2 = run.result.chi2_scale, run.result.pole_grid_I, run.result.chi2_map
        post = np.exp(-(chi2 - chi2.min()) / (2.0 * scale))
        rec.log("/inversion/pole_map", rr.Points3D(poles, colors=_magma(post), radii=0.02), static=True)
        for k, (sol, p) in enumerate(zip(run.solutions, run.probabilities)):
            label = f"#{k + 1} p={p:.2f} P={sol.period_s / 3600:.6g} h"
            rec.log(f"/inversion/solutions/{k + 1}", rr.Arrows3D(vectors=[1.25 * sol.pole_I], labels=[label], colors=[(46, 196, 255)]), static=True)
            rec.log(f"/inversion/solutions/{k + 1}/regions", rr.LineStrips3D([1.01 * ellipse_I(sol, lv) for lv in LEVELS],
                                                                              colors=[(46, 196, 255), (255, 209, 102)]), static=True)
        inside = [r.inside(0.95) for r in regions]
        if any(m.any() for m in inside):
            pts = np.concatenate([r.poles_I[m] for r, m in zip(regions, inside)])
            lv = np.concatenate([r.level[m] for r, m in zip(regions, inside)])
            rec.log("/inversion/profile_region", rr.Points3D(1.005 * pts, colors=np.where((lv <= 0.68)[:, None], [[255, 255, 255]], [[255, 209, 102]]),
                                                            radii=0.01), static=True)
        rec.log("/inversion/summary", rr.TextDocument("```json\n" + json.dumps(doc, indent=2) + "\n```", media_type="text/markdown"), static=True)
