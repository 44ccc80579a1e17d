"""A launch outside the OpArea, heading away from it, whose turn back passes the give-back
line is warned of, and the warning's bound is the simulator's (a review's start 25 m outside
a 50-m box, heading north away from it, validated and ended at 4 s)."""

from __future__ import annotations

from pathlib import Path

import pytest

from cptbt.batch.engine import simulate
from cptbt.batch.scenario import Environment, advisories, launch_pose, to_sim_params
from cptbt.loader import loads_mission
from cptbt.mission import MissionBase
from cptbt.registry import default_registry

ROOT = Path(__file__).resolve().parents[2]


def _mission(heading: float | None, start: str = "[50, 0]") -> MissionBase:
    text = (ROOT / "missions/small_oparea.yaml").read_text(encoding="utf-8")
    text = text.replace("start: [-15, -15]", f"start: {start}\nallow_outside: [start]")
    if heading is not None:
        text = text.replace("  seed: 7", f"  seed: 7\n  launch_heading_deg: {heading}")
    return loads_mission(text, "m.yaml", default_registry(), Environment)


def _warned(mission: MissionBase) -> list[str]:
    return [msg for loc, msg in advisories(mission) if "turn back" in msg]


def test_the_default_heading_away_from_the_box_is_warned_of_with_the_way_in() -> None:
    (msg,) = _warned(_mission(None))  # 25 m north of the box, heading 0 (north)
    assert "starts 25.0 m outside the OpArea heading away from it" in msg, msg
    assert "reaches about 32.5 m outside" in msg and "about 180°" in msg, msg
    # heading across (90°) or in (180°): nothing to warn of
    assert _warned(_mission(90)) == [] and _warned(_mission(180)) == []
    # inside the box: nothing
    assert _warned(_mission(0, start="[20, 0]")) == []


@pytest.mark.parametrize(("heading", "warned"), [(20, False), (15, True), (0, True)])
def test_the_warning_says_which_runs_end_at_once(heading: float, warned: bool) -> None:
    """Flown: 20° off the outward normal turns back at ~29.9 m and flies on; 15° reaches
    ~30.6 m and the AMP gives control back within seconds (seed 7)."""
    mission = _mission(heading)
    assert bool(_warned(mission)) == warned
    (run,), _, _ = simulate(mission, to_sim_params(mission), [launch_pose(mission)],
                            time_limit_s=60.0)
    assert (str(run.outcome) == "relinquished") == warned, (run.outcome, run.t_end)


@pytest.mark.parametrize(("half", "guard", "warned"), [(25, None, True), (25, 7.5, False),
                                                       (37, None, True), (38, None, False)])
def test_a_small_oparea_without_a_turn_guard_is_told_of_it(half: float, guard: float | None,
                                                          warned: bool) -> None:
    """A review's 50-m box was not told of ``turn_guard_radius_m`` (safety drove 4.4% of the
    time without it, 1.3% with it): an OpArea under 10 turning radii (75 m) across is."""
    text = (ROOT / "missions/small_oparea.yaml").read_text(encoding="utf-8")
    text = text.replace("turn_guard_radius_m: 7.5", f"turn_guard_radius_m: {guard or 'null'}")
    for a, b in (("[25, -25]", f"[{half}, -{half}]"), ("[25, 25]", f"[{half}, {half}]"),
                 ("[-25, 25]", f"[-{half}, {half}]"), ("[-25, -25]", f"[-{half}, -{half}]")):
        text = text.replace(a, b)
    mission = loads_mission(text, "m.yaml", default_registry(), Environment)
    got = [msg for loc, msg in advisories(mission) if "turn_guard_radius_m" in msg]
    assert bool(got) == warned, got
    if warned:
        assert got[0].startswith(f"the OpArea is {2 * half} m across"), got


@pytest.mark.parametrize(("half", "warned"), [(18, True), (19, False)])
def test_a_narrow_oparea_is_told_of_with_the_turn_guard_too(half: float, warned: bool) -> None:
    """A new user's 30-m channel with the guard sent 60 runs of 60 outside, up to 11.7 m, and
    validated silently: under 5 turning radii (37.5 m) across, the guard is not enough."""
    text = (ROOT / "missions/small_oparea.yaml").read_text(encoding="utf-8")
    for a, b in (("[25, -25]", f"[{half}, -{half}]"), ("[25, 25]", f"[{half}, {half}]"),
                 ("[-25, 25]", f"[-{half}, {half}]"), ("[-25, -25]", f"[-{half}, -{half}]"),
                 ("home: [-20, 0]", "home: [-10, 0]")):
        text = text.replace(a, b)
    mission = loads_mission(text, "m.yaml", default_registry(), Environment)
    assert mission.turn_guard_radius_m == 7.5
    got = [msg for loc, msg in advisories(mission) if "even with turn_guard_radius_m" in msg]
    assert bool(got) == warned, got
    if warned:
        assert got[0].startswith(f"the OpArea is {2 * half} m across, under 5 of the simulated "
                                 "vehicle's 7.5-m turning radii: even with"), got


