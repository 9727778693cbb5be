"""Re-acquisition after a lock-out: the least-squares line fit and the covariance inflation."""

import numpy as np
import pytest
from scipy.stats import chi2

from estimators.ekf import ExtendedKalmanFilter
from estimators.process_model import LinearProcessModel
from estimators.reacquisition import Reacquisition, fit_line, inflation


def test_line_fit_is_unbiased_with_its_stated_covariance_and_chi_square_residual(rng):
    """5 samples of ``b + d (t − t_K)`` with correlated noise ``R``: over 4000 draws the estimate's mean,
    covariance and residual χ² match ``(b, d)``, ``C`` and ``χ²((K−2) m)``."""
    t = np.arange(5.0) + 100.0
    b, d = np.array([3.0, -1.0, 0.5]), np.array([0.2, 0.0, -0.4])
    L = np.array([[0.3, 0.0, 0.0], [0.1, 0.2, 0.0], [-0.05, 0.1, 0.25]])
    R = L @ L.T
    fits = [fit_line(t, b + np.outer(t - t[-1], d) + rng.normal(size=(5, 3)) @ L.T, R) for _ in range(4000)]
    est = np.array([np.concatenate([f.b, f.d]) for f in fits])
    C = fits[0].C
    assert np.all(np.abs(est.mean(0) - np.concatenate([b, d])) < 4 * np.sqrt(np.diag(C) / 4000))
    np.testing.assert_allclose(np.cov(est.T), C, atol=0.1 * np.abs(C).max())
    res = np.array([f.residual_chi2 for f in fits])
    assert fits[0].dof == 9
    assert abs(res.mean() - 9) < 4 * np.sqrt(18 / 4000)
    assert abs(np.mean(res > chi2.ppf(0.99, 9)) - 0.01) < 0.006


def test_inflation_makes_the_fitted_error_of_its_expected_size(rng):
    P = np.diag([0.01, 0.04, 0.02])
    C = 0.05 * np.eye(3)
    c = np.array([3.0, -2.0, 1.0])
    lam = inflation(c, P, C)
    assert lam > 1.0
    assert c @ np.linalg.solve(lam * P + C, c) == pytest.approx(3.0, rel=1e-9)
    assert inflation(0.01 * c, P, C) == 1.0  # already plausible: untouched


def test_rescale_keeps_correlations_and_refuses_deflation():
    f = ExtendedKalmanFilter(LinearProcessModel(lambda dt: np.eye(2)), np.zeros(2), [[1.0, 0.5], [0.5, 2.0]], np.zeros((2, 2)))
    f.rescale([3.0, 1.0])
    np.testing.assert_allclose(f.P, [[9.0, 1.5], [1.5, 2.0]])
    with pytest.raises(ValueError, match=">= 1"):
        f.rescale([0.5, 1.0])


def test_reacquisition_needs_a_window_of_three():
    with pytest.raises(ValueError, match="at least 3"):
        Reacquisition(window=2)
