"""Filter consistency: 30 seeded runs of SC1 and SC3, NEES in its 95 % band after convergence.

Nominal noise is the pose-estimator model of Renis et al. §4.4 with Gaussian
rotation-vector and position errors of the paper's covariance
(``noise="gaussian"``), the ``consistent`` tuning (``Q_d = 0``: the truth is
torque-free and Keplerian and the filters' model matches it to 1e-7 m per
step). "After convergence": every run starts from an error drawn from
``P_0`` of the size a converged filter has (1-σ 0.01 rad, 1.6e-4 rad/s,
0.05 m, 2 mm/s, 0.01 on ``k``), and the NEES is tested from the tenth step
on. In SC1 (spin about a principal axis) the inertia ratios do not affect the
motion, so they are considered, not estimated (§6.1 of Renis et al.), and the NEES
has 12 degrees of freedom; in SC3 all 14 are estimated.

Two tests:

* :func:`test_nees_in_band` — the issue's criterion: the 30-run average NEES
  inside the two-sided 95 % band of ``χ²(30·dof)/30`` for ≥ 90 % of the steps.
* :func:`test_nees_matches_an_exact_kalman_filter_on_the_same_noise` — the
  same runs next to an exact linear Kalman filter on the truth-linearised
  error dynamics, fed the *same* initial errors and measurement noise. Its
  NEES is χ²-distributed by construction, so the ratio tests the EKF/UKF
  themselves, free of the luck of the draw.

Why both: the errors are correlated over the whole run, so the 30-run
criterion depends on the seed set even for a perfect filter. Measured on six
sets of 30 seeds (1000–6000), fraction of steps in band, SC1 | SC3:
exact linear KF 100, 100, 100, 100, 80, 100 | 100, 100, 100, 63, 100, 100 %;
EKF 100, 100, 100, 100, 64, 100 | 100, 70, 100, 91, 77, 100 %; UKF 100, 100,
100, 100, 74, 100 | 100, 99, 100, 68, 92, 100 %. The mean NEES/dof of the
filters is within 0.08 of the exact filter's on every set. With ten times
larger initial errors (1.6e-3 rad/s on the rate) both filters are
over-confident in some runs (mean NEES/dof 1.07–1.42 for the EKF, 0.96–1.29
for the UKF on the six sets, against 0.89–1.06 for the exact filter on the
same draws): a rate
error along the spin axis reaches the positions only through second-order
terms (`docs/known-limitations.md`).
"""

import numpy as np
import pytest

from estimators.error_state import attitude_error, boxminus, boxplus
from estimators.measurement import PoseNoise
from estimators.navigation import run_navigation
from estimators.process_model import RelativeProcessModel
from estimators.state import DR_ST_T, DTHETA, K_STATES, Q_TS, R_ST_T
from estimators.tuning import default_tuning, get_tuning
from perception.simulated_pose import simulate_pose_measurements
from studies.sim.metrics import fraction_in_band, nees

NOISE = PoseNoise(model="gaussian")
N_RUNS = 30
DURATION_S = 100.0
CONVERGED_AFTER = 10  # steps of 1 s
#: 1-σ of the initial error: attitude (rad), rate (rad/s), position (m), velocity (m/s), k.
SIGMA_0 = np.repeat([0.1, 0.005, 0.5, 0.02, 0.1], [3, 3, 3, 3, 2]) * np.sqrt(0.001)


