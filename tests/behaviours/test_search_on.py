"""The search for a further source between declarations (issue 13), tick by tick.

Alone: the cross-flow sweep's waypoints (across the flow to the walls, stepping along it,
reversing at the walls, inside the inset) in any flow. In the declaration node: the sweep is
flown while nothing unexplained has been seen since the declaration, the map's best cell once
something has; a declared source's plume is explained beyond the map's range.
"""

from __future__ import annotations

import math
from itertools import pairwise
from pathlib import Path

import numpy as np
import pytest

from cptbt.angles import unit
from cptbt.behaviours.likelihood import LikelihoodMapDeclare, LikelihoodMapParams
from cptbt.behaviours.map_guided import best_target
from cptbt.behaviours.map_model import MapModelParams
from cptbt.behaviours.source_map import SourceMap
from cptbt.behaviours.sweep import CrossFlowSweep
from cptbt.cli import main
from cptbt.frames import OpArea
from cptbt.testing import (
    ScriptedPerception,
    TreeHarness,
    fresh_namespace,
    make_context,
    square_area,
)
from cptbt.types import Point

ROOT = Path(__file__).resolve().parents[2]
AREA = square_area(100.0)  # x 0..100, y -50..50


def waypoints(sweep: CrossFlowSweep, start: Point, flow_deg: float, area: OpArea,
              n: int) -> list[Point]:
    """The sweep's first ``n`` waypoints, each reached exactly."""
    out, here = [], start
    for _ in range(n):
        nxt = sweep.target(here, flow_deg, area)
        assert nxt is not None
        out.append(nxt)
        here = nxt
    return out


def test_the_sweep_flies_lanes_across_the_flow_down_flow_then_up_flow_of_the_first() -> None:
    sweep = CrossFlowSweep(spacing_m=30.0, inset_m=10.0, arrive_m=3.0)
    got = waypoints(sweep, Point(40.0, 20.0), 0.0, AREA, 9)  # flow toward +x
    expected = [
        (40, -40),   # the lane through the start, toward its longer half (10 m inside the wall)
        (70, -40),   # the next lane, 30 m down-flow: its near end
        (70, 40),    # flown across
        (10, 40),    # no lane 30 m farther (x = 100 is outside the inset): up-flow of the first
        (10, -40),
        (25, -40),   # none left either way: a new pass from here, its lanes between the last's
        (25, 40),
        (55, 40),
        (55, -40),
    ]
    assert [(round(p.x), round(p.y)) for p in got] == expected
    assert sweep.legs == 5


def test_a_waypoint_not_yet_reached_is_kept() -> None:
    sweep = CrossFlowSweep(spacing_m=30.0, inset_m=10.0, arrive_m=3.0)
    first = sweep.target(Point(40.0, 20.0), 0.0, AREA)
    assert sweep.target(Point(40.0, 0.0), 0.0, AREA) == first  # half-way: the same leg
    assert sweep.target(Point(40.0, -38.0), 0.0, AREA) != first  # within 3 m: the next


@pytest.mark.parametrize("flow_deg", [0.0, 5.0, 20.0, 45.0, 135.0, -70.0, 90.0, 200.0])
@pytest.mark.parametrize("area", [OpArea(-127.0, 127.0, -56.0, 56.0),
                                  OpArea(-400.0, 400.0, -250.0, 250.0)])
