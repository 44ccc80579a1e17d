"""Declare-source variants, tick by tick (SPEC §7; TRO IV-D; OMAE).

Lost-contact points are produced by the real perception: a cycle detecting at the point, then a
cycle 2 s later (lambda_s = 1 s) with no detection, which appends the point to the list.
"""

from __future__ import annotations

import math

import pytest
from py_trees.common import Status
from pydantic import ValidationError

from cptbt.behaviours.declare_source import (
    RecentBoxDeclare,
    UpflowClusterDeclare,
    UpflowClusterParams,
    UpflowSpreadDeclare,
)
from cptbt.behaviours.safety import OpAreaSafety, OpAreaSafetyParams
from cptbt.mission import BehaviourEntry
from cptbt.registry import BehaviourSpec, Registry
from cptbt.testing import (
    ScriptedPerception,
    TreeHarness,
    check_behaviour,
    fresh_namespace,
    make_context,
)
from cptbt.tree import build_tree
from cptbt.types import Point

FLOW_PLUS_X = (1.0, 0.0)  # flow toward +x: upflow 180°, most up-flow = smallest x
FLOW_MINUS_Y = (0.0, -1.0)  # flow toward -y: upflow +90°, most up-flow = largest y


def harness(node: object, **context: object) -> TreeHarness:
    return TreeHarness(node, make_context(**context))  # type: ignore[arg-type]


def declare(cls: type, points: list[tuple[float, float]], flow=FLOW_PLUS_X, **params: object):
    """Run ``cls`` over the lost contacts of ``points`` with the vehicle at (50, 0)."""
    script = ScriptedPerception(flow=flow, lambda_s=1.0)
    node = cls(cls.Params(**params), namespace=fresh_namespace())
    h = harness(node)
    ticks = h.run(script.lost_contacts(points, at=(50.0, 0.0)))
    return h, ticks


def test_upflow_cluster_declares_on_a_tight_upflow_cluster() -> None:
    # Near-source points alternate with downstream ones (TRO footnote 1). With flow toward +x
    # the three most up-flow are the smallest x: (20,0), (21,1), (22,-1); box x 20..22,
    # y -1..1, R = sqrt(2² + 2²) = 2.83 <= 4 → source at the centre (21, 0). The list reaches
    # M = 6 points only on the last cycle, so nothing is declared before it. From (50, 0) the
    # bearing to (21, 0) is 180°.
    pts = [(40.0, 5.0), (20.0, 0.0), (45.0, -5.0), (21.0, 1.0), (50.0, 0.0), (22.0, -1.0)]
    h, ticks = declare(UpflowClusterDeclare, pts)
    assert [tk.status for tk in ticks[:-1]] == [Status.FAILURE] * 11
    assert ticks[-1].status == Status.RUNNING
    assert ticks[-1].command is not None and ticks[-1].command.heading_deg == 180.0
    assert h.get("declared_source") == Point(21.0, 0.0)


def test_upflow_cluster_epsilon_is_inclusive() -> None:
    # Top three x = 20, 22, 24 on y = 0: R = 4 exactly, R <= epsilon → declare at (22, 0).
    pts = [(60.0, 0.0), (20.0, 0.0), (70.0, 0.0), (24.0, 0.0), (80.0, 0.0), (22.0, 0.0)]
    h, ticks = declare(UpflowClusterDeclare, pts)
    assert ticks[-1].status == Status.RUNNING
    assert h.get("declared_source") == Point(22.0, 0.0)


def test_upflow_cluster_no_declaration_when_stretched_along_the_flow() -> None:
    # Top three x = 20, 23, 26 on y = 0: R = 6 > 4 → no declaration, no output ever.
    pts = [(20.0, 0.0), (23.0, 0.0), (26.0, 0.0), (40.0, 0.0), (45.0, 0.0), (50.0, 0.0)]
    h, ticks = declare(UpflowClusterDeclare, pts)
    assert all(tk.status == Status.FAILURE and tk.command is None for tk in ticks)
    assert h.get("declared_source") is None


