"""The chaser's own orbit and the target's relative motion about it: CoMBiNa's translational model in orbit (lcnav issue 31).

Eq. 9 of Maestrini et al. (the nonlinear equations of relative motion, :func:`estimators.dynamics.nerm_rhs`) is exact for
two point masses about a spherical Earth with the chaser on a circular orbit. In orbit neither holds: J2 moves the chaser's
orbit off the circle (its radius and its rate oscillate twice per orbit) and pulls the two bodies apart by its gradient
across their separation. Measured along the COMBINA scenario's perturbed truth (J2, drag, gravity gradient, damping) at
the closed loop's step (3.03 s), over 8 orbit phases: what eq. 9 leaves out of the relative velocity is 9.5e-8 / 1.2e-7 /
5.8e-8 m/s² RMS (radial / along-track / normal), a matched intensity (eq. 3 of :mod:`estimators.process_noise`) of
3.7e-12 m²/s³ that changes 2.3× with the orbit phase — so a run's NEES depends on where on its orbit it starts (per-run
NEES/dof 0.88–2.0 over 10 development runs, phases near 0° and 180° high); about the chaser's own orbit with two-body
gravity 2.2e-12; with J2 as well 3e-9 m/s² along-track (the differential drag, the only term left) and 9.9e-15 m²/s³.

A servicer knows its own orbit (GNSS, its own orbit determination): :class:`ChaserOrbit` holds samples of that solution
and the world's gravity (two-body, plus J2 in orbit). :meth:`ChaserOrbit.propagate_relative` carries relative states
``[r_L, v_L]`` over a step by integrating the chaser and the target in the inertial frame I (classical RK4 on the
chaser ``[R_C, V_C]`` once and every relative state ``[ρ, ρ̇]`` about it, the relative acceleration formed as ``g(R_C + ρ) − g(R_C)``, which loses nothing to
cancellation at metres: ``|g| ε ≈ 2e-15 m/s²``), from the chaser's own state at the step's start.

The relative state keeps eq. 9's convention, which is also how lcnav's truth writes it
(:func:`studies.sim.combina.simulate_lvlh_truth`): ``r_L = C_LI ρ_I`` in the LVLH axes of the chaser's actual state, and
``v_L = C_LI ρ̇_I − (n e_z) × r_L``, the relative velocity seen from a frame turning at the reference mean motion ``n``.
On the torque-free truth (a circular Keplerian chaser, two-body gravity) the propagation is eq. 9's to the integrator's
error; the paper's world keeps eq. 9 itself (:class:`estimators.combina.translation.TranslationalUKF` without an orbit).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from estimators.dynamics import MU_EARTH, R_EARTH, lvlh_dcm
from estimators.perturbations import J2_EARTH, j2_acceleration


def gravity_I(r_I: np.ndarray, mu: float = MU_EARTH, j2: bool = True) -> np.ndarray:
    """Gravitational acceleration (m/s²) at ``r_I`` (..., 3) m: ``−μ r/|r|³``, plus J2's
    (:func:`estimators.perturbations.j2_acceleration`, Vallado 2013 ch. 8) when ``j2``."""
    r = np.asarray(r_I, dtype=float)
    a = -mu * r / np.linalg.norm(r, axis=-1, keepdims=True) ** 3
    if j2:
        flat = r.reshape(-1, 3).T
        a = a + np.stack(j2_acceleration(flat, mu, J2_EARTH, R_EARTH), axis=-1).reshape(r.shape)
    return a


def _rhs(c: np.ndarray, rel: np.ndarray, mu: float, j2: bool) -> tuple[np.ndarray, np.ndarray]:
    """``d/dt`` of the chaser ``c = [R_C, V_C]`` (6,) and of the relative states ``rel = [ρ, ρ̇]`` (m, 6) about it, in I."""
    g_c = gravity_I(c[0:3], mu, j2)
    return np.concatenate([c[3:6], g_c]), np.concatenate([rel[:, 3:6], gravity_I(c[0:3] + rel[:, 0:3], mu, j2) - g_c], axis=1)


def _rk4(c: np.ndarray, rel: np.ndarray, dt_s: float, max_step_s: float, mu: float, j2: bool) -> tuple[np.ndarray, np.ndarray]:
    """Classical RK4 of :func:`_rhs` over ``dt_s`` in equal steps no longer than ``max_step_s``: the chaser once, every
    relative state about it."""
    n_sub = max(1, int(np.ceil(abs(dt_s) / max_step_s)))
    h = dt_s / n_sub
    for _ in range(n_sub):
        k1 = _rhs(c, rel, mu, j2)
        k2 = _rhs(c + 0.5 * h * k1[0], rel + 0.5 * h * k1[1], mu, j2)
        k3 = _rhs(c + 0.5 * h * k2[0], rel + 0.5 * h * k2[1], mu, j2)
        k4 = _rhs(c + h * k3[0], rel + h * k3[1], mu, j2)
        c = c + h / 6.0 * (k1[0] + 2.0 * k2[0] + 2.0 * k3[0] + k4[0])
        rel = rel + h / 6.0 * (k1[1] + 2.0 * k2[1] + 2.0 * k3[1] + k4[1])
    return c, rel


@dataclass(frozen=True)
class ChaserOrbit:
    """The chaser's own orbit as its navigation gives it, and the gravity it flies in (module docstring).

    ``t_s`` (N,) increasing sample times (s, the filter's clock); ``state_I`` (N, 6) ``[R_C (m), V_C (m/s)]`` in I at them;
    ``n_rad_s`` the reference mean motion of the ``v_L`` convention (eq. 9's ``n``); ``j2``: J2 in the gravity (in orbit)
    or two-body only; ``max_step_s`` the longest RK4 step.
    """

    t_s: np.ndarray
    state_I: np.ndarray
    n_rad_s: float
    j2: bool = True
    mu: float = MU_EARTH
    max_step_s: float = 10.0

    def __post_init__(self):
        t = np.asarray(self.t_s, dtype=float).reshape(-1)
        s = np.asarray(self.state_I, dtype=float)
        if t.size == 0 or not np.all(np.isfinite(t)) or np.any(np.diff(t) <= 0):
            raise ValueError(f"t_s: {t.size} times: expected at least one finite time, strictly increasing")
        if s.shape != (t.size, 6) or not np.all(np.isfinite(s)):
            raise ValueError(f"state_I: shape {s.shape}: expected ({t.size}, 6) finite [R_C (m), V_C (m/s)] rows, one per time")
        for name in ("n_rad_s", "mu", "max_step_s"):
            v = getattr(self, name)
            if not (np.isfinite(v) and v > 0):
                raise ValueError(f"{name}: {v!r}: expected a positive finite number")
        object.__setattr__(self, "t_s", t)
        object.__setattr__(self, "state_I", s)

    def state_at(self, t_s: float) -> np.ndarray:
        """``[R_C, V_C]`` (6,) in I at ``t_s``: the last sample at or before it, propagated with the orbit's gravity."""
        i = int(np.searchsorted(self.t_s, t_s, side="right")) - 1
        if not np.isfinite(t_s) or i < 0:
            raise ValueError(f"t_s: {t_s!r}: expected a finite time at or after the orbit's first sample {self.t_s[0]:g} s")
        dt = float(t_s - self.t_s[i])
        if dt == 0.0:
            return self.state_I[i].copy()
        return _rk4(self.state_I[i], np.zeros((0, 6)), dt, self.max_step_s, self.mu, self.j2)[0]

    def gravity_gradient(self, t_s: float) -> tuple[float, np.ndarray]:
        """``(3μ/|R|³ (rad²/s²), R̂ (3,))`` at ``t_s``: the gravity gradient's strength and radial direction in I at the chaser,
        which stand for the target's a few tens of metres away (direction 6e-6 rad, strength 2e-5 off at 40 m from 6900 km;
        :func:`estimators.combina.attitude.propagate_rigid_body`'s ``gravity_gradient``)."""
        R = self.state_at(t_s)[:3]
        r = float(np.linalg.norm(R))
        return 3.0 * self.mu / r**3, R / r

    def propagate_relative(self, x_L: np.ndarray, t_s: float, dt_s: float) -> np.ndarray:
        """Relative states ``x_L`` (m, 6) ``[r_L (m), v_L (m/s)]`` at ``t_s`` carried to ``t_s + dt_s`` (module docstring)."""
        x = np.atleast_2d(np.asarray(x_L, dtype=float))
        chaser = self.state_at(t_s)
        C_LI = lvlh_dcm(chaser[:3], chaser[3:])
        w_L = np.array([0.0, 0.0, self.n_rad_s])
        rho = x[:, :3] @ C_LI  # C_LIᵀ r_L, row-wise
        rho_dot = (x[:, 3:] + np.cross(w_L, x[:, :3])) @ C_LI
        c1, rel = _rk4(chaser, np.concatenate([rho, rho_dot], axis=1), dt_s, self.max_step_s, self.mu, self.j2)
        C1 = lvlh_dcm(c1[:3], c1[3:6])
        r1 = rel[:, :3] @ C1.T
        return np.concatenate([r1, rel[:, 3:] @ C1.T - np.cross(w_L, r1)], axis=1).reshape(np.shape(x_L))
