"""Reacquire-plume tours (SPEC §6), tick by tick; expected values derived by hand below.

Every test: OpArea x in [0, 100], y in [-50, 50]; the last detection C = (50, 0) at t = 0;
λ = 8.5 s, so contact is lost from t = 9. With flow (1, 0), upflow = 180°, and the three points
at 15 m from C are
    A = C + 15·(cos -120°, sin -120°) = (42.5, -12.990)   (upflow + 60° = 240° = -120°)
    B = C + 15·(cos 120°, sin 120°)   = (42.5, 12.990)    (upflow - 60° = 120°)
    D = C + 15·(cos 0°, sin 0°)       = (65, 0)           (down-flow)
Bearings between them: C→A -120°, A→C 60°, C→B 120°, B→C -60°, C→D 0°, D→C 180°,
A→B 90°, B→D -30°, D→A -150°, B→A -90°, A→D 30°.
"""

from __future__ import annotations

import math
from itertools import pairwise

import py_trees
import pytest
from py_trees.common import Status

from cptbt.behaviours.reacquire import (
    BEHAVIOURS,
    CloverleafReacquire,
    ThreePointParams,
    ThreePointReacquire,
)
from cptbt.registry import BehaviourSpec
from cptbt.testing import (
    ScriptedPerception,
    TreeHarness,
    check_behaviour,
    fresh_namespace,
    square_area,
)

R3 = 15 * math.sqrt(3) / 2  # 12.990
C = (50.0, 0.0)
A = (42.5, -R3)
B = (42.5, R3)
D = (65.0, 0.0)
HIT = 0.5


class Run:
    """A harness plus a script whose clock advances one second per step."""

    def __init__(self, node: py_trees.behaviour.Behaviour, flow: tuple[float, float]) -> None:
        self.h = TreeHarness(node)
        self.script = ScriptedPerception(flow=flow, lambda_s=8.5)
        self.t = 0.0

    def at(self, xy: tuple[float, float], conc: float = 0.0) -> float | None:
        """One cycle with the vehicle at ``xy``; the commanded heading or None."""
        tk = self.h.tick(self.script.step(self.t, *xy, conc=conc))
        self.t += 1.0
        assert (tk.status == Status.RUNNING) == (tk.command is not None)
        return tk.command.heading_deg if tk.command else None

    def lose_contact_at(self, detection: tuple[float, float], xy: tuple[float, float]) -> None:
        """A detection at ``detection``, then no output while in the plume (λ = 8.5 s)."""
        detected_at = self.t
        assert self.at(detection, conc=HIT) is None
        while self.t <= detected_at + 8.5:
            assert self.at(xy) is None


def set_beta_sign(node: py_trees.behaviour.Behaviour, value: int) -> None:
    py_trees.blackboard.Blackboard.set(f"{node.namespace}/beta_sign", value)  # type: ignore[attr-defined]


def cloverleaf(**params: float) -> CloverleafReacquire:
    return CloverleafReacquire(CloverleafReacquire.Params(**params), namespace=fresh_namespace())


# beta_sign +1 (or absent): leaf A first, then B, then D. beta_sign -1: B first, then A, then D.
@pytest.mark.parametrize(
    ("beta_sign", "first", "second"), [(None, A, B), (1, A, B), (-1, B, A)], ids=str
)
def test_cloverleaf_visits_c_then_the_leaves_in_order(
    beta_sign: int | None, first: tuple[float, float], second: tuple[float, float]
) -> None:
    node = cloverleaf(repeats=1)
    if beta_sign is not None:
        set_beta_sign(node, beta_sign)
    run = Run(node, (1.0, 0.0))
    run.lose_contact_at(C, (41.5, 0.0))
    # The vehicle lost contact 8.5 m up-flow of C; it returns to C first (bearing 0).
    assert run.at((41.5, 0.0)) == pytest.approx(0.0)
    # Teleported onto each waypoint in turn, it heads for the next one.
    got = [run.at(xy) for xy in (C, first, C, second, C, D)]
    want = [C, first, C, second, C, D, C]
    bearings = [math.degrees(math.atan2(b[1] - a[1], b[0] - a[0])) for a, b in pairwise(want)]
    assert got == pytest.approx(bearings)
    if beta_sign == -1:
        assert bearings[:2] == pytest.approx([120.0, -60.0])  # C→B, B→C
    else:
        assert bearings[:2] == pytest.approx([-120.0, 60.0])  # C→A, A→C
    # Back at C after leaf 3: the single repetition is done, find-plume takes over.
    assert run.at(C) is None


def test_cloverleaf_tips_follow_the_flow_toward_plus_y() -> None:
    # flow +y: upflow -90°, tips at -30° (first, beta_sign +1), -150°, and 90° (down-flow).
    run = Run(cloverleaf(repeats=1), (0.0, 1.0))
    run.lose_contact_at(C, (50.0, -8.5))
    assert run.at(C) == pytest.approx(-30.0)
    tip1 = (50 + R3, -7.5)  # C + 15·(cos -30°, sin -30°)
    assert run.at(tip1) == pytest.approx(150.0)
    assert run.at(C) == pytest.approx(-150.0)
    assert run.at((50 - R3, -7.5)) == pytest.approx(30.0)
    assert run.at(C) == pytest.approx(90.0)


