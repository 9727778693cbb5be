"""``lcnav perception frames|bench``: one stereo frame through the pipeline, and BCPD timing.

::

    lcnav perception frames --target box-wing --range 40 --seed 1 --out DIR [--json]
    lcnav perception bench [--poses 100] [--seed 1] [--json]

``frames`` renders a stereo pair of the target at the given range (random
attitude and a Sun lighting the visible side, drawn from ``--seed``), builds
the point cloud, and registers it (eqs 3–8 of Maestrini et al.) against the ideal
coarse model (3000 points on the target's surface) from a filter estimate
perturbed by ``--estimate-error-deg`` and ``--estimate-error-m``. It writes
``DIR/left.png``, ``DIR/right.png`` (the tone-mapped grey images the pipeline
sees), ``DIR/cloud.parquet`` (+ ``.csv``: points in the camera frame C, their
pixels, disparities and the rendered depth), ``DIR/summary.json`` and
``DIR/frames.rrd`` with ``/camera/left/image``, ``/camera/right/image``,
``/camera/left/depth``, ``/cloud/measured``, ``/cloud/model`` (the model at
the true pose) and ``/cloud/registered`` (at the measured pose), all in C on
``sim_time`` 0. For this single frame the inertial and LVLH frames are taken
equal to C.

``bench`` registers ~1000 measured points (one side of the target, 1 cm
noise, 10% outliers) against a 3000-point model over random initial
misalignments and prints timing and accuracy.
"""

from __future__ import annotations

import json
from pathlib import Path

import typer

from studies.engine import validate as v
from studies.engine.io import atomic_path, output_folder, write_json, write_table
from studies.recording.perception import write_frame_recording
from studies.sim.frames import bench_registration, frame_pipeline

perception_app = typer.Typer(help="Stereo frames, point clouds and BCPD pose measurements.", no_args_is_help=True)


def _validate_frames(target: str):
    from lightcurves.targets import TARGETS

    if target not in TARGETS:
        v.fail("--target", target, "one of " + ", ".join(sorted(TARGETS)))


@perception_app.command("frames")
def frames(
    target: str = typer.Option("box-wing", help="atlas-centaur, vespa, box-wing or sphere", callback=v.text()),
    range_m: float = typer.Option(40.0, "--range", help="distance from the left camera to the target's centre, m (5 to 1000)",
                                  callback=v.number(5, 1000, unit="m")),
    seed: int = typer.Option(1, help="seed of the attitude, Sun direction and estimate errors", callback=v.seed()),
    out: Path = typer.Option(..., help="output directory", callback=v.out_dir()),
    resolution: int = typer.Option(512, help="rendered image size, px (64 to 4096; Table 1's field of view at any size; 1024 = Table 1)",
                                   callback=v.count(64, 4096)),
    spp: int = typer.Option(16, help="samples per pixel (1 to 1024)", callback=v.count(1, 1024)),
    estimate_error_deg: float = typer.Option(5.0, help="attitude error of the filter estimate fed to eq. 3, deg (0 to 180)",
                                             callback=v.number(0, 180, unit="deg")),
    estimate_error_m: float = typer.Option(0.3, help="position error of the filter estimate fed to eq. 3, m (0 to 100)", callback=v.number(0, 100, unit="m")),
    rigid: bool = typer.Option(False, "--rigid", help="hold BCPD's scale at 1 (no scale gate)"),
    as_json: bool = typer.Option(False, "--json", help="print the summary as JSON"),
) -> None:
    """Render a stereo pair, build its point cloud, register it; write images, cloud and frames.rrd."""
    _validate_frames(target)
    from perception.stereo import luminance, tone_map

    frame, cloud, depth_true, model_T, C_CT, r_TC_C, meas, summary = frame_pipeline(
        target, range_m, seed, resolution=resolution, spp=spp, estimate_error_deg=estimate_error_deg, estimate_error_m=estimate_error_m,
        estimate_scale=not rigid
    )
    reg = summary["registration"]
    err_frac = summary["median_depth_error_fraction"]
    model_C = model_T @ C_CT.T + r_TC_C
    # C_CT measured = C_TI measuredᵀ (I = C for a single frame)
    registered_C = None if meas.registration is None else model_T @ meas.C_TI + meas.r_L

    white = float(luminance(frame.left).max()) or 1.0
    left_u8 = tone_map(luminance(frame.left), white)
    right_u8 = tone_map(luminance(frame.right), white)
    import cv2
    import pandas as pd

    pngs = {}
    for name, img in (("left.png", left_u8), ("right.png", right_u8)):
        ok, buf = cv2.imencode(".png", img)
        if not ok:
            raise RuntimeError(f"OpenCV could not encode {name}")
        pngs[name] = buf.tobytes()
    table = pd.DataFrame(
        {
            "x_C_m": cloud.points_C[:, 0],
            "y_C_m": cloud.points_C[:, 1],
            "z_C_m": cloud.points_C[:, 2],
            "u_px": cloud.pixels[:, 0],
            "row_px": cloud.pixels[:, 1],
            "disparity_px": cloud.disparity_px,
            "depth_true_m": depth_true,
        }
    )
    with output_folder(out, "perception frames") as stage:
        for name, data in pngs.items():
            with atomic_path(stage / name) as tmp:
                tmp.write_bytes(data)
        write_table(stage / "cloud.parquet", table, csv=True)
        write_frame_recording(stage / "frames.rrd", frame, left_u8, right_u8, cloud, model_C, registered_C,
                              recording_id=f"perception-frames-{out.absolute().name}")
        write_json(stage / "summary.json", summary)
    _report(summary, as_json, lambda: (
        f"{summary['points']} points ({cloud.detector}), median depth error {100 * err_frac:.2f}% of range; "
        f"registration {'accepted' if meas.accepted else 'rejected: ' + meas.reason}"
        + (f", rotation error {reg['rotation_error_deg']:.2f} deg, position error {reg['position_error_m']:.3f} m" if meas.registration else "")
        + f"; wrote {out}"
    ))


@perception_app.command("bench")
def bench(
    poses: int = typer.Option(100, help="number of random registration trials (1 to 100000)", callback=v.count(1, 100000)),
    seed: int = typer.Option(1, help="seed of the model, the measurements and the misalignments", callback=v.seed()),
    method: str = typer.Option("kdtree", help="BCPD E-step: kdtree (fast) or dense (reference)", callback=v.text(("kdtree", "dense"))),
    as_json: bool = typer.Option(False, "--json", help="print the result as JSON"),
) -> None:
    """Register ~1000 measured points against a ~3000-point model over random poses; timing and accuracy."""
    r = bench_registration(poses, seed, method=method)
    _report(r, as_json, lambda: (
        f"BCPD ({method}) {r['measured_points']} vs {r['model_points']} points over {poses} poses: "
        f"median {r['median_ms']:.1f} ms, p99 {r['p99_ms']:.1f} ms; rotation error median {r['median_rotation_error_deg']:.3f} deg, "
        f"p99 {r['p99_rotation_error_deg']:.3f} deg; position error median {1e3 * r['median_position_error_m']:.1f} mm"
    ))


def _report(result: dict, as_json: bool, line) -> None:
    """Print ``result`` as indented JSON (``--json``) or the one summary line ``line()`` makes."""
    typer.echo(json.dumps(result, indent=2) if as_json else line())


def register(app: typer.Typer) -> None:
    """Add ``lcnav perception`` to the root app."""
    app.add_typer(perception_app, name="perception")
