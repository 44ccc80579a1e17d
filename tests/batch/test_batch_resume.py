"""A resumed study trusts only its own intact parts: damaged, foreign and stale results are re-run
or refused, never mixed in; and a study killed outright leaves no worker behind."""

from __future__ import annotations

import json
import os
import re
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import pyarrow.parquet as pq
import pytest

from cptbt.batch.store import load_results

try:
    import psutil
except ImportError:  # the /proc scan below stands in (Linux)
    psutil = None

ROOT = Path(__file__).resolve().parents[2]
MISSION = str(ROOT / "missions/tro2006_msn007.yaml")
SCRIPT = Path(sys.executable).parent / "cptbt"
STUDY = ["--grid", "2x1", "--runs-per-start", "2", "--time-limit", "60", "--no-plots"]
PART = "c000-r00001"


def batch(out: Path, *extra: str, seed: int = 3) -> subprocess.CompletedProcess[str]:
    return subprocess.run([str(SCRIPT), "batch", MISSION, "--amp-only", *STUDY, "--seed", str(seed),
                           "--workers", "1", "--out", str(out), *extra],
                          capture_output=True, text=True, timeout=300)


def table(out: Path) -> list[dict[str, Any]]:
    rows = load_results(out)
    for r in rows:
        r.pop("wall_time_s", None)
    return sorted(rows, key=lambda r: (r["config"], r["replicate"], r["start"]))


def stderr_lines(res: subprocess.CompletedProcess[str]) -> list[str]:
    assert "Traceback" not in res.stderr
    return res.stderr.splitlines()


