"""The filters' process model: analytic Jacobians against central differences, RK4 substeps."""

import numpy as np
import pytest

from estimators.attitude import random_quaternion
from estimators.dynamics import circular_orbit_state, relative_rhs
from estimators.error_state import boxminus, boxplus
from estimators.process_model import RelativeProcessModel, relative_jacobian
from estimators.state import DK, DR_ST_T, DTHETA, DV_ST_T, DW_ST_T, W_ST_T


def _state(rng):
    x = np.concatenate([random_quaternion(rng), [0.02, -0.01, 0.045], [30.0, -20.0, 25.0], [0.1, -0.05, 0.02], [1.466, -1.439]])
    s = np.concatenate([circular_orbit_state(6.9e6, 0.9, 0.3, 0.2), random_quaternion(rng), [0.001, 0.002, -0.0011]])
    return x, s


def test_continuous_jacobian_matches_central_differences(rng):
    J_S = np.array([1.2, 1.0, 0.8])
    for _ in range(3):
        x, s = _state(rng)
        A = relative_jacobian(x, s, J_S)
        An = np.empty((15, 15))
        for i in range(15):
            h = 1e-6 * max(1.0, abs(x[i]))
            e = np.zeros(15)
            e[i] = h
            An[:, i] = (relative_rhs(x + e, s, J_S) - relative_rhs(x - e, s, J_S)) / (2 * h)
        np.testing.assert_allclose(A, An, rtol=0, atol=1e-6)


def test_gravity_gradient_part_of_the_jacobian_matches_central_differences(rng):
    """The gravity-gradient torque's part of ``∂ẋ/∂x`` (with it minus without), against central differences of the
    same difference of right-hand sides, to 1e-7 of its size: the part is ~1e-6 (``3n²`` at 500 km times the inertia
    ratios' spread), which the full Jacobian's 1e-6 tolerance would not see."""
    J_S = np.array([1.2, 1.0, 0.8])
    for _ in range(3):
        x, s = _state(rng)
        A = relative_jacobian(x, s, J_S, gravity_gradient=True) - relative_jacobian(x, s, J_S)
        An = np.empty((15, 15))
        for i in range(15):
            h = 1e-5 * max(1.0, abs(x[i]))
            e = np.zeros(15)
            e[i] = h
            d = [relative_rhs(y, s, J_S, gravity_gradient=True) - relative_rhs(y, s, J_S) for y in (x + e, x - e)]
            An[:, i] = (d[0] - d[1]) / (2 * h)
        assert np.abs(A).max() > 1e-7  # the torque is there
        np.testing.assert_allclose(A, An, rtol=0, atol=1e-7 * np.abs(A).max())


def test_gravity_gradient_rate_is_the_truths_torque(truth):
    """The filters' gravity-gradient ω̇ equals the truth's J⁻¹τ (estimators.perturbations) at the target's position."""
    from estimators.perturbations import get_truth_physics, perturbing_accelerations

    tr = truth("SC3", 20.0)
    k = 7
    f = relative_rhs(tr.x[k], tr.servicer[k], tr.J_S_diag, gravity_gradient=True) - relative_rhs(tr.x[k], tr.servicer[k], tr.J_S_diag)
    params = get_truth_physics("perturbed").body_params("target", tr.target[0, :3])
    gg = perturbing_accelerations(tr.target[k : k + 1], tr.J_T_diag, params)["gravity_gradient"][0]
    assert np.linalg.norm(gg) > 1e-7
    # the relative rate's row carries −ω̇_T (eq. 7), in T
    np.testing.assert_allclose(-f[W_ST_T], gg, rtol=1e-6, atol=0)


@pytest.mark.parametrize("dt", [0.5, 1.0])
@pytest.mark.parametrize("gravity_gradient", [False, True])
def test_discrete_error_state_jacobian_matches_central_differences(rng, dt, gravity_gradient):
    """``F = ∂(f(x ⊞ δx) ⊟ f(x))/∂δx`` of eq. 25 on the 14 error states, to 1e-6."""
    model = RelativeProcessModel(np.array([500.0, 600.0, 400.0]), gravity_gradient=gravity_gradient)
    x, s = _state(rng)
    x1, F = model.propagate_with_jacobian(x, s, dt)
    np.testing.assert_allclose(x1, model.propagate(x, s, dt), rtol=0, atol=1e-12)
    Fn = np.empty((14, 14))
    h = 1e-6
    for i in range(14):
        e = np.zeros(14)
        e[i] = h
        Fn[:, i] = (boxminus(model.propagate(boxplus(x, e), s, dt), x1) - boxminus(model.propagate(boxplus(x, -e), s, dt), x1)) / (2 * h)
    np.testing.assert_allclose(F, Fn, rtol=0, atol=1e-6)


