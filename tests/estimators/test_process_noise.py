"""Process noise from a disturbance budget (:mod:`estimators.process_noise`): closed form, consistency, signs."""

import numpy as np
import pytest
from scipy.linalg import expm
from scipy.stats import chi2

from estimators.ekf import ExtendedKalmanFilter
from estimators.measurement import LinearMeasurement
from estimators.process_model import LinearProcessModel, RelativeProcessModel
from estimators.process_noise import DisturbanceBudget, MatchedBudget, white_noise_acceleration
from estimators.state import DK, DR_ST_T, DTHETA, DV_ST_T, DW_ST_T
from studies.sim.scenarios import get_scenario
from studies.sim.truth import simulate_truth

A = np.array([[0.0, 1.0], [0.0, 0.0]])
G = np.array([[0.0], [1.0]])


def _van_loan(q: float, tau: float) -> np.ndarray:
    """``∫₀^τ e^{As} G q Gᵀ e^{Aᵀs} ds`` by Van Loan's matrix exponential (IEEE TAC 1978), independent of eq. (1)."""
    M = np.zeros((4, 4))
    M[:2, :2], M[:2, 2:], M[2:, 2:] = -A, q * G @ G.T, A.T
    E = expm(M * tau)
    F = E[2:, 2:].T
    return F @ E[:2, 2:]


@pytest.mark.parametrize("tau", [0.1, 1.0, 5.0, 10.0])
def test_white_noise_block_is_van_loans_integral(tau):
    q = 3.7e-9
    np.testing.assert_allclose(white_noise_acceleration(q, tau), _van_loan(q, tau), rtol=1e-10, atol=0)


def test_budget_blocks_are_the_closed_form_per_axis():
    b = DisturbanceBudget(sigma_alpha_rad_s2=2e-6, sigma_a_m_s2=5e-7, sigma_kdot_1_s=1e-7, correlation_time_s=20.0)
    tau = 2.0
    Q = b.Q_d(tau)
    q_alpha, q_a = (2e-6) ** 2 * 40.0, (5e-7) ** 2 * 40.0  # q = σ² max(2 T_c, τ)
    for (pos, rate), q in (((DTHETA, DW_ST_T), q_alpha), ((DR_ST_T, DV_ST_T), q_a)):
        np.testing.assert_allclose(Q[pos, pos], q * tau**3 / 3 * np.eye(3), rtol=1e-12)
        np.testing.assert_allclose(Q[pos, rate], q * tau**2 / 2 * np.eye(3), rtol=1e-12)
        np.testing.assert_allclose(Q[rate, pos], q * tau**2 / 2 * np.eye(3), rtol=1e-12)
        np.testing.assert_allclose(Q[rate, rate], q * tau * np.eye(3), rtol=1e-12)
    np.testing.assert_allclose(Q[DK, DK], (1e-7) ** 2 * 40.0 * tau * np.eye(2), rtol=1e-12)
    assert np.count_nonzero(Q) == 2 * 12 + 2  # no attitude-translation or rate-k coupling
    assert np.linalg.eigvalsh(Q).min() >= -1e-30
    # a correlation time shorter than half a step: the variance of a constant acceleration over the step, σ² τ²
    assert DisturbanceBudget(1e-6, 0.0).Q_d(3.0)[DW_ST_T, DW_ST_T][0, 0] == pytest.approx(1e-12 * 9.0)


def _double_integrator_runs(q: float, tau: float, r: float, n_runs: int, n_steps: int, rng, substeps: int = 40):
    """Truth of ``ξ̈ = w`` (white, intensity q) by piecewise-constant accelerations over ``τ/substeps``, and ``ξ`` measured with variance r."""
    h = tau / substeps
    x = np.zeros((n_runs, 2))
    x[:, 1] = rng.normal(0.0, 1.0, n_runs)
    xs, zs = [], []
    for _ in range(n_steps):
        for _ in range(substeps):
            a = rng.normal(0.0, np.sqrt(q / h), n_runs)
            x = np.column_stack([x[:, 0] + h * x[:, 1] + 0.5 * h * h * a, x[:, 1] + h * a])
        xs.append(x.copy())
        zs.append(x[:, 0] + rng.normal(0.0, np.sqrt(r), n_runs))
    return np.array(xs), np.array(zs)


def _nees_in_band(Q: np.ndarray, xs, zs, tau: float, r: float) -> float:
    model = LinearProcessModel(lambda dt: np.array([[1.0, dt], [0.0, 1.0]]))
    meas = LinearMeasurement(H=[[1.0, 0.0]], R=[[r]], name="position")
    n_steps, n_runs = zs.shape
    E = np.empty((n_runs, n_steps))
    for i in range(n_runs):
        f = ExtendedKalmanFilter(model, x0=[0.0, 0.0], P0=[1e-6, 1.0], Q=Q, gate_confidence=None)
        for k in range(n_steps):
            f.predict(None, tau)
            f.update([(meas, [zs[k, i]])])
            e = xs[k, i] - f.x
            E[i, k] = e @ np.linalg.solve(f.P, e)
    lo, hi = chi2.ppf([0.025, 0.975], 2 * n_runs) / n_runs
    avg = E.mean(axis=0)
    return float(np.mean((avg >= lo) & (avg <= hi)))


