"""How a recording looks: truth and estimate paired by colour, ±3σ as a grey bound, no quaternion sign flips, a name."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from rerun.chunk import RrdReader

from estimators.attitude import quat_multiply
from studies.recording.blueprint import SIGMA_RGBA, TRUTH_RGBA, hemisphere_continuous, run_blueprint, send_estimate, send_quaternion, send_truth
from studies.recording.reader import export_series
from studies.recording.writer import recording
from tests.rerun_cli import assert_rrd_verifies


def static_columns(path) -> dict[str, dict]:
    """``{entity: {column: value}}`` of the static chunks of the recording at ``path``."""
    reader = RrdReader(path)
    out: dict[str, dict] = {}
    for chunk in reader.stream(store=reader.recordings()[0]):
        if chunk.is_static:
            out.setdefault(str(chunk.entity_path), {}).update(chunk.to_record_batch().to_pydict())
    return out


def rgb(packed: int) -> tuple[int, int, int, int]:
    return tuple(int(packed) >> s & 0xFF for s in (24, 16, 8, 0))


@settings(max_examples=50, deadline=None)
@given(arrays(float, st.tuples(st.integers(2, 40), st.just(4)), elements=st.floats(-1, 1)).filter(
    lambda q: np.all(np.linalg.norm(q, axis=1) > 0.1)))
def test_hemisphere_continuous_keeps_each_attitude_and_removes_every_flip(q):
    c = hemisphere_continuous(q)
    # each row is ±(its input): the same attitude
    assert np.all(np.isclose(c, q, atol=0).all(axis=1) | np.isclose(c, -q, atol=0).all(axis=1))
    assert np.all(np.einsum("ij,ij->i", c[1:], c[:-1]) >= 0.0)


def test_estimate_and_error_share_a_hue_truth_is_neutral_and_sigma_a_grey_bound(tmp_path):
    t = np.arange(10.0)
    truth = np.column_stack([np.sin(t), np.cos(t), t])
    path = tmp_path / "style.rrd"
    with recording(path, recording_id="style-test", blueprint=run_blueprint(quantities=["w_ST_T"], filters=["ekf"])) as rec:
        send_truth(rec, "w_ST_T", t, truth)
        send_estimate(rec, "ekf", "w_ST_T", t, truth + 0.01, truth=truth, sigma=np.full_like(truth, 0.02))
    assert_rrd_verifies(path)
    style = static_columns(path)
    hues = set()
    for a in "xyz":
        truth_rgba = rgb(style[f"/truth/w_ST_T/{a}"]["SeriesLines:colors"][0][0])
        est_rgba = rgb(style[f"/estimate/ekf/w_ST_T/{a}"]["SeriesLines:colors"][0][0])
        err_rgba = rgb(style[f"/estimate/ekf/error/w_ST_T/{a}/value"]["SeriesLines:colors"][0][0])
        assert est_rgba[:3] == err_rgba[:3]
        assert truth_rgba == TRUTH_RGBA and truth_rgba[:3] != est_rgba[:3]  # truth in one neutral colour, told apart by colour
        assert truth_rgba[3] < est_rgba[3]  # and drawn translucent (and wide) under the estimate
        hues.add(est_rgba[:3])
        for side in ("plus3sigma", "minus3sigma"):
            assert rgb(style[f"/estimate/ekf/error/w_ST_T/{a}/{side}"]["SeriesLines:colors"][0][0]) == SIGMA_RGBA
    assert len(hues) == 3  # the three axes are told apart


def test_a_converged_estimate_plots_on_the_truth_even_when_the_signs_disagree(tmp_path):
    t = np.arange(0.0, 200.0, 1.0)
    angle = 0.1 * t  # several turns: a sign-normalised truth (q0 >= 0) flips at every half turn
    q_true = np.column_stack([np.cos(angle / 2), np.zeros_like(t), np.zeros_like(t), np.sin(angle / 2)])
    q_true[q_true[:, 0] < 0] *= -1.0
    small = np.column_stack([np.ones_like(t), np.full_like(t, 1e-3), np.zeros_like(t), np.zeros_like(t)])
    q_est = -quat_multiply(q_true, small / np.linalg.norm(small, axis=1, keepdims=True))  # 2 mrad off, stored with the other sign
    path = tmp_path / "quat.rrd"
    with recording(path, recording_id="quat-test") as rec:
        send_quaternion(rec, "ekf", "q_TS", t, q_est, q_true)
    df, _ = export_series(path)
    truth = df[[f"/truth/q_TS/{a}" for a in "wxyz"]].to_numpy()
    est = df[[f"/estimate/ekf/q_TS/{a}" for a in "wxyz"]].to_numpy()
    assert np.abs(est - truth).max() < 2e-3  # on top of the truth, not its mirror image
    assert np.abs(np.diff(truth, axis=0)).max() < 0.06  # no jump of the plotted truth (a step moves 0.05 rad)


def test_recording_is_named_for_the_viewer(tmp_path):
    path = tmp_path / "named.rrd"
    with recording(path, recording_id="run-sc3-ekf-seed1") as rec:
        send_truth(rec, "w_ST_T", np.arange(3.0), np.zeros((3, 3)))
    names = [v for cols in static_columns(path).values() for k, v in cols.items() if k.endswith(":name")]
    assert [["run-sc3-ekf-seed1"]] in names
