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

from studies.cli.choices import COMBINA_MESH_TARGETS as MESH_TARGETS
from studies.cli.choices import COMBINA_SOURCES as SOURCES
from studies.cli.choices import TRUTH_PHYSICS
from studies.engine import validate as v

#: Most measurement epochs of one run (duration × rate): a bound on the work one command may ask for.
MAX_EPOCHS = 10**5


def run_command(cfg, out: Path) -> dict:
    """Validate the :class:`~studies.sim.combina.CombinaConfig`, run it and write the three files under the ``out`` lock;
    nothing is written on bad input or failure."""
    from studies.engine.io import output_folder, write_json, write_table
    from studies.recording.combina import states_table, write_recording
    from studies.sim.combina import combina_metrics, run_combina

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


#: ``--target`` names a body, as in ``lightcurve render`` and ``perception frames``: body -> the CoMBiNa target it is.
TARGET_OF_BODY = {body: target for target, body in MESH_TARGETS.items()}


def _target(param: typer.CallbackParam, body: str) -> str:
    """``--target BODY`` -> the CoMBiNa target (``asymmetric``/``symmetric``); the names before issue 30 refused with the new one."""
    v.check_text("--target", body)
    if body in MESH_TARGETS:
        v.fail("--target", body, f"a body: {' or '.join(TARGET_OF_BODY)} (renamed: --target {body} is now --target {MESH_TARGETS[body]})")
    if body not in TARGET_OF_BODY:
        v.fail("--target", body, f"a body: {' or '.join(TARGET_OF_BODY)}")
    return TARGET_OF_BODY[body]


def _old_measurements(param: typer.CallbackParam, value: str | None) -> None:
    if value is not None:
        v.fail("--measurements", value, f"--pose-source {'|'.join(SOURCES)} (renamed; --measurements is the pose file of `lcnav run`)")


def register(app: typer.Typer) -> None:
    """Add ``combina`` to the ``lcnav`` command line."""

    @app.command("combina")
    def combina(
        target: str = typer.Option("box-wing", help="target body: box-wing (asymmetric) | atlas-centaur (axisymmetric rocket body)",
                                   callback=_target),
        pose_source: str = typer.Option("simulated", help="where the pose measurements come from: simulated | rendered (stereo frames "
                                        "through the perception pipeline)", callback=v.text(SOURCES)),
        measurements: str | None = typer.Option(None, hidden=True, callback=_old_measurements),
        duration_tu: float = typer.Option(2.0, help="duration in time units (TU = 963.65 s), at most 100", callback=v.number(0, 100, lo_open=True, unit="TU")),
        rate_hz: float = typer.Option(0.33, help="measurement rate, Hz (at most 10)", callback=v.number(0, 10, lo_open=True, unit="Hz")),
        quick: bool = typer.Option(False, "--quick", help="short run: 0.25 TU simulated; 0.05 TU at 256 px rendered"),
        seed: int = typer.Option(1, help="random seed", callback=v.seed()),
        prior: str = typer.Option("none", help="spin prior: none | init | proxy", callback=v.text()),
        prior_error: float = typer.Option(0.05, help="relative error of the spin prior", callback=v.number(0, 1, lo_open=True, hi_open=True)),
        axis_frame: str = typer.Option("known", help="axisymmetric mode: known | estimated frame I_Gamma", callback=v.text()),
        truth: str = typer.Option("torque-free", help="truth physics: torque-free (what the filters model) or perturbed (gravity gradient, "
                                  "J2, drag, nutation damping; the filters' process noise budgets for it)", callback=v.choice(TRUTH_PHYSICS)),
        out: Path = typer.Option(..., help="output directory", callback=v.out_dir()),
    ) -> None:
        """CoMBiNa relative navigation (Maestrini et al. §VI): writes metrics.json, states.parquet, combina.rrd."""
        from studies.sim.combina import CombinaConfig

        cfg = CombinaConfig(target=target, measurements=pose_source, duration_tu=duration_tu, rate_hz=rate_hz, seed=seed, prior=prior,
                            prior_error=prior_error, axis_frame=axis_frame, quick=quick, truth=truth)
        m = run_command(cfg, out)
        c = m["components"]
        summary = ", ".join(f"{k}: {'ok' if v['converged'] else 'not converged'}" for k, v in c.items())
        typer.echo(f"combina {MESH_TARGETS[cfg.target]} ({cfg.target})/{cfg.measurements} seed {cfg.seed}: mode {m['mode']}, "
                   f"symmetry detected {m['symmetry_detected']}; {summary}; wrote {out}")
