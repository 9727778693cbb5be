"""``lcnav inspect PATH.rrd|RUN_DIR [--export OUT.parquet]``: what a recording holds, and its data back.

The listing (entities, components, rows, the ``sim_time`` range) and the
export both query the recording with rerun's own dataframe API
(``rerun.chunk.RrdReader`` → ``ChunkStore.reader(index)``, a DataFusion
frame): the export is the proof that the recording holds the data, one row per
``sim_time`` step. A run folder's ``metrics.json`` (written by the sweep) is
shown with it.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Optional

import numpy as np
import pandas as pd
import typer

from studies import validate as v
from studies.io import is_complete, write_table
from studies.recording import TIMELINE
from studies.sweep import RESULT_FILE

TIME_COLUMN = f"{TIMELINE}_s"


@dataclass(frozen=True)
class ColumnSummary:
    entity_path: str
    component: str
    static: bool
    rows: int  #: rows with data on the ``sim_time`` timeline (1 for static data)


@dataclass(frozen=True)
class RecordingSummary:
    path: Path
    application_id: str
    recording_id: str
    n_blueprints: int
    columns: list[ColumnSummary]
    n_steps: int  #: distinct ``sim_time`` values
    t_min_s: float
    t_max_s: float


def _open_store(path: Path):
    from rerun.chunk import RrdReader

    try:
        reader = RrdReader(path)
        recs = reader.recordings()
        if not recs:
            raise v.InputError(f"{str(path)!r} holds no recording; expected a rerun recording written by lcnav")
        return reader, recs[0], reader.stream(store=recs[0]).collect()
    except RuntimeError as e:  # rerun reports a malformed or truncated file as a RuntimeError
        raise v.InputError(f"{str(path)!r} is not a readable rerun recording ({v.plain(str(e), 160)[1:-1]}); expected a .rrd written by lcnav") from None


def _time_frame(store, contents=None) -> pd.DataFrame:
    if TIMELINE not in [c.name for c in store.schema().index_columns()]:
        return pd.DataFrame({TIMELINE: pd.Series([], dtype="timedelta64[ns]")})
    table = store.reader(TIMELINE, contents=contents).to_arrow_table()
    # tensors (a spectrum's BarChart) are dense unions that pandas cannot hold; they are static
    # data, never a time series, so they are left out here as export_series leaves out static data
    keep = [name for name, field in zip(table.column_names, table.schema) if not _holds_union(field.type)]
    return table.select(keep).to_pandas()


def _holds_union(arrow_type) -> bool:
    import pyarrow as pa

    if pa.types.is_union(arrow_type):
        return True
    return any(_holds_union(arrow_type.field(i).type) for i in range(arrow_type.num_fields))


def summarize_recording(path) -> RecordingSummary:
    """Entities, components, rows per component and the ``sim_time`` range of the ``.rrd`` at ``path``."""
    path = Path(path)
    reader, entry, store = _open_store(path)
    df = _time_frame(store)
    cols = []
    for c in store.schema().component_columns():
        if c.is_property:
            continue
        rows = 1 if c.is_static else (int(df[c.name].notna().sum()) if c.name in df else 0)
        cols.append(ColumnSummary(c.entity_path, c.component, bool(c.is_static), rows))
    t = df[TIMELINE].dt.total_seconds().to_numpy() if len(df) else np.array([np.nan])
    return RecordingSummary(path, entry.application_id, entry.recording_id, len(reader.blueprints()), cols,
                            int(len(df)), float(np.nanmin(t)), float(np.nanmax(t)))


def _cell_values(v) -> np.ndarray | None:
    """One cell of the reader's frame (an array, an array of arrays, or missing) as a flat float array."""
    if v is None or (isinstance(v, float) and np.isnan(v)):
        return None
    v = np.asarray(v)
    if v.dtype == object:
        v = np.concatenate([np.ravel(np.asarray(e)) for e in v]) if v.size else np.array([])
    return np.asarray(v, dtype=float).ravel()


