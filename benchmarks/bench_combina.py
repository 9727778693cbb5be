"""CoMBiNa per-iteration time (``000_…`` §VII.A, Fig. 19).

One iteration = registration (here the simulated BCPD-like draw) + prediction
+ gates + update of both filters (+ the symmetry check), timed inside
:func:`studies.combina.run_combina` over 1000 measurement epochs of the §VI
scenario at 0.33 Hz. Baseline measured in the same run: the translational UKF
alone against filterpy's :class:`~filterpy.kalman.UnscentedKalmanFilter`
driving the same NERM model and sigma points.
"""

from __future__ import annotations

import time

import numpy as np
from filterpy.kalman import MerweScaledSigmaPoints, UnscentedKalmanFilter

from estimators.combina_translation import TranslationalUKF
from estimators.dynamics import nerm_rhs, rk4_step
from studies.combina import N_RAD_S, R_T_M, TU, CombinaConfig, run_combina

N_ITER = 1000
RATE_HZ = 0.33
PCT = (50, 90, 99, 99.9, 100)


def _row(name: str, dt_s: np.ndarray) -> str:
    p = np.percentile(dt_s * 1e3, PCT)
    return f"| {name} | " + " | ".join(f"{v:.2f}" for v in p) + " |"


def _translational_pair(n: int) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(0)
    dt = 1.0 / RATE_HZ
    x0 = np.array([24.0, 0.0, 2.4, 0.0, -0.6, 0.0])
    P0 = np.diag([14.4] * 3 + [1.6e-5] * 3)
    R = 1.44 * np.eye(3)
    ours = TranslationalUKF(x0, P0, n_rad_s=N_RAD_S, R_t_m=R_T_M)
    ref = UnscentedKalmanFilter(6, 3, dt, hx=lambda x: x[:3], fx=lambda x, dt: rk4_step(nerm_rhs, 0.0, x, dt, N_RAD_S, R_T_M), points=MerweScaledSigmaPoints(6, alpha=1.0, beta=2.0, kappa=0.0))
    ref.x, ref.P, ref.R = x0.copy(), P0.copy(), R
    t_ours, t_ref = np.zeros(n), np.zeros(n)
    for i in range(n):
        z = x0[:3] + rng.normal(size=3)
        tic = time.perf_counter()
        ours.predict(dt)
        ours.correct(ours.innovation(z, R))
        t_ours[i] = time.perf_counter() - tic
        tic = time.perf_counter()
        ref.predict()
        ref.update(z)
        t_ref[i] = time.perf_counter() - tic
    return t_ours, t_ref


def run() -> str:
    dur_tu = (N_ITER + 0.5) / RATE_HZ / TU
    run_combina(CombinaConfig(target="asymmetric", seed=0, duration_tu=0.05, rate_hz=RATE_HZ))  # warm-up (imports, numba caches)
    asym = run_combina(CombinaConfig(target="asymmetric", seed=1, duration_tu=dur_tu, rate_hz=RATE_HZ))
    sym = run_combina(CombinaConfig(target="symmetric", seed=1, duration_tu=dur_tu, rate_hz=RATE_HZ))
    t_ours, t_ref = _translational_pair(N_ITER)
    med_ratio = np.median(t_ours) / np.median(t_ref)
    lines = [
        "## CoMBiNa per-iteration time (simulated chain)",
        "",
        f"{N_ITER} iterations at {RATE_HZ} Hz of the 000 §VI scenario (`studies.combina.run_combina`); times in ms, percentiles as in Fig. 19 of 000.",
        "One iteration = simulated BCPD-like registration + prediction + gates + update of both filters + symmetry check.",
        "",
        "| chain | p50 | p90 | p99 | p99.9 | max |",
        "|---|---|---|---|---|---|",
        _row(f"asymmetric target, nominal mode ({asym.iteration_s.size} it.)", asym.iteration_s),
        _row(f"symmetric target, switches to axisymmetric mode at {sym.switch_time_s:.0f} s ({sym.iteration_s.size} it.)", sym.iteration_s),
        _row("translational UKF alone (predict + update), lcnav", t_ours),
        _row("translational UKF alone, filterpy `UnscentedKalmanFilter` (baseline)", t_ref),
        "",
        f"Median ratio lcnav / filterpy for the translational UKF: {med_ratio:.2f}. "
        f"Goal of 000 (p99 < 100 ms with registration): simulated chain p99 = {np.percentile(asym.iteration_s, 99) * 1e3:.1f} ms; "
        "the simulated registration is a random draw, so this is the filter cost only. "
        "The rendered chain (stereo + BCPD registration) is not benchmarked here: it is not wired into `lcnav combina` yet.",
    ]
    return "\n".join(lines)
