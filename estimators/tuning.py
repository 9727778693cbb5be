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

The names say what a tuning is: ``relinearized`` (the default of ``lcnav run``,
:data:`DEFAULT_TUNING`) is consistent from the default ``P_0``; ``*-conservative``
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

``fixed-lag`` (issue 31): ``relinearized``'s 10-s settling phase and fits every 10 s, but from ``t ≥ lag``
(:data:`LAG_S`, 60 s) each fit takes only the measurements of a moving window whose prior is the filter's own
output at the window's start (an *anchor*: a fit result with a Gaussian posterior that kept its data; why the
information sets are disjoint, and why the anchor test, in :class:`estimators.navigation._Relinearization`), and
the :data:`PERTURBED_BUDGET`'s ``Q_d`` enters both the window (each residual's ``R_j`` inflated by the noise
accumulated since the window's start, the last state's moments by the window's Kalman recursion with ``Q``:
:mod:`estimators.batch`, *Process noise*; exact on a linear model, ``tests/estimators/test_fixed_lag.py``) and
the recursion between fits. Measured 2026-11-27:

* Cost (``benchmarks/bench_realtime.py``, SC3 torque-free, two orbits, 11 400 s, seed 1, CPU time per step; re-run
  with the anchor rule): median 0.18 ms (EKF) and 0.51 ms (UKF); mean of the 100-step block at 300 s 3.93 / 4.20 ms, of
  the last block 3.87 / 4.14 ms (ratio 0.98 / 0.98: flat; the amortised cost is that of one 60-s fit every 10 s). Same
  run: ``relinearized`` EKF 51 ms at 300 s and 160 ms at 800 s (3.13×); filterpy's EKF/UKF medians 0.064 / 1.03 ms.
