"""The phase machine and the AMP session, driven message by message through a fake vehicle link.

Each give-back trigger is scripted on the vehicle's clock and must lead to ``amp.give_back``; the
vehicle's own reports then lead to ``return_to_break_off``, ``mission_a.resumed`` and
``post_mission``. No simulator: the link is a scripted double, the planner a stub.
"""

from __future__ import annotations

import math
import types
from pathlib import Path

import pytest
from conftest import scripted_registry
from transitions import MachineError

from cptbt.frames import OpArea
from cptbt.link import (
    CommandRefused,
    ConcentrationSample,
    FlowSample,
    HeadingSpeedCommand,
    OverrideEnded,
    OverrideRelease,
    OverrideRequest,
    VehicleLink,
    VehicleState,
)
from cptbt.loader import load_mission, loads_mission
from cptbt.mission import MissionBase
from cptbt.mission_a import MissionASpec, VehicleLimits
from cptbt.perception import Perception
from cptbt.phases import MissionPhases, describe, leaf_states, to_dot
from cptbt.planner import Planner
from cptbt.session import AmpSession
from cptbt.types import Command, Point, Pose

REG = scripted_registry("safety")


def mission(**mission_a: object) -> MissionBase:
    body = {"waypoints": [[10, 0], [50, 0], [90, 0]], "amp_enable_s": 100, "watchdog_s": 20}
    body.update(mission_a)
    lines = "\n".join(f"  {k}: {'null' if v is None else v}" for k, v in body.items())
    text = (
        "name: phased\nframe: planning\nop_area:\n  corners: [[0, -50], [100, -50], [100, 50], "
        "[0, 50]]\nhome: [5, 0]\ntime_limit_s: 300\nbehaviours:\n  - safety: {}\n"
        f"mission_a:\n{lines}\n"
    )
    return loads_mission(text, "phased.yaml", REG)


def advice(m: MissionBase) -> list[tuple[object, str]]:
    """The mission's advisories but the one its AMP of safety alone always has (no
    declare_source: these missions are about the phases)."""
    return [(loc, why) for loc, why in m.advisories() if "no declare_source" not in why]


class FakeLink:
    """A scripted vehicle: queue what it reports, read what the AMP sent."""

    def __init__(self) -> None:
        self.inbox: list[object] = []
        self.sent: list[object] = []

    def receive(self) -> list[object]:
        out, self.inbox = self.inbox, []
        return out

    def send(self, message: object) -> None:
        self.sent.append(message)


class StubPlanner:
    """Just enough of the planner for the session: a command every tick, a settable ``done``."""

    def __init__(self) -> None:
        self.op_area = OpArea(0, 100, -50, 50)
        self.done = False
        self.declared_source: Point | None = None
        self.samples: list[float] = []
        self.flows = 0
        self.ticks: list[float] = []
        self.speed = 1.5
        self.perception = types.SimpleNamespace(on_clock=lambda t: t)  # a clock never corrected

    def add_sample(self, t: float, c: float) -> None:
        self.samples.append(c)

    def add_flow(self, t: float, vx: float, vy: float) -> None:
        self.flows += 1

    def set_pose(self, x: float, y: float, heading_deg: float) -> None:
        pass

    def tick(self, t: float) -> Command:
        self.ticks.append(t)
        return Command(30.0, self.speed)


def state(t: float, mode: str = "mission", x: float = 50, y: float = 0, reached: int = 0
          ) -> VehicleState:
    return VehicleState(t, x, y, 0.0, 1.5, 3.0, mode, reached)  # type: ignore[arg-type]


def session(**mission_a: object) -> tuple[AmpSession, FakeLink, StubPlanner]:
    link, planner = FakeLink(), StubPlanner()
    s = AmpSession(mission(**mission_a), planner, link)  # type: ignore[arg-type]
    return s, link, planner


def step(s: AmpSession, link: FakeLink, *msgs: object) -> str:
    link.inbox.extend(msgs)
    s.update()
    return s.phases.state


def into_override(s: AmpSession, link: FakeLink) -> None:
    assert step(s, link, state(0.0, "pre_launch")) == "pre_launch"
    assert step(s, link, state(0.1)) == "mission_a.waypoints"
    assert step(s, link, state(99.9)) == "mission_a.waypoints"
    assert step(s, link, state(100.0)) == "amp.override"


