"""A run that meets a bug does not stop its study: its group is recorded as failed (outcome
``error``, with the error and where it was raised), every other group is flown and tabulated,
the tables and the command say so, the exit fails, and ``cptbt run --from`` flies it alone."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import pytest

from cptbt.batch import worker
from cptbt.batch.store import load_results
from cptbt.cli import main

ROOT = Path(__file__).resolve().parents[2]
MISSION = str(ROOT / "missions/tro2006_msn007.yaml")
STUDY = ["--amp-only", "--grid", "2x1", "--runs-per-start", "2", "--time-limit", "60",
         "--workers", "1", "--no-plots", "--seed", "3"]


@pytest.fixture
def broken_replicate(monkeypatch: pytest.MonkeyPatch) -> list[int]:
    """Replicate 1's groups raise ZeroDivisionError; returns the replicates flown."""
    real = worker.fly_group
    flown: list[int] = []

    def fly(task: Any, *args: Any, **kwargs: Any) -> Any:
        flown.append(task.replicate)
        if task.replicate == 1:
            raise ZeroDivisionError("float division by zero")
        return real(task, *args, **kwargs)

    monkeypatch.setattr(worker, "fly_group", fly)
    return flown


def test_a_group_that_meets_an_error_is_recorded_and_the_study_goes_on(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], broken_replicate: list[int]) -> None:
    out = tmp_path / "study"
    assert main(["batch", MISSION, *STUDY, "--out", str(out)]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("cptbt: error: 2 of 4 runs stopped on an error")
    assert "ZeroDivisionError: float division by zero (at test_batch_run_errors.py:" in err[0]
    assert "--row 2" in err[0]
    rows = sorted(load_results(out), key=lambda r: (r["replicate"], r["start"]))
    assert [r["outcome"] for r in rows[2:]] == ["error", "error"]
    assert not any(r["success"] for r in rows[2:])
    assert all(r["outcome"] != "error" and r.get("error") is None for r in rows[:2])
    assert [r["start_x"] for r in rows[2:]] == [r["start_x"] for r in rows[:2]]
    tables = (out / "tables.md").read_text(encoding="utf-8")
    assert "**2 of 4 runs stopped on an error" in tables
    assert "| 4 | 0.0%" in tables  # counted as failures among the runs
    # resumed, nothing is flown again (the same seed meets the same error): said again
    flown = len(broken_replicate)
    assert main(["batch", MISSION, *STUDY, "--out", str(out)]) == 1
    assert len(broken_replicate) == flown
    assert "2 of 4 runs stopped on an error" in capsys.readouterr().err


def test_run_from_flies_a_failed_row_alone(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                           monkeypatch: pytest.MonkeyPatch,
                                           broken_replicate: list[int]) -> None:
    out = tmp_path / "study"
    assert main(["batch", MISSION, *STUDY, "--out", str(out)]) == 1
    capsys.readouterr()
    rows = load_results(out)
    row = next(i for i, r in enumerate(rows) if r["outcome"] == "error")
    results = str(out / "results.parquet")
    # the bug still there: one line, and the way to its traceback
    assert main(["run", "--from", results, "--row", str(row), "--out", str(tmp_path / "a"),
                 "--no-figure"]) != 0
    assert "internal error: ZeroDivisionError" in capsys.readouterr().err
    # the bug gone: flown, and said to be unlike the study's row, which stopped on an error
    monkeypatch.undo()
    assert main(["run", "--from", results, "--row", str(row), "--out", str(tmp_path / "b"),
                 "--no-figure"]) == 1
    said = capsys.readouterr().out
    assert "where the study's row stopped on an error (ZeroDivisionError" in said


@pytest.mark.skipif(not Path("/proc/self/fd").is_dir(), reason="needs /proc (Linux)")
def test_a_full_disk_names_the_part_keeps_the_finished_groups_and_resumes(
        tmp_path: Path, capsys: pytest.CaptureFixture[str],
        monkeypatch: pytest.MonkeyPatch) -> None:
    """The disk fills while the second group's part is written: the command says which file,
    that the finished groups are kept and how to go on, in one line; it leaves no half-written
    temporary file; and the same command then writes the lost group's part from the runs its
    journal kept, flying none again."""
    from cptbt.batch import store

    real = store.os.fsync

    def fsync(fd: int) -> None:  # the disk is full when replicate 1's part is written
        if "c000-r00001" in os.readlink(f"/proc/self/fd/{fd}"):
            raise OSError(28, "No space left on device")
        real(fd)

    monkeypatch.setattr(store.os, "fsync", fsync)
    out = tmp_path / "study"
    assert main(["batch", MISSION, *STUDY, "--out", str(out)]) == 1
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "Traceback" not in err
    assert err.startswith(f"cptbt: cannot write {out / 'parts'}/"), err
    assert "No space left on device" in err and "run the same command again" in err
    assert not list(out.rglob("*.tmp")), "a half-written part was left behind"
    assert len(list((out / "parts").glob("*.parquet"))) == 1

    monkeypatch.setattr(store.os, "fsync", real)
    assert main(["batch", MISSION, *STUDY, "--out", str(out)]) == 0
    said = capsys.readouterr().out
    assert "(2 groups resumed from disk)" in said and "none flown" in said, said
    assert len(load_results(out)) == 4
