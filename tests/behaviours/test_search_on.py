"""The search for a further source between declarations (issue 13), tick by tick.

Alone: the cross-flow sweep's waypoints (across the flow to the walls, stepping along it,
reversing at the walls, inside the inset) in any flow. In the declaration node: the sweep is
flown while nothing unexplained has been seen since the declaration, the map's best cell once
something has; a declared source's plume is explained beyond the map's range.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from cptbt.angles import unit
from cptbt.behaviours.likelihood import LikelihoodMapDeclare, LikelihoodMapParams
from cptbt.behaviours.map_guided import best_target
from cptbt.behaviours.source_map import MapModelParams, SourceMap
from cptbt.behaviours.sweep import CrossFlowSweep
from cptbt.frames import OpArea
from cptbt.testing import (
    ScriptedPerception,
    TreeHarness,
    fresh_namespace,
    make_context,
    square_area,
)
from cptbt.types import Point

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


def test_the_sweep_crosses_the_flow_wall_to_wall_stepping_down_flow_then_back() -> None:
    sweep = CrossFlowSweep(spacing_m=30.0, inset_m=10.0, arrive_m=3.0)
    got = waypoints(sweep, Point(40.0, 20.0), 0.0, AREA, 8)  # flow toward +x
    expected = [
        (40, -40),   # across, to the side with more room (10 m inside the wall)
        (70, -40),   # 30 m down-flow
        (70, 40),    # across, the other way
        (90, 40),    # down-flow: only 20 m of room left
        (90, -40),
        (60, -40),   # no room down-flow: steps back up-flow
        (60, 40),
        (30, 40),
    ]
    assert [(round(p.x), round(p.y)) for p in got] == expected
    assert sweep.legs == 4


def test_a_waypoint_not_yet_reached_is_kept() -> None:
    sweep = CrossFlowSweep(spacing_m=30.0, inset_m=10.0, arrive_m=3.0)
    first = sweep.target(Point(40.0, 20.0), 0.0, AREA)
    assert sweep.target(Point(40.0, 0.0), 0.0, AREA) == first  # half-way: the same leg
    assert sweep.target(Point(40.0, -38.0), 0.0, AREA) != first  # within 3 m: the next


@pytest.mark.parametrize("flow_deg", [0.0, 35.0, -120.0, 90.0, 200.0])
def test_legs_run_across_the_flow_and_stay_inside_the_inset(flow_deg: float) -> None:
    sweep = CrossFlowSweep(spacing_m=25.0, inset_m=10.0, arrive_m=3.0)
    area = OpArea(-127.0, 127.0, -56.0, 56.0)
    here = Point(20.0, 5.0)
    fx, fy = unit(flow_deg)
    for nxt in waypoints(sweep, here, flow_deg, area, 20):
        assert area.xmin + 10 - 1e-9 <= nxt.x <= area.xmax - 10 + 1e-9
        assert area.ymin + 10 - 1e-9 <= nxt.y <= area.ymax - 10 + 1e-9
        dx, dy = nxt.x - here.x, nxt.y - here.y
        along = dx * fx + dy * fy
        across = -dx * fy + dy * fx
        # each move is either straight across the flow or straight along it, never both
        assert min(abs(along), abs(across)) < 1e-6
        assert abs(along) <= 25.0 + 1e-6
        here = nxt
    assert sweep.legs == 10


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


def searching(**params: object) -> tuple[LikelihoodMapDeclare, TreeHarness, ScriptedPerception]:
    """A node that declared (40, 0) of two sources, flow toward +x, the vehicle at (40, 0)."""
    node = LikelihoodMapDeclare(LikelihoodMapParams(max_sources=2, **params),
                                namespace=fresh_namespace())
    harness = TreeHarness(node, make_context(AREA))
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
