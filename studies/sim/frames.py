"""One stereo frame end to end (render, stereo cloud, BCPD pose measurement) and synthetic BCPD registration trials.

:func:`frame_pipeline` is what ``lcnav perception frames`` runs and writes; :func:`bench_registration` what
``lcnav perception bench`` times. Nothing here writes a file.
"""

from __future__ import annotations

import time

import numpy as np


def random_rotation(rng: np.random.Generator, max_deg: float) -> np.ndarray:
    """A rotation matrix by a uniform angle in [0, max_deg] about a uniform axis."""
    from estimators.attitude import quat_to_dcm, rotvec_to_quat

    axis = rng.normal(size=3)
    axis /= np.linalg.norm(axis)
    return quat_to_dcm(rotvec_to_quat(np.deg2rad(rng.uniform(0.0, max_deg)) * axis))


def registration_trial(target, model_T: np.ndarray, rng: np.random.Generator, *, n_measured: int = 1000, noise_m: float = 0.01, outliers: float = 0.1,
                       max_rot_deg: float = 20.0, max_offset_m: float = 0.3):
    """One synthetic registration problem: ``(measured, R_true, t_true)`` with ``model ≈ R_true measured + t_true``.

    The measured points are fresh surface samples facing a random viewing
    direction (one side of the target, as a stereo camera sees it), with
    Gaussian noise and uniform outliers in their bounding box, displaced by a
    random rotation up to ``max_rot_deg`` and offset up to ``max_offset_m``.
    """
    from perception.model import mesh_surface_points

    view = rng.normal(size=3)
    view /= np.linalg.norm(view)
    pts, nrm = mesh_surface_points(target, 4 * n_measured, rng)
    facing = pts[nrm @ view > 0.0]
    n_in = int(round((1.0 - outliers) * n_measured))
    surf = facing[rng.choice(len(facing), size=min(n_in, len(facing)), replace=False)]
    surf = surf + rng.normal(scale=noise_m, size=surf.shape)
    lo, hi = surf.min(axis=0), surf.max(axis=0)
    meas_T = np.concatenate([surf, rng.uniform(lo, hi, size=(n_measured - len(surf), 3))])
    R_true = random_rotation(rng, max_rot_deg)
    t_true = rng.uniform(-1.0, 1.0, 3) * max_offset_m / np.sqrt(3.0)
    return (meas_T - t_true) @ R_true, R_true, t_true


