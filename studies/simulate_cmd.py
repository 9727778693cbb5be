"""``lcnav simulate``: write the truth of a scenario as a table and a recording."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import numpy as np
import typer

from estimators.attitude import quat_conjugate, quat_to_dcm
from studies import validate as v
from studies.io import atomic_path, output_folder
from studies.recording import recording, send_poses, send_scalars
from studies.scenarios import get_scenario, list_scenarios
from studies.truth import Truth, simulate_truth


def equivalent_box_half_sizes(J_diag, longest_half_m: float = 6.0) -> np.ndarray:
    """Half sizes of the uniform box with the same principal-inertia ratios as ``J_diag``.

    For a box, ``I_x ∝ b² + c²`` etc., so ``a² ∝ (I_y + I_z − I_x)/2``; scaled
    so the longest half size is ``longest_half_m``. Used to draw the target.
    """
    I = np.asarray(J_diag, dtype=float)
    sq = 0.5 * (I.sum() - 2.0 * I)
    if np.any(sq <= 0):
        raise ValueError(f"inertia {I.tolist()} violates the triangle inequality of a rigid body")
    h = np.sqrt(sq)
    return h * (longest_half_m / h.max())


def record_truth(truth: Truth, path: Path, seed: int) -> None:
    """``truth.rrd``: the target as a box posed in the servicer frame, rates as scalars.

    ``/truth/target`` carries ``q_ST`` and ``r_TS_S = −R_ST r_ST_T`` (the target
    seen from the servicer); ``/truth/w_ST_T/{x,y,z}`` and ``/truth/w_T_T/...``
    the relative and the target's own rates (rad/s); ``/truth/range_m`` the range.
    """
    with recording(path, recording_id=f"truth-{truth.scenario.name}-seed{seed}") as rec:
        log_truth(rec, truth)


def log_truth(rec, truth: Truth) -> None:
    """Log the truth entities of :func:`record_truth` into the open recording ``rec``."""
    import rerun as rr

    q_ST = quat_conjugate(truth.x[:, 0:4])
    r_TS_S = -np.einsum("nij,nj->ni", quat_to_dcm(q_ST), truth.x[:, 7:10])
    rec.log("/truth/target", rr.Boxes3D(half_sizes=[equivalent_box_half_sizes(truth.J_T_diag)], colors=[[200, 160, 60]]), static=True)
    rec.log("/truth/servicer", rr.Boxes3D(half_sizes=[[1.0, 1.0, 1.0]], colors=[[90, 140, 220]]), static=True)
    send_poses(rec, "/truth/target", truth.t, r_TS_S, q_ST)
    send_scalars(rec, "/truth/w_ST_T", truth.t, truth.x[:, 4:7], ["x", "y", "z"])
    send_scalars(rec, "/truth/w_T_T", truth.t, truth.target[:, 10:13], ["x", "y", "z"])
    send_scalars(rec, "/truth/range_m", truth.t, np.linalg.norm(truth.x[:, 7:10], axis=1))


#: Most samples of a written truth (duration / dt).
MAX_STEPS = 10**6


def simulate(
    scenario: str = typer.Option("SC3", help="Scenario name (see --list).", callback=v.text()),
    duration: float = typer.Option(300.0, help="Simulated time, s (at most 1e6).", callback=v.number(0, 1e6, lo_open=True, unit="s")),
    dt: float = typer.Option(0.5, help="Sampling step of the written truth, s.", callback=v.number(0, 3600, lo_open=True, unit="s")),
    seed: int = typer.Option(1, help="Seed recorded with the run (the truth itself draws nothing).", callback=v.seed()),
    out: Optional[Path] = typer.Option(None, help="Output folder for truth.parquet and truth.rrd.", callback=v.out_dir()),
    list_: bool = typer.Option(False, "--list", help="List the scenarios and exit."),
) -> None:
    """Integrate servicer and target of a scenario; write truth.parquet and truth.rrd."""
    if list_:
        for sc in list_scenarios():
            typer.echo(f"{sc.name:8s} {sc.description}")
        return
    sc = get_scenario(scenario)
    if dt > duration or duration / dt > MAX_STEPS:
        v.fail("--duration/--dt", f"{duration:g}/{dt:g}", f"--dt <= --duration and at most {MAX_STEPS} steps")
    if out is None:
        raise v.InputError("--out: missing; expected the output folder for truth.parquet and truth.rrd")
    truth = simulate_truth(sc, duration, dt)
    df = truth.table()
    df.attrs = {"scenario": sc.name, "seed": int(seed), "duration_s": duration, "dt_s": dt}
    with output_folder(out, "simulate") as stage:
        with atomic_path(stage / "truth.parquet") as tmp:
            df.to_parquet(tmp, index=False)
        record_truth(truth, stage / "truth.rrd", seed)
    typer.echo(f"wrote {out / 'truth.parquet'} ({len(df)} rows) and {out / 'truth.rrd'}")


def register(app: typer.Typer) -> None:
    app.command("simulate")(simulate)
