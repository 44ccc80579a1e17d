"""A sweep of the OpArea across the flow: the search for a further source while nothing
points anywhere.

A plume runs down-flow of its source, so a leg flown straight across the flow, wall to wall,
crosses the plume of every source up-flow of it. :class:`CrossFlowSweep` flies such legs,
stepping ``spacing_m`` along the flow between them (down-flow first, reversing at the walls),
each planned on the flow estimate of the moment, and keeps ``inset_m`` inside the walls (the
turns then stay inside, where safety leaves the vehicle alone).
"""

from __future__ import annotations

from cptbt.angles import unit
from cptbt.behaviours.upflow_check import room
from cptbt.frames import OpArea
from cptbt.types import Point


class CrossFlowSweep:
    """The waypoints of a cross-flow sweep, one at a time (:meth:`target`).

    Args:
        spacing_m: how far along the flow one cross leg lies from the last.
        inset_m: the legs' ends are kept this far inside the walls.
        arrive_m: a waypoint counts as reached within this.
    """

    def __init__(self, spacing_m: float, inset_m: float, arrive_m: float) -> None:
        self.spacing_m, self.inset_m, self.arrive_m = spacing_m, inset_m, arrive_m
        self.waypoint: Point | None = None
        self.across = False  # the waypoint ends a leg across the flow (else a step along it)
        self.side = 1.0  # which way across the flow the last cross leg went
        self.step = 1.0  # +1: the next step goes down-flow, -1: up-flow
        self.legs = 0  # cross legs started

    def reset(self) -> None:
        """Start again from wherever the vehicle is (a declaration, a contact in between)."""
        self.waypoint = None

    def target(self, here: Point, flow_deg: float, area: OpArea) -> Point | None:
        """The waypoint to fly to from ``here`` (the flow toward ``flow_deg``); the next once the
        present one is reached. None when the OpArea, less the inset, leaves no room to move
        in any of the four directions."""
        if self.waypoint is not None and here.distance_to(self.waypoint) > self.arrive_m:
            return self.waypoint
        fx, fy = unit(flow_deg)
        if self.waypoint is None or not self.across:
            # a cross leg: the first toward the side with more room, then alternating
            sides = (-self.side, self.side) if self.waypoint is not None else \
                tuple(sorted((1.0, -1.0), key=lambda s: -room(area, here, -s * fy, s * fx,
                                                               self.inset_m)))
            nxt = self._leg(here, fx, fy, sides, across=True, area=area)
        else:
            nxt = self._leg(here, fx, fy, (self.step, -self.step), across=False, area=area)
        if nxt is None:  # boxed in: try the other kind of move before giving up
            nxt = self._leg(here, fx, fy, (1.0, -1.0), across=not self.across, area=area)
        self.waypoint = nxt
        return nxt

    def _leg(self, here: Point, fx: float, fy: float, signs: tuple[float, ...], across: bool,
             area: OpArea) -> Point | None:
        """The end of the first move, in the given senses, that has room to go farther than
        the arrival radius: across the flow to the wall, or ``spacing_m`` along it."""
        for s in signs:
            dx, dy = (-s * fy, s * fx) if across else (s * fx, s * fy)
            free = room(area, here, dx, dy, self.inset_m)
            length = free if across else min(self.spacing_m, free)
            if length > self.arrive_m:
                self.across = across
                if across:
                    self.side = s
                    self.legs += 1
                else:
                    self.step = s
                return Point(here.x + length * dx, here.y + length * dy)
        return None
