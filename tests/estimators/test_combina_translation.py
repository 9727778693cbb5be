"""Translational UKF of Maestrini et al. §IV.B: UT algebra (eqs 10–17, 21–24), NERM propagation, scaled units."""

import numpy as np
import pytest
from filterpy.kalman import MerweScaledSigmaPoints

from estimators.combina.gates import mahalanobis_gate, scale_gate
from estimators.combina.translation import ScaledUnits, TranslationalUKF
from estimators.combina.unscented import UnscentedCore
from estimators.dynamics import MU_EARTH, R_EARTH, integrate_truth, nerm_rhs
from scipy.stats import chi2

R_T = R_EARTH + 800e3
N = float(np.sqrt(MU_EARTH / R_T**3))
TU, LU = 963.65, 12.0


def _filter(units=None):
    x0 = np.array([24.0, 0.5, 2.4, 0.001, -0.05, 0.0])
    P0 = 0.1 * np.diag([LU] * 3 + [LU / TU] * 3) ** 2
    kw = {} if units is None else {"units": units}
    return TranslationalUKF(x0, P0, n_rad_s=N, R_t_m=R_T, **kw)


def test_weights_are_eq_11():
    """Ω_m⁰ = τ/(l+τ), Ω_P⁰ = Ω_m⁰ + 1 − γ² + β, others 1/(2(l+τ)), τ = γ²(l+κ) − l."""
    l, g, b, k = 6, 0.7, 2.0, 1.0
    tau = g**2 * (l + k) - l
    pts = MerweScaledSigmaPoints(l, alpha=g, beta=b, kappa=k)
    assert pts.Wm[0] == pytest.approx(tau / (l + tau))
    assert pts.Wc[0] == pytest.approx(tau / (l + tau) + 1 - g**2 + b)
    np.testing.assert_allclose(pts.Wm[1:], 1 / (2 * (l + tau)))
    core = UnscentedCore(np.zeros(l), np.eye(l), alpha=g, beta=b, kappa=k)
    assert np.sum(core.points.Wm) == pytest.approx(1.0)


def test_linear_measurement_matches_kalman_formulas():
    """For the linear h of eq. 14 the UT gives exactly S = H P Hᵀ + R and P_xz = P Hᵀ (eqs 16–17)."""
    rng = np.random.default_rng(3)
    A = rng.normal(size=(6, 6))
    P = A @ A.T + 6 * np.eye(6)
    x = rng.normal(size=6)
    core = UnscentedCore(x, P)
    R = 0.3 * np.eye(3)
    z = x[:3] + 1.0
    inn = core.innovation(z, R, lambda X: X[:, :3])
    np.testing.assert_allclose(inn.S, P[:3, :3] + R, rtol=1e-12)
    np.testing.assert_allclose(inn.P_xz, P[:, :3], rtol=1e-12)
    core.correct(inn)
    K = P[:, :3] @ np.linalg.inv(P[:3, :3] + R)
    np.testing.assert_allclose(core.x, x + K @ (z - x[:3]), rtol=1e-12)  # eq. 21
    np.testing.assert_allclose(core.P, P - K @ (P[:3, :3] + R) @ K.T, rtol=1e-10, atol=1e-12)  # eq. 22


def test_prediction_follows_nerm():
    """With a tiny covariance the predicted mean is the NERM trajectory (eq. 9) to < 1 mm over 1000 s."""
    x0 = np.array([24.0, 0.0, 2.4, 0.0, -2 * N * 24.0, 0.0])
    f = TranslationalUKF(x0, 1e-10 * np.eye(6), n_rad_s=N, R_t_m=R_T)
    for _ in range(100):
        f.predict(10.0)
    ref = integrate_truth(nerm_rhs, [0.0, 1000.0], x0, N, R_T)[-1]
    assert np.max(np.abs(f.x[:3] - ref[:3])) < 1e-3
    assert np.max(np.abs(f.x[3:] - ref[3:])) < 1e-6


def test_scaled_units_give_the_same_answers_as_si():
    """TU/LU scaling (§VI) is a change of units only: estimates agree to 1e-9 (relative), covariances to 1e-8 of σᵢσⱼ."""
    rng = np.random.default_rng(11)
    a, b = _filter(), _filter(ScaledUnits(TU_s=TU, LU_m=LU))
    R = 0.01 * LU**2 * np.eye(3)
    for _ in range(30):
        a.predict(3.0)
        b.predict(3.0)
        z = a.x[:3] + rng.normal(scale=1.0, size=3)
        ia, ib = a.innovation(z, R), b.innovation(z, R)
        np.testing.assert_allclose(ib.S, ia.S, rtol=1e-9, atol=1e-9 * np.max(np.abs(ia.S)))
        a.correct(ia)
        b.correct(ib)
    np.testing.assert_allclose(b.x, a.x, rtol=1e-9, atol=1e-12)
    sd = np.sqrt(np.diag(a.P))
    np.testing.assert_allclose(b.P / np.outer(sd, sd), a.P / np.outer(sd, sd), atol=1e-8)  # correlations and variances


def test_gates():
    """Scale gate is [0.8, 1.2] inclusive; Mahalanobis gate at the 99 % chi-square quantile, ν = 3 (eqs 18–20)."""
    assert scale_gate(0.8, t=0, source="x").accepted and scale_gate(1.2, t=0, source="x").accepted
    assert not scale_gate(0.79, t=0, source="x").accepted and not scale_gate(1.21, t=0, source="x").accepted
    assert not scale_gate(float("nan"), t=0, source="x").accepted
    core = UnscentedCore(np.zeros(6), np.eye(6))
    thr = chi2.ppf(0.99, 3)
    for e2, ok in ((thr * 0.999, True), (thr * 1.001, False)):
        z = np.array([np.sqrt(e2 * 1.5), 0.0, 0.0])  # S = I + 0.5 I on the position block
        d = mahalanobis_gate(core.innovation(z, 0.5 * np.eye(3), lambda X: X[:, :3]), t=1.0, source="translation")
        assert d.accepted is ok
        assert d.upper == pytest.approx(thr)
        assert d.e2 == pytest.approx(e2)


def test_bad_input():
    with pytest.raises(ValueError, match="dt_s"):
        _filter().predict(0.0)
    with pytest.raises(ValueError, match="P0"):
        TranslationalUKF(np.zeros(6), -np.eye(6), n_rad_s=N, R_t_m=R_T)
    with pytest.raises(ValueError, match="n_rad_s"):
        TranslationalUKF(np.zeros(6), np.eye(6), n_rad_s=-1.0, R_t_m=R_T)
    with pytest.raises(ValueError, match="LU_m"):
        ScaledUnits(TU_s=1.0, LU_m=0.0)
