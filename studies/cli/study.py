"""``lcnav study NAME``: run a registered study (:func:`studies.engine.registry.run_study`) and print its tables."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

from studies.cli.choices import CONNECT_TIMEOUT_S, MAX_CONNECT_TIMEOUT_S, STUDIES
from studies.engine import validate as v


def study(
    name: str = typer.Argument(..., help=f"Study to run: {', '.join(STUDIES)}.", callback=v.text()),
    quick: bool = typer.Option(False, "--quick", help="Small size: the config's quick table of overrides."),
    config: Optional[Path] = typer.Option(None, "--config", help="Study config TOML (default studies/catalog/configs/NAME.toml).", callback=v.path_text()),
    out: Optional[Path] = typer.Option(None, "--out", help="Output folder (default runs/NAME-TIMESTAMP); re-use it to resume.", callback=v.out_dir()),
    scheduler: Optional[str] = typer.Option(None, "--scheduler", help="Existing Dask scheduler, tcp://HOST:PORT.", callback=v.text()),
    workers: Optional[int] = typer.Option(None, "--workers", help="Local Dask workers (default: the machine's cores; at most 4 per core)."),
    connect_timeout_s: Optional[float] = typer.Option(None, "--connect-timeout-s", help="How long --scheduler has to answer before the study is "
                                                      f"refused, s (default {CONNECT_TIMEOUT_S:g}, at most {MAX_CONNECT_TIMEOUT_S:g}).",
                                                      callback=v.number(0, MAX_CONNECT_TIMEOUT_S, lo_open=True, unit="s")),
) -> None:
    """Run a study: sweep its runs (resumable), write runs.parquet, summary.parquet/.csv/.md."""
    from studies.engine.registry import run_study  # every study, pandas, Dask: not for --help (studies.cli.choices)

    result = run_study(name, config_path=config, quick=quick, out=out, scheduler=scheduler, workers=workers,
                       connect_timeout_s=connect_timeout_s)
    typer.echo(result.markdown)
    typer.echo(f"{result.n_executed} runs executed, {result.n_skipped} already stored; wrote {result.out_dir}")


def register(app: typer.Typer) -> None:
    app.command("study")(study)
