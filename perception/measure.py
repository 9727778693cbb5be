"""Pose measurements from a stereo point cloud and the coarse model, eqs 3–8 of Maestrini et al.

Frames and DCMs follow the paper's notation, ``C_AB`` maps B-components to
A-components (``v_A = C_AB v_B``; in lcnav terms ``C_AB = R(q_AB)``):

* eq. 3  ``P^T̃ = C_T̃C P^C − 1_M ⊗ C_T̃L r̂``, with ``C_T̃C = C_T̃I C_IC`` and
  ``C_T̃L = C_T̃I C_IL``: the measured cloud projected with the filter's
  estimate into the estimated target frame T̃;
* eq. 4  ``P^T = s R P^T̃ + t``: rigid BCPD against the model (:mod:`perception.bcpd`);
* eq. 5  ``C_TI = C_TT̃ C_T̃I`` with ``C_TT̃ = R``;
* eqs 6–7 the MRP of ``C_TI``. The paper's ``C_TI`` is a passive DCM (Schaub's
  ``[BN]``), so its ``σ_T`` is the MRP of the target attitude ``q_IT``
  (``v_I = R(q_IT) v_T``): ``σ_T = dcm_to_mrp(C_TI.T)``
  (:func:`estimators.attitude.dcm_to_mrp`, which implements eq. 6 with the
  corrected ``ζ(ζ + 2)`` denominator and eq. 7 at 180°);
* eq. 8  ``r = r̂ − C_LT̃ C_TT̃ᵀ t``: the corrected target position relative to
  the chaser in LVLH.

The scale gate (§IV.A): ``s`` outside ``[0.8, 1.2]`` marks the measurement
rejected. An empty or degenerate cloud is also a rejected measurement, with
the reason recorded — :func:`measure_pose` never raises inside a filter loop
for a bad cloud (only for arguments of the wrong shape, which are bugs).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from estimators.attitude import dcm_to_mrp
from perception.bcpd import BCPDResult, bcpd_rigid

__all__ = ["PoseMeasurement", "mrp_of_C_TI", "project_to_estimated_frame", "measure_pose"]


@dataclass(frozen=True)
class PoseMeasurement:
    """One pose measurement (or its rejection).

    Attributes
    ----------
    accepted : False when the cloud was degenerate or the scale gate failed.
    reason : why it was rejected (``""`` when accepted).
    n_points : finite points in the measured cloud.
    sigma_T : (3,) MRP of the target attitude, eqs 6–7 (``|σ| ≤ 1``; the MRP of
        ``q_IT``); NaN when no registration was made.
    C_TI : (3, 3) measured DCM inertial → target, eq. 5; NaN when no registration.
    r_L : (3,) measured target position relative to the chaser in LVLH, m, eq. 8.
    scale : BCPD's ``s`` (NaN when no registration).
    registration : the BCPD result, or None.
    """

    accepted: bool
    reason: str
    n_points: int
    sigma_T: np.ndarray
    C_TI: np.ndarray
    r_L: np.ndarray
    scale: float
    registration: BCPDResult | None


def mrp_of_C_TI(C_TI) -> np.ndarray:
    """MRP ``σ_T`` (``|σ| ≤ 1``) of the passive DCM ``C_TI``, eqs 6–7 of Maestrini et al.

    ``[σ̃] = (C_TIᵀ − C_TI) / (ζ (ζ + 2))``, ``ζ = √(Tr C_TI + 1)`` and, at 180°,
    ``σ σᵀ = ½ (I + C_TI)`` — both are :func:`estimators.attitude.dcm_to_mrp`
    applied to ``C_TIᵀ = C_IT``.
    """
    return dcm_to_mrp(np.swapaxes(np.asarray(C_TI, dtype=float), -1, -2))


def project_to_estimated_frame(cloud_C, C_TI_hat, C_IC, C_IL, r_L_hat) -> np.ndarray:
    """Eq. 3: the measured cloud ``(M, 3)`` in the estimated target frame T̃, m."""
    C_TC = C_TI_hat @ C_IC
    C_TL = C_TI_hat @ C_IL
    return np.asarray(cloud_C, dtype=float) @ C_TC.T - C_TL @ r_L_hat


def _rotation(name: str, C) -> np.ndarray:
    C = np.asarray(C, dtype=float)
    if C.shape != (3, 3) or not np.all(np.isfinite(C)) or not np.allclose(C @ C.T, np.eye(3), atol=1e-6):
        raise ValueError(f"{name} must be a 3x3 rotation matrix (orthonormal, finite)")
    return C


def _rejected(reason: str, n: int) -> PoseMeasurement:
    nan3 = np.full(3, np.nan)
    return PoseMeasurement(False, reason, n, nan3, np.full((3, 3), np.nan), nan3, float("nan"), None)


def measure_pose(
    cloud_C,
    model_T,
    *,
    C_TI_hat,
    C_IC,
    C_IL,
    r_L_hat,
    scale_bounds: tuple[float, float] = (0.8, 1.2),
    min_points: int = 20,
    collinear_tol: float = 1e-3,
    gamma: float = 0.1,
    **bcpd_kwargs,
) -> PoseMeasurement:
    """Pose measurement of eqs 3–8 of Maestrini et al. from one stereo cloud.

    Parameters
    ----------
    cloud_C : (M, 3) measured points in the chaser (camera) frame C, m; rows
        with non-finite coordinates are dropped.
    model_T : (N, 3) coarse model in its principal-axis frame T, m.
    C_TI_hat : (3, 3) the filter's estimated DCM inertial → target
        (``= quat_to_dcm(q_IT_hat).T`` in lcnav's quaternions).
    C_IC : (3, 3) chaser (camera) → inertial DCM, taken as known (§III.C).
    C_IL : (3, 3) LVLH → inertial DCM (``lvlh_dcm(r, v).T``).
    r_L_hat : (3,) the filter's estimated target position relative to the chaser in LVLH, m.
    scale_bounds : accepted range of BCPD's scale ``s`` (paper: [0.8, 1.2]).
    min_points : fewer finite points than this is a degenerate cloud.
    collinear_tol : a cloud whose second principal extent is below this
        fraction of its first is collinear (degenerate).
    gamma : BCPD's initial ``σ²`` relative to the clouds' mean squared
        distance. Eq. 3 already aligns the cloud with the filter's estimate, so
        a small start (0.1, against Hirose's 1) keeps the first, wide-kernel
        iterations from pulling the model's centroid onto the visible side's
        centroid: on eight rendered one-sided views of the rocket body that
        drift ended once in a local minimum 19° off with γ = 1, never with
        0.1 (max 0.5°; ``benchmarks/RESULTS.md``).
    **bcpd_kwargs : passed to :func:`perception.bcpd.bcpd_rigid`.
    """
    C_TI_hat = _rotation("C_TI_hat", C_TI_hat)
    C_IC = _rotation("C_IC", C_IC)
    C_IL = _rotation("C_IL", C_IL)
    r_L_hat = np.asarray(r_L_hat, dtype=float)
    if r_L_hat.shape != (3,) or not np.all(np.isfinite(r_L_hat)):
        raise ValueError("r_L_hat must be a finite 3-vector in m")
    cloud = np.asarray(cloud_C, dtype=float)
    if cloud.ndim != 2 or cloud.shape[1] != 3:
        raise ValueError(f"cloud_C must be an (M, 3) array of points in m, got shape {cloud.shape}")
    cloud = cloud[np.all(np.isfinite(cloud), axis=1)]
    n = cloud.shape[0]
    if n < min_points:
        return _rejected(f"degenerate cloud: {n} finite points < min_points={min_points}", n)
    sv = np.linalg.svd(cloud - cloud.mean(axis=0), compute_uv=False)
    if sv[0] == 0.0 or sv[1] < collinear_tol * sv[0]:
        return _rejected("degenerate cloud: points are collinear (or coincident)", n)

    P_est = project_to_estimated_frame(cloud, C_TI_hat, C_IC, C_IL, r_L_hat)  # eq. 3
    reg = bcpd_rigid(P_est, model_T, gamma=gamma, **bcpd_kwargs)  # eq. 4
    C_TI = reg.R @ C_TI_hat  # eq. 5, R = C_TT̃
    sigma_T = mrp_of_C_TI(C_TI)  # eqs 6-7
    C_LT_hat = C_IL.T @ C_TI_hat.T
    r_L = r_L_hat - C_LT_hat @ reg.R.T @ reg.t  # eq. 8
    lo, hi = scale_bounds
    accepted = lo <= reg.s <= hi
    reason = "" if accepted else f"scale gate: s = {reg.s:.3f} outside [{lo}, {hi}]"
    return PoseMeasurement(accepted, reason, n, sigma_T, C_TI, r_L, float(reg.s), reg)