def frame_pipeline(target: str, range_m: float, seed: int, *, resolution: int = 512, spp: int = 16, estimate_error_deg: float = 5.0,
                   estimate_error_m: float = 0.3, estimate_scale: bool = True, gamma: float = 0.1):
    """Render one stereo frame, build its cloud and register it (eqs 3–8); nothing is written.

    The attitude, Sun direction (from the camera's side) and the estimate's
    errors are drawn from ``seed``. Returns ``(frame, cloud, depth_true,
    model_T, C_CT, r_TC_C, measurement, summary)``.
    """
    from estimators.attitude import dcm_angle, quat_to_dcm, rotvec_to_quat
    from lightcurves.targets import get_target
    from perception.measure import measure_pose
    from perception.model import mesh_surface_points
    from perception.render import StereoCamera, StereoRenderer
    from perception.stereo import stereo_cloud

    rng = np.random.default_rng(seed)
    tgt = get_target(target)
    C_CT = random_rotation(rng, 180.0)
    r_TC_C = np.array([*rng.uniform(-0.05, 0.05, 2) * range_m, -range_m])
    sun_C = rng.normal(size=3)
    sun_C[2] = abs(sun_C[2]) + 1.0  # from the camera's side, so the visible face is lit
    sun_C /= np.linalg.norm(sun_C)

    renderer = StereoRenderer(tgt, StereoCamera(resolution_px=resolution))
    t0 = time.perf_counter()
    frame = renderer.render(C_CT, r_TC_C, sun_C, spp=spp, seed=seed)
    t1 = time.perf_counter()
    cloud = stereo_cloud(frame.left, frame.right, renderer.camera)
    t2 = time.perf_counter()
    row = (cloud.pixels[:, 1] - 0.5).astype(int)
    col = (cloud.pixels[:, 0] - 0.5).astype(int)
    depth_true = frame.depth_left[row, col]
    has = np.isfinite(depth_true)
    err_frac = float(np.median(np.abs(-cloud.points_C[has, 2] - depth_true[has])) / range_m) if has.any() else float("nan")

    model_T, _ = mesh_surface_points(tgt, 3000, rng)
    # filter estimate of eq. 3 (I = L = C for a single frame): truth perturbed
    axis = rng.normal(size=3)
    axis /= np.linalg.norm(axis)
    C_TC_hat = quat_to_dcm(rotvec_to_quat(np.deg2rad(estimate_error_deg) * axis)) @ C_CT.T
    offset = rng.normal(size=3)
    r_hat = r_TC_C + estimate_error_m * offset / np.linalg.norm(offset)
    eye = np.eye(3)
    t3 = time.perf_counter()
    meas = measure_pose(cloud.points_C, model_T, C_TI_hat=C_TC_hat, C_IC=eye, C_IL=eye, r_L_hat=r_hat, estimate_scale=estimate_scale, gamma=gamma)
    t4 = time.perf_counter()
    reg = {"accepted": meas.accepted, "reason": meas.reason, "bcpd_ms": 1e3 * (t4 - t3)}
    if meas.registration is not None:
        reg.update(
            rotation_error_deg=float(np.rad2deg(dcm_angle(meas.C_TI, C_CT.T))),
            position_error_m=float(np.linalg.norm(meas.r_L - r_TC_C)),
            scale=meas.scale,
            iterations=meas.registration.iterations,
            sigma_m=float(np.sqrt(meas.registration.sigma2)),
        )
        # the symmetry axis (the moment unlike the other two): roll about it is unobservable (§V.B)
        if target in ("atlas-centaur", "vespa"):
            sym = int(np.argmax(np.abs(tgt.J_diag - np.median(tgt.J_diag))))
            a_true, a_meas = C_CT[:, sym], meas.C_TI[sym]
            reg["symmetry_axis_error_deg"] = float(np.rad2deg(np.arccos(np.clip(a_true @ a_meas, -1.0, 1.0))))
    summary = {
        "target": target,
        "range_m": range_m,
        "seed": seed,
        "resolution_px": resolution,
        "variant": frame.variant,
        "detector": cloud.detector,
        "features": cloud.n_features,
        "points": int(len(cloud.points_C)),
        "points_with_true_depth": int(has.sum()),
        "median_depth_error_fraction": err_frac,
        "render_s": t1 - t0,
        "stereo_s": t2 - t1,
        "registration": reg,
    }
    return frame, cloud, depth_true, model_T, C_CT, r_TC_C, meas, summary


def bench_registration(n_poses: int, seed: int, *, n_measured: int = 1000, n_model: int = 3000, method: str = "kdtree", target: str = "box-wing") -> dict:
    """Time and accuracy of :func:`perception.bcpd.bcpd_rigid` over ``n_poses`` random trials."""
    from estimators.attitude import dcm_angle
    from lightcurves.targets import get_target
    from perception.bcpd import bcpd_rigid
    from perception.model import mesh_surface_points

    rng = np.random.default_rng(seed)
    tgt = get_target(target)
    model_T, _ = mesh_surface_points(tgt, n_model, rng)
    ms, rot, pos, scale = [], [], [], []
    for _ in range(n_poses):
        meas, R_true, t_true = registration_trial(tgt, model_T, rng, n_measured=n_measured)
        t0 = time.perf_counter()
        res = bcpd_rigid(meas, model_T, method=method)
        ms.append(1e3 * (time.perf_counter() - t0))
        rot.append(float(np.rad2deg(dcm_angle(res.R, R_true))))
        pos.append(float(np.linalg.norm(res.t - t_true)))
        scale.append(res.s)
    ms, rot, pos, scale = map(np.asarray, (ms, rot, pos, scale))
    return {
        "target": target,
        "method": method,
        "poses": n_poses,
        "measured_points": n_measured,
        "model_points": n_model,
        "median_ms": float(np.median(ms)),
        "p99_ms": float(np.percentile(ms, 99)),
        "median_rotation_error_deg": float(np.median(rot)),
        "p99_rotation_error_deg": float(np.percentile(rot, 99)),
        "median_position_error_m": float(np.median(pos)),
        "max_abs_scale_error": float(np.max(np.abs(scale - 1.0))),
        "seed": seed,
    }
