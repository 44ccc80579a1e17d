"""Find-plume billiards (SPEC §4), tick by tick.

OpArea of every test: ``square_area(100)`` = x in [0, 100], y in [-50, 50], centre (50, 0).
Flow (1, 0) has flow_dir 0° (up-flow x wall = xmin); flow (-1, 0) has flow_dir 180° (up-flow x
wall = xmax). Expected headings are worked out by hand in the comments.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

import pytest
from py_trees.common import Status

from cptbt.behaviours.find_plume import (
    BEHAVIOURS,
    AppendixBilliardFindPlume,
    BilliardFindPlume,
)
from cptbt.node import PlanBehaviour
from cptbt.registry import BehaviourSpec
from cptbt.testing import (
    ScriptedPerception,
    TreeHarness,
    check_behaviour,
    fresh_namespace,
    run_script,
    square_area,
)
from cptbt.types import Percept

PLUS_X = (1.0, 0.0)
MINUS_X = (-1.0, 0.0)


def percepts(
    path: Sequence[tuple[float, float]], flow: tuple[float, float], hit_at: tuple[int, ...] = ()
) -> list[Percept]:
    """One percept per point of ``path``, one second apart; a detection at ``hit_at`` ticks."""
    script = ScriptedPerception(square_area(100), flow=flow, lambda_s=1.0)
    return [
        script.step(float(i), x, y, conc=0.5 if i in hit_at else 0.0)
        for i, (x, y) in enumerate(path)
    ]


def headings(node: PlanBehaviour, ps: list[Percept]) -> list[float | None]:
    ticks = run_script(node, ps)
    for tk in ticks:
        assert tk.status == Status.RUNNING
    return [tk.command.heading_deg if tk.command else None for tk in ticks]


def headings_of(harness: TreeHarness, ps: list[Percept]) -> list[float | None]:
    ticks = [harness.tick(p) for p in ps]
    return [tk.command.heading_deg if tk.command else None for tk in ticks]


def billiard() -> BilliardFindPlume:
    return BilliardFindPlume(namespace=fresh_namespace())


def appendix() -> AppendixBilliardFindPlume:
    return AppendixBilliardFindPlume(namespace=fresh_namespace())


# Start in each quadrant: the larger y side sets the sign, the larger x side the offset.
# flow +x (F = 0): down-flow side = xmax - x.
#   (20, -30): down 80 > up 20 -> dtheta_down 60; +y side -> sin > 0 -> 0 + 60 = 60
#   (20, 30): down 80 -> 60; -y side -> -60
#   (80, -30): down 20 < up 80 -> dtheta_up 125; +y -> 125
#   (80, 30): 125; -y -> -125
# flow -x (F = 180): down-flow side = x - xmin.
#   (20, -30): down 20 < up 80 -> 125; +y -> 180 - 125 = 55 (sin 55 > 0; 180 + 125 = -55 is -y)
#   (20, 30): 125; -y -> -55
#   (80, -30): down 80 -> 60; +y -> 180 - 60 = 120
#   (80, 30): 60; -y -> -120
@pytest.mark.parametrize(
    ("flow", "start", "heading"),
    [
        (PLUS_X, (20, -30), 60.0),
        (PLUS_X, (20, 30), -60.0),
        (PLUS_X, (80, -30), 125.0),
        (PLUS_X, (80, 30), -125.0),
        (MINUS_X, (20, -30), 55.0),
        (MINUS_X, (20, 30), -55.0),
        (MINUS_X, (80, -30), 120.0),
        (MINUS_X, (80, 30), -120.0),
    ],
)
def test_billiard_starts_into_the_largest_sub_area(
    flow: tuple[float, float], start: tuple[float, float], heading: float
) -> None:
    assert headings(billiard(), percepts([start, start], flow)) == pytest.approx([heading] * 2)


def test_billiard_reflects_off_each_wall_with_flow_toward_plus_x() -> None:
    path = [
        (20, -30),  # start: 60 (see above)
        (40, 51),  # beyond ymax: eta < 0 -> -y; dtheta stays 60 -> -60
        (41, 52),  # still beyond: one excursion, one reflection -> -60
        (60, 40),  # back inside -> -60
        (101, 20),  # beyond xmax, the down-flow wall -> dtheta_up 125, still -y -> -125
        (102, 10),  # still beyond -> -125
        (70, -51),  # beyond ymin -> +y; dtheta stays 125 -> 125
        (-1, 0),  # beyond xmin, the up-flow wall -> dtheta_down 60, still +y -> 60
    ]
    want = [60, -60, -60, -60, -125, -125, 125, 60]
    assert headings(billiard(), percepts(path, PLUS_X)) == pytest.approx(want)


def test_billiard_reflects_off_each_wall_with_flow_toward_minus_x() -> None:
    path = [
        (80, -30),  # start: 120 (see above)
        (70, 51),  # beyond ymax -> -y, dtheta 60 -> 180 + 60 = -120
        (-1, 20),  # beyond xmin, now the DOWN-flow wall -> dtheta_up 125 -> -y: 180 + 125 = -55
        (30, -51),  # beyond ymin -> +y -> 180 - 125 = 55
        (101, 0),  # beyond xmax, now the UP-flow wall -> dtheta_down 60 -> +y: 180 - 60 = 120
        (50, 0),  # inside -> 120
    ]
    want = [120, -120, -55, 55, 120, 120]
    assert headings(billiard(), percepts(path, MINUS_X)) == pytest.approx(want)


def test_appendix_billiard_reflects_off_each_wall() -> None:
    # flow +x, psi_w = 0. theta_0 = 70 * sign(0 - (-30)) = +70.
    path = [
        (20, -30),  # 70
        (40, 51),  # y wall: theta = -70
        (101, 20),  # down-flow x wall: 110 * sign(-70) = -110
        (102, 20),  # still beyond: -110
        (70, -51),  # y wall: +110
        (-1, 0),  # up-flow x wall: 70 * sign(110) = 70
    ]
    want = [70, -70, -110, -110, 110, 70]
    assert headings(appendix(), percepts(path, PLUS_X)) == pytest.approx(want)


def test_appendix_billiard_with_flow_toward_minus_x() -> None:
    # psi_w = 180; the offset's sign heads for the +y side (reading chosen): 180 - 70 = 110.
    path = [
        (80, -30),  # 110 (the start offset is 70 whatever the x position)
        (-1, 0),  # xmin is the down-flow wall: |theta| 110, +y side -> 180 - 110 = 70
        (50, 51),  # y wall: -y side -> 180 + 110 = -70
        (101, 0),  # xmax is the up-flow wall: |theta| 70, -y -> 180 + 70 = -110
    ]
    want = [110, 70, -70, -110]
    assert headings(appendix(), percepts(path, MINUS_X)) == pytest.approx(want)


@pytest.mark.parametrize(
    ("restart", "want"),
    [
        # initial (the appendix's letter): every restart is theta_0 = 70 toward the larger y
        # side: at (80, 30) the -y side -> -70; at (30, -30) the +y side -> +70.
        ("initial", [70, -70, -70, -70, 70, 70]),
        # largest_area: the first start is still theta_0 (70); a restart after a contact heads
        # into the larger along-flow part: at (80, 30) up-flow (80 m > 20 m) -> 110 on the -y
        # side = -110; at (30, -30) down-flow (70 m > 30 m) -> 70 on the +y side = +70.
        ("largest_area", [70, -110, -110, -110, 70, 70]),
    ],
)
def test_appendix_billiard_restart_after_a_contact(restart: str, want: list[float]) -> None:
    params = AppendixBilliardFindPlume.Params(restart=restart)
    node = AppendixBilliardFindPlume(params, namespace=fresh_namespace())
    harness = TreeHarness(node)
    # Contacts at ticks 1 and 4 (lost at tick 3, λ = 1 s): each restarts find-plume.
    ps = percepts([(80, -30), (80, 30), (80, 30), (80, 30), (30, -30), (30, -30)], PLUS_X,
                  hit_at=(1, 4))
    assert headings_of(harness, ps) == pytest.approx(want)


@pytest.mark.parametrize(
    ("cls", "heading"), [(BilliardFindPlume, 60.0), (AppendixBilliardFindPlume, 70.0)]
)
def test_no_output_until_the_field_is_reached(cls: type[BilliardFindPlume], heading: float) -> None:
    node = cls(namespace=fresh_namespace())
    harness = TreeHarness(node, field_reached=False)
    ps = percepts([(20, -30)] * 3, PLUS_X)
    assert [harness.tick(p).status for p in ps[:2]] == [Status.FAILURE] * 2
    harness.set("field_reached", True)
    tk = harness.tick(ps[2])
    assert tk.status == Status.RUNNING
    assert tk.command is not None and tk.command.heading_deg == pytest.approx(heading)


def test_no_output_without_a_flow_estimate() -> None:
    p = dataclasses.replace(percepts([(20, -30)], PLUS_X)[0], flow=None)
    [tk] = run_script(billiard(), [p])
    assert tk.status == Status.FAILURE and tk.command is None


def test_pre_emption_keeps_the_bounce_but_a_plume_contact_restarts() -> None:
    node = billiard()
    harness = TreeHarness(node)
    ps = percepts(
        [(20, -30), (40, 51), (60, 20), (60, 20), (80, 30), (80, 30)], PLUS_X, hit_at=(4,)
    )
    assert headings_of(harness, ps[:2]) == pytest.approx([60, -60])
    node.stop(Status.INVALID)  # safety took over for a while
    # Restarting at (60, 20) would pick dtheta_up, -y = -125; the kept bounce state says -60.
    assert headings_of(harness, ps[2:4]) == pytest.approx([-60, -60])
    # A detection starts a new contact: find-plume restarts from (80, 30): dtheta_up, -y.
    assert headings_of(harness, ps[4:]) == pytest.approx([-125, -125])


@pytest.mark.parametrize("spec", BEHAVIOURS, ids=lambda s: s.key)
def test_conformance(spec: BehaviourSpec) -> None:
    check_behaviour(spec)