def test_the_machine_uses_dotted_names_and_snake_case_states() -> None:
    assert "return_to_break_off" in leaf_states()
    assert "amp.give_back" in leaf_states()
    m = MissionPhases()
    with pytest.raises(MachineError):
        m.fire("amp_enable", 0.0)  # not from pre_launch
    m.fire("launch", 0.0)
    assert m.state == "mission_a.waypoints"
    assert "pre_launch --launch--> mission_a.waypoints" in describe()
    # a transition from several phases names what it leaves out ("any live phase" had read
    # as leaving out pre_launch, from which it also fires)
    assert "any phase but post_mission --mission_a_complete--> post_mission" in describe()
    assert '"amp.give_back" -> "return_to_break_off" [label="vehicle_returning"]' in to_dot()


def test_amp_enable_after_a_set_time_sends_an_override_request_then_commands() -> None:
    s, link, planner = session()
    into_override(s, link)
    assert isinstance(link.sent[0], OverrideRequest)
    assert link.sent[1] == HeadingSpeedCommand(30.0, 1.5, None)
    assert planner.ticks == [100.0]
    step(s, link, state(100.5, "override"))
    step(s, link, state(101.0, "override"))
    assert planner.ticks == [100.0, 101.0]  # 1 Hz on the vehicle's clock


def test_amp_enable_at_a_waypoint() -> None:
    s, link, _ = session(amp_enable_s=None, amp_enable_waypoint=1)
    step(s, link, state(0.0, "pre_launch"))
    step(s, link, state(0.1))
    assert step(s, link, state(500.0, reached=1)) == "mission_a.waypoints"  # at waypoint 0 only
    assert step(s, link, state(501.0, reached=2)) == "amp.override"


def test_concentration_only_under_override_flow_always() -> None:
    s, link, planner = session()
    step(s, link, state(0.0, "pre_launch"))
    step(s, link, state(0.1), ConcentrationSample(0.1, 5.0), FlowSample(0.1, 0.1, 0.0))
    assert planner.samples == [] and planner.flows == 1
    assert step(s, link, state(100.0)) == "amp.override"
    step(s, link, ConcentrationSample(100.1, 0.7), state(100.1, "override"))
    assert planner.samples == [0.7]


@pytest.mark.parametrize(
    "setup, trigger",
    [
        (lambda p, t: setattr(p, "done", True), "declared_home"),
        (lambda p, t: None, "amp_time_limit"),
        (lambda p, t: None, "outside_op_area"),
    ],
)
def test_each_amp_give_back_trigger_releases_the_override(setup, trigger) -> None:  # type: ignore[no-untyped-def]
    s, link, planner = session()
    into_override(s, link)
    t = 150.0
    where = {"x": 50.0, "y": 0.0}
    if trigger == "amp_time_limit":
        t = 100.0 + 300.0  # time_limit_s after the take-over
    if trigger == "outside_op_area":
        where = {"x": 50.0, "y": 50.0 + 30.5}  # 30.5 m beyond ymax
    else:
        step(s, link, state(t - 1.0, "override", x=50, y=50 + 29.0))  # 29 m out: not yet
        assert s.phases.state == "amp.override"
    setup(planner, t)
    assert step(s, link, state(t, "override", **where)) == "amp.give_back"  # type: ignore[arg-type]
    assert s.phases.timeline[-1].trigger == trigger
    assert isinstance(link.sent[-1], OverrideRelease)
    n_ticks = len(planner.ticks)
    assert step(s, link, state(t + 0.1, "returning")) == "return_to_break_off"
    assert len(planner.ticks) == n_ticks  # the planner no longer runs


def test_watchdog_timeout_reported_by_the_vehicle_leads_to_give_back() -> None:
    s, link, _ = session()
    into_override(s, link)
    ended = OverrideEnded(121.0, "watchdog", (50.0, 0.0))
    assert step(s, link, ended, state(121.0, "returning")) == "return_to_break_off"
    triggers = [c.trigger for c in s.phases.timeline]
    assert triggers[-2:] == ["watchdog_timeout", "vehicle_returning"]
    assert not any(isinstance(m, OverrideRelease) for m in link.sent)  # the vehicle took it


