"""Disturbance budget: what the filters do not model, per term, along a scenario's perturbed truth.

The filters propagate the target's attitude torque-free and both orbits Keplerian (eq. 21 of
Renis et al.). Against a truth with the physics of :mod:`estimators.perturbations`, their
process noise has to cover

* the target's unmodelled angular acceleration ``ω̇`` (gravity gradient, nutation damping),
  rad/s², in the target frame T;
* the unmodelled differential translational acceleration of the servicer relative to the
  target, ``Δa = a_S − a_T`` (the sign of ``r_ST``; J2, drag, SRP), m/s², in the servicer's
  LVLH frame L and in T.

:func:`disturbance_budget` evaluates both along a simulated perturbed truth and reports, per
term and for their sum, the RMS per axis, the RMS of the norm and the largest norm. A white
acceleration noise of spectral density ``q`` matches an RMS acceleration ``a`` over a filter
step ``Δt`` when ``q ≈ a² Δt`` (the process noise of a random-walk rate).

Analytic orders (what the tests check the budget against): the gravity-gradient angular
acceleration about axis ``x`` is ``3 n² (C − B)/A · r̂_y r̂_z`` (``|r̂_y r̂_z| ≤ ½``, with
``n² = μ/r³``), and the differential J2 acceleration over a separation ``d`` is the J2
acceleration's gradient times ``d``, of order ``(3/2) J2 μ R_E²/r⁵ · d`` times a factor of a
few (``~3e-7 m/s²`` for the 50 m of SC1–SC4 at 500 km).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from estimators.attitude import quat_to_dcm
from estimators.dynamics import lvlh_dcm
from estimators.perturbations import ANGULAR_TERMS, TRANSLATIONAL_TERMS, TruthPhysics, get_truth_physics, perturbing_accelerations
from estimators.state import Q_IB, R_I, V_I
from studies.sim.scenarios import Scenario
from studies.sim.truth import simulate_truth

#: Step at which the budget samples the trajectory, s (the filters' step, Renis et al. §6).
BUDGET_DT_S = 1.0


@dataclass(frozen=True)
class TermStatistics:
    """One term's acceleration along the run: RMS per axis (3,), RMS of the norm, largest norm (same unit)."""

    rms_axis: np.ndarray
    rms: float
    max: float

    @classmethod
    def of(cls, a: np.ndarray) -> TermStatistics:
        norm = np.linalg.norm(a, axis=1)
        return cls(np.sqrt(np.mean(a * a, axis=0)), float(np.sqrt(np.mean(norm * norm))), float(np.max(norm)))


@dataclass(frozen=True)
class DisturbanceBudget:
    """Unmodelled accelerations of a scenario under a truth physics, per term and ``total`` (their sum).

    ``angular_T``: the target's ``ω̇`` (rad/s², frame T), terms :data:`estimators.perturbations.ANGULAR_TERMS`;
    ``translational_L`` / ``translational_T``: ``a_S − a_T`` (m/s², servicer LVLH / target frame), terms
    :data:`estimators.perturbations.TRANSLATIONAL_TERMS`. A term the physics switches off is all zeros.
    """

    scenario: str
    physics: TruthPhysics
    duration_s: float
    angular_T: dict[str, TermStatistics]
    translational_L: dict[str, TermStatistics]
    translational_T: dict[str, TermStatistics]

    def table(self) -> pd.DataFrame:
        """One row per (quantity, frame, term): ``rms_x``, ``rms_y``, ``rms_z``, ``rms``, ``max`` and the unit."""
        rows = []
        for quantity, frame, unit, stats in (("angular", "T", "rad/s2", self.angular_T), ("translational", "L", "m/s2", self.translational_L),
                                             ("translational", "T", "m/s2", self.translational_T)):
            for term, s in stats.items():
                rows.append({"quantity": quantity, "frame": frame, "term": term, "unit": unit, "rms_x": s.rms_axis[0], "rms_y": s.rms_axis[1],
                             "rms_z": s.rms_axis[2], "rms": s.rms, "max": s.max})
        return pd.DataFrame(rows)


def _with_total(per_term: dict[str, np.ndarray]) -> dict[str, TermStatistics]:
    out = {k: TermStatistics.of(a) for k, a in per_term.items()}
    out["total"] = TermStatistics.of(sum(per_term.values()))
    return out


def unmodelled_accelerations(scenario: Scenario, physics: TruthPhysics, duration_s: float) -> tuple:
    """``(truth, per-term ω̇ in T, per-term a_S − a_T in L, the same in T)`` along the truth, every :data:`BUDGET_DT_S`."""
    tr = simulate_truth(scenario, duration_s, BUDGET_DT_S, physics)
    acc_T = perturbing_accelerations(tr.target, tr.J_T_diag, physics.body_params("target", tr.target[0, R_I]))
    acc_S = perturbing_accelerations(tr.servicer, tr.J_S_diag, physics.body_params("servicer", tr.servicer[0, R_I]))
    C_LI = lvlh_dcm(tr.servicer[:, R_I], tr.servicer[:, V_I])
    C_TI = np.swapaxes(quat_to_dcm(tr.target[:, Q_IB]), 1, 2)
    diff_I = {k: acc_S[k] - acc_T[k] for k in TRANSLATIONAL_TERMS}
    return (tr, {k: acc_T[k] for k in ANGULAR_TERMS}, {k: np.einsum("nij,nj->ni", C_LI, a) for k, a in diff_I.items()},
            {k: np.einsum("nij,nj->ni", C_TI, a) for k, a in diff_I.items()})


def disturbance_budget(scenario: Scenario, physics: str | TruthPhysics = "perturbed", duration_s: float = 600.0) -> DisturbanceBudget:
    """The unmodelled accelerations along ``scenario``'s truth under ``physics``, sampled every :data:`BUDGET_DT_S`.

    The truth is the perturbed one itself (:func:`studies.sim.truth.simulate_truth`), so the accelerations are evaluated
    where the bodies really are; deterministic (nothing is drawn).
    """
    physics = get_truth_physics(physics)
    tr, angular_T, translational_L, translational_T = unmodelled_accelerations(scenario, physics, duration_s)
    return DisturbanceBudget(scenario=scenario.name, physics=physics, duration_s=float(tr.t[-1]), angular_T=_with_total(angular_T),
                             translational_L=_with_total(translational_L), translational_T=_with_total(translational_T))

