"""The chi-square validation gate of §4.3 of ``002_…`` inside both filters.

On nominal data (Gaussian noise of the paper's covariance, consistent filter)
each source's two-sided gate at confidence ``c`` must reject ``1 − c`` of the
measurements (± 2 points); injected 10-σ outliers must be rejected (≥ 99 %).
The paper's own noise (Gaussian amplitude on a uniform axis, eqs 33–34) has
the same covariance but ``|n|² ~ σ² χ²₁``: its false-alarm rate is far above
``1 − c``, which the last test measures and records.
"""

import numpy as np
import pytest

from estimators.attitude import quat_multiply, rotvec_to_quat
from estimators.error_state import boxplus
from estimators.navigation import run_navigation
from estimators.tuning import get_tuning
from perception.simulated_pose import simulate_pose_measurements

SIGMA_0 = np.repeat([0.1, 0.005, 0.5, 0.02, 0.1], [3, 3, 3, 3, 2]) * np.sqrt(0.1)
CONF = 0.95


def _runs(truth, name, n_runs, noise, outliers=False, seed=77):
    tr = truth("SC1", 100.0)
    tun = get_tuning("consistent")
    rejected = {"attitude": [], "position": []}
    outlier_rejected = []
    for i in range(n_runs):
        rng = np.random.default_rng(seed + i)
        x0 = boxplus(tr.x[0], rng.normal(size=14) * SIGMA_0)
        m = simulate_pose_measurements(tr.t, tr.x, rng, tau_s=1.0, noise=noise)
        q, r = m.q_TS.copy(), m.r_ST_T.copy()
        bad = np.zeros((len(m.t), 2), dtype=bool)
        if outliers:
            u = rng.normal(size=(len(m.t), 3))
            u /= np.linalg.norm(u, axis=1, keepdims=True)
            bad[10::4, 0] = True
            bad[12::4, 1] = True
            q[bad[:, 0]] = quat_multiply(rotvec_to_quat(10 * tun.sigma_q_rad / np.sqrt(3) * u[bad[:, 0]]), q[bad[:, 0]])
            r[bad[:, 1]] += 10 * tun.sigma_r_m / np.sqrt(3) * u[bad[:, 1]]
        run = run_navigation(name, tr.t, tr.servicer, tr.J_S_diag, m.t, q, r, x0=x0, P0=np.diag(SIGMA_0**2), tuning=tun, gate_confidence=CONF, consider=(12, 13))
        for j, s in enumerate(("attitude", "position")):
            acc = run.accepted[s][1:]
            rejected[s].append(~acc[10:][~bad[10:, j]])
            outlier_rejected.append(~acc[bad[:, j]])
    rate = {s: float(np.mean(np.concatenate(v))) for s, v in rejected.items()}
    return rate, (float(np.mean(np.concatenate(outlier_rejected))) if outliers else None)


@pytest.mark.parametrize("name,n_runs", [("ekf", 12), ("ukf", 6)])
def test_false_alarm_rate_on_nominal_data(truth, name, n_runs):
    rate, _ = _runs(truth, name, n_runs, "gaussian")
    print(f"{name}: false-alarm rate {rate} (expected {1 - CONF:.2f})")
    for s, v in rate.items():
        assert abs(v - (1 - CONF)) <= 0.02, (s, v)


@pytest.mark.parametrize("name", ["ekf", "ukf"])
def test_ten_sigma_outliers_are_rejected(truth, name):
    rate, out = _runs(truth, name, 4, "gaussian", outliers=True)
    print(f"{name}: {100 * out:.1f}% of 10-sigma outliers rejected; false alarms {rate}")
    assert out >= 0.99


def test_paper_noise_is_not_chi_square(truth):
    """Eqs 33–34 noise: same covariance, but the two-sided gate rejects far more than 1 − c."""
    rate, _ = _runs(truth, "ekf", 6, "isotropic")
    print(f"ekf, paper (isotropic) noise: rejection rate {rate} at confidence {CONF}")
    assert rate["attitude"] > (1 - CONF) + 0.05 and rate["position"] > (1 - CONF) + 0.05