def test_refused_command_is_recorded_and_the_amp_keeps_control() -> None:
    s, link, _ = session()
    into_override(s, link)
    bad = HeadingSpeedCommand(30.0, 3.5)
    why = VehicleLimits().refusal(3.5, None)
    assert why is not None and "3.5" in why
    assert step(s, link, CommandRefused(100.2, bad, why), state(100.2, "override")) == (
        "amp.override"
    )
    step(s, link, CommandRefused(101.2, bad, why), state(101.2, "override"))
    refusals = [c for c in s.phases.timeline if c.trigger == "command_refused"]
    assert len(refusals) == 1 and refusals[0].detail == why  # a streak is logged once
    assert s.refusals == 2


def test_resume_and_post_mission_follow_the_vehicle() -> None:
    s, link, _ = session()
    into_override(s, link)
    step(s, link, OverrideEnded(130.0, "watchdog", (50.0, 0.0)), state(130.0, "returning"))
    assert step(s, link, state(140.0, "returning")) == "return_to_break_off"
    assert step(s, link, state(150.0, "mission", x=51, y=1)) == "mission_a.resumed"
    assert step(s, link, state(151.0, "mission")) == "mission_a.resumed"  # no second AMP run
    assert step(s, link, state(300.0, "post_mission")) == "post_mission"
    assert [c.dest for c in s.phases.timeline] == [
        "mission_a.waypoints", "amp.override", "amp.give_back", "return_to_break_off",
        "mission_a.resumed", "post_mission",
    ]


def test_limits_and_spec_validation() -> None:
    lim = VehicleLimits(max_speed_mps=2.8, max_depth_m=50)
    assert lim.refusal(2.8, 50) is None
    assert lim.refusal(0.1, None) is not None
    assert lim.refusal(1.0, 50.5) is not None
    # A review: the simulated front seat took an infinite heading and a depth above the surface.
    assert lim.refusal(1.0, 0.0, heading_deg=-179.0) is None
    assert lim.refusal(1.0, None, heading_deg=math.inf) is not None
    assert lim.refusal(1.0, None, heading_deg=math.nan) is not None
    assert lim.refusal(1.0, -50.0) is not None and lim.refusal(1.0, -math.inf) is not None
    assert lim.refusal(math.nan, None) is not None
    with pytest.raises(ValueError):
        MissionASpec(waypoints=[(0, 0)], amp_enable_s=1, amp_enable_waypoint=0)
    with pytest.raises(ValueError):
        MissionASpec(waypoints=[(0, 0)], amp_enable_waypoint=1)


def test_fake_link_satisfies_the_protocol() -> None:
    assert isinstance(FakeLink(), VehicleLink)


def test_a_clock_step_back_does_not_silence_the_amp() -> None:
    s, link, planner = session()
    into_override(s, link)
    for t in (101.0, 102.0, 103.0):
        step(s, link, state(t))
    ticks = len(planner.ticks)
    for t in (53.0, 54.0, 55.0):  # the vehicle clock stepped back 50 s
        step(s, link, state(t))
        assert s.ticked and isinstance(link.sent[-1], HeadingSpeedCommand)
    assert len(planner.ticks) == ticks + 3 and s.in_override


def test_a_clock_step_back_does_not_extend_the_amp_time_limit() -> None:
    # A review: a 900-s step back let the AMP drive 2 700 s against a 1 800-s limit, the
    # limit measured as vehicle time minus the take-over's. Its forward steps count instead.
    s, link, _ = session()  # time_limit_s 300, take-over at 100 s
    into_override(s, link)
    for t in range(101, 201):
        step(s, link, state(float(t), "override"))
    assert s.in_override and s.amp_elapsed_s == pytest.approx(100.0)
    for t in range(50, 249):  # stepped back 150 s at 200 s: 199 more seconds of control
        step(s, link, state(float(t), "override"))
    assert s.in_override and s.amp_elapsed_s == pytest.approx(298.0)
    assert step(s, link, state(250.0, "override")) == "amp.give_back"  # 300 s in all
    assert s.phases.timeline[-1].trigger == "amp_time_limit"