def test_in_any_flow_the_lanes_advance_a_spacing_at_a_time_inside_the_inset(
        flow_deg: float, area: OpArea) -> None:
    # A review found the first sweep stalling in an oblique flow: its step along the flow ran
    # into the wall where a leg had ended, was cut short or reversed, and reversed again.
    sweep = CrossFlowSweep(spacing_m=25.0, inset_m=10.0, arrive_m=3.0)
    start = Point(-60.0, -30.0)
    here = start
    fx, fy = unit(flow_deg)
    lanes: list[float] = []
    for _ in range(40):
        nxt = sweep.target(here, flow_deg, area)
        assert nxt is not None
        assert area.xmin + 10 - 1e-6 <= nxt.x <= area.xmax - 10 + 1e-6
        assert area.ymin + 10 - 1e-6 <= nxt.y <= area.ymax - 10 + 1e-6
        if sweep.origin != start:  # a new pass began: stop reading lanes
            break
        if sweep.across:  # a lane flown: straight across the flow
            assert abs((nxt.x - here.x) * fx + (nxt.y - here.y) * fy) < 1e-6
        lanes.append((nxt.x - start.x) * fx + (nxt.y - start.y) * fy)
        here = nxt
    distinct = sorted({round(a, 6) for a in lanes})
    assert len(distinct) >= 3  # the sweep moves on along the flow...
    assert all(abs(b - a - 25.0) < 1e-6 for a, b in pairwise(distinct))  # lane by lane
    downflow = [round(a, 6) for a in lanes if a >= -1e-6]
    assert downflow == sorted(downflow)  # down-flow first, never back over a lane flown


def test_an_oparea_the_inset_leaves_no_room_in_gives_no_waypoint() -> None:
    sweep = CrossFlowSweep(spacing_m=25.0, inset_m=10.0, arrive_m=3.0)
    tiny = OpArea(0.0, 16.0, 0.0, 16.0)  # inset to its centre point
    assert sweep.target(Point(8.0, 8.0), 30.0, tiny) is None


def test_a_known_plume_is_explained_beyond_the_maps_range() -> None:
    # An OpArea longer than max_range_m: a detection 180 m down-flow of a declared source is
    # still its plume (cut off at the range, it piled the map's mass 100 m up-flow of itself).
    area = OpArea(0.0, 300.0, -50.0, 50.0)
    m = SourceMap(area, MapModelParams(max_range_m=100.0, spread_deg=3.0))
    script = ScriptedPerception(area, flow=(0.2, 0.0))
    for t in range(30):
        m.observe(script.step(t, 299.0, 49.0))
    m.explain((Point(20.0, 0.0),))
    assert m.explained_by_known(200.0, 0.0)
    assert not m.explained_by_known(200.0, 45.0)  # far to the side: not its plume
    before = m.posterior()
    m.observe(script.step(30, 200.0, 0.0, conc=1.0))
    assert np.allclose(m.posterior(), before)


def searching(threshold: float | None = None, **params: object
              ) -> tuple[LikelihoodMapDeclare, TreeHarness, ScriptedPerception]:
    """A node that declared (40, 0) of two sources, flow toward +x, the vehicle at (40, 0)
    (with a ``threshold``, the map tells strong detections, 3 times it, from weak ones)."""
    node = LikelihoodMapDeclare(LikelihoodMapParams(max_sources=2, **params),
                                namespace=fresh_namespace())
    harness = TreeHarness(node, make_context(AREA, threshold=threshold))
    script = ScriptedPerception(AREA, flow=(0.2, 0.0))
    for t in range(30):
        harness.tick(script.step(t, 99.0, 49.0))
    node._accept(Point(40.0, 0.0))
    return node, harness, script


def test_between_declarations_it_sweeps_across_the_flow() -> None:
    node, harness, script = searching()
    tick = harness.tick(script.step(30, 40.0, 10.0))
    assert tick.command is not None and abs(abs(tick.command.heading_deg) - 90.0) < 1e-6
    assert node.activity == "search on"
    # crossing the known plume on the leg (a detection it explains) does not stop the sweep
    tick = harness.tick(script.step(31, 40.0, -3.0, conc=1.0))
    assert tick.command is not None and abs(abs(tick.command.heading_deg) - 90.0) < 1e-6


def test_without_a_sweep_it_heads_for_the_maps_best_cell() -> None:
    node, harness, script = searching(search_sweep_spacing_m=None)
    tick = harness.tick(script.step(30, 40.0, 10.0))
    assert node.map is not None
    goal = best_target(node.map.belief(), Point(40.0, 10.0), explored_weight=0.1,
                       min_distance_m=3.0)
    assert goal is not None and tick.command is not None
    assert AREA.depth_inside(goal.x, goal.y) < 10.0  # before any plume: a cell by the walls
    goal = AREA.clamp(goal.x, goal.y, 10.0)  # held the inset inside: safety never turns it
    assert node.search_target == goal
    assert tick.command.heading_deg == pytest.approx(Point(40.0, 10.0).bearing_to(goal))


