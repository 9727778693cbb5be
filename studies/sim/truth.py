"""Truth simulation: servicer and target integrated independently.

By default (``torque-free``) each body follows a Keplerian orbit and torque-free
attitude dynamics (``estimators.dynamics.integrate_absolute``, DOP853 at 1e-12):
what the filters model. The ``perturbed`` truth adds physics they do not model
(:mod:`estimators.perturbations`: gravity-gradient torque and nutation damping on
the target, J2 and drag on both orbits). The relative state of eq. 17 of Renis
et al. is derived from the two absolute states at every sample, never integrated.
This is what the filters are scored against. Nothing here draws random numbers.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from estimators.attitude import dcm_to_quat
from estimators.dynamics import circular_orbit_state, inertia_from_k, integrate_absolute, lvlh_dcm, relative_state
from estimators.perturbations import TruthPhysics, get_truth_physics, integrate_perturbed
from estimators.state import R_I, V_I
from studies.sim.scenarios import Scenario

#: Column names of the relative state in tables (frame and unit in each name).
RELATIVE_COLUMNS = (
    [f"q_TS_{i}" for i in range(4)]
    + [f"w_ST_T_{a}_rad_s" for a in "xyz"]
    + [f"r_ST_T_{a}_m" for a in "xyz"]
    + [f"v_ST_T_{a}_m_s" for a in "xyz"]
    + ["k1", "k2"]
)
#: Column names of the servicer's absolute state (what its AODS gives the filters).
SERVICER_COLUMNS = (
    [f"r_S_I_{a}_m" for a in "xyz"]
    + [f"v_S_I_{a}_m_s" for a in "xyz"]
    + [f"q_IS_{i}" for i in range(4)]
    + [f"w_S_S_{a}_rad_s" for a in "xyz"]
)


@dataclass(frozen=True)
class Truth:
    """Sampled truth of one scenario."""

    scenario: Scenario
    t: np.ndarray  #: (N,) s since the scenario epoch
    target: np.ndarray  #: (N, 13) ``[r_T_I, v_T_I, q_IT, ω_T_T]``
    servicer: np.ndarray  #: (N, 13) ``[r_S_I, v_S_I, q_IS, ω_S_S]``
    x: np.ndarray  #: (N, 15) ``[q_TS, ω_ST_T, r_ST_T, v_ST_T, k1, k2]``
    J_T_diag: np.ndarray  #: (3,) target inertia, normalised (``B = 1``)
    J_S_diag: np.ndarray  #: (3,) servicer inertia, kg m²
    physics: TruthPhysics = get_truth_physics("torque-free")  #: the physics integrated

    def table(self) -> pd.DataFrame:
        """One row per sample: ``t_s``, the relative state, the servicer state."""
        cols = {"t_s": self.t}
        cols.update(dict(zip(RELATIVE_COLUMNS, self.x.T)))
        cols.update(dict(zip(SERVICER_COLUMNS, self.servicer.T)))
        return pd.DataFrame(cols)


def initial_states(scenario: Scenario) -> tuple[np.ndarray, np.ndarray]:
    """Absolute initial states ``(target, servicer)``, each ``[r_I, v_I, q_IB, ω_B]``.

    The servicer starts LVLH-aligned (its body axes on x radial, y along-track,
    z orbit normal), spinning at the orbit rate about z, which keeps it
    LVLH-pointing under torque-free motion. The target starts at the
    scenario's LVLH offset; its inertial velocity adds the rotating-frame
    term ``ω_LI × r``.
    """
    sc = scenario
    rv_S = circular_orbit_state(sc.orbit_radius_m, sc.inclination_rad, sc.raan_rad, sc.arg_latitude_rad)
    C_LI = lvlh_dcm(rv_S[R_I], rv_S[V_I])
    n = sc.mean_motion_rad_s
    r_L = np.asarray(sc.r_TS0_L_m, dtype=float)
    v_L = np.asarray(sc.v_TS0_L_m_s, dtype=float) + np.cross([0.0, 0.0, n], r_L)
    r_T = rv_S[R_I] + C_LI.T @ r_L
    v_T = rv_S[V_I] + C_LI.T @ v_L
    q_IS = dcm_to_quat(C_LI.T)
    servicer = np.concatenate([rv_S, q_IS, [0.0, 0.0, n]])
    target = np.concatenate([r_T, v_T, np.asarray(sc.q_IT0, dtype=float), np.asarray(sc.w_T0_T_rad_s, dtype=float)])
    return target, servicer


def _check_positive(name: str, value: float) -> float:
    v = float(value)
    if not np.isfinite(v) or v <= 0:
        raise ValueError(f"{name} must be a positive finite number of seconds, got {value!r}")
    return v


def simulate_truth(scenario: Scenario, duration_s: float, dt_s: float, physics: str | TruthPhysics = "torque-free") -> Truth:
    """Integrate servicer and target independently and derive the relative states.

    Samples at ``0, dt, 2 dt, …`` up to ``duration_s`` inclusive. ``physics``: a
    :class:`estimators.perturbations.TruthPhysics` or its name (``torque-free``,
    ``perturbed``); the torque-free truth is integrated exactly as before the
    perturbations existed (same calls, same numbers).
    """
    physics = get_truth_physics(physics)
    duration_s = _check_positive("duration", duration_s)
    dt_s = _check_positive("dt", dt_s)
    if dt_s > duration_s:
        raise ValueError(f"dt ({dt_s} s) must not exceed the duration ({duration_s} s)")
    n = int(np.floor(duration_s / dt_s + 1e-9))
    t = dt_s * np.arange(n + 1)
    target0, servicer0 = initial_states(scenario)
    J_T = inertia_from_k(*scenario.k)
    J_S = np.asarray(scenario.J_S_diag, dtype=float)
    if physics.torque_free:
        tg = integrate_absolute(target0, t, J_T)
        sv = integrate_absolute(servicer0, t, J_S)
    else:
        tg = integrate_perturbed(target0, t, J_T, physics.body_params("target", target0[R_I]))
        sv = integrate_perturbed(servicer0, t, J_S, physics.body_params("servicer", servicer0[R_I]))
    x = relative_state(tg.y, sv.y, scenario.k)
    return Truth(scenario=scenario, t=t, target=tg.y, servicer=sv.y, x=x, J_T_diag=J_T, J_S_diag=J_S, physics=physics)