def test_a_forward_clock_jump_ticks_once_not_a_burst() -> None:
    s, link, planner = session()
    into_override(s, link)
    step(s, link, state(101.0, "override"))
    ticks = len(planner.ticks)
    step(s, link, state(160.0, "override"))
    step(s, link, state(160.2, "override"))  # same cycle: no catch-up burst of 59 ticks
    assert len(planner.ticks) == ticks + 1


def test_a_take_the_vehicle_does_not_grant_is_sent_again_then_given_up() -> None:
    # the take was lost (or refused): the vehicle goes on reporting its own mission; the AMP
    # sat in amp.override for the rest of the run, believing it drove
    s, link, _ = session()
    into_override(s, link)
    for t in (100.5, 101.0, 101.5, 102.0, 103.0, 104.0):
        step(s, link, state(t))
    takes = [m for m in link.sent if isinstance(m, OverrideRequest)]
    assert len(takes) == 3  # at 100, then every 2 s
    assert step(s, link, state(119.9)) == "amp.override"
    assert step(s, link, state(120.0)) == "amp.give_back"  # watchdog_s (20 s) without control
    last = s.phases.timeline[-1]
    assert last.trigger == "watchdog_timeout" and isinstance(link.sent[-1], OverrideRelease)
    assert last.detail == "the vehicle did not grant the override: mode mission for 20 s"
    # it never left its mission: no return to a break-off point it never had (a field
    # review's MAVLink timeline "returned" to where the vehicle was, in the same instant)
    assert step(s, link, state(121.0)) == "mission_a.resumed"
    assert s.phases.timeline[-1].trigger == "never_granted"
    assert "return_to_break_off" not in [c.dest for c in s.phases.timeline]


def test_a_take_refused_in_vain_says_why_in_the_give_back() -> None:
    """A field re-test: a vehicle in a failsafe the AMP would not take was given back to
    "mode mission for 30 s", the link's reason (its refusals) left out of the detail."""
    s, link, _ = session()
    into_override(s, link)
    why = "the vehicle is in SURFACE, not its mission (AUTO): a pilot or a failsafe has it"
    step(s, link, state(101.0), CommandRefused(101.0, HeadingSpeedCommand(30.0, 1.5, 3.0), why))
    assert step(s, link, state(120.0)) == "amp.give_back"
    assert s.phases.timeline[-1].detail == (
        f"the vehicle did not grant the override: mode mission for 20 s; {why}")


def test_a_vehicle_that_leaves_the_override_unsaid_is_given_back_to() -> None:
    s, link, _ = session()
    into_override(s, link)
    for t in (101.0, 102.0, 103.0):
        step(s, link, state(t, "override"))
    takes = sum(isinstance(m, OverrideRequest) for m in link.sent)
    step(s, link, state(104.0, "returning"))  # no 'ended' message
    assert s.in_override and sum(isinstance(m, OverrideRequest) for m in link.sent) == takes
    assert step(s, link, state(122.9, "returning")) == "amp.override"
    assert step(s, link, state(123.0, "returning")) != "amp.override"
    (gave_back,) = [c for c in s.phases.timeline if c.trigger == "watchdog_timeout"]
    assert gave_back.detail == ("the vehicle left the override without saying so: mode "
                                "returning for 20 s")


@pytest.mark.parametrize("bad", [math.inf, math.nan, -math.inf])
def test_a_non_finite_fix_neither_ends_the_override_nor_reaches_the_planner(bad: float) -> None:
    s, link, _ = session()
    into_override(s, link)
    step(s, link, state(101.0, "override", x=bad))
    assert s.in_override and s.state is not None and s.state.x_m == 50
    step(s, link, VehicleState(math.nan, 50, 0, 0.0, 1.5, 3.0, "override", 0))
    assert s.in_override and s.t == 101.0


