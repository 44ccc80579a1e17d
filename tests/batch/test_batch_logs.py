"""Batch-sampled cycle logs: ``cptbt batch --log-runs K`` logs K seeded runs, the same ones and
the same bytes whatever the workers, and each log tells its story and replays bit for bit."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from cptbt.batch.store import load_results
from cptbt.batch.study import GroupTask, log_sample
from cptbt.logs import read_log
from cptbt.replay import replay, story

ROOT = Path(__file__).resolve().parents[2]
MSN007 = ROOT / "missions" / "tro2006_msn007.yaml"


def _tasks(groups: int, starts: int) -> list[GroupTask]:
    return [GroupTask(0, r, "", tuple((float(i), 0.0) for i in range(starts)), 7, 0.0)
            for r in range(groups)]


def _chosen(tasks: list[GroupTask]) -> set[tuple[int, int]]:
    return {(t.replicate, i) for t in tasks for i in t.log_ids}


def test_the_sample_is_seeded_sized_and_spread_over_the_groups() -> None:
    tasks = _tasks(10, 10)
    a = _chosen(log_sample(tasks, 5, 7, "logs"))
    assert len(a) == 5 and a == _chosen(log_sample(tasks, 5, 7, "logs"))
    assert a != _chosen(log_sample(tasks, 5, 8, "logs"))
    assert len(_chosen(log_sample(tasks, 500, 7, "logs"))) == 100  # at most every run
    assert all(t.log_dir == "logs" for t in log_sample(tasks, 1, 7, "logs"))
    # every run is as likely: over many seeds each of the 100 is drawn about 5% of the time
    counts = [0] * 100
    for seed in range(400):
        for r, i in _chosen(log_sample(tasks, 5, seed, "logs")):
            counts[10 * r + i] += 1
    assert min(counts) > 0 and max(counts) < 45  # mean 20


def _batch(out: Path, workers: int) -> Path:
    r = subprocess.run(
        [sys.executable, "-m", "cptbt", "batch", str(MSN007), "--amp-only", "--grid", "2x1",
         "--runs-per-start", "2",
         "--time-limit", "250", "--out", str(out), "--log-runs", "2", "--workers", str(workers),
         "--no-plots", "--quiet"], capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    return out / "logs"


@pytest.fixture(scope="module")
def logs(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    root = tmp_path_factory.mktemp("batchlogs")
    return _batch(root / "one", 1), _batch(root / "two", 2)


def test_the_same_runs_are_logged_byte_for_byte_whatever_the_workers(logs) -> None:
    one, two = logs
    names = sorted(p.name for p in one.glob("*.mcap"))
    assert len(names) == 2 and names == sorted(p.name for p in two.glob("*.mcap"))
    for name in names:
        assert (one / name).read_bytes() == (two / name).read_bytes()


def test_a_batch_log_is_its_results_row_and_replays_bit_for_bit(logs) -> None:
    one, _ = logs
    rows = {(r["replicate"], r["start"]): r for r in load_results(one.parent)}
    for path in sorted(one.glob("*.mcap")):  # c000-r00001-s0001.mcap
        _, rep_, start = path.stem.split("-")
        row = rows[(int(rep_[1:]), int(start[1:]))]
        data = read_log(path)
        assert data.mission["start_xy"] == [pytest.approx(row["start_x"]),
                                            pytest.approx(row["start_y"])]
        end = data.phases[-1]
        assert end["trigger"] == "study_run_end" and end["detail"] == f"outcome {row['outcome']}"
        declared = next((c for c in data.cycles if c["declared_source"] is not None), None)
        if row["t3"] is not None:
            assert declared is not None and float(declared["t"]) == pytest.approx(row["t3"])
            assert declared["declared_source"]["x"] == pytest.approx(row["declared_source_x"])
        rep = replay(path)
        assert rep.identical and rep.cycles == len(data.cycles) > 50
        text = "\n".join(story(data))
        assert "study_run_start" in text and "cptbt batch: config 0" in text
        # the study's start in the mission's frame, as the detections (a review)
        assert ("(study_run_start) — start at N " in text
                and f"({row['start_x']:.1f}, {row['start_y']:.1f}) (planning frame), " in text)


def test_log_runs_without_mcap_is_a_usage_error_that_writes_nothing(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
        capsys: pytest.CaptureFixture[str]) -> None:
    """A review: without the logs extra, --log-runs was an "internal error", and the folder it
    had made then refused the command without it as another study."""
    import importlib.util

    from cptbt.cli import main

    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec",
                        lambda name, *a: None if name == "mcap" else real(name, *a))
    out = tmp_path / "o"
    assert main(["batch", str(MSN007), "--amp-only", "--grid", "2x1", "--runs-per-start", "1",
                 "--out", str(out), "--log-runs", "1", "--no-plots", "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert err == ("cptbt batch: error: --log-runs needs the mcap package: pip install "
                   "'cptbt[logs]'") and not out.exists()


def test_more_logs_than_runs_is_a_usage_error(tmp_path: Path) -> None:
    r = subprocess.run(
        [sys.executable, "-m", "cptbt", "batch", str(MSN007), "--amp-only", "--grid", "2x1",
         "--runs-per-start", "1", "--out", str(tmp_path / "o"), "--log-runs", "100000",
         "--no-plots", "--quiet"], capture_output=True, text=True, timeout=120)
    lines = r.stderr.strip().splitlines()
    assert r.returncode == 2 and len(lines) == 1 and "the study has 2 runs" in lines[0]
