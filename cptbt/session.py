"""The AMP as a guest on the vehicle: phases, planner and vehicle link in one loop.

:class:`AmpSession` is the AMP computer's main loop (OMAE "AMP-REMUS protocols"): it reads what
the vehicle reports through a :class:`cptbt.link.VehicleLink`, fires the phase triggers of
:mod:`cptbt.phases` on a phase clock, feeds and ticks the :class:`cptbt.planner.Planner`
while the AMP has the override, and sends its commands back through the link. It never touches
the vehicle (or a simulator) any other way.

Readings chosen: flow samples reach the planner in every phase (the AMP hears the vehicle's sensors
at all times, so its 100 s flow average is ready at the take-over); concentration samples reach it
only under override, so the first AMP cycle does not condense Mission A samples. The AMP's time
limit (the mission's ``time_limit_s``) and the 30 m rule are checked by the AMP, the watchdog and
command limits by the vehicle.
"""

from __future__ import annotations

import dataclasses
import logging
import math
from typing import Any

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
from cptbt.mission import MissionBase
from cptbt.mission_a import MissionASpec
from cptbt.perception import MAX_CLOCK_JUMP_S, MAX_FIX_OUTSIDE_M
from cptbt.phases import MissionPhases, PhaseClock
from cptbt.planner import Planner
from cptbt.policy import give_back_trigger
from cptbt.types import Command, Point

log = logging.getLogger(__name__)


RETAKE_S = 2.0
"""A take the vehicle has not granted is sent again this often (vehicle clock), s."""

NAV_TIMEOUT_S = 5.0
"""Under override, the AMP gives back (``amp_abort``) when the vehicle's reports have run this
long, or three planning cycles if longer, since its latest usable position: without a position
the planner steers by a stale one, and safety cannot keep the vehicle in (a review's NaN
positions, and a frozen navigation clock, left the vehicle on its last command until its own
30-s watchdog, 18 m outside an 80-m OpArea). The time is the reports' own forward steps, each
counted up to :data:`MAX_REPORT_STEP_S` (one corrupt stamp of 4e9 s adds that much, not 4e9 s),
a step back of the clock adding nothing and counting on from the new time (a vehicle's computer
restarted without navigation is timed out 5 s later, not once its clock has caught up), each
kind of report (samples, flows, navigation...) on its own clock, the longest counting (samples
delivered 20 s late, mixed with flows on time, would otherwise count their lateness again and
again)."""

NO_OUTPUT_S = 5.0
"""Under override, the AMP gives back (``amp_abort``) when its planner has given no command for
this long, or three planning cycles if longer, on the vehicle's clock from the last cycle
with one (its forward steps: a step back adds nothing): a planner with no output leaves the
vehicle on the AMP's last command, which nothing then steers or keeps in the OpArea (a
review's dead current sensor: no flow estimate, no behaviour drove, and only the vehicle's own
30-s watchdog ended the override). Time, not cycles: the session plans at most once a report,
and counted in cycles a 10-Hz mission on 1-Hz reports gave back after 51 s (a diff review). A
run's last cycle, after the declaration and the trip home, is no command for one cycle only."""

MAX_REPORT_STEP_S = 1.0
"""The most one report's stamp counts toward :data:`NAV_TIMEOUT_S` past the latest before it."""

BACKLOG_S = 60.0
"""A report stamped up to this long before the latest usable position, after later ones of its
kind, is a delayed one flushed late (a serial or radio buffer): it does not count toward
:data:`NAV_TIMEOUT_S` (a re-test's 10-s backlog of samples had given back with navigation
fine). A clock stepped back further than this counts on from its new time."""

CLOCK_STEP_BACK_S = 2.0
"""A report stamped this far before the latest is taken as the clock stepped back: the time
without navigation counts on from it (a sample a little out of order is not)."""