def test_an_impossibly_far_fix_neither_ends_the_override_nor_reaches_the_planner() -> None:
    """A review's vehicle sent x_m 1e308 for 20 s: the override ended as an excursion, its
    distance printed with 300 digits. A position 1000 km out is a broken message."""
    s, link, _ = session()
    into_override(s, link)
    for k, x in enumerate((1e308, -2e6, 9.97e36)):
        step(s, link, state(101.0 + k, "override", x=x))
        assert s.in_override and s.state is not None and s.state.x_m == 50
    assert s.rejected_fixes == 3
    step(s, link, state(105.0, "override", x=50, y=50 + 30.5))  # a true excursion still counts
    assert s.phases.timeline[-1].trigger == "outside_op_area"
    assert s.phases.timeline[-1].detail == "30.5 m outside"


def test_the_planners_perception_ignores_an_impossibly_far_fix() -> None:
    p = Perception(OpArea(0, 100, -50, 50))
    p.set_pose(Pose(50, 0, 90))
    p.set_pose(Pose(1e308, 0, 90))
    p.set_pose(Pose(50, 2e6, 90))
    assert (p.pose.x, p.pose.y) == (50, 0) and p.faults()["rejected_fixes"] == 2
    p.set_pose(Pose(50, 999_000, 90))  # far, not impossible
    assert p.pose.y == 999_000 and p.rejected_fixes == 2


def test_a_take_over_waypoint_beyond_the_give_back_distance_is_warned_of() -> None:
    """A review's AMP took over 38 m outside the OpArea and gave back in the same cycle."""
    far = mission(waypoints="[[-35, 0], [50, 0], [90, 0]]", amp_enable_s=None,
                  amp_enable_waypoint=0)
    ((loc, why),) = advice(far)
    assert loc == ("mission_a", "waypoints", 0) and "35.0 m outside the OpArea" in why, why
    near = mission(waypoints="[[-25, 0], [50, 0], [90, 0]]", amp_enable_s=None,
                   amp_enable_waypoint=0)
    assert advice(near) == []


@pytest.mark.parametrize(("settings", "key", "says"), [
    ({"amp_enable_s": None, "amp_enable_waypoint": 2}, "amp_enable_waypoint",
     "2 is the last waypoint"),
    ({"amp_enable_s": 8000}, "amp_enable_s", "the AMP never takes over"),
    ({"watchdog_s": 0.5}, "watchdog_s", "no longer than a planning cycle (1 s)"),
    ({"capture_radius_m": 1e-9}, "capture_radius_m", "without coming within it"),
])
def test_mission_a_settings_under_which_the_amp_never_drives_are_warned_of(
    settings: dict[str, object], key: str, says: str
) -> None:
    # each validated, and each ran to the end with the AMP never driving, or never home
    assert advice(mission()) == []
    ((loc, why),) = advice(mission(**settings))
    assert loc == ("mission_a", key) and says in why, why
    if key == "amp_enable_waypoint":  # a looping Mission A comes round to it again
        assert advice(mission(**settings, loop="true")) == []


def test_amp_enable_s_counts_from_the_launch_not_the_vehicle_clocks_zero() -> None:
    """A review's ArduSub, booted 10 minutes before its launch, reports time since boot: it
    was taken over at the launch. ``amp_enable_s`` counts from the last report at the dock."""
    s, link, _ = session()  # amp_enable_s 100
    step(s, link, state(599.0, "pre_launch"))
    step(s, link, state(600.0, "pre_launch"))
    assert step(s, link, state(600.2)) == "mission_a.waypoints"
    assert step(s, link, state(699.9)) == "mission_a.waypoints"
    assert step(s, link, state(700.0)) == "amp.override"


def test_a_session_that_did_not_see_the_launch_does_not_take_over() -> None:
    """A review's restarted serve took a released vehicle back at its first report and flew a
    new search with a fresh time limit: a session that meets the vehicle under way never
    takes it (its timeline says why)."""
    s, link, planner = session(amp_enable_s=None, amp_enable_waypoint=1)
    assert step(s, link, state(344.6, reached=4)) == "mission_a.waypoints"
    for t in (345.0, 400.0, 500.0):
        assert step(s, link, state(t, reached=4)) == "mission_a.waypoints"
    assert not link.sent and not planner.ticks
    (launch,) = s.phases.timeline
    assert "did not see the launch, and does not take over" in launch.detail


