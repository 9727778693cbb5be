"""Spin-state inversion end to end on synthetic light curves of known spin (lightcurves.inversion.search / posterior).

The data come from the ellipsoid model itself (so the likelihood is exact) with Gaussian noise, on LEO-like passes
(the observer direction sweeps a great-circle arc across each pass, a different arc each night) or on the real
geometry of a ground site (lightcurves.geometry). Sizes are small: every inversion here runs in a few seconds.
"""

import numpy as np
import pytest
from astropy.time import Time
from scipy.spatial.transform import Rotation
from scipy.stats import binom
from scipy.stats import chi2 as chi2_dist

from lightcurves.geometry import KeplerOrbit, observe
from lightcurves.inversion.convex import ConvexModel, EllipsoidModel
from lightcurves.inversion.data import InversionCurve
from lightcurves.inversion.posterior import laplace_probabilities
from lightcurves.inversion.posterior import tangent_exp, tangent_offset
from lightcurves.inversion.profile import pole_profile_chi2, pole_profile_region
from lightcurves.inversion.search import _comb_cells, invert, period_grid, profiled_chi2
from lightcurves.inversion.frames import pole_from_radec
from lightcurves.inversion.spin import SpinState, body_directions, pole_frame
from lightcurves.render import observed_flux

EPOCH = Time("2026-01-01T00:00:00", scale="utc")
ELLIPSOID = EllipsoidModel(3.0, 2.0, 1.5, n_facets=300)
FAST = dict(n_grid_samples=40, pole_step_deg=15.0, period_oversampling=2.0, n_candidates=3, n_periods_per_pole=1, n_phases=12)


def _angle_deg(a, b):
    return float(np.degrees(np.arccos(np.clip(np.dot(a, b), -1.0, 1.0))))


def _observe_curves(state, model, geometry, rng, noise=0.02, calibrated=None):
    """Noisy curves of ``model`` spinning as ``state`` on ``geometry``: a list of (t_s, sun_I, obs_I, sun_distance_m, range_m)."""
    curves = []
    calibrated = calibrated or [False] * len(geometry)
    for (t, sun, obs, d, rho), cal in zip(geometry, calibrated):
        n = t.size
        template = InversionCurve(t, EPOCH, np.ones(n), np.ones(n), sun, obs, d, rho, calibrated=cal)
        B = model.basis(*body_directions(state, template))
        f = observed_flux(B @ np.ones(B.shape[1]), rho, d)
        sigma = noise * f.mean() * np.ones(n)
        y = np.abs(f + sigma * rng.standard_normal(n))
        k = 1.0 if cal else 1.0 / f.mean()
        curves.append(InversionCurve(t, EPOCH, y * k, sigma * k, sun, obs, d, rho, calibrated=cal))
    return curves


def _passes(rng, n=100, pass_s=600.0, gap_s=3600.0, sweep_deg=80.0, coplanar=False, nights=3):
    """LEO-like passes (module docstring); ``coplanar`` keeps Sun and observer in the I xy-plane (the mirror-pole geometry)."""
    geometry = []
    sun = np.array([1.0, 0.0, 0.0])
    for k in range(nights):
        t = np.sort(rng.uniform(0.0, pass_s, n)) + (k - 1) * gap_s
        start = Rotation.from_rotvec([0.0, 0.0, np.radians(20 + 25 * k)]).apply(sun)
        axis = np.array([0.0, 0.0, 1.0])
        if not coplanar:
            axis = Rotation.from_rotvec(start * np.radians(40 * k + 20)).apply(axis)
        obs = Rotation.from_rotvec(np.outer(np.radians(sweep_deg) * ((t - t[0]) / pass_s - 0.5), axis)).apply(start)
        rho = 1.5e6 + 5e5 * np.abs(np.linspace(-1.0, 1.0, n))
        geometry.append((t, np.tile(sun, (n, 1)), obs, np.full(n, 1.496e11), rho))
    return geometry


