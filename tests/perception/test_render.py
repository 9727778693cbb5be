"""Stereo frames: camera geometry of Table 1 and ground-truth depth against an analytic sphere."""

from __future__ import annotations

import numpy as np
import pytest

from lightcurves.targets import get_target
from perception.render import StereoCamera, StereoRenderer, pointing_dcm, pose_from_relative_state


def test_table1_camera():
    full = StereoCamera(resolution_px=1024)
    small = StereoCamera(resolution_px=256)
    assert full.f_px == pytest.approx(34 * 48)  # f d = 1632 px
    assert full.fov_deg == pytest.approx(small.fov_deg)
    assert full.fov_deg == pytest.approx(np.rad2deg(2 * np.arctan(512 / 1632)))


def _sphere_depth(camera, center_C, radius, side_offset_y=0.0):
    """Analytic z-depth of each pixel ray hitting a sphere (NaN on a miss)."""
    n = camera.resolution_px
    c = (np.arange(n) + 0.5 - camera.center_px) / camera.f_px
    d = np.stack(np.broadcast_arrays(c[:, None], c[None, :], -1.0), axis=-1)  # rows -> x_C, cols -> y_C
    d = d / np.linalg.norm(d, axis=-1, keepdims=True)
    o = np.array([0.0, side_offset_y, 0.0])
    b = d @ (center_C - o)
    disc = b * b - (np.sum((center_C - o) ** 2) - radius**2)
    t = b - np.sqrt(np.where(disc > 0, disc, np.nan))
    return -t * d[..., 2]


def test_depth_aov_and_pixel_geometry_match_an_analytic_sphere():
    cam = StereoCamera(resolution_px=128)
    target = get_target("sphere", radius_m=2.0)
    r = StereoRenderer(target, cam)
    center = np.array([1.5, -2.0, -30.0])  # off-axis: below and left of the boresight
    frame = r.render(np.eye(3), center, sun_C=np.array([0.0, 0.3, 1.0]) / np.linalg.norm([0.0, 0.3, 1.0]), spp=64)
    for depth, off in ((frame.depth_left, 0.0), (frame.depth_right, cam.baseline_m)):
        truth = _sphere_depth(cam, center, 2.0, off)
        both = np.isfinite(depth) & np.isfinite(truth)
        # every fully covered pixel is on the analytic disc, and the disc is covered
        assert np.isfinite(truth[np.isfinite(depth)]).mean() > 0.99
        assert both.sum() > 0.9 * np.isfinite(truth).sum()
        assert np.median(np.abs(depth[both] - truth[both])) < 0.005  # m: pixel-footprint averaging (0.15 m pixels) and facets
    # the lit side faces the Sun (+z toward the camera, +y to the right): brighter right half
    lum = frame.left.sum(axis=-1)
    u, row, _ = cam.project(center)
    assert lum[:, int(u) + 3 :].sum() > lum[:, : int(u) - 3].sum()
    assert np.all(frame.left[~np.isfinite(_sphere_depth(cam, center, 2.3))] == 0.0)  # black background (2 px margin)


def test_pose_helpers():
    rng = np.random.default_rng(3)
    from estimators.attitude import quat_to_dcm, random_quaternion

    q_TS = random_quaternion(rng)
    r_ST_T = np.array([1.0, 2.0, 30.0])
    x = np.concatenate([q_TS, np.zeros(3), r_ST_T, np.zeros(3), [0.1, 0.2]])
    C_CT, r_TC_C = pose_from_relative_state(x)
    assert np.allclose(C_CT @ r_ST_T, -r_TC_C)
    assert np.allclose(C_CT, quat_to_dcm(q_TS).T)
    los = np.array([0.3, -0.4, 0.2])
    C_IC = pointing_dcm(los, np.array([0.0, 0.0, 1.0]))
    assert np.allclose(C_IC.T @ C_IC, np.eye(3)) and np.isclose(np.linalg.det(C_IC), 1.0)
    assert np.allclose(C_IC @ np.array([0, 0, -1.0]), los / np.linalg.norm(los))


def test_chaser_lamp_lights_the_side_the_sun_does_not():
    cam = StereoCamera(resolution_px=64)
    target = get_target("sphere", radius_m=2.0)
    sun_behind = np.array([0.0, 0.0, -1.0])  # Sun behind the target: the visible hemisphere is dark
    dark = StereoRenderer(target, cam, texture=False).render(np.eye(3), np.array([0.0, 0.0, -30.0]), sun_behind, spp=4)
    lit = StereoRenderer(target, cam, lamp_intensity_w_sr=1.0e5, texture=False).render(np.eye(3), np.array([0.0, 0.0, -30.0]), sun_behind, spp=4)
    disc = np.isfinite(lit.depth_left)
    assert disc.sum() > 50
    assert dark.left[disc].max() < 1e-6 * dark.white_radiance
    # a Lambertian sphere lit head-on by the lamp: centre radiance ~ albedo/π · I/d²
    centre = lit.left[32, 32].mean()
    assert centre == pytest.approx(0.5 / np.pi * 1.0e5 / 28.0**2, rel=0.1)
