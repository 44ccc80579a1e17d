"""The ``mission_a:`` section: the vehicle's own pre-programmed mission (SPEC §9; TRO II; OMAE).

Mission A is what the REMUS does when the AMP is not driving: a list of waypoints ("navigate
rows"). The section also says when the AMP takes over (after a set time, or on arrival at a
programmed waypoint — OMAE's two invocation methods), the vehicle's command watchdog and the limits
beyond which the vehicle ignores a command. The AMP's own time limit is the mission's
``time_limit_s``, counted from the take-over.
"""

from __future__ import annotations

import math

from pydantic import BaseModel, ConfigDict, Field, model_validator

Coord = tuple[float, float]


class VehicleLimits(BaseModel):
    """Commands the vehicle accepts; any other command is refused (OMAE "AMP-REMUS protocols")."""

    model_config = ConfigDict(frozen=True, extra="forbid", allow_inf_nan=False)

    min_speed_mps: float = Field(default=0.25, ge=0, description="Slowest speed accepted, m/s")
    max_speed_mps: float = Field(default=2.8, gt=0, description="Fastest speed accepted, m/s")
    max_depth_m: float = Field(default=100.0, gt=0, description="Deepest depth accepted, m")

    @model_validator(mode="after")
    def _ordered(self) -> VehicleLimits:
        if self.min_speed_mps > self.max_speed_mps:
            raise ValueError("min_speed_mps must not exceed max_speed_mps")
        return self

    def refusal(self, speed_mps: float, depth_m: float | None, heading_deg: float = 0.0
                ) -> str | None:
        """Why a heading/speed/depth command would be refused, or None if it is accepted."""
        if not math.isfinite(heading_deg):
            return f"heading {heading_deg:g} deg not finite"
        if not self.min_speed_mps <= speed_mps <= self.max_speed_mps:
            return (
                f"speed {speed_mps:g} m/s outside [{self.min_speed_mps:g}, "
                f"{self.max_speed_mps:g}] m/s"
            )
        if depth_m is not None and not 0.0 <= depth_m <= self.max_depth_m:
            return f"depth {depth_m:g} m outside [0, {self.max_depth_m:g}] m"
        return None


class MissionASpec(BaseModel):
    """Mission A (waypoints) and the hand-over settings between it and the AMP."""

    model_config = ConfigDict(frozen=True, extra="forbid", allow_inf_nan=False)

    waypoints: list[Coord] = Field(
        min_length=1, description="Waypoints in the mission frame, followed in order"
    )
    loop: bool = Field(
        default=False,
        description="After the last waypoint start again at the first (else Mission A ends there)",
    )
    speed_mps: float = Field(default=1.5, gt=0, description="Mission A transit speed, m/s")
    depth_m: float = Field(default=3.0, ge=0, description="Mission A depth, m")
    capture_radius_m: float = Field(
        default=5.0, gt=0, description="A waypoint (or the break-off point) is reached within this"
    )
    amp_enable_s: float | None = Field(
        default=None, ge=0, le=7 * 86400,
        description="The AMP takes over this long after launch, s (at most a week, as the "
        "mission's time limit)",
    )
    amp_enable_waypoint: int | None = Field(
        default=None, ge=0, description="The AMP takes over on reaching this waypoint (0-based)"
    )
    amp_depth_m: float | None = Field(
        default=None, ge=0, description="Depth the AMP commands with each heading (None: hold)"
    )
    watchdog_s: float = Field(
        default=30.0,
        gt=0,
        description="The vehicle leaves the override when it hears no accepted command for this "
        "long, s",
    )
    duration_limit_s: float = Field(
        default=7200.0, gt=0, le=7 * 86400,
        description="The whole pre-programmed mission ends at this time, s; at most a week (as "
        "the AMP's time limit): a looping mission A flies until then, and a simulated run's "
        "rows are kept for all of it",
    )
    limits: VehicleLimits = Field(default_factory=VehicleLimits, description="Vehicle limits")

    @model_validator(mode="after")
    def _one_enable(self) -> MissionASpec:
        if (self.amp_enable_s is None) == (self.amp_enable_waypoint is None):
            raise ValueError("give exactly one of amp_enable_s and amp_enable_waypoint")
        if self.amp_enable_waypoint is not None and self.amp_enable_waypoint >= len(
            self.waypoints
        ):
            raise ValueError(
                f"amp_enable_waypoint {self.amp_enable_waypoint} is past the last waypoint "
                f"(there are {len(self.waypoints)})"
            )
        return self
