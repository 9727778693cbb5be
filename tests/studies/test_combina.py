"""The CoMBiNa closed loop (Maestrini et al. §VI) with simulated BCPD measurements: the issue's "tests that must hold".

Ten seeds per case; the truth of each target is integrated once and shared. The filters' process noise budgets for the
perturbed truth (gravity gradient, J2, drag: ``studies.sim.combina.COMBINA_BUDGETS``, issue 31): on that truth their NEES is
tested two-sided, on the torque-free one (the paper's, which most tests use) for over-confidence and at most 2× conservatism.
Seeds change the initial estimate (drawn from P_0 of eq. 48) and the
measurement noise/outliers.
"""

import numpy as np
import pytest

from estimators.dynamics import integrate_truth, nerm_rhs
from scipy.stats import chi2

from studies.sim.combina import N_RAD_S, R_T_M, TU, CombinaConfig, component_errors, filter_nees, run_combina, combina_metrics, simulate_lvlh_truth

SEEDS = range(10)
DT = 1.0 / 0.33


@pytest.fixture(scope="module")
def truths():
    n = int(np.floor(2.0 * TU / DT))
    return {tg: simulate_lvlh_truth(tg, n * DT, DT) for tg in ("asymmetric", "symmetric")}


def _runs(truths, target, prior):
    out = []
    for seed in SEEDS:
        run = run_combina(CombinaConfig(target=target, seed=seed, prior=prior), truth=truths[target])
        out.append((run, combina_metrics(run)))
    return out


@pytest.fixture(scope="module")
def asym(truths):
    return _runs(truths, "asymmetric", "none")


@pytest.fixture(scope="module")
def asym_prior(truths):
    return _runs(truths, "asymmetric", "init")


@pytest.fixture(scope="module")
def sym(truths):
    return _runs(truths, "symmetric", "none")


def test_truth_relative_motion_obeys_nerm(truths):
    """Two independent absolute integrations seen in LVLH follow eq. 9 (circular chaser): < 1 mm over 2 TU."""
    tr = truths["asymmetric"]
    x0 = np.concatenate([tr.r_L[0], tr.v_L[0]])
    ref = integrate_truth(nerm_rhs, tr.t, x0, N_RAD_S, R_T_M)
    assert np.max(np.abs(ref[:, :3] - tr.r_L)) < 1e-3
    rng_m = np.linalg.norm(tr.r_L, axis=1)
    assert 20.0 < rng_m.min() and rng_m.max() < 55.0  # the §VI football orbit, ≈ 37 m on average
    assert np.mean(rng_m) == pytest.approx(37.0, abs=4.0)


def test_asymmetric_target_errors_inside_3sigma_after_convergence(asym):
    """Every seed converges; with R equal to the simulated registration noise (not the paper's 4× / 23°), the
    final NEES summed over the 10 independent seeds lies below the 99.5 % quantile of χ²(10 × dof) and above half its
    0.5 % quantile (the perturbed truth's process noise makes the filters conservative here), per filter."""
    final = {"translation": [], "attitude": []}
    for run, m in asym:
        c = m["components"]
        for name in ("r", "v", "sigma", "w"):
            assert c[name]["converged"], (run.config.seed, name)
            assert c[name]["fraction_within_3sigma"] >= 0.5, (run.config.seed, name, c[name])
        for name, (t, e, dof) in filter_nees(run).items():
            final[name].append(e[-1])
        assert not m["symmetry_detected"]
        assert c["r"]["final_error"] < 0.5  # m
        assert np.rad2deg(4 * np.arctan(c["sigma"]["final_error"])) < 3.0  # deg
    for name, dof in (("translation", 6), ("attitude", 8)):
        n = len(final[name]) * dof
        assert chi2.ppf(0.005, n) / 2.0 <= np.sum(final[name]) <= chi2.ppf(0.995, n), (name, np.round(final[name], 1))