def _runs(tr, scenario, name, first_seed=1000):
    """NEES of the filter and of the exact linear KF on the same draws, (N_RUNS, steps) each, and dof."""
    one_axis = scenario == "SC1"
    n = 12 if one_axis else 14
    tun = get_tuning("consistent")
    steps = len(tr.t) - 1
    # exact linear Kalman filter on the truth-linearised error dynamics (its gains and P do not depend on the draws)
    model = RelativeProcessModel(tr.J_S_diag)
    F = [model.propagate_with_jacobian(tr.x[k], tr.servicer[k], 1.0)[1][:n, :n] for k in range(steps)]
    H = np.zeros((6, n))
    H[:3, DTHETA] = H[3:, DR_ST_T] = np.eye(3)
    R = np.zeros((6, 6))
    R[:3, :3], R[3:, 3:] = NOISE.R_attitude, NOISE.R_position
    P = np.diag(SIGMA_0[:n] ** 2)
    K, P_inv = [], []
    for k in range(steps):
        P = F[k] @ P @ F[k].T + tun.Q_d(1.0)[:n, :n]
        K.append(np.linalg.solve(H @ P @ H.T + R, H @ P).T)
        P = (np.eye(n) - K[-1] @ H) @ P
        P_inv.append(np.linalg.inv(P))
    E_filter, E_exact = [], []
    for i in range(N_RUNS):
        rng = np.random.default_rng(first_seed + i)
        x0 = boxplus(tr.x[0], rng.normal(size=14) * SIGMA_0)
        m = simulate_pose_measurements(tr.t, tr.x, rng, tau_s=1.0, sigma_q_rad=NOISE.sigma_q_rad, sigma_r_m=NOISE.sigma_r_m, noise=NOISE.model)
        run = run_navigation(
            name, tr.t, tr.servicer, tr.J_S_diag, m.t, m.q_TS, m.r_ST_T,
            x0=x0, P0=np.diag(SIGMA_0**2), tuning=tun, pose_noise=NOISE, gate_confidence=None, consider=K_STATES if one_axis else (),
        )
        E_filter.append(nees(run.x, run.P, tr.x, np.arange(n))[1:])
        noise = np.hstack([attitude_error(m.q_TS, tr.x[1:, Q_TS]), m.r_ST_T - tr.x[1:, R_ST_T]])
        e, e_hat, E = boxminus(tr.x[0], x0)[:n], np.zeros(n), np.empty(steps)
        for k in range(steps):
            e, e_hat = F[k] @ e, F[k] @ e_hat
            e_hat = e_hat + K[k] @ (H @ e + noise[k] - H @ e_hat)
            E[k] = (e - e_hat) @ P_inv[k] @ (e - e_hat)
        E_exact.append(E)
    return np.array(E_filter)[:, CONVERGED_AFTER - 1 :], np.array(E_exact)[:, CONVERGED_AFTER - 1 :], n


@pytest.fixture(scope="module")
def consistency_runs(truth):
    cache = {}

    def get(scenario, name):
        if (scenario, name) not in cache:
            cache[scenario, name] = _runs(truth(scenario, DURATION_S), scenario, name)
        return cache[scenario, name]

    return get


@pytest.mark.parametrize("scenario", ["SC1", "SC3"])
@pytest.mark.parametrize("name", ["ekf", "ukf"])
def test_nees_in_band(consistency_runs, scenario, name):
    E, _, dof = consistency_runs(scenario, name)
    frac = fraction_in_band(E, dof, confidence=0.95)
    print(f"{scenario} {name}: NEES in 95% band for {100 * frac:.1f}% of steps, mean/dof {E.mean() / dof:.3f}")
    assert frac >= 0.90


@pytest.mark.parametrize("scenario", ["SC1", "SC3"])
@pytest.mark.parametrize("name", ["ekf", "ukf"])
def test_nees_matches_an_exact_kalman_filter_on_the_same_noise(consistency_runs, scenario, name):
    E, E_exact, dof = consistency_runs(scenario, name)
    ratio = E.mean(axis=0) / E_exact.mean(axis=0)
    print(f"{scenario} {name}: 30-run NEES / exact KF's: mean {ratio.mean():.3f}, range {ratio.min():.3f}-{ratio.max():.3f}; "
          f"mean/dof {E.mean() / dof:.3f} vs {E_exact.mean() / dof:.3f}")
    assert abs(E.mean() / E_exact.mean() - 1.0) < 0.1
    assert np.all((ratio > 0.8) & (ratio < 1.25))


# ---- issue 12's criterion: from the default P_0, with the tunings lcnav ships

#: Runs, duration (s) and statistics window of the default-P_0 check (the benchmark's 300 s, shortened:
#: every failure measured so far shows by 120 s).
N_DEFAULT, DURATION_DEFAULT_S = 30, 120.0


