"""One light curve with the geometry inversion needs: :class:`InversionCurve`.

Frames and units (DESIGN.md): vectors in the inertial frame I (GCRS axes, i.e. equatorial J2000
to within the frame bias), SI units, times as float seconds since ``epoch``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from astropy.time import Time

__all__ = ["InversionCurve"]


def _vectors(name: str, v, n: int) -> np.ndarray:
    a = np.asarray(v, dtype=float)
    if a.shape != (n, 3):
        raise ValueError(f"{name}: shape {a.shape}: expected ({n}, 3), one vector per sample")
    if not np.isfinite(a).all():
        raise ValueError(f"{name}: non-finite values: expected finite vectors")
    norm = np.linalg.norm(a, axis=1)
    if not np.all(np.abs(norm - 1.0) < 1e-6):
        raise ValueError(f"{name}: norms from {norm.min():.6g} to {norm.max():.6g}: expected unit vectors")
    return a


def _positive(name: str, v, n: int) -> np.ndarray:
    a = np.asarray(v, dtype=float).reshape(-1)
    if a.shape != (n,):
        raise ValueError(f"{name}: {a.size} values: expected {n}, one per sample")
    if not (np.isfinite(a).all() and (a > 0).all()):
        raise ValueError(f"{name}: values must be finite and > 0")
    return a


@dataclass(frozen=True)
class InversionCurve:
    """One light curve of one object with its per-sample geometry.

    ``brightness`` is the flux at the observer (W/m²) when ``calibrated``; otherwise it is
    relative: any positive scale, fitted per curve. ``sigma`` is its 1-σ in the same unit.
    ``sun_dir_I`` / ``observer_dir_I`` are unit vectors from the target to the Sun and to the
    observer in I at each sample time; ``sun_distance_m`` and ``range_m`` the distances.
    """

    t_s: np.ndarray  #: (N,) s since ``epoch`` (observation times, not light-time corrected)
    epoch: Time  #: scalar UTC epoch of ``t_s``
    brightness: np.ndarray  #: (N,) W/m² if calibrated, else relative
    sigma: np.ndarray  #: (N,) 1-σ of ``brightness``
    sun_dir_I: np.ndarray  #: (N, 3) unit, target -> Sun
    observer_dir_I: np.ndarray  #: (N, 3) unit, target -> observer
    sun_distance_m: np.ndarray  #: (N,)
    range_m: np.ndarray  #: (N,)
    calibrated: bool = False
    name: str = ""
    meta: dict = field(default_factory=dict)

    def __post_init__(self):
        t = np.asarray(self.t_s, dtype=float).reshape(-1)
        n = t.size
        if n < 3:
            raise ValueError(f"t_s: {n} samples: expected at least 3")
        if not np.isfinite(t).all():
            raise ValueError("t_s: non-finite times: expected finite seconds since the epoch")
        if np.any(np.diff(t) < 0):
            raise ValueError("t_s: times go backwards: expected non-decreasing seconds since the epoch")
        if not isinstance(self.epoch, Time) or not self.epoch.isscalar:
            raise ValueError(f"epoch: {self.epoch!r}: expected a scalar astropy Time")
        object.__setattr__(self, "t_s", t)
        object.__setattr__(self, "brightness", _positive("brightness", self.brightness, n))
        object.__setattr__(self, "sigma", _positive("sigma", self.sigma, n))
        object.__setattr__(self, "sun_dir_I", _vectors("sun_dir_I", self.sun_dir_I, n))
        object.__setattr__(self, "observer_dir_I", _vectors("observer_dir_I", self.observer_dir_I, n))
        object.__setattr__(self, "sun_distance_m", _positive("sun_distance_m", self.sun_distance_m, n))
        object.__setattr__(self, "range_m", _positive("range_m", self.range_m, n))

    def __len__(self) -> int:
        return self.t_s.size

    @property
    def phase_angle_rad(self) -> np.ndarray:
        """Sun–target–observer angle at each sample."""
        c = np.einsum("ij,ij->i", self.sun_dir_I, self.observer_dir_I)
        return np.arccos(np.clip(c, -1.0, 1.0))