def test_known_shape_recovers_pole_period_and_sense():
    rng = np.random.default_rng(11)
    truth = SpinState(pole_from_radec(1.0, 0.6), 60.0, 0.3, EPOCH)
    curves = _observe_curves(truth, ELLIPSOID, _passes(rng), rng)
    seen = []
    res = invert(curves, ELLIPSOID, (59.7, 60.3), progress=lambda i, n: seen.append((i, n)), **FAST)
    best = res.best
    assert _angle_deg(best.pole_I, truth.pole_I) < 3.0
    assert best.contains(truth.pole_I, level=0.997)  # within the stated 3σ region (χ²₂)
    assert abs(best.period_s - 60.0) < 3 * best.period_sigma_s
    assert best.pole_sigma_deg < 2.0 and best.period_sigma_s < 0.01
    # the ellipsoid is symmetric under z -> −z: the spin axis is ±z
    assert abs(best.state.axis_T[2]) > 0.99
    # the sense: nothing credible near the reversed pole
    assert sum(s.probability for s in res.solutions if _angle_deg(s.pole_I, -truth.pole_I) < 20) < 1e-3
    assert sum(s.probability for s in res.solutions) == pytest.approx(1.0)
    # χ² is consistent with the noise (the exact model): within 4σ of the dof
    assert abs(best.chi2 - res.dof) < 4 * np.sqrt(2 * res.dof)
    assert seen[-1][0] == seen[-1][1] and all(b[0] >= a[0] for a, b in zip(seen, seen[1:]))


def test_pole_profile_follows_the_modes_gaussian_near_its_optimum():
    """Near a well-determined optimum the likelihood is quadratic, so the profile over everything but the pole equals the
    pole's marginal Mahalanobis distance: a pole moved k σ along either principal direction of the mode's pole covariance
    (the Gauss–Newton Hessian, computed once at the optimum) refits (rate, phase, axis) to Δχ²/s = k² (to 15 %), and the
    profile-likelihood level of that pole is F_χ²₂(k²)."""
    rng = np.random.default_rng(11)
    truth = SpinState(pole_from_radec(1.0, 0.6), 60.0, 0.3, EPOCH)
    curves = _observe_curves(truth, ELLIPSOID, _passes(rng), rng)
    res = invert(curves, ELLIPSOID, (59.7, 60.3), **FAST)
    best = res.best
    assert pole_profile_chi2(curves, ELLIPSOID, res, best.pole_I)[0] == pytest.approx(best.chi2, abs=1e-6)
    evals, evecs = np.linalg.eigh(best.covariance[:2, :2])
    e1, e2 = pole_frame(best.pole_I)[:, 0], pole_frame(best.pole_I)[:, 1]
    for k, j in ((2.0, 0), (2.0, 1), (1.0, 1)):
        t = k * np.sqrt(evals[j]) * evecs[:, j]  # tangent offset (t₁, t₂), rad
        pole = np.cos(np.linalg.norm(t)) * best.pole_I + np.sin(np.linalg.norm(t)) * (t[0] * e1 + t[1] * e2) / np.linalg.norm(t)
        chi2_p, state = pole_profile_chi2(curves, ELLIPSOID, res, pole)
        assert np.allclose(state.pole_I, pole, atol=1e-12)
        assert (chi2_p - best.chi2) / res.chi2_scale == pytest.approx(k**2, rel=0.15)
        assert res.profile_level(chi2_p) == pytest.approx(chi2_dist.cdf(k**2, 2), abs=0.05)
    for bad, match in (([0.0, 0.0, 0.0], "pole_I"), ([np.nan, 0.0, 1.0], "pole_I"), ([1.0, 0.0], "pole_I")):
        with pytest.raises(ValueError, match=match):
            pole_profile_chi2(curves, ELLIPSOID, res, bad)
    with pytest.raises(ValueError, match="n_starts"):
        pole_profile_chi2(curves, ELLIPSOID, res, best.pole_I, n_starts=0)
    assert np.isnan(res.profile_level(best.chi2 - 5.0))  # below the best: a missed optimum, no region describes it