@pytest.mark.parametrize(("out", "warned"), [(20, False), (21, True)])
def test_an_outward_current_is_counted_in_the_turn_back(out: float, warned: bool) -> None:
    """A review's start 21-22 m outside, heading straight out with the current flowing out
    too, was not warned of (the turn alone reaches 28.5 m) and gave back within seconds: the
    current carries the vehicle ~2.4 m farther while it turns (flown, seed 1)."""
    text = (ROOT / "missions/small_oparea.yaml").read_text(encoding="utf-8")
    text = text.replace("start: [-15, -15]", f"start: [{25 + out}, 0]\nallow_outside: [start]")
    text = text.replace("flow_toward_deg: 200", "flow_toward_deg: 0")  # north: outward
    mission = loads_mission(text, "m.yaml", default_registry(), Environment)
    assert bool(_warned(mission)) == warned
    (run,), _, _ = simulate(mission, to_sim_params(mission, 1), [launch_pose(mission)],
                            time_limit_s=60.0)
    assert (str(run.outcome) == "relinquished") == warned, (run.outcome, run.t_end)


def _walled(source: str, flow: float = 180.0, guard: bool = False) -> list[str]:
    text = (ROOT / "missions/tro2006_msn007.yaml").read_text(encoding="utf-8")
    text = text.replace("source: [43, -55]", f"source: {source}")
    text = text.replace("flow_toward_deg: 135", f"flow_toward_deg: {flow}")
    if guard:
        text = text.replace("cycle_hz: 1.0", "cycle_hz: 1.0\nturn_guard_radius_m: 7.5")
    mission = loads_mission(text, "m.yaml", default_registry(), Environment)
    return [msg for loc, msg in advisories(mission) if loc[:2] == ("environment", "source")]


def test_a_source_near_a_wall_or_whose_plume_leaves_the_oparea_is_told_of() -> None:
    """A review: a source 3 m inside a corner validated ``ok`` and every run went 5-14 m
    outside; one on a wall, the plume leaving the box at once, timed out. MSN007's OpArea: its
    NW corner is (130, -46) N-E; its north-west wall's nearest point to (120, -40) is some 8 m
    off, and the mission's own source (43, -55) is some 40 m in."""
    assert _walled("[43, -55]", flow=135) == []
    (msg,) = _walled("[118, -48]", flow=135)  # near the NW wall, plume into the box
    assert "m from an OpArea wall" in msg and "turn_guard_radius_m: 7.5" in msg, msg
    # with a guard, within one turning radius (7.5 m): it shortens the turns, not ends them
    (msg,) = _walled("[125, -44]", flow=135, guard=True)
    assert "does not keep them in" in msg, msg
    assert _walled("[118, -48]", flow=135, guard=True) == []  # 8-15 m in: the guard's work
    out, near = _walled("[118, -48]", flow=315)  # the flow carries the plume out at once
    assert "carries this source's plume out of the OpArea" in out, out
    assert "m from an OpArea wall" in near, near


def test_a_flow_along_a_wall_does_not_carry_the_plume_out() -> None:
    """A review: cos 90° is 6e-17, not 0, so a source on a wall with the flow along it was
    told its plume left the OpArea "0.0 m down-flow"."""
    text = (ROOT / "missions/oblique_flow.yaml").read_text(encoding="utf-8")
    mission = loads_mission(text, "m.yaml", default_registry(), Environment)
    a = mission.op_area_geometry()
    params = to_sim_params(mission)
    from cptbt.batch.sim_advice import source_wall_advice
    from cptbt.types import Point

    for direction in (0.0, 90.0, 180.0, 270.0):
        flowing = params.model_copy(update={"flow": params.flow.model_copy(
            update={"mean_dir_deg": direction})})
        on_wall = Point(0.5 * (a.xmin + a.xmax), a.ymax)  # on the +y wall, mid-way along it
        said = [m for _, m in source_wall_advice(mission, flowing, [on_wall])]
        leaves = direction == 90.0  # toward +y: out through that wall at once
        assert any("carries this source's plume out" in m for m in said) == leaves, said
        assert any("0.0 m from an OpArea wall" in m for m in said), said


