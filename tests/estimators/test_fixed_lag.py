"""The fixed-lag re-linearisation window (issue 31): exact on a linear model with process noise, bounded, consistent on the perturbed truth."""

import dataclasses

import numpy as np
import pytest
from filterpy.kalman import KalmanFilter
from scipy.stats import chi2

from estimators.batch import MeasurementHistory, posterior
from estimators.error_state import boxminus
from estimators.measurement import LinearMeasurement, PoseNoise
from estimators.navigation import run_navigation
from estimators.process_model import LinearProcessModel
from estimators.state import DK, N_ERROR
from estimators.tuning import get_tuning
from studies.sim.metrics import nees
from studies.sim.navigation import NavigationSetup, consistency_check, initial_guess, monte_carlo_run, simulate_measurements
from studies.sim.scenarios import get_scenario
from studies.sim.truth import simulate_truth


def _cv(dt):
    """2-D constant velocity, state ``[x, y, vx, vy]``."""
    F = np.eye(4)
    F[0, 2] = F[1, 3] = dt
    return F


CV2 = LinearProcessModel(_cv)
SX = LinearMeasurement(H=[[1.0, 0, 0, 0]], R=[[0.2]], name="x")
SY = LinearMeasurement(H=[[0, 1.0, 0, 0], [0, 0, 0, 1.0]], R=[[0.3, 0.05], [0.05, 0.1]], name="y")