def test_pole_profile_region_is_the_modes_ellipse_where_the_likelihood_is_quadratic():
    """The mapped region (:func:`pole_profile_region`) on the exact ellipsoid model with 3 nights. Near a mode the
    profile is its Gaussian's quadratic form plus higher orders: here the likelihood is skewed along the pole's best-known
    direction (Λ 0.68 and 1.08 one σ either side), so the even part, (Λ(x) + Λ(−x))/2 = xᵀΣ⁻¹x + O(|x|⁴), is what must equal
    the pole's marginal Mahalanobis distance from the mode (the profile of a Gaussian is its Schur complement; to 20 % + 0.2
    at every grid node and its mirror within the 99 % ellipse). The 95 % region's area is the 95 % ellipse's
    π χ²₂(0.95) √det Σ (to 35 %: a grid of one-σ cells), the fill closes, and its poles do not depend on the threads."""
    rng = np.random.default_rng(11)
    truth = SpinState(pole_from_radec(1.0, 0.6), 60.0, 0.3, EPOCH)
    curves = _observe_curves(truth, ELLIPSOID, _passes(rng), rng)
    res = invert(curves, ELLIPSOID, (59.7, 60.3), **FAST)
    best = res.best
    seen = []
    region = pole_profile_region(curves, ELLIPSOID, res, workers=1, progress=lambda n, m: seen.append(n))
    assert region.complete and seen[-1] == region.chi2.size and region.chi2.size >= 30
    own = np.array([abs(st.axis_T @ best.state.axis_T) > 0.9 for st in region.states])  # the mode's body axis (the others are branches of their own)
    assert 0 < (~own).sum() < own.sum()
    lam = (region.chi2[own] - region.chi2_min) / region.chi2_scale
    cov_inv = np.linalg.inv(best.pole_covariance_rad2)
    offsets = np.array([tangent_offset(best.pole_I, p) for p in region.poles_I[own]])
    maha2 = np.einsum("ni,ij,nj->n", offsets, cov_inv, offsets)
    mirror = np.argmin(np.linalg.norm(offsets[:, None, :] + offsets[None, :, :], axis=2), axis=1)  # the node at −x
    pairs = (np.linalg.norm(offsets + offsets[mirror], axis=1) < 1e-3 * np.sqrt(np.trace(best.pole_covariance_rad2))) & (maha2 < chi2_dist.ppf(0.99, 2))
    assert pairs.sum() >= 20
    even = 0.5 * (lam + lam[mirror])
    assert np.all(np.abs(even[pairs] - maha2[pairs]) <= 0.2 * maha2[pairs] + 0.2)
    assert region.level_at(best.pole_I) < 1e-3
    ellipse_deg2 = np.pi * chi2_dist.ppf(0.95, 2) * np.sqrt(np.linalg.det(best.pole_covariance_rad2)) * np.degrees(1.0) ** 2
    assert region.solid_angle_deg2(0.95) == pytest.approx(ellipse_deg2, rel=0.35)
    assert np.all(region.level[region.inside(0.68)] <= 0.68) and region.inside(0.95).sum() > region.inside(0.68).sum()
    # a pole's level is its cell's: at each mapped node its own, far away 1 (outside the map)
    assert all(region.level_at(p) == pytest.approx(lv) for p, lv in zip(region.poles_I[own][:10], region.level[own][:10]))
    # between nodes, bilinear in Λ: within (|Λ_11| + |Λ_22|)/8 = 0.5 of the pointwise profile (and the skew above)
    lead, A, _ = region.grids[0]
    for u in ((0.5, 0.5), (1.3, -0.7), (-2.2, 0.4)):
        x = A @ np.array(u)
        pole = tangent_exp(lead, x)
        lam_true = (pole_profile_chi2(curves, ELLIPSOID, res, pole)[0] - region.chi2_min) / region.chi2_scale
        assert chi2_dist.ppf(region.level_at(pole), 2) == pytest.approx(lam_true, abs=0.5 + 0.2 * lam_true)
    assert region.level_at(-best.pole_I) == 1.0 and region.level_at(np.cross(best.pole_I, [0.0, 0.0, 1.0])) == 1.0
    two = pole_profile_region(curves, ELLIPSOID, res, workers=2)
    assert np.array_equal(two.poles_I, region.poles_I) and np.array_equal(two.chi2, region.chi2)
    cut = pole_profile_region(curves, ELLIPSOID, res, max_poles=5)
    assert not cut.complete and cut.chi2.size == 5  # restarted on coarser grids until every step is at max_step_deg
    assert cut.step_sigmas * np.degrees(np.sqrt(np.linalg.eigvalsh(best.pole_covariance_rad2)[0])) >= 5.0 and region.step_sigmas == 1.0
    for bad, match in ((dict(max_level=1.0), "max_level"), (dict(max_poles=0), "max_poles"), (dict(max_step_deg=0.0), "max_step_deg")):
        with pytest.raises(ValueError, match=match):
            pole_profile_region(curves, ELLIPSOID, res, **bad)


