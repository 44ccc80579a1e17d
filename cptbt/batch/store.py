"""Study results on disk: one part file per finished group, written atomically, and resume.

A group's rows reach disk all at once, by writing a temporary file and renaming it, so an
interrupted or crashed study keeps every finished group and none half-written; on resume, groups
whose part exists are skipped, so no run is lost or repeated.
"""

from __future__ import annotations

import csv
import json
import os
from pathlib import Path
from typing import Any

try:  # Parquet when pyarrow is installed (the ``results`` extra), CSV otherwise
    import pyarrow as pa
    import pyarrow.parquet as pq
except ImportError:  # pragma: no cover - depends on the install
    pa = pq = None

SUFFIX = ".parquet" if pq is not None else ".csv"


class ResultStore:
    """The results folder of a study."""

    def __init__(self, folder: Path) -> None:
        self.folder = Path(folder)
        self.parts = self.folder / "parts"

    def open(self, metadata: dict[str, Any], resume: bool = True) -> None:
        """Create the folder; refuse to mix two different studies in one folder.

        Raises:
            FileExistsError: the folder holds a different study's results.
        """
        self.parts.mkdir(parents=True, exist_ok=True)
        meta = self.folder / "study.json"
        metadata = json.loads(json.dumps(metadata, default=str))
        if meta.exists():
            old = json.loads(meta.read_text(encoding="utf-8"))
            same = {k: v for k, v in old.items() if k != "code_version"} == {
                k: v for k, v in metadata.items() if k != "code_version"}
            if not same:
                raise FileExistsError(
                    f"{self.folder} holds a different study; choose another --out or remove it")
            if not resume:
                for part in self.parts.iterdir():
                    part.unlink()
        _atomic_write_text(meta, json.dumps(metadata, indent=2, default=str) + "\n")

    def done(self) -> set[str]:
        """Keys of the groups already on disk."""
        if not self.parts.exists():
            return set()
        return {p.name.removesuffix(SUFFIX) for p in self.parts.glob(f"*{SUFFIX}")}

    def write_group(self, key: str, rows: list[dict[str, Any]]) -> None:
        """Write one finished group's rows atomically."""
        _write_table(rows, self.parts / f"{key}{SUFFIX}")

    def rows(self) -> list[dict[str, Any]]:
        """Every finished run, in group order."""
        out: list[dict[str, Any]] = []
        for part in sorted(self.parts.glob(f"*{SUFFIX}")):
            if pq is not None:
                out.extend(pq.read_table(part).to_pylist())
            else:
                with part.open(newline="", encoding="utf-8") as f:
                    out.extend(_typed(r) for r in csv.DictReader(f))
        return out

    def consolidate(self) -> Path:
        """Write the single results table (``results.parquet`` or ``results.csv``)."""
        rows = self.rows()
        cols = _columns(rows)
        path = self.folder / f"results{SUFFIX}"
        _write_table([{c: r.get(c) for c in cols} for r in rows], path)
        return path


def load_results(path: Path) -> list[dict[str, Any]]:
    """Rows of a results table, a results folder, or a folder of parts."""
    path = Path(path)
    if path.is_dir():
        for name in ("results.parquet", "results.csv"):
            if (path / name).exists():
                return load_results(path / name)
        return ResultStore(path).rows()
    if path.suffix == ".parquet":
        if pq is None:
            raise RuntimeError("reading Parquet needs pyarrow: pip install 'cptbt[results]'")
        return pq.read_table(path).to_pylist()
    with path.open(newline="", encoding="utf-8") as f:
        return [_typed(r) for r in csv.DictReader(f)]


def _write_table(rows: list[dict[str, Any]], path: Path) -> None:
    """Write rows as Parquet or CSV: to a temporary file first, then renamed into place."""
    tmp = path.with_name(f".{path.name}.tmp")
    if pq is not None:
        pq.write_table(pa.Table.from_pylist(rows), tmp)
    else:
        with tmp.open("w", newline="", encoding="utf-8") as f:
            writer = csv.DictWriter(f, fieldnames=_columns(rows))
            writer.writeheader()
            writer.writerows(rows)
    os.replace(tmp, path)


def _columns(rows: list[dict[str, Any]]) -> list[str]:
    cols: dict[str, None] = {}
    for r in rows:
        cols.update(dict.fromkeys(r))
    return list(cols)


def _typed(row: dict[str, str]) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for k, v in row.items():
        if v == "":
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


def _atomic_write_text(path: Path, text: str) -> None:
    tmp = path.with_name(f".{path.name}.tmp")
    tmp.write_text(text, encoding="utf-8")
    os.replace(tmp, path)
