"""Named filter tunings: ``Q_d``, ``R_d`` and ``P_0`` (Renis et al. §4.1, §6.1).

A tuning is chosen by name (``--tuning NAME``), or from a spin prior by
:func:`estimators.prior.tuning_for_prior` (study 1 of Renis et al.: with a
prior, the scenario-specific ``Q_d``). ``Q_d`` is stored as a rate per second
of sampling time, ``Q_d = diag(q_rate) τ_s``, so one tuning serves every
``τ_s``; all blocks are over the 14 error states
``[δp (rad), δω (rad/s), δr (m), δv (m/s), δk1, δk2]``.

``R_d`` is not part of a tuning: it is the pose estimator's noise, and the
filters take it from the same :class:`~estimators.measurement.PoseNoise` the
simulated measurements are drawn from. ``P_0`` (:data:`P0_DEFAULT`) is sized to the paper's
initial guess (``x̂_0 = 0`` but for ``k``): 1 rad on the attitude, 0.1 rad/s on
``ω`` (Table 1 rates reach 0.2 rad/s), 1 m and 2 m/s on ``r`` and ``v`` (the
first measurements take over), 0.3 on ``k`` (the ±30 % of §6). The paper's
``P_0 = I₁₄`` puts 1 rad/s on ``ω`` and 1 on ``k``: the UKF's sigma points
(±3.7 σ with 14 states) then spin at 3.7 rad/s with inertia ratios of
``e^3.7 ≈ 40`` and their propagation overflows.

The names say what a tuning is: ``fixed-lag`` (the default of ``lcnav run`` since 2026-11-27,
:data:`DEFAULT_TUNING`) is real time with process noise matched to the perturbed truth; ``relinearized``
(the default before it) is consistent from the default ``P_0`` on the torque-free truth at a cost that
grows with the arc; ``*-conservative``
ones over-state their errors on purpose; ``*-paper`` ones are the paper's, as
its studies use them, whatever their consistency from the default ``P_0``
(:data:`RENAMED` maps the names before 2026-11-26 to these). The ``Q_d`` values
of ``general-conservative`` and ``sc1-paper``–``sc4-paper`` are hand-set
starting points on the order-of-magnitude grid of Algorithm 1 (faster spin →
larger rate and velocity noise); the tuning search of the studies issue
replaces them. Measured from the default ``P_0`` (30 runs, 300 s, after 60 s;
``python -m benchmarks consistency``): ``general-conservative`` (KF_gen of the
tuning study, the no-prior arm of the demo and the chain study) has a mean
NEES/dof of 0.46 on SC1 and 0.61–0.77 on SC3, below its 95 % band on every
step: the truth has no process noise, so any ``Q_d`` inflates ``P``.
Of ``sc1-paper``–``sc4-paper`` (``lcnav study init|proxy``), ``sc1-paper`` on
SC1 is conservative (0.46 and 0.45), ``sc3-paper`` on SC3 over-confident: mean
NEES/dof 4.7 (EKF) and 3.5 (UKF), worst runs 60 and 88, attitude gate
rejections 3.6 % (its small ``Q_d`` on ``k`` cannot undo the early updates from
the default ``P_0``); ``sc2-paper`` and ``sc4-paper`` are not measured.
``sc1-conservative``–``sc4-conservative`` add ``settled``'s settling phase
(:data:`SETTLING`) and are what a spin prior selects
(:func:`estimators.prior.tuning_for_prior`) in the demo and the chain study:
0.52 and 0.52 (worst 1.0 and 0.96), rejections 0.9 %, NIS in band 93–97 %. The price: ``k`` is considered
for the first 60 s, so a prior no longer lets ``k`` converge before then
(the init study's Table 5 effect needs the paper's ``sc3-paper``).

``consistent`` is ``Q_d = 0``: the truth is torque-free and Keplerian and
the filters' model matches it to 1e-7 m per step
(``tests/estimators/test_process_model.py``), so with errors of the size of
a converged filter both filters' NEES matches that of an exact linear Kalman
filter fed the same noise (``tests/estimators/test_consistency.py``). From
the default ``P_0`` (0.1 rad/s on the rate, 2 m/s, 0.3 on ``k``) it diverges:
the first-order propagation misses terms like ``2 δω × δv`` (~1 m/s² at those
errors), the early updates become over-confident, and with ``Q_d = 0`` no
later measurement can undo it (SC1 EKF mean NEES/dof 420, SC3 ~1e13).

``relinearized``: ``Q_d = 0`` after a 10 s settling phase (the ``settled``
one's ``Q_d``, ``k`` considered), and every 10 s from then on the filter is
reset to the posterior of every measurement so far
(:mod:`estimators.batch`, ``relinearize_s``); while the latest fit fails its
χ² test the settling phase comes back. Measured with ``python -m benchmarks
consistency`` (30 runs, 300 s, seeds 1000–1029, after 60 s) and on the
independent seeds 2000–2029: NEES in its 95 % band on 95–100 % of the steps
for the EKF on SC1 and SC3 and for the UKF on SC3, mean NEES/dof 0.96–1.05;
the UKF on SC1 was conservative (0.89–0.91, 70–83 % in band: its sigma points
lay 3.7 σ out along the considered ``k``) until it took considered directions
linearly (:mod:`estimators.ukf`): 100 % and 99 % in band, 0.966 and 0.955
(seeds 1000–1029, 2000–2029).
NIS in band 97 %, gate rejections 1.0 %. SC3: 100 % in band (1.04) for both
filters. On a spin *near* the intermediate axis
(``SC1-NEAR-AXIS``: 1e-4 rad/s off it, ``k`` estimated; data nobody tuned on):
77–78 % in band, mean NEES/dof 1.05–1.06, worst run 1.7 (was 5 %, 7e12 before
the fit's profile test, 2-D quadrature and restarts, :mod:`estimators.batch`);
the steps out of band lie above it.

``settled`` has a *settling phase* of 60 s (``settling_q_rate``,
``settling_s``): during it the filters add ``Q_d`` on attitude, rate,
velocity and ``k``, consider ``k`` instead of estimating it (with rate errors
of the size of the spin, Euler's equations attribute them to ``k``, which ran
off by up to 3.9 on SC3), and the EKF adds the covariance of its own
linearisation error (:mod:`estimators.ekf`). After it, a small process noise
on the rate (1.5e-7 (rad/s)²/s) and on ``k`` (3e-7 /s) stays. The truth has
none: it stands for what a Gaussian filter started from the default ``P_0``
keeps wrong after the transient. Measured on SC3 (issue 12): ``k1 + k2 =
ln(A/C)`` drives ``ω̇_y = (C − A)/B ω_x ω_z`` with a sensitivity of ~8.5 per
unit of ``k`` against ``(C − A)/B = −0.11``, so it is learnt within seconds,
while ``k1 − k2`` only scales that small coefficient (``e^δ``): the posterior
is curved along it, both filters' ``k`` ran off along ``(1, −1)`` by up to
0.9 with a 1-σ of 0.09, and with ``Q_d = 0`` afterwards nothing undoes it
(mean NEES/dof 87 UKF, 472 EKF). Considering ``k`` for the whole run is
worse (its ~1e-3 rad/s² of ``ω̇_y`` error is not linear in the rate error).
The two rates come from a grid (rate 1e-8–1e-6, ``k`` 1e-7–1e-5; 30 runs
on seeds 1000–1029) as the pair that removed the UKF's divergent runs on SC3
without making SC1 conservative; they favour the UKF. A rate noise of 5e-8 or
less brings the divergent runs back (EKF SC3, worst run NEES/dof 24 at 5e-8).

The settling phase is followed by a *release phase* of 90 s (``release_s``):
``k`` is estimated, but the combination of ``k1, k2`` that moves the rate
least (:func:`estimators.navigation.weak_inertia_direction`, ``k1 − k2`` on
SC3) stays considered. Why: that combination acts on the rate only through
``ω_y ≈ 0``, which at the end of the settling phase is known to ~0.004 rad/s,
so the first updates "learnt" ``k1 − k2`` from a gradient of the wrong size
and sign. Seen on SC3 even from a 0.08 error: ``k`` walked 0.4 along
``(1, −1)`` in 20 s while its 1-σ there shrank to 0.2, and stayed several σ off
(NEES of ``k`` alone 5–11 to 900 s). Considering it for the whole run is
consistent but never learns it (final ``k`` error 0.26 against 0.13 without
and 0.11 with 90 s). Measured with ``python -m benchmarks consistency`` (seeds
1000–1029, 300 s, after 60 s), mean NEES/dof and fraction of steps in the 95 %
band, without → with the release phase: SC3 EKF 1.27 (15 %, worst run 4.9) →
1.03 (66 %, worst 3.2), SC3 UKF 1.04 (86 %, worst 2.6) → 0.95 (79 %, worst
1.5); on the independent seeds 2000–2029: EKF 1.57 (0 %, worst 13) → 1.19
(25 %, worst 7.7), UKF 0.91 (64 %) → 0.96 (81 %, worst 3.4). SC1 (``k``
considered throughout) is unchanged: UKF 0.94 (73 %), EKF 0.81 (34 %,
conservative: rate block ~0.22 per dof, the rate noise). NIS 95–98 % in
band, gate rejections 0.7–1.0 %. Issue 12's criterion (≥ 90 % of the steps
in band) is met by none of these, and ``settled`` is neither consistent nor
conservative throughout (kept as the measured baseline of the settling phase);
``relinearized`` meets it for both filters on SC1 and SC3.

``budgeted`` (issue 31): ``settled``'s settling and release phases, then the ``Q_d`` of
:mod:`estimators.process_noise` from :data:`PERTURBED_BUDGET` — the unmodelled accelerations of
the perturbed truth, with the attitude/rate and position/velocity cross terms — and no batch
fits: real time, the EKF and the UKF their own recursions. Measured 2026-11-27 (30 runs of 300 s at
1 s, seeds 1000–1029, after 60 s, ``consistency_check``; perturbed / torque-free truth): CPU 0.30–0.48 ms
per step (EKF) and 0.98–1.15 ms (UKF), flat in time (``benchmarks/bench_realtime.py``). Mean NEES/dof
and steps in band: SC3 EKF 25.7 / 25.3 (0 % / 0 %, worst runs 718 / 707), SC3 UKF 2.40 / 2.37 (0 % /
0 %, worst 16.8), SC1 EKF 1.13 / 0.98 (60 % / 41 %), SC1 UKF 0.95 / 0.82 (78 % / 25 %, 75 % of the steps
below the band); NIS in band 77–98 %, gate rejections 0.8–2.4 %. The two truths give nearly the same
figures: what the filters keep wrong from the transient out of the default ``P_0`` (SC3: ``k`` and the
rate, see ``settled`` above) outweighs what the physics adds over 300 s, and an honest ``Q_d`` alone
does not cover it (``fixed-lag`` below is the re-linearisation that bounds the cost), so it is not the default.

``fixed-lag`` (issue 31; the default): ``relinearized``'s 10-s settling phase and fits every 10 s, but from ``t ≥ lag``
(:data:`LAG_S`, 60 s) each fit takes only the measurements of a moving window whose prior is the filter's own output at the
window's start (an *anchor*: a fit result with a Gaussian posterior that kept its data; why the information sets are
disjoint, and why the anchor test, in :class:`estimators.navigation._Relinearization`), and the process noise of
:data:`MATCHED_BUDGET` enters both the window (each residual's ``R_j`` inflated by the noise accumulated since the window's
start, the last state's moments by the window's Kalman recursion with ``Q``: :mod:`estimators.batch`, *Process noise*;
exact on a linear model, ``tests/estimators/test_fixed_lag.py``) and the recursion between fits. The EKF and the UKF keep
their own anchors, gates and recursions.

In orbit the model includes the target's gravity-gradient torque (``gravity_gradient``, since 2026-11-29;
:func:`estimators.dynamics.joint_rhs`): known physics given the inertia ratios the filter estimates and the servicer's AODS.
Left out, it was what made the filter over-confident over an orbit (SC3 perturbed, 10 dispersed runs: NEES/dof 2.99, the
attitude block alone up to 10 per 500 s): the torque's part fixed in inertial space precesses the angular momentum, which in
the tumbling target frame is a forcing at the spin frequency — where the body-frame spectrum the budget was matched to says
there is nothing to follow — and a secular attitude drift of ~5–10 mrad against a σ of 2.7. Modelled, the same runs' attitude
block is 0.8–1.2. ``fixed-lag-torque-free`` is the same machinery for the paper's torque-free world: no gravity gradient (there
is none there) and ``Q_d = 0`` after the settling phase (nothing is left out): :data:`DEFAULT_TUNINGS` picks by the world, so
the filter is told which forces exist, never their hidden parameters (inertia, damping time, area-to-mass). A filter with a
``Q`` matched to a disturbance is conservative on a truth without it (NEES/dof → ½ in steady state, eq. 4 of
:mod:`estimators.process_noise`), so one tuning cannot be in band in both worlds.

``MATCHED_BUDGET`` (:mod:`studies.sim.matched_noise`): the rate's intensity is the one for which the filters' own model,
run from the true state over the filter's memory ``H``, has rate prediction errors of unit NEES against the covariance that
intensity accumulates through the same Jacobians, with ``H = (r/q)^{1/4}`` the memory of the steady-state filter that
measures the attitude (solved together: 250 s on SC3, 260 s on SC1); the differential acceleration's and the damping's
spectra are matched to the steady-state filter (eq. 3 of :mod:`estimators.process_noise`). The rate's comes out at
0.063 (SC3) and 0.054 (SC1) of the ``σ, T_c`` budget's white-noise equivalent ``2 σ² T_c``: the torque turns with the
target, and what a filter with a memory of minutes cannot average out is little of it. Before it (2026-11-27, same
window): the σ budget itself made SC3 conservative (NEES/dof 0.69 perturbed), a tenth of it 0.962 (10 runs), none 19.4.
Re-derived 2026-11-29 with the gravity gradient in the model: the rate's 8.05e-13 (the damping's alone, at 279 s); the
translational one in the orbit frame, where the drag is a steady along-track push: eq. 5 of :mod:`estimators.process_noise`
over ``1/n`` (3.85e-11, against eq. 3's 1.70e-11, with which the push went into a pitch bias of the target frame common to
every run); none on ``k`` (the inertia is constant; the damping's random walk on ``k`` counted it twice and made the rate
and ``k`` blocks conservative, 0.5 and 0.3–0.5). The figures below the next paragraph are from before this change.

Measured 2026-11-27 (``consistency_check``, 30 runs of 600 s at 1 s, seeds 1000–1029, after 60 s; ``python -m benchmarks
truths`` regenerates it, with one-orbit runs): mean NEES/dof [95 % t interval], steps in the 95 % band (below, above), worst run:

  ========  ===========  ======  =====================  ==================  =====
  scenario  truth        filter  NEES/dof               in band             worst
  ========  ===========  ======  =====================  ==================  =====
  SC3       perturbed    EKF     0.974 [0.910, 1.038]   66 % (23 %, 11 %)   1.36
  SC3       perturbed    UKF     0.971 [0.907, 1.035]   66 % (24 %, 10 %)   1.36
  SC1       perturbed    EKF     1.32 [0.99, 1.66]      24 % (30 %, 46 %)   4.31
  SC1       perturbed    UKF     1.56 [1.18, 1.95]      32 % (9 %, 59 %)    4.56
  SC3       torque-free  EKF     0.695 [0.626, 0.764]   2 % (98 %, 0 %)     1.11
  SC1       torque-free  EKF     0.710 [0.635, 0.784]   23 % (77 %, 0 %)    1.39
  ========  ===========  ======  =====================  ==================  =====

(torque-free UKF: 0.695 and 0.706). NIS in band 93–97 %, gate rejections 0.92–1.10 % (nominal 1 %), no run diverged. On
SC3 the mean is unbiased and the steps out of band are a slow wander of the 30-run mean with the tumble (50-s block means
0.91–1.14 on 10 runs), not a saw-tooth of the 10-s fits (phase means 1.006–1.018). On the torque-free truth the filters are
conservative, as any ``Q`` matched to physics that truth lacks must make them. SC1 is over-confident: the perturbed SC1 truth
does not stay a one-axis spin — it spins about its intermediate axis (z: 4.22 between 1 and 4.33), the gravity gradient
starts the unstable mode, and ω_x reaches 0.018 rad/s at 600 s and flips the spin by 1200 s — while the filter considers
``k`` (the scenario is a one-axis tumble), whose ±30 % error then drives rate errors no linear consider term covers.
Issue 31's criterion (≥ 90 % of the steps in band on the perturbed truth) is not met: SC3's wander needs a ``Q`` that
follows the tumble, SC1 an estimated ``k`` once the spin leaves its axis.

Accuracy (EKF, 10 runs of 300 s, seeds 1000–1009, RMSE from 150 s on): on the perturbed truth against ``relinearized``
on the torque-free one, SC3 attitude 0.0108 vs 0.0106 rad (1.02×), rate 1.34e-4 vs 8.73e-5 rad/s (1.54×), position 0.082 vs
0.069 m (1.19×), velocity 5.09e-3 vs 3.03e-3 m/s (1.68×), ``k`` 0.0096 vs 0.0098 (0.98×); SC1 1.01×, 1.39×, 1.21×, 1.44×
(``k`` considered) — within issue 31's 2× (the σ budget's ``Q`` gave SC3's velocity 2.09×).

Cost (``benchmarks/bench_realtime.py``, SC3, two orbits, 11 400 s, CPU per step, measured with the σ budget's ``Q``, the same
window and fits): median 0.18 ms (EKF) and 0.51 ms (UKF); the last 100-step block 0.98× the block at 300 s for both (flat;
the amortised cost is one 60-s fit every 10 s). ``relinearized``: 51 ms at 300 s, 160 ms at 800 s. filterpy's EKF/UKF
medians on the same model 0.064 / 1.03 ms. The lag (SC3 perturbed, 10 runs of 600 s, σ budget): 60 s 0.733, 120 s 0.729 at
1.8× the CPU, so 60 s.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from estimators.process_noise import DisturbanceBudget, MatchedBudget
from estimators.state import N_ERROR


def _q(att, w, r, v, k) -> np.ndarray:
    return np.array([att] * 3 + [w] * 3 + [r] * 3 + [v] * 3 + [k] * 2, dtype=float)


@dataclass(frozen=True)
class Tuning:
    """``Q_d`` rate (14,) per s of ``τ_s`` and ``P_0`` diagonal (14,)."""

    name: str
    q_rate: np.ndarray
    p0_diag: np.ndarray
    description: str = ""
    #: settling phase: ``Q_d`` rate added for ``t < settling_s`` (14,), zeros when there is none
    settling_q_rate: np.ndarray | None = None
    settling_s: float = 0.0
    #: release phase after the settling phase (s): the weakly observable combination of ``k1, k2`` stays considered
    release_s: float = 0.0
    #: period (s) of the re-linearisation about the full-information fit (:mod:`estimators.batch`) from the end of the
    #: settling phase on; 0: never
    relinearize_s: float = 0.0
    #: unmodelled accelerations whose ``Q_d`` (:mod:`estimators.process_noise`, with cross terms) is added to ``q_rate``'s; None: none
    budget: DisturbanceBudget | MatchedBudget | None = None
    #: length (s) of the re-linearisation's moving window (fixed lag); 0: every fit takes all the measurements since ``t[0]``.
    #: A multiple of ``relinearize_s`` (:class:`estimators.navigation._Relinearization`)
    lag_s: float = 0.0
    #: the filters' process model includes the target's gravity-gradient torque (:class:`estimators.process_model.RelativeProcessModel`):
    #: known physics for a target in orbit, given the inertia ratios the filter estimates; False, the paper's torque-free target
    gravity_gradient: bool = False

    def __post_init__(self):
        if self.settling_q_rate is None:
            object.__setattr__(self, "settling_q_rate", np.zeros(N_ERROR))
        for field in ("settling_s", "release_s", "relinearize_s", "lag_s"):
            if not (np.isfinite(getattr(self, field)) and getattr(self, field) >= 0):
                raise ValueError(f"tuning {self.name!r}: {field} must be a finite number of seconds >= 0")
        for field in ("q_rate", "p0_diag", "settling_q_rate"):
            a = np.asarray(getattr(self, field), dtype=float)
            if a.shape != (N_ERROR,) or not np.all(np.isfinite(a)) or np.any(a < 0):
                raise ValueError(f"tuning {self.name!r}: {field} must be {N_ERROR} finite non-negative numbers")
            object.__setattr__(self, field, a)
        if np.any(self.p0_diag <= 0):
            raise ValueError(f"tuning {self.name!r}: P_0 must be positive definite")
        if self.lag_s > 0 and not (self.relinearize_s > 0 and abs(self.lag_s / self.relinearize_s - round(self.lag_s / self.relinearize_s)) < 1e-9):
            raise ValueError(f"tuning {self.name!r}: lag_s: {self.lag_s!r}: expected a positive multiple of relinearize_s ({self.relinearize_s!r} s)")

    def Q_d(self, tau_s: float, *, settling: bool = False) -> np.ndarray:
        """Discrete process-noise covariance for a step of ``tau_s`` seconds (14×14), in or after the settling phase."""
        Q = np.diag((self.q_rate + (self.settling_q_rate if settling else 0.0)) * float(tau_s))
        return Q if self.budget is None else Q + self.budget.Q_d(tau_s)

    @property
    def P_0(self) -> np.ndarray:
        return np.diag(self.p0_diag)


#: Default ``P_0`` diagonal: ``[δp (rad²), δω ((rad/s)²), δr (m²), δv ((m/s)²), δk]``.
P0_DEFAULT = _q(1.0, 1e-2, 1.0, 4.0, 0.09)

#: The settling phase (see the module docstring): 60 s with ``Q_d`` on attitude, rate, velocity and ``k``, ``k`` considered.
SETTLING = {"settling_q_rate": _q(1e-6, 1e-9, 0.0, 1e-6, 1e-9), "settling_s": 60.0, "release_s": 90.0}

TUNINGS: dict[str, Tuning] = {
    t.name: t
    for t in (
        Tuning("consistent", _q(0.0, 0.0, 0.0, 0.0, 0.0), P0_DEFAULT, description="Q_d = 0: the truth is noise-free (consistency tests)"),
        Tuning("settled", _q(0.0, 1.5e-7, 0.0, 0.0, 3e-7), P0_DEFAULT,
               description="the default before relinearized: settling phase, then process noise on the rate and k (in band 34-75 %)", **SETTLING),
        Tuning("relinearized", _q(0.0, 0.0, 0.0, 0.0, 0.0), P0_DEFAULT,
               description="Q_d = 0 after a 10 s settling phase, re-linearised about the full-information fit every 10 s (consistent)",
               settling_q_rate=SETTLING["settling_q_rate"], settling_s=10.0, relinearize_s=10.0),
        Tuning("general-conservative", _q(1e-4, 1e-5, 1e-3, 1e-3, 1e-5), P0_DEFAULT, description="KF_gen: conservative, for the fast 2-axis tumble (SC4)"),
        Tuning("sc1-paper", _q(1e-5, 1e-7, 1e-4, 1e-4, 0.0), P0_DEFAULT, description="KF_sc1 of Renis et al., 1-axis slow tumble (conservative on SC1)"),
        Tuning("sc2-paper", _q(1e-4, 1e-6, 1e-4, 1e-4, 0.0), P0_DEFAULT, description="KF_sc2 of Renis et al., 1-axis fast tumble (consistency not measured)"),
        Tuning("sc3-paper", _q(1e-5, 1e-6, 1e-4, 1e-4, 1e-6), P0_DEFAULT,
               description="KF_sc3 of Renis et al., 2-axis slow tumble (over-confident on SC3 from the default P_0)"),
        Tuning("sc4-paper", _q(1e-4, 1e-5, 1e-3, 1e-3, 1e-5), P0_DEFAULT, description="KF_sc4 of Renis et al., 2-axis fast tumble (consistency not measured)"),
    )
}
#: The unmodelled accelerations of the perturbed truth (studies.sim.disturbance.disturbance_budget over one orbit, 5700 s, SC1–SC4,
#: measured 2026-11-27): the target's angular acceleration 1.10–1.15e-6 rad/s² RMS of the norm (gravity gradient 1.1e-6, nutation
#: damping 0.85–3.5e-7), the differential translational one 3.23e-7 m/s² (J2 2.2e-7, drag 2.3e-7; over the first 600 s 3.85e-7); per
#: axis the largest RMS / √3 (6.8e-7 rad/s² on SC4's first 600 s, 2.23e-7 m/s²), rounded up.
#: Correlation time 1/|ω| of the slowest tumble (SC1, 0.05 rad/s): the torque and the LVLH-fixed accelerations turn with the
#: target frame. Inertia-ratio drift: the dissipation's RMS over |ω|² (estimators.process_noise.kdot_from_dissipation), largest on
#: SC3 (one orbit 9.7e-8 / 0.0492² = 4.0e-5 /s, the first 600 s 1.0e-7: 4.1e-5 /s; rounded up to 4.5e-5).
#: ``tests/estimators/test_process_noise.py`` checks the numbers against the budget.
PERTURBED_BUDGET = DisturbanceBudget(sigma_alpha_rad_s2=7.0e-7, sigma_a_m_s2=2.3e-7, sigma_kdot_1_s=4.5e-5, correlation_time_s=20.0,
                                     source="disturbance_budget of the perturbed truth, SC1-SC4, one orbit")
TUNINGS["budgeted"] = Tuning("budgeted", _q(0.0, 0.0, 0.0, 0.0, 0.0), P0_DEFAULT, budget=PERTURBED_BUDGET,
                             description="Q_d from the perturbed truth's disturbance budget (estimators.process_noise) after the settling phase; "
                             "real-time, no batch fits", **SETTLING)
#: The intensities matched to what the filters' model gets wrong on the perturbed truth once it models the target's
#: gravity-gradient torque (studies.sim.matched_noise.matched_budget of SC1 and SC3, two orbits, the default pose noise every
#: 1 s, gravity_gradient=True; measured 2026-11-29): the rate's at the filter's memory, 8.05e-13 rad²/s³ (SC3, 279 s; SC1
#: 7.39e-13 at 286 s) — the nutation damping's, 0.65 of the 1.24e-12 the gravity gradient left unmodelled asked for; the
#: differential acceleration's in the orbit frame, its steady drag push over 1/n (eq. 5 of estimators.process_noise, 3.85e-11
#: m²/s³, above eq. 3's 1.70e-11); none on k (the inertia is constant, the damping is in the rate's). The fast tumbles are
#: not matched (SC2, SC4). ``tests/studies/test_matched_noise.py`` re-measures it.
MATCHED_BUDGET = MatchedBudget(q_alpha_rad2_s3=8.047e-13, q_a_m2_s3=3.849e-11, q_kdot_1_s=0.0,
                               source="matched_budget of the perturbed truth with the gravity-gradient torque modelled, SC1 and SC3, two "
                               "orbits, default pose noise at 1 s")
#: The fixed-lag window's length (s): see the module docstring, ``fixed-lag``.
LAG_S = 60.0
TUNINGS["fixed-lag"] = dataclasses.replace(
    TUNINGS["relinearized"], name="fixed-lag", budget=MATCHED_BUDGET, lag_s=LAG_S, gravity_gradient=True,
    description=f"in orbit: the target's gravity-gradient torque modelled, re-linearised every 10 s about the fit of a {LAG_S:g}-s "
    "window from the filter's own estimate, process noise matched to what the model leaves out (bounded cost)")
TUNINGS["fixed-lag-torque-free"] = dataclasses.replace(
    TUNINGS["relinearized"], name="fixed-lag-torque-free", lag_s=LAG_S,
    description=f"the torque-free world (the paper's): re-linearised every 10 s about the fit of a {LAG_S:g}-s window, Q_d = 0 "
    "after the settling phase (bounded cost)")

#: The scenario tunings with the settling phase: what a spin prior selects in ``lcnav run``, the demo and the chain study.
TUNINGS.update({
    f"sc{i}-conservative": dataclasses.replace(TUNINGS[f"sc{i}-paper"], name=f"sc{i}-conservative",
                                               description=f"KF_sc{i} of Renis et al. with a settling phase: conservative", **SETTLING)
    for i in range(1, 5)
})


#: The tuning of ``lcnav run`` (with or without a prior) and of issue 12's consistency criterion: a target in orbit.
DEFAULT_TUNING = "fixed-lag"
#: The default tuning per world (truth physics, :data:`estimators.perturbations.TRUTH_PHYSICS`): the filter is told which
#: forces exist (the torque-free world of the paper has none; in orbit, the gravity gradient), never their hidden parameters.
DEFAULT_TUNINGS = {"torque-free": "fixed-lag-torque-free", "perturbed": DEFAULT_TUNING}


def default_tuning(physics: str) -> str:
    """The name of the default tuning in the world ``physics`` (:data:`DEFAULT_TUNINGS`); ValueError for an unknown world."""
    try:
        return DEFAULT_TUNINGS[physics]
    except KeyError:
        raise ValueError(f"unknown truth physics {physics!r}: expected one of {sorted(DEFAULT_TUNINGS)}") from None


#: Names before 2026-11-26, when the names began to say what the tunings are (issue 12): configs and scripts written
#: with them get the new name in the error.
RENAMED = {"general": "general-conservative", **{f"sc{i}": f"sc{i}-paper" for i in range(1, 5)},
           **{f"sc{i}-settled": f"sc{i}-conservative" for i in range(1, 5)}}


def get_tuning(name: str) -> Tuning:
    """The tuning called ``name``; ValueError naming the known ones (or the new name of a renamed one) otherwise."""
    try:
        return TUNINGS[name]
    except KeyError:
        if name in RENAMED:
            raise ValueError(f"tuning {name!r} is now called {RENAMED[name]!r} ({TUNINGS[RENAMED[name]].description})") from None
        raise ValueError(f"unknown tuning {name!r}: expected one of {sorted(TUNINGS)}") from None
