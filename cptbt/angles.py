"""Angle helpers with the conventions of SPEC §1.

Every planner angle is in degrees, measured from +x toward +y of the planning frame, so a unit
direction is ``(cos θ, sin θ)`` and ``atan2(dy, dx)`` gives an angle in the same convention.
Angles are wrapped to the half-open interval (-180, 180].
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray


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


# -- array forms (the fleet planner): the same numbers as the scalar helpers, element by element.
# numpy's arctan2 and hypot can differ from libm's in the last bit, so those two go through
# ``math`` element by element; fmod, degrees, radians, cos and sin agree bit for bit.


def wrap_deg_array(angle: NDArray[np.float64]) -> NDArray[np.float64]:
    """:func:`wrap_deg` of every element."""
    a = np.fmod(angle, 360.0)
    return np.where(a <= -180.0, a + 360.0, np.where(a > 180.0, a - 360.0, a))


def sign_array(value: NDArray[np.float64]) -> NDArray[np.int64]:
    """:func:`sign` of every element (``sign(0) = +1``)."""
    return np.where(value < 0, -1, 1)


def atan2_array(dy: NDArray[np.float64], dx: NDArray[np.float64]) -> NDArray[np.float64]:
    """``math.atan2`` of every pair (numpy's differs in the last bit on some inputs)."""
    return np.fromiter(map(math.atan2, dy.tolist(), dx.tolist()), dtype=float, count=len(dy))


def hypot_array(dx: NDArray[np.float64], dy: NDArray[np.float64]) -> NDArray[np.float64]:
    """``math.hypot`` of every pair; only pairs with both parts non-zero go through ``math``."""
    out = np.maximum(np.abs(dx), np.abs(dy))
    both = (dx != 0.0) & (dy != 0.0)
    if np.count_nonzero(both):
        out[both] = list(map(math.hypot, dx[both].tolist(), dy[both].tolist()))
    return out


def bearing_deg_array(dx: NDArray[np.float64], dy: NDArray[np.float64]) -> NDArray[np.float64]:
    """:func:`bearing_deg` of every vector."""
    return wrap_deg_array(np.degrees(atan2_array(dy, dx)))


def unit_array(angle_deg: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """:func:`unit` of every angle."""
    r = np.radians(angle_deg)
    return np.cos(r), np.sin(r)