class AmpSession:
    """One AMP run on one vehicle.

    Args:
        mission: a validated mission with a ``mission_a`` section.
        planner: the planner the AMP runs while it has the override.
        link: the connection to the vehicle.

    Attributes:
        phases: the phase machine and its timeline.
        state: the latest vehicle state (None before the first).
        t_amp_start: vehicle time of the take-over (None before it).
        command: the planner's command this update (None if none or no tick).
        ticked: whether the planner ticked this update.
        amp_elapsed_s: the AMP's time in control, what its time limit counts: the vehicle
            clock's forward steps since the take-over (a step back, or a leap beyond
            :data:`~cptbt.perception.MAX_CLOCK_JUMP_S`, adds nothing).
        refusals: how many commands the vehicle refused.
    """

    def __init__(self, mission: MissionBase, planner: Planner, link: VehicleLink) -> None:
        if mission.mission_a is None:
            raise ValueError("an AMP session needs a mission with a mission_a section")
        self.spec: MissionASpec = mission.mission_a
        self.mission = mission
        self.planner = planner
        self.link = link
        self.phases = MissionPhases()
        self.state: VehicleState | None = None
        self.t_amp_start: float | None = None
        self.command: Command | None = None
        self.ticked = False
        self.refusals = 0
        self.rejected_fixes = 0  # vehicle positions ignored as impossibly far out (_sane)
        self._last_refusal = ""
        self._period = 1.0 / mission.cycle_hz
        self._next_tick = math.inf
        self._take_t = math.nan  # when the take was last sent
        self._control_t: float | None = None  # the vehicle's latest report in override
        self.amp_elapsed_s = 0.0  # AMP time so far: the clock's forward steps only
        self._elapsed_t = math.nan  # the vehicle time amp_elapsed_s was last brought up to
        self._dock_t: float | None = None  # the vehicle's latest report at the dock (pre_launch)
        self.joined = False  # the first report showed the vehicle under way: no take-over
        # each kind of report's latest stamp and its time since the latest usable position
        # (kept apart: a stream delivered late, mixed with one on time, would count twice)
        self._heard: dict[type, list[float]] = {}
        self._fix_t = -math.inf  # the time of the latest report with a usable position
        self._nav_timeout = max(NAV_TIMEOUT_S, 3 * self._period)
        self._silent_cycles = 0  # planning cycles in a row without a command ...
        self._silent_s = 0.0  # ... and the vehicle time they span (forward steps)
        self._silent_t = math.nan  # the vehicle time of the latest planning cycle
        self._silent_limit_s = max(NO_OUTPUT_S, 3 * self._period)
        self._launch_base: float | None = None  # the vehicle time the launch counts from
        self._launch_offset = 0.0  # the clock's steps back since the launch, added back
        self._launch_prev_t = math.nan  # the latest state time since the launch
        self._since_launch = 0.0  # the time since the launch at the latest report that counts
        self._granted = False  # the vehicle reported the override since the latest take
        self.clock = PhaseClock()  # what the timeline is stamped on

    @property
    def t(self) -> float:
        """The vehicle's clock at its latest report (0 before any)."""
        return self.state.t_s if self.state is not None else 0.0

    def fire_phase(self, trigger: str, t: float, detail: str = "") -> None:
        """Fire a phase trigger at vehicle time ``t``, stamped on the phase clock
        (:class:`~cptbt.phases.PhaseClock`)."""
        self.phases.fire(trigger, self.clock.stamp(t), detail)

    def _track_clock(self, t: float) -> None:
        """The phase clock at a vehicle report (:class:`~cptbt.phases.PhaseClock`)."""
        if self.t_amp_start is None:
            self.clock.raw(t)
            return
        clock = getattr(getattr(self.planner, "perception", None), "on_clock", None)
        self.clock.track(t, clock(t) if self.in_override and callable(clock) else None)

    @property
    def phase_now(self) -> float:
        """The phase clock at the vehicle's latest report (0 before any)."""
        return self.clock.now

    @property
    def in_override(self) -> bool:
        """Whether the AMP is driving."""
        return self.phases.state == "amp.override"

    def update(self) -> None:
        """Handle every message from the vehicle, fire the triggers due, tick if a cycle is due."""
        self.command = None
        self.ticked = False
        for msg in self.link.receive():
            self._handle(msg)
        if self.state is None:
            return
        t = self.t
        without = max((acc for _, acc in self._heard.values()), default=0.0)
        if self.in_override and without >= self._nav_timeout:
            self.link.send(OverrideRelease())
            self.fire_phase("amp_abort", t, f"no usable navigation for {without:.3g} s of the "
                             f"vehicle's reports (the latest usable position at t = "
                             f"{self._fix_t:g} s)")
            return
        if self.phases.state == "mission_a.waypoints" and self._enable_due():
            self.link.send(OverrideRequest())
            self.fire_phase("amp_enable", t)
            self.t_amp_start = self._take_t = self._elapsed_t = t
            self.amp_elapsed_s = 0.0
            self._control_t = None
            self._granted = False
            self._next_tick = t
        if self.in_override and not self._in_control(t):
            return
        if self.in_override and t + self._period < self._next_tick - 1e-6:
            # The vehicle's clock stepped back (a reset or correction): cycle on from now rather
            # than stay silent until the old schedule comes round again. (The tolerance: a
            # real-time runner updates again at the same vehicle time, which is no step back.)
            log.warning("vehicle clock stepped back to %g s (next cycle was due at %g s): "
                        "cycling on from now", t, self._next_tick)
            self._next_tick = t
        if self.in_override and not self._give_back_due() and t + 1e-9 >= self._next_tick:
            # One tick per due cycle; after a forward jump the schedule restarts from now
            # instead of ticking repeatedly to catch up.
            self._next_tick += self._period
            if self._next_tick <= t:
                self._next_tick = t + self._period
            self._tick(t)
            if not self._give_back_due():
                self._silent_give_back(t)

    # -- internals --------------------------------------------------------------------------
    def _in_control(self, t: float) -> bool:
        """Whether the vehicle has the AMP driving, as its reported mode says; False once the
        AMP has given back for want of it.

        A take the vehicle has not granted is sent again every :data:`RETAKE_S` (a lost
        datagram); a vehicle that has not been in ``override`` for ``watchdog_s`` (it never
        granted the take, or it left the override without saying so) ends the override as its
        own watchdog would (trigger ``watchdog_timeout``): the AMP no longer believes it drives
        a vehicle that follows its own mission.
        """
        assert self.state is not None
        if self.state.mode == "override":
            self._control_t = t
            return True
        since = self._control_t if self._control_t is not None else self.t_amp_start
        assert since is not None
        if t - since >= self.spec.watchdog_s:
            self.link.send(OverrideRelease())
            what = ("did not grant the override" if self._control_t is None
                    else "left the override without saying so")
            # the link's last refusal says why, where it knows (a field re-test read "mode
            # mission" for a vehicle in a failsafe SURFACE the AMP would not take)
            why = (f"; {self._last_refusal}" if self._last_refusal and self._control_t is None
                   else "")
            self.fire_phase("watchdog_timeout", t, f"the vehicle {what}: mode "
                             f"{self.state.mode} for {t - since:g} s{why}")
            return False
        if self._control_t is None and t - self._take_t >= RETAKE_S:
            self.link.send(OverrideRequest())  # the take may have been lost on the way
            self._take_t = t
        return True

    def _sane(self, s: VehicleState) -> VehicleState | None:
        """A state with its faults repaired from the previous one; None if nothing is usable.

        A non-finite clock keeps the previous time; a non-finite position or heading, or a
        position more than :data:`~cptbt.perception.MAX_FIX_OUTSIDE_M` outside the OpArea (a
        review's ``x_m: 1e308`` ended the override as an excursion), keeps the previous fix (the
        planner's perception does the same; the latter are counted in ``rejected_fixes``), so
        one bad report can neither end the override through the 30 m rule nor reach the planner.
        """
        prev = self.state
        fixes: dict[str, Any] = {}
        if (math.isfinite(s.x_m) and math.isfinite(s.y_m)
                and self.planner.op_area.distance_outside(s.x_m, s.y_m) > MAX_FIX_OUTSIDE_M):
            self.rejected_fixes += 1
            # the 1st, 10th, 100th...: a broken navigation feed at 9 Hz had printed a warning a
            # message (38 899 lines in one run, a review); the count is in the summary anyway
            n = self.rejected_fixes
            loud = n == 10 ** int(math.log10(n) + 1e-9)
            log.log(logging.WARNING if loud else logging.DEBUG,
                    "vehicle position (%.3g, %.3g) m is more than %g m outside the OpArea: "
                    "ignored (%d so far)", s.x_m, s.y_m, MAX_FIX_OUTSIDE_M, n)
            if prev is None:
                return None
            fixes = {"x_m": prev.x_m, "y_m": prev.y_m}
        for key in ("t_s", "x_m", "y_m", "heading_deg"):
            if key not in fixes and not math.isfinite(getattr(s, key)):
                log.info("vehicle state with %s = %s ignored for that field", key,
                         getattr(s, key))
                if prev is not None:
                    fixes[key] = getattr(prev, key)
                elif key == "heading_deg":
                    fixes[key] = 0.0
                else:
                    return None
        return dataclasses.replace(s, **fixes) if fixes else s

    def _count(self, msg: object) -> None:
        """Count a report's time toward the navigation timeout (:data:`NAV_TIMEOUT_S`), on the
        clock of its own kind of report."""
        stamp = getattr(msg, "t_s", math.nan)
        if not (isinstance(stamp, float) and math.isfinite(stamp)):
            return
        kind = self._heard.get(type(msg))
        if kind is None:
            self._heard[type(msg)] = [stamp, 0.0]
        elif stamp < kind[0] - CLOCK_STEP_BACK_S:
            if self._fix_t - BACKLOG_S <= stamp <= self._fix_t:
                return  # from before the latest fix: a flushed backlog (a re-test) says nothing
            kind[0] = stamp  # the clock stepped back: on from here
        elif stamp > kind[0]:
            kind[1] += min(stamp - kind[0], MAX_REPORT_STEP_S)
            kind[0] = stamp

    def _handle(self, msg: object) -> None:
        self._count(msg)
        if isinstance(msg, VehicleState):
            state = self._sane(msg)
            if state is None:
                return
            fresh = (state.t_s > self._fix_t  # a clock that moves: a frozen one says nothing
                     or state.t_s < self._fix_t - CLOCK_STEP_BACK_S)  # (a re-test), or anew
            if fresh and state.x_m == msg.x_m and state.y_m == msg.y_m:  # its own position
                self._fix_t = state.t_s
                for kind in self._heard.values():
                    kind[1] = 0.0
            self.state = state
            self._track_clock(state.t_s)
            self._granted |= state.mode == "override"
            self._follow_vehicle_mode(state)
        elif isinstance(msg, FlowSample):
            self.planner.add_flow(msg.t_s, msg.vx_mps, msg.vy_mps)
        elif isinstance(msg, ConcentrationSample):
            if self.in_override:
                self.planner.add_sample(msg.t_s, msg.value)
        elif isinstance(msg, CommandRefused):
            self.refusals += 1
            if self.in_override and msg.reason != self._last_refusal:
                self._last_refusal = msg.reason
                self.fire_phase("command_refused", msg.t_s, msg.reason)
        elif isinstance(msg, OverrideEnded) and msg.reason == "watchdog" and self.in_override:
            # (over MAVLink, any mode change out of GUIDED the AMP did not ask for: a field
            # re-test's pilot read as "no accepted command" while set-points went out)
            self.fire_phase("watchdog_timeout", msg.t_s,
                             "the vehicle left the override: its watchdog (no accepted command "
                             f"for {self.spec.watchdog_s:g} s), a failsafe or a pilot")

    def _follow_vehicle_mode(self, s: VehicleState) -> None:
        ph = self.phases
        if s.mode == "pre_launch" and ph.state == "pre_launch":
            self._dock_t = s.t_s
        # After the launch: the clock's steps back added back; a report that leaps beyond
        # MAX_CLOCK_JUMP_S is passed over (a re-test: one nav stamped 4e9 s took over 140 s early)
        if self._launch_base is not None and s.t_s - self._launch_prev_t <= MAX_CLOCK_JUMP_S:
            if s.t_s < self._launch_prev_t:
                self._launch_offset += self._launch_prev_t - s.t_s
            self._launch_prev_t = s.t_s
            self._since_launch = s.t_s + self._launch_offset - self._launch_base
        if ph.state == "pre_launch" and s.mode != "pre_launch":
            if self._dock_t is None:
                # A session started while the vehicle was under way (a restarted serve, after a
                # give-back made for a reason): it does not know the launch, and taking over
                # at its first report would fly a new search with a fresh time limit (a review).
                self.joined = True
                why = (f"the vehicle was under way (mode {s.mode}) when this session began: it "
                       "did not see the launch, and does not take over; start the AMP before "
                       "the launch")
                log.warning(why)
                self.fire_phase("launch", s.t_s, why)
            else:
                # Counted from the last report at the dock, or from this one if the clock
                # restarted at the launch (a front seat on mission time: the dock's reports on
                # time since boot had put the take-over a boot's length late, a review).
                self._launch_base = self._dock_t if s.t_s >= self._dock_t else s.t_s
                self._launch_prev_t = s.t_s
                self._since_launch = s.t_s - self._launch_base
                self.fire_phase("launch", s.t_s)
        if s.mode == "post_mission" and ph.state != "post_mission":
            self.fire_phase("mission_a_complete", s.t_s)
            return
        if ph.state == "amp.give_back" and s.mode == "mission" and not self._granted:
            # no break-off to return to (a field review's vehicle refused GUIDED)
            self.fire_phase("never_granted", s.t_s)
            return
        if ph.state == "amp.give_back" and s.mode in ("returning", "mission"):
            self.fire_phase("vehicle_returning", s.t_s)
        if ph.state == "return_to_break_off" and s.mode == "mission":
            self.fire_phase("break_off_reached", s.t_s, self._where(s.x_m, s.y_m))

    def _where(self, x: float, y: float) -> str:
        """A planning point as the mission's frame names it (a review read an N-E mission's
        break-off ``(-20.5, 10.0)`` as N, E: it was planning x, y)."""
        if self.mission.frame == "planning":
            return f"at x {x:.1f} m, y {y:.1f} m"
        n, e = self.mission.to_ne(Point(x, y))
        return f"at N {n:.1f} m, E {e:.1f} m"

    def _enable_due(self) -> bool:
        """Whether the take-over is due: ``amp_enable_s`` after the launch, timed from the
        vehicle's last report at the dock (the launch came after it, by at most one report; from
        the first report under way if the clock restarted at the launch), its steps back added
        back: the vehicle's clock need not read 0 at the launch (a review's ArduSub, booted 10
        minutes before the launch, was taken over at once on its time since boot), and a
        ``pre_launch`` reported again under way moves nothing; or on passing waypoint
        ``amp_enable_waypoint``; never in a session that did not see the launch."""
        assert self.state is not None
        if self.joined:
            return False
        if self.spec.amp_enable_s is not None:
            if self._launch_base is None:  # not launched yet
                return False
            return self._since_launch + 1e-9 >= self.spec.amp_enable_s
        assert self.spec.amp_enable_waypoint is not None
        return self.state.waypoints_reached > self.spec.amp_enable_waypoint

    def _give_back_due(self) -> bool:
        """Fire a give-back trigger if one is due; whether the AMP has given back."""
        if not self.in_override:
            return True
        assert self.state is not None and self.t_amp_start is not None
        t = self.state.t_s
        # The time limit counts the clock's forward steps only: measured as t - t_amp_start,
        # a vehicle clock stepped back 900 s gave the AMP 2 700 s against a limit of 1 800 s
        # (a review); a forward jump counts in full (the safe side), but not a leap beyond
        # MAX_CLOCK_JUMP_S, a corrupt or re-based stamp, which counts as a step back does
        # (a review: one nav stamped 4e9 s ended the search on the time limit). Counting
        # goes on from the new time either way, so a clock that did jump keeps counting.
        step = t - self._elapsed_t
        self.amp_elapsed_s += step if 0.0 < step <= MAX_CLOCK_JUMP_S else 0.0
        self._elapsed_t = t
        due = give_back_trigger(
            self.planner.done,
            self.amp_elapsed_s,
            self.mission.time_limit_s,
            self.planner.op_area.distance_outside(self.state.x_m, self.state.y_m),
        )
        if due is None:
            return False
        self.link.send(OverrideRelease())
        self.fire_phase(due[0], t, due[1])
        return True

    def _silent_give_back(self, t: float) -> None:
        """Give back once the planner has had no command for :data:`NO_OUTPUT_S`."""
        before, self._silent_t = self._silent_t, t  # the previous cycle's time, and this one's
        if self.command is not None:
            self._silent_cycles, self._silent_s = 0, 0.0
            return
        step = t - before if math.isfinite(before) else 0.0  # since the last command's cycle
        # (a leap beyond MAX_CLOCK_JUMP_S, a corrupt stamp, counts nothing, as for the time
        # limit: a field re-test's 4e9 had given back "after 4e+09 s")
        self._silent_s += step if 0.0 < step <= MAX_CLOCK_JUMP_S else 0.0
        self._silent_cycles += 1
        if self._silent_s + 1e-9 < self._silent_limit_s:
            return
        self.link.send(OverrideRelease())
        why = getattr(self.planner, "silence", None)
        n = self._silent_cycles
        self.fire_phase("amp_abort", t, f"the planner gave no command for "
                         f"{self._silent_s:.3g} s ({n} planning cycle{'s' * (n != 1)})"
                         + (f": {why()}" if callable(why) else ""))

    def _tick(self, t: float) -> None:
        assert self.state is not None
        s = self.state
        self.planner.set_pose(s.x_m, s.y_m, s.heading_deg)
        cmd = self.planner.tick(t)
        self.command, self.ticked = cmd, True
        if cmd is not None:
            self.link.send(HeadingSpeedCommand(cmd.heading_deg, cmd.speed_mps,
                                               self.spec.amp_depth_m))
