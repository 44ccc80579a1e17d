"""The up-flow check alone (:class:`cptbt.behaviours.upflow_check.UpflowCheck`), cycle by cycle.

The flow goes toward +x, so up-flow is −x; the candidate sits at (50, 0) in a 100 × 100 m area.
"""

from __future__ import annotations

import dataclasses
import math

import pytest

from cptbt.behaviours.upflow_check import UpflowCheck
from cptbt.frames import room
from cptbt.testing import ScriptedPerception, square_area
from cptbt.types import Percept, Point

AREA = square_area(100.0)  # x 0..100, y -50..50
CAND = Point(50.0, 0.0)


def check(**kw: float | None) -> UpflowCheck:
    args: dict[str, float | None] = {"reach_m": 10.0, "band_m": 5.0, "veto_beyond_m": 10.0,
                                     "slack_m": 3.0, "memory_s": None, "timeout_s": 120.0}
    return UpflowCheck(**{**args, **kw})  # type: ignore[arg-type]


def at(script: ScriptedPerception, t: float, x: float = 70.0, y: float = 0.0,
       flow: tuple[float, float] = (0.2, 0.0)) -> Percept:
    return script.step(t, x, y, flow=flow)


def test_the_wall_is_found_along_any_direction() -> None:
    assert room(AREA, Point(50, 0), -1.0, 0.0) == 50.0
    assert room(AREA, Point(50, 0), 0.0, 1.0) == 50.0
    assert room(AREA, Point(90, 40), 0.6, 0.8) == 12.5


def test_a_crossing_on_both_sides_between_one_and_two_reaches_up_flow_passes() -> None:
    c, s = check(), ScriptedPerception(AREA)
    assert not c.passed(at(s, 0), CAND, AREA) and c.legs == 1
    assert c.target is not None and c.target.x == 40.0 and abs(c.target.y) == 5.0
    c.record(1, Point(38, 4), hit=False)  # one side, 12 m up-flow
    assert not c.passed(at(s, 1), CAND, AREA)
    assert c.target is not None and c.target.y == -5.0  # now the other side
    c.record(2, Point(25, -4), hit=False)  # 25 m up-flow: beyond the reach, no count
    assert not c.passed(at(s, 2), CAND, AREA)
    c.record(3, Point(38, -4), hit=False)  # the other side, but the line between not flown
    assert not c.passed(at(s, 3), CAND, AREA)
    assert c.target == Point(40.0, 0.0)  # over the line, 10 m up-flow
    c.record(4, Point(39, 1), hit=False)
    assert c.passed(at(s, 4), CAND, AREA) and c.target is None
    assert c.report() == {"upflow_checks": 1, "unchecked": 0, "upflow_vetoes": 0,
                          "trace_vetoes": 0, "visits": 0, "visits_ended": 0}


def test_both_sides_seen_apart_are_no_crossing_until_the_line_is_flown() -> None:
    """Two-source study, root seed 2028, replicate 113: a lane 15-30 m to one side of the
    candidate's line and, 90 s later, a loop 5-18 m to the other had each reached a side; the
    water straight up-flow, where the source lay, was never flown, and the candidate (17 m
    down-flow of it) was declared."""
    c, s = check(), ScriptedPerception(AREA)
    for t, (x, y) in enumerate(((36, 20), (38, 16), (40, 12))):  # one side, 10-14 m up-flow
        c.record(t, Point(x, y), hit=False)
    for t, (x, y) in enumerate(((48, 12), (52, 4), (55, -4), (48, -8)), start=3):  # round,
        c.record(t, Point(x, y), hit=False)  # over the line 2 m down-flow: short of the window
    for t, (x, y) in enumerate(((39, -6), (38, -10), (37, -14)), start=7):  # the other side
        c.record(t, Point(x, y), hit=False)
    assert not c.passed(at(s, 10), CAND, AREA)
    assert c.target == Point(40.0, 0.0) and c.kind == "check leg"
    for t, (x, y) in enumerate(((45, -4), (43, -4)), start=11):  # along, beside the line
        c.record(t, Point(x, y), hit=False)
    assert not c.passed(at(s, 13), CAND, AREA)
    c.record(14, Point(37, 4), hit=False)  # from (43, -4): over the line, 7-13 m up-flow
    assert c.passed(at(s, 14), CAND, AREA) and c.target is None and c.legs == 1


