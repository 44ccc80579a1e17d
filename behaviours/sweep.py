"""A sweep of the OpArea across the flow: the search for a further source while nothing
points anywhere.

A plume runs down-flow of its source, so a leg flown straight across the flow, wall to wall,
crosses the plume of every source up-flow of it. :class:`CrossFlowSweep` lays *lanes* across the
flow, ``spacing_m`` apart along it, in a frame fixed when the sweep starts (where the vehicle is,
the flow estimate of that moment): in any flow direction, oblique to the OpArea or not, each
lane is the part of a line across the flow inside the OpArea shrunk by ``inset_m``, and the
vehicle flies one lane end to end, then to the near end of the next, lane after lane down-flow;
at the down-flow end of the OpArea it goes on up-flow of the first lane, and when no lane is
left either way the sweep starts again from where the vehicle is, its lanes half-way between
the last pass's. Every waypoint lies inside the shrunk OpArea, which is convex, so the straight
path between two does too; the turn at a lane's end swings up to about a turn's diameter
beyond it, so with an inset of 10 m and REMUS's 7.5-m turning radius it can cross the wall by a
few metres (measured: up to 7 m in an oblique flow), where safety takes over. Lanes no longer
than ``min_lane_m`` (a turn's diameter: the vehicle could only circle their ends) are not
flown. Lanes lie at most half the shrunk OpArea's extent along the flow apart (but not closer
than ``min_lane_m``), so a pass has two lanes or more whatever ``spacing_m`` (a spacing longer
than the OpArea had the vehicle fly one lane for the rest of the mission). Where no lane
across the flow is long enough (a corridor along the flow narrower than a turn plus the
insets), the lanes run along the flow instead, spaced across it: in such a corridor a lane
along its middle runs through every plume (the search had headed for the map's most
probable cell, which before any unexplained plume is one at the down-flow wall no miss can
rule out, and loitered there, outside the OpArea for a third of the mission).

Readings chosen: the frame is not turned with the flow estimate during a sweep (an estimate
wandering by 10-20 degrees moved a 500-m leg re-planned from it by 90-170 m along the flow and
swept the same water again); a lane still crosses a plume whose flow has turned that much.
"""

from __future__ import annotations

import math

from cptbt.angles import unit
from cptbt.frames import OpArea
from cptbt.types import Point