@pytest.fixture(scope="module")
def default_p0_runs(truth):
    from estimators.tuning import get_tuning
    from studies.sim.navigation import consistency_check

    cache = {}

    def get(scenario, name, tuning, n_runs=N_DEFAULT):
        key = (scenario, name, tuning, n_runs)
        if key not in cache:
            cache[key] = consistency_check(truth(scenario, DURATION_DEFAULT_S), name, get_tuning(tuning), n_runs=n_runs)
        return cache[key]

    return get


@pytest.mark.slow
@pytest.mark.parametrize(("scenario", "name", "n_runs"), [("SC1", "ukf", N_DEFAULT), ("SC3", "ekf", 8)])
def test_default_tuning_on_the_torque_free_truth_is_not_overconfident(default_p0_runs, scenario, name, n_runs):
    """The torque-free world's default (``fixed-lag-torque-free``: the same bounded window as the orbit's ``fixed-lag``,
    no gravity gradient and ``Q_d = 0`` after the settling phase, since nothing is left out of its model) on the truth
    its model matches: not over-confident, NIS in band, gates at their nominal rate. The perturbed truth's criterion is
    :func:`tests.estimators.test_fixed_lag.test_fixed_lag_is_consistent_on_the_perturbed_truth`. ``relinearized``
    (the default before 2026-11-27) was in band here on 95–100 % of the steps, and 3.4 NEES/dof on the perturbed truth.

    Measured (30 runs of 120 s): NEES/dof 0.997 / 1.039 (SC1 / SC3 EKF), 0.993 / 1.038 (UKF), in band on 100 % of the
    steps after the settling phase; NIS 95–98 % in band; gates 0.8–1.3 %. One filter per scenario here, and 8 runs on SC3
    (its window fits, with ``k`` estimated, cost ~0.5 s each: 30 runs took 3 min): the other two are within 0.001 of these."""
    r = default_p0_runs(scenario, name, default_tuning("torque-free"), n_runs)
    print({k: v for k, v in r.items() if not k.endswith(("_lo", "_hi"))})
    _assert_not_overconfident(r)


def _assert_not_overconfident(r, lowest_nees_per_dof: float = 0.6):
    """Mean NEES/dof under the upper 95 % bound of an N_DEFAULT-run mean (the time average only narrows it), not below
    ``lowest_nees_per_dof``;
    mean NIS/dof under the upper 95 % bound of all the innovations after the settling time (3 dof each, white for a
    consistent filter); NIS in its band on ≥ 90 % of the steps; one-sided gate rejections within 2× the nominal 1 %, and not
    below the lower 99 % binomial bound of the nominal 1 % for the number of measurements gated (0.49 % for 30 runs)."""
    from scipy.stats import binom, chi2

    assert r["diverged"] == 0
    n = r["runs"] * r["dof"]
    assert lowest_nees_per_dof <= r["nees_per_dof"] <= chi2.ppf(0.975, n) / n
    n_nis = 3 * r["runs"] * int(r["duration_s"] - r["settling_s"])  # one measurement per second
    for s in ("attitude", "position"):
        assert r[f"nis_{s}_per_dof"] <= chi2.ppf(0.975, n_nis) / n_nis
        assert r[f"nis_{s}_in_band"] >= 0.9
        n_gated = r["runs"] * int(r["duration_s"] - r["settling_s"])
        assert binom.ppf(0.005, n_gated, 0.01) / n_gated <= r[f"gate_{s}_rejected"] <= 0.02


