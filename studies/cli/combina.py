"""``lcnav combina``: run the CoMBiNa closed loop and write its files.

``DIR/metrics.json`` (see :func:`studies.sim.combina.combina_metrics`),
``DIR/states.parquet`` (one row per measurement epoch: truth, estimates, 1-σ,
measurement, gate decisions) and ``DIR/combina.rrd`` (the same as time series
on the ``sim_time`` timeline, plus the 3-D relative trajectory, measured
positions, gate events and mode switches). Point clouds are logged only by a
measurement source that has them (the rendered chain); the simulated source
has none.
"""

from __future__ import annotations

from pathlib import Path

import typer

from studies.engine import validate as v
from studies.engine.io import output_folder, write_json, write_table
from studies.recording.combina import states_table, write_recording
from studies.sim.combina import CombinaConfig, run_combina, combina_metrics

#: Most measurement epochs of one run (duration × rate): a bound on the work one command may ask for.
MAX_EPOCHS = 10**5


def run_command(cfg: CombinaConfig, out: Path) -> dict:
    """Validate, run and write the three files under the ``out`` lock; nothing is written on bad input or failure."""
    cfg.validate()
    v.check_out_dir("--out", out)
    if cfg.effective_duration_s * cfg.rate_hz > MAX_EPOCHS:
        v.fail("--duration-tu × --rate-hz", f"{cfg.effective_duration_s * cfg.rate_hz:g}", f"at most {MAX_EPOCHS} measurements")
    run = run_combina(cfg)
    metrics = combina_metrics(run)
    with output_folder(out, "combina") as stage:
        write_table(stage / "states.parquet", states_table(run))
        write_recording(stage / "combina.rrd", run)
        write_json(stage / "metrics.json", metrics)
    return metrics


def register(app: typer.Typer) -> None:
    """Add ``combina`` to the ``lcnav`` command line."""

    @app.command("combina")
    def combina(
        target: str = typer.Option("asymmetric", help="asymmetric (box-wing) | symmetric (rocket body)", callback=v.text()),
        measurements: str = typer.Option("simulated", help="simulated | rendered", callback=v.text()),
        duration_tu: float = typer.Option(2.0, help="duration in time units (TU = 963.65 s), at most 100", callback=v.number(0, 100, lo_open=True, unit="TU")),
        rate_hz: float = typer.Option(0.33, help="measurement rate, Hz (at most 10)", callback=v.number(0, 10, lo_open=True, unit="Hz")),
        quick: bool = typer.Option(False, help="short run: 0.25 TU simulated; 0.05 TU at 256 px rendered"),
        seed: int = typer.Option(1, help="random seed", callback=v.seed()),
        prior: str = typer.Option("none", help="spin prior: none | init | proxy", callback=v.text()),
        prior_error: float = typer.Option(0.05, help="relative error of the spin prior", callback=v.number(0, 1, lo_open=True, hi_open=True)),
        axis_frame: str = typer.Option("known", help="axisymmetric mode: known | estimated frame I_Gamma", callback=v.text()),
        out: Path = typer.Option(..., help="output directory", callback=v.out_dir()),
    ) -> None:
        """CoMBiNa relative navigation (Maestrini et al. §VI): writes metrics.json, states.parquet, combina.rrd."""
        cfg = CombinaConfig(target=target, measurements=measurements, duration_tu=duration_tu, rate_hz=rate_hz, seed=seed, prior=prior,
                            prior_error=prior_error, axis_frame=axis_frame, quick=quick)
        m = run_command(cfg, out)
        c = m["components"]
        summary = ", ".join(f"{k}: {'ok' if v['converged'] else 'not converged'}" for k, v in c.items())
        typer.echo(f"combina {cfg.target}/{cfg.measurements} seed {cfg.seed}: mode {m['mode']}, "
                   f"symmetry detected {m['symmetry_detected']}; {summary}; wrote {out}")
