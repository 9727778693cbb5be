"""The simulated BCPD-like pose source: noise statistics, outliers, random roll of a symmetric target."""

import numpy as np
import pytest

from estimators.attitude import attitude_angle, quat_multiply, quat_conjugate, quat_to_dcm, quat_to_rotvec, random_quaternion
from perception.simulated_bcpd import SimulatedBCPD


def _draw(src, n=3000, seed=0):
    q = random_quaternion(np.random.default_rng(seed))
    r = np.array([24.0, -10.0, 2.4])
    return q, r, [src.measure(float(i), r, q) for i in range(n)]


def test_nominal_noise_and_outlier_fraction():
    src = SimulatedBCPD(np.random.default_rng(1), position_sigma_m=0.3, attitude_sigma_rad=np.deg2rad(2.0), outlier_probability=0.05)
    q, r, ms = _draw(src)
    nom = [m for m in ms if m.kind == "nominal"]
    frac_out = 1 - len(nom) / len(ms)
    assert abs(frac_out - 0.05) < 4 * np.sqrt(0.05 * 0.95 / len(ms))
    dr = np.array([m.r_L - r for m in nom])
    np.testing.assert_allclose(dr.std(axis=0), 0.3, rtol=0.08)
    rv = np.array([quat_to_rotvec(quat_multiply(quat_conjugate(q), m.q_IT)) for m in nom])  # error in T
    np.testing.assert_allclose(rv.std(axis=0), np.deg2rad(2.0), rtol=0.08)
    assert all(0.8 <= m.scale <= 1.2 for m in nom)
    assert all(not (0.8 <= m.scale <= 1.2) for m in ms if m.kind == "deformed")
    mis = [m for m in ms if m.kind == "misaligned"]
    assert mis and all(np.linalg.norm(m.r_L - r) > 3.0 for m in mis)


def test_symmetric_target_random_roll_keeps_the_axis():
    """Roll about body y is uniform; the measured symmetry axis (2nd row of C_TI) keeps nominal accuracy."""
    src = SimulatedBCPD(np.random.default_rng(2), outlier_probability=0.0, symmetry_axis_T=[0.0, 1.0, 0.0])
    q, r, ms = _draw(src, n=2000)
    J_true = quat_to_dcm(q)[:, 1]
    ax_err = np.array([np.arccos(np.clip(m.C_TI[1] @ J_true, -1, 1)) for m in ms])
    assert np.percentile(ax_err, 99) < np.deg2rad(2.0) * 3.5
    ang = np.array([attitude_angle(q, m.q_IT) for m in ms])
    # principal angle of a uniform roll is uniform on [0, π]: mean π/2, and about a tenth below 18°
    assert np.mean(ang) == pytest.approx(np.pi / 2, abs=0.06)
    assert np.mean(ang < np.deg2rad(18)) == pytest.approx(0.1, abs=0.03)


def test_bad_input():
    with pytest.raises(TypeError):
        SimulatedBCPD(np.random.RandomState(0))
    with pytest.raises(ValueError, match="outlier_probability"):
        SimulatedBCPD(np.random.default_rng(0), outlier_probability=1.5)
    with pytest.raises(ValueError, match="symmetry_axis_T"):
        SimulatedBCPD(np.random.default_rng(0), symmetry_axis_T=[0.0, 0.0, 0.0])
