"""Kinematic vehicles, stepped together as arrays.

Heading response (SPEC §10), either

- ``"first_order"``: ``dpsi/dt = a·wrap(psi_cmd - psi)`` (AB footnote 3, a = 5 1/s), integrated
  exactly over a step for a held command: ``psi += (1 - e^{-a dt})·wrap(psi_cmd - psi)``; or
- ``"turn_radius"``: the same law with the turn rate clipped to ``speed / turning_radius``
  (REMUS: 5–10 m), so the path is never tighter than the radius.

Through-water speed follows the command at once, clipped to ``[min_speed, max_speed]`` (REMUS
0.25–2.8 m/s). Position integrates speed along the new heading plus the current. A NaN command
holds the vehicle's present heading or speed.
"""

from __future__ import annotations

import math
from typing import Literal

import numpy as np
from numpy.typing import NDArray
from pydantic import BaseModel, ConfigDict, Field, model_validator


def wrap_deg(a: NDArray[np.float64]) -> NDArray[np.float64]:
    """Wrap angles in degrees to (-180, 180]."""
    return 180.0 - np.mod(180.0 - a, 360.0)


class VehicleParams(BaseModel):
    """Vehicle dynamics settings (defaults: REMUS, TRO)."""

    model_config = ConfigDict(frozen=True, extra="forbid", allow_inf_nan=False)

    heading_mode: Literal["first_order", "turn_radius"] = "turn_radius"
    heading_gain_per_s: float = Field(
        default=5.0, gt=0.0, description="Heading gain a, 1/s (AB: 5)."
    )
    turning_radius_m: float = Field(
        default=7.5, gt=0.0, description="Tightest turn, m (REMUS 5–10)."
    )
    min_speed_mps: float = Field(
        default=0.25, ge=0.0, description="Slowest through-water speed, m/s."
    )
    max_speed_mps: float = Field(
        default=2.8, gt=0.0, description="Fastest through-water speed, m/s."
    )
    initial_speed_mps: float = Field(
        default=1.5, ge=0.0, description="Speed before any command, m/s."
    )
    advected: bool = Field(
        default=True,
        description="The current carries the vehicle (an AUV); False for a searcher whose "
        "speed is over ground (AB's 1 m/s searcher in a 1 m/s mean flow).",
    )

    @model_validator(mode="after")
    def _check_speeds(self) -> VehicleParams:
        if self.min_speed_mps > self.max_speed_mps:
            raise ValueError("min_speed_mps must not exceed max_speed_mps")
        return self


class Vehicles:
    """N vehicles: true position (N, 2), heading (N,) in degrees, through-water speed (N,).

    Args:
        params: Dynamics settings.
        xy: Initial true positions (N, 2), m.
        heading_deg: Initial headings (N,), degrees from +x toward +y.
        speed_mps: Initial speeds (N,); ``params.initial_speed_mps`` if None.
    """

    def __init__(
        self,
        params: VehicleParams,
        xy: NDArray[np.float64],
        heading_deg: NDArray[np.float64],
        speed_mps: NDArray[np.float64] | None = None,
    ) -> None:
        self.params = params
        self.xy = np.array(xy, dtype=float).reshape(-1, 2)
        n = len(self.xy)
        self.heading_deg = wrap_deg(np.broadcast_to(np.asarray(heading_deg, float), (n,)).copy())
        speed = params.initial_speed_mps if speed_mps is None else speed_mps
        self.speed_mps = np.clip(
            np.broadcast_to(np.asarray(speed, float), (n,)).copy(),
            params.min_speed_mps,
            params.max_speed_mps,
        )

    @property
    def n(self) -> int:
        """Number of vehicles."""
        return len(self.xy)

    def step(
        self,
        dt: float,
        cmd_heading_deg: NDArray[np.float64],
        cmd_speed_mps: NDArray[np.float64],
        current: NDArray[np.float64],
    ) -> None:
        """Advance all vehicles by ``dt``.

        Args:
            dt: Step, s.
            cmd_heading_deg: Commanded headings (N,); NaN holds the present heading.
            cmd_speed_mps: Commanded speeds (N,); NaN holds the present speed.
            current: Water velocity at each vehicle (N, 2), m/s.
        """
        p = self.params
        cmd_h = np.asarray(cmd_heading_deg, dtype=float)
        cmd_s = np.asarray(cmd_speed_mps, dtype=float)
        cmd_s = np.where(np.isnan(cmd_s), self.speed_mps, cmd_s)
        self.speed_mps = np.minimum(np.maximum(cmd_s, p.min_speed_mps), p.max_speed_mps)
        err = wrap_deg(np.where(np.isnan(cmd_h), self.heading_deg, cmd_h) - self.heading_deg)
        turn = (1.0 - math.exp(-p.heading_gain_per_s * dt)) * err
        if p.heading_mode == "turn_radius":
            max_turn = self.speed_mps * (math.degrees(dt) / p.turning_radius_m)
            turn = np.minimum(np.maximum(turn, -max_turn), max_turn)
        self.heading_deg = wrap_deg(self.heading_deg + turn)
        rad = np.radians(self.heading_deg)
        vx = self.speed_mps * np.cos(rad) + current[:, 0]
        vy = self.speed_mps * np.sin(rad) + current[:, 1]
        self.xy[:, 0] += vx * dt
        self.xy[:, 1] += vy * dt
