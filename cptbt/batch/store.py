"""Study results on disk: one part file per finished group, written atomically, checked on resume.

A group's rows reach disk all at once, by writing a temporary file, syncing it and renaming it,
so an interrupted or crashed study keeps every finished group and none half-written; the runs a
group under way had finished are kept in its journal (:mod:`cptbt.batch.journal`). Each part
also carries its group's identity, the study's fingerprint (``integrity``) and a checksum of
its rows, in the Parquet key-value metadata (or a ``.json`` sidecar beside a CSV part). A
resume keeps only the parts that pass every check and re-runs the others, saying why: a part
that is empty, truncated or garbage, changed since it was written, copied from another study,
or written by other code is never mixed into the results.
"""

from __future__ import annotations

import atexit
import csv
import io
import json
import os
from collections import Counter
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, BinaryIO

from cptbt.batch.errors import BatchError, CodeChanged
from cptbt.batch.integrity import fingerprint, rows_checksum
from cptbt.batch.journal import JOURNAL_SUFFIX, read_journal, unsettled_rows
from cptbt.batch.study import GroupTask
from cptbt.batch.study_diff import differences
from cptbt.batch.tabular import as_csv_reads, columns, csv_rows

try:  # Parquet when pyarrow is installed (the ``results`` extra), CSV otherwise
    import pyarrow as pa
    import pyarrow.parquet as pq
except ImportError:  # pragma: no cover - depends on the install
    pa = pq = None

Rows = list[dict[str, Any]]
META_KEY = "cptbt"
LOCK_NAME = ".lock"
"""The file a writing study holds locked (see :meth:`ResultStore.open`)."""
_HELD: dict[Path, Any] = {}
"""The folders this process holds locked, with their open lock files (kept until it ends)."""


def _unlock(key: Path) -> None:
    """At a clean exit: empty ``.lock`` (it keeps no pid of a process that has ended) and
    release it. A crash leaves the pid, and the kernel releases the lock all the same."""
    f = _HELD.pop(key, None)
    if f is None:
        return
    try:
        f.seek(0)
        f.truncate()
        f.close()  # closing the file releases the flock
    except OSError:  # pragma: no cover - a folder removed under us
        pass


FORMAT = 1
# Columns every results table has (the figures and tables are built from them).
REQUIRED_COLUMNS = ("config", "replicate", "start", "start_x", "start_y", "success")


class StudyMismatch(BatchError):
    """The results folder holds a different study (other mission or options)."""


class PartError(Exception):
    """A part or table that cannot be trusted; the message says why, in a few words."""


class _Parquet:
    suffix = ".parquet"

    def write(self, path: Path, rows: Rows, meta: dict[str, Any]) -> None:
        if pq is None:  # pragma: no cover - depends on the install
            raise BatchError("writing Parquet needs pyarrow: pip install 'cptbt[results]'")
        # from_pylist takes its columns from the first row: give every row every column, or a
        # column only later rows have (a behaviour one vehicle never used) would be dropped.
        cols = columns(rows)
        table = pa.Table.from_pylist([{c: r.get(c) for c in cols} for r in rows])
        meta = {**meta, "rows": table.num_rows, "sha256": rows_checksum(table.to_pylist())}
        table = table.replace_schema_metadata({META_KEY: json.dumps(meta)})
        _atomic_write(path, lambda f: pq.write_table(table, f))

    def read(self, path: Path) -> tuple[Rows, dict[str, Any] | None]:
        if pq is None:  # pragma: no cover - depends on the install
            raise BatchError("reading Parquet needs pyarrow: pip install 'cptbt[results]'")
        _check_not_empty(path)
        try:
            table = pq.read_table(path)
            rows = table.to_pylist()
        except (pa.ArrowException, OSError, ValueError) as exc:
            raise PartError(f"unreadable ({_first_line(exc)})") from None
        raw = (table.schema.metadata or {}).get(META_KEY.encode())
        return rows, None if raw is None else _parse_meta(raw)


