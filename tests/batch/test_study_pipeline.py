"""Studies as files and rows that fly again: the study section, start modes, mission-frame
starts, missions with a Mission A, and ``cptbt run --from RESULTS --row N``."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from cptbt.batch.store import load_results

ROOT = Path(__file__).resolve().parents[2]
SCRIPT = Path(sys.executable).parent / "cptbt"
MSN007 = (ROOT / "missions" / "tro2006_msn007.yaml").read_text(encoding="utf-8")


def cptbt(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([str(SCRIPT), *args], capture_output=True, text=True, timeout=600)


def planner_only(study: str = "") -> str:
    """MSN007 without its Mission A, a short time limit, launched on the OpArea's side away
    from the plume (planning (0, -45)), and an optional study section."""
    text = MSN007[: MSN007.index("\nmission_a:")] + MSN007[MSN007.index("\nenvironment:"):]
    text = text.replace("  seed: 7", "  seed: 7\n  launch: [31, 33]")
    return text.replace("time_limit_s: 1800", "time_limit_s: 150") + study


@pytest.fixture(scope="module")
def study(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("study")
    mission = folder / "m.yaml"
    mission.write_text(planner_only(
        "study:\n  starts: [[-55.5, 82.9], [0, 60]]\n  runs_per_start: 2\n"
        "  start_mode: launch\n"), encoding="utf-8")
    res = cptbt("batch", str(mission), "--out", str(folder / "out"), "--workers", "1",
                "--no-plots", "--quiet")
    assert res.returncode == 0, res.stderr
    return folder / "out"


def test_the_study_section_is_the_study(study: Path) -> None:
    rows = load_results(study)
    meta = json.loads((study / "study.json").read_text())
    assert len(rows) == 4 and meta["runs_per_start"] == 2 and meta["start_mode"] == "launch"
    # Starts given in N-E metres, the mission's frame, recorded in the planning frame.
    assert {r["start"] for r in rows} == {0, 1}
    xs = sorted({round(r["start_x"], 1) for r in rows})
    assert xs == sorted({round(x, 1) for x, _ in meta["starts"]}) and len(xs) == 2
    assert all(r["seed_key"] == f"{meta['root_seed']}/{r['replicate']}/{r['start']}"
               for r in rows)
    assert meta["geometry"]["source"] and meta["geometry"]["area"]


def test_launch_mode_drives_to_each_start(study: Path) -> None:
    rows = load_results(study)
    assert all((r.get("time_move_to_field_s") or 0) > 10 for r in rows), [
        r.get("time_move_to_field_s") for r in rows]
    # every start column is the study's start, not the launch (a review read the launch in
    # start_north/east, the grid start in start_x/y and tables.md)
    meta = json.loads((study / "study.json").read_text())
    for r in rows:
        x, y = meta["starts"][r["start"]]
        assert (r["start_x"], r["start_y"]) == pytest.approx((x, y))
        assert (r["start_north"], r["start_east"]) == pytest.approx(
            {0: (-55.5, 82.9), 1: (0.0, 60.0)}[r["start"]], abs=1e-6)


def test_flags_override_the_study_section(tmp_path: Path) -> None:
    mission = tmp_path / "m.yaml"
    mission.write_text(planner_only("study:\n  grid: [2, 1]\n  runs_per_start: 3\n"),
                       encoding="utf-8")
    res = cptbt("batch", str(mission), "--runs-per-start", "1", "--start-mode", "place",
                "--time-limit", "20", "--out", str(tmp_path / "o"), "--workers", "1",
                "--no-plots", "--quiet")
    assert res.returncode == 0, res.stderr
    rows = load_results(tmp_path / "o")
    assert len(rows) == 2 and {r["start_mode"] for r in rows} == {"place"}
    # Placed at its start, the vehicle has nothing to drive to.
    assert all((r.get("time_move_to_field_s") or 0) <= 1 for r in rows)


def test_a_mission_with_mission_a_needs_amp_only(tmp_path: Path) -> None:
    res = cptbt("batch", str(ROOT / "missions" / "tro2006_msn007.yaml"), "--out",
                str(tmp_path / "o"))
    lines = res.stderr.strip().splitlines()
    assert res.returncode == 2 and len(lines) == 1 and "--amp-only" in lines[0]
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("row", [0, 3])
def test_a_row_flies_again_bit_for_bit(study: Path, tmp_path: Path, row: int) -> None:
    res = cptbt("run", "--from", str(study), "--row", str(row), "--out", str(tmp_path / "r"),
                "--no-figure")
    assert res.returncode == 0, res.stderr + res.stdout
    assert "bit for bit" in res.stdout
    again = json.loads((tmp_path / "r" / "summary.json").read_text())
    assert again["refly"]["same_as_study"] and again["refly"]["differs_in"] == []
    # the verdict and why the run ended, as cptbt run tells them
    assert f"flown again: {again['outcome']} (" in res.stdout
    if again["outcome"] == "timeout":
        assert "  timeout: the AMP's time limit came" in res.stdout, res.stdout


def test_a_row_of_a_swept_study_flies_again_bit_for_bit(tmp_path: Path) -> None:
    # The configuration label (from the sweep's coordinates) is part of the row: a re-flown row
    # of a swept study must carry it too, or every swept row reads "DIFFERENT".
    mission = tmp_path / "m.yaml"
    mission.write_text(planner_only("study:\n  grid: [1, 1]\n  runs_per_start: 1\n"),
                       encoding="utf-8")
    res = cptbt("batch", str(mission), "--sweep", "speed_mps=1.0,1.2", "--time-limit", "20",
                "--out", str(tmp_path / "o"), "--workers", "1", "--no-plots", "--quiet")
    assert res.returncode == 0, res.stderr
    res = cptbt("run", "--from", str(tmp_path / "o"), "--row", "1", "--out", str(tmp_path / "r"),
                "--no-figure")
    assert res.returncode == 0, res.stderr + res.stdout
    assert "bit for bit" in res.stdout
    assert "(speed_mps=1.2)" in res.stdout  # which configuration, not only the mission's name
    again = json.loads((tmp_path / "r" / "summary.json").read_text())
    assert again["refly"]["configuration"] == {"speed_mps": 1.2}
    # Without --out, a second re-flight of the row writes beside the first, never over it.
    folders = []
    for _ in range(2):
        res = subprocess.run([str(SCRIPT), "run", "--from", str(tmp_path / "o"), "--row", "1",
                              "--no-figure"], capture_output=True, text=True, timeout=600,
                             cwd=tmp_path)
        assert res.returncode == 0, res.stderr
        folders.append(res.stdout.split("wrote ")[-1].strip())
    assert folders[0] != folders[1] and folders[1] == folders[0] + "-2"


def test_a_row_flown_with_another_seed_is_reported_different(study: Path, tmp_path: Path
                                                             ) -> None:
    copy = tmp_path / "copy"
    copy.mkdir()
    for name in ("results.parquet", "study.json"):
        (copy / name).write_bytes((study / name).read_bytes())
    meta = json.loads((copy / "study.json").read_text())
    meta["root_seed"] += 1
    (copy / "study.json").write_text(json.dumps(meta))
    res = cptbt("run", "--from", str(copy), "--row", "0", "--out", str(tmp_path / "r"),
                "--no-figure")
    assert res.returncode == 1 and "DIFFERENT" in res.stdout


def test_a_row_whose_behaviour_is_not_installed_says_so_without_a_false_line(
        study: Path, tmp_path: Path) -> None:
    """A review's plug-in, uninstalled: the error pointed at "study.json:30", a line of the
    stored mission and not of the file, and did not say a plug-in was missing."""
    copy = tmp_path / "copy"
    copy.mkdir()
    for name in ("results.parquet", "study.json"):
        (copy / name).write_bytes((study / name).read_bytes())
    meta = json.loads((copy / "study.json").read_text())
    meta["config_missions"] = [m.replace("variant: cloverleaf", "variant: square_spiral")
                               for m in meta["config_missions"]]
    assert "square_spiral" in meta["config_missions"][0]
    (copy / "study.json").write_text(json.dumps(meta))
    res = cptbt("run", "--from", str(copy), "--row", "0", "--no-figure")
    (line,) = res.stderr.strip().splitlines()
    assert res.returncode != 0 and "study.json:" not in line, line
    assert f"{copy}/study.json, configuration 0: its mission no longer loads (a behaviour the " \
           "study flew is not installed here" in line, line
    assert "unknown variant 'square_spiral'" in line, line


def test_row_out_of_range_is_one_line(study: Path) -> None:
    res = cptbt("run", "--from", str(study), "--row", "99")
    assert res.returncode == 2 and len(res.stderr.strip().splitlines()) == 1


def test_a_column_only_later_rows_have_is_kept(tmp_path: Path) -> None:
    # pyarrow's from_pylist takes its schema from the first row; the store must not lose a
    # behaviour that only the second vehicle of a group used.
    from cptbt.batch.store import _Parquet

    rows = [{"start": 0, "time_none_s": 1.0},
            {"start": 1, "time_none_s": 2.0, "time_reacquire_plume_s": 14.0}]
    fmt = _Parquet()
    fmt.write(tmp_path / "t.parquet", rows, {})
    back, _ = fmt.read(tmp_path / "t.parquet")
    assert back[1]["time_reacquire_plume_s"] == 14.0 and back[0]["time_reacquire_plume_s"] is None


def test_flat_rows_keep_each_behaviour_leaf_and_family_totals() -> None:
    from cptbt.batch.worker import flatten

    row = flatten({"time_in_behaviour_s": {"maintain_plume.track_in": 40.0,
                                           "maintain_plume.track_out": 33.0, "none": 1.0}})
    assert row["time_maintain_plume.track_in_s"] == 40.0
    assert row["time_maintain_plume_s"] == 73.0 and row["time_none_s"] == 1.0
    assert row["declared_points"] == "[]"


def test_a_flat_row_keeps_every_declared_point() -> None:
    # declared_source_* is the last point alone: a two-source row lost the first
    import json

    from cptbt.batch.worker import flatten

    row = flatten({"declared_source": {"x": 3.0, "y": 4.0},
                   "declared_sources": [{"x": 1.0, "y": 2.0, "error_m": 0.5},
                                        {"x": 3.0, "y": 4.0, "error_m": 7.0}]})
    assert json.loads(row["declared_points"]) == [[1.0, 2.0, 0.5], [3.0, 4.0, 7.0]]
    assert row["declared_source_x"] == 3.0 and "declared_sources" not in row


def test_a_place_a_run_may_lack_has_the_same_columns_either_way() -> None:
    # a held candidate's place, present or not: one schema (a None had made a column of its
    # own, and a study with no held candidate had no held_candidate_x at all)
    from cptbt.batch.worker import flatten

    held = flatten({"held_candidate": {"x": 3.0, "y": 4.0, "north": 1.0, "east": 2.0}})
    none = flatten({"held_candidate": None})
    assert set(held) == set(none) and none["held_candidate_x"] is None
    assert "held_candidate" not in none
    # in a geodetic mission a place has lat and lon too: so does an absent one
    geo = {"x": 1.0, "y": 2.0, "north": 3.0, "east": 4.0, "lat": 32.9, "lon": -118.5}
    row = flatten({"true_source": geo, "held_candidate": None, "declared_source": None})
    assert row["held_candidate_lat"] is None and row["declared_source_lon"] is None
    assert set(flatten({"verifying_candidate": None})) == {  # a fly-by's candidate alike
        "verifying_candidate_x", "verifying_candidate_y", "verifying_candidate_north",
        "verifying_candidate_east", "declared_points"}


@pytest.mark.parametrize(("args", "says"), [
    (["missions/tro2006_msn007.yaml", "--row", "3"], "give --from RESULTS too"),
    (["--from", "results"], "needs --row N"),
    (["missions/tro2006_msn007.yaml", "--from", "results", "--row", "1"], "not both"),
])
def test_row_and_from_mistakes_say_what_is_missing(args: list[str], says: str) -> None:
    res = cptbt("run", *args)
    lines = res.stderr.strip().splitlines()
    assert res.returncode == 2 and len(lines) == 1 and says in lines[0], res.stderr


def test_a_row_flown_again_has_its_verdict_in_the_figure_title(
        study: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The title says whether the row was a success (and how many sources it found), as
    ``cptbt run``'s own figure does: the outcome alone ("declared") does not."""
    pytest.importorskip("matplotlib")
    from cptbt.cli import main, run_cmd

    titles: list[str] = []
    monkeypatch.setattr(run_cmd, "trajectory_figure",
                        lambda path, run, mission, source, title, **kw: titles.append(title))
    assert main(["run", "--from", str(study), "--row", "0", "--out", str(tmp_path / "r"),
                 "--quiet"]) == 0
    (title,) = titles
    s = json.loads((tmp_path / "r" / "summary.json").read_text())
    assert title.endswith(f": {s['outcome']}, {run_cmd.short_verdict(s)}"), title


