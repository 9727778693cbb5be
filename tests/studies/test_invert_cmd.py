"""``lcnav lightcurve invert``: a known spin state recovered from synthetic nights, its files, and its refusals.

The curves are made with the inversion's own forward model (a triaxial ellipsoid, Lommel–Seeliger +
Lambert facets) turned by a known :class:`SpinState` and seen from a real ground site (ESA's OGS at Teide)
watching lcnav's default GPS-disposal orbit: three 10-minute arcs, two in one night and one the next,
spanning 100° to 30° of phase angle. They are written as DAMIT/convexinv text, the field's format.
"""

import json

import astropy.units as u
import numpy as np
import pandas as pd
import pytest
from astropy.time import Time

from lightcurves.geometry import DEFAULT_SITE, find_visible_start, observe
from lightcurves.inversion import InversionCurve
from lightcurves.inversion.convex import EllipsoidModel
from lightcurves.inversion.io import damit_text
from lightcurves.inversion.frames import pole_from_ecliptic, pole_from_radec
from lightcurves.inversion.spin import SpinState, body_directions
from lightcurves.render import observed_flux
from lightcurves.simulate import DEFAULT_ORBIT
from studies.cli import main
from studies.engine.io import COMPLETE_FILE
from tests.rerun_cli import assert_rrd_verifies, blueprint_views

SEMI_AXES_M = (3.0, 1.5, 1.0)
PERIOD_S = 120.0
NOISE = 0.01  # relative 1-σ of each brightness
#: Arc starts, h after 2024-03-21T18:00 UTC: the pass's phase angle falls from ~100° to ~30° over each night.
ARC_STARTS_H = (2.2, 3.6, 28.6)
ARC_S = 600.0


def _arcs(rng, n_per_arc=80):
    """Geometry-only curves (unit brightness) of the three arcs from the OGS."""
    epoch = Time("2024-03-21T18:00:00", scale="utc")
    out = []
    for h in ARC_STARTS_H:
        ep = epoch + h * u.h
        t0 = find_visible_start(DEFAULT_ORBIT, ep, ARC_S, DEFAULT_SITE, search_s=3 * 3600.0)
        t = t0 + np.sort(rng.uniform(0.0, ARC_S, n_per_arc))
        o = observe(DEFAULT_ORBIT, t, ep, DEFAULT_SITE)
        ones = np.ones(t.size)
        out.append(InversionCurve(t_s=t - t0, epoch=ep + t0 * u.s, brightness=ones, sigma=ones, sun_dir_I=o.sun_dir_I,
                                  observer_dir_I=o.observer_dir_I, sun_distance_m=o.sun_distance_m, range_m=o.range_m))
    return out


def _observe(geometry, state, rng):
    """Relative curves (brightness / its mean, 1 % noise) of the ellipsoid spinning as ``state`` over ``geometry``."""
    model = EllipsoidModel(*SEMI_AXES_M, n_facets=1000)
    out = []
    for c in geometry:
        sun_T, obs_T = body_directions(state, c)
        f = observed_flux(model.basis(sun_T, obs_T)[:, 0], c.range_m, c.sun_distance_m)
        f = f / f.mean()
        y = f * (1.0 + NOISE * rng.standard_normal(f.size))
        out.append(InversionCurve(t_s=c.t_s, epoch=c.epoch, brightness=y, sigma=NOISE * f, sun_dir_I=c.sun_dir_I, observer_dir_I=c.observer_dir_I,
                                  sun_distance_m=c.sun_distance_m, range_m=c.range_m, calibrated=False))
    return out


def _angle_deg(a, b):
    return float(np.degrees(np.arccos(np.clip(np.dot(a, b) / np.linalg.norm(a) / np.linalg.norm(b), -1.0, 1.0))))


def _period_arg(lo=0.995, hi=1.005):
    return f"{lo * PERIOD_S / 3600:.8f},{hi * PERIOD_S / 3600:.8f}"


TRUE_POLE_I = pole_from_radec(np.radians(40.0), np.radians(35.0))


