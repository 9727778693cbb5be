"""Symmetry detection of 000 §IV.C: eq. 33 (corrected) against eq. 34 over a window."""

import numpy as np
import pytest

from estimators.attitude import quat_multiply, quat_to_dcm, random_quaternion, rotvec_to_quat
from estimators.symmetry import SymmetryDetector

W = np.array([-0.3953, -0.7065, -0.8153]) / 963.65
DT = 3.0


def _truth(n, seed=0):
    """Attitudes of a body spinning at constant W (body frame) from a random start."""
    q = [random_quaternion(np.random.default_rng(seed))]
    step = rotvec_to_quat(W * DT)
    for _ in range(n - 1):
        q.append(quat_multiply(q[-1], step))
    return np.array(q)


def test_eq33_equals_eq34_for_exact_measurements():
    """Without noise the measured principal angle is |ω| Δt to 1e-9 rad, and symmetry is never declared."""
    d = SymmetryDetector()
    for i, q in enumerate(_truth(60)):
        c = d.add(i * DT, quat_to_dcm(q).T, W)
        if c is not None:
            assert c.phi_measured_rad == pytest.approx(np.linalg.norm(W) * DT, abs=1e-9)
            assert c.discrepancy_rad < 1e-9
    assert not d.detected


def test_random_roll_about_an_axis_is_detected_and_isolated_outliers_are_not():
    rng = np.random.default_rng(5)
    qs = _truth(200, seed=1)
    noisy, sym = SymmetryDetector(), SymmetryDetector()
    for i, q in enumerate(qs):
        dq = rotvec_to_quat(np.deg2rad(2.0) * rng.normal(size=3))
        if i % 6 == 3:  # an isolated gross outlier every sixth measurement
            dq = rotvec_to_quat(rng.uniform(1.0, 3.0) * rng.normal(size=3) / np.sqrt(3))
        noisy.add(i * DT, quat_to_dcm(quat_multiply(q, dq)).T, W)
        roll = rotvec_to_quat(np.array([0.0, rng.uniform(0, 2 * np.pi), 0.0]))
        sym.add(i * DT, quat_to_dcm(quat_multiply(q, quat_multiply(dq, roll))).T, W)
    assert not noisy.detected
    assert sym.detected and sym.detected_at <= DT * (sym.window + 5)


def test_bad_input():
    with pytest.raises(ValueError, match="window"):
        SymmetryDetector(window=0)
    with pytest.raises(ValueError, match="threshold_rad"):
        SymmetryDetector(threshold_rad=-1.0)