def test_inertia_ratios_converge_more_slowly(asym):
    """k error and 3σ shrink over 2 TU in every seed; k converges later than ω (Fig. 11); k's final NEES
    (2 dof) summed over the 10 seeds lies below the 99.5 % quantile of χ²(20) and above half its 0.5 % quantile
    (without process noise on k its covariance collapsed and k ended 5–45σ off)."""
    later, nees = 0, []
    for run, m in asym:
        t, e, sd = component_errors(run)["k"]
        assert np.linalg.norm(e[-1]) < np.linalg.norm(e[0])
        assert np.max(sd[-1]) < 0.7 * np.max(sd[0])
        P_k = run.steps[-1].P_a[6:8, 6:8]
        nees.append(float(e[-1] @ np.linalg.solve(P_k, e[-1])))
        tk = m["components"]["k"]["convergence_time_s"]
        later += tk is None or tk > m["components"]["w"]["convergence_time_s"]
    assert later >= 9
    assert chi2.ppf(0.005, 2 * len(nees)) / 2.0 <= np.sum(nees) <= chi2.ppf(0.995, 2 * len(nees)), np.round(nees, 1)


def test_symmetry_never_detected_on_the_asymmetric_target(asym, asym_prior):
    assert not any(m["symmetry_detected"] for _, m in asym + asym_prior)


def test_symmetric_target_detected_and_axis_estimated(sym):
    detected = [(run, m) for run, m in sym if m["symmetry_detected"]]
    assert len(detected) >= 9
    for run, m in detected:
        assert m["mode"] == "axisymmetric"
        assert m["axis_error_deg"] < 5.0
        t, e, sd = component_errors(run)["gamma_over_a"]
        assert abs(e[-1, 0]) <= 3 * sd[-1, 0]
        assert set(m["components"]) == {"r", "v", "sigma", "w", "k", "phi", "delta", "gamma_over_a"}


def test_spin_prior_as_w0_converges_sooner(asym, asym_prior):
    """Paired over the 10 seeds (a seed's two runs share their measurements and initial errors; the prior replaces ω_0): with a
    5 % prior as ω_0, ω converges no later than without it in at least 7 seeds, and sooner on average. Measured: 8 of 10, 3 of
    them at once; mean paired difference −58 s (−148 s before). (The medians, 341 s and 320 s, no longer order the arms: with the process noise
    matched to the filters the runs without a prior converge sooner than before — median 385 s, seed 1 at 1039 s, now 315 s —
    while the runs with it are unchanged.)"""
    dur = asym[0][0].steps[-1].t

    def times(runs):
        return np.array([m["components"]["w"]["convergence_time_s"] if m["components"]["w"]["converged"] else dur for _, m in runs])

    with_prior, without = times(asym_prior), times(asym)
    assert np.sum(with_prior <= without) >= 7, (with_prior, without)
    assert np.mean(with_prior - without) < 0.0


def test_every_gate_decision_is_recorded(asym):
    run, m = asym[0]
    n = len(run.measurements)
    g = m["gate_counts"]
    for f in ("translation", "attitude"):
        assert sum(g["by_filter"][f].values()) == n
    assert g["accepted"] + g["rejected_scale"] + g["rejected_mahalanobis"] == 2 * n
    n_deformed = sum(mm.kind == "deformed" for mm in run.measurements)
    assert g["by_filter"]["translation"]["rejected_scale"] == n_deformed


def test_proxy_rate_replaces_rejected_measurements(truths):
    """--prior proxy: one rate update per rejected attitude measurement; the filter stays consistent (final
    attitude NEES summed over 3 seeds below the 99.5 % quantile of χ²(24), above half its 0.5 % quantile)."""
    nees = []
    for seed in range(3):
        run = run_combina(CombinaConfig(target="asymmetric", seed=seed, prior="proxy"), truth=truths["asymmetric"])
        m = combina_metrics(run)
        rejected = m["gate_counts"]["by_filter"]["attitude"]
        assert run.proxy_updates == rejected["rejected_scale"] + rejected["rejected_mahalanobis"] > 0
        for name in ("sigma", "w"):
            assert m["components"][name]["converged"]
        nees.append(float(filter_nees(run)["attitude"][1][-1]))
    assert chi2.ppf(0.005, 24) / 2.0 <= np.sum(nees) <= chi2.ppf(0.995, 24), np.round(nees, 1)