def test_derived_q_makes_a_kalman_filter_consistent_and_a_wrong_one_not():
    """Double integrator, white acceleration of intensity q: eq. (1) gives NEES in its 95 % band (50 runs) on ≥ 90 % of the steps.

    The truth is integrated with piecewise-constant accelerations on 40 sub-steps (not eq. 1); a Q ten times too small
    (what a budget that missed a term would give) is out of band on most steps, so the check can fail.
    """
    rng = np.random.default_rng(31)
    q, tau, r = 1e-4, 1.0, 0.01
    xs, zs = _double_integrator_runs(q, tau, r, n_runs=50, n_steps=100, rng=rng)
    assert _nees_in_band(white_noise_acceleration(q, tau), xs, zs, tau, r) >= 0.90
    assert _nees_in_band(white_noise_acceleration(q / 10.0, tau), xs, zs, tau, r) < 0.5


def test_cross_term_signs_are_the_jacobians():
    """``∂δp/∂δω`` and ``∂δr/∂δv`` over a short step are ``+τ I`` to first order: the signs of eq. (1)'s cross terms."""
    tr = simulate_truth(get_scenario("SC3"), 1.0, 0.5)
    tau = 0.05
    _, F = RelativeProcessModel(tr.J_S_diag).propagate_with_jacobian(tr.x[0], tr.servicer[0], tau)
    np.testing.assert_allclose(F[DTHETA, DW_ST_T], tau * np.eye(3), atol=0.05 * tau)
    np.testing.assert_allclose(F[DR_ST_T, DV_ST_T], tau * np.eye(3), atol=0.05 * tau)


@pytest.mark.parametrize("scenario", ["SC3", "SC4"])
def test_budgeted_tuning_covers_the_perturbed_truths_disturbances(scenario):
    """`budgeted`'s σ per axis is at least the RMS per axis (norm / √3) of what the perturbed truth adds, and within 2× of it."""
    from estimators.process_noise import kdot_from_dissipation
    from estimators.tuning import PERTURBED_BUDGET, get_tuning
    from studies.sim.disturbance import disturbance_budget

    sc = get_scenario(scenario)
    b = disturbance_budget(sc, "perturbed", 600.0)
    alpha, acc = b.angular_T["total"].rms / np.sqrt(3), b.translational_T["total"].rms / np.sqrt(3)
    assert alpha <= PERTURBED_BUDGET.sigma_alpha_rad_s2 <= 2 * alpha
    assert acc <= PERTURBED_BUDGET.sigma_a_m_s2 <= 2 * acc
    assert kdot_from_dissipation(b.angular_T["dissipation"].rms, np.linalg.norm(sc.w_T0_T_rad_s)) <= PERTURBED_BUDGET.sigma_kdot_1_s
    assert get_tuning("budgeted").budget is PERTURBED_BUDGET


def test_combina_translational_noise_is_eq_1_per_lvlh_axis():
    """CoMBiNa's translational Q over [r_L, v_L]: eq. 1 per axis, no coupling between axes, positive definite."""
    from estimators.combina.translation import translational_process_noise

    b = MatchedBudget(q_alpha_rad2_s3=0.0, q_a_m2_s3=5.77e-12)
    Q = translational_process_noise(3.0, b)
    block = white_noise_acceleration(5.77e-12, 3.0)
    for i in range(3):
        assert Q[np.ix_([i, 3 + i], [i, 3 + i])] == pytest.approx(block, rel=1e-12)
    off = Q.copy()
    for i in range(3):
        off[np.ix_([i, 3 + i], [i, 3 + i])] = 0.0
    assert np.all(off == 0.0) and np.linalg.eigvalsh(Q).min() > 0


@pytest.mark.parametrize("q_over_r", [1e-9, 1.0, 1e6])
def test_a_matched_filter_has_half_the_nees_where_the_disturbance_is_absent(q_over_r):
    """Eq. (4): the steady-state Kalman–Bucy filter of eq. (2) (gains ``K = [√2 ω_n, ω_n²]``, ``ω_n = (q/r)^{1/4}``) splits its
    error covariance into the parts driven by the acceleration and by the measurement noise (two Lyapunov equations, solved by
    scipy); without the acceleration the error is the second part alone, and its expected NEES per state is 1/2 whatever q/r:
    3/4 of the position variance and 1/4 of the rate variance. Checked against the Riccati solution of the same filter."""
    from scipy.linalg import solve_continuous_are, solve_continuous_lyapunov

    r = 0.27
    q = q_over_r * r
    wn = q_over_r**0.25
    K = np.array([[np.sqrt(2.0) * wn], [wn * wn]])
    F = A - K @ np.array([[1.0, 0.0]])
    P_w = solve_continuous_lyapunov(F, -q * G @ G.T)
    P_v = solve_continuous_lyapunov(F, -r * K @ K.T)
    P = solve_continuous_are(A.T, np.array([[1.0], [0.0]]), q * G @ G.T, np.array([[r]]))  # the filter's own covariance
    np.testing.assert_allclose(P_w + P_v, P, rtol=1e-8)
    assert np.trace(np.linalg.solve(P, P_v)) / 2.0 == pytest.approx(0.5, rel=1e-8)
    np.testing.assert_allclose(np.diag(P_v) / np.diag(P), [0.75, 0.25], rtol=1e-8)
