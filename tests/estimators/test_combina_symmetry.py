"""Symmetry detection of Maestrini et al. §IV.C: measured vs predicted relative rotations over a window, and the geometric roll test."""

import numpy as np
import pytest

from estimators.attitude import dcm_angle, quat_multiply, quat_to_dcm, random_quaternion, rotvec_to_quat
from estimators.dynamics import inertia_from_k, integrate_absolute
from scipy.spatial.transform import Rotation

from estimators.combina.symmetry import RollSymmetryTest, SymmetryDetector, cloud_in_model_frame, roll_discrepancy, roll_self_registration
from lightcurves.targets import get_target
from perception.model import mesh_surface_points

DT = 3.0


def _tumbling_truth(n, rate_rad_s, seed):
    """Attitudes of a nutating tri-axial body (k = [0.8, −0.6]) at |ω| = rate, every DT seconds."""
    rng = np.random.default_rng(seed)
    w = rng.normal(size=3)
    y0 = np.concatenate([[7e6, 0, 0, 0, 7.5e3, 0], random_quaternion(rng), rate_rad_s * w / np.linalg.norm(w)])
    tr = integrate_absolute(y0, DT * np.arange(n), inertia_from_k(0.8, -0.6))
    return tr.q_IB, tr.w_B


def _feed(detector, qs_meas, qs_pred_rel_from):
    """Feed measured attitudes with the relative rotations predicted from ``qs_pred_rel_from`` (the filter's estimates)."""
    C_hat = [quat_to_dcm(q).T for q in qs_pred_rel_from]
    for i, q in enumerate(qs_meas):
        detector.add(i * DT, quat_to_dcm(q).T, C_hat[i] @ C_hat[i - 1].T if i else np.eye(3))


def test_fast_nutating_target_exact_prediction_never_detected():
    """At 1.2 rad/s the target turns 206° per step and nutates: eq. 34's |ω̂|Δt disagrees with eq. 33 by far more
    than 20° on most pairs (the old false detection), the integrated prediction agrees to round-off."""
    qs, ws = _tumbling_truth(80, 1.2, seed=3)
    d = SymmetryDetector()
    old_eq34 = []
    for i, q in enumerate(qs):
        C = quat_to_dcm(q).T
        c = d.add(i * DT, C, C @ quat_to_dcm(qs[i - 1]) if i else np.eye(3))
        if c is not None:
            assert c.discrepancy_rad < 1e-6  # arccos near 0: ~sqrt(eps)
            old_eq34.append(abs(float(dcm_angle(quat_to_dcm(qs[i - 1]).T, C)) - np.linalg.norm(ws[i - 1]) * DT))
    assert not d.detected
    assert np.median(old_eq34) > np.deg2rad(20.0)


def test_no_false_detection_at_fast_rates_over_seeds():
    """Asymmetric target at 1.0 rad/s, 2° registration noise, 5% gross outliers, a prediction off by 1°:
    the issue's bound is ≤ 2% false detections; over 40 seeds × 100 measurements a detector at exactly 2%
    would show 0 with probability 45% only, and the old detector fired on most fast seeds. We require 0."""
    n_seeds, detections = 40, 0
    for seed in range(n_seeds):
        rng = np.random.default_rng(100 + seed)
        qs, _ = _tumbling_truth(100, 1.0, seed=seed)
        meas, pred = [], []
        for q in qs:
            dq = rotvec_to_quat(np.deg2rad(2.0) * rng.normal(size=3))
            if rng.random() < 0.05:
                dq = rotvec_to_quat(rng.uniform(0.7, np.pi) * rng.normal(size=3) / np.sqrt(3))
            meas.append(quat_multiply(q, dq))
            pred.append(quat_multiply(q, rotvec_to_quat(np.deg2rad(1.0) * rng.normal(size=3))))
        d = SymmetryDetector()
        _feed(d, meas, pred)
        detections += d.detected
    assert detections == 0


def test_random_roll_about_an_axis_is_detected_at_fast_and_slow_rates():
    for rate in (0.005, 1.0):
        rng = np.random.default_rng(5)
        qs, _ = _tumbling_truth(60, rate, seed=1)
        meas = [quat_multiply(q, quat_multiply(rotvec_to_quat(np.deg2rad(2.0) * rng.normal(size=3)),
                                               rotvec_to_quat(np.array([0.0, rng.uniform(0, 2 * np.pi), 0.0])))) for q in qs]
        d = SymmetryDetector()
        _feed(d, meas, qs)
        assert d.detected and d.detected_at <= DT * (d.window + 5), rate


def test_unsure_prediction_is_not_counted():
    """A filter whose prediction is uncertain (3σ above the threshold) adds nothing to the window."""
    rng = np.random.default_rng(2)
    d = SymmetryDetector()
    for i in range(60):
        d.add(i * DT, quat_to_dcm(random_quaternion(rng)).T, np.eye(3), sd_pred_rad=np.deg2rad(30.0))
    assert not d.detected
    with pytest.raises(ValueError, match="sd_pred_rad"):
        d.add(0.0, np.eye(3), np.eye(3), sd_pred_rad=float("nan"))