def test_upflow_cluster_uses_only_the_m_most_recent_points() -> None:
    # An old tight cluster (20,0), (20.5,0.5), (21,0) then six new points spread along the flow
    # 10 m apart. On the last cycle the window is the six new points: top three x = 30, 40, 50,
    # R = 20 > 4 → no declaration. Control: the percept holding only the old cluster plus the
    # first three new points (6 points) does declare, at the old cluster's box centre
    # (20.5, 0.25) — so the old cluster is declarable and only the window excludes it.
    script = ScriptedPerception(flow=FLOW_PLUS_X, lambda_s=1.0)
    old = [(20.0, 0.0), (20.5, 0.5), (21.0, 0.0)]
    new = [(30.0, 0.0), (40.0, 0.0), (50.0, 0.0), (60.0, 0.0), (70.0, 0.0), (80.0, 0.0)]
    percepts = script.lost_contacts(old + new, at=(90.0, 0.0))
    assert len(percepts[-1].lost_contacts) == 9 and len(percepts[11].lost_contacts) == 6
    late = harness(UpflowClusterDeclare(namespace=fresh_namespace()))
    assert late.tick(percepts[-1]).status == Status.FAILURE
    assert late.get("declared_source") is None
    early = harness(UpflowClusterDeclare(namespace=fresh_namespace()))
    assert early.tick(percepts[11]).status == Status.RUNNING
    assert early.get("declared_source") == Point(20.5, 0.25)


# Cluster A is most up-flow for flow toward +x (smallest x): box centre (11, -20), R = 2.83.
# Cluster B is most up-flow for flow toward -y (largest y, projection on (0, 1)): centre (41, 20).
MIXED = [(10.0, -20.0), (40.0, 20.0), (11.0, -19.0), (41.0, 21.0), (12.0, -21.0), (42.0, 19.0)]


@pytest.mark.parametrize(
    ("flow", "source"), [(FLOW_PLUS_X, Point(11.0, -20.0)), (FLOW_MINUS_Y, Point(41.0, 20.0))]
)
def test_upflow_sorting_follows_the_current_flow(flow: tuple[float, float], source: Point) -> None:
    h, ticks = declare(UpflowClusterDeclare, MIXED, flow=flow)
    assert ticks[-1].status == Status.RUNNING
    got = h.get("declared_source")
    assert isinstance(got, Point)
    assert math.isclose(got.x, source.x) and math.isclose(got.y, source.y, abs_tol=1e-9)


def test_go_to_source_then_home_then_mission_done() -> None:
    # Declared at (21, 0) with the vehicle at (50, 0); home (70, 40). Then, hand by hand:
    #   (35, 0): 14 m from the source > 10 → toward the source, 180°
    #   (30, 0): 9 m <= 10 → target home: atan2(40, 40) = 45°
    #   (70, 0): 49 m from the source but the switch is latched: atan2(40, 0) = 90°
    #   (70, 31): 9 m from home <= 10 → mission_done, still heading home, 90°
    script = ScriptedPerception(flow=FLOW_PLUS_X, lambda_s=1.0)
    pts = [(40.0, 5.0), (20.0, 0.0), (45.0, -5.0), (21.0, 1.0), (50.0, 0.0), (22.0, -1.0)]
    percepts = script.lost_contacts(pts, at=(50.0, 0.0))
    h = harness(UpflowClusterDeclare(namespace=fresh_namespace()), home=(70.0, 40.0))
    h.run(percepts)
    expected = [((35.0, 0.0), 180.0, False), ((30.0, 0.0), 45.0, False)]
    expected += [((70.0, 0.0), 90.0, False), ((70.0, 31.0), 90.0, True)]
    for i, ((x, y), heading, done) in enumerate(expected):
        tk = h.tick(script.step(20.0 + i, x, y))
        assert tk.status == Status.RUNNING
        assert tk.command is not None and math.isclose(tk.command.heading_deg, heading)
        assert h.get("mission_done") is done


