"""What a run's recording holds, where, and how the rerun viewer lays it out.

Entity layout (DESIGN.md paths; every series on the ``sim_time`` timeline):

==========================================================  =====================================
``/truth/<quantity>/<axis>``                                true value (``rr.Scalars``)
``/estimate/<filter>/<quantity>/<axis>``                    the filter's estimate
``/estimate/<filter>/error/<quantity>/<axis>/value``        estimate − truth
``/estimate/<filter>/error/<quantity>/<axis>/plus3sigma``   +3σ of the filter's covariance
``/estimate/<filter>/error/<quantity>/<axis>/minus3sigma``  −3σ
``/gate/<filter>/<source>/e2`` (and ``/lower``, ``/upper``) normalised innovation squared and its
                                                            chi-square bounds; rejections as
                                                            ``rr.TextLog`` at ``/gate/<filter>/log``
``/measurement/<source>/...``                               measurements as the filter saw them
``/lightcurve/<name>``                                      magnitudes (``rr.Scalars``)
``/spectrum/<name>``                                        a spectrum (``rr.BarChart`` with the
                                                            frequencies as ``abscissa``)
``/camera/left|right/...``                                  stereo images
``/cloud/...``                                              point clouds (``rr.Points3D``)
==========================================================  =====================================

:func:`send_truth` and :func:`send_estimate` write the scalar parts of that
layout; :func:`run_blueprint` builds the viewer layout that opens on them:
truth-vs-estimate plots, errors within ±3σ, gate events, light curve and
spectrum, camera images and clouds — only the panels for what the run holds.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
import rerun.blueprint as rrb

from studies.recording.writer import send_scalars

AXES = ("x", "y", "z")

#: One hue per component, shared by estimate and error, so a plot pairs them at a glance (the truth is neutral: TRUTH_RGBA).
COMPONENT_RGB = {"w": (110, 110, 110), "x": (215, 50, 45), "y": (35, 150, 60), "z": (40, 90, 215),
                 "k1": (200, 120, 20), "k2": (130, 60, 190)}
#: The ±3σ envelope: thin and grey, so it reads as a bound, not as data.
SIGMA_RGBA = (140, 140, 140, 150)
#: The truth: one fixed neutral near-black for every component, wide and translucent under the coloured estimates, so
#: that truth and estimate are told apart by colour, not by a shade of one hue (the viewer draws no dashed lines).
TRUTH_RGBA = (25, 25, 25, 140)
#: The unit of each recorded quantity and of its error, as its plots' titles show them (``"w_ST_T (rad/s)"``): SI
#: (DESIGN.md), ``1`` for a dimensionless one. ``q_TS``'s error is the rotation vector of q̂ ⊗ q⁻¹ (rad); CoMBiNa's
#: ``sigma`` error is an error MRP (dimensionless), its ``gamma_over_a`` the angular momentum over the axial inertia (rad/s).
UNITS = {"q_TS": ("1", "rad"), "w_ST_T": ("rad/s", "rad/s"), "w_T_T": ("rad/s", "rad/s"), "r_ST_T": ("m", "m"), "v_ST_T": ("m/s", "m/s"),
         "k": ("1", "1"), "range_m": ("m", "m"),
         "r": ("m", "m"), "v": ("m/s", "m/s"), "sigma": ("1", "1"), "w": ("rad/s", "rad/s"), "phi": ("rad", "rad"), "delta": ("rad", "rad"),
         "gamma_over_a": ("rad/s", "rad/s")}
#: The part of a run (its last fraction, by time) whose errors and gate values set a plot's visible range
#: (:func:`converged_range`): the first seconds' transient would otherwise flatten everything after it.
CONVERGED_FRACTION = 0.5


def _component_rgb(axis: str, index: int) -> tuple[int, int, int]:
    palette = list(COMPONENT_RGB.values())
    return COMPONENT_RGB.get(axis, palette[index % len(palette)])


def style_series(rec, entity: str, name: str, rgba, *, width: float) -> None:
    """Static line style of one scalar series: its colour (RGB or RGBA), width and legend name."""
    import rerun as rr

    rec.log(entity, rr.SeriesLines(colors=[tuple(rgba)], widths=[width], names=[name]), static=True)


def send_truth(rec, quantity: str, t_s, values, axes: Sequence[str] = AXES) -> None:
    """``/truth/<quantity>/<axis>`` (``values`` of shape ``(N, len(axes))``, or ``(N,)`` for ``/truth/<quantity>``)."""
    send_scalars(rec, f"/truth/{quantity}", t_s, values, list(axes))
    for a in axes:  # wide, translucent and neutral under the estimate (TRUTH_RGBA)
        style_series(rec, f"/truth/{quantity}/{a}", f"truth {a}", TRUTH_RGBA, width=3.0)


def send_estimate(rec, filter_name: str, quantity: str, t_s, estimate, *, truth=None, sigma=None,
                  axes: Sequence[str] = AXES) -> None:
    """The estimate of ``quantity`` by ``filter_name``, and with ``truth`` its error, with ``sigma`` its ±3σ.

    ``estimate``, ``truth`` and ``sigma`` are ``(N, len(axes))`` arrays (σ as the
    square root of the covariance diagonal, same units as the estimate). Where
    the error is not a difference (an attitude error as a rotation vector), pass
    ``truth=None`` and send the error through :func:`send_error`.
    """
    est = np.atleast_2d(np.asarray(estimate, dtype=float).T).T
    send_scalars(rec, f"/estimate/{filter_name}/{quantity}", t_s, est, list(axes))
    for j, a in enumerate(axes):
        style_series(rec, f"/estimate/{filter_name}/{quantity}/{a}", f"{filter_name} {a}", _component_rgb(a, j), width=1.5)
    if truth is not None:
        send_error(rec, filter_name, quantity, t_s, est - np.atleast_2d(np.asarray(truth, dtype=float).T).T, sigma, axes)


def send_error(rec, filter_name: str, quantity: str, t_s, error, sigma=None, axes: Sequence[str] = AXES) -> None:
    """``/estimate/<filter>/error/<quantity>/<axis>/{value,plus3sigma,minus3sigma}``."""
    err = np.atleast_2d(np.asarray(error, dtype=float).T).T
    base = f"/estimate/{filter_name}/error/{quantity}"
    for j, a in enumerate(axes):
        send_scalars(rec, f"{base}/{a}/value", t_s, err[:, j])
        style_series(rec, f"{base}/{a}/value", f"error {a}", _component_rgb(a, j), width=1.5)
        if sigma is not None:
            s3 = 3.0 * np.atleast_2d(np.asarray(sigma, dtype=float).T).T[:, j]
            for side, sign in (("plus3sigma", 1.0), ("minus3sigma", -1.0)):
                send_scalars(rec, f"{base}/{a}/{side}", t_s, sign * s3)
                style_series(rec, f"{base}/{a}/{side}", f"{'+' if sign > 0 else '−'}3σ {a}", SIGMA_RGBA, width=0.75)


def hemisphere_continuous(q) -> np.ndarray:
    """Quaternions ``(N, 4)`` with signs chosen so that consecutive ones have a non-negative dot product.

    ``q`` and ``−q`` are one attitude; a series that flips sign looks like a jump in a plot.
    """
    q = np.array(q, dtype=float)
    flips = np.concatenate([[False], np.einsum("ij,ij->i", q[1:], q[:-1]) < 0.0])
    q[np.cumsum(flips) % 2 == 1] *= -1.0
    return q


def send_quaternion(rec, filter_name: str, quantity: str, t_s, q_estimate, q_truth,
                    axes: Sequence[str] = ("w", "x", "y", "z")) -> None:
    """Truth and estimate of a quaternion, plotted without sign flips.

    The truth is made continuous in time (:func:`hemisphere_continuous`); each
    estimate takes the sign that puts it in the truth's hemisphere, so a
    converged filter plots on top of the truth instead of as its mirror image.
    """
    q_true = hemisphere_continuous(q_truth)
    q_est = np.array(q_estimate, dtype=float)
    q_est[np.einsum("ij,ij->i", q_est, q_true) < 0.0] *= -1.0
    send_truth(rec, quantity, t_s, q_true, axes)
    send_estimate(rec, filter_name, quantity, t_s, q_est, axes=axes)


def converged_range(t_s, *series, fraction: float = CONVERGED_FRACTION, margin: float = 1.25,
                    floor: float = 0.0) -> tuple[float, float]:
    """``(lo, hi)``: a plot's visible range that holds ``series`` over the last ``fraction`` of the run, with ``margin``.

    ``t_s`` (N,) and each series (N,) or (N, m), NaN ignored. Symmetric about 0
    when the series take both signs (errors and their ±3σ), else from 0 up to the
    largest value (an e² and its bounds); at least ``floor`` high. Where no value is
    finite, ``(-1, 1)``.
    """
    t = np.asarray(t_s, dtype=float)
    late = t >= t[0] + (1.0 - fraction) * (t[-1] - t[0])
    values = np.concatenate([np.asarray(v, dtype=float).reshape(len(t), -1)[late].ravel() for v in series])
    values = values[np.isfinite(values)]
    if not values.size:
        return (-1.0, 1.0)
    top = max(margin * float(np.abs(values).max()), floor)
    return (-top, top) if values.min() < 0 else (0.0, top)


def whole_run_plot(*, y_range: tuple[float, float] | None = None, legend: bool = True, **view) -> rrb.TimeSeriesView:
    """A time-series view over the whole ``sim_time`` range (not a window that follows the time cursor).

    ``y_range``: the visible range of the values (:func:`converged_range`); ``None`` lets the viewer fit all of them.
    ``legend``: a legend in the plot's top-left corner (off where the title and the component colours say it all).
    """
    everything = {"start": rrb.TimeRangeBoundary.infinite(), "end": rrb.TimeRangeBoundary.infinite()}
    axis_y = None if y_range is None else rrb.ScalarAxis(range=tuple(float(v) for v in y_range), zoom_lock=False)
    return rrb.TimeSeriesView(**view, time_ranges=rrb.VisibleTimeRange("sim_time", **everything),
                              axis_x=rrb.TimeAxis(view_range=rrb.TimeRange(**everything), zoom_lock=False),
                              axis_y=axis_y, plot_legend=rrb.PlotLegend(corner=rrb.components.Corner2D.LeftTop, visible=legend))


def run_blueprint(
    *,
    quantities: Sequence[str] = (),
    filters: Sequence[str] = (),
    errors: bool = True,
    gates: bool = False,
    lightcurve: bool = False,
    spectrum: bool = False,
    cameras: bool = False,
    cloud: bool = False,
    error_ranges: Mapping[tuple[str, str], tuple[float, float]] | None = None,
    gate_range: tuple[float, float] | None = None,
    units: Mapping[str, tuple[str, str]] | None = None,
) -> rrb.Blueprint:
    """The viewer layout of one run, in tabs, the first (truth vs estimate) active.

    ``quantities`` are the ``<quantity>`` parts of the paths above
    (``w_ST_T``, ``r_ST_T``, ``k``, ...), ``filters`` the ``<filter>`` parts
    (``ekf``, ``ukf``, ``combina``, ...). Tabs: *states* (one plot per quantity:
    truth and every filter's estimate), *errors* (one plot per filter and
    quantity: error and ±3σ), *gates*, *light curve* (curve and spectrum),
    *perception* (both cameras and the 3-D clouds with the truth pose).
    ``error_ranges`` (``{(filter, quantity): (lo, hi)}``) and ``gate_range`` set
    those plots' visible ranges (:func:`converged_range`), so that the converged
    errors, their ±3σ and the gate bounds are readable after the initial transient.
    Every plot's title ends in its unit: ``units`` (``{quantity: (unit, error unit)}``) over :data:`UNITS`; a quantity
    in neither is a ValueError. An error plot has no legend: its lines take the component colours of the *states* tab
    (x red, y green, z blue), its ±3σ envelope is grey, as its title says.
    """
    error_ranges = dict(error_ranges or {})
    units = {**UNITS, **(units or {})}
    unknown = [q for q in quantities if q not in units]
    if unknown:
        raise ValueError(f"run_blueprint: quantities {unknown}: no unit: expected a quantity of UNITS or units={{quantity: (unit, error unit)}}")
    tabs = []
    if quantities:
        views = [
            whole_run_plot(name=f"{q} ({units[q][0]})", origin="/", contents=[f"/truth/{q}/**"] + [f"/estimate/{f}/{q}/**" for f in filters])
            for q in quantities
        ]
        tabs.append(rrb.Grid(*views, name="states"))
        if errors and filters:
            err_views = [
                whole_run_plot(name=f"{f}: {q} error, ±3σ grey ({units[q][1]})", origin=f"/estimate/{f}/error/{q}",
                               y_range=error_ranges.get((f, q)), legend=False)
                for f in filters
                for q in quantities
            ]
            tabs.append(rrb.Grid(*err_views, name="errors ±3σ"))
    if gates:
        tabs.append(rrb.Vertical(whole_run_plot(name="gates: e² and bounds (1)", origin="/gate", y_range=gate_range),
                                 rrb.TextLogView(name="gate events", origin="/gate"), name="gates"))
    lc = []
    if lightcurve:
        lc.append(whole_run_plot(name="light curve (mag)", origin="/lightcurve"))
    if spectrum:
        lc.append(rrb.BarChartView(name="spectrum", origin="/spectrum"))
    if lc:
        tabs.append(rrb.Vertical(*lc, name="light curve"))
    perception = []
    if cameras:
        perception.append(rrb.Vertical(rrb.Spatial2DView(name="left camera", origin="/camera/left"),
                                       rrb.Spatial2DView(name="right camera", origin="/camera/right")))
    if cloud:
        perception.append(rrb.Spatial3DView(name="clouds", origin="/", contents=["/cloud/**", "/truth/**"]))
    if perception:
        tabs.append(rrb.Horizontal(*perception, name="perception"))
    if not tabs:
        raise ValueError("run_blueprint: nothing to show (give quantities, or enable gates/lightcurve/spectrum/cameras/cloud)")
    # paused: a playing viewer scrolls every plot along with the time cursor instead of showing the run
    return rrb.Blueprint(rrb.Tabs(*tabs, active_tab=0), rrb.TimePanel(timeline="sim_time", play_state="paused"),
                         collapse_panels=True)


def lightcurve_blueprint(*, spectra: Sequence[str] = ("dirty", "clean", "residual", "window")) -> rrb.Blueprint:
    """The viewer layout of a light-curve recording: the curve, its geometry, its spectra.

    The viewer cannot invert a plot axis, so the curve is shown as relative
    flux (up = brighter) above the magnitudes (up = fainter, as logged). Each
    spectrum is a bar chart over frequency in mHz (``/spectrum/<name>``).
    """
    curve = rrb.Vertical(
        whole_run_plot(name="relative flux (1; up = brighter)", origin="/lightcurve/relative_flux"),
        whole_run_plot(name="magnitude (mag; up = fainter)", origin="/lightcurve", contents=["/lightcurve/mag", "/lightcurve/mag_true"]),
        rrb.Horizontal(
            whole_run_plot(name="phase angle and elevation (deg)", origin="/lightcurve/geometry",
                           contents=["/lightcurve/geometry/phase_angle_deg", "/lightcurve/geometry/elevation_deg"]),
            whole_run_plot(name="range (km)", origin="/lightcurve/geometry", contents=["/lightcurve/geometry/range_km"]),
        ),
        name="light curve",
    )
    views = [rrb.BarChartView(name=f"{n} spectrum (amplitude vs mHz)", origin=f"/spectrum/{n}",
                              contents=[f"/spectrum/{n}"] + (["/spectrum/rotation_frequency"] if n == "clean" else [])) for n in spectra]
    spectrum = rrb.Vertical(*views,
                            rrb.TextDocumentView(name="extracted prior", origin="/spectrum/summary"), name="spectrum")
    return rrb.Blueprint(rrb.Tabs(curve, spectrum, active_tab=0), rrb.TimePanel(timeline="sim_time", play_state="paused"),
                         collapse_panels=True)