def test_relative_and_calibrated_curves_mix():
    """One calibrated night fixes the reflectance (truth 1); the relative nights' scales are 1/mean flux."""
    rng = np.random.default_rng(12)
    truth = SpinState(pole_from_radec(4.0, -0.3), 45.0, 1.0, EPOCH)
    geometry = _passes(rng)
    curves = _observe_curves(truth, ELLIPSOID, geometry, rng, calibrated=[False, True, False])
    best = invert(curves, ELLIPSOID, (44.8, 45.2), **FAST).best
    assert _angle_deg(best.pole_I, truth.pole_I) < 3.0 and best.contains(truth.pole_I, level=0.997)
    assert best.weights[0] == pytest.approx(1.0, rel=0.03)
    assert best.scales[1] == 1.0
    for k in (0, 2):  # relative brightness = flux / mean flux, so the fitted factor is 1 / mean flux
        B = ELLIPSOID.basis(*body_directions(truth, curves[k]))[:, 0]
        mean_flux = observed_flux(B, curves[k].range_m, curves[k].sun_distance_m).mean()
        assert best.scales[k] * mean_flux == pytest.approx(1.0, rel=0.03)


def test_mirror_pole_is_reported_for_coplanar_geometry():
    """Sun and observer in one plane (here I's xy-plane): a pole p and its mirror (−p_x, −p_y, p_z) give the same light
    curves for a mirror-symmetric shape (Kaasalainen & Lamberg, Inverse Problems 22, 2006); both are reported."""
    rng = np.random.default_rng(13)
    truth = SpinState(pole_from_radec(0.7, 0.5), 50.0, 0.0, EPOCH)
    mirror = truth.pole_I * np.array([-1.0, -1.0, 1.0])
    curves = _observe_curves(truth, ELLIPSOID, _passes(rng, coplanar=True), rng)
    res = invert(curves, ELLIPSOID, (49.8, 50.2), **FAST)
    near_truth = [s for s in res.solutions if _angle_deg(s.pole_I, truth.pole_I) < 5]
    near_mirror = [s for s in res.solutions if _angle_deg(s.pole_I, mirror) < 5]
    assert near_truth and near_mirror
    assert sum(s.probability for s in near_truth) > 0.05 and sum(s.probability for s in near_mirror) > 0.05
    assert abs(near_truth[0].chi2 - near_mirror[0].chi2) < 5.0


