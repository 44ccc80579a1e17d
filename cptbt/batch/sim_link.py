"""The simulated vehicle behind a :class:`cptbt.link.VehicleLink`: a one-vehicle world with an
emulated REMUS executive.

The executive is what the REMUS computer does on its own (OMAE "AMP-REMUS protocols"): it follows
Mission A's waypoints (go-to-goal on each in turn), suspends them on an override request, applies
the AMP's accepted commands, refuses commands beyond its limits, leaves the override on a release
or when it hears no accepted command for the watchdog time, then transits back to the break-off
point and resumes Mission A with the objective it was interrupted on (OMAE invocation method 1).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from cptbt.link import (
    CommandRefused,
    ConcentrationSample,
    FlowSample,
    HeadingSpeedCommand,
    InMessage,
    OutMessage,
    OverrideEnded,
    OverrideRelease,
    OverrideRequest,
    VehicleMode,
    VehicleState,
)
from cptbt.mission_a import MissionASpec
from cptbt.sim.world import StepOutput, World
from cptbt.types import Point


@dataclass(frozen=True, slots=True)
class LinkFaults:
    """Faults to inject for tests and studies.

    Attributes:
        drop_commands_from_s: AMP messages sent at or after this vehicle time are lost.
    """

    drop_commands_from_s: float | None = None


class SimVehicleLink:
    """The simulator as the vehicle at the other end of the AMP's link.

    Args:
        world: a world with exactly one vehicle, warmed up.
        spec: Mission A and the vehicle's hand-over settings.
        waypoints: Mission A's waypoints in the planning frame.
        faults: faults to inject.
    """

    def __init__(
        self,
        world: World,
        spec: MissionASpec,
        waypoints: Sequence[Point],
        faults: LinkFaults | None = None,
    ) -> None:
        if world.n != 1:
            raise ValueError("SimVehicleLink drives a world with exactly one vehicle")
        self.world = world
        self.spec = spec
        self.waypoints = list(waypoints)
        self.faults = faults or LinkFaults()
        self.mode: VehicleMode = "pre_launch"
        self.waypoint_index = 0
        self.waypoints_reached = 0
        self.break_off: tuple[float, float] | None = None
        self.depth_m = 0.0
        self._cmd: tuple[float, float] = (math.nan, math.nan)
        self._last_accepted_t = 0.0
        self._inbox: list[InMessage] = []
        self._outbox: list[OutMessage] = []
        self._nav = (float(world.vehicles.xy[0, 0]), float(world.vehicles.xy[0, 1]))
        self._nav_heading = float(world.vehicles.heading_deg[0])
        self._report(world.t_s)

    # -- VehicleLink ------------------------------------------------------------------------
    def receive(self) -> list[InMessage]:
        """Messages queued since the last call."""
        out, self._inbox = self._inbox, []
        return out

    def send(self, message: OutMessage) -> None:
        """Queue an AMP message; the vehicle acts on it at its next step."""
        if self.faults.drop_commands_from_s is not None and (
            self.world.t_s + 1e-9 >= self.faults.drop_commands_from_s
        ):
            return
        self._outbox.append(message)

    # -- the vehicle ------------------------------------------------------------------------
    def step(self) -> StepOutput:
        """Act on the AMP's messages, steer, advance the world one step and report."""
        self.prepare()
        out = self.world.step()
        self.observe(out)
        return out

    def prepare(self) -> None:
        """Before a world step: act on the AMP's messages and steer."""
        t = self.world.t_s
        if self.mode == "pre_launch":
            self.mode = "mission"
        for msg in self._outbox:
            self._apply(msg, t)
        self._outbox.clear()
        heading, speed = self._steer()
        self.world.set_commands(np.array([heading]), np.array([speed]))

    def observe(self, out: StepOutput) -> None:
        """After a world step: the vehicle's own events, and its reports to the AMP."""
        t = out.t_s
        self._nav = (float(out.nav_xy[0, 0]), float(out.nav_xy[0, 1]))
        self._nav_heading = float(out.nav_heading_deg[0])
        self._advance(t)
        if out.adcp_flow is not None:
            self._inbox.append(FlowSample(t, float(out.adcp_flow[0, 0]),
                                          float(out.adcp_flow[0, 1])))
        if out.fluorometer is not None:
            self._inbox.append(ConcentrationSample(t, float(out.fluorometer[0])))
        self._report(t)

    def _apply(self, msg: OutMessage, t: float) -> None:
        if isinstance(msg, OverrideRequest) and self.mode == "mission":
            self.mode = "override"
            self.break_off = self._nav
            self._last_accepted_t = t
            self._cmd = (math.nan, math.nan)  # hold heading and speed until the AMP commands
        elif isinstance(msg, OverrideRelease) and self.mode == "override":
            self._leave_override(t, "released")
        elif isinstance(msg, HeadingSpeedCommand) and self.mode == "override":
            reason = self.spec.limits.refusal(msg.speed_mps, msg.depth_m, msg.heading_deg)
            if reason is not None:
                self._inbox.append(CommandRefused(t, msg, reason))
                return
            self._cmd = (msg.heading_deg, msg.speed_mps)
            if msg.depth_m is not None:
                self.depth_m = msg.depth_m
            self._last_accepted_t = t

    def _leave_override(self, t: float, reason: str) -> None:
        assert self.break_off is not None
        self.mode = "returning"
        self._inbox.append(OverrideEnded(t, reason, self.break_off))  # type: ignore[arg-type]

    def _goto(self, goal: tuple[float, float]) -> float:
        return math.degrees(math.atan2(goal[1] - self._nav[1], goal[0] - self._nav[0]))

    def _steer(self) -> tuple[float, float]:
        if self.mode == "override":
            return self._cmd
        if self.mode == "returning":
            assert self.break_off is not None
            return self._goto(self.break_off), self.spec.speed_mps
        if self.mode == "mission":
            self.depth_m = self.spec.depth_m
            wp = self.waypoints[self.waypoint_index]
            return self._goto((wp.x, wp.y)), self.spec.speed_mps
        return math.nan, self.world.params.vehicle.min_speed_mps

    def _advance(self, t: float) -> None:
        """Vehicle-side events after the step: watchdog, captures, end of mission."""
        if self.mode == "override" and t - self._last_accepted_t > self.spec.watchdog_s:
            self._leave_override(t, "watchdog")
        r = self.spec.capture_radius_m
        if self.mode == "returning":
            assert self.break_off is not None
            if math.dist(self._nav, self.break_off) <= r:
                self.mode = "mission"
        elif self.mode == "mission":
            wp = self.waypoints[self.waypoint_index]
            if math.dist(self._nav, (wp.x, wp.y)) <= r:
                self.waypoints_reached += 1
                self.waypoint_index += 1
                if self.waypoint_index == len(self.waypoints):
                    if self.spec.loop:
                        self.waypoint_index = 0
                    else:
                        self.mode = "post_mission"
        if t + 1e-9 >= self.spec.duration_limit_s and self.mode != "post_mission":
            if self.mode == "override":
                self._leave_override(t, "mission_end")
            self.mode = "post_mission"

    def _report(self, t: float) -> None:
        v = self.world.vehicles
        self._inbox.append(VehicleState(
            t_s=t, x_m=self._nav[0], y_m=self._nav[1], heading_deg=self._nav_heading,
            speed_mps=float(v.speed_mps[0]), depth_m=self.depth_m, mode=self.mode,
            waypoints_reached=self.waypoints_reached,
        ))
