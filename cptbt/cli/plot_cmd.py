"""``cptbt plot``: a study's figures and tables rebuilt from its results (registered with
``cptbt batch``, whose study it reads)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from cptbt.batch.comparison import study_json
from cptbt.batch.report import StudyGeometry
from cptbt.batch.store import load_results


def saved_study(results: Path) -> dict[str, Any]:
    """The study's ``study.json`` beside its results (empty if there is none or it cannot be
    read)."""
    return study_json(results if results.is_dir() else results.parent)


def _saved_geometry(results: Path) -> StudyGeometry | None:
    """The geometry a study saved in its ``study.json`` (None if there is none)."""
    return StudyGeometry.from_data(saved_study(results).get("geometry"))


def cmd_plot(args: argparse.Namespace) -> int:
    """Rebuild a study's figures and Markdown tables from its results table."""
    results = Path(args.results)
    rows = load_results(results)  # before making any folder: a bad input writes nothing
    out = Path(args.out) if args.out else (results if results.is_dir() else results.parent)
    from cptbt.batch.report import compared, write_report

    planned = saved_study(results).get("total_runs")
    planned = planned if isinstance(planned, int) and not isinstance(planned, bool) else None
    for note in compared(rows, planned)[1]:  # said before the tables that carry it
        print(f"cptbt plot: warning: {note}", file=sys.stderr)
    for path in write_report(rows, out, _saved_geometry(results), planned_runs=planned,
                             study=saved_study(results)):  # a --out elsewhere has none
        print(f"  wrote {path}")
    return 0