* Consistency (``consistency_check``, 30 runs of 600 s at 1 s, seeds 1000–1029, after 60 s; mean NEES/dof [95 %
  t interval], steps in the 95 % band, worst run, NIS in band attitude/position, gate rejections attitude/position):

  ========  ===========  ======  =====================  ==========================  =====  =========  =========
  scenario  truth        filter  NEES/dof               in band (below, above)      worst  NIS (%)    gate (%)
  ========  ===========  ======  =====================  ==========================  =====  =========  =========
  SC3       perturbed    EKF     0.688 [0.637, 0.738]   0.5 % (99.5 %, 0 %)         0.97   97 / 93    0.99 / 0.96
  SC3       perturbed    UKF     0.686 [0.635, 0.736]   0.5 % (99.5 %, 0 %)         0.96   97 / 93    0.99 / 0.96
  SC1       perturbed    EKF     1.18 [0.88, 1.48]      35 % (37 %, 28 %)           3.15   97 / 93    0.96 / 1.25
  SC1       perturbed    UKF     1.41 [1.04, 1.79]      44 % (15 %, 40 %)           3.94   97 / 92    0.96 / 1.27
  SC3       torque-free  EKF     0.630 [0.573, 0.688]   0.4 % (99.6 %, 0 %)         0.96   97 / 93    0.98 / 0.94
  SC3       torque-free  UKF     0.631 [0.574, 0.689]   0.4 % (99.6 %, 0 %)         0.97   97 / 93    0.98 / 0.94
  SC1       torque-free  EKF     0.686 [0.617, 0.754]   5.0 % (95 %, 0 %)           1.15   97 / 93    0.98 / 0.89
  SC1       torque-free  UKF     0.683 [0.615, 0.752]   4.8 % (95 %, 0 %)           1.15   97 / 93    0.98 / 0.89
  ========  ===========  ======  =====================  ==========================  =====  =========  =========

  Diagnostics (same seeds, EKF): SC3 torque-free with ``Q = 0`` (no budget, the window fits deterministic):
  0.979 [0.873, 1.085], 100 % in band, worst run 1.65 — the bounded window itself is consistent from the default
  ``P_0`` over 600 s, as ``relinearized`` is over 300 s; SC3 perturbed with the budget's correlation time 4 s instead of 20 s (``Q``'s
  intensities 5× smaller): 0.818 [0.761, 0.876], 21 % in band (79 % below). The lag, chosen by measurement (SC3 perturbed, seeds 1000–1009, 600 s): 60 s 0.733
  [0.629, 0.838], 120 s 0.729 [0.627, 0.831] at 1.8× the CPU (112 s against 63 s for the 10 runs), so 60 s.
  ``relinearized`` on SC3 perturbed, 10 runs of 300 s (the data of ``test_fixed_lag.py``'s consistency test):
  3.44 [3.08, 3.80], 14 % in band (86 % above); ``fixed-lag`` 0.761 [0.580, 0.941], 29 % (71 % below).

* Accuracy (10 runs of 300 s, seeds 1000–1009, RMSE from 150 s on; EKF): SC3 on the perturbed truth
  against ``relinearized`` on the torque-free one: attitude 0.0109 vs 0.0106 rad (1.03×), rate 1.62e-4 vs
  8.73e-5 rad/s (1.86×), position 0.0896 vs 0.0689 m (1.30×), velocity 6.32e-3 vs 3.03e-3 m/s (2.09×), ``k``
  0.0102 vs 0.0098 (1.04×); SC1: 0.0107 vs 0.0103, 1.83e-4 vs 1.29e-4 (1.43×), 0.0951 vs 0.0808 (1.18×),
  7.25e-3 vs 4.89e-3 (1.48×) (``k`` considered). On the torque-free truth the figures are those of the perturbed
  one within 4 % (SC3): the budget's ``Q_d``, not the physics, sets them. The UKF's are the EKF's to 4 digits.

Not the default (``DEFAULT_TUNING`` stays ``relinearized``): the cost criterion is met, the consistency one is not —
on SC3 the filters are conservative on both truths (the budget's ``Q_d``, sized for the worst of SC1–SC4 and taken
as white noise of intensity ``2 σ² T_c``, is far more than what the gravity gradient and the damping do to SC3 over
a window: a torque that turns with the target has little power at zero frequency, so its integral stays bounded
instead of growing like a random walk), on SC1 they are over-confident on the perturbed truth on 28–40 % of the steps (worst runs 3.2 and
3.9) and conservative on the torque-free one (0.68), and SC3's velocity RMSE is 2.09× ``relinearized``'s (criterion 2×), again the budget's noise.
The window and its anchors are consistent without the budget (the ``Q = 0`` diagnostic); what is missing is an honest,
scenario-independent ``Q`` for it (issue 31, deliverable 2). Measured afterwards (EKF, 10 runs of 600 s, seeds 1000–1009,
perturbed truth): with no ``Q`` at all SC3's NEES/dof is 19.4 (88 % of the steps above the band) and SC1's 1.83; with the
budget's three intensities scaled by 0.1, SC3's is 0.962 [0.834, 1.09], 96.5 % of the steps in band (0.01: 1.83), SC3
torque-free 0.777 (64 % of the steps below the band), SC1 perturbed 0.954 [0.58, 1.33] with 48 % in band (37 % below,
14 % above; worst run 2.2). The
zero-frequency intensity of the perturbed truth's own disturbance, ``q_H = H · Var`` of its ``H``-second means (one orbit,
per axis), agrees with that factor for the angular part: ``q_H / q_budget`` = 0.34, 0.076, 0.041 at ``H`` = 60, 300, 600 s
(SC3; SC1 0.23, 0.061, 0.035): the torque turns with the target and its integral stays bounded. The differential
translational acceleration is the other way round, 0.99, 4.7, 8.1× the budget's (J2 and drag are nearly constant over
minutes; the 0.37-m position noise hides it over 600 s). A budget stated as ``q_H`` at the window's horizon is the
derivation to try next; it does not explain SC1's over-confidence, which more ``Q`` did not remove. The EKF and the UKF differ (their own anchors, gates and
recursions) but by little: SC3 NEES/dof 0.688 vs 0.686, RMSE equal to 4 digits — the window fit, not the filter,
sets the estimate at every fit.

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
#: The intensities matched to what the filters' model gets wrong on the perturbed truth (studies.sim.matched_noise.matched_budget of
#: SC1 and SC3, two orbits, the default pose noise every 1 s; measured 2026-11-27): the rate's at the filter's memory, 250 s (SC3)
#: and 260 s (SC1), 1.24e-12 and 1.05e-12 rad²/s³ (0.063 and 0.054 of PERTURBED_BUDGET's 2 σ² T_c); the differential
#: acceleration's spectrum 3.9e-12 and 2.1e-12 m²/s³; the damping's 1.0e-8 and 2.2e-8 /s on k. The fast tumbles need more: SC2
#: (0.2 rad/s about the intermediate axis) 2.0e-11 at 132 s, SC4 6.0e-12 at 169 s (1.0 and 0.30 of PERTURBED_BUDGET's), so this
#: budget is for the slow tumbles (SC1, SC3). ``tests/studies/test_matched_noise.py`` re-measures it.
MATCHED_BUDGET = MatchedBudget(q_alpha_rad2_s3=1.239e-12, q_a_m2_s3=3.935e-12, q_kdot_1_s=2.230e-8,
                               source="matched_budget of the perturbed truth, SC1 and SC3, two orbits, default pose noise at 1 s")
#: The fixed-lag window's length (s): see the module docstring, ``fixed-lag``.
LAG_S = 60.0
TUNINGS["fixed-lag"] = dataclasses.replace(
    TUNINGS["relinearized"], name="fixed-lag", budget=MATCHED_BUDGET, lag_s=LAG_S,
    description=f"re-linearised every 10 s about the fit of a {LAG_S:g}-s window from the filter's own estimate, with the process noise "
    "matched to the perturbed truth inside the window and between fits (bounded cost)")

#: The scenario tunings with the settling phase: what a spin prior selects in ``lcnav run``, the demo and the chain study.
TUNINGS.update({
    f"sc{i}-conservative": dataclasses.replace(TUNINGS[f"sc{i}-paper"], name=f"sc{i}-conservative",
                                               description=f"KF_sc{i} of Renis et al. with a settling phase: conservative", **SETTLING)
    for i in range(1, 5)
})


#: The tuning of ``lcnav run`` (with or without a prior) and of issue 12's consistency criterion.
DEFAULT_TUNING = "fixed-lag"


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
