"""Maintain-plume (SPEC §5), tick by tick; expected headings derived by hand in the comments.

Angles: 0° = +x, 90° = +y. Flow (1, 0): flow_dir 0°, upflow 180°. Flow (0, 1): flow_dir 90°,
upflow -90°.
"""

from __future__ import annotations

import pytest
from py_trees.common import Status

from cptbt.behaviours.maintain_plume import (
    BEHAVIOURS,
    CounterTurnParams,
    CounterTurnTrack,
    TrackParams,
)
from cptbt.registry import BehaviourSpec
from cptbt.testing import ScriptedPerception, TreeHarness, check_behaviour, fresh_namespace
from cptbt.types import Percept

TRACK_IN_OUT = BEHAVIOURS[0]
HIT = 0.5


def track_in_out(params: TrackParams | None = None) -> TreeHarness:
    return TreeHarness(TRACK_IN_OUT.build(params or TrackParams(), fresh_namespace()))


def heading(harness: TreeHarness, p: Percept) -> float | None:
    tk = harness.tick(p)
    assert (tk.status == Status.RUNNING) == (tk.command is not None)
    return tk.command.heading_deg if tk.command else None


@pytest.mark.parametrize(
    ("flow", "upflow"), [((1.0, 0.0), 180.0), ((0.0, 1.0), -90.0), ((-1.0, 0.0), 0.0)]
)
def test_track_in_heads_upflow_while_detecting(flow: tuple[float, float], upflow: float) -> None:
    h = track_in_out()
    script = ScriptedPerception(flow=flow)
    tk = h.tick(script.step(0.0, 50, 0, conc=HIT))
    assert tk.status == Status.RUNNING and tk.active == "maintain_plume.track_in"
    assert tk.command is not None and tk.command.heading_deg == pytest.approx(upflow)


# Last detection at (50, 0). beta = 10*sign(wrap(flow_dir - phi)), phi = bearing vehicle -> last.
# flow +x (flow_dir 0):
#   vehicle (45, 5): phi = atan2(-5, 5) = -45, dphi = 45 -> beta +10 -> 190 = -170 (turns to -y)
#   vehicle (45, -5): phi = 45, dphi = -45 -> beta -10 -> 170 (turns to +y)
# flow +y (flow_dir 90):
#   vehicle (55, -5): phi = atan2(5, -5) = 135, dphi = -45 -> -10 -> 260 = -100 (turns to -x)
#   vehicle (45, -5): phi = atan2(5, 5) = 45, dphi = 45 -> +10 -> 280 = -80 (turns to +x)
@pytest.mark.parametrize(
    ("flow", "where", "want", "beta_sign"),
    [
        ((1.0, 0.0), (45, 5), -170.0, 1),
        ((1.0, 0.0), (45, -5), 170.0, -1),
        ((0.0, 1.0), (55, -5), -100.0, -1),
        ((0.0, 1.0), (45, -5), -80.0, 1),
    ],
)
def test_track_out_bends_toward_the_side_of_the_last_detection(
    flow: tuple[float, float], where: tuple[float, float], want: float, beta_sign: int
) -> None:
    h = track_in_out()
    script = ScriptedPerception(flow=flow)
    h.tick(script.step(0.0, 50, 0, conc=HIT))
    tk = h.tick(script.step(1.0, *where))
    assert tk.status == Status.RUNNING and tk.active == "maintain_plume.track_out"
    assert tk.command is not None and tk.command.heading_deg == pytest.approx(want)
    assert h.get("beta_sign") == beta_sign


def test_track_out_ends_when_lambda_expires() -> None:
    # lambda = 8.5 s: a detection at t = 0 keeps the vehicle "in the plume" up to t = 8.5.
    h = track_in_out()
    script = ScriptedPerception(flow=(1.0, 0.0), lambda_s=8.5)
    got = [
        heading(h, script.step(0.0, 50, 0, conc=HIT)),  # track-in: 180
        heading(h, script.step(4.0, 46, 5)),  # phi = atan2(-5, 4) < 0 -> dphi > 0 -> -170
        heading(h, script.step(8.5, 42, 5)),  # still within lambda -> -170
        heading(h, script.step(9.0, 41, 5)),  # lambda passed: no output
    ]
    assert got == pytest.approx([180.0, -170.0, -170.0, None])


def test_track_in_out_has_no_output_before_any_detection() -> None:
    h = track_in_out()
    script = ScriptedPerception(flow=(1.0, 0.0))
    assert heading(h, script.step(0.0, 50, 0)) is None


def counter_turn() -> TreeHarness:
    return TreeHarness(CounterTurnTrack(CounterTurnParams(), namespace=fresh_namespace()))


def test_counter_turn_holds_then_reverses_then_gives_up() -> None:
    # L = 8.5 s, B = 10°, T_w = 17 s; flow +x, upflow 180.
    h = counter_turn()
    script = ScriptedPerception(flow=(1.0, 0.0), lambda_s=17.0)
    # At the detection the vehicle heads 170° (moving +y): s = sign(wrap(170 - 180)) = -1.
    steps = [
        (0.0, 170.0, HIT, 170.0),  # 180 - 10: keep crossing toward +y
        (8.0, 170.0, 0.0, 170.0),  # within L of the detection: hold
        (8.5, 170.0, 0.0, -170.0),  # L without detection: reverse, 180 + 10 = 190 = -170
        (16.5, -170.0, 0.0, -170.0),
        (17.5, -170.0, 0.0, None),  # T_w passed: reacquire takes over
    ]
    got = [heading(h, script.step(t, 50, 0, psi, conc=c)) for t, psi, c, _ in steps]
    assert got == pytest.approx([want for *_, want in steps])


def test_counter_turn_keeps_crossing_the_way_it_entered() -> None:
    h = counter_turn()
    script = ScriptedPerception(flow=(1.0, 0.0), lambda_s=17.0)
    steps = [
        # psi = -150 (moving -y): wrap(-150 - 180) = 30 -> s = +1 -> 190 = -170
        (0.0, -150.0, HIT, -170.0),
        (9.0, -170.0, 0.0, 170.0),  # reversed after L: 180 - 10
        # Detected again while heading 170 (the reversal): wrap(170 - 180) = -10 -> s = -1: 170
        (10.0, 170.0, HIT, 170.0),
        (18.0, 170.0, 0.0, 170.0),  # 8 s since the last detection: hold
        (19.0, 170.0, 0.0, -170.0),  # 9 s: reverse
    ]
    got = [heading(h, script.step(t, 50, 0, psi, conc=c)) for t, psi, c, _ in steps]
    assert got == pytest.approx([want for *_, want in steps])
    assert h.get("beta_sign") == 1


def test_counter_turn_keeps_its_sign_across_pre_emption() -> None:
    h = counter_turn()
    script = ScriptedPerception(flow=(1.0, 0.0), lambda_s=17.0)
    assert heading(h, script.step(0.0, 50, 0, -150.0, conc=HIT)) == pytest.approx(-170.0)
    h.root.stop(Status.INVALID)
    # Heading 170 now would give s = -1 if the sign were re-taken; it belongs to the detection.
    assert heading(h, script.step(2.0, 48, 0, 170.0)) == pytest.approx(-170.0)


@pytest.mark.parametrize("spec", BEHAVIOURS, ids=lambda s: s.key)
def test_conformance(spec: BehaviourSpec) -> None:
    check_behaviour(spec)


def test_no_variant_declares_the_contact_timeout_twice() -> None:
    # λ is the perception's (the mission's perception.lambda_s), declared once, not per variant.
    assert not any("lambda_s" in spec.params.model_fields for spec in BEHAVIOURS)