def test_a_compass_mission_without_a_flow_direction_is_told_which_it_gets() -> None:
    """A review: without ``flow_toward_deg`` the current took the preset's direction along the
    OpArea's x axis, so the same box drawn rotated 30° flowed 30° elsewhere, validated ``ok``."""
    text = (ROOT / "missions/small_oparea.yaml").read_text(encoding="utf-8")
    assert "  flow_toward_deg: 200" in text
    plain = loads_mission(text.replace("  flow_toward_deg: 200", ""), "m.yaml",
                          default_registry(), Environment)
    said = [(loc, m) for loc, m in advisories(plain) if "no flow_toward_deg" in m]
    bearing = plain.op_area_geometry().frame.x_bearing_deg % 360
    ((loc, msg),) = said
    assert loc == ("environment",) and f"toward compass {(bearing + 2) % 360:.1f}°" in msg, msg
    given = loads_mission(text, "m.yaml", default_registry(), Environment)
    assert not [m for _, m in advisories(given) if "no flow_toward_deg" in m]
    # a planning-frame flow.mean_dir_deg turns with the box too (a diff review)
    planning = loads_mission(text.replace("  flow_toward_deg: 200", "  flow: {mean_dir_deg: 0}"),
                             "m.yaml", default_registry(), Environment)
    (msg,) = [m for _, m in advisories(planning) if "no flow_toward_deg" in m]
    assert "environment.flow.mean_dir_deg, a planning-frame angle" in msg, msg


def test_a_distance_under_a_mark_is_not_shown_rounded_up_to_it() -> None:
    """A review: 14.99999 m read "15.0 m from an OpArea wall, under two of the ... 7.5-m
    turning radii"."""
    from cptbt.batch.sim_advice import _under

    assert _under(14.99999) == "14.9" and _under(3.25) == "3.2" and _under(0.0) == "0.0"


def test_a_source_farther_outside_than_the_success_radius_is_told_no_run_can_succeed() -> None:
    """A review: a source 20 m beyond the up-flow wall (``allow_outside: [source]``) validated
    ``ok``; the run declared at the wall, 25.5 m off, a failure no setting could avoid."""
    text = (ROOT / "missions/tro2006_msn007.yaml").read_text(encoding="utf-8")
    mission = loads_mission(text, "m.yaml", default_registry(), Environment)
    a = mission.op_area_geometry()

    def told(outside: float) -> list[str]:
        from cptbt.types import Point

        p = mission.to_ne(Point(a.xmin - outside, 0.5 * (a.ymin + a.ymax)))
        moved = text.replace("source: [43, -55]", f"source: [{p[0]:.3f}, {p[1]:.3f}]").replace(
            "\nbehaviours:", "\nallow_outside: [source]\nbehaviours:")
        m = loads_mission(moved, "m.yaml", default_registry(), Environment)
        return [msg for loc, msg in advisories(m) if "no run can succeed" in msg]

    (msg,) = told(20.0)
    assert msg.startswith("20.0 m outside the OpArea, farther than the success radius (15 m)")
    assert told(10.0) == []  # within the radius of the wall: a declaration there can succeed


@pytest.mark.parametrize(("half_width", "warned"), [(7.5, True), (5, True), (10, False)])
def test_a_box_no_wider_than_the_turning_circle_is_told_whatever_the_guard(
        half_width: float, warned: bool) -> None:
    """A review's 60 x 10 m corridor with ``turn_guard_radius_m`` validated without a word and
    went 11.7 m outside (safety 16% of the time): the guard picks a turn's side, and no
    turn-around fits in a box no wider than the turning circle."""
    text = (ROOT / "missions/small_oparea.yaml").read_text(encoding="utf-8")
    for a, b in (("[25, -25]", f"[25, -{half_width}]"), ("[25, 25]", f"[25, {half_width}]"),
                 ("[-25, 25]", f"[-25, {half_width}]"), ("[-25, -25]", f"[-25, -{half_width}]")):
        assert a in text
        text = text.replace(a, b)
    text = text.replace("start: [-15, -15]", "start: [-15, 0]").replace(
        "source: [12, 10]", "source: [12, 0]")
    mission = loads_mission(text, "m.yaml", default_registry(), Environment)
    assert mission.turn_guard_radius_m == 7.5
    got = [msg for loc, msg in advisories(mission) if "turning circle" in msg]
    assert bool(got) == warned, got
    if warned:
        assert got[0].startswith(f"the OpArea is {2 * half_width:g} m across, no more than"), got


