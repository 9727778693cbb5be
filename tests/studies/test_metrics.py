"""Metrics of Renis et al. §6 (convergence time, steady-state RMSE) and NEES/NIS bands."""

import numpy as np
import pytest
from scipy.stats import chi2

from estimators.attitude import rotvec_to_quat
from estimators.error_state import boxplus
from estimators.state import Q_TS, R_ST_T
from studies.sim import metrics as M


def test_convergence_time_is_when_it_stays_below():
    t = np.arange(10.0) + 100.0
    m = np.array([5, 3, 0.5, 2, 0.4, 0.3, 0.9, 0.2, 0.1, 0.1])
    assert M.convergence_time(t, m, 1.0) == 4.0  # below at 2 s but back above at 3 s
    assert M.convergence_time(t, np.full(10, 0.1), 1.0) == 0.0
    assert np.isnan(M.convergence_time(t, np.r_[m[:-1], 2.0], 1.0))
    assert M.steady_state_rmse(t, m, 4.0) == pytest.approx(np.sqrt(np.mean(m[4:] ** 2)))
    assert np.isnan(M.steady_state_rmse(t, m, np.nan))


def test_late_rmse_scores_the_same_steps_whatever_the_convergence():
    """The second half of a ramp ``m = t`` on ``[0, T]``: ``√(∫_{T/2}^T t² dt / (T/2)) = T √(7/12)``; two runs that
    differ only before ``T/2`` (one converged sooner, one later) score the same, unlike §6's steady-state RMSE."""
    t = np.linspace(0.0, 1000.0, 100001)
    assert M.late_rmse(t + 50.0, t) == pytest.approx(1000.0 * np.sqrt(7.0 / 12.0), rel=1e-4)
    soon, late = np.r_[np.full(20, 5.0), np.full(80, 0.1)], np.r_[np.full(40, 5.0), np.full(60, 0.1)]
    tt = np.arange(100.0)
    assert M.late_rmse(tt, soon) == M.late_rmse(tt, late) == pytest.approx(0.1)
    assert M.steady_state_rmse(tt, soon, M.convergence_time(tt, soon, 1.0)) == pytest.approx(0.1)
    with pytest.raises(ValueError, match="fraction"):
        M.late_rmse(tt, soon, fraction=0.0)


def test_state_and_filter_magnitudes():
    x = np.zeros((3, 15))
    x[:, 0] = 1.0
    y = x.copy()
    y[:, Q_TS] = rotvec_to_quat(np.array([0.0, 0.0, 0.03]))
    y[:, R_ST_T] = [3.0, 4.0, 0.0]
    e = M.state_errors(x, y)
    np.testing.assert_allclose(e["q"], 0.03)
    np.testing.assert_allclose(e["r"], 5.0)
    np.testing.assert_allclose(e["w"], 0.0)
    P = np.tile(np.diag(np.repeat([1e-4, 1e-6, 4.0, 1.0, 0.01], [3, 3, 3, 3, 2])), (3, 1, 1))
    s = M.filter_sigmas(P)
    np.testing.assert_allclose(s["q"], np.sqrt(3e-4))
    np.testing.assert_allclose(s["r"], np.sqrt(12.0))
    res = M.evaluate(np.arange(3.0), y, P, x)
    assert np.isnan(res["state"]["r"].convergence_time_s)  # 5 m > 1 m threshold throughout
    assert res["state"]["q"].convergence_time_s == 0.0 and res["state"]["q"].steady_state_rmse == pytest.approx(0.03)


def test_nees_of_drawn_errors_is_chi_square_and_band_holds():
    rng = np.random.default_rng(0)
    A = rng.normal(size=(14, 14))
    P = A @ A.T + 14 * np.eye(14)
    L = np.linalg.cholesky(P)
    x_est = np.tile(np.r_[1.0, np.zeros(14)], (30, 400, 1))
    x_est[..., Q_TS] = rotvec_to_quat(rng.normal(size=(30, 400, 3)) * 0.3)
    dx = rng.normal(size=(30, 400, 14)) @ L.T * 1e-2
    x_true = boxplus(x_est, dx)
    e = M.nees(x_est, np.broadcast_to(P * 1e-4, (30, 400, 14, 14)), x_true)
    assert np.mean(e) == pytest.approx(14.0, rel=0.02)
    lo, hi = M.chi_square_band(14, 30, 0.95)
    assert lo == pytest.approx(chi2.ppf(0.025, 420) / 30) and hi == pytest.approx(chi2.ppf(0.975, 420) / 30)
    frac = M.fraction_in_band(e, 14)
    assert 0.92 <= frac <= 0.98  # independent steps: 95 % ± sampling
    # a 20 % overconfident filter falls out of the band
    assert M.fraction_in_band(1.2 * e, 14) < 0.5
    # a subset of states has its own degrees of freedom
    assert np.mean(M.nees(x_est, np.broadcast_to(P * 1e-4, (30, 400, 14, 14)), x_true, states=np.arange(12))) == pytest.approx(12.0, rel=0.03)


