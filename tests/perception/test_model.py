"""Coarse model: outlier removal, carving, downsampling and PCA axes (§III.B of Maestrini et al.)."""

from __future__ import annotations

import numpy as np
import pytest

from estimators.attitude import quat_to_dcm, random_quaternion, rotvec_to_quat
from estimators.dynamics import cw_propagate
from lightcurves.targets import get_target
from perception.model import (
    accumulate_clouds,
    axis_errors_deg,
    build_coarse_model,
    carve_mask,
    football_orbit_L,
    knn_outlier_mask,
    voxel_downsample,
)
from perception.render import StereoCamera, StereoRenderer, pointing_dcm
from perception.stereo import stereo_cloud
from tests.perception.shapes import box_surface


def _ring_observations(rng, n_views=16, spurious=0.05):
    """Box-surface points seen from a ring of cameras, plus spurious points floating in front of them."""
    half = np.array([1.0, 0.75, 0.5])
    surf = box_surface(rng, 5000, 2 * half)
    normal = np.where(np.isclose(np.abs(surf), half), np.sign(surf), 0.0)
    pts, org, bad = [], [], []
    for a in np.linspace(0, 2 * np.pi, n_views, endpoint=False):
        cam = np.array([30 * np.cos(a), 30 * np.sin(a), 8 * np.sin(2 * a)])
        seen = surf[(np.einsum("ij,ij->i", normal, cam - surf) > 0) & (rng.random(len(surf)) < 0.3)]
        k = int(spurious * len(seen))
        base = seen[rng.choice(len(seen), k)]
        ray = (cam - base) / np.linalg.norm(cam - base, axis=1)[:, None]
        floating = base + ray * rng.uniform(0.4, 1.5, (k, 1))
        pts += [seen, floating]
        org += [np.broadcast_to(cam, seen.shape), np.broadcast_to(cam, floating.shape)]
        bad += [np.zeros(len(seen), bool), np.ones(k, bool)]
    return np.concatenate(pts), np.concatenate(org), np.concatenate(bad)


def test_carving_removes_seen_through_points_and_keeps_the_surface():
    rng = np.random.default_rng(1)
    p, o, bad = _ring_observations(rng)
    keep = carve_mask(p, o, rng=rng)
    assert (~keep[bad]).mean() > 0.8  # floating points in seen-through space are carved
    assert keep[~bad].mean() > 0.95  # surface points survive


def test_knn_density_test_flags_isolated_points():
    rng = np.random.default_rng(2)
    surf = box_surface(rng, 3000, (2.0, 1.5, 1.0))
    far = rng.uniform(-8, 8, (60, 3))
    far = far[np.max(np.abs(far) / [1.0, 0.75, 0.5], axis=1) > 2.0]  # well away from the box
    keep = knn_outlier_mask(np.concatenate([surf, far]))
    assert keep[:3000].mean() > 0.95
    assert (~keep[3000:]).mean() > 0.9


def test_voxel_downsample_hits_the_target_count():
    rng = np.random.default_rng(3)
    p = box_surface(rng, 20000, (2.0, 1.5, 1.0))
    d = voxel_downsample(p, 3000)
    assert 2400 <= len(d) <= 3000
    assert np.max(np.abs(d)) <= 1.0 + 1e-9  # centroids stay within the box


def test_football_orbit_is_the_closed_cw_ellipse_of_eq46():
    t, r = football_orbit_L(64)
    lu = 12.0
    assert np.allclose(r[0], [2 * lu, 0, 0.2 * lu])
    assert np.ptp(r[:, 1]) == pytest.approx(8 * lu, rel=0.01)  # along-track 2:1 with radial +-2 LU
    n = 1 / 963.65
    x0 = np.array([2 * lu, 0, 0.2 * lu, 0, -4 * lu * n, 0])
    assert np.allclose(cw_propagate(x0, n, 2 * np.pi / n)[:3], r[0], atol=1e-6)  # periodic


def test_pca_of_a_rendered_coarse_model_within_10_deg_of_principal_axes():
    """Render one football orbit around a tumbling box-wing, build the model, compare PCA with T."""
    target = get_target("box-wing")
    renderer = StereoRenderer(target, StereoCamera(resolution_px=256))
    rng = np.random.default_rng(5)
    t, r_L = football_orbit_L(24)
    w_T = np.array([0.004, 0.012, -0.008])  # rad/s tumble in T
    sun_L = np.array([0.6, 0.7, 0.3]) / np.linalg.norm([0.6, 0.7, 0.3])
    clouds, C_TC, o_T = [], [], []
    for ti, rl in zip(t, r_L):
        C_LT = quat_to_dcm(rotvec_to_quat(w_T * ti))
        C_LC = pointing_dcm(rl, np.array([0.0, 0.0, 1.0]))
        C_CT, r_TC_C = C_LC.T @ C_LT, C_LC.T @ rl
        frame = renderer.render(C_CT, r_TC_C, C_LC.T @ sun_L, spp=8)
        clouds.append(stereo_cloud(frame.left, frame.right, renderer.camera).points_C)
        C_TC.append(C_CT.T)
        o_T.append(-C_CT.T @ r_TC_C)
    C_MT = quat_to_dcm(random_quaternion(rng))  # an arbitrary target-fixed map frame
    pts, org = accumulate_clouds(clouds, [C_MT @ c for c in C_TC], [C_MT @ o for o in o_T], rng=rng, pose_noise_rad=0.002, pose_noise_m=0.02)
    model = build_coarse_model(pts, org, rng=rng)
    assert 1000 <= len(model.points_P) <= 3000
    err = axis_errors_deg(model.C_PM, C_MT.T)  # rows of C_MT.T: T's axes in M
    assert np.all(err < 10.0), err
