"""Real-time cost: CPU time per filter step against elapsed time (issue 31, deliverable 3).

SC3, the perturbed truth (the world of the default ``fixed-lag``), pose measurements every 1 s, §6's initial guess, one process. Per filter, the CPU time
(``time.process_time``) of every step — predict, update, and for ``relinearized`` its full-information fit every
10 s — read by :func:`estimators.navigation.run_navigation`'s ``clock``, in 100-step blocks:

* ``budgeted`` EKF and UKF (:mod:`estimators.process_noise`; real time, no fits) and ``fixed-lag`` EKF and UKF (the default: a fit
  of a bounded window every 10 s, :class:`estimators.navigation._Relinearization`) over two orbits of the 500 km
  orbit (:data:`DURATION_S`, 11 400 s);
* ``relinearized`` EKF (``lcnav run``'s default until ``fixed-lag`` replaced it) over :data:`RELINEARIZED_S` only: its per-step cost grows
  with the elapsed time (each fit costs ∝ the measurements so far), so two orbits would take hours;
* baselines in the same run, on the same model, measurements and ``Q_d``: filterpy's ``ExtendedKalmanFilter``
  (``F`` from the model's Jacobian, the error state reset after each step) and ``UnscentedKalmanFilter`` (14-state
  error-state sigma points, each propagated by the model on its own: filterpy's loop).

Targets of issue 31: the block at the end ≤ 1.2× the block at 300 s; median ≤ 1 ms (EKF), ≤ 3 ms (UKF).
Writes ``benchmarks/realtime.png`` (median per block against elapsed time). ``LCNAV_BENCH_QUICK=1``: 1200 s.
"""

from __future__ import annotations

import os
import time
from pathlib import Path

import numpy as np
from filterpy.kalman import ExtendedKalmanFilter, MerweScaledSigmaPoints, UnscentedKalmanFilter

from estimators.filter import _block_diag
from estimators.measurement import PoseNoise
from estimators.navigation import run_navigation
from estimators.process_model import RelativeProcessModel
from estimators.state import DR_ST_T, R_ST_T
from estimators.tuning import get_tuning
from studies.sim.navigation import NavigationSetup, initial_guess, simulate_measurements
from studies.sim.scenarios import get_scenario
from studies.sim.truth import simulate_truth

HERE = Path(__file__).resolve().parent
QUICK = os.environ.get("LCNAV_BENCH_QUICK") == "1"
#: Two orbits of the 500 km orbit at 1 s (one orbit is 5677 s).
DURATION_S = 1200.0 if QUICK else 11400.0
#: The re-linearised filter's run: long enough to show its growth, short enough to finish (fits cost ∝ elapsed time).
RELINEARIZED_S = 500.0 if QUICK else 900.0
BLOCK = 100
SEED = 1


def _data(duration_s: float):
    tr = simulate_truth(get_scenario("SC3"), duration_s, 1.0, "perturbed")
    rng = np.random.default_rng(SEED)
    meas = simulate_measurements(tr, NavigationSetup("ekf", get_tuning("budgeted")), rng)
    return tr, meas, initial_guess(tr, rng)


def _lcnav(name: str, tuning: str, tr, meas, x0) -> np.ndarray:
    run = run_navigation(name, tr.t, tr.servicer, tr.J_S_diag, *meas[:3], x0=x0, tuning=get_tuning(tuning), pose_noise=PoseNoise(),
                         gate_start_s=10.0, clock=time.process_time)
    return run.step_s[1:]


def _filterpy(kind: str, tr, meas, x0) -> np.ndarray:
    """CPU s per step of filterpy's EKF or UKF on the error state of the same model, ``Q_d`` (``budgeted``) and ``R_d``."""
    model = RelativeProcessModel(tr.J_S_diag)
    tun = get_tuning("budgeted")
    att, pos = PoseNoise().sources()
    R = _block_diag([att.R, pos.R])
    H = np.vstack([att.jacobian(x0), pos.jacobian(x0)])
    Q = tun.Q_d(1.0)
    x = x0.copy()
    ref = {}
    if kind == "ekf":
        f = ExtendedKalmanFilter(14, 6)
    else:
        pts = MerweScaledSigmaPoints(14, alpha=1.0, beta=2.0, kappa=0.0)
        f = UnscentedKalmanFilter(14, 6, 1.0, hx=lambda d: np.concatenate([att.h_chart(model.boxplus(ref["c"], d), ref["c"]), d[DR_ST_T]]),
                                  fx=lambda d, dt: model.boxminus(model.propagate(model.boxplus(ref["x"], d), ref["s"], dt), ref["c"]), points=pts)
    f.P, f.Q, f.R = tun.P_0.copy(), Q, R
    _, q_meas, r_meas = meas[:3]
    out = np.empty(len(tr.t) - 1)
    for k in range(1, len(tr.t)):
        c0 = time.process_time()
        f.x = np.zeros(14)
        if kind == "ekf":
            c, f.F = model.propagate_with_jacobian(x, tr.servicer[k - 1], 1.0)
            f.predict()
        else:
            ref.update(x=x, s=tr.servicer[k - 1], c=model.propagate(x, tr.servicer[k - 1], 1.0))
            c = ref["c"]
            f.predict()
        z = np.concatenate([att.z_chart(q_meas[k - 1], c), r_meas[k - 1] - c[R_ST_T]])
        if kind == "ekf":
            f.update(z, HJacobian=lambda d: H, Hx=lambda d: H @ d)
        else:
            f.update(z)
        x = model.boxplus(c, f.x)
        out[k - 1] = time.process_time() - c0
    return out