def test_unknown_convex_shape_and_brute_force_grid():
    """Unknown shape (free facet areas) on ellipsoid data; then a dense grid of the SAME profiled likelihood around the
    solution finds no lower χ² than the refinement and its minimum next to it."""
    rng = np.random.default_rng(14)
    truth = SpinState(pole_from_radec(2.5, 0.2), 60.0, 0.0, EPOCH)
    model = ConvexModel(60)
    curves = _observe_curves(truth, ELLIPSOID, _passes(rng), rng, noise=0.05)
    best = invert(curves, model, (59.8, 60.2), **FAST).best
    # the search finds a fit at least as good as the truth's: with free areas three passes leave the pole loosely
    # determined (measured 7–26° errors on such data, beyond the Gauss–Newton σ of ~1°), so no pole bound here
    assert best.chi2 <= profiled_chi2(curves, model, truth)[0] + 1.0
    assert abs(best.chi2 - 300) < 4 * np.sqrt(2 * 300)
    # brute force around the optimum: pole offsets along the two tangent axes × periods, ±3σ
    C = np.linalg.cholesky(best.covariance)
    e = pole_frame(best.pole_I)
    grid = np.linspace(-3, 3, 7)
    chi2 = {}
    for a in grid:
        for b in grid:
            for c in grid:
                dt = C @ np.array([a, b, c])
                pole = best.pole_I + dt[0] * e[:, 0] + dt[1] * e[:, 1]
                state = SpinState(pole, best.period_s + dt[2], best.state.phase_rad, best.state.epoch)
                chi2[(a, b, c)] = profiled_chi2(curves, model, state)[0]
    key = min(chi2, key=chi2.get)
    assert chi2[key] >= best.chi2 - 1e-6 * best.chi2 - 0.5
    assert max(abs(v) for v in key) <= 1.0  # the grid's minimum is one step (1σ) from the refined optimum at most


def test_ground_site_geometry_over_three_nights():
    """A LEO rocket-body-like ellipsoid (1200 km, i = 70°) seen from the default site on three evenings."""
    orbit = KeplerOrbit(a_m=6378e3 + 1200e3, e=0.0, i_rad=np.radians(70.0), raan_rad=np.radians(300.0))
    epoch = Time("2026-03-20T18:00:00", scale="utc")
    geometry = []
    for night in range(3):  # the first 240-s visible arc of each evening (30-s visibility grid)
        grid = night * 86400.0 + np.arange(0.0, 0.17 * 86400, 30.0)
        vis = observe(orbit, grid, epoch).visible
        run = np.convolve(vis.astype(int), np.ones(9, int), mode="valid") == 9
        start = grid[np.argmax(run)]
        ob = observe(orbit, start + np.linspace(0.0, 240.0, 100), epoch)
        assert run.any() and ob.visible.all()
        geometry.append((ob.t_s, ob.sun_dir_I, ob.observer_dir_I, ob.sun_distance_m, ob.range_m))
    rng = np.random.default_rng(15)
    truth = SpinState(pole_from_radec(3.0, -0.8), 40.0, 0.5, epoch, [1.0, 0.0, 0.0])
    curves = [InversionCurve(c.t_s, epoch, c.brightness, c.sigma, c.sun_dir_I, c.observer_dir_I, c.sun_distance_m, c.range_m)
              for c in _observe_curves(SpinState(truth.pole_I, 40.0, 0.5, EPOCH, truth.axis_T), ELLIPSOID, geometry, rng)]
    # the period known to 0.05 % (a user's synodic estimate, narrowed to keep the test short)
    res = invert(curves, ELLIPSOID, (39.98, 40.02), **FAST)
    best = res.best
    assert _angle_deg(best.pole_I, truth.pole_I) < 3.0 and best.contains(truth.pole_I, level=0.997)
    assert abs(best.period_s - 40.0) < 3 * best.period_sigma_s
    assert abs(best.state.axis_T[0]) > 0.99


def test_period_grid_step_is_a_quarter_turn_over_the_span():
    w = period_grid((10.0, 10.1), 1000.0)
    assert np.all(np.diff(w) * 1000.0 <= np.pi / 2 + 1e-12)
    assert w[0] == pytest.approx(2 * np.pi / 10.1) and w[-1] == pytest.approx(2 * np.pi / 10.0)


def test_laplace_probabilities_follow_chi2_and_volume():
    p = laplace_probabilities([10.0, 12.0], [0.0, 0.0], 1.0)
    assert p[0] / p[1] == pytest.approx(np.exp(1.0))
    p = laplace_probabilities([10.0, 10.0], [0.0, 2 * np.log(4.0)], 1.0)  # √det Σ four times larger
    assert p[1] / p[0] == pytest.approx(4.0)


