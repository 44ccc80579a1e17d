"""The vehicle link: how the AMP (a guest computer) talks to the vehicle (OMAE "AMP-REMUS
protocols"; Stokey 2002, WHOI external-control protocol).

The vehicle reports its state and sensor data at all times; the AMP sends heading/speed(/depth)
commands and asks for or ends the override. The vehicle may ignore a command beyond its limits,
leaves the override by itself when it hears no command for a set time, and on leaving the override
goes back to the break-off point and resumes its own mission. Everything the AMP knows about the
vehicle comes through :class:`VehicleLink`; the simulator is one implementation of it (in the
application layer), a serial-port adapter for a real REMUS would be another.

Messages are in the planning frame (metres, degrees from +x toward +y) and carry the vehicle's
clock ``t_s``: an adapter for a vehicle that reports latitude/longitude converts with
:mod:`cptbt.geodesy` and :class:`cptbt.frames.PlanningFrame`, so the AMP never sees another frame
and never reads a wall clock.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal, Protocol, runtime_checkable

VehicleMode = Literal["pre_launch", "mission", "override", "returning", "post_mission"]
"""OMAE's operating modes (pre-launch, in mission, post mission), with the in-mission mode split
into following Mission A, under override, and returning to the break-off point."""


@dataclass(frozen=True, slots=True)
class VehicleState:
    """The vehicle's navigation state and operating mode.

    Attributes:
        t_s: vehicle clock, s.
        x_m, y_m: navigation estimate, planning frame, m.
        heading_deg: planning-frame heading.
        speed_mps: through-water speed.
        depth_m: depth (None if not reported).
        mode: operating mode.
        waypoints_reached: Mission A waypoints reached so far.
    """

    t_s: float
    x_m: float
    y_m: float
    heading_deg: float
    speed_mps: float
    depth_m: float | None = None
    mode: VehicleMode = "mission"
    waypoints_reached: int = 0


@dataclass(frozen=True, slots=True)
class ConcentrationSample:
    """One fluorometer sample."""

    t_s: float
    value: float


@dataclass(frozen=True, slots=True)
class FlowSample:
    """One ADCP-derived flow-over-ground sample, planning frame, m/s."""

    t_s: float
    vx_mps: float
    vy_mps: float


@dataclass(frozen=True, slots=True)
class HeadingSpeedCommand:
    """A guidance command: planning-frame heading, speed and (optionally) depth."""

    heading_deg: float
    speed_mps: float
    depth_m: float | None = None


@dataclass(frozen=True, slots=True)
class OverrideRequest:
    """The AMP asks to take control; the current Mission A objective is suspended."""


@dataclass(frozen=True, slots=True)
class OverrideRelease:
    """The AMP gives control back; the vehicle returns to the break-off point."""


@dataclass(frozen=True, slots=True)
class CommandRefused:
    """The vehicle ignored a command (it keeps the last accepted one)."""

    t_s: float
    command: HeadingSpeedCommand
    reason: str


@dataclass(frozen=True, slots=True)
class OverrideEnded:
    """The vehicle left the override.

    Attributes:
        t_s: vehicle clock, s.
        reason: ``released`` (the AMP gave back), ``watchdog`` (no command heard for the
            timeout) or ``mission_end`` (the vehicle's own mission ended).
        break_off: where the override began (planning frame), where the vehicle now returns.
    """

    t_s: float
    reason: Literal["released", "watchdog", "mission_end"]
    break_off: tuple[float, float]


InMessage = VehicleState | ConcentrationSample | FlowSample | CommandRefused | OverrideEnded
OutMessage = HeadingSpeedCommand | OverrideRequest | OverrideRelease


@runtime_checkable
class VehicleLink(Protocol):
    """Both ends of the AMP ↔ vehicle connection, as the AMP sees it."""

    def receive(self) -> Sequence[InMessage]:
        """Messages from the vehicle since the last call, oldest first (never blocks)."""
        ...

    def send(self, message: OutMessage) -> None:
        """Send a command or an override request/release to the vehicle."""
        ...
