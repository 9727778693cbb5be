"""Simulated pose-estimator measurements (Renis et al. §4.4, eqs 33–34).

A CNN pose estimator seen from the filter: at a fixed rate ``1/τ_s`` it returns
the relative attitude ``q_TS`` and position ``r_ST_T`` (eq. 24) with

* attitude noise ``q̃ = q ⊗ δq_n`` (eq. 33), ``δq_n = [cos(α_n/2), r_n sin(α_n/2)]``
  (eq. 34) with a Gaussian amplitude ``α_n ~ N(0, σ_q²)`` and an axis ``r_n``
  uniform on the unit sphere (``σ_q = 0.12`` rad);
* position noise: a vector of Gaussian length ``~ N(0, σ_r²)`` along a uniform
  direction (``σ_r = 0.37`` m at 50 m), optionally scaled with the range
  (``σ_r |r| / 50 m``);
* fault windows ``(start_s, length_s)`` where both parts come with heavy noise
  (``fault_sigma_q_rad``, ``fault_sigma_r_m``) — e.g. an eclipse.

The paper calls ``σ`` a variance; it is used here as the standard deviation of
the amplitude, which is what 0.12 rad and 0.37 m can only mean. This noise
(``noise="isotropic"``, the paper's) has per-axis covariance ``σ²/3 I`` but is
*not* Gaussian: ``|noise|² = σ² χ²₁``, not ``σ²/3 χ²₃``, so a chi-square test on
it does not have its nominal false-alarm rate (measured in
``tests/estimators/test_gates_in_filter.py``). ``noise="gaussian"`` draws the
rotation vector and the position error as ``N(0, σ²/3 I)`` instead: the same
covariance with a Gaussian distribution, the nominal case of the chi-square
tests.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from estimators.attitude import quat_multiply, rotvec_to_quat
from estimators.measurement import NOISE_MODELS, PoseNoise
from estimators.state import Q_TS, R_ST_T


@dataclass(frozen=True)
class PoseMeasurements:
    """Measurements at ``t`` (M,): ``q_TS`` (M, 4), ``r_ST_T`` (M, 3) m, ``faulty`` (M,) bool."""

    t: np.ndarray
    q_TS: np.ndarray
    r_ST_T: np.ndarray
    faulty: np.ndarray
    sigma_q_rad: float  #: nominal amplitude σ of the attitude noise
    sigma_r_m: np.ndarray  #: (M,) amplitude σ of the position noise actually used (range-scaled or not)
    noise: str


def _unit_vectors(rng: np.random.Generator, n: int) -> np.ndarray:
    u = rng.normal(size=(n, 3))
    return u / np.linalg.norm(u, axis=1, keepdims=True)


def _noise_vectors(rng, sigma, n: int, noise: str) -> np.ndarray:
    sigma = np.broadcast_to(np.asarray(sigma, dtype=float), (n,))
    if noise == "isotropic":
        return rng.normal(size=n)[:, None] * sigma[:, None] * _unit_vectors(rng, n)
    return rng.normal(size=(n, 3)) * (sigma / np.sqrt(3.0))[:, None]


def parse_faults(faults) -> tuple[tuple[float, float], ...]:
    """Validate fault windows ``[(start_s, length_s), ...]``."""
    out = []
    for f in faults or ():
        try:
            start, length = (float(v) for v in f)
        except (TypeError, ValueError):
            raise ValueError(f"fault window must be (start_s, length_s), got {f!r}") from None
        if not (np.isfinite(start) and np.isfinite(length) and start >= 0 and length > 0):
            raise ValueError(f"fault window needs start >= 0 and length > 0 (s), got {f!r}")
        out.append((start, length))
    return tuple(out)


def simulate_pose_measurements(
    t,
    x_true,
    rng: np.random.Generator,
    *,
    tau_s: float,
    sigma_q_rad: float = PoseNoise.sigma_q_rad,
    sigma_r_m: float = PoseNoise.sigma_r_m,
    range_scaling: bool = False,
    reference_range_m: float = 50.0,
    faults=(),
    fault_sigma_q_rad: float = 1.5,
    fault_sigma_r_m: float = 20.0,
    noise: str = "isotropic",
    t_start: float | None = None,
) -> PoseMeasurements:
    """Noisy pose measurements of the truth ``x_true`` (N, 15) sampled at ``t`` (N,) s.

    Measurements are taken every ``tau_s`` seconds from ``t_start`` (default:
    one sampling time after ``t[0]``, the first filter update) to ``t[-1]``;
    those instants must be on the truth grid (to 1e-9 s). The amplitudes and
    ``noise`` are those of a :class:`~estimators.measurement.PoseNoise`, from
    which the filters take their ``R_d`` (:func:`studies.sim.navigation.navigate`
    passes one object to both). The default ``noise="isotropic"`` is eq. 34
    read literally.
    """
    t = np.asarray(t, dtype=float)
    x_true = np.asarray(x_true, dtype=float)
    if x_true.ndim != 2 or x_true.shape[1] != 15 or x_true.shape[0] != t.shape[0]:
        raise ValueError(f"x_true must be (N, 15) with N = len(t), got {x_true.shape} and {t.shape}")
    if not (np.isfinite(tau_s) and tau_s > 0):
        raise ValueError(f"tau_s must be positive (s), got {tau_s!r}")
    if noise not in NOISE_MODELS:
        raise ValueError(f"noise must be one of {NOISE_MODELS}, got {noise!r}")
    for name, v in (("sigma_q_rad", sigma_q_rad), ("sigma_r_m", sigma_r_m), ("fault_sigma_q_rad", fault_sigma_q_rad), ("fault_sigma_r_m", fault_sigma_r_m)):
        if not (np.isfinite(v) and v >= 0):
            raise ValueError(f"{name} must be finite and >= 0, got {v!r}")
    faults = parse_faults(faults)
    t0 = t[0] + tau_s if t_start is None else float(t_start)
    t_meas = t0 + tau_s * np.arange(int(np.floor((t[-1] - t0) / tau_s + 1e-9)) + 1)
    idx = np.searchsorted(t, t_meas - 1e-9)
    idx = np.clip(idx, 0, len(t) - 1)
    if np.any(np.abs(t[idx] - t_meas) > 1e-9):
        raise ValueError(f"measurement instants every tau_s={tau_s} s are not on the truth time grid")
    x = x_true[idx]
    n = len(idx)
    faulty = np.zeros(n, dtype=bool)
    for start, length in faults:
        faulty |= (t_meas >= start) & (t_meas < start + length)

    rng_m = np.linalg.norm(x[:, R_ST_T], axis=1)
    s_r = sigma_r_m * (rng_m / reference_range_m if range_scaling else np.ones(n))
    s_r = np.where(faulty, fault_sigma_r_m, s_r)
    s_q = np.where(faulty, fault_sigma_q_rad, sigma_q_rad)
    dq = rotvec_to_quat(_noise_vectors(rng, s_q, n, noise))
    q = quat_multiply(x[:, Q_TS], dq)  # eq. 33
    q = q * np.where(q[:, :1] < 0, -1.0, 1.0)
    r = x[:, R_ST_T] + _noise_vectors(rng, s_r, n, noise)
    return PoseMeasurements(t=t_meas, q_TS=q, r_ST_T=r, faulty=faulty, sigma_q_rad=float(sigma_q_rad), sigma_r_m=s_r, noise=noise)
