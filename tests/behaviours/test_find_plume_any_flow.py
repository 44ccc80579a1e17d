"""Find-plume in any flow (SPEC §4 clarified; issue 11), tick by tick and in closed loop.

OpArea of the tick-by-tick tests: ``square_area(100)`` = x in [0, 100], y in [-50, 50], centre
(50, 0). The default reference is the OpArea axis the flow projects on most (an exact diagonal
goes to the x axis): flow 0° and 45° → axis 0°; 90° → 90°; 135° and 180° → 180°; 270° → -90°.
s = +1 moves toward ``axis + 90°``. Expected headings are worked out by hand in the comments.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import py_trees
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from py_trees.common import Status

from cptbt.angles import unit
from cptbt.behaviours.find_plume import (
    AppendixBilliardFindPlume,
    AppendixBilliardParams,
    BilliardFindPlume,
    BilliardParams,
)
from cptbt.frames import OpArea, WallExit
from cptbt.node import PlanBehaviour
from cptbt.testing import (
    FakeVehicle,
    ScriptedPerception,
    TreeHarness,
    fresh_namespace,
    make_context,
    square_area,
)
from cptbt.types import Point


def flow_at(angle_deg: float, speed: float = 0.1) -> tuple[float, float]:
    ux, uy = unit(angle_deg)
    return speed * ux, speed * uy


def billiard(**params: object) -> BilliardFindPlume:
    return BilliardFindPlume(BilliardParams(**params), namespace=fresh_namespace())  # type: ignore[arg-type]


def run_path(
    node: PlanBehaviour,
    path: Sequence[tuple[float, float]],
    flows: Sequence[tuple[float, float]],
    area: OpArea | None = None,
) -> list[float | None]:
    """Headings commanded at each point of ``path`` (flow ``flows[i]`` at tick i)."""
    area = area or square_area(100)
    harness = TreeHarness(node, make_context(area))
    script = ScriptedPerception(area, flow=flows[0], flow_window_s=1.0)
    out: list[float | None] = []
    for i, ((x, y), flow) in enumerate(zip(path, flows, strict=True)):
        tk = harness.tick(script.step(float(i), x, y, flow=flow))
        assert tk.status == Status.RUNNING
        out.append(tk.command.heading_deg if tk.command else None)
    return out


# Axis 0° (flow 0°, and 45° which ties to x): TRO's own pattern.
#   (20, -30): down part x > 20 (80) times +y part (80): dtheta_down 60, s = +1 -> 60
#   (40, 51) beyond ymax, a side: s = -1 -> -60
#   (101, 20) beyond xmax, the down-flow end: dtheta_up, s kept -> -125
#   (70, -51) beyond ymin, a side: s = +1 -> 125
#   (-1, 0) beyond xmin, the up-flow end: dtheta_down -> 60
# Axis 90° (flow toward +y): ymax is the down-flow end, x walls the sides, n = 180° (-x).
#   (20, -30): up-flow part y > -30 is the down part (80); -x side 20 wide, +x side 80: the
#     largest is down and s = -1 (toward +x) -> 90 - 60 = 30
#   (101, 0): side, -x is inward: s = +1 -> 150;  (60, 51): down-flow end -> 90 + 125 = -145
#   (-1, 10): side: s = -1 -> 90 - 125 = -35;  (40, -51): up-flow end -> 90 - 60 = 30
# Axis 180° (flow 180°, and 135° which ties to x): test_find_plume's flow -x path.
# Axis -90° (flow toward -y): ymin is the down-flow end, n = 0° (+x).
#   (20, -30): the part y > -30 is up-flow (80), x > 20 is +n (80): dtheta_up, s = +1 -> 35
#   (101, 0): side: s = -1 -> -90 - 125 = 145;  (60, 51): up-flow end: -90 - 60 = -150
#   (-1, 10): side: s = +1 -> -30;  (40, -51): down-flow end: -90 + 125 = 35
X_PATH = [(20, -30), (40, 51), (101, 20), (70, -51), (-1, 0)]
MINUS_X_PATH = [(80, -30), (70, 51), (-1, 20), (30, -51), (101, 0)]
Y_PATH = [(20, -30), (101, 0), (60, 51), (-1, 10), (40, -51)]


@pytest.mark.parametrize(
    ("angle", "path", "want"),
    [
        (0, X_PATH, [60, -60, -125, 125, 60]),
        (45, X_PATH, [60, -60, -125, 125, 60]),
        (90, Y_PATH, [30, 150, -145, -35, 30]),
        (135, MINUS_X_PATH, [120, -120, -55, 55, 120]),
        (180, MINUS_X_PATH, [120, -120, -55, 55, 120]),
        (270, Y_PATH, [35, 145, -150, -30, 35]),
    ],
)
def test_bounces_off_every_wall_at_any_flow_angle(
    angle: float, path: list[tuple[float, float]], want: list[float]
) -> None:
    got = run_path(billiard(), path, [flow_at(angle)] * len(path))
    assert got == pytest.approx(want)


@pytest.mark.parametrize(
    ("angle", "path", "want"),
    [
        # AB: theta_0 = 70 toward the larger cross-flow side; y wall flips; x walls 110 / 70.
        (0, X_PATH, [70, -70, -110, 110, 70]),
        # Axis 90: start s = sign(eta) = -1 (toward +x) -> 20; then as the TRO variant.
        (90, Y_PATH, [20, 160, -160, -20, 20]),
        # Axis -90: s = +1 (toward +x) -> -20; at (60, 51) -160 already heads back in: kept.
        (270, Y_PATH, [-20, -160, -160, -20, 20]),
    ],
)
def test_appendix_billiard_bounces_at_any_flow_angle(
    angle: float, path: list[tuple[float, float]], want: list[float]
) -> None:
    node = AppendixBilliardFindPlume(namespace=fresh_namespace())
    assert run_path(node, path, [flow_at(angle)] * len(path)) == pytest.approx(want)


def test_a_flow_turning_90_degrees_mid_search_turns_the_pattern() -> None:
    # Along x: 60, -60, -125 (s = -1, dtheta_up). The flow turns to +y: 90° from the axis in
    # use, beyond 45 + 10, so the axis becomes 90 and the same state heads 90 - 125 = -35.
    # Then the 90° rules: ymin is the up-flow end -> dtheta_down, s = -1: 30; xmax a side with
    # -x inward -> s = +1: 150; ymax the down-flow end -> 90 + 125 = -145.
    path = [(20, -30), (40, 51), (101, 20), (50, 0), (40, -51), (101, 0), (60, 51)]
    flows = [flow_at(0)] * 3 + [flow_at(90)] * 4
    assert run_path(billiard(), path, flows) == pytest.approx([60, -60, -125, -35, 30, 150, -145])


def test_the_axis_has_hysteresis_about_the_diagonal() -> None:
    # Started along x (60). A flow at 50° is within 45 + 10 of x: the pattern stays (60); at
    # 56° it changes to the y axis: 90 + 60 = 150; back at 40° it stays on y (50 from it).
    path = [(20, -30), (30, -20), (31, -19), (32, -18)]
    flows = [flow_at(0), flow_at(50), flow_at(56), flow_at(40)]
    assert run_path(billiard(), path, flows) == pytest.approx([60, 60, 150, 150])


def test_reference_flow_is_the_letter_of_tro() -> None:
    # reference: flow lays the offsets off the flow estimate: flow 20° from (20, -30): the
    # largest part is down-flow and toward +n -> 20 + 60 = 80; beyond ymax (a side) -> -40.
    got = run_path(billiard(reference="flow"), [(20, -30), (40, 51)], [flow_at(20)] * 2)
    assert got == pytest.approx([80, -40])


def test_a_wall_within_the_margin_counts_as_left_only_when_heading_out() -> None:
    # (97, 0) is within 5 m of xmax. Arriving with heading 60 (out through xmax) reflects to
    # 125; at (97, 10) heading 125 points back in: kept. With wall_margin_m 0 nothing happens.
    path = [(20, -30), (97, 0), (97, 10)]
    flows = [flow_at(0)] * 3
    assert run_path(billiard(), path, flows) == pytest.approx([60, 125, 125])
    assert run_path(billiard(wall_margin_m=0.0), path, flows) == pytest.approx([60, 60, 60])


def test_safety_report_makes_the_next_leg_leave_that_wall() -> None:
    # Find-plume heads 60 (out through ymax eventually). Safety reports an exit at (50, 56)
    # through ymax: a side, so s flips: -60. The same report is not applied twice, and a
    # report about a wall the heading already leaves changes nothing.
    node = billiard()
    area = square_area(100)
    harness = TreeHarness(node, make_context(area))
    script = ScriptedPerception(area, flow=flow_at(0), flow_window_s=1.0)

    def heading(t: float, x: float, y: float) -> float:
        tk = harness.tick(script.step(t, x, y))
        assert tk.command is not None
        return tk.command.heading_deg

    assert heading(0, 20, -30) == pytest.approx(60)
    key = f"{node.namespace}/oparea_exit"
    py_trees.blackboard.Blackboard.set(key, WallExit(1.0, Point(50, 56), ((0.0, 1.0),)))
    assert heading(1, 50, 40) == pytest.approx(-60)
    assert heading(2, 50, 30) == pytest.approx(-60)
    py_trees.blackboard.Blackboard.set(key, WallExit(3.0, Point(50, 56), ((0.0, 1.0),)))
    assert heading(3, 50, 30) == pytest.approx(-60)


@settings(max_examples=60, deadline=None)
@given(
    angle=st.floats(-180, 180),
    reference=st.sampled_from(["oparea_axis", "flow"]),
    ab=st.booleans(),
    path=st.lists(
        st.tuples(st.floats(-15, 115), st.floats(-65, 65)), min_size=2, max_size=25
    ),
)
def test_no_heading_chosen_at_a_wall_drives_back_out_through_it(
    angle: float, reference: str, ab: bool, path: list[tuple[float, float]]
) -> None:
    params = dict(reference=reference)
    node: PlanBehaviour = (
        AppendixBilliardFindPlume(AppendixBilliardParams(**params), namespace=fresh_namespace())  # type: ignore[arg-type]
        if ab
        else billiard(**params)
    )
    area = square_area(100)
    headings = run_path(node, path, [flow_at(angle)] * len(path))
    for (x, y), h in zip(path, headings, strict=True):
        assert h is not None
        walls = area.walls_beyond(x, y, 5.0)
        hx, hy = unit(h)
        dots = [hx * wx + hy * wy for wx, wy in walls]
        if reference == "oparea_axis" or len(walls) == 1:
            assert all(d < 0 for d in dots), (x, y, h, walls)
        elif walls:  # a corner, oblique legs: back in across the corner
            assert sum(dots) < 0, (x, y, h, walls)


# ---- closed loop: a kinematic vehicle, coverage after N wall bounces -----------------------

TRO_AREA = OpArea(-127.0, 127.0, -56.0, 56.0)  # TRO MSN007's OpArea, 254 x 112 m
BOUNCES = 20


def fly(
    cls: type[PlanBehaviour],
    area: OpArea,
    flow_of: object,
    start: tuple[float, float],
    *,
    bounces: int = BOUNCES,
    reference: str = "oparea_axis",
) -> tuple[np.ndarray, float]:
    """Fly find-plume alone with an instant-turning vehicle at 1.5 m/s, 1 s cycle.

    Returns the path and how far it ever went outside the OpArea. A bounce is a change of
    heading near a wall (within the 5 m margin or beyond); ``flow_of(n)`` is the flow after n
    bounces.
    """
    params = cls.Params(reference=reference)  # type: ignore[call-arg]
    node = cls(params, namespace=fresh_namespace())
    harness = TreeHarness(node, make_context(area, speed_mps=1.5))
    script = ScriptedPerception(area, flow=flow_of(0), flow_window_s=1.0)  # type: ignore[operator]
    vehicle = FakeVehicle(*start)
    path = [start]
    n, last, outside, t = 0, None, 0.0, 0.0
    while n < bounces and t < 20_000:
        tk = harness.tick(script.step(t, vehicle.x, vehicle.y, flow=flow_of(n)))  # type: ignore[operator]
        assert tk.command is not None
        h = tk.command.heading_deg
        if last is not None and h != last and area.walls_beyond(vehicle.x, vehicle.y, 5.0):
            n += 1
        last = h
        vehicle.apply(tk.command, 1.0)
        outside = max(outside, area.distance_outside(vehicle.x, vehicle.y))
        path.append((vehicle.x, vehicle.y))
        t += 1.0
    return np.array(path), outside


def coverage(area: OpArea, path: np.ndarray, radius_m: float = 20.0, cell_m: float = 4.0) -> float:
    """Fraction of the OpArea within ``radius_m`` of the path (sampled every 1.5 m)."""
    xs = np.arange(area.xmin + cell_m / 2, area.xmax, cell_m)
    ys = np.arange(area.ymin + cell_m / 2, area.ymax, cell_m)
    grid = np.stack(np.meshgrid(xs, ys), axis=-1).reshape(-1, 2)
    covered = np.zeros(len(grid), dtype=bool)
    for chunk in np.array_split(path, max(1, len(path) // 256)):
        d2 = ((grid[:, None, :] - chunk[None, :, :]) ** 2).sum(-1)
        covered |= (d2 <= radius_m**2).any(axis=1)
    return float(covered.mean())


STARTS = [(0.8, 0.3), (0.25, 0.6)]


def starts(area: OpArea) -> list[tuple[float, float]]:
    w, h = area.xmax - area.xmin, area.ymax - area.ymin
    return [(area.xmin + fx * w, area.ymin + fy * h) for fx, fy in STARTS]


_baseline: dict[tuple[str, str], float] = {}


def along_x(cls: type[PlanBehaviour], area_name: str, area: OpArea) -> float:
    """Mean coverage with the flow along +x (computed once per variant and OpArea)."""
    key = (cls.__name__, area_name)
    if key not in _baseline:
        _baseline[key] = float(np.mean([
            coverage(area, fly(cls, area, lambda n: flow_at(0), s)[0]) for s in starts(area)
        ]))
    return _baseline[key]


TURNING = "0 then 90 after 10 bounces"


def flows_for(angle: float | str) -> object:
    if angle == TURNING:
        return lambda n: flow_at(0 if n < BOUNCES // 2 else 90)
    return lambda n: flow_at(float(angle))


@pytest.mark.parametrize("cls", [BilliardFindPlume, AppendixBilliardFindPlume])
@pytest.mark.parametrize(
    ("area_name", "area"), [("100m", square_area(100)), ("50m", square_area(50))]
)
@pytest.mark.parametrize("angle", [45, 90, 135, 180, 270, TURNING])
def test_coverage_after_n_bounces_is_that_of_the_along_x_case(
    cls: type[PlanBehaviour], area_name: str, area: OpArea, angle: float | str
) -> None:
    reference = along_x(cls, area_name, area)
    for start in starts(area):
        path, outside = fly(cls, area, flows_for(angle), start)
        got = coverage(area, path)
        assert got >= 0.9 * reference, (angle, start, got, reference)
        assert outside == 0.0  # turns within the wall margin; this vehicle turns at once


@pytest.mark.parametrize("cls", [BilliardFindPlume, AppendixBilliardFindPlume])
@pytest.mark.parametrize("angle", [45, 135, 180, TURNING])
def test_coverage_in_tro_oparea_when_the_flow_faces_its_short_walls(
    cls: type[PlanBehaviour], angle: float | str
) -> None:
    reference = along_x(cls, "tro", TRO_AREA)
    for start in starts(TRO_AREA):
        path, outside = fly(cls, TRO_AREA, flows_for(angle), start)
        assert coverage(TRO_AREA, path) >= 0.9 * reference, (angle, start)
        assert outside == 0.0


@pytest.mark.parametrize("cls", [BilliardFindPlume, AppendixBilliardFindPlume])
@pytest.mark.parametrize(("angle", "turn"), [(90, -1), (270, 1)])
def test_flow_across_tro_oparea_sweeps_as_the_papers_pattern_turned(
    cls: type[PlanBehaviour], angle: float, turn: int
) -> None:
    # Flow along ±y in a 254 x 112 m area is the papers' flow-along-x case in the same area
    # turned 90°: the path, turned back, is the one flown in a 112 x 254 m area with the flow
    # along +x from the turned start, and sweeps the same share. (This is slower per bounce
    # than along x in the 254 x 112 area: the legs run end to end; the benchmark shows both
    # saturate within the time limit.)
    turned = OpArea(-56.0, 56.0, -127.0, 127.0)
    for x, y in starts(TRO_AREA):
        path, _ = fly(cls, TRO_AREA, lambda n: flow_at(angle), (x, y))
        start = (-turn * y, turn * x)  # (x, y) turned by -90° (turn -1) or +90° (turn +1)
        ref, _ = fly(cls, turned, lambda n: flow_at(0), start)
        np.testing.assert_allclose(
            np.column_stack([-turn * path[:, 1], turn * path[:, 0]]), ref, atol=1e-6
        )
        assert coverage(turned, ref) > 0.7


def test_legs_off_an_oblique_flow_lock_into_a_loop() -> None:
    # Why reference: flow is not the default (module docstring): flow 60° in TRO's OpArea.
    area = TRO_AREA
    start = starts(area)[1]
    loop, _ = fly(BilliardFindPlume, area, lambda n: flow_at(60), start, bounces=40,
                  reference="flow")
    axis, _ = fly(BilliardFindPlume, area, lambda n: flow_at(60), start, bounces=40)
    assert coverage(area, loop) < 0.8 < 0.9 < coverage(area, axis)


def test_coverage_helper_counts_the_swept_band() -> None:
    # A straight pass along the middle of a 100 x 100 m area sweeps a 40 m band: 40%.
    area = square_area(100)
    path = np.array([(x, 0.0) for x in np.arange(-30.0, 131.0, 1.5)])
    assert coverage(area, path, cell_m=1.0) == pytest.approx(0.4, abs=0.02)
    assert math.isclose(coverage(area, np.array([(500.0, 500.0)])), 0.0)
