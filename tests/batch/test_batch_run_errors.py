"""A run that meets a bug does not stop its study: its group is recorded as failed (outcome
``error``, with the error and where it was raised), every other group is flown and tabulated,
the tables and the command say so, the exit fails, and ``cptbt run --from`` flies it alone."""

from __future__ import annotations

import os
import time
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


def _rows(out: Path) -> list[dict[str, Any]]:
    return sorted(load_results(out), key=lambda r: (r["replicate"], r["start"]))


SAME = ("sim_time_s", "path_m", "closest_approach_m", "farthest_outside_m", "t1")
"""Columns a run flown again alone gives as it did in its group."""


def test_a_run_that_raises_is_the_only_error_of_its_group(
        tmp_path: Path, capsys: pytest.CaptureFixture[str],
        monkeypatch: pytest.MonkeyPatch) -> None:
    """A review's plug-in raised in one run at t = 983 s, and every run of its group (a
    replicate: every start of one plume) became an error row with that run's message, three of
    them home by 474 s. The run that raised is the error; the others are flown again without it
    and are the runs a study without the fault flies."""
    from cptbt.planner import Planner

    clean = tmp_path / "clean"
    assert main(["batch", MISSION, *STUDY, "--out", str(clean)]) == 0
    want = _rows(clean)
    bad_start = (want[1]["start_x"], want[1]["start_y"])
    real = Planner.tick

    def tick(self: Planner, t: float) -> Any:
        start = self.context.start
        if t >= 30.0 and start is not None and (start.x, start.y) == bad_start:
            raise KeyError("a plug-in's bug")
        return real(self, t)

    monkeypatch.setattr(Planner, "tick", tick)
    out = tmp_path / "study"
    assert main(["batch", MISSION, *STUDY, "--out", str(out)]) == 1
    err = capsys.readouterr().err
    assert "2 of 4 runs stopped on an error" in err  # start 1 of each replicate, not 4 of 4
    rows = _rows(out)
    assert [r["outcome"] == "error" for r in rows] == [False, True, False, True]
    for got, clean_row in zip(rows[::2], want[::2], strict=True):  # flown again alone
        assert {k: got[k] for k in SAME} == {k: clean_row[k] for k in SAME}
    # ... and the errors count at the time limit in the mean search time, as failures do
    assert all(r["run_time_limit_s"] == 60.0 for r in rows)
    tables = (out / "tables.md").read_text(encoding="utf-8")
    assert "**2 of 4 runs stopped on an error" in tables
    # the error row flown again alone meets its error again, and writes what it flew (a review)
    row = str(next(i for i, r in enumerate(load_results(out)) if r["outcome"] == "error"))
    again = tmp_path / "again"
    capsys.readouterr()
    assert main(["run", "--from", str(out / "results.parquet"), "--row", row, "--out",
                 str(again)]) != 0
    assert "KeyError" in capsys.readouterr().err
    assert (again / "trajectory.png").exists() and any(again.glob("trace.*"))


