"""Spin priors: the prior object, its three uses, and the 120 s blackout of §6.3 of Renis et al."""

import numpy as np
import pytest

from estimators.attitude import quat_to_dcm
from estimators.error_state import boxplus
from estimators.measurement import TargetRateMeasurement
from estimators.navigation import run_navigation
from estimators.prior import BodyRatePrior, initialize_with_prior, rate_proxy, tuning_for_prior
from estimators.measurement import PoseNoise
from estimators.state import DW_ST_T, K, K_STATES, N_ERROR, N_STATE, Q_TS, W_B, W_ST_T
from estimators.tuning import get_tuning
from perception.simulated_pose import simulate_pose_measurements
from studies.sim.metrics import DEFAULT_THRESHOLDS, convergence_time, state_errors
from studies.sim.scenarios import get_scenario


def test_prior_needs_a_rate_and_a_positive_sigma():
    with pytest.raises(ValueError, match="no rate"):
        BodyRatePrior(None, [0.01, 0.01, 0.01])
    with pytest.raises(ValueError, match="three finite numbers"):
        BodyRatePrior([0.0, np.nan, 0.05], 0.01)
    with pytest.raises(ValueError, match="sigma_rad_s must be positive"):
        BodyRatePrior([0.0, 0.0, 0.05], 0.0)
    with pytest.raises(ValueError, match="positive fraction"):
        BodyRatePrior.from_truth([0.0, 0.0, 0.05], -0.05)
    p = BodyRatePrior.from_truth([0.0, 0.0, 0.05], 0.05)
    np.testing.assert_allclose(p.w_T_T_rad_s, [0.0, 0.0, 0.0525])
    np.testing.assert_allclose(p.sigma_rad_s, 0.0025)


def test_prior_from_a_rate_and_sigma():
    p = BodyRatePrior.from_rate(0.05, 0.002, axis_T=(0.0, 0.0, 2.0))
    np.testing.assert_allclose(p.w_T_T_rad_s, [0.0, 0.0, 0.05])
    np.testing.assert_allclose(p.sigma_rad_s, 0.002)
    with pytest.raises(ValueError, match="no rate"):
        BodyRatePrior.from_rate(None, None)
    with pytest.raises(ValueError, match="sigma_rad_s must be positive"):
        BodyRatePrior.from_rate(0.05, None)
    with pytest.raises(ValueError, match="spin axis"):
        BodyRatePrior.from_rate(0.05, 0.002, axis_T=(0.0, 0.0, 0.0))


def test_light_curve_prior_makes_the_body_rate_prior(rng):
    """The light curve's rate prior (lightcurves.SpinPrior) → ω_T = rate · â, 1-σ σ_rate per axis; no period, no prior."""
    from lightcurves import extract_spin_prior

    t = np.arange(0.0, 1800.0, 2.0)
    rate = 0.05  # rad/s: a two-maxima light curve at twice the rotation frequency, 14 rotations
    mag = 0.3 * np.cos(2.0 * rate * t) + 0.1 * np.cos(rate * t + 0.4) + rng.normal(0.0, 0.02, t.size)
    lc = extract_spin_prior(t, mag, np.full(t.size, 0.02))
    assert lc.significant and lc.rate_rad_s == pytest.approx(rate, rel=1e-3)
    axis = np.array([1.0, 0.0, 2.0])
    p = lc.body_rate_prior(axis, source="test curve")
    np.testing.assert_allclose(p.w_T_T_rad_s, lc.rate_rad_s * axis / np.linalg.norm(axis), rtol=1e-15)
    np.testing.assert_array_equal(p.sigma_rad_s, np.full(3, lc.rate_sigma_rad_s))
    assert p.source == "test curve" and tuning_for_prior(p) == "sc3-conservative"  # slow, two axes
    noise = extract_spin_prior(t, rng.normal(0.0, 0.02, t.size), np.full(t.size, 0.02))
    assert not noise.significant
    with pytest.raises(ValueError, match="no rate"):
        noise.body_rate_prior()


@pytest.mark.parametrize("name,expected", [("SC1", "sc1-conservative"), ("SC2", "sc2-conservative"), ("SC3", "sc3-conservative"), ("SC4", "sc4-conservative")])
def test_tuning_by_name_from_the_prior(name, expected):
    prior = BodyRatePrior.from_truth(get_scenario(name).w_T0_T_rad_s, 0.05)
    assert tuning_for_prior(prior) == expected
    get_tuning(expected)  # every name it returns exists