def test_bad_input_names_the_field():
    rng = np.random.default_rng(1)
    curves = _observe_curves(SpinState([0, 0, 1.0], 60.0, 0.0, EPOCH), ELLIPSOID, _passes(rng, n=10), rng)
    with pytest.raises(ValueError, match="period_range_s"):
        invert(curves, ELLIPSOID, (60.0, 50.0))
    with pytest.raises(ValueError, match="period_range_s"):
        invert(curves, ELLIPSOID, [(50.0, 60.0), (120.0, np.nan)])
    with pytest.raises(ValueError, match="period_range_s"):
        invert(curves, ELLIPSOID, "50,60")
    with pytest.raises(ValueError, match="curves"):
        invert([], ELLIPSOID, (50.0, 60.0))
    with pytest.raises(ValueError, match="pole_step_deg"):
        invert(curves, ELLIPSOID, (50.0, 60.0), pole_step_deg=0.0)


@pytest.mark.slow
def test_credible_regions_are_calibrated():
    """20 objects, random poles and phases: the truth falls in the best mode's 68 % and 95 % regions (pole and period,
    χ²₃), and its pole in the profile-likelihood regions (:func:`pole_profile_chi2`), at rates within the binomial 99 % bounds."""
    rng = np.random.default_rng(2026)
    n = 20
    inside = {0.68: 0, 0.95: 0}
    profile = {0.68: 0, 0.95: 0}
    for _ in range(n):
        pole = rng.normal(size=3)
        truth = SpinState(pole / np.linalg.norm(pole), 60.0 + rng.uniform(-0.1, 0.1), rng.uniform(0, 2 * np.pi), EPOCH)
        curves = _observe_curves(truth, ELLIPSOID, _passes(rng, n=60), rng)
        res = invert(curves, ELLIPSOID, (59.8, 60.2), rng=rng, **FAST)
        # the mode containing the truth is the one to score (a mirror may be listed first)
        best = min(res.solutions, key=lambda s: s.mahalanobis2(truth.pole_I, truth.period_s))
        level_truth = res.profile_level(pole_profile_chi2(curves, ELLIPSOID, res, truth.pole_I)[0])
        for level in inside:
            inside[level] += best.contains(truth.pole_I, truth.period_s, level=level)
            profile[level] += level_truth <= level
    for level, k in [*inside.items(), *profile.items()]:
        lo, hi = binom.ppf(0.005, n, level), binom.ppf(0.995, n, level)
        assert lo <= k <= hi, (level, k)


@pytest.mark.parametrize("calibrated", [[True, True, True], [False, True, False]])
def test_analytic_jacobian_of_the_profiled_residuals_equals_central_differences(calibrated):
    """The known shape's Jacobian of the profiled residuals in θ (pole-frame rotation, rate, body axis; the linear scale and
    the relative curves' scales re-solved) from the model's rotation gradient equals central differences of the residuals,
    to 1e-5 of each column's largest entry (measured ≤ 3e-7: the differences' own error), away from θ = 0."""
    from scipy.spatial.transform import Rotation

    from lightcurves.inversion.known_shape import KnownShapeModel
    from lightcurves.inversion.search import _Problem, _stack
    from lightcurves.inversion.spin import axis_frame
    from lightcurves.targets import get_target

    model = KnownShapeModel.from_target(get_target("atlas-centaur"))
    rng = np.random.default_rng(21)
    truth = SpinState(pole_from_radec(2.0, 0.4), 80.0, 0.7, EPOCH, [1.0, 0.0, 0.0])
    curves = _observe_curves(truth, model, _passes(rng, n=80), rng, calibrated=calibrated)
    C_IP0 = pole_frame(truth.pole_I) @ Rotation.from_rotvec([0.0, 0.0, 0.7]).as_matrix()
    problem = _Problem(_stack(curves), model, C_IP0, truth.rate_rad_s, axis_frame(truth.axis_T), True, True)
    assert problem.analytic
    theta = np.array([0.02, -0.03, 0.05, 0.3, 0.02, -0.01])
    r, J = problem.residuals_and_jacobian(theta)
    problem.analytic = False  # the central differences of the residuals themselves
    np.testing.assert_array_equal(r, problem.residuals(theta))
    fd = problem.jacobian(theta, step=1e-6)
    assert np.all(np.abs(J - fd).max(axis=0) <= 1e-5 * np.abs(fd).max(axis=0)), np.abs(J - fd).max(axis=0) / np.abs(fd).max(axis=0)


