"""Plume behaviours near the OpArea walls (issue 11): tracking turned along a wall, tours inside.

Also the OpArea geometry helpers those behaviours use (``cptbt.frames``). OpArea
``square_area(100)``: x in [0, 100], y in [-50, 50], centre (50, 0); default margins: tracking
5 m, tour points 10 m.
"""

from __future__ import annotations

import math

import pytest
from hypothesis import given
from hypothesis import strategies as st
from py_trees.common import Status

from cptbt.angles import unit
from cptbt.behaviours.maintain_plume import BEHAVIOURS as MAINTAIN
from cptbt.behaviours.maintain_plume import (
    CounterTurnParams,
    CounterTurnTrack,
    TrackParams,
)
from cptbt.frames import OpArea
from cptbt.testing import ScriptedPerception, TreeHarness, fresh_namespace, square_area
from cptbt.types import Point

HIT = 0.5
AREA = square_area(100)


def track(params: TrackParams | None = None) -> TreeHarness:
    return TreeHarness(MAINTAIN[0].build(params or TrackParams(), fresh_namespace()))


def heading(h: TreeHarness, script: ScriptedPerception, t: float, x: float, y: float,
            conc: float = 0.0, psi: float = 0.0) -> float | None:
    tk = h.tick(script.step(t, x, y, psi, conc=conc))
    assert (tk.status == Status.RUNNING) == (tk.command is not None)
    return tk.command.heading_deg if tk.command else None


# Flow toward -x (upflow 0°, toward xmax): track-in heads 0° into xmax.
@pytest.mark.parametrize(
    ("where", "want"),
    [
        ((50, 0), 0.0),  # far from every wall: up-flow, as TRO
        ((96, -10), 90.0),  # within 5 m, straight at the wall: along it, toward the centre
        ((96, 10), -90.0),
        ((96, 0), 180.0),  # on the centre line nothing is left along the wall: turn back
    ],
)
def test_track_in_turns_along_a_wall_instead_of_out_through_it(
    where: tuple[float, float], want: float
) -> None:
    h = track()
    script = ScriptedPerception(flow=(-1.0, 0.0))
    got = heading(h, script, 0.0, *where, conc=HIT)
    assert got == pytest.approx(want, abs=1e-6)


def test_track_in_corner_heads_for_the_centre() -> None:
    h = track()
    script = ScriptedPerception(flow=(-1.0, 0.0))
    # At (96, 47), upflow 0° is out through xmax; with xmax's component removed nothing is left
    # to run along, and ymax is near too: toward the centre (50, 0).
    got = heading(h, script, 0.0, 96, 47, conc=HIT)
    assert got == pytest.approx(math.degrees(math.atan2(-47, -46)))


def test_track_out_keeps_beta_sign_but_its_heading_inside() -> None:
    # Flow -x (upflow 0). Last detection (98, 0); the vehicle at (97, -3): phi = atan2(3, 1),
    # dphi = wrap(180 - 71.6) > 0 -> beta +10 -> heading 10°, out through xmax: along the wall,
    # +y (the heading's own side) -> 90°. beta_sign still +1.
    h = track()
    script = ScriptedPerception(flow=(-1.0, 0.0))
    heading(h, script, 0.0, 98, 0, conc=HIT)
    assert heading(h, script, 1.0, 97, -3) == pytest.approx(90.0)
    assert h.get("beta_sign") == 1


def test_track_out_beyond_the_wall_turns_back_in() -> None:
    # Detection at (98, 0); at (103, 10) (detections there would be ignored, SPEC §2):
    # phi = atan2(-10, -5), dphi = wrap(180 - phi) < 0 -> beta -10 -> heading -10°, out through
    # xmax; beyond it the outward component is reversed: -170°.
    h = track()
    script = ScriptedPerception(flow=(-1.0, 0.0))
    heading(h, script, 0.0, 98, 0, conc=HIT)
    assert heading(h, script, 1.0, 103, 10) == pytest.approx(-170.0)


def test_counter_turn_turns_along_the_wall() -> None:
    # Flow -x (upflow 0), B = 10, entering while heading 10° (s = +1): 10°, out through xmax
    # at (97, 0): along the wall, +y -> 90°. Far from walls it is 10° as OMAE.
    h = TreeHarness(CounterTurnTrack(CounterTurnParams(), namespace=fresh_namespace()))
    script = ScriptedPerception(flow=(-1.0, 0.0), lambda_s=17.0)
    assert heading(h, script, 0.0, 50, 0, conc=HIT, psi=10.0) == pytest.approx(10.0)
    assert heading(h, script, 1.0, 97, 0, psi=10.0) == pytest.approx(90.0)


def test_zero_margin_is_the_papers_letter() -> None:
    h = track(TrackParams(wall_margin_m=0.0))
    script = ScriptedPerception(flow=(-1.0, 0.0))
    assert heading(h, script, 0.0, 99, 0, conc=HIT) == pytest.approx(0.0)


# ---- the geometry helpers -------------------------------------------------------------------


def test_walls_beyond_and_depth_inside() -> None:
    assert AREA.walls_beyond(50, 0) == ()
    assert AREA.walls_beyond(101, -51) == ((1.0, 0.0), (0.0, -1.0))
    assert AREA.walls_beyond(97, 0, margin_m=5) == ((1.0, 0.0),)
    assert AREA.depth_inside(50, 0) == 50
    assert AREA.depth_inside(97, 40) == 3
    assert AREA.depth_inside(103, 54) == pytest.approx(-5)


def test_clamp_extent_and_corners() -> None:
    assert AREA.clamp(-5, 70, 10) == Point(10, 40)
    assert OpArea(0, 10, -1, 1).clamp(20, 5, 10) == Point(5, 0)  # inset capped at half widths
    lo, hi = AREA.extent_along(45)
    assert (lo, hi) == pytest.approx((-50 / math.sqrt(2), 150 / math.sqrt(2)))
    assert AREA.corners[0] == Point(0, -50) and AREA.corners[2] == Point(100, 50)


@pytest.mark.parametrize("axis", [0.0, 30.0, 45.0, 120.0, -100.0])
def test_sector_areas_partition_the_oparea(axis: float) -> None:
    origin = Point(20, -30)
    parts = [AREA.sector_area(origin, axis, a, c) for a in (1, -1) for c in (1, -1)]
    assert sum(parts) == pytest.approx(100 * 100)
    if axis == 0.0:  # x > 20 and y > -30: 80 x 80
        assert parts[0] == pytest.approx(6400)


@given(
    h=st.floats(-180, 180),
    x=st.floats(-20, 120),
    y=st.floats(-70, 70),
    margin=st.floats(0, 20),
)
def test_heading_inside_never_points_out_near_a_wall(
    h: float, x: float, y: float, margin: float
) -> None:
    out = AREA.heading_inside(h, x, y, margin)
    ux, uy = unit(out)
    for wx, wy in AREA.walls_beyond(x, y, margin):
        assert ux * wx + uy * wy <= 1e-9
    if not AREA.walls_beyond(x, y, margin):
        assert out == h