def test_cloverleaf_stops_after_n_re_repetitions_until_a_new_contact_is_lost() -> None:
    node = cloverleaf()  # N_re = 3
    run = Run(node, (1.0, 0.0))
    run.lose_contact_at(C, C)
    headings = [run.at(xy) for xy in [C, A, C, B, C, D] * 3 + [C]]
    # Each arrival at a waypoint sends the vehicle to the next; the 19th (C, after the third
    # leaf 3) ends the tour.
    assert headings == pytest.approx([-120.0, 60.0, 120.0, -60.0, 0.0, 180.0] * 3 + [None])
    # Finished for this lost contact: no output, even after a fresh activation.
    node.stop(Status.INVALID)
    assert [run.at((30.0, 5.0)) for _ in range(3)] == [None, None, None]
    # A new contact at (30, 0), lost again: a new cloverleaf about the new centre.
    run.lose_contact_at((30.0, 0.0), (20.0, 0.0))
    assert run.at((20.0, 0.0)) == pytest.approx(0.0)  # back to the new C first
    assert run.at((30.0, 0.0)) == pytest.approx(-120.0)


def test_an_interrupted_cloverleaf_starts_afresh() -> None:
    node = cloverleaf()
    run = Run(node, (1.0, 0.0))
    run.lose_contact_at(C, C)
    assert run.at(C) == pytest.approx(-120.0)  # heading out to A
    node.stop(Status.INVALID)  # pre-empted (safety) half-way to A
    # A fresh tour starts at C again: from (46, -6) C bears atan2(6, 4) = 56.31°.
    assert run.at((46.0, -6.0)) == pytest.approx(math.degrees(math.atan2(6, 4)))
    # A detection hands over to maintain-plume (no output) and the next loss starts a new tour.
    run.lose_contact_at((46.0, -6.0), (40.0, -6.0))
    # C is now (46, -6); from (40, -6) it bears 0°.
    assert run.at((40.0, -6.0)) == pytest.approx(0.0)


def test_tips_beyond_the_op_area_are_pulled_inside() -> None:
    # No inset: C = (5, 0): D stays (20, 0); A and B would have x = -2.5, so they move to x = 0.
    run = Run(cloverleaf(wall_inset_m=0.0), (1.0, 0.0))
    run.lose_contact_at((5.0, 0.0), (5.0, 0.0))
    assert run.at((5.0, 0.0)) == pytest.approx(math.degrees(math.atan2(-R3, -5.0)))


def test_the_whole_tour_keeps_the_wall_inset() -> None:
    # Default inset 10 m: C = (5, 0) is flown as (10, 0); A = (-2.5, -R3) as (10, -R3),
    # B as (10, R3); D = (20, 0) is 10 m inside already. From (5, 0): 0° to the hub, then
    # -90° to A, 90° back to the hub, 90° to B, -90° back, 0° to D.
    node = cloverleaf(repeats=1)
    run = Run(node, (1.0, 0.0))
    run.lose_contact_at((5.0, 0.0), (5.0, 0.0))
    path = [(5.0, 0.0), (10.0, 0.0), (10.0, -R3), (10.0, 0.0), (10.0, R3), (10.0, 0.0)]
    assert [run.at(xy) for xy in path] == pytest.approx([0.0, -90.0, 90.0, 90.0, -90.0, 0.0])
    area = square_area(100)
    assert all(area.depth_inside(w.x, w.y) >= 10.0 for w in node.waypoints)


def test_three_point_keeps_the_wall_inset_in_a_corner() -> None:
    # C = (3, -47) in the corner: every point is moved to x >= 10, y >= -40.
    node = three_point()
    run = Run(node, (1.0, 0.0))
    run.lose_contact_at((3.0, -47.0), (3.0, -47.0))
    assert run.at((3.0, -47.0)) is not None
    assert {(round(w.x, 6), round(w.y, 6)) for w in node.waypoints} == {
        (10.0, -40.0), (10.0, -34.009619), (18.0, -40.0)}


def three_point(**params: float) -> ThreePointReacquire:
    return ThreePointReacquire(ThreePointParams(**params), namespace=fresh_namespace())


def test_three_point_visits_p1_p2_p3_ten_times_then_stops() -> None:
    run = Run(three_point(), (1.0, 0.0))
    run.lose_contact_at(C, C)
    # P1 = A, P2 = B, P3 = D. From C the first heading is C→A = -120°.
    assert run.at(C) == pytest.approx(-120.0)
    # Arriving at P1, P2, P3, P1, ... (10 visits): A→B 90, B→D -30, D→A -150, ...
    headings = [run.at(xy) for xy in [A, B, D, A, B, D, A, B, D, A]]
    assert headings == pytest.approx([90.0, -30.0, -150.0] * 3 + [None])
    assert run.at(C) is None


def test_three_point_starts_on_the_side_of_beta() -> None:
    node = three_point()
    set_beta_sign(node, -1)
    run = Run(node, (1.0, 0.0))
    run.lose_contact_at(C, C)
    assert [run.at(xy) for xy in (C, B, A, D)] == pytest.approx([120.0, -90.0, 30.0, 150.0])


@pytest.mark.parametrize("spec", BEHAVIOURS, ids=lambda s: s.key)
def test_conformance(spec: BehaviourSpec) -> None:
    check_behaviour(spec)
