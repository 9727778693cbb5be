"""Filter consistency: 30 seeded runs of SC1 and SC3, NEES in its 95 % band after convergence.

Nominal noise is the pose-estimator model of ``002_…`` §4.4 with Gaussian
rotation-vector and position errors of the paper's covariance
(``noise="gaussian"``), initial errors drawn from ``P_0``, the
``consistent`` tuning. The run-averaged NEES (30 runs) is tested at every
step after the first 10 s (convergence) against the two-sided 95 % band of
``χ²(30 · dof) / 30``; it must be inside for ≥ 90 % of those steps.

In SC1 (spin about a principal axis) the inertia ratios do not affect the
motion, so they are considered, not estimated (§6.1 of ``002_…``), and the NEES
has 12 degrees of freedom; in SC3 all 14 are estimated.

The criterion is sensitive to the seed set, because with ``Q_d ≈ 0`` the
errors are correlated over the whole run and a run whose early steps left a
bias keeps it (EKF run seed 5011: 4σ on the spin phase and ``ω_z`` for 90 s).
Measured on other sets of 30 seeds (fraction of steps in band, SC1/SC3):
EKF 2000: 35/29 %, 3000: 90/66 %, 4000: 100/100 %, 5000: 8/34 %, 6000: 71/56 %
(run-averaged NEES/dof 0.95–1.26); UKF 2000: 100/96 %, 4000: 91/78 %,
5000: 57/71 % (0.90–1.13). The seeds below (1000–1029) are the first set tried.
"""

import numpy as np
import pytest

from estimators.error_state import boxplus
from estimators.navigation import run_navigation
from estimators.tuning import get_tuning
from perception.simulated_pose import simulate_pose_measurements
from studies.metrics import fraction_in_band, nees

N_RUNS = 30
DURATION_S = 100.0
CONVERGED_AFTER = 10  # steps of 1 s
#: 1-σ of the initial error: attitude (rad), rate (rad/s), position (m), velocity (m/s), k.
SIGMA_0 = np.repeat([0.1, 0.005, 0.5, 0.02, 0.1], [3, 3, 3, 3, 2]) * np.sqrt(0.1)


@pytest.mark.slow
@pytest.mark.parametrize("scenario", ["SC1", "SC3"])
@pytest.mark.parametrize("name", ["ekf", "ukf"])
def test_nees_in_band(truth, scenario, name):
    tr = truth(scenario, DURATION_S)
    one_axis = scenario == "SC1"
    states = np.arange(12) if one_axis else np.arange(14)
    E = []
    for i in range(N_RUNS):
        rng = np.random.default_rng(1000 + i)
        x0 = boxplus(tr.x[0], rng.normal(size=14) * SIGMA_0)
        m = simulate_pose_measurements(tr.t, tr.x, rng, tau_s=1.0, noise="gaussian")
        run = run_navigation(
            name, tr.t, tr.servicer, tr.J_S_diag, m.t, m.q_TS, m.r_ST_T,
            x0=x0, P0=np.diag(SIGMA_0**2), tuning=get_tuning("consistent"), gate_confidence=None,
            consider=(12, 13) if one_axis else (),
        )
        E.append(nees(run.x, run.P, tr.x, states))
    E = np.array(E)[:, CONVERGED_AFTER:]
    frac = fraction_in_band(E, len(states), confidence=0.95)
    print(f"{scenario} {name}: NEES in 95% band for {100 * frac:.1f}% of steps, mean/dof {E.mean() / len(states):.3f}")
    assert frac >= 0.90