def test_the_runs_that_had_ended_keep_their_rows(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """An error in one run's end (its row) after another run of the group had ended: that run
    keeps its row, the other is the error."""
    real = worker.fly_group

    def fly(task: Any, *args: Any, on_end: Any = None, **kwargs: Any) -> Any:
        def ended(k: int, *rest: Any) -> None:
            if task.ids[k] == 1:
                raise ValueError("no row for this one")
            on_end(k, *rest)
        return real(task, *args, on_end=ended, **kwargs)

    monkeypatch.setattr(worker, "fly_group", fly)
    out = tmp_path / "study"
    assert main(["batch", MISSION, *STUDY, "--out", str(out)]) == 1
    rows = _rows(out)
    assert [r["outcome"] == "error" for r in rows] == [False, True, False, True]
    assert all("ValueError: no row for this one" in r["error"] for r in rows[1::2])
    assert all(r.get("error") is None and r["sim_time_s"] == 60.0 for r in rows[::2])


def test_run_from_says_when_the_code_is_not_the_studys(
        tmp_path: Path, capsys: pytest.CaptureFixture[str],
        monkeypatch: pytest.MonkeyPatch) -> None:
    """A review edited its plug-in after a study; ``run --from`` said "DIFFERENT" alone, which
    reads as a run that does not reproduce. It says the code is not the study's."""
    import json

    out = tmp_path / "study"
    assert main(["batch", MISSION, *STUDY, "--out", str(out)]) == 0
    record = out / "study.json"
    meta = json.loads(record.read_text(encoding="utf-8"))
    results = str(out / "results.parquet")
    run = ["run", "--from", results, "--row", "0", "--no-figure", "--out"]
    capsys.readouterr()
    assert main([*run, str(tmp_path / "a")]) == 0  # the same code: the same row, nothing said
    assert "flown by cptbt" not in capsys.readouterr().out
    record.write_text(json.dumps({**meta, "code": "0.0.1+src.0123456789abcdef"}),
                      encoding="utf-8")
    real = worker.row_of
    monkeypatch.setattr(worker, "row_of", lambda *a, **k: {**real(*a, **k), "path_m": -1.0})
    assert main([*run, str(tmp_path / "b")]) == 1
    said = capsys.readouterr().out
    assert "DIFFERENT from the study's row in path_m; the study was flown by cptbt " \
           "0.0.1+src.0123456789abcdef, this is " in said


def test_plot_of_a_stopped_study_of_other_code_says_the_batch_will_not_resume_it(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """A review: ``cptbt plot`` of a stopped study said the same command resumes it, where
    ``cptbt batch`` refused it, the code having changed since."""
    import json

    out = tmp_path / "study"
    assert main(["batch", MISSION, *STUDY, "--out", str(out)]) == 0
    (out / "results.parquet").unlink()
    next((out / "parts").glob("*.parquet")).unlink()  # stopped with a group to fly
    capsys.readouterr()
    assert main(["plot", str(out)]) == 0
    assert "was flown by cptbt" not in capsys.readouterr().err
    record = out / "study.json"
    meta = json.loads(record.read_text(encoding="utf-8"))
    record.write_text(json.dumps({**meta, "code": "0.0.1+src.0123456789abcdef"}),
                      encoding="utf-8")
    assert main(["plot", str(out)]) == 0
    err = capsys.readouterr().err
    assert "Incomplete study: 2 of 4 planned runs" in err
    assert "the study was flown by cptbt 0.0.1+src.0123456789abcdef, this is " in err
    assert "resumes it only with the code it was flown by" in err


def test_a_study_off_a_terminal_says_its_progress(
        tmp_path: Path, capsys: pytest.CaptureFixture[str],
        monkeypatch: pytest.MonkeyPatch) -> None:
    """A review: under nohup a study printed nothing until its end, and a hung plug-in could
    not be told from a slow study. Off a terminal it prints a line now and then, counting the
    runs of groups under way from their journals."""
    import threading

    from cptbt.batch import runner

    monkeypatch.setattr(runner.Progress, "LINE_EVERY_S", 0.0)
    assert main(["batch", MISSION, *STUDY, "--out", str(tmp_path / "s")]) == 0
    lines = [x for x in capsys.readouterr().err.splitlines() if x.startswith("cptbt batch: ")]
    assert lines and lines[-1].startswith("cptbt batch: 4 of 4 runs done after ")
    # the runs a group under way has journalled count before the group ends
    journal = tmp_path / "j.runs.jsonl"
    journal.write_bytes(b"{}\n{}\n{}\n{\"torn\n{\"torn")  # one held before, two torn
    progress = runner.Progress(10, 4, 2, quiet=False)
    stop = threading.Event()
    watcher = threading.Thread(target=runner._watch,
                               args=(progress, {"g": (str(journal), 1)}, stop))
    watcher.start()
    try:
        deadline = time.monotonic() + 10.0
        while "6 of 10 runs done" not in capsys.readouterr().err:
            assert time.monotonic() < deadline, "the journal's runs were not counted"
            time.sleep(0.2)
    finally:
        stop.set()
        watcher.join()


def test_a_big_study_says_its_size_before_it_flies(
        tmp_path: Path, capsys: pytest.CaptureFixture[str],
        monkeypatch: pytest.MonkeyPatch) -> None:
    """A review: 5 000 000 missions began without a word (the AB default study is 50 500)."""
    from cptbt.cli import batch_cmd

    monkeypatch.setattr(batch_cmd, "BIG_STUDY_RUNS", 4)
    assert main(["batch", MISSION, *STUDY, "--out", str(tmp_path / "s")]) == 0
    assert ("cptbt: note: 4 missions to fly (1 configuration x 2 starts x 2 replicates); "
            "Ctrl-C keeps every finished run") in capsys.readouterr().err
    monkeypatch.setattr(batch_cmd, "BIG_STUDY_RUNS", 5)
    assert main(["batch", MISSION, *STUDY, "--out", str(tmp_path / "t")]) == 0
    assert "missions to fly" not in capsys.readouterr().err


def test_many_runs_that_raise_in_one_group_are_each_its_own_error(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A diff review: each error flew the rest of the group again, one level of recursion per
    error (600 starts, 570 raising: every run an error, "maximum recursion depth exceeded"),
    at a cost growing with the square of the errors. A run whose planner raises now ends alone
    while the others fly on."""
    from cptbt.planner import Planner

    study = ["--amp-only", "--grid", "6x4", "--runs-per-start", "1", "--time-limit", "60",
             "--workers", "1", "--no-plots", "--seed", "3"]
    monkeypatch.setenv("CPTBT_PLANNER", "tree")
    assert main(["batch", MISSION, *study, "--out", str(tmp_path / "clean")]) == 0
    want = _rows(tmp_path / "clean")
    keep = {(want[k]["start_x"], want[k]["start_y"]) for k in (5, 17)}
    real = Planner.tick

    def tick(self: Planner, t: float) -> Any:
        start = self.context.start
        if start is not None and (start.x, start.y) not in keep and t >= 10.0 + start.x % 30:
            raise KeyError("a plug-in's bug")
        return real(self, t)

    monkeypatch.setattr(Planner, "tick", tick)
    assert main(["batch", MISSION, *study, "--out", str(tmp_path / "f")]) == 1
    rows = _rows(tmp_path / "f")
    assert [r["start"] for r in rows if r["outcome"] != "error"] == [5, 17]
    for k in (5, 17):
        assert {c: rows[k][c] for c in SAME} == {c: want[k][c] for c in SAME}
    assert all("KeyError" in r["error"] for r in rows if r["outcome"] == "error")


@pytest.mark.parametrize("planner", ["tree", "fleet"])
def test_a_run_whose_row_cannot_be_made_is_its_own_error_under_either_planner(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, planner: str) -> None:
    """A diff review: under the fleet planner an error making one run's row stopped every run
    of the group still flying (6 errors where the tree planner gave 1)."""
    study = ["--grid", "4x2", "--runs-per-start", "1", "--time-limit", "60",
             "--workers", "1", "--no-plots", "--seed", "3"]
    monkeypatch.setenv("CPTBT_PLANNER", planner)
    real = worker.row_of

    def row_of(task: Any, k: int, *args: Any, **kwargs: Any) -> Any:
        if task.ids[k] == 3:
            raise ZeroDivisionError("no row for this one")
        return real(task, k, *args, **kwargs)

    monkeypatch.setattr(worker, "row_of", row_of)
    ab = str(ROOT / "missions/ab2001_strategy1.yaml")  # one the fleet planner flies
    assert main(["batch", ab, *study, "--out", str(tmp_path / "s")]) == 1
    rows = _rows(tmp_path / "s")
    assert [r["start"] for r in rows if r["outcome"] == "error"] == [3]
    assert "ZeroDivisionError: no row for this one" in rows[3]["error"]