@pytest.mark.parametrize(("scenario", "name"), [("SC1", "ekf"), ("SC1", "ukf"), ("SC3", "ekf"), ("SC3", "ukf")])
def test_settled_tuning_from_the_default_p0(default_p0_runs, scenario, name):
    """``settled`` from the default ``P_0``: not over-confident, NIS in band, gates at their nominal rate.

    Measured at 120 s: mean NEES/dof 0.66 (SC1 EKF), 0.76 (SC1 UKF), 0.89 (SC3 UKF); NIS 95–98 % in band; gates
    0.8–1.0 %. With ``Q_d = 0`` after the settling phase (the tuning before issue 12's process noise on the rate
    and ``k``) the SC3 UKF's mean NEES/dof was 87 at 300 s (``k`` run off along ``(1, −1)``, estimators.tuning).
    The SC3 EKF failed this test with every tuning tried (mean NEES/dof 3.6, worst run 79, position NIS 71 % in band)
    until the release phase (:func:`estimators.navigation.weak_inertia_direction`): now 1.01, worst run 4.0.
    """
    r = default_p0_runs(scenario, name, "settled")
    print({k: v for k, v in r.items() if not k.endswith(("_lo", "_hi"))})
    _assert_not_overconfident(r)


@pytest.mark.parametrize("name", ["ekf", "ukf"])
def test_prior_chosen_tuning_is_conservative_not_overconfident(default_p0_runs, name):
    """``sc3-conservative`` (what a spin prior of a slow two-axis tumble selects, Renis et al. study 1) from the default ``P_0``.

    The paper's ``sc3-paper`` without a settling phase is over-confident: mean NEES/dof 4.7 (EKF) and 3.5 (UKF), worst run
    60-88, attitude gate rejections 3.6 % (300 s, ``python -m benchmarks consistency``). With it: 0.52 and 0.52,
    worst run 1.0 and 0.96, rejections 0.9 %. Conservative on purpose (its ``Q_d`` stands for unmodelled
    torques the truth does not have), so only the upper side is tested, and a floor that says "not absurdly".
    """
    r = default_p0_runs("SC3", name, "sc3-conservative")
    print({k: v for k, v in r.items() if not k.endswith(("_lo", "_hi"))})
    _assert_not_overconfident(r, lowest_nees_per_dof=0.3)


@pytest.mark.slow
def test_ukf_rate_covariance_agrees_with_the_ekf_where_k_is_considered(truth):
    """SC1 from the default ``P_0``: ``k`` is considered with its prior's σ, and the spin about the intermediate axis
    grows like ``e^{λ(k) t}``. Sigma points √14 = 3.7 σ out along ``k`` over-stated the rate's error: on these 30
    draws, rate NEES/dof 0.63 (UKF) against 1.00 (EKF) over 60–120 s (now 1.00 and 1.00); at 300 s the UKF had 83 % of
    the steps in band against the EKF's 100 % (``python -m benchmarks consistency``). The UKF now takes considered
    directions linearly, as the Schmidt–Kalman EKF does (:meth:`estimators.ukf.UnscentedKalmanFilter._predict_considering`): the two agree within 10 %."""
    from estimators.state import DW_ST_T, N_ERROR

    tr = truth("SC1", DURATION_DEFAULT_S)
    tun, rate = get_tuning(default_tuning("torque-free")), np.arange(N_ERROR)[DW_ST_T]
    E = {"ekf": [], "ukf": []}
    for i in range(N_DEFAULT):
        for name in E:
            rng = np.random.default_rng(1000 + i)  # the same measurements and initial error for both filters
            m = simulate_pose_measurements(tr.t, tr.x, rng, tau_s=1.0, sigma_q_rad=NOISE.sigma_q_rad, sigma_r_m=NOISE.sigma_r_m, noise=NOISE.model)
            x0 = boxplus(tr.x[0], rng.multivariate_normal(np.zeros(N_ERROR), tun.P_0))
            run = run_navigation(name, tr.t, tr.servicer, tr.J_S_diag, m.t, m.q_TS, m.r_ST_T, x0=x0, tuning=tun, pose_noise=NOISE,
                                 gate_confidence=0.99, gate_start_s=10.0, consider=K_STATES)
            E[name].append(nees(run.x, run.P, tr.x, rate)[61:])
    ratio = np.mean(E["ukf"]) / np.mean(E["ekf"])
    print(f"rate NEES/dof 60-120 s: EKF {np.mean(E['ekf']) / 3:.3f}, UKF {np.mean(E['ukf']) / 3:.3f}, ratio {ratio:.3f}")
    assert 0.9 < ratio < 1.1