def test_no_usable_navigation_under_override_gives_back() -> None:
    """A review's NaN positions (dropped by the decoder) left the vehicle on its last command
    until its own watchdog, 18 m outside the OpArea: the AMP gives back when the other reports
    run 5 s past its latest usable position."""
    s, link, _ = session()
    into_override(s, link)
    step(s, link, state(101.0, "override"))
    for k in range(1, 61):  # samples go on; navigation has stopped at 101 s
        step(s, link, ConcentrationSample(101.0 + 0.1 * k, 0.0))
    assert s.phases.state == "amp.give_back" and isinstance(link.sent[-1], OverrideRelease)
    gave = s.phases.timeline[-1]
    assert gave.trigger == "amp_abort" and gave.t_s == 101.0  # the vehicle time it last said
    assert gave.detail == ("no usable navigation for 5 s of the vehicle's reports (the latest "
                           "usable position at t = 101 s)")
    assert len(s.phases.timeline) == 3  # launch, take-over, abort: and only after 5 s
    # fired at the 50th sample (5 s), not before: samples 1..49 left the override standing


def test_a_held_position_is_no_usable_navigation_for_long() -> None:
    """A non-finite fix keeps the last (one bad report must not end the override), but not for
    ever: 5 s of them give back as no navigation does."""
    s, link, _ = session()
    into_override(s, link)
    step(s, link, state(101.0, "override"))
    for k in range(1, 5):
        assert step(s, link, state(101.0 + k, "override", x=math.nan)) == "amp.override"
    assert step(s, link, state(106.0, "override", x=math.nan)) == "amp.give_back"
    assert s.phases.timeline[-1].trigger == "amp_abort"


def test_a_corrupt_stamp_is_not_taken_for_time_without_navigation() -> None:
    """A diff review: one flow sample stamped 4e9 s (or samples on a clock 6 s ahead) ended the
    AMP's search at once; a report's stamp counts at most a second past the one before."""
    s, link, _ = session()
    into_override(s, link)
    step(s, link, state(101.0, "override"), FlowSample(4e9, 0.1, 0.0),
         ConcentrationSample(1e20, 0.0))
    assert step(s, link, state(101.5, "override")) == "amp.override"
    for k in range(20):  # samples 6 s ahead of the navigation, navigation on time
        assert step(s, link, ConcentrationSample(108.0 + 0.1 * k, 0.0),
                    state(102.0 + 0.1 * k, "override")) == "amp.override"


def test_no_navigation_after_a_clock_step_back_is_timed_out_on_the_new_clock() -> None:
    """A diff review: a vehicle computer restarted (its clock from 0, no position while its
    navigation starts) kept the override 254 s, until the new clock passed the last fix."""
    s, link, _ = session()
    into_override(s, link)
    step(s, link, state(101.0, "override"))
    k = 0
    while s.in_override and k < 200:
        k += 1
        step(s, link, ConcentrationSample(0.1 * k, 0.0))
    assert not s.in_override and 49 <= k <= 72, k  # 5 s of the new clock (and the step)


def test_amp_enable_s_counts_from_a_launch_on_a_restarted_clock() -> None:
    """A diff review: a front seat on mission time restarts its clock at the launch; the dock's
    reports, on time since boot, had put the take-over a boot's length late."""
    s, link, _ = session()  # amp_enable_s 100
    step(s, link, state(600.0, "pre_launch"))
    assert step(s, link, state(0.1)) == "mission_a.waypoints"
    assert step(s, link, state(100.0)) == "mission_a.waypoints"
    assert step(s, link, state(100.1)) == "amp.override"


def test_a_pre_launch_reported_under_way_does_not_restart_the_count() -> None:
    """A diff review: a mode glitch (or a MAVLink disarm) every 90 s kept the AMP out."""
    s, link, _ = session()  # amp_enable_s 100
    step(s, link, state(0.0, "pre_launch"))
    step(s, link, state(0.1))
    step(s, link, state(90.0, "pre_launch"))
    assert step(s, link, state(99.9)) == "mission_a.waypoints"
    assert step(s, link, state(100.0)) == "amp.override"