def _blocks(step_s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(block start times s, mean CPU s per step in each block of :data:`BLOCK` steps: the amortised cost, fits included)."""
    n = len(step_s) // BLOCK
    return BLOCK * np.arange(n) + 1.0, step_s[: n * BLOCK].reshape(n, BLOCK).mean(axis=1)


def _figure(series: dict) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from studies.engine.io import atomic_path

    fig, ax = plt.subplots(figsize=(8, 4.5))
    for label, s in series.items():
        t0, med = _blocks(s)
        ax.semilogy(t0 + BLOCK / 2, 1e3 * med, label=label)
    ax.set_xlabel("elapsed time (s)")
    ax.set_ylabel(f"CPU per step, mean of {BLOCK} steps (ms)")
    ax.set_title("SC3, 1 s steps: cost per step against elapsed time")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    with atomic_path(HERE / "realtime.png") as tmp:
        fig.savefig(tmp, dpi=110, format="png")
    plt.close(fig)


def run() -> str:
    t0 = time.perf_counter()
    tr, meas, x0 = _data(DURATION_S)
    series = {f"{tun} {f.upper()} (lcnav)": _lcnav(f, tun, tr, meas, x0) for tun in ("budgeted", "fixed-lag") for f in ("ekf", "ukf")}
    short = _data(RELINEARIZED_S)
    series["relinearized EKF (lcnav, the former default)"] = _lcnav("ekf", "relinearized", *short)
    series["filterpy ExtendedKalmanFilter (baseline)"] = _filterpy("ekf", tr, meas, x0)
    series["filterpy UnscentedKalmanFilter (baseline)"] = _filterpy("ukf", tr, meas, x0)
    _figure(series)
    at = int(300 // BLOCK)
    lines = ["## Real-time cost per step (EKF, UKF)", "",
             f"SC3, perturbed truth, 1 s steps with a pose measurement each, seed {SEED}, one process; CPU time per step "
             f"(`time.process_time`): the median over the run, and the mean of {BLOCK}-step blocks (amortised: a block holds 10 "
             f"of `relinearized`'s or `fixed-lag`'s fits, which the median misses). `budgeted` and `fixed-lag` run {DURATION_S:.0f} s"
             f"{'' if QUICK else ' (two orbits at 500 km)'}; "
             f"`relinearized` (the former default, a full-information fit every 10 s) runs {RELINEARIZED_S:.0f} s. filterpy's filters run the "
             "same model, measurements and `Q_d` on the error state (the same-run baseline). Issue 31's targets: last block ≤ 1.2× the "
             "block at 300 s; median ≤ 1 ms (EKF), ≤ 3 ms (UKF). Figure: `benchmarks/realtime.png`.", "",
             "| filter | steps | median (ms) | p90 (ms) | block mean at 300 s (ms) | last block mean (ms) | last / at 300 s | "
             "median / filterpy's (same kind) |", "|---|---|---|---|---|---|---|---|"]
    base = {"EKF": np.median(series["filterpy ExtendedKalmanFilter (baseline)"]), "UKF": np.median(series["filterpy UnscentedKalmanFilter (baseline)"])}
    for label, s in series.items():
        _, med = _blocks(s)
        kind = "UKF" if "UKF" in label or "Unscented" in label else "EKF"
        lines.append(f"| {label} | {len(s)} | {1e3 * np.median(s):.3f} | {1e3 * np.percentile(s, 90):.3f} | {1e3 * med[at]:.3f} | "
                     f"{1e3 * med[-1]:.3f} | {med[-1] / med[at]:.2f} | {np.median(s) / base[kind]:.2f} |")
    lines += ["", f"Wall time {time.perf_counter() - t0:.0f} s (2 cores shared with other jobs: CPU time, not wall time, is reported)."]
    return "\n".join(lines)


if __name__ == "__main__":
    print(run())
