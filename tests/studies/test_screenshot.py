"""A recording drawn by rerun's own viewer, headless: the blueprint opens on the styled series."""

import matplotlib.image as mpimg
import numpy as np
import pytest

from studies.recording.blueprint import COMPONENT_RGB, run_blueprint, send_estimate, send_truth
from studies.recording.writer import recording
from studies.recording.screenshot import screenshot_recording


def pixels_near(image: np.ndarray, rgb, tol: int = 30) -> int:
    """How many pixels of ``image`` (float RGBA in [0, 1]) lie within ``tol`` of ``rgb`` on every channel."""
    px = np.round(image[..., :3] * 255.0)
    return int(np.all(np.abs(px - np.asarray(rgb)) <= tol, axis=-1).sum())


def test_the_viewer_opens_on_truth_and_estimate_in_their_component_colours(tmp_path):
    t = np.arange(0.0, 600.0, 1.0)
    truth = np.column_stack([np.sin(t / 50), np.cos(t / 70), 0.5 * np.sin(t / 30)])
    path = tmp_path / "run.rrd"
    with recording(path, recording_id="shot-test", blueprint=run_blueprint(quantities=["w_ST_T"], filters=["ekf"])) as rec:
        send_truth(rec, "w_ST_T", t, truth)
        send_estimate(rec, "ekf", "w_ST_T", t, truth + 0.05, truth=truth, sigma=np.full_like(truth, 0.02))
    png = screenshot_recording(path, tmp_path / "shot.png", width_px=900, height_px=600)
    image = mpimg.imread(png)
    assert image.shape[0] >= 600 and image.shape[1] >= 900
    counts = {a: pixels_near(image, COMPONENT_RGB[a]) for a in "xyz"}
    # each estimate line is drawn across the plot: hundreds of pixels of its hue
    assert min(counts.values()) > 300, counts
    # and an empty recording (the same blueprint, nothing logged) shows none of them
    empty = tmp_path / "empty.rrd"
    with recording(empty, recording_id="shot-empty", blueprint=run_blueprint(quantities=["w_ST_T"], filters=["ekf"])):
        pass
    blank = mpimg.imread(screenshot_recording(empty, tmp_path / "empty.png", width_px=900, height_px=600))
    assert max(pixels_near(blank, COMPONENT_RGB[a]) for a in "xyz") < 0.1 * min(counts.values())


def test_bad_requests_fail_before_drawing(tmp_path):
    with pytest.raises(FileNotFoundError, match="no recording"):
        screenshot_recording(tmp_path / "missing.rrd", tmp_path / "x.png")
    (tmp_path / "a.rrd").write_bytes(b"")
    with pytest.raises(ValueError, match=r"\.png"):
        screenshot_recording(tmp_path / "a.rrd", tmp_path / "x.jpg")
    with pytest.raises(ValueError, match="size"):
        screenshot_recording(tmp_path / "a.rrd", tmp_path / "x.png", width_px=10)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.rrd"]