class CrossFlowSweep:
    """The waypoints of a cross-flow sweep, one at a time (:meth:`target`).

    Args:
        spacing_m: how far along the flow one lane lies from the next.
        inset_m: the lanes' ends are kept this far inside the walls (limited to half the
            OpArea's width on each axis, as :meth:`~cptbt.frames.OpArea.clamp`).
        arrive_m: a waypoint counts as reached within this.
        min_lane_m: lanes no longer than this (nor than ``arrive_m``) are not flown.
    """

    def __init__(self, spacing_m: float, inset_m: float, arrive_m: float,
                 min_lane_m: float = 0.0) -> None:
        self.spacing_m, self.inset_m, self.arrive_m = spacing_m, inset_m, arrive_m
        self.min_lane_m = max(min_lane_m, arrive_m)
        self.waypoint: Point | None = None
        self.origin: Point | None = None  # the frame: where the sweep started
        self.flow = (1.0, 0.0)  # and the flow's unit vector then
        self.lane = 0.0  # the lane under way: its distance down-flow of the origin
        self.side = 1.0  # the end of the lane the vehicle flies to (+1: the +cross end)
        self.across = False  # the waypoint is the far end of a lane (else its near end)
        self.step = 1.0  # +1: the next lane is down-flow; -1: up-flow
        self.swept = (0.0, 0.0)  # the lanes flown span this, along the flow
        self.legs = 0  # lanes flown (started)
        self.gap = spacing_m  # the lanes' spacing in this frame (at most half the extent)

    def reset(self) -> None:
        """Start again from wherever the vehicle is next asked for (a declaration, the end of
        a spell of heading for the map): a new frame, down-flow first."""
        self.waypoint = self.origin = None

    def target(self, here: Point, flow_deg: float, area: OpArea) -> Point | None:
        """The waypoint to fly to from ``here`` (the flow toward ``flow_deg`` if a new sweep
        starts); the next once the present one is reached. None when the shrunk OpArea leaves
        no lane longer than the arrival radius anywhere along the flow."""
        if self.waypoint is not None and here.distance_to(self.waypoint) > self.arrive_m:
            return self.waypoint
        if self.origin is None or self.waypoint is None:
            nxt = self._start(here, flow_deg, area)
        elif not self.across:  # at a lane's near end: fly it to the far end
            self.side = -self.side
            nxt = self._end(area, self.lane, self.side)
            self.across, self.legs = True, self.legs + 1
        else:  # at a lane's far end: on to the near end of the next lane
            nxt = self._next_lane(area)
            if nxt is None:  # none left either way: sweep again, between the last lanes
                nxt = self._start(here, flow_deg, area, 0.5 * self.gap)
        self.waypoint = nxt
        return nxt

    # -- the lanes -----------------------------------------------------------------------
    def _start(self, here: Point, flow_deg: float, area: OpArea,
               offset_m: float = 0.0) -> Point | None:
        """A new frame at ``here`` (its nearest point inside the inset): fly the lane through
        it toward its longer half, or with ``offset_m`` (a pass after the first) or no lane
        through it, go to the nearest lane's nearer end first."""
        self.step = 1.0
        # across the flow; where no lane across it is long enough (a corridor along the flow),
        # along it: such a lane runs through every plume in the corridor; (a pass between the
        # last's lanes, or, where none lies between them, the first's); from where the vehicle
        # is, or, where no lane passes there (a corner of a corridor in a flow a little
        # oblique to it), from the OpArea's centre
        centre = area.centre
        reach = math.hypot(area.xmax - area.xmin, area.ymax - area.ymin)
        for origin in (area.clamp(here.x, here.y, self.inset_m), centre):
            self.origin = origin
            for turn, offset in ((0.0, offset_m), (90.0, offset_m), (0.0, 0.0), (90.0, 0.0)):
                self.flow = unit(flow_deg + turn)
                self.gap = min(self.spacing_m, max(0.5 * self._extent(area), self.min_lane_m))
                n = int(reach / self.gap) + 2 if self.gap > 0 else 0
                lanes = sorted((offset + j * self.gap for j in range(-n, n + 1)),
                               key=lambda a: (abs(a), -a))  # nearest first, down-flow first
                for lane in lanes:
                    span = self._span(area, lane)
                    if span is None:
                        continue
                    lo, hi = span
                    self.lane, self.swept = lane, (lane, lane)
                    if lane == 0.0 and origin is not centre:  # on it: toward its longer half
                        self.side = 1.0 if hi >= -lo else -1.0
                        self.across, self.legs = True, self.legs + 1
                    else:  # to the lane's nearer end first
                        self.side = 1.0 if abs(hi) <= abs(lo) else -1.0
                        self.across = False
                    return self._end(area, lane, self.side)
        self.origin = None
        return None

    def _insets(self, area: OpArea) -> tuple[float, float]:
        """The inset on each axis, limited to half the OpArea's width there."""
        return (min(self.inset_m, 0.5 * (area.xmax - area.xmin)),
                min(self.inset_m, 0.5 * (area.ymax - area.ymin)))

    def _extent(self, area: OpArea) -> float:
        """How far the shrunk OpArea reaches along the sweep's flow direction."""
        fx, fy = self.flow
        ix, iy = self._insets(area)
        return ((area.xmax - area.xmin - 2 * ix) * abs(fx)
                + (area.ymax - area.ymin - 2 * iy) * abs(fy))

    def _next_lane(self, area: OpArea) -> Point | None:
        """Move to the next lane not yet flown, down-flow while there is one, then up-flow of
        the first; its near end (the side the vehicle is on), or None if none is left."""
        lo, hi = self.swept
        for step in (self.step, -self.step):
            lane = hi + self.gap if step > 0 else lo - self.gap
            if self._span(area, lane) is not None:
                self.step, self.lane = step, lane
                self.swept = (min(lo, lane), max(hi, lane))
                self.across = False
                return self._end(area, lane, self.side)
        return None

    def _span(self, area: OpArea, lane: float) -> tuple[float, float] | None:
        """The lane's extent across the flow inside the shrunk OpArea, as signed distances
        from its point on the origin's flow line; None if not longer than ``min_lane_m``."""
        assert self.origin is not None
        fx, fy = self.flow
        nx, ny = -fy, fx  # across the flow
        px, py = self.origin.x + lane * fx, self.origin.y + lane * fy
        ix, iy = self._insets(area)
        lo, hi = -math.inf, math.inf
        for p, n, a, b in ((px, nx, area.xmin + ix, area.xmax - ix),
                           (py, ny, area.ymin + iy, area.ymax - iy)):
            if abs(n) < 1e-12:
                if not a - 1e-9 <= p <= b + 1e-9:
                    return None
                continue
            s1, s2 = (a - p) / n, (b - p) / n
            lo, hi = max(lo, min(s1, s2)), min(hi, max(s1, s2))
        if hi - lo <= self.min_lane_m:
            return None
        return lo, hi

    def _end(self, area: OpArea, lane: float, side: float) -> Point:
        """The lane's end on ``side`` (+1: the end toward ``(-fy, fx)``, -1: the other)."""
        assert self.origin is not None
        span = self._span(area, lane)
        assert span is not None
        s = span[1] if side > 0 else span[0]
        fx, fy = self.flow
        return Point(self.origin.x + lane * fx - s * fy, self.origin.y + lane * fy + s * fx)
