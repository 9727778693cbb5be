"""Perception benchmark: BCPD fast vs dense reference, stereo pipeline time, feature cover.

* BCPD: ~1000 measured points (one side of the box-wing, 1 cm noise, 10%
  outliers, random misalignment up to 20° and 0.3 m) against models of ~1000
  and ~3000 surface points; the fast method (downsampled + k-d tree,
  ``method="kdtree"``) over many poses and the dense reference on the first
  few of the same problems: time, accuracy, speed-up and fast−dense agreement.
  Goals of issue #5: median ≤ 50 ms, p99 ≤ 150 ms.
* Stereo: render and point-cloud time per frame at 512 and 1024 px.
* Feature cover of ORB, SIFT and GFTT (fraction of the ROI's 8-px cells with a
  feature), the choice made in :mod:`perception.stereo`.
"""

from __future__ import annotations

import time

import numpy as np

N_FAST = 60
N_DENSE = 6


def _bcpd_rows() -> list[str]:
    from estimators.attitude import dcm_angle
    from lightcurves.targets import get_target
    from perception.bcpd import bcpd_rigid
    from perception.model import mesh_surface_points
    from studies.sim.frames import registration_trial

    tgt = get_target("box-wing")
    rows = [
        "| model points | method | poses | median ms | p99 ms | median rot. err. deg | p99 rot. err. deg | median pos. err. mm | max abs(s-1) |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    summary = []
    warm, _ = mesh_surface_points(tgt, 500, np.random.default_rng(0))
    bcpd_rigid(warm[:300], warm)  # compile (or load) the numba E-step outside the timings
    for n_model in (1000, 3000):
        rng = np.random.default_rng(n_model)
        model, _ = mesh_surface_points(tgt, n_model, rng)
        trials = [registration_trial(tgt, model, rng, n_measured=1000) for _ in range(N_FAST)]
        res = {}
        for method, n in (("kdtree", N_FAST), ("dense", N_DENSE)):
            ms, rot, pos, sc, out = [], [], [], [], []
            for meas, R_true, t_true in trials[:n]:
                t0 = time.perf_counter()
                r = bcpd_rigid(meas, model, method=method)
                ms.append(1e3 * (time.perf_counter() - t0))
                rot.append(np.rad2deg(dcm_angle(r.R, R_true)))
                pos.append(1e3 * np.linalg.norm(r.t - t_true))
                sc.append(abs(r.s - 1))
                out.append(r)
            res[method] = (np.array(ms), out)
            rows.append(
                f"| {n_model} | {method} | {n} | {np.median(ms):.1f} | {np.percentile(ms, 99):.1f} | {np.median(rot):.3f} | "
                f"{np.percentile(rot, 99):.3f} | {np.median(pos):.1f} | {max(sc):.4f} |"
            )
        fast_ms, fast = res["kdtree"]
        dense_ms, dense = res["dense"]
        d_rot = [np.rad2deg(dcm_angle(a.R, b.R)) for a, b in zip(fast, dense)]
        d_pos = [1e3 * np.linalg.norm(a.t - b.t) for a, b in zip(fast, dense)]
        summary.append(
            f"| {n_model} | {np.median(dense_ms) / np.median(fast_ms[:N_DENSE]):.0f}x | {np.median(d_rot):.3f} | {max(d_rot):.3f} "
            f"| {np.median(d_pos):.1f} | {max(d_pos):.1f} |"
        )
    rows += [
        "",
        f"Fast vs dense on the same {N_DENSE} problems (speed-up = ratio of medians):",
        "",
        "| model points | speed-up | median rot. diff deg | max rot. diff deg | median pos. diff mm | max pos. diff mm |",
        "|---|---|---|---|---|---|",
        *summary,
    ]
    return rows


def _gamma_rows() -> list[str]:
    """Initial σ² (Hirose's γ) in measure_pose on rendered one-sided views of the rocket body."""
    from studies.sim.frames import frame_pipeline

    rows = ["| gamma | frames | median axis err. deg | max axis err. deg | median pos. err. mm | max pos. err. mm | median BCPD ms |",
            "|---|---|---|---|---|---|---|"]
    cases = [(35.0 + 5.0 * (seed % 3), seed) for seed in range(1, 9)]
    for gamma in (1.0, 0.1):
        ax, pos, ms = [], [], []
        for range_m, seed in cases:
            reg = frame_pipeline("atlas-centaur", range_m, seed, gamma=gamma)[-1]["registration"]
            ax.append(reg["symmetry_axis_error_deg"])
            pos.append(1e3 * reg["position_error_m"])
            ms.append(reg["bcpd_ms"])
        rows.append(f"| {gamma} | {len(cases)} | {np.median(ax):.2f} | {max(ax):.2f} | {np.median(pos):.0f} | {max(pos):.0f} | {np.median(ms):.0f} |")
    return rows


def _stereo_rows() -> list[str]:
    from estimators.attitude import quat_to_dcm, random_quaternion
    from lightcurves.targets import get_target
    from perception.render import StereoCamera, StereoRenderer
    from perception.stereo import DETECTORS, luminance, feature_cover, stereo_cloud, tone_map

    import cv2

    sun_C = np.array([0.4, 0.3, 0.87]) / np.linalg.norm([0.4, 0.3, 0.87])
    timing = ["| target | resolution px | range m | render s | stereo ms | points | median depth err. % of range |", "|---|---|---|---|---|---|---|"]
    cover = ["| target | range m | " + " | ".join(f"{d} features / cover" for d in DETECTORS) + " |", "|---|---|" + "---|" * len(DETECTORS)]
    variant = None
    for name in ("box-wing", "atlas-centaur"):
        tgt = get_target(name)
        for res in (512, 1024):
            renderer = StereoRenderer(tgt, StereoCamera(resolution_px=res))
            variant = renderer.variant
            rng = np.random.default_rng(7)
            renderer.render(np.eye(3), np.array([0.0, 0.0, -40.0]), sun_C, spp=1)  # JIT warm-up
            for range_m in (30.0, 40.0, 50.0):
                C_CT = quat_to_dcm(random_quaternion(rng))
                t0 = time.perf_counter()
                f = renderer.render(C_CT, np.array([0.2, -0.3, -range_m]), sun_C, spp=16)
                t1 = time.perf_counter()
                pc = stereo_cloud(f.left, f.right, renderer.camera)
                t2 = time.perf_counter()
                z = f.depth_left[(pc.pixels[:, 1] - 0.5).astype(int), (pc.pixels[:, 0] - 0.5).astype(int)]
                ok = np.isfinite(z)
                err = np.median(np.abs(-pc.points_C[ok, 2] - z[ok])) / range_m * 100
                timing.append(f"| {name} | {res} | {range_m:.0f} | {t1 - t0:.2f} | {1e3 * (t2 - t1):.0f} | {len(pc.points_C)} | {err:.2f} |")
                if res == 512:
                    L = luminance(f.left)
                    g = cv2.createCLAHE(clipLimit=3.0, tileGridSize=(8, 8)).apply(tone_map(L, L.max()))
                    cells = [feature_cover(g, d) for d in DETECTORS]
                    cover.append(f"| {name} | {range_m:.0f} | " + " | ".join(f"{n} / {c:.2f}" for n, c in cells) + " |")
    return [f"Mitsuba variant: `{variant}`, 16 spp, textured targets.", "", *timing, "",
            "Feature cover on the same 512-px left images (CLAHE-equalised, as the pipeline sees them):", "", *cover]


def run() -> str:
    lines = [
        "## Perception (BCPD, stereo)",
        "",
        "### BCPD registration: ~1000 measured points (one side, 1 cm noise, 10% outliers, up to 20 deg / 0.3 m off)",
        "",
        *_bcpd_rows(),
        "",
        "### Initial sigma^2 in measure_pose: rendered one-sided views of the rocket body",
        "",
        "atlas-centaur at 35-45 m, 512 px, estimate 5 deg / 0.3 m off (`lcnav perception frames` seeds 1-8); symmetry-axis error",
        "(roll about the axis is free). Hirose's gamma = 1 starts from the clouds' mean squared distance; measure_pose uses 0.1",
        "because eq. 3 already aligns the cloud with the estimate.",
        "",
        *_gamma_rows(),
        "",
        "### Stereo pipeline per frame (render + point cloud)",
        "",
        *_stereo_rows(),
    ]
    return "\n".join(lines)
