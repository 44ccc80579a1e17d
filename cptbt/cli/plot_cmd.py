"""``cptbt plot``: a study's figures and tables rebuilt from its results (registered with
``cptbt batch``, whose study it reads)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from cptbt.batch.comparison import code_change, study_json
from cptbt.batch.report import StudyGeometry
from cptbt.batch.store import load_results


def saved_study(results: Path) -> dict[str, Any]:
    """The study's ``study.json`` beside its results (empty if there is none or it cannot be
    read)."""
    return study_json(results if results.is_dir() else results.parent)


def cmd_plot(args: argparse.Namespace) -> int:
    """Rebuild a study's figures and Markdown tables from its results table."""
    results = Path(args.results)
    notes: list[str] = []
    rows = load_results(results, notes)  # before making any folder: a bad input writes nothing
    for note in notes:  # parts left out, or that nothing vouches for
        print(f"cptbt plot: warning: {note}", file=sys.stderr)
    out = Path(args.out) if args.out else (results if results.is_dir() else results.parent)
    from cptbt.batch.report import compared, write_report

    study = saved_study(results)
    record = (results if results.is_dir() else results.parent) / "study.json"
    if not study and record.exists():  # a review: a corrupt record was passed over in silence
        print(f"cptbt plot: warning: {record} cannot be read as a study's record: the tables "
              "say nothing of what was flown, and the figures draw no OpArea", file=sys.stderr)
    planned = study.get("total_runs")
    planned = planned if isinstance(planned, int) and not isinstance(planned, bool) else None
    for note in compared(rows, planned)[1]:  # said before the tables that carry it
        print(f"cptbt plot: warning: {note}", file=sys.stderr)
    change = code_change(study, str(record)) if planned is not None and len(rows) < planned \
        else None
    if change is not None:  # "the same arguments resume it" is then not so (a review)
        print(f"cptbt plot: warning: the study was flown by cptbt {change[0]}, this is "
              f"{change[1]}: `cptbt batch` resumes it only with the code it was flown by "
              "(--restart discards its runs)", file=sys.stderr)
    for path in write_report(rows, out, StudyGeometry.from_data(study.get("geometry")),
                             planned_runs=planned, study=study):  # a --out elsewhere has none
        print(f"  wrote {path}")
    return 0
