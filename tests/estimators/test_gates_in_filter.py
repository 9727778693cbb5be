"""The chi-square validation gate inside both filters (Maestrini et al. eq. 18–20; Renis et al. §4.3).

The gate is one-sided (:mod:`estimators.gates`): on nominal data (Gaussian
noise of the filters' own ``R_d``, consistent filter) each source must reject
``1 − c`` of the measurements, every one of them *above* the bound. The
rejection count over ``N`` tested measurements is checked against the 99.9 %
binomial interval of ``Binomial(N, 1 − c)`` and against the issue's "within 2×
nominal"; injected 10-σ outliers must be rejected (≥ 99 %). The paper's own
noise (Gaussian amplitude on a uniform axis, eqs 33–34) has the same
covariance but ``|n|² ~ σ² χ²₁``: its false-alarm rate is about twice
``1 − c`` (``P(3χ²₁ > χ²₃(0.95)) = P(χ²₁ > 2.60) = 0.107`` when ``R``
dominates ``S``), which the last test measures.
"""

import numpy as np
import pytest
from scipy.stats import binom

from estimators.attitude import quat_multiply, rotvec_to_quat
from estimators.error_state import boxplus
from estimators.measurement import PoseNoise
from estimators.navigation import run_navigation
from estimators.state import K_STATES
from estimators.tuning import get_tuning
from perception.simulated_pose import simulate_pose_measurements

SIGMA_0 = np.repeat([0.1, 0.005, 0.5, 0.02, 0.1], [3, 3, 3, 3, 2]) * np.sqrt(0.1)
CONF = 0.95


def _runs(truth, name, n_runs, model, outliers=False, seed=77):
    tr = truth("SC1", 100.0)
    tun = get_tuning("consistent")
    noise = PoseNoise(model=model)
    rejected = {"attitude": [], "position": []}
    below = []
    outlier_rejected = []
    for i in range(n_runs):
        rng = np.random.default_rng(seed + i)
        x0 = boxplus(tr.x[0], rng.normal(size=14) * SIGMA_0)
        m = simulate_pose_measurements(tr.t, tr.x, rng, tau_s=1.0, sigma_q_rad=noise.sigma_q_rad, sigma_r_m=noise.sigma_r_m, noise=noise.model)
        q, r = m.q_TS.copy(), m.r_ST_T.copy()
        bad = np.zeros((len(m.t), 2), dtype=bool)
        if outliers:
            u = rng.normal(size=(len(m.t), 3))
            u /= np.linalg.norm(u, axis=1, keepdims=True)
            bad[10::4, 0] = True
            bad[12::4, 1] = True
            q[bad[:, 0]] = quat_multiply(rotvec_to_quat(10 * noise.sigma_q_rad / np.sqrt(3) * u[bad[:, 0]]), q[bad[:, 0]])
            r[bad[:, 1]] += 10 * noise.sigma_r_m / np.sqrt(3) * u[bad[:, 1]]
        run = run_navigation(name, tr.t, tr.servicer, tr.J_S_diag, m.t, q, r, x0=x0, P0=np.diag(SIGMA_0**2), tuning=tun,
                             pose_noise=noise, gate_confidence=CONF, consider=K_STATES)
        below += [d for d in run.decisions if not d.accepted and d.e2 < d.upper]
        for j, s in enumerate(("attitude", "position")):
            acc = run.accepted[s][1:]
            rejected[s].append(~acc[10:][~bad[10:, j]])
            outlier_rejected.append(~acc[bad[:, j]])
    assert not below, "the gate rejected a measurement below its upper bound"
    counts = {s: (int(np.concatenate(v).sum()), int(np.concatenate(v).size)) for s, v in rejected.items()}
    return counts, (float(np.mean(np.concatenate(outlier_rejected))) if outliers else None)


@pytest.mark.parametrize("name,n_runs", [("ekf", 12), ("ukf", 6)])
def test_false_alarm_rate_on_nominal_data(truth, name, n_runs):
    counts, _ = _runs(truth, name, n_runs, "gaussian")
    print(f"{name}: rejections {counts} (expected rate {1 - CONF:.2f})")
    for s, (k, n) in counts.items():
        lo, hi = binom.interval(0.999, n, 1 - CONF)
        assert lo <= k <= hi, (s, k, n, lo, hi)
        assert 0.5 * (1 - CONF) <= k / n <= 2.0 * (1 - CONF), (s, k / n)


@pytest.mark.parametrize("name", ["ekf", "ukf"])
def test_ten_sigma_outliers_are_rejected(truth, name):
    counts, out = _runs(truth, name, 4, "gaussian", outliers=True)
    print(f"{name}: {100 * out:.1f}% of 10-sigma outliers rejected; false alarms {counts}")
    assert out >= 0.99


def test_paper_noise_is_not_chi_square(truth):
    """Eqs 33–34 noise: same covariance, but the gate rejects about twice 1 − c."""
    counts, _ = _runs(truth, "ekf", 6, "isotropic")
    print(f"ekf, paper (isotropic) noise: rejections {counts} at confidence {CONF}")
    for s, (k, n) in counts.items():
        assert k > binom.interval(0.999, n, 1 - CONF)[1], (s, k, n)
