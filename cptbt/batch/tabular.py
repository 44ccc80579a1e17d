"""Rows as a CSV results table holds them: the column list, the typed read-back, and the round
trip a row makes through it (so rows that never went through a CSV part compare equal with
those that did)."""

from __future__ import annotations

import csv
import io
from typing import Any

Rows = list[dict[str, Any]]


def columns(rows: Rows) -> list[str]:
    cols: dict[str, None] = {}
    for r in rows:
        cols.update(dict.fromkeys(r))
    return list(cols)


def csv_rows(text: str) -> Rows:
    rows = []
    for row in csv.DictReader(io.StringIO(text, newline="")):
        if None in row:
            raise ValueError("a row has more fields than the header")
        rows.append(typed(row))
    return rows


def typed(row: dict[str, str | None]) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for k, v in row.items():
        if v == "" or v is None:
            out[k] = None
        elif v in ("True", "False"):
            out[k] = v == "True"
        else:
            try:
                out[k] = int(v)
            except ValueError:
                try:
                    out[k] = float(v)
                except ValueError:
                    out[k] = v
    return out


def as_csv_reads(rows: Rows) -> Rows:
    """``rows`` as a CSV part gives them back (a list-valued setting comes back as its text):
    a journal's rows beside CSV parts had kept lists, and a study stopped part way paired none
    of its configurations (a diff review)."""
    if not rows:
        return rows
    buffer = io.StringIO(newline="")
    writer = csv.DictWriter(buffer, fieldnames=columns(rows))
    writer.writeheader()
    writer.writerows(rows)
    return csv_rows(buffer.getvalue())
