"""OpArea safety (SPEC §3, §8), tick by tick, and with find-plume in a tree.

OpArea ``square_area(100)``: x in [0, 100], y in [-50, 50]. Defaults: take over 5 m outside,
steer for the point 10 m inside nearest the vehicle, hand back 5 m inside.
"""

from __future__ import annotations

import math
from itertools import pairwise

import py_trees
import pytest
from py_trees.common import Status

from cptbt.angles import unit
from cptbt.behaviours.find_plume import BilliardFindPlume
from cptbt.behaviours.safety import BEHAVIOURS, OpAreaSafety, OpAreaSafetyParams
from cptbt.frames import OpArea, WallExit
from cptbt.registry import BehaviourSpec
from cptbt.testing import (
    FakeVehicle,
    ScriptedPerception,
    TreeHarness,
    check_behaviour,
    fresh_namespace,
    make_context,
    square_area,
)
from cptbt.types import Command, Point


class Run:
    """Safety alone, one second per step."""

    def __init__(self, area: OpArea | None = None, **params: float) -> None:
        self.area = area or square_area(100)
        self.node = OpAreaSafety(OpAreaSafetyParams(**params), namespace=fresh_namespace())
        self.h = TreeHarness(self.node, make_context(self.area))
        self.script = ScriptedPerception(self.area)
        self.t = 0.0

    def at(self, x: float, y: float) -> float | None:
        tk = self.h.tick(self.script.step(self.t, x, y))
        self.t += 1.0
        assert (tk.status == Status.RUNNING) == (tk.command is not None)
        return tk.command.heading_deg if tk.command else None

    def report(self) -> object:
        return py_trees.blackboard.Blackboard.storage.get(f"{self.node.namespace}/oparea_exit")


def test_takes_over_beyond_the_trigger_and_heads_in_along_the_inward_normal() -> None:
    run = Run()
    assert run.at(50, -54) is None  # 4 m outside: the behaviours below handle it
    assert run.at(50, -56) == pytest.approx(90)  # 6 m outside: toward (50, -40), +y
    assert run.at(106, 20) == pytest.approx(180)  # still out (other wall): toward (90, 20)


def test_hands_back_only_a_margin_inside_and_reports_the_walls() -> None:
    run = Run()
    assert run.at(50, 57) == pytest.approx(-90)
    assert run.at(50, 51) == pytest.approx(-90)
    assert run.at(50, 48) == pytest.approx(-90)  # inside, 2 m: not yet
    assert run.report() is None
    assert run.at(50, 44) is None  # 6 m inside: handed back
    assert run.report() == WallExit(3.0, Point(50, 57), ((0.0, 1.0),))
    assert run.at(50, 48) is None  # inside: no new take-over


def test_in_a_corner_it_heads_diagonally_in_and_reports_both_walls() -> None:
    run = Run()
    # (-6, -56): nearest point 10 m inside is (10, -40): bearing 45°.
    assert run.at(-6, -56) == pytest.approx(45)
    assert run.at(-1, -49) == pytest.approx(math.degrees(math.atan2(9, 11)))
    assert run.at(6, -44) is None
    report = run.report()
    assert isinstance(report, WallExit)
    assert set(report.normals) == {(-1.0, 0.0), (0.0, -1.0)}


def test_release_depth_is_clipped_in_a_narrow_oparea() -> None:
    # 12 m wide in y: the release depth is min(5, 10, 12/4) = 3 m, the inset 6 m (half width).
    run = Run(OpArea(0, 100, -6, 6))
    assert run.at(50, 12) == pytest.approx(-90)  # toward (50, 0)
    assert run.at(50, 4) == pytest.approx(-90)  # 2 m inside
    assert run.at(50, 2.5) is None  # 3.5 m inside


def test_no_chatter_when_hovering_at_the_trigger_line() -> None:
    run = Run()
    got = [run.at(50, y) for y in (-56, -54, -56, -52, -50, -47, -44)]
    assert got == pytest.approx([90, 90, 90, 90, 90, 90, None])


@pytest.mark.parametrize("spec", BEHAVIOURS, ids=lambda s: s.key)
def test_conformance(spec: BehaviourSpec) -> None:
    check_behaviour(spec)


