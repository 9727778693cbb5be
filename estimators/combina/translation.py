"""CoMBiNa's translational UKF (Maestrini et al. §IV.B, eqs 9–17 and 21–24).

State ``x_s = [r, v]`` of the target's centre of mass relative to the chaser,
in the chaser's LVLH frame ``L`` (x radial, y along-track, z orbit normal).
Process model: the nonlinear equations of relative motion (eq. 9,
:func:`estimators.dynamics.nerm_rhs`) about the chaser's circular orbit of
radius ``R_t`` (the paper's); in orbit, given the chaser's own orbit, the relative motion
about it with J2 (:class:`estimators.combina.own_orbit.ChaserOrbit`, beyond the paper: eq. 9 leaves
out of the perturbed truth a J2 signal whose size depends on the orbit phase); measurement:
the position ``r`` (eq. 14).

The public interface is SI (m, m/s, s, m², ...). With ``units=ScaledUnits(...)``
the filter runs internally in the paper's scaled units (§VI: time in
``TU = 1/n``, length in ``LU``); inputs and outputs stay SI, and the answers
agree with the SI filter to round-off (``tests/estimators/test_combina_translation.py``).

References
----------
.. [1] Maestrini, De Luca, Di Lizia, *Relative Navigation Strategy About Unknown and Uncooperative
   Targets*, Journal of Guidance, Control, and Dynamics, 2023.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from estimators.combina.own_orbit import ChaserOrbit
from estimators.combina.unscented import Innovation, UnscentedCore
from estimators.dynamics import MU_EARTH, nerm_rhs, rk4_step
from estimators.process_noise import MatchedBudget, white_noise_acceleration


@dataclass(frozen=True)
class ScaledUnits:
    """The scaled units of §VI of Maestrini et al.: ``TU`` seconds and ``LU`` metres."""

    TU_s: float
    LU_m: float

    def __post_init__(self):
        for name in ("TU_s", "LU_m"):
            v = getattr(self, name)
            if not (np.isfinite(v) and v > 0):
                raise ValueError(f"{name} must be positive and finite, got {v!r}")

    def state_scale(self) -> np.ndarray:
        """SI value of one internal unit of each state component ``[r (3), v (3)]``."""
        return np.array([self.LU_m] * 3 + [self.LU_m / self.TU_s] * 3)


SI_UNITS = ScaledUnits(TU_s=1.0, LU_m=1.0)
"""The identity scaling: the filter runs in SI."""


def translational_process_noise(dt_s: float, budget: MatchedBudget) -> np.ndarray:
    """``Q`` (6×6, SI) over ``[r_L, v_L]`` for one prediction of ``dt_s`` s from the disturbance budget.

    What the filter's model leaves out (in orbit, about the chaser's own orbit with J2: the differential drag; eq. 9 about
    a circular reference orbit leaves out J2 as well, on the chaser's orbit and across the separation) enters as the
    white-noise-acceleration model of :mod:`estimators.process_noise` (its eq. 1) with the budget's matched intensity
    ``q = budget.q_a_m2_s3`` per LVLH axis (its eq. 3: the white noise that gives the steady-state filter the velocity-error
    variance the unmodelled acceleration's spectrum gives it, :func:`studies.sim.matched_noise.combina_matched_budget`):
    ``Q_rr = q τ³/3``, ``Q_rv = q τ²/2``, ``Q_vv = q τ`` per axis, no coupling between axes.
    """
    if not (np.isfinite(dt_s) and dt_s > 0):
        raise ValueError(f"dt_s: {dt_s!r}: expected a positive, finite step in s")
    return np.kron(white_noise_acceleration(budget.q_a_m2_s3, dt_s), np.eye(3))


class TranslationalUKF:
    """UKF on ``[r_L, v_L]`` with NERM propagation (eq. 9) and position measurements (eq. 14).

    Parameters
    ----------
    x0_L : (6,) m, m/s
        initial estimate ``[r, v]`` of the target relative to the chaser, in LVLH.
    P0 : (6, 6) SI
        its covariance.
    n_rad_s : float
        the chaser's mean motion ``n``.
    R_t_m : float
        the chaser's orbit radius ``R_t``.
    units : ScaledUnits
        internal units (``SI_UNITS`` by default).
    max_step_s : float
        longest RK4 step of the propagation (steps are split to stay below it).
    Q : (6, 6) SI or callable, optional
        additive process noise per prediction, or ``Q(dt_s)`` (e.g. :func:`translational_process_noise`
        with a budget); the paper uses none.
    orbit : ChaserOrbit, optional
        the chaser's own orbit: the states are then propagated about it
        (:meth:`~estimators.combina.own_orbit.ChaserOrbit.propagate_relative`) instead of by eq. 9.
    t0_s : float
        the time of ``x0_L`` on the orbit's clock (s); each prediction advances it.
    """

    def __init__(self, x0_L, P0, *, n_rad_s: float, R_t_m: float, mu: float = MU_EARTH, units: ScaledUnits = SI_UNITS,
                 max_step_s: float = 10.0, Q=None, alpha: float = 1.0, beta: float = 2.0, kappa: float = 0.0,
                 orbit: ChaserOrbit | None = None, t0_s: float = 0.0):
        for name, v in (("n_rad_s", n_rad_s), ("R_t_m", R_t_m), ("max_step_s", max_step_s)):
            if not (np.isfinite(v) and v > 0):
                raise ValueError(f"{name} must be positive and finite, got {v!r}")
        self.units = units
        self._d = units.state_scale()
        D = np.outer(self._d, self._d)
        self._n = n_rad_s * units.TU_s
        self._R_t = R_t_m / units.LU_m
        self._mu = mu * units.TU_s**2 / units.LU_m**3
        self._max_step = max_step_s / units.TU_s
        self._Q = Q if Q is None or callable(Q) else np.asarray(Q, dtype=float)
        if not np.isfinite(t0_s):
            raise ValueError(f"t0_s must be finite, got {t0_s!r}")
        self.orbit = orbit
        self.t_s = float(t0_s)
        self.core = UnscentedCore(np.asarray(x0_L, dtype=float) / self._d, np.asarray(P0, dtype=float) / D, alpha=alpha, beta=beta, kappa=kappa)

    # ---- SI views of the internal state
    @property
    def x(self) -> np.ndarray:
        """``[r_L (m), v_L (m/s)]``."""
        return self.core.x * self._d

    @property
    def P(self) -> np.ndarray:
        """Covariance in SI."""
        return self.core.P * np.outer(self._d, self._d)

    def _propagate(self, X: np.ndarray, dt: float) -> np.ndarray:
        if self.orbit is not None:
            return self.orbit.propagate_relative(X * self._d, self.t_s, dt * self.units.TU_s) / self._d
        n_sub = max(1, int(np.ceil(abs(dt) / self._max_step)))
        h = dt / n_sub
        for _ in range(n_sub):
            X = rk4_step(nerm_rhs, 0.0, X, h, self._n, self._R_t, self._mu)  # eq. 9
        return X

    def predict(self, dt_s: float) -> None:
        """Eqs 10–13 over ``dt_s`` seconds."""
        if not (np.isfinite(dt_s) and dt_s > 0):
            raise ValueError(f"dt_s must be positive and finite, got {dt_s!r}")
        dt = dt_s / self.units.TU_s
        Q = self._Q(dt_s) if callable(self._Q) else self._Q
        self.core.predict(lambda X: self._propagate(X, dt), Q=None if Q is None else Q / np.outer(self._d, self._d))
        self.t_s += dt_s

    def innovation(self, r_meas_L, R_m2) -> Innovation:
        """Eqs 14–17, 23 for a measured position ``r_meas_L`` (m) with covariance ``R_m2`` (m²).

        The returned innovation is in SI.
        """
        L = self.units.LU_m
        inn = self.core.innovation(np.asarray(r_meas_L, dtype=float) / L, np.asarray(R_m2, dtype=float) / L**2, lambda X: X[:, :3])  # eq. 14
        return Innovation(z=inn.z * L, z_pred=inn.z_pred * L, y=inn.y * L, S=inn.S * L**2, P_xz=inn.P_xz * np.outer(self._d, np.full(3, L)))

    def correct(self, inn: Innovation) -> None:
        """Eqs 21, 22, 24 with an (SI) innovation from :meth:`innovation`."""
        L = self.units.LU_m
        self.core.correct(Innovation(z=inn.z / L, z_pred=inn.z_pred / L, y=inn.y / L, S=inn.S / L**2, P_xz=inn.P_xz / np.outer(self._d, np.full(3, L))))
