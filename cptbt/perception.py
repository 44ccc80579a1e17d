"""Perception shared by every behaviour (SPEC §2).

Samples arrive faster than the planner cycles; :class:`Perception` accumulates them and, once per
cycle, condenses them into an immutable :class:`~cptbt.types.Percept`. Faulty samples (NaN,
infinite) are dropped, so a sensor fault degrades to "no detection" instead of crashing anything.
"""

from __future__ import annotations

import math
from collections import deque

from cptbt.frames import OpArea
from cptbt.types import Detection, FlowEstimate, Percept, Point, Pose

TIME_EPS_S = 1e-9
"""Tolerance on time comparisons, far below any cycle period."""


class Perception:
    """Turns raw samples into one :class:`Percept` per planning cycle.

    Args:
        op_area: detections outside it are ignored (TRO V).
        threshold: a cycle's concentration above this is a detection (TRO Table I: 0.20).
        lambda_s: contact is lost after this long without a detection (TRO Table I: 8.5 s).
        flow_window_s: the flow estimate is the vector mean over this window (TRO: 100 s).
    """

    def __init__(
        self, op_area: OpArea, threshold: float, lambda_s: float, flow_window_s: float = 100.0
    ) -> None:
        self.op_area = op_area
        self.threshold = threshold
        self.lambda_s = lambda_s
        self.flow_window_s = flow_window_s
        self.reset()

    def reset(self) -> None:
        """Forget everything: a new mission."""
        self._cycle_max = -math.inf
        self._flows: deque[tuple[float, float, float]] = deque()
        self._sum_vx = 0.0
        self._sum_vy = 0.0
        self._pose = Pose(math.nan, math.nan, 0.0)
        self._last: Detection | None = None
        self._first_t: float | None = None
        self._was_in_plume = False
        self._contacts = 0
        self._lost: tuple[Point, ...] = ()
        self.latest: Percept | None = None

    def add_sample(self, t: float, concentration: float) -> None:
        """One fluorometer sample; NaN or infinite values (sensor faults) are ignored."""
        if math.isfinite(concentration) and concentration > self._cycle_max:
            self._cycle_max = concentration

    def add_flow(self, t: float, vx: float, vy: float) -> None:
        """One flow-over-ground sample (planning frame, m/s); non-finite samples are ignored."""
        if not (math.isfinite(vx) and math.isfinite(vy)):
            return
        self._flows.append((t, vx, vy))
        self._sum_vx += vx
        self._sum_vy += vy

    def set_pose(self, pose: Pose) -> None:
        """The latest navigation estimate; a non-finite one keeps the previous estimate."""
        if math.isfinite(pose.x) and math.isfinite(pose.y):
            heading = pose.heading_deg if math.isfinite(pose.heading_deg) else 0.0
            self._pose = Pose(pose.x, pose.y, heading)

    def _flow(self, t: float) -> FlowEstimate | None:
        while self._flows and self._flows[0][0] <= t - self.flow_window_s:
            _, vx, vy = self._flows.popleft()
            self._sum_vx -= vx
            self._sum_vy -= vy
        if not self._flows:
            # Keep the last known estimate rather than forgetting the flow in a long dropout.
            return self.latest.flow if self.latest is not None else None
        n = len(self._flows)
        return FlowEstimate(self._sum_vx / n, self._sum_vy / n)

    def cycle(self, t: float) -> Percept:
        """Close the current cycle at time ``t`` and return its percept."""
        pose = self._pose
        conc = self._cycle_max if self._cycle_max > -math.inf else math.nan
        self._cycle_max = -math.inf
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