class _Csv:
    suffix = ".csv"

    def write(self, path: Path, rows: Rows, meta: dict[str, Any]) -> None:
        buffer = io.StringIO(newline="")
        writer = csv.DictWriter(buffer, fieldnames=columns(rows))
        writer.writeheader()
        writer.writerows(rows)
        text = buffer.getvalue()
        seen = csv_rows(text)  # the checksum is of what a reader will see
        meta = {**meta, "rows": len(seen), "sha256": rows_checksum(seen)}
        # Sidecar first: a crash between the two renames leaves a mismatch, never a false match.
        _atomic_write(_sidecar(path), lambda f: f.write(json.dumps(meta).encode("utf-8")))
        _atomic_write(path, lambda f: f.write(text.encode("utf-8")))

    def read(self, path: Path) -> tuple[Rows, dict[str, Any] | None]:
        _check_not_empty(path)
        try:
            rows = csv_rows(path.read_text(encoding="utf-8"))
        except (OSError, ValueError, csv.Error) as exc:
            raise PartError(f"unreadable ({_first_line(exc)})") from None
        sidecar = _sidecar(path)
        try:
            raw = sidecar.read_bytes()
        except FileNotFoundError:
            return rows, None
        except OSError as exc:
            raise PartError(f"unreadable checksum file ({_first_line(exc)})") from None
        return rows, _parse_meta(raw)


_FORMATS: dict[str, _Parquet | _Csv] = {"parquet": _Parquet(), "csv": _Csv()}
DEFAULT_FORMAT = "parquet" if pq is not None else "csv"
SUFFIX = _FORMATS[DEFAULT_FORMAT].suffix


@dataclass
class Resume:
    """What a results folder already holds of a study."""

    done: set[str] = field(default_factory=set)
    """Keys of the groups whose parts passed every check."""
    rerun: dict[str, str] = field(default_factory=dict)
    """Keys of the groups whose parts failed a check, and why."""
    partial: dict[str, Rows] = field(default_factory=dict)
    """Keys of unfinished groups whose journal holds finished runs, and those runs' rows."""
    runs: int = 0
    successes: int = 0