def test_the_result_does_not_depend_on_the_number_of_worker_threads():
    """A stage's independent fits run on ``workers`` threads and are taken in their order: the known-shape search (box-wing,
    its facet kernel run from several threads at once) gives the same modes, χ² and states with 1 and 3 threads, and so
    does the pole's profile."""
    from lightcurves.inversion.known_shape import KnownShapeModel
    from lightcurves.targets import get_target

    model = KnownShapeModel.from_target(get_target("box-wing"))
    rng = np.random.default_rng(21)
    truth = SpinState(pole_from_radec(2.0, 0.4), 120.0, 0.5, EPOCH)
    curves = _observe_curves(truth, model, _passes(rng, n=60, nights=2), rng)
    one, three = (invert(curves, model, (119.0, 121.0), workers=w, **FAST) for w in (1, 3))
    assert len(one.solutions) == len(three.solutions) >= 1
    for a, b in zip(one.solutions, three.solutions):
        assert a.chi2 == b.chi2 and a.probability == b.probability
        np.testing.assert_array_equal(a.state.pole_I, b.state.pole_I)
        np.testing.assert_array_equal(a.state.axis_T, b.state.axis_T)
        assert a.state.period_s == b.state.period_s
    with pytest.raises(ValueError, match="workers"):
        invert(curves, model, (119.0, 121.0), workers=0, **FAST)
    # the pole's profile: its starts' fits on threads too
    elsewhere = pole_from_radec(0.5, -0.2)
    (c1, s1), (c3, s3) = (pole_profile_chi2(curves, model, one, elsewhere, n_starts=1, max_nfev=20, workers=w) for w in (1, 3))
    assert c1 == c3 and s1.period_s == s3.period_s
    np.testing.assert_array_equal(s1.axis_T, s3.axis_T)


def test_a_held_pole_fit_whose_rate_runs_through_zero_is_no_profile_point(monkeypatch):
    """A held-pole fit of one short night at a far pole can drive the rate through zero (the inversion benchmark's one-night
    vespa: a period of −8700 s, and the whole region map raised). Such a fit is no spin state the search considers: the
    profile there is infinite (outside every region) and the state handed on is the fit's start, whose rate is positive."""
    from scipy.optimize import OptimizeResult

    from lightcurves.inversion import profile as P
    from lightcurves.inversion.search import _pole_phase_frame, _stack
    from lightcurves.inversion.spin import axis_frame

    rng = np.random.default_rng(5)
    truth = SpinState(pole_from_radec(1.0, 0.6), 60.0, 0.3, EPOCH)
    curves = _observe_curves(truth, ELLIPSOID, _passes(rng, nights=1), rng)
    data = _stack(curves)
    start = (_pole_phase_frame(truth, data.epoch), truth.rate_rad_s, axis_frame(truth.axis_T))
    chi2, state = P._held_fit(data, ELLIPSOID, False, start, 20)
    assert np.isfinite(chi2) and state.period_s == pytest.approx(60.0, rel=1e-3)  # the fit itself, unharmed
    tau = np.abs(data.t_s).max()
    ran_off = OptimizeResult(x=np.array([-2.0 * truth.rate_rad_s * tau]), cost=1.0)  # (x_ω): a convex model absorbs the phase
    monkeypatch.setattr(P, "least_squares", lambda *a, **k: ran_off)
    chi2, state = P._held_fit(data, ELLIPSOID, False, start, 20)
    assert chi2 == np.inf and state.period_s == pytest.approx(60.0)


