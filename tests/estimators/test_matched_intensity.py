"""Matched intensity (eq. 3 of :mod:`estimators.process_noise`): white spectra, the Gauss–Markov limit, a filter it makes consistent."""

import numpy as np
import pytest

from estimators.process_noise import MatchedBudget, matched_intensity, relative_Q_d, white_noise_acceleration
from estimators.state import DK, DTHETA, DW_ST_T

F_HZ = np.linspace(0.0, 0.5, 200_001)  # to the Nyquist frequency of 1-s samples


def _gauss_markov_psd(sigma: float, tc_s: float) -> np.ndarray:
    """One-sided density (unit²/Hz) of a first-order Gauss–Markov process of variance σ² and correlation time T_c."""
    return 4.0 * sigma**2 * tc_s / (1.0 + (2.0 * np.pi * F_HZ * tc_s) ** 2)


def test_a_white_spectrum_is_its_own_intensity():
    assert matched_intensity(F_HZ, np.full(F_HZ.size, 2 * 3.1e-12), 4.8e-3) == pytest.approx(3.1e-12, rel=1e-9)


def test_a_fast_gauss_markov_process_matches_2_sigma2_tc():
    """T_c = 5 s against a filter band of ~1/300 s: the white-noise equivalent 2 σ² T_c of Bar-Shalom et al. §8.2."""
    q = matched_intensity(F_HZ, _gauss_markov_psd(1e-6, 5.0), 4.8e-3)
    assert q == pytest.approx(2 * 1e-12 * 5.0, rel=0.01)


def test_power_far_above_the_filter_band_counts_for_almost_nothing():
    """A torque at the spin harmonics (all power at 0.016 Hz, 0.1 rad/s) against ω_n ~ 3e-3 rad/s: |E(jω)|² ~ 1/ω² there."""
    G = np.zeros(F_HZ.size)
    i = np.searchsorted(F_HZ, 0.1 / (2 * np.pi))
    G[i] = (1e-6) ** 2 / (F_HZ[1] - F_HZ[0])  # variance σ² in one bin
    q = matched_intensity(F_HZ, G, 4.8e-3)
    assert 0 < q < 0.02 * 2 * (1e-6) ** 2 * (1 / 0.1)  # < 2 % of the 2 σ² T_c of a process with T_c = 1/ω (1.3 % measured)


@pytest.mark.parametrize("tc_s", [100.0, 400.0])
def test_the_matched_white_noise_makes_a_kalman_filter_consistent_on_a_correlated_acceleration(tc_s):
    """One axis, ``ξ̈ = a`` with ``a`` Gauss–Markov (T_c of the filter's band, where 2 σ² T_c is far off), ``ξ`` measured
    every second: a Kalman filter whose ``Q`` is eq. (1) with the matched q has the rate error variance it states
    (steady state, 400 000 steps), while the Gauss–Markov's own ``2 σ² T_c`` over-states it."""
    sigma, R, dt, n = 2e-6, 4.8e-3, 1.0, 400_000
    q = matched_intensity(F_HZ, _gauss_markov_psd(sigma, tc_s), R * dt)
    rng = np.random.default_rng(7)
    phi = np.exp(-dt / tc_s)
    a = np.empty(n)
    a[0] = sigma * rng.standard_normal()
    drive = sigma * np.sqrt(1 - phi**2) * rng.standard_normal(n)
    for k in range(1, n):
        a[k] = phi * a[k - 1] + drive[k]
    F = np.array([[1.0, dt], [0.0, 1.0]])
    Q = white_noise_acceleration(q, dt)
    # steady-state gain by iterating the Riccati recursion
    P = np.eye(2)
    for _ in range(20_000):
        M = F @ P @ F.T + Q
        K = M[:, 0] / (M[0, 0] + R)
        P = M - np.outer(K, M[0])
    P_pred = F @ P @ F.T + Q
    K = P_pred[:, 0] / (P_pred[0, 0] + R)
    x, x_hat = np.zeros(2), np.zeros(2)
    noise = np.sqrt(R) * rng.standard_normal(n)
    err = np.empty(n)
    for k in range(n):
        x = np.array([x[0] + dt * x[1] + 0.5 * dt**2 * a[k], x[1] + dt * a[k]])
        x_hat = F @ x_hat
        x_hat = x_hat + K * (x[0] + noise[k] - x_hat[0])
        err[k] = x[1] - x_hat[1]
    ratio = np.var(err[20_000:]) / P[1, 1]
    assert ratio == pytest.approx(1.0, abs=0.12)
    assert 2 * sigma**2 * tc_s > 2 * q  # the Gauss–Markov white-noise equivalent is more than twice the matched one


def test_matched_budget_assembles_eq_1():
    b = MatchedBudget(q_alpha_rad2_s3=2e-12, q_a_m2_s3=3e-12, q_kdot_1_s=1e-8)
    Q = b.Q_d(2.0)
    np.testing.assert_array_equal(Q, relative_Q_d(2e-12, 3e-12, 1e-8, 2.0))
    np.testing.assert_allclose(Q[DTHETA, DW_ST_T], white_noise_acceleration(2e-12, 2.0)[0, 1] * np.eye(3))
    np.testing.assert_allclose(Q[DK, DK], 2e-8 * np.eye(2))
    with pytest.raises(ValueError, match="q_kdot_1_s"):
        MatchedBudget(1e-12, 1e-12, q_kdot_1_s=float("nan"))
    with pytest.raises(ValueError, match="freq_hz"):
        matched_intensity(F_HZ[::-1], np.ones(F_HZ.size), 1.0)