def test_late_samples_mixed_with_reports_on_time_are_no_time_without_navigation() -> None:
    """Each kind of report counts on its own clock: samples 20 s late between flows on time
    had counted their lateness at every alternation, and given back with navigation at 1 Hz."""
    s, link, _ = session()
    into_override(s, link)
    for k in range(1, 600):
        t = 100.0 + 0.1 * k
        msgs: list[object] = [ConcentrationSample(t - 20.0, 0.0), FlowSample(t, 0.1, 0.0)]
        if k % 10 == 0:
            msgs.append(state(t, "override"))
        assert step(s, link, *msgs) == "amp.override", t


def test_a_frozen_navigation_clock_is_no_usable_navigation() -> None:
    """A re-test: navigation stamped with a frozen clock (positions still coming) kept the
    override, the planner silent, until the vehicle's own watchdog."""
    s, link, _ = session()
    into_override(s, link)
    step(s, link, state(101.0, "override"))
    for k in range(1, 70):
        step(s, link, state(101.0, "override", x=50 + 0.1 * k),
             ConcentrationSample(101.0 + 0.1 * k, 0.0))
        if not s.in_override:
            break
    assert not s.in_override and 49 <= k <= 51, k
    assert s.phases.timeline[-1].trigger == "amp_abort"


def test_a_corrupt_navigation_stamp_does_not_bring_the_take_over_forward() -> None:
    """A re-test: one nav stamped 4e9 s in Mission A took over 140 s early."""
    s, link, _ = session()  # amp_enable_s 100
    step(s, link, state(0.0, "pre_launch"))
    step(s, link, state(0.1))
    assert step(s, link, state(4e9)) == "mission_a.waypoints"
    assert step(s, link, state(50.0)) == "mission_a.waypoints"
    assert step(s, link, state(99.9)) == "mission_a.waypoints"
    assert step(s, link, state(100.0)) == "amp.override"  # on time: the leap passed over


def test_a_flushed_backlog_of_samples_is_no_time_without_navigation() -> None:
    """A re-test: 10 s of samples held by a buffer and flushed after a fresh fix counted their
    own steps as time without navigation, and gave back with navigation fine."""
    s, link, _ = session()
    into_override(s, link)
    for k in range(1, 231):
        step(s, link, state(100.0 + 0.1 * k, "override"), ConcentrationSample(100.0 + 0.1 * k, 0))
    backlog = [ConcentrationSample(110.0 + 0.1 * k, 0.0) for k in range(100)]
    assert step(s, link, state(123.1, "override"), *backlog) == "amp.override"
    assert step(s, link, state(123.2, "override")) == "amp.override"


def test_a_planner_with_no_output_gives_back() -> None:
    """A review's dead current sensor: the planner gave no command, the vehicle flew the AMP's
    last one unsteered until its own 30-s watchdog. The AMP gives back after 5 s of cycles
    without a command (5 at 1 Hz); a cycle or two without one changes nothing."""
    s, link, planner = session()
    into_override(s, link)
    silent = {"on": True}
    ticks = planner.tick

    def tick(t: float) -> Command | None:
        out = ticks(t)
        return None if silent["on"] else out

    planner.tick = tick  # type: ignore[method-assign]
    for t in (101.0, 102.0):
        assert step(s, link, state(t, "override")) == "amp.override"
    silent["on"] = False
    assert step(s, link, state(103.0, "override")) == "amp.override"
    silent["on"] = True
    for t in (104.0, 105.0, 106.0, 107.0):
        assert step(s, link, state(t, "override")) == "amp.override"
    assert not isinstance(link.sent[-1], OverrideRelease)
    assert step(s, link, state(108.0, "override")) == "amp.give_back"
    assert isinstance(link.sent[-1], OverrideRelease)
    gave = s.phases.timeline[-1]
    assert gave.trigger == "amp_abort" and gave.t_s == 108.0
    assert gave.detail == "the planner gave no command for 5 s (5 planning cycles)"