def _flatten(name: str, series: pd.Series) -> dict[str, np.ndarray] | None:
    """A column of per-row arrays as float columns: one for length-1 cells, ``name[i]`` for fixed length k."""
    try:
        arrays = [_cell_values(v) for v in series]
    except (TypeError, ValueError):
        return None
    lengths = {a.size for a in arrays if a is not None}
    if len(lengths) != 1:
        return None
    k = lengths.pop()
    mat = np.full((len(arrays), k), np.nan)
    for i, a in enumerate(arrays):
        if a is not None:
            mat[i] = a
    if k == 1:
        return {name: mat[:, 0]}
    return {f"{name}[{j}]": mat[:, j] for j in range(k)}


def export_series(path, contents: list[str] | None = None) -> tuple[pd.DataFrame, list[str]]:
    """The time series of the ``.rrd`` at ``path`` as a table: ``sim_time_s`` and one float column per series.

    ``contents`` are rerun entity-path expressions (``/truth/**``); default all.
    Scalars become one column named by the entity path; fixed-size vectors
    (translations, quaternions) one column per element (``path:component[i]``).
    Static data and columns of other shapes (images, clouds) are left out;
    their names are returned as the second item.
    """
    path = Path(path)
    _, _, store = _open_store(path)
    try:
        df = _time_frame(store, contents)
    except (ValueError, RuntimeError) as e:  # a malformed entity-path expression
        raise v.InputError(f"--contents {v.plain(contents)}: {v.plain(str(e), 160)[1:-1]}; expected entity-path expressions like '/truth/**'") from None
    static = {c.name for c in store.schema().component_columns() if c.is_static}
    out = {TIME_COLUMN: df[TIMELINE].dt.total_seconds().to_numpy()}
    skipped = []
    for col in df.columns:
        if col == TIMELINE or col in static:
            continue
        entity, _, component = col.partition(":")
        name = entity if component == "Scalars:scalars" else col
        flat = _flatten(name, df[col])
        if flat is None:
            skipped.append(col)
        else:
            out.update(flat)
    return pd.DataFrame(out), skipped


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
        raise v.InputError(f"{str(path)!r} is not JSON ({type(e).__name__}); expected the metrics.json lcnav writes") from None
    if not isinstance(rec, dict) or not all(isinstance(rec.get(k, {}), dict) for k in ("params", "metrics")):
        raise v.InputError(f"{str(path)!r} holds no JSON object with 'params' and 'metrics' objects; expected the metrics.json lcnav writes")
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
        raise v.InputError(f"{str(table)!r} is not a readable Parquet table ({v.plain(str(e), 120)[1:-1]}); expected the runs table of `lcnav study`") from None
    if "run_id" not in runs.columns:
        raise v.InputError(f"{str(table)!r} has columns {v.plain(list(map(str, runs.columns)))} without 'run_id'; expected the runs table of `lcnav study`")
    done = is_complete(out_dir)
    state = f"complete ({done.get('command')}, {done.get('finished_utc')})" if done else "INCOMPLETE: no .complete.json (killed or failed; re-run the study on it to resume)"
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
    if export is not None:
        if len(rrds) != 1:
            raise ValueError(f"--export needs exactly one recording; {path} holds {len(rrds)}: give the .rrd file")
    for rrd in rrds:
        typer.echo(format_summary(summarize_recording(rrd)))
    if metrics is not None:
        rec = _read_metrics(metrics)
        typer.echo(f"metrics ({metrics}): run {rec.get('run_id')!r}, seed {rec.get('seed')}")
        for k, value in {**rec.get("params", {}), **rec.get("metrics", {})}.items():
            typer.echo(f"  {k:<28} {value}")
    if export is not None:
        table, skipped = export_series(rrds[0], contents)
        if table.shape[1] < 2 or len(table) == 0:
            raise v.InputError(f"--contents {v.plain(contents)} matches no time series in {str(rrds[0])!r}; expected a pattern naming logged "
                               f"entities (see the listing above), e.g. '/truth/**'")
        write_table(export, table)
        typer.echo(f"exported {len(table)} rows x {table.shape[1]} columns to {export}")
        if skipped:
            typer.echo(f"not exported (not fixed-size numbers): {', '.join(skipped)}")


def register(app: typer.Typer) -> None:
    app.command("inspect")(inspect)