def test_declaration_made_while_safety_drives_in_a_real_tree() -> None:
    # Every lost-contact cycle happens at (110, 0), 10 m outside the 100-m OpArea: safety drives
    # toward (90, 0), heading 180°. The sixth loss completes the cluster of the first test; the
    # watcher declares (21, 0) although safety holds the output. Back inside at (21, 20),
    # declare-source drives: bearing to (21, 0) = -90°. Out again at (120, 0): safety, 180°.
    # Inside at (21, 20) again: declare-source resumes (declaration kept across pre-emption).
    registry = Registry()
    registry.register_all([BehaviourSpec.of(OpAreaSafety), BehaviourSpec.of(UpflowClusterDeclare)])
    entries = [
        BehaviourEntry(family="safety", variant="oparea", params=OpAreaSafetyParams()),
        BehaviourEntry(
            family="declare_source", variant="upflow_cluster", params=UpflowClusterParams()
        ),
    ]
    root = build_tree(entries, registry, fresh_namespace())
    h = TreeHarness(root, make_context())
    script = ScriptedPerception(flow=FLOW_PLUS_X, lambda_s=1.0)
    pts = [(40.0, 5.0), (20.0, 0.0), (45.0, -5.0), (21.0, 1.0), (50.0, 0.0), (22.0, -1.0)]
    ticks = h.run(script.lost_contacts(pts, at=(110.0, 0.0)))
    assert [tk.status for tk in ticks] == [Status.FAILURE, Status.RUNNING] * 6
    driven = [(tk.active, tk.command.heading_deg if tk.command else None) for tk in ticks[1::2]]
    assert driven == [("safety.oparea", 180.0)] * 6
    assert h.get("declared_source") == Point(21.0, 0.0)
    after = [((21.0, 20.0), -90.0), ((120.0, 0.0), 180.0), ((21.0, 20.0), -90.0)]
    names = ["declare_source.upflow_cluster (to source)", "safety.oparea",
             "declare_source.upflow_cluster (to source)"]
    for i, (((x, y), heading), name) in enumerate(zip(after, names, strict=True)):
        tk = h.tick(script.step(20.0 + i, x, y))
        assert tk.active == name
        assert tk.command is not None and tk.command.heading_deg == heading
    # at the source: the trip home is recorded as such, not as the declaration's own time
    assert h.tick(script.step(24.0, 21.0, 0.5)).active == "declare_source.upflow_cluster (home)"


def test_recent_box_declares_on_the_last_three_points_only() -> None:
    # Last three (20,0), (23,3.5), (21,1): length 3 < 4, width 3.5 < 4 → box centre
    # (21.5, 1.75); the older far point (80, 40) is outside the window.
    h, ticks = declare(RecentBoxDeclare, [(80.0, 40.0), (20.0, 0.0), (23.0, 3.5), (21.0, 1.0)])
    assert [tk.status for tk in ticks[:-1]] == [Status.FAILURE] * 7
    assert ticks[-1].status == Status.RUNNING
    assert h.get("declared_source") == Point(21.5, 1.75)


def test_recent_box_side_limit_is_strict() -> None:
    # Length exactly 4 (x 20..24) is not < 4 → no declaration.
    h, ticks = declare(RecentBoxDeclare, [(20.0, 0.0), (24.0, 0.0), (22.0, 1.0)])
    assert all(tk.status == Status.FAILURE for tk in ticks)
    assert h.get("declared_source") is None


def test_upflow_spread_tests_the_along_flow_spread_only() -> None:
    # Flow toward +x: top three x = 20, 22, 24 → along-flow spread 4 <= 5 → declare at their
    # centroid ((20+22+24)/3, (10-10+0)/3) = (22, 0) though they are 20 m apart across the flow.
    pts = [(20.0, 10.0), (40.0, 0.0), (22.0, -10.0), (45.0, 5.0), (24.0, 0.0), (50.0, 0.0)]
    h, ticks = declare(UpflowSpreadDeclare, pts)
    assert [tk.status for tk in ticks[:-1]] == [Status.FAILURE] * 11
    assert ticks[-1].status == Status.RUNNING
    assert h.get("declared_source") == Point(22.0, 0.0)


def test_upflow_spread_no_declaration_when_spread_along_the_flow() -> None:
    # Top three x = 20, 23, 26: spread 6 > 5.
    pts = [(20.0, 0.0), (23.0, 0.0), (26.0, 0.0), (40.0, 0.0), (45.0, 0.0), (50.0, 0.0)]
    h, ticks = declare(UpflowSpreadDeclare, pts)
    assert all(tk.status == Status.FAILURE for tk in ticks)
    assert h.get("declared_source") is None


def test_cluster_larger_than_window_is_rejected() -> None:
    with pytest.raises(ValidationError):
        UpflowClusterParams(recent_points=2, cluster_points=3)


@pytest.mark.parametrize(
    "cls", [UpflowClusterDeclare, RecentBoxDeclare, UpflowSpreadDeclare]
)
def test_conformance(cls: type) -> None:
    check_behaviour(BehaviourSpec.of(cls))