@pytest.fixture(scope="module")
def inverted(tmp_path_factory):
    """One run of ``invert --json --out --record`` on three arcs of a known ellipsoid (known-shape mode)."""
    rng = np.random.default_rng(11)
    geometry = _arcs(rng)
    state = SpinState(TRUE_POLE_I, PERIOD_S, 1.1, geometry[0].epoch)
    tmp = tmp_path_factory.mktemp("invert")
    lcs = tmp / "three_arcs.txt"
    lcs.write_text(damit_text(_observe(geometry, state, rng)))
    out, rrd = tmp / "out", tmp / "inv.rrd"
    argv = ["lightcurve", "invert", str(lcs), "--shape", "ellipsoid:" + ",".join(map(str, SEMI_AXES_M)), "--period-range-h", _period_arg(),
            "--quick", "--json", "--out", str(out), "--record", str(rrd)]  # fmt: skip
    return argv, geometry, out, rrd


@pytest.mark.slow
def test_invert_json_recovers_the_pole_and_period_within_the_reported_3_sigma(inverted, capsys):
    argv, geometry, _, _ = inverted
    assert main(argv) == 0
    cap = capsys.readouterr()
    doc = json.loads(cap.out)  # stdout is the JSON document alone
    sols = doc["solutions"]
    assert sols and abs(sum(s["probability"] for s in sols) - 1.0) < 1e-9
    assert [s["probability"] for s in sols] == sorted((s["probability"] for s in sols), reverse=True)
    best = sols[0]
    err = _angle_deg(best["pole_I"], TRUE_POLE_I)
    assert err <= max(3.0 * best["pole_sigma_deg"], 0.5), (err, best["pole_sigma_deg"])
    assert abs(best["sidereal_period_h"] - PERIOD_S / 3600) <= 3.0 * best["sidereal_period_sigma_h"]
    # the reported angles are the pole vector's, in both frames
    assert _angle_deg(pole_from_radec(np.radians(best["pole_ra_deg"]), np.radians(best["pole_dec_deg"])), best["pole_I"]) < 1e-6
    ecl = pole_from_ecliptic(np.radians(best["pole_ecliptic_lon_deg"]), np.radians(best["pole_ecliptic_lat_deg"]))
    assert _angle_deg(ecl, best["pole_I"]) < 1e-4  # obliquity-only vs IAU 2006 + frame bias: 1e-7 rad apart
    # a known shape reports the body spin axis: the ellipsoid turns about its short axis, body ±z (sense carried by the pole)
    assert abs(best["body_spin_axis_T"][2]) > np.cos(np.radians(3.0 * max(best["body_spin_axis_sigma_deg"] or 0.0, 1.0)))
    fit = doc["fit"]
    assert fit["n_points"] == sum(len(c) for c in geometry) and fit["n_curves"] == 3 and fit["n_relative"] == 3
    assert 0.7 < fit["chi2_per_dof"] < 1.3  # 1 % noise fitted by the true model: χ²/dof ~ 1 ± √(2/dof)
    assert doc["shape_mode"] == "known" and doc["period_ranges"][0]["source"].startswith("given")


