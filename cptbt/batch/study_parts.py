"""A study folder's parts read without its task list (``cptbt plot`` of a stopped study): only
those that are its study's."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from cptbt.batch.comparison import study_json
from cptbt.batch.errors import BatchError
from cptbt.batch.journal import unsettled_rows
from cptbt.batch.store import PartError, Rows, _check_sum


def study_parts(folder: Path, fmt: Any, notes: list[str]) -> Rows:
    """The rows of the parts in ``folder/parts`` that are its study's, in group order: each
    part's checksum checked, its fingerprint against ``study.json``'s and its group against its
    name, and no run twice; a part that fails is left out and said in ``notes`` (a review:
    ``cptbt plot`` of a stopped study tabled a part copied in from another study, 52 runs under
    a header of 48, where ``cptbt batch`` refused it; a damaged part stopped the whole plot)."""
    meta = study_json(folder)  # empty when missing or unreadable
    tag = meta.get("fingerprint") if isinstance(meta.get("fingerprint"), str) else None
    count = meta.get("runs_per_start")
    if meta.get("until_sem") is not None or not isinstance(count, int) or isinstance(count, bool):
        count = None  # unknown, or adaptive: --until-sem adds replicates as it flies
    rows: Rows = []
    seen: set[tuple[Any, Any, Any]] = set()
    left: list[str] = []
    for path in sorted((folder / "parts").glob(f"*{fmt.suffix}")):
        try:
            got, part = fmt.read(path)
            _check_sum(got, part)
            assert part is not None
            if tag is not None and part.get("study") != tag:
                raise PartError("from another study or code version (its fingerprint is not "
                                "study.json's)")
            if part.get("group") != path.stem:
                raise PartError(f"holds group {part.get('group')}")
            keys = [(r.get("config"), r.get("replicate"), r.get("start")) for r in got]
            if seen.intersection(keys) or len(set(keys)) < len(keys):
                raise PartError("holds runs another part holds")
            if count is not None and any(int(r.get("replicate") or 0) >= count for r in got):
                raise PartError(f"a replicate beyond the study's {count} runs per start (kept "
                                "from a larger flight of it)")
        except PartError as exc:
            left.append(f"{path.name} ({exc})")
            continue
        seen.update(keys)
        rows.extend(got)
    if left and not rows and not unsettled_rows(folder):  # nothing to table: why, in a line
        raise BatchError(f"{folder}: no part could be read: " + "; ".join(left))
    if left:
        notes.append(f"{len(left)} part{'s' * (len(left) != 1)} left out of the tables: "
                     + "; ".join(left))
    if tag is None and rows:
        notes.append(f"{folder / 'study.json'} is missing or unreadable: the parts cannot be "
                     "checked to be one study's (a part copied from another would be tabled)")
    return rows