def test_once_plume_no_declared_source_explains_was_seen_the_map_leads() -> None:
    node, harness, script = searching()
    # plume well clear of the known one: handed back to plume tracking (no command)
    assert harness.tick(script.step(30, 80.0, -40.0, conc=1.0)).command is None
    # contact lost, then the known plume crossed again: the search resumes on the map
    for t in range(31, 40):
        harness.tick(script.step(t, 80.0, -40.0 + (t - 30), conc=0.0))
    tick = harness.tick(script.step(40, 60.0, 0.0, conc=1.0))
    assert node.map is not None and tick.command is not None
    goal = node.search_target
    assert goal is not None
    assert tick.command.heading_deg == pytest.approx(Point(60.0, 0.0).bearing_to(goal))
    assert math.hypot(goal.x - 80.0, goal.y + 40.0) < 60.0  # up-flow of that plume


def test_the_sweep_resumes_from_where_it_is_once_the_maps_lead_is_old() -> None:
    node, harness, script = searching(search_map_s=50.0)
    assert harness.tick(script.step(30, 80.0, -40.0, conc=1.0)).command is None  # a false alarm?
    for t in range(31, 80):  # the map leads (the known plume crossed now and then)
        tick = harness.tick(script.step(t, 60.0, 0.0, conc=float(t % 5 == 0)))
        assert not node.sweeping
    tick = harness.tick(script.step(81, 60.0, 10.0))  # 51 s after it: across the flow again
    assert node.sweeping and tick.command is not None
    assert abs(abs(tick.command.heading_deg) - 90.0) < 1e-6
    assert node.sweep.waypoint is not None and node.sweep.waypoint.x == pytest.approx(60.0)


def test_a_false_alarm_hands_over_to_the_plume_behaviours_only_for_a_while() -> None:
    node, harness, script = searching(search_map_s=100.0)
    assert harness.tick(script.step(30, 80.0, -40.0, conc=1.0)).command is None  # plume?
    for t in range(31, 130):  # nothing more: reacquire and find-plume lead
        assert harness.tick(script.step(t, 80.0, -40.0)).command is None
    tick = harness.tick(script.step(131, 80.0, -40.0))  # 101 s on: the sweep again
    assert tick.command is not None and node.sweeping
    assert abs(abs(tick.command.heading_deg) - 90.0) < 1e-6


def test_the_declarations_own_model_explains_a_known_plume_far_down_flow() -> None:
    # With the declaration's defaults (detection chance falling over 150 m) a known plume's
    # chance fell below explained_prob ~400 m down-flow even on its axis: beyond max_range_m
    # it keeps the chance it has there.
    area = OpArea(0.0, 700.0, -100.0, 100.0)
    m = SourceMap(area, LikelihoodMapParams())
    script = ScriptedPerception(area, flow=(0.2, 0.0))
    for t in range(30):
        m.observe(script.step(t, 699.0, 99.0))
    m.explain((Point(20.0, 0.0),))
    for x in (100.0, 300.0, 500.0, 680.0):
        assert m.explained_by_known(x, 0.0), x
    assert not m.explained_by_known(500.0, 90.0)


def test_a_strong_detection_far_down_a_known_plume_is_not_explained_by_it() -> None:
    # strong detections are rare far down a plume: one 90 m down-flow of a declared source
    # and 30 m aside (near a review's second source) says another source is close, though
    # the known plume's meander cone reaches a weak one there
    area = OpArea(-130.0, 130.0, -60.0, 60.0)
    m = SourceMap(area, LikelihoodMapParams(), strong_concentration=0.6)
    script = ScriptedPerception(area, flow=(0.1, 0.0))
    for t in range(30):
        m.observe(script.step(t, 129.0, 59.0))
    m.explain((Point(-90.0, -30.0),))
    assert m.explained_by_known(0.0, 0.0, level=1)
    assert not m.explained_by_known(0.0, 0.0, level=2)
    assert m.explained_by_known(-80.0, -30.0, level=2)  # 10 m down its axis: its own
    before = m.unexplained
    m.observe(script.step(30, 0.0, 0.0, conc=0.4))  # weak there: the known source's
    assert m.unexplained == before
    m.observe(script.step(31, 0.0, 0.0, conc=1.0))  # strong: evidence of another
    assert m.unexplained == before + 1