@pytest.fixture(scope="module")
def clean(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A finished study (two groups of two runs), never changed by a test."""
    out = tmp_path_factory.mktemp("clean")
    res = batch(out)
    assert res.returncode == 0, res.stderr
    return out


@pytest.fixture(scope="module")
def reference(clean: Path) -> list[dict[str, Any]]:
    rows = table(clean)
    assert {(r["replicate"], r["start"]) for r in rows} == {(0, 0), (0, 1), (1, 0), (1, 1)}
    return rows


@pytest.fixture
def study(clean: Path, tmp_path: Path) -> Path:
    """A copy of the clean study to damage."""
    out = tmp_path / "study"
    shutil.copytree(clean, out)
    return out


def test_intact_study_resumes_everything(study: Path, reference: list[dict[str, Any]]) -> None:
    res = batch(study)
    assert res.returncode == 0 and stderr_lines(res) == []
    # nothing was flown, and the summary says so (not "0.0 s wall, 0.0 missions/s")
    assert res.stdout.startswith("4 missions (2 groups resumed from disk): success ")
    assert res.stdout.splitlines()[0].endswith(
        "; all 4 runs were already on disk; none flown"), res.stdout
    assert "missions/s" not in res.stdout
    assert table(study) == reference


def _tamper(part: Path) -> None:
    """Change one value but keep the part's metadata (and so its recorded checksum)."""
    t = pq.read_table(part)
    column = t.column_names.index("sim_time_s")
    t = t.set_column(column, "sim_time_s", [[v + 1.0 for v in t.column("sim_time_s").to_pylist()]])
    pq.write_table(t, part)


@pytest.mark.parametrize(("damage", "reason"), [
    (lambda p: p.write_bytes(b""), "empty file"),
    (lambda p: p.write_bytes(p.read_bytes()[: p.stat().st_size // 2]), "unreadable ("),
    (lambda p: p.write_bytes(os.urandom(3000)), "unreadable ("),
    (_tamper, "checksum mismatch (changed since it was written)"),
    (lambda p: pq.write_table(pq.read_table(p).replace_schema_metadata(None), p),
     "no checksum (written by an older cptbt, or not by cptbt)"),
], ids=["empty", "truncated", "garbage", "tampered", "no-checksum"])
def test_damaged_part_is_rerun_and_said_so(
    study: Path, reference: list[dict[str, Any]], damage: Any, reason: str
) -> None:
    damage(study / "parts" / f"{PART}.parquet")
    res = batch(study)
    assert res.returncode == 0, res.stderr
    (line,) = stderr_lines(res)
    assert line.startswith(f"cptbt: re-running part {PART}: {reason}"), line
    assert "(1 group resumed from disk)" in res.stdout
    assert table(study) == reference


def test_part_of_another_study_is_rerun(
    study: Path, reference: list[dict[str, Any]], tmp_path: Path
) -> None:
    other = tmp_path / "other"
    assert batch(other, seed=4).returncode == 0
    shutil.copy(other / "parts" / f"{PART}.parquet", study / "parts" / f"{PART}.parquet")
    res = batch(study)
    assert res.returncode == 0, res.stderr
    assert stderr_lines(res) == [f"cptbt: re-running part {PART}: from another study or code "
                                 "version (its fingerprint differs)"]
    assert table(study) == reference


def test_part_copied_under_another_groups_name_is_rerun(
    study: Path, reference: list[dict[str, Any]]
) -> None:
    # Before parts knew their group, this gave replicate 0 twice and replicate 1 not at all.
    parts = study / "parts"
    shutil.copy(parts / "c000-r00000.parquet", parts / f"{PART}.parquet")
    res = batch(study)
    assert res.returncode == 0, res.stderr
    assert stderr_lines(res) == [
        f"cptbt: re-running part {PART}: holds group c000-r00000, not {PART}"]
    assert table(study) == reference


def _set_code(study: Path, code: str | None) -> None:
    meta = study / "study.json"
    data = json.loads(meta.read_text())
    if code is None:  # as written before studies had fingerprints
        for key in ("code", "study", "fingerprint"):
            del data[key]
    else:
        data["code"] = code
    meta.write_text(json.dumps(data))


@pytest.mark.parametrize("code", ["0.0.9+src.0123456789abcdef", None], ids=["other", "older"])
def test_study_of_other_code_is_refused_without_restart(
    study: Path, reference: list[dict[str, Any]], code: str | None
) -> None:
    _set_code(study, code)
    before = {p.name: p.read_bytes() for p in (study / "parts").iterdir()}
    res = batch(study)
    assert res.returncode == 1
    (line,) = stderr_lines(res)
    made_by = f"cptbt {code}, this is " if code else "an older cptbt ("
    assert line.startswith(f"cptbt: {study} was made by {made_by}"), line
    assert line.endswith("rerun with --restart to discard its results, or choose a new --out")
    assert {p.name: p.read_bytes() for p in (study / "parts").iterdir()} == before

    res = batch(study, "--restart")
    assert res.returncode == 0, res.stderr
    assert stderr_lines(res) == []
    assert "(0 groups resumed from disk)" in res.stdout
    assert table(study) == reference
    assert json.loads((study / "study.json").read_text())["code"] != code


def test_unreadable_study_record_needs_restart(
    study: Path, reference: list[dict[str, Any]]
) -> None:
    (study / "study.json").write_text("{not json")
    (line,) = stderr_lines(res := batch(study))
    assert res.returncode == 1 and "study.json is unreadable" in line and "--restart" in line
    assert batch(study, "--restart").returncode == 0
    assert table(study) == reference


def test_folder_of_a_different_study_is_refused_even_with_restart(study: Path) -> None:
    for extra in ((), ("--restart",)):
        res = batch(study, *extra, seed=4)
        assert res.returncode == 1
        # it names what differs (a review changed one option and could not tell which)
        also = " (--restart discards a study's runs, not another study)" if extra else ""
        assert stderr_lines(res) == [f"cptbt: {study} holds a different study (root seed 3 "
                                     f"there, 4 here): choose another --out or remove it{also}"]
    assert len(list((study / "parts").iterdir())) == 2


def test_more_runs_per_start_extend_a_study_keeping_its_runs(
    study: Path, reference: list[dict[str, Any]]
) -> None:
    """Asking a finished folder for more runs per start was refused as a different study
    (a review expected it to fly only the new ones): replicate r's rows do not depend on how
    many there are."""
    before = {p.name: p.stat().st_mtime_ns for p in (study / "parts").iterdir()}
    # ... but not with --log-runs: its sample is drawn from a study of known size
    res = batch(study, "--runs-per-start", "3", "--log-runs", "1")
    assert res.returncode == 2 and "--log-runs with --runs-per-start 3" in res.stderr
    assert len(list((study / "parts").iterdir())) == 2
    res = batch(study, "--runs-per-start", "3")
    assert res.returncode == 0, res.stderr
    after = {p.name: p.stat().st_mtime_ns for p in (study / "parts").iterdir()}
    assert len(after) == 3 and all(after[k] == v for k, v in before.items())  # kept, not re-flown
    rows = table(study)
    assert [r for r in rows if r["replicate"] < 2] == reference
    assert {(r["replicate"], r["start"]) for r in rows if r["replicate"] == 2} == {(2, 0), (2, 1)}
    assert json.loads((study / "study.json").read_text())["runs_per_start"] == 3
    res = batch(study)  # and back to the first two, saying that the third's runs are left out
    assert res.returncode == 0 and table(study) == reference
    assert "2 runs of this study on disk, beyond its count, are left out" in res.stdout


# -- workers die with their parent ------------------------------------------------------------

def _descendants(pid: int) -> list[int]:
    if psutil is None:
        parents: dict[int, list[int]] = {}
        for stat in Path("/proc").glob("[0-9]*/stat"):
            try:
                fields = stat.read_text().rsplit(")", 1)[1].split()
            except OSError:
                continue
            parents.setdefault(int(fields[1]), []).append(int(stat.parent.name))
        out, todo = [], [pid]
        while todo:
            kids = parents.get(todo.pop(), [])
            out += kids
            todo += kids
        return out
    return [p.pid for p in psutil.Process(pid).children(recursive=True)]


def _running(pid: int) -> bool:
    """Alive and not a zombie (an orphan's zombie waits for a reaper that may never come)."""
    if psutil is None:
        try:
            state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
        except OSError:
            return False
        return state != "Z"
    try:
        return psutil.Process(pid).status() != psutil.STATUS_ZOMBIE
    except psutil.NoSuchProcess:
        return False


@pytest.mark.skipif(psutil is None and not Path("/proc/self/stat").exists(),
                    reason="needs psutil or /proc to see the workers")
def test_workers_die_when_the_study_is_killed(tmp_path: Path) -> None:
    proc = subprocess.Popen(
        [str(SCRIPT), "batch", MISSION, "--amp-only", "--grid", "2x1", "--runs-per-start", "20",
         "--time-limit", "60", "--workers", "2", "--out", str(tmp_path), "--no-plots",
         "--quiet"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    workers: list[int] = []
    try:
        parts = tmp_path / "parts"
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline and proc.poll() is None:  # the pool is at work
            if parts.exists() and any(p.suffix == ".parquet" for p in parts.iterdir()):
                break
            time.sleep(0.05)
        workers = [pid for pid in _descendants(proc.pid) if _running(pid)]
        assert proc.poll() is None and len(workers) >= 2, "catch the study with its workers"
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait()
        deadline = time.monotonic() + 5
        while time.monotonic() < deadline and any(_running(pid) for pid in workers):
            time.sleep(0.05)
        assert not [pid for pid in workers if _running(pid)], "workers outlived the study"
    finally:
        proc.kill()
        for pid in workers:  # do not leave them behind if the test failed
            if _running(pid):
                os.kill(pid, signal.SIGKILL)


@pytest.mark.parametrize("how", ["ctrl-c", "sigterm", "sigterm-group"])
def test_ctrl_c_stops_the_study_and_its_workers_at_once(tmp_path: Path, how: str) -> None:
    """``sigterm-group``: ``timeout``, systemd and Slurm stop the whole process group (a
    review: the workers inherited the main process's SIGTERM-as-Ctrl-C handler, stopped at
    random points, and the study hung for good)."""
    proc = subprocess.Popen(
        [str(SCRIPT), "batch", MISSION, "--amp-only", "--grid", "3x1", "--runs-per-start", "20",
         "--time-limit", "900", "--workers", "2", "--out", str(tmp_path), "--no-plots"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))  # as in a terminal
    workers: list[int] = []
    try:
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline and proc.poll() is None and len(workers) < 2:
            workers = [pid for pid in _descendants(proc.pid) if _running(pid)]
            time.sleep(0.05)
        time.sleep(1.0)  # into the groups
        t0 = time.monotonic()
        if how == "ctrl-c":
            os.killpg(proc.pid, signal.SIGINT)  # Ctrl-C: the whole process group
        elif how == "sigterm-group":
            os.killpg(proc.pid, signal.SIGTERM)
        else:  # kill, or a scheduler's stop: the study's process alone (it died silently)
            os.kill(proc.pid, signal.SIGTERM)
        _, err = proc.communicate(timeout=60)
        # the 57 queued groups take seconds each: a stop that waited for them takes minutes
        assert time.monotonic() - t0 < 15, "waited for the queued groups (seconds each)"
        # One line that says what is kept (every run finished) and how to go on.
        assert proc.returncode == 130 and re.fullmatch(
            r"cptbt: interrupted: \d+ of 60 runs are saved in .+; the same command flies the "
            r"rest\n", err), err
        assert not [pid for pid in workers if _running(pid)]
    finally:
        proc.kill()
        for pid in workers:
            if _running(pid):
                os.kill(pid, signal.SIGKILL)


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGKILL])
def test_an_interrupted_group_keeps_its_finished_runs(tmp_path: Path, sig: int) -> None:
    """A review's Ctrl-C kept only whole groups (a group is one replicate from every start: up
    to 99 finished runs lost on a 10 x 10 grid). Each run is journalled as it ends; a resume
    flies only the rest of the group, and the table is the uninterrupted study's."""
    study = ["--grid", "3x2", "--runs-per-start", "1", "--time-limit", "900", "--no-plots",
             "--seed", "5", "--workers", "1"]
    cmd = [str(SCRIPT), "batch", MISSION, "--amp-only", *study]
    out = tmp_path / "stopped"
    proc = subprocess.Popen([*cmd, "--out", str(out)], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    journal = out / "parts" / "c000-r00000.runs.jsonl"
    try:
        deadline = time.monotonic() + 240
        while time.monotonic() < deadline and proc.poll() is None:
            if journal.exists() and journal.read_text(encoding="utf-8").count("\n") >= 2:
                break
            time.sleep(0.02)
        assert proc.poll() is None, "stop the group while it flies"
        proc.send_signal(sig)
        _, err = proc.communicate(timeout=60)
    finally:
        proc.kill()
    kept = journal.read_text(encoding="utf-8").count("\n")
    assert 2 <= kept < 6 and not (out / "parts" / "c000-r00000.parquet").exists()
    if sig == signal.SIGINT:
        assert f"interrupted: {kept} of 6 runs are saved in" in err, err
    res = subprocess.run([*cmd, "--out", str(out)], capture_output=True, text=True, timeout=300)
    assert res.returncode == 0, res.stderr
    assert f"and {kept} runs of groups under way when it stopped" in res.stdout, res.stdout
    assert not journal.exists()  # its runs are in the part now
    ref = tmp_path / "whole"
    assert subprocess.run([*cmd, "--out", str(ref)], capture_output=True, text=True,
                          timeout=300).returncode == 0
    assert table(out) == table(ref)