@pytest.mark.slow
def test_out_folder_holds_the_tables_figures_and_a_verifying_recording(inverted, capsys):
    argv, geometry, out, rrd = inverted
    if not (out / COMPLETE_FILE).exists():
        assert main(argv) == 0
    capsys.readouterr()
    doc = json.loads((out / "inversion.json").read_text())
    table = pd.read_parquet(out / "solutions.parquet")
    assert len(table) == len(doc["solutions"]) and table["probability"].iloc[0] == pytest.approx(doc["solutions"][0]["probability"])
    assert pd.read_csv(out / "solutions.csv")["sidereal_period_h"].to_numpy() == pytest.approx(table["sidereal_period_h"].to_numpy())
    names = set(json.loads((out / COMPLETE_FILE).read_text())["files"])
    assert {"inversion.json", "solutions.csv", "solutions.parquet", "pole_posterior.png"} | {f"fit_night_{k}.png" for k in (1, 2, 3)} <= names
    for name in names - {"inversion.json", "solutions.csv", "solutions.parquet"}:
        assert (out / name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert_rrd_verifies(rrd)
    origins, queries = blueprint_views(rrd)
    assert "/inversion" in origins and "/inversion/summary" in origins
    assert {f"/lightcurve/night_{k}/fitted" for k in (1, 2, 3)} <= queries


def test_fitted_curves_reproduce_the_solution_chi2():
    """The fit figures' model (s_k g B w at the solution) gives back the search's own χ² for that solution."""
    from studies.catalog.inversion import PeriodRange, fitted_brightness, run_inversion

    rng = np.random.default_rng(5)
    geometry = _arcs(rng, n_per_arc=40)
    curves = _observe(geometry, SpinState(TRUE_POLE_I, PERIOD_S, 0.3, geometry[0].epoch), rng)
    # any solution will do (the identity holds at every one): the smallest search
    run = run_inversion(curves, "convex", [PeriodRange(0.999 * PERIOD_S, 1.001 * PERIOD_S, "test")], rng=rng,
                        search_options={"pole_step_deg": 30.0, "n_grid_samples": 30, "n_candidates": 1, "n_periods_per_pole": 1})
    sol = run.solutions[0]
    fitted = fitted_brightness(sol, run.result, curves)
    chi2 = sum(float(np.sum(((c.brightness - f) / c.sigma) ** 2)) for c, f in zip(curves, fitted))
    assert chi2 == pytest.approx(sol.chi2, rel=1e-4)  # measured 2.6e-6: the epoch as astropy Time, the phase to ~1e-8 rad


@pytest.mark.slow
def test_coplanar_geometry_lists_both_mirror_poles(tmp_path, capsys):
    """Sun and observer in one plane (the equator): poles (λ, β) and (λ + 180°, β) give the same curves.

    Turning the whole motion by 180° about the plane's normal negates every body-frame Sun and observer
    direction, and a centrally symmetric body (the ellipsoid) is as bright under (−ŝ, −ô) as under (ŝ, ô).
    Four arcs, the observer sweeping 10° along each, phase angles 15° to 75°.
    """
    rng = np.random.default_rng(2)
    geometry = []
    epoch = Time("2024-03-21T00:00:00", scale="utc")
    for k, (sun_deg, obs_deg) in enumerate(((0.0, 15.0), (10.0, 40.0), (20.0, 70.0), (30.0, 95.0))):
        t = np.sort(rng.uniform(0.0, ARC_S, 80))
        n = t.size
        sun = pole_from_radec(np.full(n, np.radians(sun_deg)), np.zeros(n))
        obs = pole_from_radec(np.radians(obs_deg + 10.0 * t / ARC_S), np.zeros(n))
        ones = np.ones(n)
        geometry.append(InversionCurve(t_s=t, epoch=epoch + k * 5 * u.h, brightness=ones, sigma=ones, sun_dir_I=sun, observer_dir_I=obs,
                                       sun_distance_m=1.496e11 * ones, range_m=2.6e7 * ones))
    pole = pole_from_radec(np.radians(60.0), np.radians(40.0))
    lcs = tmp_path / "coplanar.txt"
    lcs.write_text(damit_text(_observe(geometry, SpinState(pole, PERIOD_S, 0.4, epoch), rng)))
    argv = ["lightcurve", "invert", str(lcs), "--shape", "ellipsoid:" + ",".join(map(str, SEMI_AXES_M)), "--period-range-h",
            _period_arg(0.998, 1.002), "--quick", "--json", "--pole-region", "--out", str(tmp_path / "out"), "--record", str(tmp_path / "inv.rrd")]  # fmt: skip
    assert main(argv) == 0
    doc = json.loads(capsys.readouterr().out)
    sols = doc["solutions"]
    mirror = np.array([-pole[0], -pole[1], pole[2]])  # turned by 180° about the plane's normal (I's z)
    near = [min(_angle_deg(s["pole_I"], p) for s in sols) for p in (pole, mirror)]
    assert max(near) < 5.0, (near, [(s["pole_I"], s["probability"]) for s in sols])
    p_true = sum(s["probability"] for s in sols if _angle_deg(s["pole_I"], pole) < 5.0)
    p_mirror = sum(s["probability"] for s in sols if _angle_deg(s["pole_I"], mirror) < 5.0)
    assert min(p_true, p_mirror) > 0.2, (p_true, p_mirror)  # the data cannot tell them apart
    # --pole-region: the profile-likelihood region has an island at each of the two poles, each within its mode's 3σ
    (region,) = doc["pole_profile_regions"]
    assert region["complete"] and region["solid_angle_95_deg2"] > 0
    inside = [pole_from_ecliptic(np.radians(q["pole_ecliptic_lon_deg"]), np.radians(q["pole_ecliptic_lat_deg"])) for q in region["poles"] if q["level"] <= 0.95]
    for p in (pole, mirror):
        sol = min(sols, key=lambda s: _angle_deg(s["pole_I"], p))
        assert 0 < sum(_angle_deg(q, sol["pole_I"]) < 3.0 * sol["pole_sigma_deg"] for q in inside)
    assert_rrd_verifies(tmp_path / "inv.rrd")
    assert json.loads((tmp_path / "out" / "inversion.json").read_text())["pole_profile_regions"] == doc["pole_profile_regions"]


@pytest.mark.parametrize(("extra", "message"), [
    (["--shape", "dodecahedron"], "--shape 'dodecahedron': expected one of"),
    (["--shape", "ellipsoid:1,2,3"], "expected one of"),
    (["--period-range-h", "0.05,0.01"], "--period-range-h '0.05,0.01': expected 'MIN,MAX'"),
    (["--period-range-h", "0.01,0.5"], "expected 'MIN,MAX' sidereal periods in hours with 0 < MIN < MAX <= 10 MIN"),
    (["--period-range-h", "0.1,1"], "period trials over the data's time span: expected at most"),
])  # fmt: skip
def test_bad_input_gives_one_line_exit_2_and_writes_nothing(tmp_path, capsys, extra, message):
    rng = np.random.default_rng(1)
    lcs = tmp_path / "arcs.txt"
    geometry = _arcs(rng, n_per_arc=20)
    lcs.write_text(damit_text(_observe(geometry, SpinState(TRUE_POLE_I, PERIOD_S, 0.0, geometry[0].epoch), rng)))
    out, rrd = tmp_path / "out", tmp_path / "r.rrd"
    assert main(["lightcurve", "invert", str(lcs), "--out", str(out), "--record", str(rrd), *extra]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("lcnav: error: ") and "\n" not in err and message in err, err
    assert not out.exists() and not rrd.exists()


def test_missing_or_unparsable_file_gives_one_line_exit_2(tmp_path, capsys):
    bad = tmp_path / "bad.txt"
    bad.write_text("2\n3 0\n2451545.0 1.0 1 0 0 0 1\n")
    for path in (tmp_path / "missing.txt", bad):
        assert main(["lightcurve", "invert", str(path), "--period-range-h", "0.03,0.034"]) == 2
        err = capsys.readouterr().err.strip()
        assert err.startswith("lcnav: error: ") and "\n" not in err, err


def test_derived_period_ranges_hold_the_true_sidereal_period():
    """Without --period-range-h: every arc's single-night period ± max(3σ, 1 %), doubled when one maximum per cycle.

    A triaxial ellipsoid shows two nearly equal maxima per rotation; the single-night fit may take them for
    one maximum at half the period, so the true sidereal period must lie in one of the derived ranges.
    """
    from lightcurves.inversion.periods import curve_periods, period_ranges

    rng = np.random.default_rng(4)
    geometry = _arcs(rng, n_per_arc=200)
    curves = _observe(geometry, SpinState(TRUE_POLE_I, PERIOD_S, 0.2, geometry[0].epoch), rng)
    ranges = period_ranges(curves)
    assert any(r.lo_s < PERIOD_S < r.hi_s for r in ranges), [(r.lo_s, r.hi_s) for r in ranges]
    for p in curve_periods(curves):
        assert p.significant
        for m in (1, 2) if p.maxima_per_rotation == 1 else (1,):
            assert sum(r.lo_s <= m * p.period_s <= r.hi_s for r in ranges) == 1
    for r in ranges:
        assert r.hi_s / r.lo_s >= (1.01 / 0.99) - 1e-12  # at least ±1 %