def test_the_sweep_hands_over_to_a_strong_detection_in_a_known_plume() -> None:
    node, harness, script = searching(threshold=0.2)  # (40, 0) declared, flow toward +x
    assert node.map is not None and node.map.strong_concentration == pytest.approx(0.6)
    for t in range(30, 33):
        harness.tick(script.step(t, 60.0, -49.0))
    # 58 m down-flow of it, 22 m aside: a weak detection there is the known plume's (the
    # sweep goes on), a strong one is not (handed over to the plume behaviours)
    assert harness.tick(script.step(33, 98.0, -22.0, conc=0.3)).command is not None
    assert harness.tick(script.step(34, 98.0, -22.0, conc=1.0)).command is None


@pytest.mark.parametrize(("setting", "says"), [
    ("search_sweep_spacing_m: 5", "shorter than a turn across"),
    ("search_sweep_inset_m: 0", "less than a turn's radius"),
    ("search_sweep_inset_m: 100000", "leaves 0 m across the OpArea's long side"),
    ("search_sweep_inset_m: 120", "leaves 14 m across the OpArea's long side"),
])
def test_sweep_settings_unlikely_meant_are_warned_of(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], setting: str, says: str) -> None:
    text = (ROOT / "missions/two_sources.yaml").read_text(encoding="utf-8")
    mission = tmp_path / "m.yaml"
    mission.write_text(text.replace("max_sources: 2}", f"max_sources: 2, {setting}}}"),
                       encoding="utf-8")
    assert main(["validate", str(mission)]) == 0
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert f"declare_source.{setting.split(':')[0]}: warning: " in line and says in line


