"""A group's journal: the rows of its runs finished so far, kept while the group flies.

The worker appends each run's row as soon as the run ends, one JSON line carrying the study's
fingerprint, the group and the row's checksum (:func:`journal_line`); a resume reads back the
sound lines (:func:`read_journal`) and flies only the rest of the group; the study removes the
journal once the group's part is written (:mod:`cptbt.batch.store`). A run flown again alone is
the same run (its seeds are its own): the resumed table is the uninterrupted one in every column
but ``wall_time_s``, the group's wall time to that run's end shared over its runs, a measure of
the machine.
"""

from __future__ import annotations

import json
import os
from collections.abc import Iterator
from pathlib import Path
from typing import Any, TextIO

from cptbt.batch.integrity import rows_checksum
from cptbt.batch.study import GroupTask

Rows = list[dict[str, Any]]

JOURNAL_SUFFIX = ".runs.jsonl"
"""A journal's file name after its group's key, in the study's ``parts/``."""


def journal_line(tag: str, key: str, row: dict[str, Any]) -> str:
    """One journal line: the row, its group, the study's fingerprint and the row's checksum
    (a torn or edited line is never taken for a run)."""
    plain = json.loads(json.dumps(row, default=_plain))
    return json.dumps({"study": tag, "group": key, "sha256": rows_checksum([plain]),
                       "row": plain}) + "\n"


def _plain(value: Any) -> Any:
    as_list = getattr(value, "tolist", None)  # a numpy scalar or array
    return as_list() if callable(as_list) else str(value)


def _sound_rows(path: Path, tag: str, key: str) -> Iterator[dict[str, Any]]:
    """The rows of the journal at ``path`` whose lines are whole, unedited (their checksum
    holds) and of study ``tag`` and group ``key``; none if the file cannot be read. Read line
    by line as bytes: a line that is not UTF-8 is one bad line (a review: one stray byte had
    lost every run of the journal)."""
    try:
        data = path.read_bytes()
    except OSError:
        return
    for line in data.splitlines():
        try:
            entry = json.loads(line.decode("utf-8"))
            row = entry["row"]
            ok = (entry["study"] == tag and entry["group"] == key
                  and entry["sha256"] == rows_checksum([row]) and isinstance(row["start"], int))
        except (ValueError, TypeError, KeyError):
            continue
        if ok:
            yield row


def read_journal(path: Path, tag: str, task: GroupTask) -> Rows:
    """The rows of ``task``'s runs the journal at ``path`` holds, one per start, in start
    order; lines torn by a kill, edited, of another study (``tag``) or group, or of a start
    not in the task are left out (those runs are flown again)."""
    ids = set(task.ids)
    rows: dict[int, dict[str, Any]] = {}
    for row in _sound_rows(path, tag, task.key):
        if (row["start"] in ids and row.get("config") == task.config
                and row.get("replicate") == task.replicate):
            rows.setdefault(row["start"], row)
    return [rows[i] for i in sorted(rows)]


def study_tag(folder: Path) -> str | None:
    """The fingerprint study ``folder``'s ``study.json`` records (None: none, or unreadable)."""
    try:
        tag = json.loads((folder / "study.json").read_text(encoding="utf-8"))["fingerprint"]
    except (OSError, ValueError, UnicodeDecodeError, TypeError, KeyError):
        return None
    return tag if isinstance(tag, str) else None


def unsettled_rows(folder: Path) -> Rows:
    """The rows the journals in study ``folder``'s ``parts/`` hold for groups with no part
    (a ``.parquet`` or ``.csv`` file), for a table of a study stopped part way (``cptbt plot``
    had left them out while the batch counted them saved): sound lines of the study its
    ``study.json`` names only (none if it cannot be read), one per group and start, in group
    and start order."""
    tag = study_tag(folder)
    if tag is None:
        return []
    parts = folder / "parts"
    settled = {p.stem for p in parts.glob("*") if p.suffix in (".parquet", ".csv")}
    rows: dict[tuple[str, int], dict[str, Any]] = {}
    for path in sorted(parts.glob(f"*{JOURNAL_SUFFIX}")):
        key = path.name[: -len(JOURNAL_SUFFIX)]
        if key not in settled:
            for row in _sound_rows(path, tag, key):
                rows.setdefault((key, row["start"]), row)
    return [rows[k] for k in sorted(rows)]


class JournalFile:
    """The file a worker appends a group's rows to (flushed line by line: a killed process
    keeps them in the page cache). One that cannot be written (a full disk) or a row JSON
    cannot hold is given up, silently: the group's part is written whole when it ends all
    the same."""

    def __init__(self, path: str, tag: str, key: str) -> None:
        self.path, self.tag, self.key = Path(path), tag, key
        self.file: TextIO | None = None
        self.given_up = False

    def write(self, row: dict[str, Any]) -> None:
        """Append one run's row."""
        if self.given_up:
            return
        try:
            line = journal_line(self.tag, self.key, row)
            if self.file is None:
                self.file = open_journal(self.path)
            self.file.write(line)
            self.file.flush()
        except (OSError, ValueError, TypeError):
            self.given_up = True

    def close(self) -> None:
        """Close the file, if it was opened."""
        if self.file is not None:
            self.file.close()
            self.file = None


def open_journal(path: Path) -> TextIO:
    """A journal opened to append, after ending a line a kill tore (the next line would
    otherwise join it and be lost with it: a review)."""
    f = path.open("a", encoding="utf-8")
    try:
        with path.open("rb") as old:
            old.seek(0, os.SEEK_END)
            if old.tell():
                old.seek(-1, os.SEEK_END)
                if old.read(1) != b"\n":
                    f.write("\n")
    except OSError:
        f.close()
        raise
    return f
