"""A fast stand-in for the stereo + BCPD pose measurement (Maestrini et al. §IV.A, §V.B).

The real chain renders a stereo pair, triangulates a point cloud and registers
the on-board coarse model to it with BCPD, which returns a similarity
transform ``s R (·) + t``: from it come the measured attitude ``C_TI`` (eq. 5),
the target position ``r`` in LVLH (eq. 8) and the scale ``s``. This module
draws such outputs directly from the true pose, for studies that need
thousands of measurements:

* nominal registrations: position error ``N(0, σ_r² I)`` (m), attitude error a
  rotation vector ``N(0, σ_a² I)`` (rad) applied in the target frame, scale
  ``1 + N(0, σ_s²)``;
* with probability ``outlier_probability`` a failed registration, half of
  them *deformed* (scale drawn outside ``[0.8, 1.2]``: ``U(0.5, 0.75)`` or
  ``U(1.25, 1.6)``) and half *misaligned* with a plausible scale (position
  off by ``U(4, 10)`` m in a random direction, attitude by a random rotation
  of ``U(40°, 180°)``) — the two kinds the scale and Mahalanobis gates catch;
* for an axisymmetric target (``symmetry_axis_T`` given) BCPD cannot see the
  roll about the symmetry axis, so every registration carries an extra roll
  about that axis drawn uniformly in ``[0, 2π)``; the axis direction itself
  is still measured correctly (§V.B).

All randomness comes from the ``numpy.random.Generator`` given at construction.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from estimators.attitude import quat_multiply, quat_normalize, quat_to_dcm, rotvec_to_quat


@dataclass(frozen=True)
class RegisteredPose:
    """One registration result as the filters consume it (also the rendered chain's, once converted)."""

    t: float  #: s since the scenario epoch
    r_L: np.ndarray  #: (3,) m, target centre of mass relative to the chaser, LVLH (eq. 8)
    q_IT: np.ndarray  #: (4,) measured target attitude, T to I (eq. 5)
    scale: float  #: BCPD similarity scale ``s``
    kind: str  #: "nominal", "deformed", "misaligned" (simulated, for diagnostics only), "rendered", "no registration: …"
    cloud_L: np.ndarray | None = None  #: (M, 3) m, the measured cloud relative to the chaser in LVLH (rendered chain only)

    @property
    def C_TI(self) -> np.ndarray:
        """The paper's ``C_TI`` (I to T), ``R(q_IT)ᵀ``."""
        return quat_to_dcm(self.q_IT).T


class SimulatedBCPD:
    """Draws pose measurements around the true pose (see the module docstring).

    Parameters
    ----------
    rng : numpy.random.Generator
    position_sigma_m : float
        1-σ position error per axis of a nominal registration.
    attitude_sigma_rad : float
        1-σ attitude error per axis (rotation vector) of a nominal registration.
    scale_sigma : float
        1-σ of the scale about 1 for a nominal registration.
    outlier_probability : float
        probability that a registration fails.
    symmetry_axis_T : (3,), optional
        symmetry axis in the target frame; enables the random roll.
    """

    def __init__(self, rng: np.random.Generator, *, position_sigma_m: float = 0.3, attitude_sigma_rad: float = np.deg2rad(2.0), scale_sigma: float = 0.02,
                 outlier_probability: float = 0.05, symmetry_axis_T=None):
        if not isinstance(rng, np.random.Generator):
            raise TypeError("rng must be a numpy.random.Generator")
        for name, v in (("position_sigma_m", position_sigma_m), ("attitude_sigma_rad", attitude_sigma_rad), ("scale_sigma", scale_sigma)):
            if not (np.isfinite(v) and v >= 0):
                raise ValueError(f"{name} must be finite and non-negative, got {v!r}")
        if not (0.0 <= outlier_probability <= 1.0):
            raise ValueError(f"outlier_probability must lie in [0, 1], got {outlier_probability!r}")
        self.rng = rng
        self.position_sigma_m = float(position_sigma_m)
        self.attitude_sigma_rad = float(attitude_sigma_rad)
        self.scale_sigma = float(scale_sigma)
        self.outlier_probability = float(outlier_probability)
        if symmetry_axis_T is None:
            self.symmetry_axis_T = None
        else:
            a = np.asarray(symmetry_axis_T, dtype=float)
            if a.shape != (3,) or not np.linalg.norm(a) > 0:
                raise ValueError("symmetry_axis_T must be a non-zero 3-vector")
            self.symmetry_axis_T = a / np.linalg.norm(a)

    def _random_direction(self) -> np.ndarray:
        u = self.rng.normal(size=3)
        return u / np.linalg.norm(u)

    def measure(self, t: float, r_L_true, q_IT_true, *, r_L_hat=None, q_IT_hat=None) -> RegisteredPose:
        """A registration of the target at true position ``r_L_true`` (m) and attitude ``q_IT_true``.

        ``r_L_hat``, ``q_IT_hat`` (the filters' estimates, which seed a real
        registration through eq. 3) are accepted for interface compatibility and
        not used: the simulated errors do not depend on them.
        """
        rng = self.rng
        r = np.asarray(r_L_true, dtype=float) + self.position_sigma_m * rng.normal(size=3)
        dq = rotvec_to_quat(self.attitude_sigma_rad * rng.normal(size=3))
        scale = 1.0 + self.scale_sigma * rng.normal()
        kind = "nominal"
        if rng.random() < self.outlier_probability:
            if rng.random() < 0.5:
                kind = "deformed"
                scale = rng.uniform(0.5, 0.75) if rng.random() < 0.5 else rng.uniform(1.25, 1.6)
            else:
                kind = "misaligned"
                r = r + rng.uniform(4.0, 10.0) * self._random_direction()
                dq = rotvec_to_quat(rng.uniform(np.deg2rad(40.0), np.pi) * self._random_direction())
        if self.symmetry_axis_T is not None:
            roll = rotvec_to_quat(rng.uniform(0.0, 2.0 * np.pi) * self.symmetry_axis_T)
            dq = quat_multiply(dq, roll)
        q = quat_normalize(quat_multiply(np.asarray(q_IT_true, dtype=float), dq))  # error applied in T
        return RegisteredPose(t=float(t), r_L=r, q_IT=q, scale=float(scale), kind=kind)
