"""``lcnav inspect PATH.rrd|RUN_DIR [--export OUT.parquet] [--screenshot OUT.png]``: what a recording holds, its data back, its picture.

The listing and the export are :mod:`studies.recording.reader`'s; a run folder's ``metrics.json``
(written by the sweep) is shown with it, a study folder as its runs table. ``--screenshot`` draws the
recording as the viewer opens it (:func:`studies.recording.screenshot.screenshot_recording`, rerun's
headless viewer).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Optional

import pandas as pd
import typer

from studies.engine import validate as v
from studies.engine.io import is_complete, write_table
from studies.engine.sweep import RESULT_FILE
from studies.recording.reader import RecordingSummary, export_series, summarize_recording
from studies.recording.writer import TIMELINE


def _find_recordings(path: Path) -> tuple[list[Path], Path | None]:
    if path.is_file():
        if path.suffix != ".rrd":
            raise ValueError(f"PATH must be a .rrd file or a run folder, got {path}")
        metrics = path.parent / RESULT_FILE
        return [path], metrics if metrics.is_file() else None
    if path.is_dir():
        rrds = sorted(path.glob("*.rrd"))
        metrics = path / RESULT_FILE
        if not rrds and not metrics.is_file():
            raise ValueError(f"{path} holds no .rrd recording and no {RESULT_FILE}")
        return rrds, metrics if metrics.is_file() else None
    raise FileNotFoundError(f"{path} does not exist")


def _read_metrics(path: Path) -> dict:
    """A run's ``metrics.json``: a JSON object (``params`` and ``metrics`` objects if present)."""
    try:
        rec = json.loads(path.read_bytes())
    except (ValueError, RecursionError) as e:
        raise v.InputError(f"{str(path)!r} is not JSON ({type(e).__name__}): expected the metrics.json lcnav writes") from None
    if not isinstance(rec, dict) or not all(isinstance(rec.get(k, {}), dict) for k in ("params", "metrics")):
        raise v.InputError(f"{str(path)!r} holds no JSON object with 'params' and 'metrics' objects: expected the metrics.json lcnav writes")
    return rec


def format_summary(s: RecordingSummary) -> str:
    lines = [
        f"recording {s.path}",
        f"  application {s.application_id!r}, recording id {s.recording_id!r}, {s.n_blueprints} blueprint(s)",
        f"  timeline {TIMELINE}: {s.n_steps} steps, {s.t_min_s:g} .. {s.t_max_s:g} s",
    ]
    w = max((len(c.entity_path) for c in s.columns), default=10)
    for c in s.columns:
        lines.append(f"  {c.entity_path:<{w}}  {c.component:<28} {'static' if c.static else c.rows}")
    return "\n".join(lines)


def format_study(out_dir: Path) -> str:
    """A study folder: its runs (from ``runs.parquet``), where they are, whether it finished, and ``summary.md``."""
    table = out_dir / "runs.parquet"
    try:
        runs = pd.read_parquet(table)
    except (ValueError, OSError) as e:  # pyarrow: not Parquet / truncated
        raise v.InputError(f"{str(table)!r} is not a readable Parquet table ({v.plain(str(e), 120)[1:-1]}): expected the runs table of `lcnav study`") from None
    if "run_id" not in runs.columns:
        raise v.InputError(f"{str(table)!r} has columns {v.plain(list(map(str, runs.columns)))} without 'run_id': expected the runs table of `lcnav study`")
    done = is_complete(out_dir)
    state = (f"complete ({done.get('command')}, {done.get('finished_utc')})" if done
             else "INCOMPLETE: no .complete.json (killed or failed; re-run the study on it to resume)")
    lines = [f"study folder {out_dir}: {state}; {len(runs)} runs in runs.parquet; per run: {out_dir / 'runs'}/<run_id>/"]
    lines += [f"  {rid}" for rid in runs["run_id"]]
    summary = out_dir / "summary.md"
    if summary.is_file():
        lines += ["", summary.read_text().rstrip()]
    return "\n".join(lines)


def inspect(
    path: Path = typer.Argument(..., help="A .rrd recording, a run folder (DIR/runs/<run_id>) or a study folder (DIR).", callback=v.path_text()),
    export: Optional[Path] = typer.Option(None, "--export", help="Write the recording's time series to this Parquet file.", callback=v.out_file(".parquet")),
    contents: Optional[list[str]] = typer.Option(None, "--contents", help="Entity-path expression(s) to export, e.g. '/truth/**'.", callback=v.text()),
    screenshot: Optional[Path] = typer.Option(None, "--screenshot", help="Draw the recording as the viewer opens it (rerun's headless viewer, "
                                              "software Vulkan) into this PNG.", callback=v.out_file(".png")),
) -> None:
    """List what a recording holds (entities, time range, counts) and the run's metrics; optionally export series.

    Given a study's output folder (with ``runs.parquet``), print its summary and its run folders instead.
    """
    if path.is_dir() and (path / "runs.parquet").is_file():
        if export is not None:
            raise ValueError(f"{path} is a study folder; --export needs one run: give {path}/runs/<run_id>")
        typer.echo(format_study(path))
        return
    rrds, metrics = _find_recordings(path)
    for flag, given in (("--export", export), ("--screenshot", screenshot)):
        if given is not None and len(rrds) != 1:
            raise ValueError(f"{flag} needs exactly one recording; {path} holds {len(rrds)}: give the .rrd file")
    for rrd in rrds:
        typer.echo(format_summary(summarize_recording(rrd)))
    if metrics is not None:
        rec = _read_metrics(metrics)
        typer.echo(f"metrics ({metrics}): run {rec.get('run_id')!r}, seed {rec.get('seed')}")
        for k, value in {**rec.get("params", {}), **rec.get("metrics", {})}.items():
            typer.echo(f"  {k:<28} {value}")
    if export is not None:
        _export(rrds[0], export, contents)
    if screenshot is not None:
        _screenshot(rrds[0], screenshot)


def _export(rrd: Path, export: Path, contents) -> None:
    table, skipped = export_series(rrd, contents)
    if table.shape[1] < 2 or len(table) == 0:
        raise v.InputError(f"--contents {v.plain(contents)} matches no time series in {str(rrd)!r}: expected a pattern naming logged "
                           f"entities (see the listing above), e.g. '/truth/**'")
    write_table(export, table)
    typer.echo(f"exported {len(table)} rows x {table.shape[1]} columns to {export}")
    if skipped:
        typer.echo(f"not exported (not fixed-size numbers): {', '.join(skipped)}")


def _screenshot(rrd: Path, png: Path) -> None:
    """``png``: the recording as the viewer opens it; a viewer that cannot draw it is one line, exit 2."""
    from studies.recording.screenshot import ScreenshotError, screenshot_recording

    try:
        screenshot_recording(rrd, png)
    except ScreenshotError as e:
        raise v.InputError(f"--screenshot {str(png)!r}: {e}: expected a machine whose rerun draws headless (a Vulkan driver: "
                           "Debian mesa-vulkan-drivers)") from None
    typer.echo(f"drew {rrd} to {png}")


def register(app: typer.Typer) -> None:
    app.command("inspect")(inspect)
