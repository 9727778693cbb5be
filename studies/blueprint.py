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

from collections.abc import Sequence

import numpy as np
import rerun.blueprint as rrb

from studies.recording import send_scalars

AXES = ("x", "y", "z")


def send_truth(rec, quantity: str, t_s, values, axes: Sequence[str] = AXES) -> None:
    """``/truth/<quantity>/<axis>`` (``values`` of shape ``(N, len(axes))``, or ``(N,)`` for ``/truth/<quantity>``)."""
    send_scalars(rec, f"/truth/{quantity}", t_s, values, list(axes))


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
    if truth is not None:
        send_error(rec, filter_name, quantity, t_s, est - np.atleast_2d(np.asarray(truth, dtype=float).T).T, sigma, axes)


def send_error(rec, filter_name: str, quantity: str, t_s, error, sigma=None, axes: Sequence[str] = AXES) -> None:
    """``/estimate/<filter>/error/<quantity>/<axis>/{value,plus3sigma,minus3sigma}``."""
    err = np.atleast_2d(np.asarray(error, dtype=float).T).T
    base = f"/estimate/{filter_name}/error/{quantity}"
    for j, a in enumerate(axes):
        send_scalars(rec, f"{base}/{a}/value", t_s, err[:, j])
        if sigma is not None:
            s3 = 3.0 * np.atleast_2d(np.asarray(sigma, dtype=float).T).T[:, j]
            send_scalars(rec, f"{base}/{a}/plus3sigma", t_s, s3)
            send_scalars(rec, f"{base}/{a}/minus3sigma", t_s, -s3)


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
) -> rrb.Blueprint:
    """The viewer layout of one run, in tabs, the first (truth vs estimate) active.

    ``quantities`` are the ``<quantity>`` parts of the paths above
    (``w_ST_T``, ``r_ST_T``, ``k``, ...), ``filters`` the ``<filter>`` parts
    (``ekf``, ``ukf``, ``combina``, ...). Tabs: *states* (one plot per quantity:
    truth and every filter's estimate), *errors* (one plot per filter and
    quantity: error and ±3σ), *gates*, *light curve* (curve and spectrum),
    *perception* (both cameras and the 3-D clouds with the truth pose).
    """
    tabs = []
    if quantities:
        views = [
            rrb.TimeSeriesView(
                name=q, origin="/", contents=[f"/truth/{q}/**"] + [f"/estimate/{f}/{q}/**" for f in filters]
            )
            for q in quantities
        ]
        tabs.append(rrb.Grid(*views, name="states"))
        if errors and filters:
            err_views = [
                rrb.TimeSeriesView(name=f"{f}: {q} error ±3σ", origin=f"/estimate/{f}/error/{q}")
                for f in filters
                for q in quantities
            ]
            tabs.append(rrb.Grid(*err_views, name="errors ±3σ"))
    if gates:
        tabs.append(rrb.Vertical(rrb.TimeSeriesView(name="gates: e² and bounds", origin="/gate"),
                                 rrb.TextLogView(name="gate events", origin="/gate"), name="gates"))
    lc = []
    if lightcurve:
        lc.append(rrb.TimeSeriesView(name="light curve", origin="/lightcurve"))
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
    return rrb.Blueprint(rrb.Tabs(*tabs, active_tab=0), collapse_panels=True)
