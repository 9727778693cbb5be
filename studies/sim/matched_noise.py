"""The relative filters' process noise matched to what their model gets wrong on the perturbed truth (issue 31).

:mod:`estimators.process_noise` turns intensities into ``Q_d`` (eq. 1 there); this module measures the intensities.
A ``σ, T_c`` budget (:class:`estimators.process_noise.DisturbanceBudget`) over-states a tumbling target's torque:
it turns with the target, so its integral stays bounded while a white noise's grows (the module docstring there).
What a filter needs instead is a ``Q`` whose accumulated covariance over the filter's memory matches the error its
own process model makes over that time. Measured directly:

1. **Prediction errors.** Along the truth, from windows starting every :data:`STRIDE_S` s, propagate the *true*
   state with the filters' model (:class:`estimators.process_model.RelativeProcessModel`) for ``H`` seconds:
   ``δx = x(t₀ + H) ⊟ f_H(x(t₀))`` — all of it is the unmodelled physics (the model's own integration error is
   1e-7 m per step).
2. **The model's covariance of them.** A unit white acceleration on the rate (``Q_d`` of eq. 1 with ``q = 1``, per
   step) accumulated through the same trajectory's step Jacobians ``F_j``:
   ``M_α = Σ_j Φ(H, j) Q_d,j Φ(H, j)ᵀ`` — the covariance the filter would predict for ``δx`` per unit intensity, with
   the Euler and orbital couplings it models.
3. **Angular intensity** (eq. M1): ``q_α(H) = mean over windows of δωᵀ (M_α,ωω)⁻¹ δω / 3``, the intensity for which
   the rate's prediction errors have unit NEES.
4. **Horizon** (eq. M2): the memory of the steady-state filter that measures attitude with intensity
   ``r = R τ_s`` (:mod:`estimators.process_noise`, eq. 2): ``H = 1/ω_n = (r / q_α)^{1/4}``; eqs. M1–M2 are solved
   together (:func:`matched_angular`).
5. **Translational intensity**: the differential acceleration ``a_S − a_T`` in the orbit frame L, where J2's and
   drag's are nearly steady (in T they turn with the tumble and their slow part hides at the spin harmonics): the larger of
   its spectrum matched to the filter that measures position (:func:`estimators.process_noise.matched_intensity`, eq. 3)
   and its mean's white equivalent over the relative orbit's time scale ``1/n``
   (:func:`estimators.process_noise.constant_acceleration_intensity`, eq. 5: the drag is a constant along-track push,
   which the filter could otherwise read as a pitch of the target frame). Not by steps 1–4: the position–velocity
   prediction errors in T are mostly the rotation's (at 50 m a rate error of 2e-5 rad/s is 1e-3 m/s of relative velocity
   in the target frame, far more than J2 and drag do), and along the directions the rotation leaves alone they are
   millimetres against the 0.2-m measurement noise.
6. **Inertia ratios**: no noise when the filters' model includes the gravity-gradient torque. The inertia is constant;
   what the truth's nutation damping does is a torque, which step 3 already counts (the rate's prediction errors are the
   damping's once the gravity gradient is modelled). Measured (SC3, 20 runs of one orbit, EKF): with the damping also
   mapped to a random walk of ``k`` (``k̇ = α_d/|ω|²``, 1e-8 /s) the rate block's NEES/dof was 0.5 and ``k``'s 0.3–0.5
   (the two counted twice); with none, 0.82–1.20 and 0.74–1.11. Without the gravity gradient in the model its torque is
   unmodelled and the inertia ratios take the old random walk (:func:`estimators.process_noise.kdot_from_dissipation`).

The largest of the scenarios' intensities is the budget (:func:`matched_budget`), as for the ``σ`` budget.

CoMBiNa's filters (Maestrini et al., JGCD 2023) propagate the relative translation with the NERM of a circular reference orbit
(their eq. 9) and the attitude with torque-free Euler equations (eq. 29); :func:`combina_matched_budget` measures, along the
COMBINA scenario's perturbed truth at the filters' own step, what each model gets wrong over one step — the unmodelled
acceleration ``(x_{j+1} − f_τ(x_j))_rate / τ`` — and matches its spectrum to the filter that measures the position or the
attitude (:func:`estimators.process_noise.matched_intensity`, eq. 3 there). Step 5's argument holds for both: each filter
measures the quantity whose second derivative is disturbed, so eq. 3's double integrator is the filter, axis by axis.
"""

from __future__ import annotations

import numpy as np
from scipy.signal import periodogram

