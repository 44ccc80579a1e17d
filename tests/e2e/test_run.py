"""Closed-loop missions in the simulator: outcomes, outputs and reproducibility."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from cptbt.batch.engine import simulate
from cptbt.batch.scenario import Environment, launch_pose, to_sim_params
from cptbt.batch.summary import summarise
from cptbt.loader import load_mission
from cptbt.registry import default_registry
from cptbt.types import Point

ROOT = Path(__file__).resolve().parents[2]
MSN007 = ROOT / "missions/tro2006_msn007.yaml"


def fly(seed: int, trace: bool = False):  # type: ignore[no-untyped-def]
    mission = load_mission(MSN007, default_registry(), Environment)
    params = to_sim_params(mission, seed)
    (run,), _, wall = simulate(mission, params, [launch_pose(mission)], trace=trace)
    return run, summarise(run, mission, Point(*params.source_xy_m), seed, wall).to_dict()


def same_trace(a: dict | None, b: dict | None) -> bool:  # type: ignore[type-arg]
    """Column by column, bit for bit (NaN equal to NaN)."""
    assert a is not None and b is not None
    return a.keys() == b.keys() and all(
        np.array_equal(np.asarray(a[k]), np.asarray(b[k]),
                       equal_nan=np.asarray(a[k]).dtype.kind == "f") for k in a
    )


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_tro_mission_declares_near_the_true_source(seed: int) -> None:
    _, s = fly(seed)
    assert s["outcome"] == "declared", s
    # The AMP declares from lost-contact points in its navigation frame (3 m drift, LBL jumps):
    # TRO reports errors of 15-50 m in the field; in our ocean the bound is tighter: 15 m, the
    # bound of issue 11 (40 seeds: median 4.4 m, 2 beyond 12 m, the largest 14.5 m, seed 2).
    assert s["error_m"] < 15.0, s
    assert s["t1"] is not None and s["t1"] <= s["t2"] <= s["t3"]
    assert s["D1"] > 0 and s["D0"] > 0
    assert math.isclose(s["T_F"] + s["T_T"] + s["T_D"], s["t3"])


def test_same_seed_same_run_bit_for_bit() -> None:
    a, sa = fly(5, trace=True)
    b, sb = fly(5, trace=True)
    assert same_trace(a.trace, b.trace)
    sa.pop("wall_time_s"), sb.pop("wall_time_s")
    assert sa == sb
    c, _ = fly(6, trace=True)
    assert not same_trace(c.trace, a.trace)


def test_cptbt_run_writes_summary_trace_and_figure(tmp_path: Path) -> None:
    script = Path(sys.executable).parent / "cptbt"
    res = subprocess.run([str(script), "run", str(MSN007), "--seed", "3", "--out", str(tmp_path)],
                         capture_output=True, text=True, timeout=300)
    assert res.returncode == 0, res.stderr
    summary = json.loads((tmp_path / "summary.json").read_text())
    for key in ("mission", "seed", "outcome", "declared_source", "true_source", "error_m",
                "t0", "t1", "t2", "t3", "T_F", "T_T", "T_D", "T_total", "D0", "D1", "D2", "D3",
                "sim_time_s", "wall_time_s", "time_in_behaviour_s"):
        assert key in summary
    assert summary["seed"] == 3 and summary["outcome"] == "declared"
    src = summary["true_source"]
    assert src["north"] == pytest.approx(43) and src["east"] == pytest.approx(-55)
    assert set(summary["start"]) == set(src)  # the start in every frame the sources are in
    # the mission's own start: (TRO Table III's), not where the AMP took over (a review)
    mission_start = summary["mission_start"]
    assert mission_start["north"] == pytest.approx(-55.5)
    assert mission_start["east"] == pytest.approx(82.9)
    assert (mission_start["north"], mission_start["east"]) != (summary["start"]["north"],
                                                                summary["start"]["east"])
    # home too (a review found none): where the run ends, in the mission's own frame
    home = summary["home"]
    assert home["north"] == pytest.approx(-100) and home["east"] == pytest.approx(40)
    assert set(summary["home"]) == set(src)
    # the simulated current flown, in the mission's compass (a review could tell it only from
    # the figure when the mission did not give it)
    assert summary["mean_flow"] == {"toward_deg": 135.0, "speed_mps": 0.1}
    assert (tmp_path / "trace.parquet").exists() or (tmp_path / "trace.csv").exists()
    png = (tmp_path / "trajectory.png").read_bytes()
    assert png.startswith(b"\x89PNG") and len(png) > 20_000
    assert "declared" in res.stdout


def test_run_folders_never_overwrite_and_stay_inside_runs(tmp_path: Path) -> None:
    from cptbt.cli.run_cmd import run_folder

    mission = load_mission(MSN007, default_registry(), Environment)
    first = run_folder(mission, 7, tmp_path)
    first.mkdir()
    second = run_folder(mission, 7, tmp_path)
    assert second != first and second.parent == tmp_path and second.name.endswith("-2")
    other = mission.model_copy(update={"speed_mps": 1.2})  # a different setting: its own folder
    assert run_folder(other, 7, tmp_path).name.split("-")[1] != first.name.split("-")[1]


def test_a_run_that_ends_without_a_declaration_says_why(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # A navigation error of 100 km: the AMP gives control back at once, and the run said
    # only "relinquished"
    from cptbt.cli import main

    text = (ROOT / "missions/two_sources.yaml").read_text(encoding="utf-8")
    path = tmp_path / "nav.yaml"
    path.write_text(text.replace("environment:\n", "environment:\n  navigation: {drift_std_m: "
                                 "100000, drift_tau_s: 1, fix_rate_per_s: 0.5}\n", 1),
                    encoding="utf-8")
    assert main(["run", str(path), "--out", str(tmp_path / "o"), "--no-figure"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert ": relinquished (" in out[0], out
    assert out[1].startswith("  relinquished: the vehicle's estimated position was more than "
                             "30 m outside the OpArea"), out


def test_a_time_limit_during_the_search_for_more_sources_is_said_so(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # one of two sources declared when the limit came: not "with no declaration"
    from cptbt.cli import main

    text = (ROOT / "missions/two_sources.yaml").read_text(encoding="utf-8")
    path = tmp_path / "tl.yaml"
    # 220 s: the first source is declared between 150 and 200 s, the second at 306 s (seed 11)
    path.write_text(text.replace("time_limit_s: 3600", "time_limit_s: 220"), encoding="utf-8")
    assert main(["run", str(path), "--out", str(tmp_path / "o"), "--no-figure"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[1] == "  timeout: the AMP's time limit came while it searched for more sources", out


def test_a_log_path_among_the_run_outputs_or_unwritable_leaves_nothing_behind(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # --log X/summary.json --out X: the summary overwrote the log; a --log that could not be
    # opened left an empty output folder
    from cptbt.cli import main

    msn = str(ROOT / "missions/tro2006_msn007.yaml")
    out = tmp_path / "x"
    assert main(["run", msn, "--out", str(out), "--log", str(out / "summary.json")]) == 2
    assert "is one of the files the run writes" in capsys.readouterr().err
    assert not out.exists()
    assert main(["run", msn, "--out", str(out), "--log", str(tmp_path)]) != 0  # a folder
    assert not out.exists()


def test_the_summary_says_how_far_outside_the_oparea_the_vehicle_went() -> None:
    """A review found the measure the README quotes (7.3 -> 3.8 m) in no output: the summary
    has it, from the true track, and 0 when the track stayed inside."""
    mission = load_mission(ROOT / "missions/small_oparea.yaml", default_registry(), Environment)
    params = to_sim_params(mission)
    (run,), _, wall = simulate(mission, params, [launch_pose(mission)], trace=True)
    s = summarise(run, mission, Point(*params.source_xy_m), 7, wall).to_dict()
    trace = run.trace
    assert trace is not None
    area = mission.op_area_geometry()
    far = area.distance_outside_array(np.asarray(trace["x"]), np.asarray(trace["y"])).max()
    assert s["farthest_outside_m"] == pytest.approx(float(far), abs=0.5)
    assert s["farthest_outside_m"] > 1.0  # seed 7 leaves the 50-m box (safety drives)
    inside = mission.model_copy(update={"time_limit_s": 20.0})
    (run,), _, wall = simulate(inside, params, [launch_pose(inside)])
    assert summarise(run, inside, Point(*params.source_xy_m), 7, wall).farthest_outside_m == 0.0


def test_the_way_to_a_home_and_from_a_launch_outside_are_not_excursions(tmp_path: Path) -> None:
    """A review's dock 18 m outside (``allow_outside: [home]``, the launch there too) read
    "left the OpArea: 10.9 m" for the leg home after the declaration, and "safety drove 5.1%"
    for safety bringing the vehicle in: both are the mission's own legs. The search's own
    excursion still counts."""
    from cptbt.batch.comparison import excursions

    text = (ROOT / "missions/small_oparea.yaml").read_text()
    text = text.replace("home: [-20, 0]", "home: [-40, 0]\nallow_outside: [home]")
    text = text.replace("  seed: 7", "  seed: 7\n  launch: [-40, -10]")
    text = text.replace("max_spread_m: 5}", "max_spread_m: 5, home_radius_m: 2}")
    (tmp_path / "m.yaml").write_text(text)
    mission = load_mission(tmp_path / "m.yaml", default_registry(), Environment)
    params = to_sim_params(mission)
    (run,), _, wall = simulate(mission, params, [launch_pose(mission)], trace=True)
    s = summarise(run, mission, Point(*params.source_xy_m), 7, wall).to_dict()
    trace = run.trace
    assert trace is not None and s["outcome"] == "declared"
    area = mission.op_area_geometry()
    far = area.distance_outside_array(np.asarray(trace["x"]), np.asarray(trace["y"]))
    home = np.array([a.endswith(" (home)") for a in trace["active"]])
    assert far[home].max() > 10.0  # the leg home went out toward the dock, 15 m out
    assert s["farthest_outside_m"] == pytest.approx(float(far[~home][10:].max()), abs=0.5)
    assert s["farthest_outside_m"] < 9.0  # the search's own excursion, 7.2 m
    # safety brought the vehicle in from the launch, and kept it in after
    entering, safety = s["safety_entering_s"], s["time_in_behaviour_s"]["safety.oparea"]
    assert 10.0 < entering < safety
    row = {"time_safety_s": safety, "time_other_s": 100.0, "safety_entering_s": entering}
    share = excursions([row])[3]
    assert share == pytest.approx((safety - entering) / (safety + 100.0))


def test_the_way_in_from_a_start_placed_outside_is_not_an_excursion() -> None:
    """A review's start 20 m outside the box (``allow_outside: [start]``) printed "left the
    OpArea: at most 19.8 m": the way in is the mission's. Once in, leaving counts again."""
    from cptbt.batch.outside import farthest_outside as _farthest_outside

    mission = load_mission(ROOT / "missions/small_oparea.yaml", default_registry(), Environment)
    a = mission.op_area_geometry()
    y = 0.5 * (a.ymin + a.ymax)
    way_in = np.array([[a.xmin - 20.0, y], [a.xmin - 5.0, y], [a.xmin + 5.0, y]])
    assert _farthest_outside(mission, way_in) == 0.0
    out_again = np.vstack([way_in, [[a.xmax + 3.0, y], [a.xmax - 1.0, y]]])
    assert _farthest_outside(mission, out_again) == pytest.approx(3.0)
    never_in = np.array([[a.xmin - 20.0, y], [a.xmin - 26.0, y], [a.xmin - 10.0, y]])
    # 6 m farther out than its start: 26 m outside (a review: "at most 4.5 m outside it" for a
    # track given back 30 m out)
    assert _farthest_outside(mission, never_in) == pytest.approx(26.0)
    heading_in = np.array([[a.xmin - 20.0, y], [a.xmin - 12.0, y], [a.xmin - 4.0, y]])
    assert _farthest_outside(mission, heading_in) == 0.0  # on its way in when the run ended
    unknown_first = np.vstack([[[np.nan, np.nan]], never_in])  # (a diff review: read 0)
    assert _farthest_outside(mission, unknown_first) == pytest.approx(26.0)
    # a detour on the way in (a review of the change: it had scored 0)
    detour = np.array([[a.xmin - 5.0, y], [a.xmin - 20.0, y], [a.xmin + 5.0, y]])
    assert _farthest_outside(mission, detour) == pytest.approx(20.0)


def test_the_way_home_counts_only_the_walls_home_is_not_beyond() -> None:
    """A diff review: blanking the whole leg home hid a 2.7-m overshoot through the far wall
    on the turn after a declaration. Home beyond the low-y wall: that wall's crossing is the
    mission's, any other wall's still an excursion."""
    from cptbt.batch.outside import outside_away_from
    from cptbt.frames import OpArea

    area = OpArea(0.0, 100.0, 0.0, 50.0)
    x = np.array([50.0, 105.0, 50.0, -2.0, 50.0])
    y = np.array([-10.0, -5.0, 53.0, 20.0, 25.0])
    away = outside_away_from(area, x, y, Point(50.0, -20.0))
    assert away == pytest.approx([0.0, 5.0, 3.0, 2.0, 0.0])