def test_conditional_nees_is_chi_square_when_p_is_right_and_finds_misstated_correlations():
    """Eq. (1) of ``conditional_nees``: χ²(len(block)) under the filter's own Gaussian; for two unit-variance states that
    ``P`` says correlate by ``r`` while the errors correlate by ``ρ``, its mean is ``(1 − 2 r ρ + r²)/(1 − r²)`` (both
    marginal NEES stay 1)."""
    rng = np.random.default_rng(3)
    A = rng.normal(size=(14, 14))
    P = A @ A.T + 3 * np.eye(14)
    n = 20000
    x_est = np.tile(np.r_[1.0, np.zeros(14)], (n, 1))
    x_est[:, Q_TS] = rotvec_to_quat(rng.normal(size=(n, 3)) * 0.3)
    dx = rng.normal(size=(n, 14)) @ np.linalg.cholesky(P).T * 1e-2
    x_true = boxplus(x_est, dx)
    Pn = np.broadcast_to(P * 1e-4, (n, 14, 14))
    for block in (np.arange(3, 6), np.arange(12, 14), np.array([0, 9])):
        e = M.conditional_nees(x_est, Pn, x_true, block)
        lo, hi = chi2.ppf([0.0005, 0.9995], n * len(block)) / n
        assert lo <= e.mean() <= hi, (block, e.mean())
    # within a subset of the states, the rest is that subset's other states
    e = M.conditional_nees(x_est, Pn, x_true, np.arange(3, 6), states=np.arange(12))
    assert chi2.ppf(0.0005, 3 * n) / n <= e.mean() <= chi2.ppf(0.9995, 3 * n) / n
    # misstated correlation: r claimed, rho actual (w_x and w_y; the other states independent, unit variance)
    r, rho = 0.5, 0.9
    C = np.eye(14)
    C[3, 4] = C[4, 3] = rho
    dx = rng.normal(size=(n, 14)) @ np.linalg.cholesky(C).T * 1e-2
    x_true = boxplus(x_est, dx)
    Pc = np.eye(14)
    Pc[3, 4] = Pc[4, 3] = r
    Pn = np.broadcast_to(Pc * 1e-4, (n, 14, 14))
    e = M.conditional_nees(x_est, Pn, x_true, [3])
    expected = (1 - 2 * r * rho + r**2) / (1 - r**2)  # 0.467
    assert e.mean() == pytest.approx(expected, rel=0.05)
    assert np.mean(M.nees(x_est, Pn, x_true, states=[3])) == pytest.approx(1.0, rel=0.05)


def test_conditional_nees_rejects_a_block_outside_the_tested_states():
    P = np.broadcast_to(np.eye(14), (2, 14, 14))
    x = np.tile(np.r_[1.0, np.zeros(14)], (2, 1))
    with pytest.raises(ValueError, match="proper subset"):
        M.conditional_nees(x, P, x, [12], states=np.arange(12))
    with pytest.raises(ValueError, match="proper subset"):
        M.conditional_nees(x, P, x, np.arange(14))


def test_joint_nees_is_a_block_alone_plus_the_rest_given_it():
    """The chain rule of the Gaussian: ``eᵀ P⁻¹ e = e_aᵀ P_aa⁻¹ e_a + ε_b|a`` for a partition ``a ∪ b`` of the tested states,
    whatever ``P`` and the errors (here errors that do not follow ``P``); ``block_nees_per_dof`` gives each block alone and
    given the rest, as NEES/dof."""
    rng = np.random.default_rng(5)
    A = rng.normal(size=(14, 14))
    P = np.broadcast_to(A @ A.T + 2 * np.eye(14), (50, 14, 14)) * 1e-4
    x_est = np.tile(np.r_[1.0, np.zeros(14)], (50, 1))
    x_true = boxplus(x_est, rng.standard_t(3, size=(50, 14)) * 1e-2)
    a, b = np.arange(0, 6), np.arange(6, 14)
    joint = M.nees(x_est, P, x_true)
    assert np.allclose(joint, M.nees(x_est, P, x_true, a) + M.conditional_nees(x_est, P, x_true, b))
    assert np.allclose(joint, M.nees(x_est, P, x_true, b) + M.conditional_nees(x_est, P, x_true, a))
    alone, given = M.block_nees_per_dof(x_est, P, x_true, states=np.arange(12))
    assert list(alone) == list(given) == ["q", "w", "r", "v"]  # k is not among the tested states
    assert alone["v"] == pytest.approx(np.mean(M.nees(x_est, P, x_true, np.arange(9, 12))) / 3)
    assert given["q"] == pytest.approx(np.mean(M.conditional_nees(x_est, P, x_true, np.arange(3), np.arange(12))) / 3)