def test_a_crossing_beyond_the_reach_rules_out_only_sources_beyond_it() -> None:
    """Two-source study, root seed 2029, replicate 37: a sweep lane crossed 23 m up-flow of
    the candidate, past its source (20 m up-flow), and saw nothing; counted as the check, it
    let the candidate be declared 20 m short. A crossing counts within ``slack_m`` of the
    reach (7-13 m here) only."""
    c, s = check(), ScriptedPerception(AREA)
    for t, y in enumerate(range(12, -13, -2)):  # a lane over the line, 18 m up-flow
        c.record(t, Point(32, y), hit=False)
    assert not c.passed(at(s, 13), CAND, AREA)
    assert c.target is not None and c.target.x == 40.0  # the leg: 10 m up-flow
    for t, y in enumerate(range(-12, 13, 2), start=14):  # the leg, 11 m up-flow
        c.record(t, Point(39, y), hit=False)
    assert c.passed(at(s, 27), CAND, AREA) and c.legs == 1
    wide = check(window_m=23.0)  # the rule before (twice the reach plus slack): it counts
    for t, y in enumerate(range(12, -13, -2)):
        wide.record(t, Point(32, y), hit=False)
    assert wide.passed(at(s, 13), CAND, AREA) and wide.legs == 0


def test_two_crossings_must_be_passes_apart_and_the_leg_goes_back_over_the_line() -> None:
    """With ``crossings=2`` (several sources) one lane over the line is not enough, however
    long it dwells there: the leg turns back to the line's point, and a pass more than
    :attr:`UpflowCheck.CROSSING_GAP_S` later is the second crossing."""
    c, s = check(crossings=2), ScriptedPerception(AREA)
    for t, y in enumerate(range(-8, 9, 2)):  # a lane over the line, 10 m up-flow
        c.record(t, Point(40, y), hit=False)
    for t in range(9, 9 + 12):  # lingering beside the line: the same pass
        c.record(t, Point(41, 1.0 if t % 2 else -1.0), hit=False)
    assert not c.passed(at(s, 21), CAND, AREA)
    assert c.target == Point(40.0, 0.0) and c.kind == "check leg" and c.legs == 1
    for t, y in enumerate(range(8, -9, -2), start=21 + int(UpflowCheck.CROSSING_GAP_S)):
        c.record(t, Point(39, y), hit=False)  # back over the line, a pass of its own
    assert c.passed(at(s, 50), CAND, AREA) and c.target is None and c.legs == 1
    one = check()  # one crossing (a single source): the first lane passes
    for t, y in enumerate(range(-8, 9, 2)):
        one.record(t, Point(40, y), hit=False)
    assert one.passed(at(s, 9), CAND, AREA)


def test_the_gap_between_passes_is_a_setting_the_mission_reaches() -> None:
    """``upflow_crossing_gap_s`` (session 20's measurement): with 40 s, passes 25 s apart are
    one crossing; the setting travels from the mission's parameters to the check."""
    from cptbt.behaviours.likelihood import LikelihoodMapDeclare

    c, s = check(crossings=2, crossing_gap_s=40.0), ScriptedPerception(AREA)
    for t, y in enumerate(range(-8, 9, 2)):
        c.record(t, Point(40, y), hit=False)
    for t, y in enumerate(range(8, -9, -2), start=33):  # 25 s after the first pass ended
        c.record(t, Point(39, y), hit=False)
    assert not c.passed(at(s, 42), CAND, AREA)
    for t, y in enumerate(range(-8, 9, 2), start=90):
        c.record(t, Point(40, y), hit=False)
    assert c.passed(at(s, 99), CAND, AREA)
    from cptbt.behaviours.likelihood_params import LikelihoodMapParams
    from cptbt.testing import fresh_namespace

    params = LikelihoodMapParams(max_sources=2, upflow_crossing_gap_s=40.0)
    node = LikelihoodMapDeclare(params, namespace=fresh_namespace())
    assert node.upflow.crossing_gap_s == 40.0 and node.upflow.crossings == 2