class ResultStore:
    """The results folder of a study: ``study.json``, ``parts/`` and the consolidated table."""

    def __init__(self, folder: Path, fmt: str = DEFAULT_FORMAT) -> None:
        """A store in ``folder``, writing ``fmt`` ("parquet" or "csv") files."""
        self.folder = Path(folder)
        self.parts = self.folder / "parts"
        self.format = _FORMATS[fmt]
        self.fingerprint = ""

    def open(self, metadata: dict[str, Any], *, study: str, code: str,
             restart: bool = False) -> None:
        """Create the folder, or take it up again: refuse to mix studies or code versions.

        Args:
            metadata: what ``study.json`` records for people (the command, sweeps, seeds).
            study: the study's identity (``Study.identity()``).
            code: the code identity (``integrity.code_identity()``).
            restart: discard the folder's finished groups, e.g. after the code changed.

        Raises:
            StudyMismatch: the folder holds a different study (``restart`` does not help).
            CodeChanged: the folder's results were made by other code, or its ``study.json``
                is unreadable, and ``restart`` is false.
            BatchError: ``folder`` exists and is not a folder, or another process is
                writing it (``.lock``).
        """
        if self.folder.exists() and not self.folder.is_dir():
            raise BatchError(f"{self.folder} exists and is not a folder")
        ours = [self.folder / f"results{f.suffix}" for f in _FORMATS.values()]
        if (not (self.folder / "study.json").exists() and any(p.exists() for p in ours)
                and not any(self.parts.glob("*"))):  # a review's --out overwrote a user's table
            raise StudyMismatch(f"{self.folder} holds a results table but no study.json or "
                                "parts/: not a study's folder")
        if self.parts.exists() and not self.parts.is_dir():  # "File exists" said nothing
            raise BatchError(f"{self.parts} exists and is not a folder (a study keeps its runs "
                             "there): move it aside")
        self.parts.mkdir(parents=True, exist_ok=True)
        self._lock()
        meta = self.folder / "study.json"
        if meta.exists():
            try:
                old = json.loads(meta.read_text(encoding="utf-8"))
                if not isinstance(old, dict):
                    raise ValueError("not a JSON object")
            except (ValueError, UnicodeDecodeError) as exc:
                if not restart:
                    raise CodeChanged(f"{meta} is unreadable ({_first_line(exc)})") from None
                old = {}
            if old and old.get("study") not in (None, study):
                raise StudyMismatch(f"{self.folder} holds a different study ("
                                    f"{differences(old, metadata)})")
            if old and old.get("code") != code and not restart:
                if old.get("code"):
                    raise CodeChanged(
                        f"{self.folder} was made by cptbt {old['code']}, this is {code} (the "
                        "code identity covers cptbt's source, the source of the behaviour "
                        "plug-ins the study flies, and numpy's and py_trees' versions)")
                raise CodeChanged(f"{self.folder} was made by an older cptbt "
                                  f"({old.get('code_version', 'version unknown')})")
        if restart:
            self._discard()
        self.fingerprint = fingerprint(study, code)
        record = {**metadata, "study": study, "code": code, "fingerprint": self.fingerprint}
        text = json.dumps(record, indent=2, default=str) + "\n"
        _atomic_write(meta, lambda f: f.write(text.encode("utf-8")))

    def _lock(self) -> None:
        """Hold ``.lock`` in the folder until this process ends: one writing process per folder.

        Two studies writing one folder at once would each take the other's finished parts for
        their own and race on ``study.json`` and the consolidated table (a ``--restart`` would
        even delete the other's parts under it). An advisory ``flock`` is released by the
        kernel when the process ends, however it ends, so a crashed or killed batch never
        leaves a stale lock. Where ``fcntl`` does not exist (Windows) folders are not locked.

        Raises:
            BatchError: another process holds the folder.
        """
        key = self.folder.resolve()
        if key in _HELD:  # this process holds it already (another store on the same folder)
            return
        try:
            import fcntl
        except ImportError:  # pragma: no cover - not POSIX
            return
        f = (self.folder / LOCK_NAME).open("a+", encoding="utf-8")
        try:
            fcntl.flock(f.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            f.seek(0)
            holder = f.read().strip() or "unknown"
            f.close()
            raise BatchError(
                f"{self.folder} is being written by another cptbt batch (pid {holder}): wait "
                "for it to end, or choose another --out") from None
        f.seek(0)
        f.truncate()
        f.write(f"{os.getpid()}\n")
        f.flush()
        _HELD[key] = f
        atexit.register(_unlock, key)  # a finished folder's .lock named a dead pid (a review)

    def path(self, key: str) -> Path:
        """The part file of group ``key``."""
        return self.parts / f"{key}{self.format.suffix}"

    def journal_path(self, key: str) -> Path:
        """The journal of group ``key`` (its runs finished before it was)."""
        return self.parts / f"{key}{JOURNAL_SUFFIX}"

    def journal_rows(self, task: GroupTask) -> Rows:
        """The rows of ``task``'s runs its journal holds, one per start, in start order; lines
        torn by a kill, edited, of another study or group, or of a start not in the task are
        left out (those runs are flown again)."""
        return read_journal(self.journal_path(task.key), self.fingerprint, task)

    def check(self, tasks: Sequence[GroupTask]) -> Resume:
        """Which groups are finished on disk, which parts must be re-run and why, and the
        finished runs of the groups under way when the study stopped."""
        resume = Resume()
        for task in tasks:
            rows: Rows = []
            if self.path(task.key).exists():
                try:
                    rows = self._verified(task)
                except PartError as exc:
                    resume.rerun[task.key] = str(exc)
                    continue
                resume.done.add(task.key)
                # killed between writing the part and removing the journal: a leftover
                self.journal_path(task.key).unlink(missing_ok=True)
            else:
                rows = self.journal_rows(task)
                if not rows:
                    continue
                resume.partial[task.key] = rows
            resume.runs += len(rows)
            resume.successes += sum(bool(r.get("success")) for r in rows)
        return resume

    def write_group(self, task: GroupTask, rows: Rows) -> None:
        """Write one finished group's rows atomically, with its identity and checksum.

        Raises:
            BatchError: the part could not be written (a full disk, say): the message names it,
                and says that the groups already written are kept and the same command resumes.
        """
        path = self.path(task.key)
        try:
            self.format.write(path, rows, {
                "format": FORMAT, "study": self.fingerprint, "group": task.key,
                "config": task.config, "replicate": task.replicate,
            })
        except OSError as exc:
            raise BatchError(f"cannot write {path}: {exc.strerror or _first_line(exc)}; the "
                             f"finished groups are kept in {self.parts}: make room and run "
                             "the same command again to go on") from None
        self.journal_path(task.key).unlink(missing_ok=True)  # its runs are in the part now

    def rows(self, tasks: Sequence[GroupTask]) -> Rows:
        """Every run of ``tasks``, in group order (a folder's parts without its tasks:
        :func:`load_results`).

        Raises:
            BatchError: a part is missing or fails a check.
        """
        out: Rows = []
        for task in tasks:
            try:
                out.extend(self._verified(task))
            except (PartError, FileNotFoundError) as exc:
                raise BatchError(f"{self.path(task.key)}: {exc}") from None
        return out

    def left_out(self, tasks: Sequence[GroupTask]) -> int:
        """The runs of this study's finished groups on disk that ``tasks`` do not include (a
        review: a finished study run again with a smaller ``--runs-per-start``, or a looser
        ``--until-sem``, was tabled from a subset without a word of the rest)."""
        keys = {t.key for t in tasks}
        n = 0
        for path in self.parts.glob(f"*{self.format.suffix}"):
            if path.stem not in keys:
                try:
                    rows, meta = self.format.read(path)
                except PartError:
                    continue
                n += len(rows) if meta is not None and meta.get("study") == self.fingerprint \
                    else 0
        return n

    def consolidate(self, tasks: Sequence[GroupTask]) -> Path:
        """Write the single results table (``results.parquet`` or ``results.csv``)."""
        rows = self.rows(tasks)
        cols = columns(rows)
        path = self.folder / f"results{self.format.suffix}"
        try:
            self.format.write(path, [{c: r.get(c) for c in cols} for r in rows],
                              {"format": FORMAT, "study": self.fingerprint})
        except OSError as exc:
            raise BatchError(f"cannot write {path}: {exc.strerror or _first_line(exc)}; every "
                             f"run is kept in {self.parts}: make room and run the same command "
                             "again to write it") from None
        return path

    def _verified(self, task: GroupTask) -> Rows:
        rows, meta = self.format.read(self.path(task.key))
        _check_sum(rows, meta)
        assert meta is not None
        if meta.get("study") != self.fingerprint:
            raise PartError("from another study or code version (its fingerprint differs)")
        if meta.get("group") != task.key:
            raise PartError(f"holds group {meta.get('group')}, not {task.key}")
        got = Counter((r.get("config"), r.get("replicate"), r.get("start")) for r in rows)
        want = Counter((task.config, task.replicate, i) for i in range(len(task.starts)))
        if got != want:
            raise PartError(f"its rows are not the {len(task.starts)} runs of group {task.key}")
        return rows

    def _discard(self) -> None:
        """Delete the finished groups, their journals and the consolidated table: files named
        as a group's (``c000-r00001``), nothing else in the folder (a review's own
        ``parts/my.csv`` had gone with a ``--restart``)."""
        for path in self.parts.glob(f"c*-r*{JOURNAL_SUFFIX}"):
            path.unlink()
        for fmt in _FORMATS.values():
            for path in self.parts.glob(f"c[0-9]*-r[0-9]*{fmt.suffix}"):
                path.unlink()
                _sidecar(path).unlink(missing_ok=True)
            (self.folder / f"results{fmt.suffix}").unlink(missing_ok=True)
            _sidecar(self.folder / f"results{fmt.suffix}").unlink(missing_ok=True)


def load_results(path: Path, notes: list[str] | None = None) -> Rows:
    """Rows of a results table, a results folder, or a folder of parts.

    A folder without a results table is read from its parts that are its study's (their
    checksums, fingerprints and groups checked: :func:`~cptbt.batch.study_parts.study_parts`);
    ``notes`` gets a sentence on each part left out, and on parts no ``study.json`` vouches for.

    Raises:
        BatchError: nothing readable there, a checksum that does not match, or a table that is
            not a cptbt results table.
    """
    path = Path(path)
    if not path.exists():
        raise BatchError(f"{path}: No such file or directory")  # as the system words it
    if path.is_dir():
        for fmt in _FORMATS.values():
            if (path / f"results{fmt.suffix}").exists():
                return load_results(path / f"results{fmt.suffix}")
        rows, found = [], _FORMATS[DEFAULT_FORMAT]
        for fmt in _FORMATS.values():
            if any((path / "parts").glob(f"*{fmt.suffix}")):
                from cptbt.batch.study_parts import study_parts

                rows, found = study_parts(path, fmt, notes if notes is not None else []), fmt
                break
        unsettled = unsettled_rows(path)  # runs of groups stopped part way, as parts read
        rows += as_csv_reads(unsettled) if isinstance(found, _Csv) else unsettled
        if not rows:
            raise BatchError(f"{path} holds no results table (results.parquet or results.csv) "
                             "and no parts/")
    elif path.suffix.lower() not in (".parquet", ".csv"):
        raise BatchError(f"{path} is not a results table (results.parquet or results.csv) "
                         "or a study's folder")
    else:
        try:
            rows = _read_checked(_FORMATS["parquet" if path.suffix == ".parquet" else "csv"],
                                 path)
        except BatchError as exc:  # a review: the way out was not said
            if path.stem == "results" and any((path.parent / "parts").glob("*")):
                raise BatchError(f"{exc}; the study's parts/ are read without it: delete it, "
                                 "or run the batch command again to write it anew") from None
            raise
    _check_columns(rows, path)
    return rows


def _read_checked(fmt: _Parquet | _Csv, path: Path) -> Rows:
    """Rows of one table; its checksum is checked if it has one (tables made elsewhere have not).
    """
    try:
        rows, meta = fmt.read(path)
        if meta is not None:
            _check_sum(rows, meta)
    except PartError as exc:
        raise BatchError(f"{path}: {exc}") from None
    return rows


def _check_sum(rows: Rows, meta: dict[str, Any] | None) -> None:
    if meta is None:
        raise PartError("no checksum (written by an older cptbt, or not by cptbt)")
    if meta.get("sha256") != rows_checksum(rows):
        raise PartError("checksum mismatch (changed since it was written)")


def _check_columns(rows: Rows, path: Path) -> None:
    if not rows:
        raise BatchError(f"{path}: no results in it")
    missing = [c for c in REQUIRED_COLUMNS if any(c not in r for r in rows)]
    if missing:
        raise BatchError(f"{path}: not a cptbt results table (no column {', '.join(missing)})")
    bad = [r for r in rows if not all(isinstance(r[c], int | float) and not isinstance(r[c], bool)
                                      for c in ("start_x", "start_y"))]
    if bad:
        raise BatchError(f"{path}: not a cptbt results table (start_x, start_y not numbers)")


def _check_not_empty(path: Path) -> None:
    try:
        size = path.stat().st_size
    except OSError as exc:
        raise PartError(f"unreadable ({_first_line(exc)})") from None
    if size == 0:
        raise PartError("empty file")


def _parse_meta(raw: bytes) -> dict[str, Any]:
    try:
        meta = json.loads(raw)
    except (ValueError, UnicodeDecodeError):
        raise PartError("damaged metadata") from None
    if not isinstance(meta, dict):
        raise PartError("damaged metadata")
    return meta


def _sidecar(path: Path) -> Path:
    return path.with_name(f"{path.name}.json")


def _first_line(exc: BaseException) -> str:
    text = str(exc).strip().splitlines()
    return text[0] if text else type(exc).__name__


def _atomic_write(path: Path, write: Callable[[BinaryIO], object]) -> None:
    """Write through ``write(binary_file)`` to a temporary file, sync it, rename it into place."""
    tmp = path.with_name(f".{path.name}.tmp")
    try:
        with tmp.open("wb") as f:
            write(f)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:  # a full disk, say, or Ctrl-C mid-write: leave no half-written file
        tmp.unlink(missing_ok=True)
        raise