from estimators.error_state import boxminus
from estimators.measurement import PoseNoise
from estimators.perturbations import TruthPhysics, get_truth_physics
from estimators.process_model import RelativeProcessModel
from estimators.process_noise import MatchedBudget, constant_acceleration_intensity, kdot_from_dissipation, matched_intensity, relative_Q_d
from estimators.state import DW_ST_T, N_ERROR
from studies.sim.disturbance import BUDGET_DT_S, unmodelled_accelerations
from studies.sim.scenarios import Scenario

#: Record the intensities are measured on, s: two orbits at 500 km (the spectra's lowest frequency, 1/11 400 Hz, lies
#: below the filters' band, ~1/300 s).
MATCH_DURATION_S = 11_400.0
#: Spacing of the prediction windows' starts, s (not a divisor of the spin or orbit periods).
STRIDE_S = 97.0

def prediction_errors(truth, horizon_s: float, stride_s: float = STRIDE_S, *, gravity_gradient: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """Steps 1–2 of the module docstring on ``truth`` (sampled every :data:`BUDGET_DT_S`): ``(δx (n, 14), M_α (n, 14, 14))``
    for windows of ``horizon_s`` starting every ``stride_s``; ``gravity_gradient``: the filters' model includes the
    target's gravity-gradient torque (:class:`estimators.process_model.RelativeProcessModel`), so it is no longer
    unmodelled."""
    H, stride = int(round(horizon_s / BUDGET_DT_S)), max(1, int(round(stride_s / BUDGET_DT_S)))
    if H < 1 or H >= len(truth.t):
        raise ValueError(f"horizon_s: {horizon_s!r}: expected at least one step and less than the truth's {truth.t[-1]:g} s")
    model = RelativeProcessModel(truth.J_S_diag, gravity_gradient=gravity_gradient)
    Q_alpha = relative_Q_d(1.0, 0.0, 0.0, BUDGET_DT_S)
    d, M_alpha = [], []
    for i0 in range(0, len(truth.t) - H, stride):
        X, _, F = model.trajectory(truth.x[i0], truth.servicer[i0:i0 + H], BUDGET_DT_S)
        d.append(boxminus(truth.x[i0 + H], X[-1]))
        T = np.eye(N_ERROR)  # Φ(H, j): from the end of step j to the window's end, accumulated backwards
        M = np.zeros((N_ERROR, N_ERROR))
        for j in range(H - 1, -1, -1):
            M += T @ Q_alpha @ T.T
            T = T @ F[j]
        M_alpha.append(M)
    return np.array(d), np.array(M_alpha)


def angular_intensity(d: np.ndarray, M_alpha: np.ndarray) -> float:
    """Eq. M1: ``mean δωᵀ (M_α,ωω)⁻¹ δω / 3`` over the windows (rad²/s³)."""
    dw = d[:, DW_ST_T]
    return float(np.mean(np.einsum("ni,ni->n", dw, np.linalg.solve(M_alpha[:, DW_ST_T, DW_ST_T], dw[..., None])[..., 0])) / 3.0)


def filter_memory_s(q: float, r: float) -> float:
    """Eq. M2: ``1/ω_n = (r/q)^{1/4}`` (s), the memory of the steady-state filter of eq. 2 (:mod:`estimators.process_noise`)."""
    if not (q > 0 and r > 0):
        raise ValueError(f"q, r: {q!r}, {r!r}: expected two intensities > 0")
    return (float(r) / float(q)) ** 0.25


def matched_angular(truth, r: float, *, resolution_s: float = 2.0, gravity_gradient: bool = False) -> tuple[float, float]:
    """Eqs. M1–M2: ``(q_α, H)`` with ``H = (r / q_α(H))^{1/4}``, by bisection on ``H`` between 10 s and a quarter of the truth.

    ``q_α(H)`` grows with ``H`` (the model's errors grow faster than a random walk's once the unmodelled physics has moved
    the truth off its torque-free trajectory), so ``H − (r / q_α(H))^{1/4}`` grows and has one root. Near an
    intermediate-axis spin it grows by orders of magnitude within tens of seconds (SC2: 0.4 → 16× the ``σ`` budget's
    intensity from 120 to 150 s), which an iteration of eq. M2 jumps across; bisection does not.
    """
    lo, hi = 10.0, float(truth.t[-1]) / 4.0
    q_of = {}

    def excess(H: float) -> float:
        q_of[H] = angular_intensity(*prediction_errors(truth, H, gravity_gradient=gravity_gradient))
        return H - filter_memory_s(q_of[H], r)

    if excess(lo) >= 0.0 or excess(hi) <= 0.0:
        raise RuntimeError(f"matched_angular: no horizon between {lo:g} and {hi:g} s is the filter's memory")
    while hi - lo > resolution_s:
        mid = round(0.5 * (lo + hi))
        lo, hi = (mid, hi) if excess(mid) < 0.0 else (lo, mid)
    return q_of[hi], hi


def _axis_psd(a: np.ndarray, dt_s: float = BUDGET_DT_S) -> tuple[np.ndarray, np.ndarray]:
    """One-sided spectral density of ``a`` (n, 3) sampled every ``dt_s`` (Hann window, mean kept: a constant acceleration is a
    disturbance too), mean over the 3 axes."""
    f, G = periodogram(a, fs=1.0 / dt_s, window="hann", detrend=False, axis=0)
    return f, G.mean(axis=1)


def matched_budget(scenarios: list[Scenario], physics: str | TruthPhysics = "perturbed", duration_s: float = MATCH_DURATION_S,
                   pose_noise: PoseNoise = PoseNoise(), tau_s: float = BUDGET_DT_S, *, gravity_gradient: bool = False) -> MatchedBudget:
    """Steps 1–6 of the module docstring for each scenario; the largest intensity of each kind. Deterministic.

    ``pose_noise``: the measurements the filter is matched to (its ``R``), every ``tau_s`` s. ``gravity_gradient``: the
    filters' model includes the target's gravity-gradient torque, which then leaves the rate's budget (step 3).
    """
    physics = get_truth_physics(physics)
    r_att, r_pos = pose_noise.R_attitude[0, 0] * tau_s, pose_noise.R_position[0, 0] * tau_s
    q, horizons = np.zeros(3), []
    for scenario in scenarios:
        truth, angular_T, translational_L, _ = unmodelled_accelerations(scenario, physics, duration_s)
        q_alpha, H = matched_angular(truth, r_att, gravity_gradient=gravity_gradient)
        a_L = sum(translational_L.values())
        q_a = max(matched_intensity(*_axis_psd(a_L), r_pos), constant_acceleration_intensity(a_L.mean(axis=0), 1.0 / scenario.mean_motion_rad_s))
        q_k = 0.0 if gravity_gradient else (matched_intensity(*_axis_psd(angular_T["dissipation"]), r_att)
                                            * kdot_from_dissipation(1.0, float(np.linalg.norm(scenario.w_T0_T_rad_s))) ** 2)
        q = np.maximum(q, [q_alpha, q_a, q_k])
        horizons.append(f"{scenario.name} {H:g} s")
    return MatchedBudget(*map(float, q), source=f"matched_budget of the {physics.name} truth over {duration_s:g} s, horizons "
                         f"{', '.join(horizons)}; R of {pose_noise} every {tau_s:g} s")


#: Orbit phases (the chaser's argument of latitude at ``t = 0``, rad) at which :func:`combina_matched_budget` measures: eight,
#: evenly over half an orbit — J2 (through ``sin²`` of the latitude), the gravity gradient (quadratic in the radial direction)
#: and the co-rotating atmosphere repeat every half orbit, and the Monte-Carlo runs of :mod:`studies.sim.combina_consistency`
#: draw their phase uniformly.
COMBINA_PHASES_RAD = tuple(float(u) for u in np.arange(8) * np.pi / 8)
#: Record the CoMBiNa intensities are measured on, in chaser orbits (its lowest frequency lies below the filters' bands,
#: memories of 90–520 s).
COMBINA_ORBITS = 2.0


def combina_model_errors(target: str, arg_latitude_rad: float, physics: str = "perturbed", orbits: float = COMBINA_ORBITS, *,
                         gravity_gradient: bool = True) -> tuple:
    """``(τ, a_L (n, 3) m/s², α_T (n, 3) rad/s²)``: the one-step errors of CoMBiNa's process models along ``target``'s truth.

    At the closed loop's step ``τ`` (:class:`studies.sim.combina.CombinaConfig`'s rate): ``a_L`` is what the translational
    filter's model in that world (:func:`studies.sim.combina.chaser_orbit`: eq. 9 in the torque-free world, the relative motion
    about the chaser's own orbit with J2 in orbit; integrated as the filter does) leaves out of the LVLH relative velocity,
    ``α_T`` what eq. 29 with the target's own
    inertia ratios (:func:`estimators.combina.attitude.propagate_rigid_body`, as the attitude filter integrates it; in orbit
    with the gravity-gradient torque about the chaser's radial direction, as the filter has it since 2026-12-02, unless
    ``gravity_gradient`` is False: the axisymmetric filter's torque-free model) leaves out of the body rate, each per unit time.
    On the torque-free truth both are the integrators' round-off (1e-10 m/s², 1e-15
    rad/s²); on the perturbed one, gravity gradient, J2, drag and damping.
    """
    from estimators.combina.attitude import propagate_rigid_body
    from estimators.dynamics import MU_EARTH, nerm_rhs, rk4_step
    from studies.sim.combina import N_RAD_S, R_T_M, TU, CombinaConfig, chaser_orbit, simulate_lvlh_truth, target_k

    tau = 1.0 / CombinaConfig().rate_hz
    n = int(np.floor(orbits * 2.0 * np.pi * TU / tau))
    tr = simulate_lvlh_truth(target, n * tau, tau, k=target_k(target), physics=physics, arg_latitude_rad=arg_latitude_rad)
    X = np.concatenate([tr.r_L, tr.v_L], axis=1)
    orbit = chaser_orbit(physics, tr)
    if orbit is None:
        Y = X[:-1]
        for _ in range(int(np.ceil(tau / 10.0))):  # the filter's largest RK4 step, 10 s
            Y = rk4_step(nerm_rhs, 0.0, Y, tau / np.ceil(tau / 10.0), N_RAD_S, R_T_M, MU_EARTH)
    else:
        Y = np.array([orbit.propagate_relative(x, t, tau) for x, t in zip(X[:-1], tr.t[:-1])])
    Z = np.concatenate([tr.q_IT, tr.w_T, np.broadcast_to(tr.k, (tr.t.size, 2))], axis=1)
    gg = None
    if orbit is not None and gravity_gradient:  # in orbit the attitude filter's model has the gravity gradient (AttitudeUKF(orbit=)), at each step's mid-time
        g, r_I = zip(*(orbit.gravity_gradient(t + 0.5 * tau) for t in tr.t[:-1]))
        gg = (np.array(g), np.array(r_I))
    W = propagate_rigid_body(Z[:-1], tau, gravity_gradient=gg)
    return tau, (X[1:, 3:] - Y[:, 3:]) / tau, (Z[1:, 4:7] - W[:, 4:7]) / tau


def combina_matched_budget(target: str, physics: str = "perturbed", phases_rad=COMBINA_PHASES_RAD, orbits: float = COMBINA_ORBITS) -> MatchedBudget:
    """The intensities of CoMBiNa's process noise for ``target``: eq. 3 of :mod:`estimators.process_noise` on the spectra of
    :func:`combina_model_errors` at each of ``phases_rad``, averaged over them. Deterministic.

    The mean, not the largest: a run starts at a random phase, so the disturbance the filter meets is a mixture over phases,
    whose variance is the mean of the phases' variances; to first order the error a fixed filter makes is linear in the
    disturbance's spectral level, so the intensity matched to the mixture is the mean of the phases' (they range over 2.3× for
    the translation, 1.25× for the attitude: a run's NEES depends on its phase, and the run-mean NEES on the mean).

    Matched to the closed loop's measurements (the simulated registration's own noise, :class:`perception.simulated_bcpd.SimulatedBCPD`,
    every step ``τ``): ``r = σ_r² τ`` (position, m² s) and ``r = σ_a² τ`` (attitude angle, rad² s). ``q_kdot_1_s`` is 0: the inertia
    ratios are constant in the truth (the damping is a torque, in ``α_T``). The attitude model has the gravity gradient in
    orbit (:func:`combina_model_errors`).
    """
    from perception.simulated_bcpd import SimulatedBCPD

    source = SimulatedBCPD(np.random.default_rng(0))
    q = []
    for u in phases_rad:
        tau, a_L, alpha_T = combina_model_errors(target, u, physics, orbits)
        q.append([matched_intensity(*_axis_psd(alpha_T, tau), source.attitude_sigma_rad**2 * tau),
                  matched_intensity(*_axis_psd(a_L, tau), source.position_sigma_m**2 * tau)])
    q_alpha, q_a = np.mean(q, axis=0)
    return MatchedBudget(q_alpha_rad2_s3=float(q_alpha), q_a_m2_s3=float(q_a), source=f"combina_matched_budget of COMBINA-{target}, {physics} truth, "
                         f"{orbits:g} orbits, mean over {len(phases_rad)} orbit phases; R of the simulated registration every {tau:.3g} s")