def test_a_one_cycle_dip_of_confidence_is_not_a_new_leg_and_keeps_the_clock() -> None:
    c, s = check(timeout_s=30.0), ScriptedPerception(AREA)
    for t in range(0, 32, 2):  # the candidate drifting a little, as a map's mean does
        assert c.passed(at(s, t), Point(50.0 + 0.1 * t, 0.0), AREA) == (t >= 30)
        c.drop()  # the map unsure for a cycle between each test
    assert c.legs == 1 and c.unchecked == 1  # one leg, timed out at 30 s


def test_a_candidate_elsewhere_is_a_new_leg() -> None:
    c, s = check(), ScriptedPerception(AREA)
    c.passed(at(s, 0), CAND, AREA)
    c.passed(at(s, 1), Point(20.0, 30.0), AREA)
    assert c.legs == 2


def test_plume_up_flow_vetoes_counting_candidates_not_detections() -> None:
    c, s = check(), ScriptedPerception(AREA)
    for t, x in enumerate((35.0, 33.0, 31.0)):  # three detections 15-19 m up-flow, on the line
        c.record(t, Point(x, 1.0), hit=True)
        assert not c.passed(at(s, t), CAND, AREA) and c.target is None
    assert c.vetoes == 1
    c.drop()
    c.record(3, Point(30.0, 0.0), hit=True)
    assert not c.passed(at(s, 3), CAND, AREA) and c.vetoes == 2  # a new episode
    # a crossing does not lift a veto: the detections are still remembered (no memory set)
    for t, y in ((4, 4.0), (5, -4.0)):
        c.record(t, Point(38.0, y), hit=False)
    assert not c.passed(at(s, 6), CAND, AREA) and c.vetoes == 2


def test_the_veto_reaches_three_reaches_up_flow_and_is_forgotten_after_its_memory() -> None:
    far, s = check(), ScriptedPerception(AREA)
    far.record(0, Point(15.0, 0.0), hit=True)  # 35 m up-flow: beyond 3 × 10 m
    for t, y in ((1, 4.0), (2, -4.0)):
        far.record(t, Point(38.0, y), hit=False)
    assert far.passed(at(s, 3), CAND, AREA) and far.vetoes == 0
    short = check(memory_s=5.0)
    short.record(0, Point(30.0, 0.0), hit=True)
    assert not short.passed(at(s, 1), CAND, AREA)
    for t, y in ((7, 4.0), (8, -4.0)):
        short.record(t, Point(38.0, y), hit=False)
    assert short.passed(at(s, 9), CAND, AREA)  # 9 s old: forgotten


def test_the_veto_can_begin_nearer_than_the_declaration_radius() -> None:
    """Plume 7 m up-flow of the candidate: inside the 10-m radius it is the candidate's own
    plume by default; with ``veto_near_m`` 5 it says the source is farther up-flow."""
    for near, vetoed in ((None, False), (5.0, True)):
        c, s = check(veto_near_m=near), ScriptedPerception(AREA)
        c.record(0, Point(43.0, 1.0), hit=True)  # 7 m up-flow, 1 m off the line
        for t, y in ((1, 4.0), (2, -4.0)):  # the crossing, 12 m up-flow
            c.record(t, Point(38.0, y), hit=False)
        assert c.passed(at(s, 3), CAND, AREA) is not vetoed
        assert c.vetoes == int(vetoed)
        c2 = check(veto_near_m=near)
        c2.record(0, Point(46.0, 0.0), hit=True)  # 4 m up-flow: never a veto
        for t, y in ((1, 4.0), (2, -4.0)):
            c2.record(t, Point(38.0, y), hit=False)
        assert c2.passed(at(s, 3), CAND, AREA) and c2.vetoes == 0


def test_a_new_search_starts_from_a_clean_track() -> None:
    c, s = check(), ScriptedPerception(AREA)
    c.record(0, Point(30.0, 0.0), hit=True)  # the previous source's plume
    for t, y in ((1, 4.0), (2, -4.0)):
        c.record(t, Point(38.0, y), hit=False)
    c.restart(5.0)
    assert not c.passed(at(s, 6), CAND, AREA) and c.vetoes == 0  # no veto, but no crossing
    assert c.target is not None


def test_without_a_flow_direction_the_candidate_passes_unchecked_and_is_counted() -> None:
    c, s = check(), ScriptedPerception(AREA)
    assert c.passed(at(s, 0, flow=(0.0, 0.0)), CAND, AREA)
    assert c.unchecked == 1 and c.target is None