def test_initialisation_from_the_prior(truth):
    tr = truth("SC3", 5.0)
    prior = BodyRatePrior.from_truth(tr.target[0, W_B], 0.05)
    x0 = tr.x[0].copy()
    x0[W_ST_T] = 0.0
    P0 = get_tuning("sc3-paper").P_0
    x1, P1 = initialize_with_prior(x0, P0, prior, tr.servicer[0])
    # with the true attitude, ω_ST_0 is the truth's up to the prior's 5 % error (eq. 1)
    np.testing.assert_allclose(x1[W_ST_T] - tr.x[0, W_ST_T], -0.05 * tr.target[0, W_B], atol=1e-12)
    np.testing.assert_allclose(P1[DW_ST_T, DW_ST_T], np.diag(prior.sigma_rad_s**2))
    np.testing.assert_array_equal(np.delete(np.delete(P1, DW_ST_T, 0), DW_ST_T, 1), np.delete(np.delete(P0, DW_ST_T, 0), DW_ST_T, 1))


def test_proxy_measures_the_target_rate(truth, rng):
    tr = truth("SC3", 20.0)
    prior = BodyRatePrior.from_truth(tr.target[0, W_B], 0.05)
    src, z = rate_proxy(prior, tr.servicer[7])
    assert isinstance(src, TargetRateMeasurement)
    np.testing.assert_allclose(src.R, 1e-3 * np.eye(3) + prior.covariance)  # R_ω I (§6.3) plus the prior's own uncertainty
    np.testing.assert_array_equal(z, prior.w_T_T_rad_s)
    # h(x_true) is the target's own rate in its body frame
    np.testing.assert_allclose(src.h_chart(tr.x[7], tr.x[7]), tr.target[7, W_B], atol=1e-12)
    # H against central differences on the error state
    x = tr.x[7]
    H = src.jacobian(x)
    Hn = np.empty((3, N_ERROR))
    for i in range(N_ERROR):
        e = np.zeros(N_ERROR)
        e[i] = 1e-6
        Hn[:, i] = (src.h_chart(boxplus(x, e), x) - src.h_chart(boxplus(x, -e), x)) / 2e-6
    np.testing.assert_allclose(H, Hn, atol=1e-9)
    assert np.allclose(quat_to_dcm(x[Q_TS]) @ tr.servicer[7, W_B] - x[W_ST_T], tr.target[7, W_B])


def _blackout(truth, name, proxy, seed=1, reacquire_window=5):
    """SC1, 240 s at τ_s = 1 s, fault 60–180 s on both parts, prior (+5 %) as initial condition."""
    tr = truth("SC1", 240.0)
    m = simulate_pose_measurements(tr.t, tr.x, np.random.default_rng(seed), tau_s=1.0, faults=[(60.0, 120.0)])
    prior = BodyRatePrior.from_truth(tr.target[0, W_B], 0.05)
    tun = get_tuning("sc1-paper")
    x0 = np.zeros(N_STATE)
    x0[Q_TS] = (1.0, 0.0, 0.0, 0.0)
    x0[K] = [1.466 * 1.1, -1.439 * 0.9]
    x0, P0 = initialize_with_prior(x0, tun.P_0, prior, tr.servicer[0])
    run = run_navigation(name, tr.t, tr.servicer, tr.J_S_diag, m.t, m.q_TS, m.r_ST_T, x0=x0, P0=P0, tuning=tun, pose_noise=PoseNoise(model="isotropic"),
                         gate_confidence=0.99, gate_start_s=10.0, prior=prior, proxy=proxy, consider=K_STATES,
                         reacquire_window=reacquire_window)
    e = state_errors(run.x, tr.x)
    fault = (tr.t >= 60.0) & (tr.t < 180.0)
    w_rms = float(np.sqrt(np.mean(e["w"][fault] ** 2)))
    return w_rms, e, run


