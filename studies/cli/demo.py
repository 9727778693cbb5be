"""``lcnav demo [--out DIR] [--quick]``: the main job end to end (:func:`studies.catalog.demo.run_demo`), what ``make demo`` runs."""

from __future__ import annotations

from pathlib import Path

import typer

from studies.cli.choices import DEMO_OUT
from studies.engine.validate import out_dir


def demo(
    out: Path = typer.Option(DEMO_OUT, "--out", help="Output folder (tables, figures, recordings).", callback=out_dir()),
    quick: bool = typer.Option(False, "--quick", help="Smaller run (shorter light curve and filter runs, fewer renders) for tests."),
) -> None:
    """The main job: light curve -> spin prior -> EKF/UKF on SC3 with and without it; tables, figures, recordings."""
    from studies.catalog.demo import QUICK, DemoConfig, run_demo

    result = run_demo(out, QUICK if quick else DemoConfig(), echo=typer.echo)
    typer.echo("")
    typer.echo(result.markdown)
    typer.echo(f"wrote {len(result.files)} files to {out} in {result.elapsed_s:.0f} s; open a recording with `rerun {out / 'ekf_prior.rrd'}` "
               f"(or several: `rerun {out}/*.rrd`)")


def register(app: typer.Typer) -> None:
    app.command("demo")(demo)