def test_validate_checks_the_study_as_batch_flies_it_the_amp_alone(tmp_path: Path) -> None:
    """A review: a launch 35 m outside, brought in by the mission's Mission A, validated "ok",
    and `cptbt batch` of its own study section (always --amp-only) refused it."""
    from cptbt.cli.inspect_cmds import load
    from cptbt.types import Point

    area = load(str(ROOT / "missions" / "tro2006_msn007.yaml")).op_area_geometry()
    mission = load(str(ROOT / "missions" / "tro2006_msn007.yaml"))
    n, e = mission.to_ne(Point(area.xmin - 40.0, area.centre.y))
    text = MSN007.replace("  seed: 7", f"  seed: 7\n  launch: [{n:.1f}, {e:.1f}]")
    text += "study:\n  grid: [2, 1]\n"
    assert "\nmission_a:" in text
    path = tmp_path / "far.yaml"
    path.write_text(text, encoding="utf-8")
    res = cptbt("validate", str(path))
    assert res.returncode == 2 and "Traceback" not in res.stderr
    assert "environment.launch: 40.0 m outside the OpArea" in res.stderr
    assert "the study: section flies the AMP alone" in res.stderr
    assert cptbt("validate", str(ROOT / "missions" / "tro2006_msn007.yaml")).returncode == 0
