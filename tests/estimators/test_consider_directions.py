"""Considered directions (Schmidt–Kalman along a combination of states) and the weak inertia direction.

A considered direction ``u`` is not corrected: ``uᵀ δx = 0`` and, since ``uᵀ K = 0``, the Joseph form keeps
``uᵀ P⁺ u = uᵀ P⁻ u`` exactly. The release phase of the tunings (:mod:`estimators.tuning`) considers the
combination of ``k1, k2`` that moves the rate least (:func:`estimators.navigation.weak_inertia_direction`).
"""

import numpy as np
import pytest

from estimators.ekf import ExtendedKalmanFilter
from estimators.measurement import LinearMeasurement
from estimators.navigation import weak_inertia_direction
from estimators.process_model import LinearProcessModel, RelativeProcessModel
from estimators.state import DK
from estimators.ukf import UnscentedKalmanFilter
from studies.sim.scenarios import get_scenario
from studies.sim.truth import simulate_truth


def _filter(Filter, rng, n=4):
    A = rng.normal(size=(n, n))
    P0 = A @ A.T + n * np.eye(n)
    model = LinearProcessModel(lambda dt: np.eye(n))
    return Filter(model, x0=rng.normal(size=n), P0=P0, Q=np.zeros(n), gate_confidence=None)


@pytest.mark.parametrize("Filter", [ExtendedKalmanFilter, UnscentedKalmanFilter])
def test_a_considered_direction_is_neither_corrected_nor_shrunk(Filter):
    rng = np.random.default_rng(5)
    f = _filter(Filter, rng)
    u = rng.normal(size=4)
    u /= np.linalg.norm(u)
    f.consider_directions = u[None, :]
    cam = LinearMeasurement(H=rng.normal(size=(2, 4)), R=np.diag([0.3, 0.5]), name="cam")
    for _ in range(5):
        x, P = f.x.copy(), f.P.copy()
        f.update([(cam, rng.normal(size=2))])
        assert u @ (f.x - x) == pytest.approx(0.0, abs=1e-12)
        assert u @ f.P @ u == pytest.approx(u @ P @ u, rel=1e-10)
        assert np.linalg.eigvalsh(f.P).min() > 0
        # and the rest of the state did learn something
        assert np.trace(f.P) < np.trace(P)


@pytest.mark.parametrize("Filter", [ExtendedKalmanFilter, UnscentedKalmanFilter])
def test_a_considered_axis_as_a_direction_equals_a_considered_index(Filter):
    cam = LinearMeasurement(H=[[1.0, 0.5, 0.0, 2.0], [0.0, 1.0, -1.0, 0.0]], R=np.diag([0.2, 0.4]), name="cam")
    f_idx = _filter(Filter, np.random.default_rng(9))
    f_dir = _filter(Filter, np.random.default_rng(9))
    f_idx.consider = np.array([2])
    f_dir.consider_directions = np.eye(4)[[2]]
    for z in ([0.4, -1.0], [1.2, 0.3]):
        f_idx.update([(cam, np.array(z))])
        f_dir.update([(cam, np.array(z))])
    np.testing.assert_allclose(f_dir.x, f_idx.x, rtol=0, atol=1e-12)
    np.testing.assert_allclose(f_dir.P, f_idx.P, rtol=0, atol=1e-12)


def test_weak_inertia_direction_of_a_near_axisymmetric_tumble_is_k1_minus_k2():
    """SC3 (A ≈ C, spin about x and z): ``ω̇_y = (C − A)/B ω_x ω_z`` fixes ``k1 + k2``; ``k1 − k2`` moves the rate
    only through ``ω_y ≈ 0``. Its sensitivity is smaller than the other one's by more than an order of magnitude."""
    tr = simulate_truth(get_scenario("SC3"), 2.0, 1.0)
    model = RelativeProcessModel(tr.J_S_diag)
    u = weak_inertia_direction(model, tr.x[0], tr.servicer[0], 1.0)
    assert u.shape == (1, 14) and np.linalg.norm(u) == pytest.approx(1.0)
    assert abs(u[0, DK] @ np.array([1.0, -1.0]) / np.sqrt(2.0)) > 0.99
    _, F = model.propagate_with_jacobian(tr.x[0], tr.servicer[0], 1.0)
    s = np.linalg.svd(F[3:6, DK], compute_uv=False)
    assert s[1] < 0.05 * s[0]