@pytest.mark.parametrize(("step", "warned"), [(None, True), (14, True), (15, False)])
def test_infotaxis_moves_shorter_than_the_turning_circle_are_told(step: float | None,
                                                                 warned: bool) -> None:
    """A new user swapped infotaxis and SAI in at their defaults (6-m moves) as the reacquire
    behaviour of their own MSN007-like mission: the REMUS was over 45° off the command most
    cycles, and the two flew one track, bit for bit (their seed; not every seed)."""
    text = (ROOT / "missions/tro2006_msn007_infotaxis.yaml").read_text(encoding="utf-8")
    given = "step_m: 15, replan_s: 6"
    assert given in text
    text = text.replace(given, "replan_s: 6" if step is None else f"step_m: {step}, replan_s: 6")
    mission = loads_mission(text, "m.yaml", default_registry(), Environment)
    got = [(loc, msg) for loc, msg in advisories(mission) if "turning circle" in msg]
    assert bool(got) == warned, got
    if warned:
        assert got[0][0][-1] == "step_m" and "cannot turn onto before it reaches them" in got[0][1]


CHANNEL = """\
name: channel
frame: planning
op_area:
  corners: [[0, -20], [200, -20], [200, 20], [0, 20]]
home: [5, 0]
start: [150, 0]
speed_mps: 1.5
turn_guard_radius_m: 3
behaviours:
  - safety: {}
  - declare_source: {variant: upflow_cluster}
  - maintain_plume: {variant: track_in_out}
  - reacquire_plume: {variant: three_point, radius_m: RADIUS}
  - find_plume: {variant: billiard}
  - move_to_field: {}
environment:
  preset: tro_ocean
  source: [40, 0]
  flow_toward_deg: TOWARD
  flow_speed_mps: 0.1
"""


@pytest.mark.parametrize(("radius", "toward", "warned"), [
    (12, 0, True),  # along the channel: 20.8 m across, in 20 m of room
    (11, 0, False),  # 19.1 m across
    (12, 90, False),  # across the channel: 18 m across, it fits
])
def test_a_tour_that_fits_only_turned_from_the_flow_is_told_of(radius: int, toward: int,
                                                               warned: bool) -> None:
    """A review's 40-m channel with the flow along it and a tour too wide for it across was
    warned of by nothing: the behaviour's own advice checks every orientation, and one fits."""
    text = CHANNEL.replace("RADIUS", str(radius)).replace("TOWARD", str(toward))
    mission = loads_mission(text, "m.yaml", default_registry(), Environment)
    told = [(loc, msg) for loc, msg in advisories(mission) if "simulated mean flow" in msg]
    assert bool(told) == warned, told
    if warned:
        assert told[0][0] == ("behaviours", 3, "reacquire_plume", "radius_m")
        assert "(180 × 20 m)" in told[0][1]
    # no mean flow: laid out along the estimate's direction, whatever it reads; the share of
    # directions it fits in is said (diff reviews: "toward 0°" with no flow, then silence)
    still = loads_mission(text.replace("flow_speed_mps: 0.1", "flow_speed_mps: 0.0"), "m.yaml",
                          default_registry(), Environment)
    assert not [m for _, m in advisories(still) if "simulated mean flow" in m]
    shares = [m for _, m in advisories(still) if "no mean current" in m]
    assert len(shares) == (radius == 12), shares


def test_the_tours_flow_is_told_as_the_file_gives_it() -> None:
    """A diff review: MSN007 (a compass mission) was told "toward 358.6° from the OpArea's x
    axis" where its file says compass 135°."""
    text = (ROOT / "missions/tro2006_msn007.yaml").read_text(encoding="utf-8").replace(
        "reacquire_plume: {variant: cloverleaf, d_leaf_m: 15, repeats: 3}",
        "reacquire_plume: {variant: three_point, radius_m: 55}")
    mission = loads_mission(text, "m.yaml", default_registry(), Environment)
    (told,) = [m for _, m in advisories(mission) if "simulated mean flow" in m]
    assert "laid out for the simulated mean flow (toward compass 135.0°)" in told, told