def test_a_large_arrival_radius_is_no_error_with_one_source(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    # the sweep's spacing is checked against it only where a sweep can fly (max_sources > 1)
    text = (ROOT / "missions/tro2006_msn007.yaml").read_text(encoding="utf-8")
    old = "declare_source: {variant: upflow_cluster, recent_points: 6, epsilon_m: 4}"
    assert old in text
    mission = tmp_path / "m.yaml"
    mission.write_text(text.replace(old, "declare_source: {variant: likelihood_map, "
                                         "arrive_radius_m: 50}"), encoding="utf-8")
    assert main(["validate", str(mission)]) == 0, capsys.readouterr().err


def test_a_sweep_starts_on_the_nearest_lane_inside_even_from_outside_the_inset() -> None:
    # a flow exactly along y in a 40-m strip: the lane through the start (y = -15, outside the
    # 10-m inset) has no length, nor have those a spacing from it; y = -10 has
    sweep = CrossFlowSweep(spacing_m=40.0, inset_m=10.0, arrive_m=3.0, min_lane_m=15.0)
    area = OpArea(-150.0, 150.0, -20.0, 20.0)
    first = sweep.target(Point(0.0, -15.0), 90.0, area)
    assert first is not None and first.y == pytest.approx(-10.0) and abs(first.x) > 100


def test_lanes_no_longer_than_a_turn_are_not_flown() -> None:
    sweep = CrossFlowSweep(spacing_m=10.0, inset_m=10.0, arrive_m=3.0, min_lane_m=15.0)
    area = OpArea(0.0, 30.0, 0.0, 30.0)  # 10 m between the insets, either way
    assert sweep.target(Point(15.0, 15.0), 0.0, area) is None
    assert CrossFlowSweep(10.0, 10.0, 3.0).target(Point(15.0, 15.0), 0.0, area) is not None


def test_in_a_corridor_along_the_flow_the_lanes_run_along_it() -> None:
    # 10 m between the insets across a flow along x: no lane across it is longer than a turn,
    # so the vehicle flies the corridor's middle end to end, which runs through every plume
    sweep = CrossFlowSweep(spacing_m=100.0, inset_m=10.0, arrive_m=3.0, min_lane_m=15.0)
    area = OpArea(0.0, 300.0, 0.0, 30.0)
    got = waypoints(sweep, Point(250.0, 15.0), 0.0, area, 5)
    assert all(p.y == pytest.approx(15.0) for p in got)
    assert sorted({round(p.x) for p in got}) == [10, 290]  # end to end, back and forth
    assert [round(p.x) for p in got[:2]] in ([10, 290], [290, 10])


@pytest.mark.parametrize("flow_deg", [0.5, -0.5, 89.5, 90.5, 180.5])
@pytest.mark.parametrize("start", [Point(-20.0, -20.0), Point(420.0, 50.0), Point(0.0, 30.0)])
def test_from_beyond_a_corner_of_a_corridor_the_sweep_still_has_a_lane(
        flow_deg: float, start: Point) -> None:
    # the start clamps onto a corner of the 10-m strip, where the lane through it has no
    # length and the others lie outside: the lanes are then laid from the OpArea's centre
    area = OpArea(0.0, 400.0, 0.0, 30.0)
    sweep = CrossFlowSweep(40.0, 10.0, 5.0, min_lane_m=15.0)
    got = waypoints(sweep, start, flow_deg, area, 4)
    assert all(area.depth_inside(p.x, p.y) >= 10.0 - 1e-6 for p in got)
    assert max(p.x for p in got) - min(p.x for p in got) > 300.0  # along the corridor


def test_a_spacing_longer_than_the_oparea_still_sweeps_two_lanes_a_pass() -> None:
    # 80 m between the insets along the flow: lanes at most 40 m apart, not one lane forever
    sweep = CrossFlowSweep(spacing_m=500.0, inset_m=10.0, arrive_m=3.0, min_lane_m=15.0)
    got = waypoints(sweep, Point(40.0, 20.0), 0.0, AREA, 8)
    lanes = sorted({round(p.x) for p in got})
    assert len(lanes) >= 3 and all(10 <= x <= 90 for x in lanes)
    assert sweep.gap == pytest.approx(40.0)


def test_after_a_hand_over_the_sweep_starts_anew_from_where_the_vehicle_is() -> None:
    node, harness, script = searching(search_map_s=100.0)
    harness.tick(script.step(30, 40.0, 10.0))  # sweeping, toward (40, -40)
    assert node.sweep.origin == Point(40.0, 10.0)
    harness.tick(script.step(31, 20.0, 30.0, conc=1.0))  # plume no declared source explains
    for t in range(32, 132):
        harness.tick(script.step(t, 20.0, 30.0))
    tick = harness.tick(script.step(132, 20.0, 30.0))
    assert node.sweeping and node.sweep.origin == Point(20.0, 30.0)
    assert tick.command is not None and abs(abs(tick.command.heading_deg) - 90.0) < 1e-6


def test_a_candidate_held_in_a_known_plume_is_reported_and_can_end_the_search(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """A confident candidate where the declared source's plume is likely is held, not
    declared; the latest one is reported (a probable source, unconfirmed), and with
    ``search_give_up_s`` holds that long in all end the search, though plume keeps coming (the
    held candidate's own: the plain give-up clock never runs out). The map is scripted: its
    mass is on (60, 0), 20 m down-flow of the declared (40, 0), where that plume is likely."""
    node, harness, script = searching(search_give_up_s=50.0)
    assert node.map is not None
    confident = [True]
    monkeypatch.setattr(node.map, "mass_and_mean", lambda centre, radius, post=None: (
        0.99 if confident[0] else 0.5, Point(60.0, 0.0)))
    monkeypatch.setattr(node.map, "known_chance", lambda at: 0.5)
    t = 30
    while not node.held_in_known_plume:  # unexplained plume (strong, 40 m aside): the rule tests
        harness.tick(script.step(t, 62.0, 40.0, conc=1.0))
        t += 1
        assert t < 200
    held = 1
    for k in range(120):  # unsure two cycles in three: those do not count
        confident[0] = k % 3 == 0
        held += confident[0]
        harness.tick(script.step(t, 62.0, 40.0, conc=1.0))
        t += 1
        assert not node.search_given_up, t
    assert held == 41 and node.blocked_s == pytest.approx(41.0)  # a second a held cycle
    report = node.bb.declaration_report
    assert report["held_at"] == (60.0, 0.0) and report["held_in_known_plume"] == held
    confident[0] = True
    for _ in range(10):
        harness.tick(script.step(t, 62.0, 40.0, conc=1.0))
        t += 1
    assert node.search_given_up and node.heading_home
    assert node.search_end is not None and node.search_end.startswith(
        "candidates held or vetoed 50 s in all")
    assert node.search_end.endswith("(held in a declared source's plume; search_give_up_s)")
    assert node.sources == (Point(40.0, 0.0),)  # the held point was never declared


def test_without_a_give_up_a_held_candidate_is_held_to_the_end(
        monkeypatch: pytest.MonkeyPatch) -> None:
    node, harness, script = searching()
    assert node.map is not None
    monkeypatch.setattr(node.map, "mass_and_mean",
                        lambda centre, radius, post=None: (0.99, Point(60.0, 0.0)))
    monkeypatch.setattr(node.map, "known_chance", lambda at: 0.5)
    for t in range(30, 400):
        harness.tick(script.step(t, 62.0, 40.0, conc=1.0))
    assert not node.search_given_up and node.sources == (Point(40.0, 0.0),)
    assert node.bb.declaration_report["held_at"] == (60.0, 0.0)


def test_a_candidate_vetoed_by_a_known_plume_counts_toward_the_give_up(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """With ``upflow_known_veto`` a candidate in a known plume is vetoed (its plume seen up-flow
    of it) rather than held, and the vehicle circled it to the time limit: vetoed cycles count
    toward ``search_give_up_s`` as held ones do."""
    node, harness, script = searching(search_give_up_s=30.0, upflow_known_veto=True,
                                      known_plume_max_prob=None)
    assert node.map is not None
    monkeypatch.setattr(node.map, "mass_and_mean",
                        lambda centre, radius, post=None: (0.99, Point(60.0, 0.0)))
    for t in range(30, 200):
        # in turn: the declared source's plume 15 m up-flow of the candidate (it explains that
        # detection), and plume it does not explain 40 m aside (new evidence: the plain give-up
        # clock never runs out)
        here = (45.0, 0.5) if t % 2 else (62.0, 40.0)
        harness.tick(script.step(t, *here, conc=1.0))
        if node.search_given_up:
            break
    assert node.upflow.vetoes >= 1 and node.search_given_up, (node.upflow.report(), t)
    assert node.sources == (Point(40.0, 0.0),) and node.held_at is None


def test_a_candidate_far_from_the_last_blocked_one_starts_the_count_again(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """Held 30 s at (60, 0), then at (5, -40), 68 m away (beyond same_plume_m): the second
    gets its own 50 s (a review saw a third source's candidate cut off by the time spent on
    another 80 m away)."""
    node, harness, script = searching(search_give_up_s=50.0)
    assert node.map is not None
    where = [Point(60.0, 0.0)]
    monkeypatch.setattr(node.map, "mass_and_mean",
                        lambda centre, radius, post=None: (0.99, where[0]))
    monkeypatch.setattr(node.map, "known_chance", lambda at: 0.5)
    t = 30
    while node.blocked_s < 30.0:
        harness.tick(script.step(t, 62.0, 40.0, conc=1.0))
        t += 1
    where[0] = Point(5.0, -40.0)
    for _ in range(45):
        harness.tick(script.step(t, 62.0, 40.0, conc=1.0))
        t += 1
        assert not node.search_given_up, (t, node.blocked_s)
    for _ in range(10):
        harness.tick(script.step(t, 62.0, 40.0, conc=1.0))
        t += 1
    assert node.search_given_up and node.held_at == Point(5.0, -40.0)
