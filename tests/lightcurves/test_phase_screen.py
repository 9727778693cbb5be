"""The known-shape phase screen (lightcurves.inversion.phase_screen) against the exact profiled likelihood.

Where the screen needs no approximation — one rate, equal to its node, and every curve's mid-time phase on the
phase grid — its χ² must be the exact profiled χ² of :func:`lightcurves.inversion.search.profiled_chi2` minimised
over the grid's phases and the body axes, with the calibrated curves sharing one scale and each relative curve its own.
"""

import numpy as np
import pytest
from astropy.time import Time
from scipy.spatial.transform import Rotation

from lightcurves.inversion.convex import EllipsoidModel
from lightcurves.inversion.data import InversionCurve
from lightcurves.inversion.phase_screen import _combine, rate_nodes, screen_phases
from lightcurves.inversion.search import _stack, profiled_chi2
from lightcurves.inversion.spin import SpinState, body_directions
from lightcurves.render import observed_flux

EPOCH = Time("2026-01-01T00:00:00", scale="utc")
MODEL = EllipsoidModel(3.0, 2.0, 1.5, n_facets=200)
M = 24


def _curves(rng, truth, gap_s=5000.0, n=50, arc_s=100.0, calibrated=(True, False)):
    """Two arcs with the same sample offsets, ``gap_s`` apart (mid-times ±gap/2 from the span's middle), calibrated or relative."""
    t = np.linspace(0.0, arc_s, n)
    out = []
    for k, cal in enumerate(calibrated):
        sun = np.tile([1.0, 0.0, 0.0], (n, 1))
        obs = Rotation.from_rotvec(np.outer(np.radians(30 + 20 * k + 0.2 * t), [0.2, 0.3, 0.93])).apply([1.0, 0.0, 0.0])
        d, rho = np.full(n, 1.496e11), np.full(n, 2.0e7)
        template = InversionCurve(t + k * gap_s, EPOCH, np.ones(n), np.ones(n), sun, obs, d, rho, calibrated=cal)
        f = observed_flux(MODEL.basis(*body_directions(truth, template))[:, 0], rho, d)
        sigma = 0.02 * f.mean() * np.ones(n)
        y = np.abs(f + sigma * rng.standard_normal(n)) * (1.0 if cal else 3.7)
        out.append(InversionCurve(t + k * gap_s, EPOCH, y, sigma * (1.0 if cal else 3.7), sun, obs, d, rho, calibrated=cal))
    return out


@pytest.mark.parametrize("calibrated", [(True, True), (False, False), (True, False)])
def test_screen_equals_the_exact_profiled_chi2_on_its_grid(calibrated):
    """Calibrated curves share the scale, relative ones each have their own; the screen and the search's closed-form profile
    (``search._one_column_solve``) are both the exact minimum over the scales, mixed curves included (the search's former
    joint NNLS, which fitted the shape's scale to the relative curves too, was up to 1 % above it there)."""
    rng = np.random.default_rng(3)
    gap = 5000.0
    omega = 2 * np.pi * 401 / (M * gap / 2)  # the mid-time phases ±ω·gap/2 fall on the grid (401 steps); P = 150 s
    truth = SpinState([0.3, -0.5, 0.81], 2 * np.pi / omega, 0.7, EPOCH)
    curves = _curves(rng, truth, gap, calibrated=calibrated)
    data = _stack(curves)
    poles = np.array([truth.pole_I, [0.0, 0.6, 0.8], [-0.6, 0.0, -0.8]])
    axes = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0]])
    screen = screen_phases(data, MODEL, poles, axes, np.array([omega]), n_phases=M)
    phases = np.arange(M) * 2 * np.pi / M
    for ip, pole in enumerate(poles):
        exact = np.array([[profiled_chi2(curves, MODEL, SpinState(pole, 2 * np.pi / omega, ph, data.epoch, ax))[0] for ph in phases] for ax in axes])
        ia, ij = np.unravel_index(np.argmin(exact), exact.shape)
        assert screen.chi2[ip, 0] == pytest.approx(exact[ia, ij], rel=1e-6)
        assert screen.axis_index[ip, 0] == ia and screen.phase_rad[ip, 0] == pytest.approx(phases[ij])


def test_rate_nodes_bound_the_drift_within_a_curve():
    omegas = np.linspace(0.10, 0.11, 500)
    for half, tol in ((50.0, 0.1), (300.0, 0.02), (1e-3, 0.1)):
        nodes, node_of = rate_nodes(omegas, half, tol)
        assert np.max(np.abs(omegas - nodes[node_of])) * half <= tol * (1 + 1e-9)
        assert nodes.size == max(1, int(np.ceil(0.01 * half / (2 * tol))))
    with pytest.raises(ValueError, match="n_phases: 2: expected an integer >= 4"):
        screen_phases(_stack(_curves(np.random.default_rng(0), SpinState([0, 0, 1], 60.0, 0.0, EPOCH))), MODEL, np.array([[0, 0, 1.0]]),
                      np.array([[0, 0, 1.0]]), np.array([0.1]), n_phases=2)