class TurningVehicle(FakeVehicle):
    """A vehicle whose heading turns at most ``rate_deg_s`` toward the command."""

    def __init__(self, x: float, y: float, heading_deg: float, rate_deg_s: float,
                 current: tuple[float, float]) -> None:
        super().__init__(x, y, heading_deg, current)
        self.rate = rate_deg_s

    def apply(self, cmd: Command | None, dt: float) -> None:
        if cmd is not None:
            err = (cmd.heading_deg - self.heading_deg + 180.0) % 360.0 - 180.0
            self.heading_deg += max(-self.rate * dt, min(self.rate * dt, err))
            speed = cmd.speed_mps
        else:
            speed = 0.0
        ux, uy = unit(self.heading_deg)
        self.x += (speed * ux + self.current[0]) * dt
        self.y += (speed * uy + self.current[1]) * dt


@pytest.mark.parametrize("flow_angle", [0, 45, 90, 135, 180, 270])
def test_safety_and_find_plume_share_the_wall_without_repeated_take_overs(
    flow_angle: float,
) -> None:
    # Safety over find-plume in one tree, a REMUS-like vehicle (1.5 m/s, 11.5°/s = 7.5 m turning
    # radius), a 0.3 m/s current and no wall margin in find-plume (it reflects only once
    # beyond a wall), for 40 minutes: find-plume's own reflections plus safety's report keep
    # the vehicle near the OpArea; safety takes over only now and then, never twice running
    # at one wall, and each excursion stays under 15 m.
    ns = fresh_namespace()
    area = square_area(100)
    safety = OpAreaSafety(namespace=ns)
    find = BilliardFindPlume(BilliardFindPlume.Params(wall_margin_m=0.0), namespace=ns)
    root = py_trees.composites.Selector("amp", memory=False, children=[safety, find])
    harness = TreeHarness(root, make_context(area, speed_mps=1.5))
    fx, fy = unit(flow_angle)
    current = (0.3 * fx, 0.3 * fy)
    script = ScriptedPerception(area, flow=current, flow_window_s=1.0)
    vehicle = TurningVehicle(50.0, 0.0, 0.0, math.degrees(1.5 / 7.5), current)
    active: list[str | None] = []
    worst = 0.0
    for t in range(2400):
        tk = harness.tick(script.step(float(t), vehicle.x, vehicle.y, vehicle.heading_deg))
        active.append(tk.active)
        vehicle.apply(tk.command, 1.0)
        worst = max(worst, area.distance_outside(vehicle.x, vehicle.y))
    takes = [i for i, a in enumerate(active) if a == "safety.oparea" and
             (i == 0 or active[i - 1] != "safety.oparea")]
    assert worst < 15.0
    assert len(takes) <= 8, takes
    gaps = [b - a for a, b in pairwise(takes)]
    assert all(g > 30 for g in gaps), gaps


def test_stands_aside_for_the_homeward_leg_to_a_home_outside() -> None:
    """A home outside the OpArea (allow_outside): once the AMP is homeward, safety no longer
    pulls the vehicle back at the wall (the two looped there until the time limit)."""
    area = square_area(100)
    for home, homeward, expect_output in (((50, -70), True, False),   # home outside: aside
                                          ((50, -70), False, True),   # not homeward yet
                                          ((50, 0), True, True)):     # home inside: as usual
        node = OpAreaSafety(OpAreaSafetyParams(), namespace=fresh_namespace())
        h = TreeHarness(node, make_context(area, home=home))
        h.set("homeward", homeward)
        tk = h.tick(ScriptedPerception(area).step(0.0, 50, -60))  # 10 m outside
        assert (tk.command is not None) == expect_output, (home, homeward)


def test_hands_back_when_the_vehicle_turns_homeward_mid_excursion() -> None:
    area = square_area(100)
    node = OpAreaSafety(OpAreaSafetyParams(), namespace=fresh_namespace())
    h = TreeHarness(node, make_context(area, home=(50, -70)))
    script = ScriptedPerception(area)
    assert h.tick(script.step(0.0, 50, -60)).command is not None  # takes over
    h.set("homeward", True)
    tk = h.tick(script.step(1.0, 50, -61))
    assert tk.command is None and tk.status == Status.FAILURE
    report = py_trees.blackboard.Blackboard.storage.get(f"{node.namespace}/oparea_exit")
    assert isinstance(report, WallExit)  # the excursion is still reported to find-plume