def test_substeps_make_the_model_match_the_truth(truth):
    """One 1 s RK4 step is 3e-5 m off the truth in SC1; 0.25 s substeps bring it below 1e-6 m."""
    tr = truth("SC1", 30.0)
    errs = {}
    for max_step in (np.inf, 0.25):
        m = RelativeProcessModel(tr.J_S_diag, max_step_s=max_step)
        e = np.array([boxminus(tr.x[k], m.propagate(tr.x[k - 1], tr.servicer[k - 1], 1.0)) for k in range(1, len(tr.t))])
        errs[max_step] = np.abs(e[:, DR_ST_T]).max()
        assert np.abs(e[:, DTHETA]).max() < 1e-9  # attitude (rad)
    assert errs[np.inf] > 1e-5
    assert errs[0.25] < 1e-6


def test_bad_model_input():
    with pytest.raises(ValueError, match="J_S_diag"):
        RelativeProcessModel(np.array([1.0, -1.0, 1.0]))
    with pytest.raises(ValueError, match="dt"):
        RelativeProcessModel(np.ones(3)).propagate(np.r_[1.0, np.zeros(14)], np.r_[7e6, 0, 0, 0, 7.5e3, 0, 1, 0, 0, 0, 0, 0, 0], 0.0)


def test_tuning_settling_phase():
    from estimators.tuning import Tuning, get_tuning

    t = get_tuning("settled")
    # after the settling phase, process noise on the rate and k only (estimators.tuning)
    assert t.settling_s > 0 and np.all(t.q_rate[np.r_[DTHETA, DR_ST_T, DV_ST_T]] == 0) and np.all(t.q_rate[DW_ST_T] > 0)
    assert np.all(t.q_rate[DK] > 0)
    np.testing.assert_allclose(t.Q_d(2.0), np.diag(2.0 * t.q_rate))
    np.testing.assert_allclose(np.diag(t.Q_d(2.0, settling=True)), 2.0 * (t.q_rate + t.settling_q_rate))
    assert np.all(get_tuning("general-conservative").settling_q_rate == 0) and get_tuning("general-conservative").settling_s == 0
    with pytest.raises(ValueError, match="settling_s"):
        Tuning("x", np.zeros(14), np.ones(14), settling_s=-1.0)
    with pytest.raises(ValueError, match="settling_q_rate"):
        Tuning("x", np.zeros(14), np.ones(14), settling_q_rate=-np.ones(14))


@pytest.mark.parametrize("gravity_gradient", [False, True])
def test_a_state_far_from_physical_gives_a_non_finite_trajectory_not_an_exception(rng, gravity_gradient):
    """A window fit's profile probe pushed ``k₂`` to 913 (SC3, measurements every 10 s, seed 3029 of the truths benchmark):
    ``e^{−k₂}`` underflows to 0 and the Jacobian's ``(e^{k₁} − 1)/e^{−k₂}`` divided by zero. Numba's default error model
    raised ``ZeroDivisionError`` out of the filter; the trajectory must be non-finite instead, which the fit tests for
    (``estimators.batch``: the cost rises without bound there)."""
    x, s = _state(rng)
    x[W_ST_T] = [-0.37, 2.09, -0.006]
    x[-1] = 913.0
    X, Phi, F = RelativeProcessModel(np.array([500.0, 600.0, 400.0]), gravity_gradient=gravity_gradient).trajectory(x, np.tile(s, (6, 1)), 10.0)
    assert not (np.isfinite(X).all() and np.isfinite(Phi).all())
    x[-1] = -1.439  # the same state with a physical k: finite
    X, Phi, F = RelativeProcessModel(np.array([500.0, 600.0, 400.0]), gravity_gradient=gravity_gradient).trajectory(x, np.tile(s, (6, 1)), 10.0)
    assert np.isfinite(X).all() and np.isfinite(Phi).all()
