"""Reading a recording back: what it holds (:func:`summarize_recording`) and its time series (:func:`export_series`).

The listing (entities, components, rows, the ``sim_time`` range) and the
export both query the recording with rerun's own dataframe API
(``rerun.chunk.RrdReader`` → ``ChunkStore.reader(index)``, a DataFusion
frame): the export is the proof that the recording holds the data, one row per
``sim_time`` step.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from studies.engine import validate as v
from studies.recording.writer import TIMELINE

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
            raise v.InputError(f"{str(path)!r} holds no recording: expected a rerun recording written by lcnav")
        return reader, recs[0], reader.stream(store=recs[0]).collect()
    except RuntimeError as e:  # rerun reports a malformed or truncated file as a RuntimeError
        raise v.InputError(f"{str(path)!r} is not a readable rerun recording ({v.plain(str(e), 160)[1:-1]}): expected a .rrd written by lcnav") from None


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
    arrays = [None if a is None or not a.size else a for a in arrays]  # an empty cell is a cleared row: a break in a line, no value
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
    their names are returned as the second item. Rows with no value at all (the
    cleared rows that break a plotted line at a light curve's gaps) are left out.
    """
    path = Path(path)
    _, _, store = _open_store(path)
    try:
        df = _time_frame(store, contents)
    except (ValueError, RuntimeError) as e:  # a malformed entity-path expression
        raise v.InputError(f"--contents {v.plain(contents)}: {v.plain(str(e), 160)[1:-1]}: expected entity-path expressions like '/truth/**'") from None
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
    frame = pd.DataFrame(out)
    values = frame.drop(columns=TIME_COLUMN)
    if values.shape[1]:
        frame = frame[values.notna().any(axis=1).to_numpy()].reset_index(drop=True)
    return frame, skipped


@dataclass(frozen=True)
class StoredView:
    """One view of the blueprint a recording carries: its kind (``TimeSeries``, ``BarChart``, ...), title and origin."""

    kind: str
    name: str
    origin: str


def blueprint_views(path) -> list[StoredView]:
    """The views of the blueprint stored in the ``.rrd`` at ``path``, in the order stored (none without a blueprint)."""
    reader, _, _ = _open_store(Path(path))
    views = []
    for store in reader.blueprints():
        for chunk in reader.stream(store=store):
            cols = chunk.to_record_batch().to_pydict()
            kinds = cols.get("ViewBlueprint:class_identifier", [])
            names, origins = (cols.get(f"ViewBlueprint:{k}", [None] * len(kinds)) for k in ("display_name", "space_origin"))
            views += [StoredView(k[0], n[0] if n else "", o[0] if o else "") for k, n, o in zip(kinds, names, origins) if k]
    return views
