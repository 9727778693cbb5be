"""Kinematics of a principal-axis (uniform) rotation: :class:`SpinState` and the attitude it implies.

The body turns at the constant sidereal rate ``ω = 2π/P`` about the inertial direction ``pole_I`` (the
angular-momentum direction: the rotation is right-handed about it, so the pole carries the sense).
Its attitude is (the rotation model of Kaasalainen, Torppa & Muinonen, Icarus 153, 2001, in matrix form)

    C_IT(t) = C_IP · R_z(φ(t)) · C_AT,      φ(t) = φ₀ + ω (t − t₀ − ρ(t)/c)

* ``C_IP`` = [e₁, e₂, p] — the pole frame P: ``p`` the pole, ``e₁`` the unit projection of the
  equatorial north (I's z-axis) on the plane normal to ``p`` (I's x-axis when ``p`` is within 1e-9 of
  ±z), ``e₂ = p × e₁``. This is Kaasalainen's zero of φ up to the reference plane (equator instead of
  ecliptic): at φ = 0 the body reference axis lies in the plane of the pole and the north direction.
* ``R_z(φ)`` the active rotation by φ about z (right-handed, so body points move counter-clockwise
  seen from the pole).
* ``C_AT`` maps the body frame T onto the axis frame A = [a₁, a₂, a]: ``a = axis_T`` (the body spin
  axis), ``a₁`` the unit projection of the body x-axis on the plane normal to ``a`` (the body y-axis
  when ``a`` is along ±x), ``a₂ = a × a₁``. For ``axis_T = z`` this is the identity: the body x-axis
  is the reference axis of φ.
* ``ρ(t)/c`` the light time: the brightness seen at ``t`` left the target at ``t − ρ/c``.

Frames (DESIGN.md): I = GCRS axes (equatorial J2000), T = target body. A light curve measures the
*synodic* rate ``ω_syn = ω − Ω_bis`` where ``Ω_bis`` is the turning rate of the Sun–observer bisector
about the pole (:func:`lightcurves.geometry.bisector_rate`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from astropy.time import Time

from lightcurves.inversion.data import InversionCurve
from lightcurves.inversion.frames import pole_to_ecliptic, pole_to_radec

__all__ = ["SpinState", "C_LIGHT_M_S", "pole_frame", "axis_frame", "emission_time_s", "rotation_phase", "unspin", "C_TI", "body_directions"]

C_LIGHT_M_S = 299_792_458.0
"""Speed of light in vacuum, m/s (exact, SI)."""


def _unit(name: str, v) -> np.ndarray:
    a = np.asarray(v, dtype=float).reshape(-1)
    n = np.linalg.norm(a) if a.shape == (3,) else np.nan
    if not (np.isfinite(n) and n > 0):
        raise ValueError(f"{name}: {v!r}: expected a finite non-zero 3-vector")
    return a / n


def _reference_frame(axis, reference, fallback) -> np.ndarray:
    """Columns [r₁, axis × r₁, axis] with r₁ the unit projection of ``reference`` normal to ``axis`` (``fallback`` if parallel).

    ``axis`` may be (..., 3); the result is (..., 3, 3).
    """
    a = np.asarray(axis, dtype=float)
    r = np.asarray(reference, dtype=float) - (a @ reference)[..., None] * a
    norm = np.linalg.norm(r, axis=-1, keepdims=True)
    degenerate = norm[..., 0] < 1e-9
    if np.any(degenerate):
        r_f = np.asarray(fallback, dtype=float) - (a @ fallback)[..., None] * a
        r = np.where(degenerate[..., None], r_f, r)
        norm = np.linalg.norm(r, axis=-1, keepdims=True)
    r1 = r / norm
    return np.stack([r1, np.cross(a, r1), a], axis=-1)


def pole_frame(pole_I) -> np.ndarray:
    """``C_IP`` (..., 3, 3): columns e₁, e₂, p of the pole frame (module docstring) for unit poles (..., 3) in I."""
    return _reference_frame(pole_I, np.array([0.0, 0.0, 1.0]), np.array([1.0, 0.0, 0.0]))


def axis_frame(axis_T) -> np.ndarray:
    """``C_TA`` (3, 3): columns a₁, a₂, a of the axis frame (module docstring) for the unit body spin axis ``axis_T``."""
    return _reference_frame(axis_T, np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0]))


@dataclass(frozen=True)
class SpinState:
    """A principal-axis rotation (module docstring for the attitude it defines).

    pole_I : (3,) unit angular-momentum direction in I.
    period_s : sidereal period P, s (> 0).
    phase_rad : rotational phase φ₀ at ``epoch``, rad.
    epoch : astropy Time t₀ of ``phase_rad`` (light-time corrected: φ(t₀) = φ₀ for light that left then).
    axis_T : (3,) unit body spin axis in T (z for shapes fitted with the spin axis as body z).
    """

    pole_I: np.ndarray
    period_s: float
    phase_rad: float
    epoch: Time
    axis_T: np.ndarray = field(default_factory=lambda: np.array([0.0, 0.0, 1.0]))

    def __post_init__(self):
        object.__setattr__(self, "pole_I", _unit("pole_I", self.pole_I))
        object.__setattr__(self, "axis_T", _unit("axis_T", self.axis_T))
        if not (np.isfinite(self.period_s) and self.period_s > 0):
            raise ValueError(f"period_s: {self.period_s!r}: expected a finite period > 0 s")
        if not np.isfinite(self.phase_rad):
            raise ValueError(f"phase_rad: {self.phase_rad!r}: expected a finite angle in rad")
        if not isinstance(self.epoch, Time) or not self.epoch.isscalar:
            raise ValueError(f"epoch: {self.epoch!r}: expected a scalar astropy Time")
        object.__setattr__(self, "period_s", float(self.period_s))
        object.__setattr__(self, "phase_rad", float(self.phase_rad))

    @property
    def rate_rad_s(self) -> float:
        """Sidereal rotation rate ω = 2π/P, rad/s."""
        return 2.0 * np.pi / self.period_s

    @property
    def ecliptic_rad(self) -> tuple[float, float]:
        """Pole ecliptic longitude and latitude (λ, β), rad, J2000 mean ecliptic and equinox (:mod:`.frames`)."""
        lam, beta = pole_to_ecliptic(self.pole_I)
        return float(lam), float(beta)

    @property
    def radec_rad(self) -> tuple[float, float]:
        """Pole right ascension and declination (α, δ), rad, J2000 (GCRS) axes (:mod:`.frames`)."""
        ra, dec = pole_to_radec(self.pole_I)
        return float(ra), float(dec)


def emission_time_s(curve: InversionCurve, epoch: Time) -> np.ndarray:
    """(N,) s: when the light of each sample left the target, ``t − ρ/c``, counted from ``epoch``."""
    return (curve.epoch - epoch).to_value("s") + curve.t_s - curve.range_m / C_LIGHT_M_S


def rotation_phase(state: SpinState, curve: InversionCurve) -> np.ndarray:
    """φ(t) (N,) rad at each sample of ``curve``: φ₀ + ω (t − t₀ − ρ/c) (module docstring)."""
    return state.phase_rad + state.rate_rad_s * emission_time_s(curve, state.epoch)


def unspin(phi, v_P) -> np.ndarray:
    """R_z(φ)ᵀ v: vectors (..., N, 3) of the pole frame turned back by the angles φ (N,) (broadcast over leading axes)."""
    c, s = np.cos(phi), np.sin(phi)
    x, y = v_P[..., 0], v_P[..., 1]
    return np.stack([c * x + s * y, -s * x + c * y, v_P[..., 2]], axis=-1)


def C_TI(state: SpinState, curve: InversionCurve) -> np.ndarray:
    """DCM ``C_TI`` (N, 3, 3) mapping I to T at each sample of ``curve`` (the transpose of C_IT of the module docstring)."""
    phi = rotation_phase(state, curve)
    c, s = np.cos(phi), np.sin(phi)
    Rz = np.zeros((phi.size, 3, 3))
    Rz[:, 0, 0], Rz[:, 0, 1], Rz[:, 1, 0], Rz[:, 1, 1], Rz[:, 2, 2] = c, -s, s, c, 1.0
    C_IT = pole_frame(state.pole_I) @ Rz @ axis_frame(state.axis_T).T
    return np.transpose(C_IT, (0, 2, 1))


def body_directions(state: SpinState, curve: InversionCurve) -> tuple[np.ndarray, np.ndarray]:
    """Sun and observer unit directions in the body frame T, (N, 3) each, at the samples of ``curve``."""
    phi = rotation_phase(state, curve)
    C_IP, C_TA = pole_frame(state.pole_I), axis_frame(state.axis_T)
    sun_T = unspin(phi, curve.sun_dir_I @ C_IP) @ C_TA.T
    obs_T = unspin(phi, curve.observer_dir_I @ C_IP) @ C_TA.T
    return sun_T, obs_T
