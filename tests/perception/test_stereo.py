"""Stereo point clouds agree with the rendered depth (issue #5) and eq. 1 inverts the projection."""

from __future__ import annotations

import numpy as np
import pytest

from estimators.attitude import quat_to_dcm, random_quaternion
from lightcurves.targets import get_target
from perception.render import StereoCamera, StereoRenderer
from perception.stereo import stereo_cloud, triangulate


def test_eq1_inverts_the_pinhole_projection():
    cam = StereoCamera(resolution_px=1024)
    rng = np.random.default_rng(0)
    p = np.column_stack([rng.uniform(-3, 3, 50), rng.uniform(-3, 3, 50), -rng.uniform(20, 60, 50)])
    u, r, alpha = cam.project(p)
    assert np.allclose(triangulate(cam, u, r, alpha), p, atol=1e-9)
    assert np.allclose(alpha, 34 * 48 * 1.0 / -p[:, 2])  # α = f d b / depth (Table 1)


@pytest.mark.parametrize("range_m, resolution_px", [(30.0, 512), (40.0, 1024), (50.0, 512)])
def test_cloud_agrees_with_rendered_depth(range_m, resolution_px):
    rng = np.random.default_rng(int(range_m))
    renderer = StereoRenderer(get_target("box-wing"), StereoCamera(resolution_px=resolution_px))
    cam = renderer.camera
    sun_C = np.array([0.4, 0.3, 0.87]) / np.linalg.norm([0.4, 0.3, 0.87])
    frame = renderer.render(quat_to_dcm(random_quaternion(rng)), np.array([0.3, -0.4, -range_m]), sun_C, spp=16)
    cloud = stereo_cloud(frame.left, frame.right, cam)
    assert len(cloud.points_C) > 100
    row = (cloud.pixels[:, 1] - 0.5).astype(int)
    col = (cloud.pixels[:, 0] - 0.5).astype(int)
    truth = frame.depth_left[row, col]
    has_truth = np.isfinite(truth)  # pixels fully on the target
    assert has_truth.mean() > 0.7
    err = np.abs(-cloud.points_C[has_truth, 2] - truth[has_truth])
    assert np.median(err) < 0.02 * range_m
    # every point lies in front of the camera within the target's reach of its centre
    assert np.all(cloud.points_C[:, 2] < 0)
    reach = get_target("box-wing").radius_m
    centre = np.array([0.3, -0.4, -range_m])
    assert np.median(np.linalg.norm(cloud.points_C - centre, axis=1)) < reach


def test_black_frame_gives_an_empty_cloud():
    cam = StereoCamera(resolution_px=64)
    black = np.zeros((64, 64, 3))
    cloud = stereo_cloud(black, black, cam)
    assert cloud.points_C.shape == (0, 3)


def test_bad_images_raise():
    cam = StereoCamera(resolution_px=64)
    with pytest.raises(ValueError, match="must be \\(64, 64, 3\\) images"):
        stereo_cloud(np.zeros((32, 32, 3)), np.zeros((32, 32, 3)), cam)
    with pytest.raises(ValueError, match="detector must be one of"):
        stereo_cloud(np.zeros((64, 64, 3)), np.zeros((64, 64, 3)), cam, detector="surf")