def test_a_fan_widens_the_crossing_and_the_veto_band_up_flow() -> None:
    # tan 30° ≈ 0.577: 10 m up-flow the band reaches 5 + 5.8 m to either side, 15 m up-flow
    # 5 + 8.7 m.
    s = ScriptedPerception(AREA)
    narrow, wide = check(), check(fan_deg=30.0)
    for c in (narrow, wide):
        for t, y in ((0, 4.0), (1, -4.0)):  # a crossing 12 m up-flow reaching 4 m each side
            c.record(t, Point(38.0, y), hit=False)
    assert narrow.passed(at(s, 2), CAND, AREA)
    assert not wide.passed(at(s, 2), CAND, AREA)  # not wide enough for the fan
    assert wide.target is not None and wide.target.x == 40.0
    assert abs(wide.target.y) == pytest.approx(5.0 + 10.0 * math.tan(math.radians(30.0)))
    for t, y in ((3, 9.5), (4, -9.5)):  # 12 m up-flow: 5 + 12 tan 30° - 3 m slack = 8.9 m
        wide.record(t, Point(38.0, y), hit=False)
    assert wide.passed(at(s, 5), CAND, AREA)
    # plume 15 m up-flow and 10 m aside: outside the narrow band, inside the fan
    narrow, wide = check(), check(fan_deg=30.0)
    for c in (narrow, wide):
        c.record(6, Point(35.0, 10.0), hit=True)
        for t, y in ((7, 12.0), (8, -12.0)):
            c.record(t, Point(38.0, y), hit=False)
    assert narrow.passed(at(s, 9), CAND, AREA)
    assert not wide.passed(at(s, 9), CAND, AREA) and wide.vetoes == 1 and wide.target is None


def test_a_trace_up_flow_vetoes_like_a_detection_and_is_counted_as_one() -> None:
    c, s = check(trace_level=0.05), ScriptedPerception(AREA)
    for t in range(-20, 0):  # clean water reads 0: the noise floor is 0
        c.record(t, Point(80.0, 20.0 + t), hit=False, reading=0.0)
    c.record(0, Point(45.0, 0.0), hit=False, reading=0.9)  # 5 m up-flow: inside radius_m
    c.record(1, Point(36.0, 2.0), hit=False, reading=0.04)  # 14 m up-flow, below the level
    c.record(2, Point(36.0, 9.0), hit=False, reading=0.9)  # beside the band
    c.record(3, Point(70.0, 0.0), hit=False, reading=0.9)  # down-flow
    c.record(4, Point(36.0, 0.0), hit=False, reading=math.nan)  # a dropout
    assert not c.passed(at(s, 4), CAND, AREA) and c.target is not None  # no veto: a leg
    c.record(5, Point(34.0, -1.0), hit=False, reading=0.06)  # 16 m up-flow, on the line
    assert not c.passed(at(s, 5), CAND, AREA) and c.target is None
    assert (c.vetoes, c.trace_vetoes) == (1, 1)
    c.drop()
    c.record(6, Point(33.0, 0.0), hit=True, reading=0.5)  # a detection there as well
    assert not c.passed(at(s, 6), CAND, AREA)
    assert (c.vetoes, c.trace_vetoes) == (2, 1)  # a detection's veto is not a trace's


def test_without_a_trace_level_only_detections_veto() -> None:
    c, s = check(), ScriptedPerception(AREA)
    c.record(0, Point(34.0, 0.0), hit=False, reading=0.19)
    assert not c.passed(at(s, 0), CAND, AREA) and c.target is not None and c.vetoes == 0


def test_a_trace_must_stand_clear_of_the_sensors_noise_floor() -> None:
    c, s = check(trace_level=0.05), ScriptedPerception(AREA)
    for t in range(20):  # clean water reading 0.03 (noise, or an offset): floor 3 x 0.03
        c.record(t, Point(80.0, 20.0 + t), hit=False, reading=0.03)
    assert c.trace_floor() == pytest.approx(0.09)
    c.record(20, Point(34.0, 0.0), hit=False, reading=0.08)  # above the level, in the noise
    assert not c.passed(at(s, 20), CAND, AREA) and c.vetoes == 0
    c.record(21, Point(34.0, 0.0), hit=False, reading=0.1)
    assert not c.passed(at(s, 21), CAND, AREA) and c.trace_vetoes == 1


