"""Paper-style summary tables: Parquet for programs, CSV and Markdown for people.

A study's ``summarise`` returns :class:`Table` objects; :func:`write_tables`
writes each as ``DIR/<name>.parquet`` and ``DIR/<name>.csv`` and all of them
as one ``DIR/summary.md`` (a heading, the table, its notes), atomically.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import pandas as pd

from studies.engine.io import write_table, write_text


@dataclass(frozen=True)
class Table:
    """One table of a study: a file name, a title, the data, and how to print it.

    ``formats`` maps a column to a format spec (``".3g"``, ``".1%"``); other
    float columns print with ``default_format``. Column names carry units.
    """

    name: str
    title: str
    frame: pd.DataFrame
    notes: str = ""
    formats: Mapping[str, str] = field(default_factory=dict)
    default_format: str = ".4g"

    def __post_init__(self):
        if not self.name.replace("_", "").replace("-", "").isalnum():
            raise ValueError(f"table name {self.name!r} must be a file stem (letters, digits, '_', '-')")


def _cell(value, fmt: str) -> str:
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return "–"
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, float):
        return format(value, fmt)
    return _escape(str(value))


def _escape(text: str) -> str:
    """``text`` for a Markdown table cell: ``|`` escaped (``max ||q|-1|`` would split the row into cells), one line."""
    return text.replace("|", "\\|").replace("\n", " ")


def to_markdown(table: Table) -> str:
    """The table as GitHub-flavoured Markdown, with its title as a ``###`` heading and its notes below.

    Header and cells have their ``|`` escaped, so every row has as many cell
    separators as the header (column names such as ``|H| drift`` carry units and norms).
    """
    df = table.frame
    cols = [str(c) for c in df.columns]
    header = [_escape(c) for c in cols]
    lines = [f"### {table.title}", "", "| " + " | ".join(header) + " |", "|" + "|".join("---" for _ in cols) + "|"]
    for row in df.itertuples(index=False):
        cells = [_cell(v, table.formats.get(c, table.default_format)) for c, v in zip(cols, row)]
        lines.append("| " + " | ".join(cells) + " |")
    if table.notes:
        lines += ["", table.notes.strip()]
    return "\n".join(lines) + "\n"


def write_tables(out_dir, tables: Sequence[Table], *, heading: str = "") -> str:
    """Write every table (Parquet + CSV) and ``summary.md``; return the Markdown."""
    out_dir = Path(out_dir)
    names = [t.name for t in tables]
    if len(set(names)) != len(names):
        raise ValueError(f"table names must be unique, got {names}")
    parts = [f"## {heading}\n"] if heading else []
    for t in tables:
        write_table(out_dir / f"{t.name}.parquet", t.frame, csv=True)
        parts.append(to_markdown(t))
    text = "\n".join(parts)
    write_text(out_dir / "summary.md", text)
    return text
