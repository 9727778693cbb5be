"""A filter run's recording opens on readable plots: visible ranges from the converged part, truth in a neutral colour.

Issue 30: the "errors ±3σ" tab auto-scaled to the initial transient (default
``P_0``: 3σ of 0.3 rad/s on the rate at t = 0 against ~0.003 later), so later
errors and their bands were flat lines; truth differed from the estimate only by
a lighter shade. Checked on a real EKF run's recording, read back from the file.
"""

import numpy as np
from rerun.chunk import RrdReader

from estimators.error_state import boxminus
from estimators.state import DTHETA, DW_ST_T, W_ST_T
from estimators.tuning import get_tuning
from studies.recording.blueprint import CONVERGED_FRACTION, TRUTH_RGBA, converged_range
from studies.recording.navigation import record_navigation
from studies.sim.navigation import NavigationSetup, navigate
from studies.sim.scenarios import get_scenario
from studies.sim.truth import simulate_truth
from tests.studies.test_recording_style import rgb, static_columns


def y_ranges(path) -> dict[str, tuple[float, float]]:
    """``{view origin: (lo, hi)}`` of the views of the ``.rrd``'s blueprint that set a visible value range."""
    reader = RrdReader(path)
    origins, ranges = {}, {}
    for chunk in reader.stream(store=reader.blueprints()[0]):
        cols = chunk.to_record_batch().to_pydict()
        path_ = str(chunk.entity_path)
        for o in cols.get("ViewBlueprint:space_origin", []):
            origins[path_] = o[0]
        for r in cols.get("ScalarAxis:range", []):
            ranges[path_.rsplit("/ScalarAxis", 1)[0]] = tuple(r[0])
    return {origins[view]: r for view, r in ranges.items()}


def test_converged_range_ignores_the_transient():
    t = np.arange(100.0)
    error = np.where(t < 10, 100.0, 0.01 * np.sin(t))
    lo, hi = converged_range(t, error, margin=1.25)
    late = t >= 50.0
    assert hi == -lo == 1.25 * np.abs(error[late]).max()
    assert converged_range(t, np.abs(error), floor=3.0) == (0.0, 3.0)  # non-negative series: from 0; the floor holds
    assert converged_range(t, np.full(100, np.nan)) == (-1.0, 1.0)


def test_error_and_gate_plots_open_on_the_converged_part(tmp_path):
    tr = simulate_truth(get_scenario("SC3"), 60.0, 1.0)
    run, meas = navigate(tr, NavigationSetup("ekf", get_tuning("relinearized")), np.random.default_rng(3))
    path = tmp_path / "run.rrd"
    record_navigation(path, tr, run, meas, recording_id="ranges")
    ranges = y_ranges(path)
    sig = np.sqrt(np.diagonal(run.P, axis1=1, axis2=2))
    late = tr.t >= tr.t[0] + (1 - CONVERGED_FRACTION) * (tr.t[-1] - tr.t[0])
    for name, err, s in (("w_ST_T", run.x[:, W_ST_T] - tr.x[:, W_ST_T], sig[:, DW_ST_T]),
                         ("q_TS", boxminus(run.x, tr.x)[:, DTHETA], sig[:, DTHETA])):
        lo, hi = ranges[f"/estimate/ekf/error/{name}"]
        assert lo == -hi
        assert hi >= np.abs(err[late]).max() and hi >= 3 * s[late].max()  # the converged errors and bands are in view
    # the rate's initial 3σ (default P_0: 0.1 rad/s) lies far outside: the transient does not set the scale
    assert 3 * sig[0, DW_ST_T].max() > 10 * ranges["/estimate/ekf/error/w_ST_T"][1]
    lo, hi = ranges["/gate"]
    upper = max(d.upper for d in run.decisions)
    assert lo == 0.0 and hi >= 1.25 * upper
    style = static_columns(path)
    for a in "xyz":
        truth = rgb(style[f"/truth/w_ST_T/{a}"]["SeriesLines:colors"][0][0])
        estimate = rgb(style[f"/estimate/ekf/w_ST_T/{a}"]["SeriesLines:colors"][0][0])
        assert truth == TRUTH_RGBA and truth[:3] != estimate[:3]