def test_readings_that_say_nothing_of_this_source_do_not_lower_the_floor() -> None:
    c, s = check(trace_level=0.05), ScriptedPerception(AREA)
    for t in range(10):  # a noisy sensor in clean water
        c.record(t, Point(80.0, 20.0 + t), hit=False, reading=0.03)
    for t in range(10, 40):  # a declared source's plume, or outside the OpArea: no reading
        c.record(t, Point(80.0, -20.0), hit=False, reading=math.nan)
    assert c.trace_floor() == pytest.approx(0.09)  # as 0 they made it 0.05 (the level)
    c.record(40, Point(34.0, 0.0), hit=False, reading=0.08)
    assert not c.passed(at(s, 40), CAND, AREA) and c.vetoes == 0


def test_a_candidate_with_no_plume_seen_near_it_is_visited_first() -> None:
    c, s = check(near_m=10.0), ScriptedPerception(AREA)
    c.record(0, Point(62.0, 0.0), hit=True)  # 12 m down-flow: not near enough
    assert not c.passed(at(s, 0), CAND, AREA)
    assert c.target == CAND and c.kind == "visit" and (c.visits, c.legs) == (1, 0)
    c.record(1, Point(55.0, 1.0), hit=False)  # on the way there: the same visit
    assert not c.passed(at(s, 1), Point(50.5, 0.0), AREA) and c.visits == 1
    c.record(2, Point(52.0, 1.0), hit=True)  # plume 2 m from it: now the crossing
    assert not c.passed(at(s, 2), CAND, AREA)
    assert c.kind == "check leg" and c.target is not None and c.target.x == 40.0
    assert c.report()["visits"] == 1 and c.legs == 1


def test_a_visit_that_cannot_get_there_ends_and_holds_the_candidate_back() -> None:
    c, s = check(near_m=10.0, timeout_s=30.0), ScriptedPerception(AREA)
    c.record(0, Point(80.0, 0.0), hit=True)
    for t in range(0, 30, 5):  # held where it is
        assert not c.passed(at(s, t), CAND, AREA) and c.kind == "visit"
    for t in (30, 60, 600):  # timed out: not declared, no target (the tree searches on)
        assert not c.passed(at(s, t), CAND, AREA) and c.target is None
    for t, y in ((601, 4.0), (602, -4.0)):  # a crossing does not make up for no plume near
        c.record(t, Point(38.0, y), hit=False)
    assert not c.passed(at(s, 603), CAND, AREA) and c.target is None
    assert (c.visits, c.visits_ended, c.unchecked, c.legs) == (1, 1, 0, 0)
    c.record(604, Point(45.0, 1.0), hit=True)  # plume seen 5 m from it: now it may go on
    assert c.passed(at(s, 605), CAND, AREA)


def test_a_held_back_candidate_that_moves_is_visited_again() -> None:
    c, s = check(near_m=10.0, timeout_s=30.0), ScriptedPerception(AREA)
    c.record(0, Point(80.0, 0.0), hit=True)
    assert not c.passed(at(s, 0), CAND, AREA) and c.kind == "visit"
    assert not c.passed(at(s, 30), CAND, AREA) and c.target is None
    assert not c.passed(at(s, 31), Point(52.0, 3.0), AREA) and c.target is None  # same one
    other = Point(30.0, 20.0)  # more than veto_beyond_m away: a new visit, a new clock
    assert not c.passed(at(s, 32), other, AREA) and c.target == other and c.kind == "visit"
    assert (c.visits, c.visits_ended) == (2, 1)


def test_plume_seen_near_before_this_sources_search_does_not_count() -> None:
    c, s = check(near_m=10.0), ScriptedPerception(AREA)
    c.record(0, Point(52.0, 0.0), hit=True)
    c.restart(1.0)  # a source declared: the next one's search begins
    assert not c.passed(at(s, 2), CAND, AREA) and c.kind == "visit"