def test_axisymmetric_variant_estimating_the_frame(truths):
    """The variant that also estimates σ_IΓ (frame started 5° off, 1-σ per axis) still ends below 5°."""
    for seed in range(3):
        run = run_combina(CombinaConfig(target="symmetric", seed=seed, axis_frame="estimated"), truth=truths["symmetric"])
        m = combina_metrics(run)
        assert m["symmetry_detected"] and m["axis_error_deg"] < 5.0
        t, e, sd = component_errors(run)["gamma_over_a"]
        assert abs(e[-1, 0]) <= 3 * sd[-1, 0]


def test_translation_started_beyond_its_gate_restarts_from_the_measurements():
    """Eq. 48's P_0 draws a position error beyond the ν = 3 gate (position NEES above χ²₃'s 99 % quantile) in 1 % of the runs;
    the reset to P_0 kept that mean and every later measurement was rejected (seen on a development seed: 190 of 190).
    Started 4σ off per axis (15 m), each of 5 seeds restarts from the measured positions after the 5 rejections in a row and
    passes the coverage study's test: the NEES (6 dof) of its last 10 epochs below the Bonferroni quantile χ²₆(1 − 0.01/10)."""
    from studies.sim.combina import LU, _ClosedLoop, make_source

    t = CombinaConfig(target="asymmetric", duration_tu=0.3).epochs_s()
    truth = simulate_lvlh_truth("asymmetric", t[-1], t[1])
    for seed in range(5):
        cfg = CombinaConfig(target="asymmetric", duration_tu=0.3, seed=seed)
        rng, rng_meas = (np.random.default_rng(s) for s in np.random.SeedSequence(seed).spawn(2))
        loop = _ClosedLoop(cfg, truth, make_source(cfg, rng_meas, truth), rng)
        offset_m = 4.0 * np.sqrt(loop.trans.P[0, 0]) * np.array([1.0, -1.0, 1.0])
        loop.trans.core.x = np.concatenate([(truth.r_L[0] + offset_m) / LU, loop.trans.core.x[3:]])  # internal units: LU
        for i in range(1, t.size):
            loop.iterate(i, float(t[i]), float(t[1]))
        run = loop.result()
        assert run.translation_restarts >= 1
        tt, e, dof = filter_nees(run)["translation"]
        assert np.all(e[-10:] <= chi2.ppf(1 - 0.01 / 10, dof)), (seed, np.round(e[-10:], 1))


def _nees_in_band(runs) -> dict[str, tuple[float, float]]:
    """Per filter, pooled over runs: fractions of the steps after the first 0.3 of a run with NEES in / above its 95 % band."""
    flags: dict[str, list] = {}
    for run in runs:
        for name, (t, nees, dof) in filter_nees(run).items():
            lo, hi = chi2.ppf([0.025, 0.975], dof)
            x = nees[t > 0.3 * t[-1]]
            flags.setdefault(name, []).append(np.stack([(x > lo) & (x < hi), x >= hi]))
    return {name: tuple(np.round(np.concatenate(f, axis=1).mean(axis=1), 3).tolist()) for name, f in flags.items()}


def test_rocket_body_filters_hold_their_band_over_two_tu_of_the_perturbed_truth():
    """On the rocket body's perturbed truth over 2 TU, with Q from the budget, the translational and the axisymmetric filters' NEES
    lies in its 95 % band on ≥ 85 % of the steps after the first 0.3 of the run, pooled over 4 seeds (measured 92 % and 88 %;
    97 % for the translation with eq. 9 about the circular orbit, before the chaser's own orbit entered its model).
    Without the budget (no translational Q, a white 1e-7 rad/s² per step on ω) the axisymmetric filter's NEES/dof was ~4000.
    Over a whole orbit it fails (the gravity gradient turns Γ by 40–50°: ``python -m benchmarks combina_consistency``). The
    box-wing's filters are tested over an orbit with dispersed orbit phases (``tests/studies/test_combina_consistency.py``); on
    this one fixed-phase truth over 2 TU its attitude filter has 82 % of the steps in the per-step band, 18 % above."""
    n = np.floor(2.0 * TU / DT) * DT
    truth = simulate_lvlh_truth("symmetric", n, DT, physics="perturbed")
    band = _nees_in_band([run_combina(CombinaConfig(target="symmetric", seed=seed, truth="perturbed"), truth=truth) for seed in range(1, 5)])
    assert band["translation"][0] >= 0.85 and band["axisymmetric"][0] >= 0.85, band  # the attitude filter is replaced at the symmetry switch


