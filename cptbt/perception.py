"""Perception shared by every behaviour (SPEC §2).

Samples arrive faster than the planner cycles; :class:`Perception` accumulates them and, once per
cycle, condenses them into an immutable :class:`~cptbt.types.Percept`. Faulty samples (NaN,
infinite) are dropped, so a sensor fault degrades to "no detection" instead of crashing anything.
"""

from __future__ import annotations

import logging
import math
from collections import deque
from typing import Literal

from pydantic import BaseModel, ConfigDict, Field

from cptbt.frames import OpArea
from cptbt.types import Detection, FlowEstimate, Percept, Point, Pose

log = logging.getLogger(__name__)

TIME_EPS_S = 1e-9
"""Tolerance on time comparisons, far below any cycle period."""

STUCK_FLOOR = 1e-12
"""Readings no farther from zero than this are never taken for a stuck sensor: a low-pass
filter's output decays to the smallest float (5e-324) in clean water and stays there exactly."""

LATE_SAMPLE_S = 5.0
"""A fluorometer sample stamped more than this (or a planning period, if longer) before the
previous cycle is late: placed where the vehicle is now, its plume would be 7.5 m or more from
where it was sampled, at REMUS speed. Not less: a fluorometer whose clock runs a few seconds
behind the navigation's would have every sample dropped, the AMP searching blind (a re-test's
3 s), where a few metres of misplacement still declared within 6 m."""

MAX_CLOCK_JUMP_S = 3600.0
"""A cycle stamped more than this after the previous one is taken as a corrupt or re-based
stamp (corrected as a step back is), not as that much elapsed time: no mission runs this long
without a cycle."""

MAX_STAMP_S = 1e12
"""A time stamp larger than this in magnitude (some 31,700 years) is taken as a missing one: its
float spacing is coarse enough to break the planner's timers (a review: a *first* stamp of 1e20
froze the clock, 1e20 + 1 == 1e20, and one of 1e17 ran it 16 times fast, since the leap check
needs an earlier cycle). Epoch seconds (1.7e9) keep sub-microsecond spacing."""

SILENT_SENSOR_S = 10.0
"""A fluorometer with no reading this long (since its last one) is warned of once an outage:
the planner then sees no plume, and clean water cannot be told from a dead sensor (a field
review: samples cut at t = 200 s, 780 cycles later the run timed out and nothing said so)."""


def usable_stamp(t: float) -> bool:
    """Whether a time stamp can be elapsed time: finite and within :data:`MAX_STAMP_S`."""
    return math.isfinite(t) and abs(t) <= MAX_STAMP_S


MAX_FIX_OUTSIDE_M = 1e6
"""A navigation fix more than this outside the OpArea (1000 km: beyond any AUV mission's reach
of its area, and the planning frame's flat-earth geometry) is a broken message, not a position."""


class PerceptionSettings(BaseModel):
    """The ``perception:`` section of a mission: how raw samples become percepts (SPEC §2).

    These settings are shared by every behaviour, so they are declared once here rather than
    on any one behaviour's entry.
    """

    model_config = ConfigDict(frozen=True, extra="forbid", allow_inf_nan=False)

    threshold: float = Field(
        default=0.20, ge=0, description="A cycle's concentration above this is a detection "
        "(TRO Table I: 0.20)"
    )
    lambda_s: float = Field(
        default=8.5, gt=0, le=3600, description="λ: contact is lost after this long without a "
        "detection, s (TRO Table I: 8.5; AB Table 3: 1; OMAE counter-turning T_w: 17)"
    )
    flow_window_s: float = Field(
        default=100.0, gt=0, le=3600, description="The flow estimate is the vector mean over "
        "this window, s (TRO IV: 100; AB's searcher senses the local flow: a few seconds)"
    )
    flow_source: Literal["adcp", "none"] = Field(
        default="adcp", description="'adcp': flow over ground from the ADCP and the vehicle's "
        "velocity (TRO IV); 'none': the vehicle has no flow sensor (behaviours that steer by "
        "the flow cannot be used)"
    )
    stuck_after_s: float | None = Field(
        default=3.0, gt=0, le=3600, description="A fluorometer giving exactly the same reading "
        "away from zero for this long is stuck: its samples are dropped (no observation) until the "
        "reading changes. A working sensor's noise and a plume's filaments make exact repeats "
        "rare; a stuck reading above the threshold read as plume (the vehicle tracked it to the "
        "up-flow wall and declared there), one below it as clean water. A reading stuck at "
        "zero cannot be told from clean water. None: never, s"
    )
    max_flow_speed_mps: float = Field(
        default=5.0, gt=0, le=100, description="Flow samples faster than this are impossible "
        "(sensor faults, fill values) and ignored, m/s"
    )