def test_a_dead_current_sensor_gives_back_and_says_why() -> None:
    """The real planner of TRO MSN007 with no flow sample: no behaviour drives without a flow
    estimate once the vehicle is at the start, and the give-back (after 5 cycles at 1 Hz)
    names the missing estimate."""
    m = load_mission(Path(__file__).parents[2] / "missions" / "tro2006_msn007.yaml")
    link = FakeLink()
    s = AmpSession(m, Planner(m), link)
    at = m.to_xy(m.start)
    step(s, link, state(0.0, "pre_launch"))
    step(s, link, state(1.0))
    assert step(s, link, state(240.0)) == "amp.override"
    for t in range(241, 245):
        assert step(s, link, state(float(t), "override", x=at.x, y=at.y),
                    ConcentrationSample(float(t), 0.0)) == "amp.override"
    assert step(s, link, state(245.0, "override", x=at.x, y=at.y)) == "amp.give_back"
    gave = s.phases.timeline[-1]
    assert gave.trigger == "amp_abort" and gave.t_s == 245.0
    assert gave.detail == ("the planner gave no command for 5 s (5 planning cycles): no flow "
                           "estimate (no usable flow sample has arrived)")


def test_no_output_is_timed_on_the_vehicles_clock_not_in_cycles() -> None:
    """A diff review: counted in cycles, a 10-Hz mission on 1-Hz reports (the session plans at
    most once a report) gave back after 51 s, past the vehicle's 30-s watchdog."""
    fast = loads_mission(
        "name: phased\nframe: planning\nop_area:\n  corners: [[0, -50], [100, -50], [100, 50], "
        "[0, 50]]\nhome: [5, 0]\ntime_limit_s: 300\ncycle_hz: 10\nbehaviours:\n  - safety: {}\n"
        "mission_a:\n  waypoints: [[10, 0], [50, 0], [90, 0]]\n  amp_enable_s: 100\n"
        "  watchdog_s: 20\n", "phased.yaml", REG)
    link, planner = FakeLink(), StubPlanner()
    s = AmpSession(fast, planner, link)  # type: ignore[arg-type]
    into_override(s, link)
    planner.tick = lambda t: None  # type: ignore[assignment,method-assign]
    for t in (101.0, 102.0, 103.0, 104.0):
        assert step(s, link, state(t, "override")) == "amp.override"
    assert step(s, link, state(105.0, "override")) == "amp.give_back"
    detail = s.phases.timeline[-1].detail
    assert detail == "the planner gave no command for 5 s (5 planning cycles)"


def test_a_corrupt_leap_of_the_clock_does_not_end_the_search_on_its_time_limit() -> None:
    """A review: one navigation report stamped 4e9 s under override ended the AMP's search on
    its 300-s time limit. A leap beyond an hour counts as a step back does; a clock that has
    really jumped keeps counting from its new time."""
    s, link, _ = session()
    into_override(s, link)
    step(s, link, state(101.0, "override"))
    assert step(s, link, state(4e9, "override")) == "amp.override"
    for t in (102.0, 103.0, 104.0):
        assert step(s, link, state(t, "override")) == "amp.override"
    assert s.amp_elapsed_s == pytest.approx(3.0)  # 101-102 lost to the leap, then counted
    assert step(s, link, state(10_000.0, "override")) == "amp.override"  # jumped for good
    for t in range(10_001, 10_297):
        step(s, link, state(float(t), "override"))
    assert s.phases.state == "amp.override" and s.amp_elapsed_s == pytest.approx(299.0)
    assert step(s, link, state(10_297.0, "override")) == "amp.give_back"  # 300 s counted
    assert s.phases.timeline[-1].trigger == "amp_time_limit"


def test_a_corrupt_leap_does_not_time_out_a_silent_planner() -> None:
    """A field re-test: with the planner silent, one nav stamped 4e9 s gave back at once,
    "no command for 4e+09 s", the timeline at t = 4e9."""
    s, link, planner = session()
    into_override(s, link)
    planner.tick = lambda t: None  # type: ignore[assignment,method-assign]
    assert step(s, link, state(101.0, "override")) == "amp.override"
    assert step(s, link, state(4e9, "override")) == "amp.override"
    for t in (102.0, 103.0, 104.0):
        assert step(s, link, state(t, "override")) == "amp.override"
    assert step(s, link, state(106.0, "override")) == "amp.give_back"
    gave = s.phases.timeline[-1]
    assert gave.t_s == 106.0 and "for 5 s" in gave.detail, gave