def test_filters_on_the_torque_free_truth_without_process_noise(asym):
    """On the torque-free truth eqs 9 and 29 are the truth's motion and neither filter has process noise. The translational
    filter's per-step NEES lies in its 95 % band on ≥ 92 % of the steps after the first 0.3 of a 2-TU run, pooled over 10 seeds
    (measured 95.8 %), ≤ 5 % above it. The attitude filter, restarted from refits of its initial state while it learns ``k``
    (:class:`estimators.combina.acquisition.LearningRefits`), ≥ 80 % in band and ≤ 15 % above (measured 87.7 % and 7.2 %):
    over-confident while ``k`` is still uncertain (`docs/known-limitations.md`, issue 31). It used to carry the perturbed world's budget,
    1.38e-12 rad²/s³, which covered a torque that is not there: conservative (26 % of the steps below the band)."""
    band = _nees_in_band([run for run, _ in asym])
    assert band["translation"][0] >= 0.92 and band["translation"][1] <= 0.05, band
    assert band["attitude"][0] >= 0.80 and band["attitude"][1] <= 0.15, band
    assert all(run.attitude_refits >= 3 for run, _ in asym)


def test_axisymmetric_start_uses_the_initial_rate_and_a_vetted_axis(truths):
    """The switch (§V.C) starts ``Γ/A`` from the initial estimate's ``|ω̂_0|`` (eq. 48), not from the attitude filter's rate, which
    registrations with a random roll about the axis can drive anywhere (0.22 rad/s against Γ/A = 1.0e-3 on a benchmark seed);
    and the axis from the median of the last three registrations, so that one misaligned among them (here turned by 90°) does not
    start it off: within 3σ of ``P_0`` in ``Γ/A``, and the axis no farther off than the worse of the two good registrations."""
    from estimators.attitude import quat_multiply, rotvec_to_quat
    from studies.sim.combina import OMEGA, _ClosedLoop, _start_axisymmetric, angular_momentum_I, make_source, quat_to_dcm

    truth = truths["symmetric"]
    cfg = CombinaConfig(target="symmetric", seed=3)
    rng, rng_meas = (np.random.default_rng(s) for s in np.random.SeedSequence(3).spawn(2))
    loop = _ClosedLoop(cfg, truth, make_source(cfg, rng_meas, truth), rng)
    i = 30
    noise = [rotvec_to_quat(np.deg2rad(2.0) * rng.normal(size=3)) for _ in range(3)]
    turned = rotvec_to_quat(np.deg2rad(90.0) * np.array([1.0, 0.0, 0.0]))
    loop.last_att_meas = [(truth.t[j], quat_multiply(truth.q_IT[j], dq)) for j, dq in zip((i - 2, i - 1, i), (noise[0], turned, noise[2]))]
    J_true = quat_to_dcm(truth.q_IT[i])[:, 1]

    def angle_deg(J):
        return np.rad2deg(np.arccos(np.clip(J @ J_true, -1.0, 1.0)))

    J_meas = loop._measured_axis()
    good = [angle_deg(quat_to_dcm(q)[:, 1]) for k, (_, q) in enumerate(loop.last_att_meas) if k != 1]  # each within its 2°-per-axis noise
    assert angle_deg(J_meas) <= max(good) + 0.5 and angle_deg(quat_to_dcm(loop.last_att_meas[1][1])[:, 1]) > 45.0
    loop.att.core.x[OMEGA] = 0.2 * np.ones(3) / np.sqrt(3.0)  # what random-roll registrations did to the attitude filter
    axi, _ = _start_axisymmetric(cfg, truth, i, J_meas, loop.x0_a[OMEGA], rng)
    g_true = np.linalg.norm(angular_momentum_I(truth.q_IT[i], truth.w_T[i], truth.J_T)) / truth.J_T[0]
    assert abs(axi.x[2] - g_true) <= 3.0 * np.sqrt(axi.P[2, 2])
