"""Phased missions in simulation: each trigger leads to its phase, the vehicle resumes Mission A at
the break-off point, and the reversed-flow MSN010 mission finds and declares the source.

The AMP talks to the simulator only through the vehicle link (cptbt.batch.sim_link); faults are
injected at the link. Fixed seeds; each test simulates well under 20 s of wall time.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any, ClassVar

import numpy as np
import pytest

from cptbt.batch.phased import PhasedRun, simulate_phased
from cptbt.batch.scenario import Environment, to_sim_params
from cptbt.batch.sim_link import LinkFaults
from cptbt.cli.inspect_cmds import load
from cptbt.loader import loads_mission
from cptbt.mission import MissionBase
from cptbt.node import BehaviourParams, PlanBehaviour
from cptbt.planner import Planner
from cptbt.registry import BehaviourSpec, load_entry_points
from cptbt.types import Command, Percept, Point

ROOT = Path(__file__).resolve().parents[2]
MSN010 = load(str(ROOT / "missions" / "tro2006_msn010.yaml"))


def variant(base: MissionBase, time_limit_s: float | None = None, **spec: Any) -> MissionBase:
    assert base.mission_a is not None
    update: dict[str, Any] = {"mission_a": base.mission_a.model_copy(update=spec)}
    if time_limit_s is not None:
        update["time_limit_s"] = time_limit_s
    return base.model_copy(update=update)


def fly(mission: MissionBase, faults: LinkFaults | None = None, **kw: Any) -> PhasedRun:
    run, _, _ = simulate_phased(mission, to_sim_params(mission), faults=faults, **kw)
    return run


def assert_resumed_at_break_off(run: PhasedRun, mission: MissionBase) -> None:
    """The vehicle's reported position on resuming is within the capture radius of the break-off
    point (both in the navigation frame the vehicle steers by), and it then finishes Mission A."""
    assert mission.mission_a is not None
    assert run.break_off is not None and run.resumed_at is not None
    assert math.dist(run.break_off, run.resumed_at) <= mission.mission_a.capture_radius_m
    assert run.triggers()[-3:] == ["vehicle_returning", "break_off_reached", "mission_a_complete"]
    assert run.end_phase == "post_mission"


def test_msn010_reversed_flow_finds_and_declares_the_source_then_resumes_mission_a() -> None:
    run = fly(MSN010, trace=True)
    assert run.triggers() == [
        "launch", "amp_enable", "declared_home", "vehicle_returning", "break_off_reached",
        "mission_a_complete",
    ]
    assert run.amp.outcome == "declared"
    source = Point(*to_sim_params(MSN010).source_xy_m)
    declared = run.amp.declared
    assert declared is not None
    # TRO Table III errors were 15–50 m against a GPS-surveyed source; the simulated one is exact
    assert math.hypot(declared.x - source.x, declared.y - source.y) < 10.0
    # SPEC 4a, reversed flow: the flow runs toward -x, so from the start (x ≈ 93, up-flow of the
    # source) find-plume must head down-flow, i.e. toward -x, on its first tick
    trace = run.amp.trace
    assert trace is not None
    first = next(i for i, a in enumerate(trace["active"]) if a.startswith("find_plume"))
    assert math.cos(math.radians(trace["cmd_heading"][first])) < 0
    # the AMP took over on arrival at waypoint 1 (the MSN010r2 start)
    start = MSN010.to_xy(MSN010.start)  # type: ignore[arg-type]
    assert run.break_off is not None
    assert math.dist(run.break_off, (start.x, start.y)) <= 5.0 + 2.0  # capture + one step
    assert_resumed_at_break_off(run, MSN010)
    assert set(trace["phase"]) >= {"mission_a.waypoints", "amp.override",
                                   "return_to_break_off", "mission_a.resumed"}


def test_amp_enable_after_a_set_time_and_the_amp_time_limit() -> None:
    m = variant(MSN010, time_limit_s=60, amp_enable_s=40.0, amp_enable_waypoint=None)
    run = fly(m)
    enable = run.timeline[1]
    assert (enable.trigger, enable.dest) == ("amp_enable", "amp.override")
    assert enable.t_s == pytest.approx(40.0, abs=0.12)  # one vehicle step
    limit = run.timeline[2]
    assert (limit.trigger, limit.dest) == ("amp_time_limit", "amp.give_back")
    assert limit.t_s - enable.t_s == pytest.approx(60.0, abs=0.12)
    assert run.amp.outcome == "timeout"
    assert_resumed_at_break_off(run, m)


def test_vehicle_more_than_30_m_outside_the_op_area_takes_control_back() -> None:
    # Mission A's waypoint 1 lies 45 m beyond the OpArea's y edge; the AMP takes over there
    area = MSN010.op_area_geometry()
    outside = MSN010.to_geodetic(Point(93.0, area.ymin - 45.0))
    assert outside is not None
    assert MSN010.mission_a is not None
    wps = list(MSN010.mission_a.waypoints)
    wps[1] = (outside.lat_deg, outside.lon_deg)
    m = variant(MSN010, waypoints=wps)
    run = fly(m)
    give_back = run.timeline[2]
    assert (give_back.trigger, give_back.dest) == ("outside_op_area", "amp.give_back")
    assert give_back.t_s - run.timeline[1].t_s < 2.0  # at the first check after the take-over
    assert run.amp.outcome == "relinquished"
    # given back in the instant it was taken: the vehicle never left its mission, so it has no
    # break-off to return to (it had been shown "returning" to where it was)
    assert run.triggers()[-2:] == ["never_granted", "mission_a_complete"]
    assert run.end_phase == "post_mission"


def test_command_watchdog_when_the_link_goes_silent() -> None:
    m = variant(MSN010, watchdog_s=15.0)
    assert m.mission_a is not None
    run = fly(m, faults=LinkFaults(drop_commands_from_s=120.0))
    triggers = run.triggers()
    assert triggers[2] == "watchdog_timeout"
    t_watchdog = run.timeline[2].t_s
    # the last command reached the vehicle before t = 120 s (1 Hz cycle): timeout in (134, 136]
    assert 120.0 + 15.0 - 1.0 < t_watchdog <= 120.0 + 15.0 + 0.12
    assert run.timeline[2].dest == "amp.give_back"
    assert run.amp.outcome == "watchdog"
    assert_resumed_at_break_off(run, m)


@pytest.mark.parametrize(
    "change, reason",
    [({"amp_depth_m": 150.0}, "depth 150 m outside [0, 100] m"),
     ({"speed": 3.0}, "speed 3 m/s outside")],
)
def test_refused_commands_are_recorded_and_starve_the_watchdog(
    change: dict[str, float], reason: str
) -> None:
    m = variant(MSN010, watchdog_s=10.0,
                **{k: v for k, v in change.items() if k != "speed"})
    if "speed" in change:
        m = m.model_copy(update={"speed_mps": change["speed"]})
    run = fly(m)
    t_enable = run.timeline[1].t_s
    refused = run.timeline[2]
    assert (refused.trigger, refused.source, refused.dest) == (
        "command_refused", "amp.override", "amp.override"
    )
    assert reason in refused.detail
    assert run.refusals >= 9  # one per 1 Hz cycle until the watchdog
    watchdog = run.timeline[3]
    assert (watchdog.trigger, watchdog.dest) == ("watchdog_timeout", "amp.give_back")
    assert watchdog.t_s - t_enable == pytest.approx(10.0, abs=0.25)
    assert_resumed_at_break_off(run, m)


def test_cptbt_phases_prints_the_machine_and_writes_dot(tmp_path: Path, capsys: Any) -> None:
    from cptbt.cli import main

    dot = tmp_path / "phases.dot"
    assert main(["phases", str(ROOT / "missions" / "tro2006_msn010.yaml"), "--dot", str(dot)]) == 0
    out = capsys.readouterr().out
    assert "amp.override --watchdog_timeout--> amp.give_back" in out
    assert "amp_enable: on reaching waypoint 1" in out
    text = dot.read_text()
    assert text.startswith("digraph") and '"return_to_break_off" -> "mission_a.resumed"' in text
    assert "no mission_a section" not in out
    # a mission without Mission A says so before the machine, not after it (a review)
    assert main(["phases", str(ROOT / "missions" / "oblique_flow.yaml")]) == 0
    first = capsys.readouterr().out.splitlines()[1]
    assert first.startswith("  this mission has no mission_a section"), first


def test_cptbt_run_reports_phases_and_geodetic_positions(tmp_path: Path) -> None:
    import json

    from cptbt.cli import main

    assert main(["run", str(ROOT / "missions" / "tro2006_msn010.yaml"), "--out", str(tmp_path),
                 "--quiet", "--no-figure"]) == 0
    s = json.loads((tmp_path / "summary.json").read_text())
    assert [c["trigger"] for c in s["phases"]["timeline"]][:3] == [
        "launch", "amp_enable", "declared_home"
    ]
    assert s["t0"] == s["phases"]["t_amp_start"] > 0
    true = s["true_source"]  # TRO Table II: 32°58.867'N 118°32.248'W
    assert true["lat"] == pytest.approx(32 + 58.867 / 60, abs=1e-7)
    assert true["lon"] == pytest.approx(-(118 + 32.248 / 60), abs=1e-7)
    assert {"x", "y", "north", "east", "lat", "lon"} <= set(s["declared_source"])
    assert {"x", "y", "north", "east", "lat", "lon"} <= set(s["start"])  # the take-over point


class Straight(PlanBehaviour):
    """Find-plume that heads one way, walls or not (a review's, to leave the OpArea)."""

    family: ClassVar[str] = "find_plume"
    variant: ClassVar[str] = "straight"
    Params: ClassVar[type[BehaviourParams]] = BehaviourParams

    def decide(self, p: Percept) -> Command | None:
        return self.command(-90.0)


def test_farthest_outside_counts_the_give_back_step(tmp_path: Path) -> None:
    """A review's AMP, with no safety and a find-plume heading out, was given back 30 m outside
    the OpArea; the summary said 25.8 m: the give-back step, where the AMP's last command had
    taken the vehicle (27.3 m, true), records no row and was left out."""
    from cptbt.batch.summary import summarise

    text = (ROOT / "missions" / "tro2006_msn007.yaml").read_text(encoding="utf-8")
    text = text.replace("  - safety: {variant: oparea}\n", "").replace(
        "find_plume: {variant: billiard, dtheta_up_deg: 125, dtheta_down_deg: 60}",
        "find_plume: {variant: straight}")
    registry = load_entry_points()  # a registry of its own: the default one is shared
    registry.register(BehaviourSpec.of(Straight))
    mission = loads_mission(text, "out.yaml", registry, Environment)
    params = to_sim_params(mission)
    run, _, wall = simulate_phased(mission, params, trace=True,
                                   planner=Planner(mission, registry))
    assert run.amp.outcome is not None and run.amp.outcome.value == "relinquished"
    s = summarise(run.amp, mission, Point(*params.source_xy_m), 7, wall)
    trace = run.amp.trace
    assert trace is not None
    area = mission.op_area_geometry()
    t = np.asarray(trace["t"])
    amp = (t >= (run.t_amp_start or 0.0)) & (t <= run.amp.t_end + 1e-9)  # the AMP's steps
    far = area.distance_outside_array(np.asarray(trace["x"])[amp],
                                      np.asarray(trace["y"])[amp]).max()
    assert s.farthest_outside_m == pytest.approx(float(far), abs=1e-9)
    assert s.farthest_outside_m > 25.0
