"""The turn guard: a large turn starts on the side that keeps the turning circle inside."""

from __future__ import annotations

import math

import pytest

from cptbt.frames import OpArea
from cptbt.turns import arc_excursion, guard_heading

BOX = OpArea(-25.0, 25.0, -25.0, 25.0)
R = 7.5


def test_a_half_circle_beside_a_wall_goes_out_by_its_diameter_less_the_gap() -> None:
    # From (0, 20) heading +x, turning +180° (toward +y) at R: the top of the circle is at
    # y = 20 + 2R = 35, 10 m past the wall at 25.
    assert arc_excursion(0.0, 20.0, 0.0, 180.0, R, BOX) == pytest.approx(10.0, abs=0.05)
    assert arc_excursion(0.0, 20.0, 0.0, -180.0, R, BOX) == 0.0  # the other way: inside
    assert arc_excursion(0.0, 0.0, 0.0, 360.0, R, BOX) == 0.0


def test_a_short_turn_toward_the_wall_is_started_the_long_way() -> None:
    # 3 m from the +y wall heading 45° (toward +x, +y); the command -170° is 145° the short
    # way (through +y: out) and 215° the long way (through +x and -y: inside).
    assert guard_heading(15.0, 22.0, 45.0, -170.0, R, BOX) == pytest.approx(-45.0)
    # Mid-box the same command passes: the short way stays inside.
    assert guard_heading(0.0, 0.0, 45.0, -170.0, R, BOX) == -170.0


@pytest.mark.parametrize(("x", "y", "heading", "command"), [
    (15.0, 22.0, 45.0, 120.0),          # 75° of turn: never guarded
    (15.0, 22.0, math.nan, -170.0),     # no heading estimate
    (math.nan, 22.0, 45.0, -170.0),     # no position
])
def test_small_turns_and_unknown_poses_pass_unchanged(x: float, y: float, heading: float,
                                                      command: float) -> None:
    assert guard_heading(x, y, heading, command, R, BOX) == command


def test_in_a_corner_where_both_ways_leave_the_smaller_excursion_wins() -> None:
    # 0.5 m from +x, 5.8 m from +y, heading 63° into the corner: both ways leave the box; the
    # short way (5.1 m out) is kept because the long way, through +x first, leaves farther.
    short = arc_excursion(24.5, 19.2, 62.9, 141.2, R, BOX)
    long = arc_excursion(24.5, 19.2, 62.9, -218.8, R, BOX)
    assert 0.0 < short < long
    assert guard_heading(24.5, 19.2, 62.9, -155.9, R, BOX) == -155.9


def test_the_planner_applies_the_guard_to_what_the_tree_commands() -> None:
    from pathlib import Path

    from cptbt.batch.scenario import Environment
    from cptbt.fleet import fleet_support
    from cptbt.loader import load_mission
    from cptbt.planner import Planner
    from cptbt.registry import default_registry

    path = Path(__file__).resolve().parents[2] / "missions" / "small_oparea.yaml"
    guarded = load_mission(path, default_registry(), Environment).model_copy(
        update={"mission_a": None})
    bare = guarded.model_copy(update={"turn_guard_radius_m": None})
    # 3 m from the +y wall and 5 m from the -x wall, heading 100°; move-to-field wants -82°:
    # 178° the short way, through 180° (toward -x: 10 m out), so the long way is started.
    headings = []
    for mission in (bare, guarded):
        planner = Planner(mission)
        planner.set_pose(-20.0, 22.0, 100.0)
        cmd = planner.tick(0.0)
        assert cmd is not None and planner.active == "move_to_field.go_to"
        headings.append(cmd.heading_deg)
    assert headings[0] == pytest.approx(-82.3, abs=0.05)
    assert headings[1] == pytest.approx(10.0)
    # Next cycle, turned 90° the long way: the rest of the turn is the short way, inside.
    planner.set_pose(-17.0, 21.0, 10.0)
    cmd = planner.tick(1.0)
    assert cmd is not None and cmd.heading_deg == pytest.approx(-86.8, abs=0.05)  # go_to's
    # The fleet planner has no array form of the rule: such a mission flies py_trees.
    support = fleet_support(guarded)
    assert not support.ok and "turn_guard" in support.reason
