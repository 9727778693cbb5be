"""Markdown tables render: every row has as many unescaped ``|`` as the header (issue 30: ``study truth``'s header did not)."""

import re

import pandas as pd

from studies.engine.tables import Table, to_markdown

#: a ``|`` not preceded by a backslash: a cell separator
SEPARATOR = re.compile(r"(?<!\\)\|")


def table_rows(markdown: str) -> list[str]:
    return [line for line in markdown.splitlines() if line.startswith("|")]


def assert_rows_align(markdown: str, n_columns: int) -> None:
    rows = table_rows(markdown)
    assert len(rows) >= 3  # header, rule, at least one row
    counts = [len(SEPARATOR.findall(row)) for row in rows]
    assert counts == [n_columns + 1] * len(rows), dict(zip(rows, counts))


def test_pipes_in_names_and_cells_are_escaped():
    frame = pd.DataFrame({"scenario": ["SC1", "a|b"], "|H| drift": [1e-12, 2e-12], "max ||q|-1|": [3e-16, 0.0], "runs < 1 mm": [3, 3]})
    text = to_markdown(Table("summary", "RK4 of eq. 21", frame))
    assert_rows_align(text, 4)
    assert "| \\|H\\| drift |" in text and "max \\|\\|q\\|-1\\|" in text and "a\\|b" in text


def test_truth_study_summary_renders(quick_truth):
    text = (quick_truth / "summary.md").read_text()
    header = table_rows(text)[0]
    n_columns = len(SEPARATOR.findall(header)) - 1
    assert n_columns == len(pd.read_parquet(quick_truth / "summary.parquet").columns)  # the header's cells are the table's columns
    assert_rows_align(text, n_columns)