@pytest.mark.parametrize("name", ["ekf", "ukf"])
def test_blackout_proxy_keeps_rate_error_down_and_filter_reconverges(truth, name):
    """§6.3 of Renis et al.: a 120 s fault on both parts, seeds 1–5.

    Reconverged within 30 s of the end of the fault means: ``ω``, ``r`` and
    ``v`` are back below the §6 thresholds (2 deg/s, 1 m, 0.1 m/s) by 30 s and
    stay there, and the attitude error over the rest of the run (the paper's
    Table 6 window, after a 30 s settling) is no more than twice the one of the
    30 s before the fault. The attitude is judged against its own pre-fault
    level because its steady-state error (1–2°, from σ_q = 0.12 rad) lies
    around the 2° threshold, so "stays below 2°" is a coin toss with or
    without a fault.
    """
    t = truth("SC1", 240.0).t
    before, settled, after = (t >= 30.0) & (t < 60.0), t >= 210.0, t >= 180.0
    pairs = []
    for seed in range(1, 6):
        w_none, _, _ = _blackout(truth, name, None, seed)
        w_proxy, e, run = _blackout(truth, name, "on_reject", seed)
        reconv = {g: convergence_time(t[after], e[g][after], DEFAULT_THRESHOLDS[g]) for g in ("w", "r", "v")}
        q_ratio = np.sqrt(np.mean(e["q"][settled] ** 2) / np.mean(e["q"][before] ** 2))
        print(f"{name} seed {seed}: rms ω error over the fault {w_proxy:.4f} rad/s with the proxy, {w_none:.4f} without; "
              f"reconvergence after the fault (s) {reconv}, attitude rms settled/before {q_ratio:.2f}, re-acquisitions {run.reacquisitions}")
        pairs.append((w_proxy, w_none))
        assert run.proxy_used[(run.t >= 60) & (run.t < 180)].mean() > 0.9  # pushed while the camera is rejected
        for g, tc in reconv.items():
            assert tc <= 30.0, (seed, g, reconv)
        assert q_ratio <= 2.0, (seed, q_ratio)
        # heavy fault noise never looks like a lost filter: no re-acquisition inside the fault
        assert not [ev for ev in run.reacquisitions if 60.0 <= ev[0] < 180.0]
    # the proxy lowers the rate error over the fault on the five seeds together and on at least four of them
    # (one run's path depends on which early measurements its gate took: seed 3's EKF 0.0074 vs 0.0068 rad/s)
    w_proxy, w_none = np.array(pairs).T
    assert w_proxy.mean() < w_none.mean() and np.sum(w_proxy < w_none) >= 4, pairs


def test_without_reacquisition_the_gate_locks_the_ukf_out(truth):
    """The paper's rule alone (§4.3 of Renis et al.) does not guarantee recovery: after the blackout the gate can
    reject every good position for good. Seeds 1–3: seed 2 stays locked out (18.9 m off at the end); seeds 1 and 3
    are readmitted 20–47 s after it (since the UKF takes the considered ``k`` linearly, estimators.ukf; before, seed 1
    was locked out too)."""
    locked = []
    for seed in (1, 2, 3):
        _, e, run = _blackout(truth, "ukf", "on_reject", seed, reacquire_window=None)
        after = run.t >= 180.0
        locked.append(not run.accepted["position"][after].any() and e["r"][-1] > 10.0)
    assert any(locked)


def test_prior_with_a_full_covariance_initialises_the_rate_block_with_it():
    """An inversion's axis uncertainty is correlated: the ω block of P_0 is the prior's full covariance, and a
    covariance that is not symmetric positive definite, or whose diagonal is not σ², is refused."""
    L = np.array([[2e-3, 0.0, 0.0], [1e-3, 1e-3, 0.0], [-5e-4, 2e-4, 5e-4]])
    C = L @ L.T
    p = BodyRatePrior([0.02, 0.0, 0.045], np.sqrt(np.diag(C)), covariance_rad2_s2=C)
    np.testing.assert_array_equal(p.covariance, C)
    x0 = np.zeros(N_STATE)
    x0[Q_TS] = [1.0, 0.0, 0.0, 0.0]
    servicer = np.zeros(13)
    servicer[W_B] = [0.0, 0.0, 1e-3]
    x, P = initialize_with_prior(x0, np.eye(N_ERROR), p, servicer)
    np.testing.assert_allclose(P[DW_ST_T, DW_ST_T], C, rtol=1e-12)
    np.testing.assert_allclose(x[W_ST_T], servicer[W_B] - p.w_T_T_rad_s)
    assert np.all(P[DW_ST_T][:, [i for i in range(N_ERROR) if i not in range(*DW_ST_T.indices(N_ERROR))]] == 0.0)
    with pytest.raises(ValueError, match="square root of the covariance's diagonal"):
        BodyRatePrior([0.02, 0.0, 0.045], np.sqrt(np.diag(C)) * 1.1, covariance_rad2_s2=C)
    with pytest.raises(ValueError, match="positive definite"):
        bad = np.diag([1e-6, 1e-6, 1e-6]) + 2e-6 * (np.ones((3, 3)) - np.eye(3))
        BodyRatePrior([0.02, 0.0, 0.045], np.sqrt(np.diag(bad)), covariance_rad2_s2=bad)
    with pytest.raises(ValueError, match="symmetric"):
        BodyRatePrior([0.02, 0.0, 0.045], np.sqrt(np.diag(C)), covariance_rad2_s2=C + np.triu(np.full((3, 3), 1e-7), 1))
