"""Monte Carlo studies end to end: results, determinism across workers, resume, Dask."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from cptbt.batch.runner import run_study
from cptbt.batch.starts import grid_starts
from cptbt.batch.store import ResultStore, load_results
from cptbt.batch.study import Study, configurations
from cptbt.cli.inspect_cmds import load

ROOT = Path(__file__).resolve().parents[2]
MISSION = str(ROOT / "missions/tro2006_msn007.yaml")
SCRIPT = Path(sys.executable).parent / "cptbt"
ARGS = ["--grid", "2x2", "--runs-per-start", "3", "--time-limit", "400", "--seed", "11"]


def batch(out: Path, *extra: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([str(SCRIPT), "batch", MISSION, "--amp-only",
                               *ARGS, "--out", str(out), *extra],
                          capture_output=True, text=True, timeout=600)


def table(out: Path) -> list[dict]:  # type: ignore[type-arg]
    rows = load_results(out)
    for r in rows:
        r.pop("wall_time_s", None)
    return sorted(rows, key=lambda r: (r["config"], r["replicate"], r["start"]))


@pytest.fixture(scope="module")
def reference(tmp_path_factory: pytest.TempPathFactory) -> list[dict]:  # type: ignore[type-arg]
    out = tmp_path_factory.mktemp("ref")
    res = batch(out, "--workers", "1")
    assert res.returncode == 0, res.stderr
    assert (out / "tables.md").exists() and (out / "time_to_source_map.png").exists()
    assert (out / "study.json").exists()
    return table(out)


def test_small_study_has_one_row_per_run(reference: list[dict]) -> None:  # type: ignore[type-arg]
    assert len(reference) == 12
    assert {(r["replicate"], r["start"]) for r in reference} == {
        (rep, s) for rep in range(3) for s in range(4)}
    assert sum(r["success"] for r in reference) >= 3  # 400 s is short for the TRO ocean
    # Every run has its own seed: first detections are not all alike.
    assert len({r["t1"] for r in reference}) > 3


def test_two_workers_give_the_same_table(tmp_path: Path, reference: list[dict]) -> None:  # type: ignore[type-arg]
    res = batch(tmp_path, "--workers", "2", "--no-plots")
    assert res.returncode == 0, res.stderr
    assert table(tmp_path) == reference
    # --no-plots skips the figures, not the tables
    assert (tmp_path / "tables.md").is_file() and not list(tmp_path.glob("*.png"))


def test_killed_study_resumes_without_losing_or_repeating_runs(
    tmp_path: Path, reference: list[dict]  # type: ignore[type-arg]
) -> None:
    proc = subprocess.Popen([str(SCRIPT), "batch", MISSION, "--amp-only",
                                 *ARGS, "--out", str(tmp_path),
                             "--workers", "1", "--no-plots"],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    parts = tmp_path / "parts"
    deadline = time.monotonic() + 300
    while time.monotonic() < deadline and proc.poll() is None:
        if parts.exists() and any(p.suffix in (".parquet", ".csv") for p in parts.iterdir()):
            break
        time.sleep(0.05)
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    finished = list(parts.glob("*.parquet"))
    assert 1 <= len(finished) < 3, "kill the study part-way"
    res = batch(tmp_path, "--workers", "2", "--no-plots")
    assert res.returncode == 0, res.stderr
    n = len(finished)
    assert f"{n} group{'s' * (n != 1)} resumed" in res.stdout
    assert table(tmp_path) == reference


def test_interrupted_run_keeps_finished_groups(tmp_path: Path) -> None:
    mission = load(MISSION)
    study = Study(configurations(mission, [], MISSION), grid_starts(mission, 1, 1), 3, 5, 0.0,
                  200.0)
    store = ResultStore(tmp_path)
    store.open({"test": 1}, study=study.identity(), code="test")

    def stop(task, rows):  # type: ignore[no-untyped-def]
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        run_study(study.tasks(), store, quiet=True, on_group=stop)
    assert len(store.check(study.tasks()).done) == 1
    stats = run_study(study.tasks(), store, quiet=True)
    assert stats["groups_skipped"] == 1 and stats["groups_run"] == 2
    assert len(store.rows(study.tasks())) == 3


def test_dask_local_cluster_gives_the_same_table(tmp_path: Path, reference: list[dict]) -> None:  # type: ignore[type-arg]
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster:
        res = batch(tmp_path, "--scheduler", cluster.scheduler_address, "--no-plots")
    assert res.returncode == 0, res.stderr
    assert table(tmp_path) == reference


def test_sweep_of_variants_and_bad_sweep(tmp_path: Path) -> None:
    res = subprocess.run(
        [str(SCRIPT), "batch", MISSION, "--amp-only",
             "--runs-per-start", "1", "--time-limit", "120",
         "--sweep", "reacquire_plume.variant=cloverleaf,three_point", "--out", str(tmp_path),
         "--workers", "1", "--quiet"],
        capture_output=True, text=True, timeout=600)
    assert res.returncode == 0, res.stderr
    rows = load_results(tmp_path)
    assert sorted(r["reacquire_plume.variant"] for r in rows) == ["cloverleaf", "three_point"]
    bad = subprocess.run([str(SCRIPT), "batch", MISSION, "--amp-only",
                              "--sweep", "reacquire_plume.variant=nope",
                          "--out", str(tmp_path / "x")], capture_output=True, text=True)
    assert bad.returncode == 2 and "Traceback" not in bad.stderr
    assert "unknown variant 'nope'" in bad.stderr




def test_a_whole_behaviour_sweep_flies_labelled_rows_and_each_flies_again(tmp_path: Path) -> None:
    """One study of the mission's rule against two settings of the likelihood map: a row per
    setting, labelled by what it flies, and a row flown again alone is the same run."""
    res = subprocess.run(
        [str(SCRIPT), "batch", MISSION, "--amp-only", "--runs-per-start", "1",
         "--sweep", "declare_source=upflow_cluster,{variant: likelihood_map, radius_m: 8},"
         "{variant: likelihood_map, radius_m: 12}", "--out", str(tmp_path / "s"),
         "--workers", "1", "--no-plots"],
        capture_output=True, text=True, timeout=600)
    assert res.returncode == 0, res.stderr
    assert "likelihood_map flies with its own defaults" in res.stderr  # the cluster's settings
    rows = sorted(load_results(tmp_path / "s"), key=lambda r: r["config"])
    assert [r["declare_source"] for r in rows] == [
        "upflow_cluster", "likelihood_map(radius_m=8)", "likelihood_map(radius_m=12)"]
    assert "declare_source=likelihood_map(radius_m=12)" in rows[2]["configuration"]
    again = subprocess.run([str(SCRIPT), "run", "--from", str(tmp_path / "s"), "--row", "1",
                            "--out", str(tmp_path / "r"), "--no-figure"],
                           capture_output=True, text=True, timeout=600)
    assert again.returncode == 0, again.stderr
    assert "(declare_source=likelihood_map(radius_m=8)) flown again" in again.stdout
    assert "bit for bit" in again.stdout