@pytest.fixture(scope="module")
def models():
    rng = np.random.default_rng(0)
    return {name: mesh_surface_points(get_target(name), 3000, rng)[0] for name in ("atlas-centaur", "box-wing")}


def test_roll_self_registration_separates_the_meshes(models):
    """One-sided noisy clouds (2 cm) of the Atlas-Centaur fit its model after 90/180/270° rolls about y (ratios ≤ 1.3);
    the box-wing's worst roll leaves them off the surface (ratio ≥ 3) — 10 clouds each."""
    rng = np.random.default_rng(1)
    for name, (lo, hi) in (("atlas-centaur", (0.0, 1.3)), ("box-wing", (3.0, np.inf))):
        for _ in range(10):
            pts, _ = mesh_surface_points(get_target(name), 4000, rng)
            view = rng.normal(size=3)
            cloud = pts[pts @ view > 0] + 0.02 * rng.normal(size=(int(np.sum(pts @ view > 0)), 3))
            worst = float(np.max(roll_self_registration(cloud, models[name], [0.0, 1.0, 0.0])))
            assert lo <= worst <= hi, (name, worst)


def _one_sided_cloud(name: str, rng) -> np.ndarray:
    pts, _ = mesh_surface_points(get_target(name), 4000, rng)
    view = rng.normal(size=3)
    return pts[pts @ view > 0] + 0.02 * rng.normal(size=(int(np.sum(pts @ view > 0)), 3))


def test_roll_discrepancy_is_small_only_for_the_symmetric_body(models):
    """Well registered one-sided clouds (2 cm noise), 10 each: a roll about y adds < 1 % of what a perpendicular 90° turn
    adds to the Atlas-Centaur's residual, > 10 % to the box-wing's (100 clouds each: −0.003–0.004 and 0.19–1.7)."""
    rng = np.random.default_rng(2)
    for name, (lo, hi) in (("atlas-centaur", (-0.01, 0.01)), ("box-wing", (0.1, np.inf))):
        for _ in range(10):
            d, turn = roll_discrepancy(_one_sided_cloud(name, rng), models[name], [0.0, 1.0, 0.0])
            assert lo <= d <= hi and turn > 2.0, (name, d, turn)


def test_a_failed_registration_does_not_look_symmetric(models):
    """Box-wing clouds registered 60–90° and 0.3 m off fit the model as badly rolled as unrolled (worst roll ratio
    < 1.5: the ratio test declared symmetry on such clouds on the rendered chain); a 90° turn fits them as well as
    their registration, so they do not count, and the test never declares symmetry."""
    rng = np.random.default_rng(3)
    test = RollSymmetryTest(models["box-wing"], [0.0, 1.0, 0.0])
    ratios = []
    for i in range(3 * test.window):
        axis = rng.normal(size=3)
        turn = Rotation.from_rotvec(np.deg2rad(rng.uniform(60.0, 90.0)) * axis / np.linalg.norm(axis))
        cloud = turn.apply(_one_sided_cloud("box-wing", rng)) + 0.3 * rng.normal(size=3)
        ratios.append(float(np.max(roll_self_registration(cloud, models["box-wing"], [0.0, 1.0, 0.0]))))
        test.add(i * DT, cloud)
    assert np.median(ratios) < 1.5
    assert not test.detected and len(test.recent) < test.window


def test_roll_test_window_and_cloud_frame(models):
    """Clouds given in LVLH relative to the chaser come back into the model frame; 5 symmetric clouds detect."""
    rng = np.random.default_rng(4)
    q = random_quaternion(rng)
    C_TI, C_IL = quat_to_dcm(q).T, quat_to_dcm(random_quaternion(rng))
    r_L = np.array([30.0, -5.0, 2.0])
    test = RollSymmetryTest(models["atlas-centaur"], [0.0, 1.0, 0.0])
    for i in range(test.window):
        pts, _ = mesh_surface_points(get_target("atlas-centaur"), 2000, rng)
        cloud_L = r_L + pts @ (C_IL.T @ C_TI.T).T  # p_L = C_LI C_IT p_T + r
        back = cloud_in_model_frame(cloud_L, r_L, C_TI, C_IL)
        np.testing.assert_allclose(back, pts, atol=1e-9)
        test.add(i * DT, back)
    assert test.detected and test.detected_at == (test.window - 1) * DT


def test_bad_input():
    with pytest.raises(ValueError, match="window"):
        SymmetryDetector(window=0)
    with pytest.raises(ValueError, match="threshold_rad"):
        SymmetryDetector(threshold_rad=-1.0)
    with pytest.raises(ValueError, match="cloud_T"):
        roll_self_registration(np.zeros((3, 3)), np.zeros((10, 3)), [0, 1, 0])
    with pytest.raises(ValueError, match="threshold"):
        RollSymmetryTest(np.zeros((10, 3)), [0, 1, 0], threshold=1.0)
    with pytest.raises(ValueError, match="axis_T"):
        roll_discrepancy(np.ones((20, 3)), np.zeros((10, 3)), [0, 0, 0])