@pytest.mark.parametrize("known_veto", [False, True])
def test_plume_a_declared_source_explains_vetoes_only_when_asked(known_veto: bool) -> None:
    """A detection up-flow of the candidate that a declared source's plume explains (``hit``
    False, ``seen`` True) says nothing of this source by default; with ``known_veto`` it vetoes
    as unexplained plume does (the check cannot tell that plume from the candidate's own)."""
    c, s = check(), ScriptedPerception(AREA)
    c.known_veto = known_veto
    c.record(0, Point(34.0, 1.0), hit=False, reading=math.nan, seen=True)  # 16 m up-flow
    for t, y in ((1, 4.0), (2, -4.0)):  # then a crossing between one and two reaches
        c.record(t, Point(38.0, y), hit=False, reading=0.0, seen=False)
    assert c.passed(at(s, 3), CAND, AREA) is not known_veto
    assert c.vetoes == int(known_veto) and c.trace_vetoes == 0
    # a miss recorded without ``seen`` is no plume either way
    c2 = check()
    c2.known_veto = True
    for t, y in ((0, 4.0), (1, -4.0)):
        c2.record(t, Point(38.0, y), hit=False)
    assert c2.passed(at(s, 4), CAND, AREA)


# -- the early leg (the map nearly sure: upflow_early_fraction) ------------------------------
def test_an_early_leg_is_flown_and_its_crossing_counts_once_the_map_is_sure() -> None:
    c, s = check(), ScriptedPerception(AREA)
    assert not c.passed(at(s, 0), CAND, AREA, early=True) and c.legs == 1
    assert c.target is not None and c.target.x == 40.0 and c.kind == "check leg"
    for t, y in ((1, 4.0), (2, -4.0)):
        c.record(t, Point(38.0, y), hit=False)
    assert c.passed(at(s, 3), CAND, AREA, early=True) and c.target is None
    assert c.passed(at(s, 4), CAND, AREA) and c.legs == 1  # sure now: nothing more to fly


def test_an_early_leg_out_of_time_passes_nothing_and_the_sure_leg_has_its_own_clock() -> None:
    c, s = check(timeout_s=30.0), ScriptedPerception(AREA)
    for t in range(0, 40, 2):  # the vehicle held where it is (a safety hold, say)
        assert not c.passed(at(s, t), CAND, AREA, early=True)
    assert c.unchecked == 0 and c.target is None, "an early leg passed its candidate unchecked"
    assert c.legs == 1  # and it is not flown early again for that candidate
    assert not c.passed(at(s, 40), CAND, AREA) and c.target is not None and c.legs == 2
    assert not c.passed(at(s, 68), CAND, AREA)  # the sure leg's clock started at 40
    assert c.passed(at(s, 70), CAND, AREA) and c.unchecked == 1


def test_an_early_leg_still_under_way_when_the_map_becomes_sure_restarts_its_clock() -> None:
    c, s = check(timeout_s=30.0), ScriptedPerception(AREA)
    assert not c.passed(at(s, 0), CAND, AREA, early=True)
    assert not c.passed(at(s, 29), CAND, AREA)  # sure at 29 s: the same leg, a fresh clock
    assert c.legs == 1 and c.target is not None
    assert not c.passed(at(s, 58), CAND, AREA)
    assert c.passed(at(s, 59), CAND, AREA) and c.unchecked == 1 and c.legs == 1


def test_an_early_test_counts_no_veto_and_keeps_the_crossings_and_needs_a_flow() -> None:
    c, s = check(), ScriptedPerception(AREA)
    c.record(0, Point(38.0, 4.0), hit=False)  # a crossing, both sides
    c.record(1, Point(38.0, -4.0), hit=False)
    c.record(2, Point(33.0, 0.0), hit=True)  # then plume 17 m up-flow
    assert not c.passed(at(s, 3), CAND, AREA, early=True) and c.target is None
    assert c.vetoes == 0 and c.veto_t == -math.inf
    assert not c.passed(at(s, 4), CAND, AREA) and c.vetoes == 1  # sure: vetoed and counted
    c2, blind = check(), dataclasses.replace(at(s, 5), flow=None)
    assert not c2.passed(blind, CAND, AREA, early=True)
    assert c2.unchecked == 0 and c2.target is None
    assert c2.passed(blind, CAND, AREA) and c2.unchecked == 1  # sure: declared, unchecked