class Perception:
    """Turns raw samples into one :class:`Percept` per planning cycle.

    Robust to the faults a vehicle's sensors and clock produce (issue 9):

    - concentration: NaN or infinite samples are dropped (a fault degrades to "no detection"),
      and so are the samples of a reading stuck away from zero (``stuck_after_s``: the same
      value that long, to the last bit, more than :data:`STUCK_FLOOR` from zero) until it
      changes; a cycle with no sample left has a NaN
      concentration, which no behaviour takes for plume or for clean water (such cycles are
      counted, ``blind_cycles``, and an outage of :data:`SILENT_SENSOR_S` is warned of); a
      sample stamped
      more than :data:`LATE_SAMPLE_S` (or the nominal period, if longer) before the previous
      cycle (a late delivery: its plume was where the vehicle no longer is) is dropped and
      counted (``late_samples``), unless that cycle finds the clock stepped back;
    - flow: non-finite samples and samples faster than ``max_flow_speed_mps`` (fill values such
      as 9.97e36, spikes) are dropped; the windowed vector mean is summed afresh each cycle with
      :func:`math.fsum`, so no sample outlives its window and no running sum loses precision;
    - position: a non-finite fix keeps the previous estimate;
    - time: the planner runs on its own monotonic clock. A cycle whose time stamp is not finite
      (or beyond :data:`MAX_STAMP_S`, the first cycle's too), repeats, or steps back is taken
      as one nominal period after the previous cycle, and later time stamps are shifted by the
      same amount (a clock step is a correction, not elapsed time), so timers never run
      backwards and the planner is never silenced; a forward jump is
      elapsed time and ages every timer, up to :data:`MAX_CLOCK_JUMP_S`: a longer one is a
      corrupt or re-based stamp, corrected as a step back is.

    Args:
        op_area: detections outside it are ignored (TRO V).
        settings: threshold, λ, flow window and flow gate (the mission's ``perception:``).
        nominal_period_s: the planning period (the mission's ``1 / cycle_hz``), what a cycle
            counts for until two usable stamps have measured it (a review: with every stamp
            unusable, 10-Hz cycles had counted 1 s each).
    """

    def __init__(self, op_area: OpArea, settings: PerceptionSettings | None = None,
                 nominal_period_s: float = 1.0) -> None:
        self.op_area = op_area
        self.nominal_period_s = nominal_period_s
        # A sample stamped more than this before the previous cycle is late: the nominal
        # period, or LATE_SAMPLE_S if longer (the measured period, up to 60 s, had dropped a
        # 10-Hz mission's samples at 0.25 s of latency and kept a minute-old one: a review).
        self.late_after_s = max(LATE_SAMPLE_S, nominal_period_s)
        self.settings = settings or PerceptionSettings()
        self.threshold = self.settings.threshold
        self.lambda_s = self.settings.lambda_s
        self.flow_window_s = self.settings.flow_window_s
        self.reset()

    def reset(self) -> None:
        """Forget everything: a new mission."""
        self._cycle_max = -math.inf
        self._flows: deque[tuple[float, float, float]] = deque()
        self._pose = Pose(math.nan, math.nan, 0.0)
        self._last: Detection | None = None
        self._first_t: float | None = None
        self._was_in_plume = False
        self._contacts = 0
        self._lost: tuple[Point, ...] = ()
        self._t_prev = -math.inf
        self._offset = 0.0
        self._period = self.nominal_period_s
        self.rejected_flow_samples = 0
        self.clock_corrections = 0
        self.stuck_samples = 0
        self.missing_samples = 0  # fluorometer samples not finite (dropouts)
        self.rejected_fixes = 0  # navigation fixes ignored as impossibly far out
        self.late_samples = 0  # fluorometer samples stamped well before the previous cycle
        self._held: list[tuple[float, float]] = []  # such samples (stamp, value) of this cycle,
        # held until it closes
        self._run_value = math.nan  # the latest sample, and since when it has read so
        self._run_t = math.nan
        self._flow_held = False  # the flow estimate is held for want of samples (said once)
        self.flow_held_cycles = 0  # cycles planned on a held flow estimate
        self.blind_cycles = 0  # cycles with no fluorometer reading (_note_reading)
        self._read_t = math.nan  # the latest cycle with a reading (NaN: none yet)
        self._start_t = math.nan  # the first cycle without one, before any reading
        self._early = 0  # cycles without a reading before the first, not yet counted
        self._silent = False  # the outage under way has been warned of
        self._outages = 0  # outages of SILENT_SENSOR_S so far
        self.latest: Percept | None = None

    def faults(self) -> dict[str, int]:
        """What the perception has dropped or corrected so far (the run summary's sensor
        faults): fluorometer samples missing (not finite) or dropped as stuck or late, flow
        samples and navigation fixes rejected, clock steps back corrected, the cycles planned
        on a held flow estimate (no usable flow sample in the window), and the cycles with no
        fluorometer reading (a dropout, or a silent sensor; :meth:`_note_reading`)."""
        return {"missing_samples": self.missing_samples, "stuck_samples": self.stuck_samples,
                "late_samples": self.late_samples, "rejected_fixes": self.rejected_fixes,
                "rejected_flow_samples": self.rejected_flow_samples,
                "clock_corrections": self.clock_corrections,
                "flow_held_cycles": self.flow_held_cycles, "blind_cycles": self.blind_cycles}

    def on_clock(self, t: float) -> float:
        """A vehicle time stamp on the planner's clock (shifted by the steps back so far): the
        time the measures of a run read."""
        return self._clock(t)

    def _clock(self, t: float) -> float:
        """A sample's time on the planner's clock (the vehicle's, shifted by past steps back)."""
        if not usable_stamp(t):
            return self._t_prev if math.isfinite(self._t_prev) else 0.0
        return t + self._offset

    def add_sample(self, t: float, concentration: float) -> None:
        """One fluorometer sample; NaN or infinite values and a reading stuck away from zero
        (sensor faults: the class docstring) are ignored."""
        if not math.isfinite(concentration):
            self.missing_samples += 1
            return  # a dropout between two frozen readings does not unfreeze the sensor
        if (math.isfinite(self._t_prev) and usable_stamp(t)
                and self._clock(t) < self._t_prev - self.late_after_s - TIME_EPS_S):
            # Taken well before the previous cycle: placed at the present pose it would be a
            # detection where the vehicle is not (a review's samples 20 s late declared a
            # source 15.7 m off, nothing said). Held aside until the next cycle says whether
            # the clock stepped back instead (a diff review: a step back had dropped the next
            # cycle's samples, called late): then they count; else they are dropped, counted.
            self._held.append((t, concentration))
            return
        self._take(t, concentration)

    def _take(self, t: float, concentration: float) -> None:
        """A finite sample on time: dropped if stuck, else into this cycle's maximum."""
        if self.settings.stuck_after_s is not None and self._stuck(self._clock(t), concentration):
            self.stuck_samples += 1
            level = logging.INFO if self.stuck_samples == 1 else logging.DEBUG
            log.log(level, "fluorometer reading %g since t = %g s: stuck, samples dropped until "
                    "it changes (%d so far)", concentration, self._run_t, self.stuck_samples)
            return
        if concentration > self._cycle_max:
            self._cycle_max = concentration

    def _stuck(self, t: float, value: float) -> bool:
        """Whether this sample repeats a reading away from zero held ``stuck_after_s`` or longer
        (``t`` on the planner clock)."""
        limit = self.settings.stuck_after_s
        assert limit is not None
        if value != self._run_value or abs(value) <= STUCK_FLOOR:
            self._run_value, self._run_t = value, t
            return False
        return t - self._run_t >= limit - TIME_EPS_S

    def add_flow(self, t: float, vx: float, vy: float) -> None:
        """One flow-over-ground sample (planning frame, m/s); impossible samples are ignored."""
        if self.settings.flow_source == "none":
            return
        if not (math.isfinite(vx) and math.isfinite(vy)) or (
            math.hypot(vx, vy) > self.settings.max_flow_speed_mps
        ):
            self.rejected_flow_samples += 1
            level = logging.INFO if self.rejected_flow_samples == 1 else logging.DEBUG
            log.log(level, "flow sample (%g, %g) m/s at t = %g s ignored: not finite or faster "
                    "than %g m/s (%d so far)", vx, vy, t, self.settings.max_flow_speed_mps,
                    self.rejected_flow_samples)
            return
        self._flows.append((self._clock(t), vx, vy))

    def set_pose(self, pose: Pose) -> None:
        """The latest navigation estimate; a non-finite one, or one more than
        :data:`MAX_FIX_OUTSIDE_M` outside the OpArea (a fill value, a corrupt message: a review's
        ``x_m: 1e308`` ended the override as an excursion), keeps the previous estimate."""
        if not (math.isfinite(pose.x) and math.isfinite(pose.y)):
            return
        if self.op_area.distance_outside(pose.x, pose.y) > MAX_FIX_OUTSIDE_M:
            self.rejected_fixes += 1
            log.info("navigation fix (%.3g, %.3g) m is more than %g m outside the OpArea: "
                     "ignored (%d so far)", pose.x, pose.y, MAX_FIX_OUTSIDE_M,
                     self.rejected_fixes)
            return
        # a non-finite heading keeps the previous one (0 had turned the pose's heading north)
        heading = (pose.heading_deg if math.isfinite(pose.heading_deg) else
                   self._pose.heading_deg if math.isfinite(self._pose.heading_deg) else 0.0)
        self._pose = Pose(pose.x, pose.y, heading)

    @property
    def pose(self) -> Pose:
        """The navigation estimate the planner uses (NaN before the first usable fix)."""
        return self._pose

    def _flow(self, t: float) -> FlowEstimate | None:
        lo, hi = t - self.flow_window_s, t + self.flow_window_s
        while self._flows and self._flows[0][0] <= lo:
            self._flows.popleft()
        # Samples time-stamped after this cycle (a clock that stepped back) still count, but
        # not one a whole window ahead (a corrupt stamp): at the deque's front it had kept
        # every later sample in the window for good (a review: one sample stamped 4e9 s made
        # the 100-s mean an all-time mean, 2 991 samples, 26 degrees off after a turn).
        if any(not lo < f[0] <= hi for f in self._flows):
            kept = deque(f for f in self._flows if lo < f[0] <= hi)
            self.rejected_flow_samples += sum(f[0] > hi for f in self._flows)
            self._flows = kept
        if not self._flows:
            # Keep the last known estimate rather than forgetting the flow in a long dropout,
            # and say so once an outage (a field re-test: a current sensor dead after the
            # take-over went unnoticed for 920 s of planning on the held average)
            held = self.latest.flow if self.latest is not None else None
            if held is not None and not self._flow_held:
                log.warning("no flow sample for %g s (t = %g s on the planner clock): the flow "
                            "estimate is the last one, held until samples come back",
                            self.flow_window_s, t)
            self._flow_held = held is not None
            self.flow_held_cycles += held is not None
            return held
        self._flow_held = False
        n = len(self._flows)
        return FlowEstimate(
            math.fsum(f[1] for f in self._flows) / n, math.fsum(f[2] for f in self._flows) / n
        )

    def _cycle_time(self, t: float) -> float:
        """This cycle's time on the monotonic planner clock (see the class docstring)."""
        usable = usable_stamp(t)
        now = t + self._offset if usable else -math.inf
        # A leap beyond MAX_CLOCK_JUMP_S is not elapsed time but a corrupt or re-based stamp:
        # one of 1e300 had frozen the clock (1e300 + 1 == 1e300) and held a detection "now"
        # for good (a review). It is corrected as a step back is; later stamps shift by it.
        leap = math.isfinite(self._t_prev) and now - self._t_prev > MAX_CLOCK_JUMP_S
        if now <= self._t_prev or leap:  # not finite, repeated, stepped back or leapt ahead
            target = self._t_prev + self._period if math.isfinite(self._t_prev) else 0.0
            if usable:
                self._offset += target - now
            self.clock_corrections += 1
            why = ("is not after the previous cycle" if usable else
                   f"is not a usable time stamp (not finite, or beyond {MAX_STAMP_S:g} s)")
            log.info("cycle time %g s %s (%g s on the planner clock): taken as %g s", t, why,
                     self._t_prev, target)
            now = target
        elif math.isfinite(self._t_prev):
            self._period = min(now - self._t_prev, 60.0)
        self._t_prev = now
        return now

    def _note_reading(self, t: float, conc: float) -> None:
        """Count a cycle with no reading, and warn once an outage of :data:`SILENT_SENSOR_S`;
        say when readings come back. Before the first reading, cycles count only once the
        sensor is that late (a first cycle before the first sample is no fault)."""
        if math.isfinite(conc):
            if self._silent:
                log.log(self._outage_level(), "fluorometer readings back at t = %.1f s, after "
                        "%.1f s without one", t, t - self._read_t)
            self._read_t, self._silent = t, False
            return
        if math.isnan(self._read_t):  # none yet: a sensor starting counts once it is late
            self._start_t = t if math.isnan(self._start_t) else self._start_t
            self._early += 1
            since = self._start_t
            if t - since < SILENT_SENSOR_S:
                return
            self.blind_cycles += self._early
            self._early = 0
        else:
            self.blind_cycles += 1
            since = self._read_t
        if not self._silent and t - since >= SILENT_SENSOR_S:
            self._silent = True
            self._outages += 1
            log.log(self._outage_level(), "no fluorometer reading kept for %.1f s (t = %.1f s on "
                    "the planner clock; none sent, or each dropped as missing, stuck or late: "
                    "outage %d; said at the 1st, 10th, 100th ..., each with -vv): the planner "
                    "sees no plume, and cannot tell clean water from a silent sensor",
                    t - since, t, self._outages)

    def _outage_level(self) -> int:
        """WARNING for the 1st, 10th, 100th ... outage and its end, DEBUG for the others (an
        attacker's sensor off 11 s and on 11 s had printed 148 lines in one run)."""
        n = self._outages
        return logging.WARNING if n > 0 and 10 ** int(math.log10(n)) == n else logging.DEBUG

    def cycle(self, t: float) -> Percept:
        """Close the current cycle at vehicle time ``t`` and return its percept.

        The percept's ``t`` is the planner clock (equal to ``t`` unless the clock stepped back).
        """
        corrected = self.clock_corrections
        t = self._cycle_time(t)
        if self._held:
            held, self._held = self._held, []
            if self.clock_corrections > corrected:  # the clock stepped back: on the new clock,
                for ts, value in held:  # each through the stuck check, in order (a review)
                    self._take(ts, value)
            else:
                before = self.late_samples
                self.late_samples += len(held)
                n = self.late_samples
                # said the first time and at each power of ten passed, not every cycle
                loud = before == 0 or int(math.log10(n)) > int(math.log10(before))
                log.log(logging.WARNING if loud else logging.DEBUG,
                        "%d fluorometer sample%s (the latest stamped %g s) reached the planner "
                        "after %s cycle: dropped as late (%d so far)", len(held),
                        "s" * (len(held) != 1), held[-1][0],
                        "its" if len(held) == 1 else "their", n)
        pose = self._pose
        conc = self._cycle_max if self._cycle_max > -math.inf else math.nan
        self._cycle_max = -math.inf
        self._note_reading(t, conc)
        located = math.isfinite(pose.x)
        in_area = located and self.op_area.contains(pose.x, pose.y)
        detected = in_area and conc > self.threshold
        if detected:
            if not self._was_in_plume:
                self._contacts += 1
                self._first_t = t
            self._last = Detection(t, pose.x, pose.y)
        # A nanosecond of slack: at 10 Hz, 2.2 - 1.2 = 1.0000000000000002 > lambda_s = 1.0 would
        # lose contact one cycle early on float time stamps.
        in_plume = self._last is not None and t - self._last.t <= self.lambda_s + TIME_EPS_S
        if self._was_in_plume and not in_plume and self._last is not None:
            self._lost = (*self._lost, self._last.point)
        self._was_in_plume = in_plume
        self.latest = Percept(
            t=t,
            pose=pose,
            concentration=conc,
            detected=detected,
            flow=self._flow(t),
            last_detection=self._last,
            first_detection_t=self._first_t,
            in_plume=in_plume,
            contact_count=self._contacts,
            lost_contacts=self._lost,
            in_op_area=in_area,
        )
        return self.latest
