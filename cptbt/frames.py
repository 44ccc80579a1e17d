"""The OpArea and the N-E ↔ planning-frame rotation of SPEC §1.

The N-E frame has its origin at the OpArea centre, N along latitude and E along longitude. The
planning frame is the N-E frame rotated about the vertical so that +x lies along the OpArea's long
axis; +y is 90° clockwise from +x (TRO draws it positive down). With ``b`` the compass bearing of
+x, a point maps as ``x = n cos b + e sin b``, ``y = -n sin b + e cos b`` and a planning angle θ is
the compass heading ``b + θ``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from cptbt.angles import wrap_deg
from cptbt.types import Point


@dataclass(frozen=True, slots=True)
class PlanningFrame:
    """Rotation (and offset) between user N-E metres and the planning frame.

    Attributes:
        x_bearing_deg: compass bearing of the planning +x axis.
        origin_n: north coordinate, in the user's N-E metres, of the planning origin.
        origin_e: east coordinate of the planning origin.
    """

    x_bearing_deg: float = 0.0
    origin_n: float = 0.0
    origin_e: float = 0.0

    def ne_to_xy(self, n: float, e: float) -> Point:
        """Map N-E metres to the planning frame."""
        b = math.radians(self.x_bearing_deg)
        dn, de = n - self.origin_n, e - self.origin_e
        return Point(dn * math.cos(b) + de * math.sin(b), -dn * math.sin(b) + de * math.cos(b))

    def xy_to_ne(self, x: float, y: float) -> tuple[float, float]:
        """Map a planning-frame point to N-E metres."""
        b = math.radians(self.x_bearing_deg)
        return (
            self.origin_n + x * math.cos(b) - y * math.sin(b),
            self.origin_e + x * math.sin(b) + y * math.cos(b),
        )

    def compass_deg(self, planning_deg: float) -> float:
        """Compass heading (0..360) of a planning angle."""
        return (self.x_bearing_deg + planning_deg) % 360.0

    def planning_deg(self, compass_deg: float) -> float:
        """Planning angle of a compass heading."""
        return wrap_deg(compass_deg - self.x_bearing_deg)


@dataclass(frozen=True, slots=True)
class OpArea:
    """The operating area: an axis-aligned rectangle in the planning frame.

    Attributes:
        xmin, xmax, ymin, ymax: bounds in planning metres.
        frame: how planning coordinates relate to the user's N-E metres.
    """

    xmin: float
    xmax: float
    ymin: float
    ymax: float
    frame: PlanningFrame = PlanningFrame()

    def __post_init__(self) -> None:
        if not (self.xmin < self.xmax and self.ymin < self.ymax):
            raise ValueError("OpArea bounds must satisfy xmin < xmax and ymin < ymax")

    @property
    def centre(self) -> Point:
        """Centre of the rectangle."""
        return Point(0.5 * (self.xmin + self.xmax), 0.5 * (self.ymin + self.ymax))

    def contains(self, x: float, y: float) -> bool:
        """Whether (x, y) is inside or on the boundary."""
        return self.xmin <= x <= self.xmax and self.ymin <= y <= self.ymax

    def distance_outside(self, x: float, y: float) -> float:
        """Distance from (x, y) to the rectangle; zero inside."""
        dx = max(self.xmin - x, 0.0, x - self.xmax)
        dy = max(self.ymin - y, 0.0, y - self.ymax)
        return math.hypot(dx, dy)

    @staticmethod
    def side_bearings(corners: Sequence[tuple[float, float]]) -> list[float]:
        """Compass bearings in [0, 180) of the four sides of N-E corners taken around the centre."""
        cn = sum(c[0] for c in corners) / 4.0
        ce = sum(c[1] for c in corners) / 4.0
        ordered = sorted(corners, key=lambda c: math.atan2(c[1] - ce, c[0] - cn))
        return [
            math.degrees(
                math.atan2(ordered[(i + 1) % 4][1] - ordered[i][1],
                           ordered[(i + 1) % 4][0] - ordered[i][0])
            ) % 180.0
            for i in range(4)
        ]

    def corner_misfit_m(self, corners: Sequence[tuple[float, float]]) -> float:
        """How far the farthest N-E corner lies from the nearest corner of this rectangle, m."""
        box = [(x, y) for x in (self.xmin, self.xmax) for y in (self.ymin, self.ymax)]
        pts = [self.frame.ne_to_xy(n, e) for n, e in corners]
        return max(min(math.hypot(p.x - bx, p.y - by) for bx, by in box) for p in pts)

    @property
    def diagonal_m(self) -> float:
        """Length of the rectangle's diagonal, m."""
        return math.hypot(self.xmax - self.xmin, self.ymax - self.ymin)

    @classmethod
    def from_ne_corners(
        cls, corners: Sequence[tuple[float, float]], x_bearing_deg: float | None = None
    ) -> OpArea:
        """Build the OpArea from four N-E corners (any order).

        The planning origin is the corners' centroid. Unless ``x_bearing_deg`` is given, +x runs
        along the long axis in the direction whose compass bearing lies in [0, 180). Corners that
        are only approximately rectangular (as in TRO Table II) are enclosed by their bounding box
        in the planning frame.

        Raises:
            ValueError: not four distinct corners, or a degenerate area.
        """
        if len(corners) != 4:
            raise ValueError(f"an OpArea needs 4 corners, got {len(corners)}")
        cn = sum(c[0] for c in corners) / 4.0
        ce = sum(c[1] for c in corners) / 4.0
        ordered = sorted(corners, key=lambda c: math.atan2(c[1] - ce, c[0] - cn))
        edges = [
            (ordered[(i + 1) % 4][0] - ordered[i][0], ordered[(i + 1) % 4][1] - ordered[i][1])
            for i in range(4)
        ]
        lengths = [math.hypot(*e) for e in edges]
        if min(lengths) <= 0.0:
            raise ValueError("OpArea corners must be distinct")
        if x_bearing_deg is None:
            long_edge = edges[max(range(4), key=lambda i: lengths[i])]
            x_bearing_deg = math.degrees(math.atan2(long_edge[1], long_edge[0])) % 180.0
        frame = PlanningFrame(x_bearing_deg, cn, ce)
        pts = [frame.ne_to_xy(n, e) for n, e in corners]
        return cls(
            min(p.x for p in pts),
            max(p.x for p in pts),
            min(p.y for p in pts),
            max(p.y for p in pts),
            frame,
        )
