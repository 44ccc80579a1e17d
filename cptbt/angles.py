"""Angle helpers with the conventions of SPEC §1.

Every planner angle is in degrees, measured from +x toward +y of the planning frame, so a unit
direction is ``(cos θ, sin θ)`` and ``atan2(dy, dx)`` gives an angle in the same convention.
Angles are wrapped to the half-open interval (-180, 180].
"""

from __future__ import annotations

import math


def wrap_deg(angle: float) -> float:
    """Wrap an angle in degrees to (-180, 180]."""
    a = math.fmod(angle, 360.0)
    if a <= -180.0:
        a += 360.0
    elif a > 180.0:
        a -= 360.0
    return a


def sign(value: float) -> int:
    """Sign with ``sign(0) = +1`` (SPEC §4a), so a heading offset is never zero."""
    return -1 if value < 0 else 1


def bearing_deg(dx: float, dy: float) -> float:
    """Planning angle of the vector (dx, dy), wrapped to (-180, 180]."""
    return wrap_deg(math.degrees(math.atan2(dy, dx)))


def unit(angle_deg: float) -> tuple[float, float]:
    """Unit vector along a planning angle."""
    r = math.radians(angle_deg)
    return math.cos(r), math.sin(r)


def upflow_deg(flow_dir_deg: float) -> float:
    """Direction opposite the flow (where the water comes from)."""
    return wrap_deg(flow_dir_deg + 180.0)