def test_window_fit_with_process_noise_is_the_kalman_filter():
    """Linear model, known ``Q`` and ``R``: each window's fit from the Kalman filter's own output ``L`` steps back equals
    the Kalman filter at the fit's step to 1e-9 (mean and covariance), over a chain of windows; without ``Q`` it does not."""
    rng = np.random.default_rng(11)
    Q = np.diag([1e-3, 2e-3, 1e-2, 5e-3]) + 1e-4
    P0 = np.diag([4.0, 2.0, 1.0, 0.5])
    x_true = np.array([1.0, -2.0, 0.3, 0.1])
    kf = KalmanFilter(dim_x=4, dim_z=3)
    kf.x, kf.P, kf.F, kf.Q = np.zeros(4), P0.copy(), _cv(1.0), Q
    lag, period, n = 12, 4, 48
    history = MeasurementHistory()
    out = {0: (kf.x.copy(), kf.P.copy())}
    checked = 0
    for k in range(1, n + 1):
        x_true = _cv(1.0) @ x_true + rng.multivariate_normal(np.zeros(4), Q)
        zx = SX.H @ x_true + rng.normal(0, np.sqrt(0.2), 1)
        zy = SY.H @ x_true + rng.multivariate_normal(np.zeros(2), SY.R)
        history.add(k, SX, zx)
        kf.predict()
        if k % 3:  # partial steps: the x source only
            history.add(k, SY, zy)
            kf.update(np.concatenate([zx, zy]), R=np.block([[SX.R, np.zeros((1, 2))], [np.zeros((2, 1)), SY.R]]), H=np.vstack([SX.H, SY.H]))
        else:
            kf.update(zx, R=SX.R, H=SX.H)
        out[k] = (kf.x.copy(), kf.P.copy())
        if k % period == 0 and k >= lag:
            k0 = k - lag
            history.prune(k0)
            post = posterior(CV2, [None] * k, history, *out[k0], k, 1.0, k_start=k0, Q=Q)
            np.testing.assert_allclose(post.x, kf.x, rtol=0, atol=1e-9)
            np.testing.assert_allclose(post.P, kf.P, rtol=0, atol=1e-9)
            assert post.dof == sum(len(ks) * s.R.shape[0] for s, ks, _, _ in history.groups(k0, k)) == lag + 2 * (lag - lag // 3)  # x every step, y on 2 of 3
            deterministic = posterior(CV2, [None] * k, history, *out[k0], k, 1.0, k_start=k0)
            assert np.max(np.abs(deterministic.x - kf.x)) > 1e-3  # the window's process noise matters here
            checked += 1
    assert checked == (n - lag) // period + 1


def test_history_prune_keeps_only_the_window():
    """``prune(k)`` forgets steps ≤ k of every source, keeps the rest in order, and drops a source with none left."""
    h = MeasurementHistory()
    for k in range(1, 11):
        h.add(k, SX, [float(k)])
        if k <= 4:
            h.add(k, SY, [0.0, 0.0])
    h.prune(6)
    assert len(h) == 4
    groups = list(h.groups(0, 10))
    assert len(groups) == 1 and groups[0][0] is SX
    np.testing.assert_array_equal(groups[0][1], [7, 8, 9, 10])
    np.testing.assert_array_equal(groups[0][2][:, 0], [7.0, 8.0, 9.0, 10.0])


def test_fixed_lag_fit_touches_the_same_measurements_at_5_and_20_lags():
    """The cost of a window's fit does not grow with the elapsed time: at t = 5·lag and t = 20·lag each fit takes
    the measurements of one window, lag/τ × 6 degrees of freedom (pose every step), no more."""
    tau, lag = 2.0, 20.0
    tuning = dataclasses.replace(get_tuning("fixed-lag"), name="fixed-lag-20", lag_s=lag)
    tr = simulate_truth(get_scenario("SC1"), 20 * lag, tau)
    rng = np.random.default_rng(5)
    meas = simulate_measurements(tr, NavigationSetup("ekf", tuning), rng)
    run = run_navigation("ekf", tr.t, tr.servicer, tr.J_S_diag, *meas[:3], x0=initial_guess(tr, rng), tuning=tuning, pose_noise=PoseNoise(),
                         gate_start_s=10.0, consider=np.arange(12, 14))
    dof = {t: d for t, _, usable, d in run.relinearizations if usable}
    assert dof[5 * lag] == dof[20 * lag] == int(lag / tau) * 6
    # from 3 lags on every fit takes one window's data (the acquisition's fits at 10 and 20 s keep one pose source: no anchor,
    # so the window from t[0] lasts until 40 s; estimators.navigation._Relinearization), against 20 lags' for the full-information fit;
    # a fit that fails its χ² test anchors nothing, so the window that would start there reaches back one fit period further
    # (one of these 36 fits failed, at 250 s: the fit at 270 s took 90 dof), and the next is back to one window
    usable = {t: u for t, _, u, _ in run.relinearizations}
    for t, _, _, d in run.relinearizations:
        if t >= 3 * lag:
            assert d == int((lag + (0 if usable[t - lag] else tuning.relinearize_s)) / tau) * 6, (t, d)
    assert sum(not u for t, u in usable.items() if t >= 3 * lag) <= 2


@pytest.mark.slow
def test_fixed_lag_is_consistent_on_the_perturbed_truth():
    """SC3 on the perturbed truth (gravity gradient, J2, drag, nutation damping), 6 runs × 300 s: the EKF's mean NEES/dof
    lies in the 99 % chi-square band of 6 runs × 14 dof, 0.65–1.44 (each run's time mean counted as one χ²(14)/14 draw,
    which over-states its spread: conservative). Measured 2026-11-27 with the matched process noise (estimators.tuning,
    ``MATCHED_BUDGET``): 0.991, worst run 1.38, 99 % of the steps in band; with the σ budget's ``Q_d`` 0.761 (conservative);
    ``relinearized`` on the same data: 3.44 (worst run 4.39), above the band. With the gravity gradient in the model and the
    budget re-derived (2026-11-29) these 6 runs give 1.18 (worst run 1.71, 90 % of the steps in band); 6 rather than 10
    to keep the test suite within its budget."""
    tr = simulate_truth(get_scenario("SC3"), 300.0, 1.0, "perturbed")
    r = consistency_check(tr, "ekf", get_tuning("fixed-lag"), n_runs=6)
    assert r["diverged"] == 0
    n = 6 * r["dof"]
    assert chi2.ppf(0.005, n) / n < r["nees_per_dof"] < chi2.ppf(0.995, n) / n


def test_a_window_whose_process_noise_loses_definiteness_fails_the_fit_not_the_filter():
    """``R + S_j`` with ``S_j`` spanning more decades than double precision is not positive definite to machine precision:
    the fit fails with :class:`BatchFitError`, which the filter survives (the settling phase comes back), instead of a
    ``LinAlgError`` escaping the run (it escaped in one of the one-orbit runs of ``python -m benchmarks truths``)."""
    from estimators.batch import BatchFitError, _inflated_root

    R = np.eye(3) * 0.12**2 / 3
    u = np.array([1.0, 1e-9, 0.0]) / np.linalg.norm([1.0, 1e-9, 0.0])
    S = (1e30 * np.outer(u, u) - 1.0 * np.eye(3))[None]  # a rank-one 1e30 term whose rounding leaves −1 along the others
    with pytest.raises(BatchFitError, match="positive definite"):
        _inflated_root(R, S)
    L = _inflated_root(R, np.zeros((1, 3, 3)))
    np.testing.assert_allclose(L[0] @ L[0].T, np.linalg.inv(R), rtol=1e-12)


def test_the_windows_prior_is_whitened_without_inverting_its_covariance():
    """The window's prior rows ``Lᵀ δ`` with ``L Lᵀ = P_0⁻¹``: factored from ``P_0`` itself. Through ``P_0⁻¹`` (the code before
    2026-11-29) a covariance of condition 1e10 failed to factor on 23 of 50 random bases and 1e12 on all (a
    ``LinAlgError`` escaped an SC1 torque-free orbit of ``python -m benchmarks truths``); from ``P_0`` it whitens to
    ``|Lᵀ P_0 L − I| < 1e-4`` there, and a hopeless one (1e18) is a :class:`BatchFitError`, which the filter survives."""
    from estimators.batch import BatchFitError, _inverse_root

    rng = np.random.default_rng(0)
    for cond in (1e10, 1e12):
        for _ in range(10):
            U, _r = np.linalg.qr(rng.normal(size=(14, 14)))
            P = U @ np.diag(np.logspace(0.0, -np.log10(cond), 14)) @ U.T
            L = _inverse_root(0.5 * (P + P.T), "P")
            assert np.abs(L.T @ P @ L - np.eye(14)).max() < 1e-4
    with pytest.raises(BatchFitError, match="P is not positive definite"):
        _inverse_root(np.diag([1.0, -1e-30]), "P")


def test_the_window_stays_bounded_when_every_fit_fails():
    """SC1 on the perturbed truth (its orbit dispersed, seed 1003): the window fits fail their χ² test from 340 s on (the
    gravity gradient starts the intermediate-axis flip). Without a bound each window reached back to the last fit that
    passed (2133 degrees of freedom at 1500 s, CPU per step 3 → 2192 ms); with it no fit takes more than
    ``MAX_WINDOW_LAGS`` lags of measurements, and a fit from a last-resort anchor that disagrees with the filter does not
    reset it (measured without that test: one such fit at 1010 s took the NEES/dof from 0.9 to 37 for 50 s)."""
    from estimators.error_state import boxplus
    from estimators.navigation import MAX_WINDOW_LAGS
    from estimators.state import K_STATES, N_ERROR
    from perception.simulated_pose import simulate_pose_measurements
    from studies.sim.navigation import dispersed_truth

    seed, tuning, pn = 1003, get_tuning("fixed-lag"), PoseNoise()
    tr = dispersed_truth(simulate_truth(get_scenario("SC1"), 1500.0, 1.0, "perturbed"), np.random.default_rng((seed, 1)))
    rng = np.random.default_rng(seed)
    m = simulate_pose_measurements(tr.t, tr.x, rng, tau_s=1.0, sigma_q_rad=pn.sigma_q_rad, sigma_r_m=pn.sigma_r_m, noise=pn.model)
    x0 = boxplus(tr.x[0], rng.multivariate_normal(np.zeros(N_ERROR), tuning.P_0))
    run = run_navigation("ekf", tr.t, tr.servicer, tr.J_S_diag, m.t, m.q_TS, m.r_ST_T, x0=x0, tuning=tuning, pose_noise=pn, consider=K_STATES)
    fits = [(t, usable, dof) for t, _, usable, dof in run.relinearizations]
    assert sum(not usable for t, usable, _ in fits if t > 400) >= 100  # the case: (nearly) every fit fails
    assert max(dof for *_, dof in fits) <= MAX_WINDOW_LAGS * tuning.lag_s * 6 <= 1080  # 6 pose components a second; 3 lags of 60 s
    e = nees(run.x, run.P, tr.x, np.arange(12)) / 12
    assert np.mean(e[tr.t >= 60]) < 2.0, np.mean(e[tr.t >= 60])  # 1.16 measured (2.5 with the reset of the fit at 1010 s)


@pytest.mark.slow
def test_a_window_whose_inertia_prior_left_the_data_is_refitted_from_the_initial_one():
    """SC1 on the perturbed truth, seed 3026 of the ten-minute consistency row (EKF, 600 s): the window fits moved ``k`` to
    5 σ from the truth at 280 s and every later one failed, the filter lost the rate (run NEES/dof 240). Refitted with
    ``k``'s prior widened to ``P_0``'s, windows pass again, ``k`` ends within 3 σ of the truth and the run's NEES/dof over
    its last 300 steps is within the 99.9 % χ² bound of one 14-dof draw per step averaged over 30 independent ones
    (a loose bound: the steps are correlated)."""
    tr = simulate_truth(get_scenario("SC1"), 600.0, 1.0, "perturbed")
    tr_i, run = monte_carlo_run(tr, "ekf", get_tuning("fixed-lag"), 3026, disperse_orbit_phase=True)
    assert run.inertia_resets, "the failing windows were not refitted"
    e_k = boxminus(tr_i.x[-1], run.x[-1])[DK]
    assert np.all(np.abs(e_k) < 3.0 * np.sqrt(np.diag(run.P[-1])[DK])), e_k
    late = nees(run.x[-300:], run.P[-300:], tr_i.x[-300:], np.arange(N_ERROR))
    assert late.mean() / N_ERROR < chi2.ppf(0.999, 30 * N_ERROR) / (30 * N_ERROR), late.mean() / N_ERROR