def test_several_period_ranges_are_searched_as_one():
    """P and 2P (one night cannot tell a single-peaked rotation from half a double-peaked one) in one search: its best is
    the right range's own search's best (the wrong range first), no mode of the wrong range is listed (its best
    fit is far beyond reach), the pole map holds both ranges' screens (each pole once), and the progress bar counts both and ends full."""
    rng = np.random.default_rng(11)
    truth = SpinState(pole_from_radec(1.0, 0.6), 60.0, 0.3, EPOCH)
    curves = _observe_curves(truth, ELLIPSOID, _passes(rng), rng)
    right, wrong = (59.7, 60.3), (119.4, 120.6)
    one = invert(curves, ELLIPSOID, right, rng=np.random.default_rng(3), **FAST)
    seen = []
    both = invert(curves, ELLIPSOID, [wrong, right], rng=np.random.default_rng(3), progress=lambda i, n: seen.append((i, n)), **FAST)
    assert both.best.chi2 == pytest.approx(one.best.chi2, rel=1e-6)
    assert _angle_deg(both.best.pole_I, one.best.pole_I) < 0.01
    assert all(right[0] < s.period_s < right[1] for s in both.solutions)
    at_2p = both.period_map_s > 90.0
    assert at_2p.any() and (~at_2p).any() and both.pole_grid_I.shape[0] > one.pole_grid_I.shape[0]
    assert np.unique(both.pole_grid_I, axis=0).shape[0] == both.pole_grid_I.shape[0]  # a pole screened in both ranges once
    assert both.chi2_map[at_2p].min() > 2 * both.chi2_map[~at_2p].min()  # 124 against 30 on the tempered grid samples
    done = [i for i, _ in seen]
    assert done == sorted(done) and seen[-1][0] == seen[-1][1]


def test_a_flat_comb_weighs_every_tooth_once():
    """:func:`_comb_cells`: with χ² the same at every fitted tooth, each of the comb's teeth weighs 1 and counts for the nearest
    fitted one (so the comb's evidence factor is the number of teeth); a tooth Δχ² = 2 s higher weighs e⁻¹."""
    n_eval = np.array([0, -1, 1, -3, 3, -7, 9])
    cells = _comb_cells(n_eval, np.full(n_eval.size, 100.0), -7, 9, 1.3)
    assert cells.sum() == pytest.approx(17.0)
    assert cells[list(n_eval).index(9)] == pytest.approx(3.0)  # 7, 8, 9 (6 is as near 3 as 9 and counts for 3)
    raised = _comb_cells(np.array([0, 1]), np.array([10.0, 10.0 + 2 * 1.3]), 0, 1, 1.3)
    assert raised[1] / raised[0] == pytest.approx(np.exp(-1.0))


@pytest.mark.parametrize("seed", [0, 2])
def test_cycle_count_aliases_are_one_mode_as_wide_as_their_comb(seed):
    """Two passes a day apart of a 60-s spinner, the period searched over ±1 % (28 teeth ω + 2πn/Δt, 0.042 s apart): the
    teeth near the truth fit alike, so the most probable mode is the comb moment-matched (:func:`_comb_moments`): the truth
    (pole and period) inside its 99 % region, its period σ (0.022 and 0.035 s) a good part of a tooth's spacing. Without the
    comb (each tooth its own mode, its period σ 1e-4 s): seed 0 put the truth's tooth at probability 0.21, seed 2 missed it
    (Mahalanobis² 7.9e4)."""
    rng = np.random.default_rng(seed)
    pole = rng.normal(size=3)
    truth = SpinState(pole / np.linalg.norm(pole), 60.0, rng.uniform(0, 2 * np.pi), EPOCH)
    curves = _observe_curves(truth, ELLIPSOID, _passes(rng, n=60, gap_s=86400.0, nights=2), rng)
    res = invert(curves, ELLIPSOID, (59.4, 60.6), rng=rng, **FAST)
    assert res.best.mahalanobis2(truth.pole_I, truth.period_s) <= chi2_dist.ppf(0.99, 3)
    assert res.best.period_sigma_s > 0.25 * 60.0**2 / 86400.0
