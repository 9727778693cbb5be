"""``lcnav simulate``: write the truth of a scenario as a table and a recording."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Optional

import typer

from studies.io import atomic_path
from studies.scenarios import get_scenario, list_scenarios
from studies.truth import simulate_truth
from studies.truth_recording import record_truth


def simulate(
    scenario: str = typer.Option("SC3", help="Scenario name (see --list)."),
    duration: float = typer.Option(300.0, help="Simulated time, s."),
    dt: float = typer.Option(0.5, help="Sampling step of the written truth, s."),
    seed: int = typer.Option(1, help="Seed recorded with the run (the truth itself draws nothing)."),
    out: Optional[Path] = typer.Option(None, help="Output folder for truth.parquet and truth.rrd."),
    list_: bool = typer.Option(False, "--list", help="List the scenarios and exit."),
) -> None:
    """Integrate servicer and target of a scenario; write truth.parquet and truth.rrd."""
    if list_:
        for sc in list_scenarios():
            typer.echo(f"{sc.name:8s} {sc.description}")
        return
    sc = get_scenario(scenario)
    for name, value in (("--duration", duration), ("--dt", dt)):
        if not math.isfinite(value) or value <= 0:
            raise ValueError(f"{name} must be a positive finite number of seconds, got {value}")
    if seed < 0:
        raise ValueError(f"--seed must be a non-negative integer, got {seed}")
    if out is None:
        raise ValueError("--out DIR is required (where truth.parquet and truth.rrd go)")
    if out.exists() and not out.is_dir():
        raise NotADirectoryError(f"--out {out} exists and is not a folder")
    truth = simulate_truth(sc, duration, dt)
    df = truth.table()
    df.attrs = {"scenario": sc.name, "seed": int(seed), "duration_s": duration, "dt_s": dt}
    with atomic_path(out / "truth.parquet") as tmp:
        df.to_parquet(tmp, index=False)
    record_truth(truth, out / "truth.rrd", seed)
    typer.echo(f"wrote {out / 'truth.parquet'} ({len(df)} rows) and {out / 'truth.rrd'}")


def register(app: typer.Typer) -> None:
    app.command("simulate")(simulate)