class _Glint:
    """A known shape of unit diffuse brightness with a specular lobe of ``amplitude`` and Gaussian ``width_rad`` in the
    observer's body azimuth about +x_T (a glint, like a flat panel's; ``basis`` (N, 1) as the screen requires)."""

    def __init__(self, amplitude: float, width_rad: float):
        self.amplitude, self.width_rad = amplitude, width_rad

    def basis(self, sun_T, obs_T):
        azimuth = np.arctan2(obs_T[:, 1], obs_T[:, 0])
        return (1.0 + self.amplitude * np.exp(-0.5 * (azimuth / self.width_rad) ** 2))[:, None]


@pytest.mark.parametrize("sub_step", [0.25, 0.5, 0.75])
def test_screen_chi2_is_never_negative_next_to_a_glint(sub_step):
    """χ² = Σ(y − w b)²/σ² minimised over w ≥ 0 is a sum of squares: ≥ 0 at every (pole, rate, axis, phase), however
    the screen interpolates between its grid phases. A glint 4° wide (under the 15° step of M = 24 phases) that the data
    did not catch (y the diffuse part only) makes S_BB a sharp peak in phase; the Catmull–Rom cubic undershoots beside
    it, and S_yB²/S_BB then broke Cauchy–Schwarz on the code before the screen's guard (merge 'invspeed'): χ² down to
    −2.8e5 here (S_yy = 8e5), −2.7e10 on a 3-night atlas-centaur campaign, where it sent the search 42° off."""
    n, gap = 40, 4000.0
    # the curves' mid-time phases ±ω·gap/2 fall ``sub_step`` of a grid step past a grid phase (3 + sub_step steps of 2π/M, mod 2π)
    omega = (2 * np.pi * 50 + (3 + sub_step) * 2 * np.pi / M) / (gap / 2)
    t = np.linspace(-5.0, 5.0, n)
    curves = [InversionCurve(t + k * gap, EPOCH, np.ones(n), np.full(n, 0.01), np.tile([0.0, 1.0, 0.0], (n, 1)), np.tile([1.0, 0.0, 0.0], (n, 1)),
                             np.full(n, 1.496e11), np.full(n, 2.0e7), calibrated=False) for k in range(2)]
    data = _stack(curves)
    S_yy = float(np.sum((data.y / data.sigma) ** 2))
    z = np.array([[0.0, 0.0, 1.0]])
    for amplitude in np.geomspace(10.0, 1e4, 13):
        screen = screen_phases(data, _Glint(amplitude, np.radians(4.0)), z, z, np.array([omega]), n_phases=M)
        assert screen.chi2.min() >= -1e-12 * S_yy, amplitude


def test_combine_is_the_closed_form_profile_at_every_phase():
    """``_combine`` against the module docstring's χ² written out in numpy: for each (pole, rate) the minimum over axes and
    grid phases of Σ_cal S_yy − max(Σ_cal S_yB, 0)²/Σ_cal S_BB + Σ_rel (S_yy,k − max(S_yB,k, 0)²/S_BB,k), curve k read at its
    rate's node and at grid phase (shift_k + j) mod M. Whole-step shifts (the sub-step tables then hold the grid values), some
    near M so that the reads wrap around; calibrated and relative curves mixed."""
    rng = np.random.default_rng(11)
    K, n_a, n_p, n_node, n_w, m = 3, 2, 3, 4, 9, 12
    S_BB = rng.uniform(0.5, 2.0, (K, n_a, n_p, n_node, m))
    S_yB = rng.uniform(-0.3, 1.0, (K, n_a, n_p, n_node, m)) * np.sqrt(S_BB)  # some negative: the scale's bound w ≥ 0 acts
    S_yy = np.array([2.0, 3.0, 2.5])
    relative = np.array([False, True, False])
    node_of = rng.integers(0, n_node, (K, n_w))
    shift = rng.integers(0, m, (K, n_w)).astype(float)
    shift[:, 0] = m - 1
    chi2, best = np.empty((n_p, n_w)), np.empty((n_p, n_w), np.int64)
    _combine(S_yB, S_BB, S_yy, relative, node_of, shift, chi2, best)
    for p in range(n_p):
        for w in range(n_w):
            idx = (shift[:, w, None].astype(int) + np.arange(m)) % m  # (K, m)
            yb = np.stack([S_yB[k, :, p, node_of[k, w]][:, idx[k]] for k in range(K)])  # (K, n_a, m)
            bb = np.stack([S_BB[k, :, p, node_of[k, w]][:, idx[k]] for k in range(K)])
            cal = ~relative
            c2 = S_yy[cal].sum() - np.maximum(yb[cal].sum(0), 0) ** 2 / bb[cal].sum(0)
            c2 = c2 + sum(S_yy[k] - np.maximum(yb[k], 0) ** 2 / bb[k] for k in np.flatnonzero(relative))
            assert chi2[p, w] == pytest.approx(c2.min(), rel=1e-12)
            assert best[p, w] == np.argmin(c2)  # axis · m + phase index
