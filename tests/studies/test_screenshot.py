"""A recording drawn by rerun's own viewer, headless: the blueprint opens on the styled series, and an error is an error.

Tests that need a picture skip (with the reason) on a machine that cannot draw headless (no Vulkan driver); the
checks of a bad file and of an error picture run wherever the viewer starts.
"""

import os
import subprocess

import matplotlib.image as mpimg
import numpy as np
import pytest

from studies.cli import main
from studies.recording.blueprint import COMPONENT_RGB, run_blueprint, send_estimate, send_truth
from studies.recording.screenshot import ERROR_BANNER_RGB, ScreenshotError, ScreenshotUnavailable, check_picture, rerun_executable, screenshot_recording
from studies.recording.writer import recording


def pixels_near(image: np.ndarray, rgb, tol: int = 30) -> int:
    """How many pixels of ``image`` (float RGBA in [0, 1]) lie within ``tol`` of ``rgb`` on every channel."""
    px = np.round(image[..., :3] * 255.0)
    return int(np.all(np.abs(px - np.asarray(rgb)) <= tol, axis=-1).sum())


def shot(rrds, png, **kw):
    """:func:`screenshot_recording`, or a skip naming why this machine cannot draw."""
    try:
        return screenshot_recording(rrds, png, **kw)
    except ScreenshotUnavailable as e:
        pytest.skip(f"no headless screenshots here: {e}")


XYZ = {a: COMPONENT_RGB[a] for a in "xyz"}  #: the three components' line colours


def line_pixels(png) -> dict:
    """Pixels of each component's line colour in the picture ``png``: one picture, no retry (the viewer is asked to draw
    only once it has loaded the files; pictures taken after a fixed number of frames missed the plots on a loaded machine)."""
    image = mpimg.imread(png)
    return {k: pixels_near(image, rgb) for k, rgb in XYZ.items()}


def headless_viewers() -> set[int]:
    """Process ids of the headless viewers running now (the launcher's child included)."""
    import psutil

    out = set()
    for p in psutil.process_iter(["cmdline"]):
        cmd = p.info["cmdline"] or []
        if "--headless" in cmd and any(c.endswith("rerun") for c in cmd[:2]):
            out.add(p.pid)
    return out


@pytest.fixture(scope="module")
def small_run(tmp_path_factory):
    """A recording of one filter's ``w_ST_T`` estimate (coloured per component) against its truth, 600 s."""
    t = np.arange(0.0, 600.0, 1.0)
    truth = np.column_stack([np.sin(t / 50), np.cos(t / 70), 0.5 * np.sin(t / 30)])
    path = tmp_path_factory.mktemp("shot") / "run.rrd"
    with recording(path, recording_id="shot-test", blueprint=run_blueprint(quantities=["w_ST_T"], filters=["ekf"])) as rec:
        send_truth(rec, "w_ST_T", t, truth)
        send_estimate(rec, "ekf", "w_ST_T", t, truth + 0.05, truth=truth, sigma=np.full_like(truth, 0.02))
    return path


def test_the_viewer_opens_on_truth_and_estimate_in_their_component_colours(small_run, tmp_path, monkeypatch):
    (tmp_path / "run.rrd").symlink_to(small_run)
    monkeypatch.chdir(tmp_path)  # relative paths, as in the README: the viewer once showed "No such file" for them
    before = headless_viewers()
    assert shot("run.rrd", "shot.png", width_px=900, height_px=600) == tmp_path / "shot.png"
    assert headless_viewers() <= before  # the viewer ended with its launcher (it once outlived it)
    assert mpimg.imread(tmp_path / "shot.png").shape[:2] >= (600, 900)
    counts = line_pixels(tmp_path / "shot.png")
    # each estimate line is drawn across the plot: hundreds of pixels of its hue
    assert min(counts.values()) > 300, counts
    # and an empty recording (the same blueprint, nothing logged) shows none of them
    empty = tmp_path / "empty.rrd"
    with recording(empty, recording_id="shot-empty", blueprint=run_blueprint(quantities=["w_ST_T"], filters=["ekf"])):
        pass
    blank = mpimg.imread(shot(empty, tmp_path / "empty.png", width_px=900, height_px=600))
    assert max(pixels_near(blank, COMPONENT_RGB[a]) for a in "xyz") < 0.1 * min(counts.values())


def test_lcnav_inspect_screenshot_draws_the_recording(small_run, tmp_path, capsys):
    png = tmp_path / "inspect.png"

    code = main(["inspect", str(small_run), "--screenshot", str(png)])
    err = capsys.readouterr().err
    if code == 2 and "Vulkan" in err:
        pytest.skip(f"no headless screenshots here: {err.strip()}")
    assert code == 0, err
    counts = line_pixels(png)
    assert min(counts.values()) > 300, counts
    assert main(["inspect", str(small_run), "--screenshot", str(tmp_path / "x.jpg")]) == 2  # refused before drawing
    assert "expected a .png file name" in capsys.readouterr().err and not (tmp_path / "x.jpg").exists()


def test_a_file_the_viewer_cannot_load_is_an_error_not_a_picture(tmp_path):
    bad = tmp_path / "bad.rrd"
    bad.write_bytes(b"not a recording")
    try:
        with pytest.raises(ScreenshotError, match=r"could not show .*bad\.rrd: .*Failed to load") as info:
            screenshot_recording(bad, tmp_path / "bad.png", width_px=300, height_px=200)
    except ScreenshotUnavailable as e:
        pytest.skip(f"no headless screenshots here: {e}")
    assert not isinstance(info.value, ScreenshotUnavailable)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.rrd"]  # no picture, no scratch folder


def test_the_viewers_error_screen_and_a_blank_picture_fail_the_picture_check(tmp_path):
    """The viewer's own picture of a missing file (exit 0, a PNG written) is recognised from its pixels alone."""
    png = tmp_path / "error.png"
    res = subprocess.run([str(rerun_executable()), "--headless", "--renderer", "vulkan", "--bind", "127.0.0.1", "--port", "auto",
                          "--window-size", "900x600", "--screenshot-to", str(png), str(tmp_path / "missing.rrd")],
                         capture_output=True, text=True, timeout=180, env=dict(os.environ, RERUN_ANALYTICS="0"))
    if not png.is_file():
        pytest.skip(f"no headless screenshots here: rerun exited {res.returncode}")
    assert res.returncode == 0  # what made the old check pass: the viewer itself does not fail
    assert "No such file" in res.stderr + res.stdout
    assert pixels_near(mpimg.imread(png), ERROR_BANNER_RGB, tol=0) > 1000
    with pytest.raises(ScreenshotError, match="load-error screen"):
        check_picture(png)
    mpimg.imsave(tmp_path / "blank.png", np.full((200, 300, 3), 0.05))
    with pytest.raises(ScreenshotError, match="blank picture"):
        check_picture(tmp_path / "blank.png")


def test_bad_requests_fail_before_drawing(tmp_path):
    with pytest.raises(FileNotFoundError, match="no recording"):
        screenshot_recording(tmp_path / "missing.rrd", tmp_path / "x.png")
    (tmp_path / "a.rrd").write_bytes(b"")
    with pytest.raises(ValueError, match=r"\.png"):
        screenshot_recording(tmp_path / "a.rrd", tmp_path / "x.jpg")
    with pytest.raises(ValueError, match="size"):
        screenshot_recording(tmp_path / "a.rrd", tmp_path / "x.png", width_px=10)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.rrd"]
