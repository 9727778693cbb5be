"""``lcnav simulate``: write the truth of a scenario as a table and a recording."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

from estimators.perturbations import TRUTH_PHYSICS, get_truth_physics
from studies.engine import validate as v
from studies.engine.io import atomic_path, output_folder
from studies.sim.scenarios import get_scenario, list_scenarios
from studies.sim.truth import simulate_truth
from studies.recording.truth import record_truth


#: Most samples of a written truth (duration / dt).
MAX_STEPS = 10**6


def simulate(
    scenario: str = typer.Option("SC3", help="Scenario name (see --list).", callback=v.text()),
    duration: float = typer.Option(300.0, help="Simulated time, s (at most 1e6).", callback=v.number(0, 1e6, lo_open=True, unit="s")),
    dt: float = typer.Option(0.5, help="Sampling step of the written truth, s.", callback=v.number(0, 3600, lo_open=True, unit="s")),
    seed: int = typer.Option(1, help="Seed recorded with the run (the truth itself draws nothing).", callback=v.seed()),
    truth: str = typer.Option("torque-free", help="Truth physics: torque-free (what the filters model) or perturbed (gravity gradient, "
                              "J2, drag, nutation damping; see estimators.perturbations).", callback=v.choice(TRUTH_PHYSICS)),
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
        raise v.InputError("--out: missing: expected the output folder for truth.parquet and truth.rrd")
    physics = get_truth_physics(truth)
    tr = simulate_truth(sc, duration, dt, physics)
    df = tr.table()
    df.attrs = {"scenario": sc.name, "seed": int(seed), "duration_s": duration, "dt_s": dt, "truth": physics.name,
                "truth_physics": physics.as_dict()}
    with output_folder(out, "simulate") as stage:
        with atomic_path(stage / "truth.parquet") as tmp:
            df.to_parquet(tmp, index=False)
        record_truth(tr, stage / "truth.rrd", seed)
    typer.echo(f"wrote {out / 'truth.parquet'} ({len(df)} rows, {physics.name} truth) and {out / 'truth.rrd'}")


def register(app: typer.Typer) -> None:
    app.command("simulate")(simulate)
