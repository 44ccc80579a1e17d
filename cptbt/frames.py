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

import numpy as np
from numpy.typing import NDArray

from cptbt.angles import bearing_deg, hypot_array, unit, wrap_deg
from cptbt.types import Point

FloatArray = NDArray[np.float64]

Normal = tuple[float, float]
"""Outward unit normal of an OpArea wall: (-1, 0) xmin, (1, 0) xmax, (0, -1) ymin, (0, 1) ymax."""


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

    def disc_share(self, radius_m: float) -> float:
        """The largest share of the area a disc of ``radius_m`` can cover (centred in it: in a
        long, thin area the disc overhangs the sides)."""
        a, b = 0.5 * (self.xmax - self.xmin), 0.5 * (self.ymax - self.ymin)
        if a <= 0 or b <= 0:
            return 1.0
        reach = min(a, radius_m)
        x = np.linspace(-reach, reach, 2001)
        chord = 2.0 * np.minimum(b, np.sqrt(np.maximum(radius_m**2 - x * x, 0.0)))
        inside = float(np.sum(0.5 * (chord[1:] + chord[:-1]) * np.diff(x)))  # trapezoids
        return min(inside / (4.0 * a * b), 1.0)

    def disc_radius(self, share: float) -> float:
        """The radius of the smallest disc that can cover ``share`` of the area."""
        lo, hi = 0.0, math.hypot(self.xmax - self.xmin, self.ymax - self.ymin)
        for _ in range(60):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if self.disc_share(mid) < share else (lo, mid)
        return hi

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

    @property
    def corners(self) -> tuple[Point, Point, Point, Point]:
        """The four corners, counter-clockwise when drawn with +y up (xmin-ymin first)."""
        return (
            Point(self.xmin, self.ymin),
            Point(self.xmax, self.ymin),
            Point(self.xmax, self.ymax),
            Point(self.xmin, self.ymax),
        )

    def depth_inside(self, x: float, y: float) -> float:
        """Distance from (x, y) to the nearest wall when inside; minus the distance outside."""
        if not self.contains(x, y):
            return -self.distance_outside(x, y)
        return min(x - self.xmin, self.xmax - x, y - self.ymin, self.ymax - y)

    def walls_beyond(self, x: float, y: float, margin_m: float = 0.0) -> tuple[Normal, ...]:
        """Outward normals of the walls that (x, y) is beyond, or within ``margin_m`` inside of."""
        walls: list[Normal] = []
        if x < self.xmin + margin_m:
            walls.append((-1.0, 0.0))
        if x > self.xmax - margin_m:
            walls.append((1.0, 0.0))
        if y < self.ymin + margin_m:
            walls.append((0.0, -1.0))
        if y > self.ymax - margin_m:
            walls.append((0.0, 1.0))
        return tuple(walls)

    def extent_along(self, angle_deg: float) -> tuple[float, float]:
        """The OpArea projected on the direction ``angle_deg``: (min, max) of ``q·u`` over it."""
        ux, uy = unit(angle_deg)
        values = [c.x * ux + c.y * uy for c in self.corners]
        return min(values), max(values)

    def clamp(self, x: float, y: float, inset_m: float = 0.0) -> Point:
        """The point of the OpArea shrunk by ``inset_m`` nearest (x, y).

        The inset is limited to half the OpArea's width on each axis, so a small OpArea shrinks
        to its centre line rather than to nothing.
        """
        ix = min(inset_m, 0.5 * (self.xmax - self.xmin))
        iy = min(inset_m, 0.5 * (self.ymax - self.ymin))
        return Point(
            min(max(x, self.xmin + ix), self.xmax - ix),
            min(max(y, self.ymin + iy), self.ymax - iy),
        )

    def sector_area(self, origin: Point, axis_deg: float, along: int, across: int) -> float:
        """Area of the part of the OpArea in one quadrant about ``origin``.

        The quadrant is where ``(q - origin)·u`` has the sign of ``along`` and
        ``(q - origin)·n`` the sign of ``across``, with ``u`` along ``axis_deg`` and ``n`` 90°
        from it (toward +y when ``axis_deg`` is 0).
        """
        ux, uy = unit(axis_deg)
        nx, ny = -uy, ux
        poly = [(c.x, c.y) for c in self.corners]
        for (ax, ay), s in (((ux, uy), along), ((nx, ny), across)):
            poly = _clip(poly, s * ax, s * ay, s * (origin.x * ax + origin.y * ay))
        return _polygon_area(poly)

    def heading_inside(self, heading_deg: float, x: float, y: float, margin_m: float) -> float:
        """``heading_deg`` changed so it does not drive out through a wall near (x, y).

        For each wall the estimated position is within ``margin_m`` of (or beyond), a heading
        with an outward component is changed: inside, the outward component is removed (the
        vehicle runs along the wall); beyond the wall, it is reversed (the vehicle turns back
        in). A heading straight at a wall (nothing left along it) turns along the wall toward
        the OpArea's centre, or toward the centre itself in a corner. Headings that already
        point inward, and positions farther than ``margin_m`` from every wall, are returned
        unchanged.
        """
        hx, hy = unit(heading_deg)
        changed = False
        for wx, wy in self.walls_beyond(x, y, margin_m):
            out = hx * wx + hy * wy
            if out <= 0.0:
                continue
            beyond = (wx < 0 and x < self.xmin) or (wx > 0 and x > self.xmax) or (
                wy < 0 and y < self.ymin) or (wy > 0 and y > self.ymax)
            k = 2.0 if beyond else 1.0
            hx, hy = hx - k * out * wx, hy - k * out * wy
            changed = True
        if not changed:
            return heading_deg
        if math.hypot(hx, hy) < 1e-6:
            c = self.centre
            tx, ty = c.x - x, c.y - y
            walls = self.walls_beyond(x, y, margin_m)
            if len(walls) == 1:  # along the wall toward the centre
                wx, wy = walls[0]
                along = tx * wx + ty * wy
                tx, ty = tx - along * wx, ty - along * wy
            if math.hypot(tx, ty) < 1e-9:
                return wrap_deg(heading_deg + 180.0)
            return bearing_deg(tx, ty)
        return bearing_deg(hx, hy)

    # -- array forms (the fleet planner): the same numbers as the methods above, per element.

    def distance_outside_array(self, x: FloatArray, y: FloatArray) -> FloatArray:
        """:meth:`distance_outside` of every point."""
        dx = np.maximum(np.maximum(self.xmin - x, 0.0), x - self.xmax)
        dy = np.maximum(np.maximum(self.ymin - y, 0.0), y - self.ymax)
        return hypot_array(dx, dy)

    def contains_array(self, x: FloatArray, y: FloatArray) -> NDArray[np.bool_]:
        """:meth:`contains` of every point."""
        return (self.xmin <= x) & (x <= self.xmax) & (self.ymin <= y) & (y <= self.ymax)

    def depth_inside_array(self, x: FloatArray, y: FloatArray) -> FloatArray:
        """:meth:`depth_inside` of every point."""
        inside = np.minimum(np.minimum(x - self.xmin, self.xmax - x),
                            np.minimum(y - self.ymin, self.ymax - y))
        return np.where(self.contains_array(x, y), inside, -self.distance_outside_array(x, y))

    def walls_beyond_bits(self, x: FloatArray, y: FloatArray, margin_m: float = 0.0
                          ) -> NDArray[np.int64]:
        """:meth:`walls_beyond` of every point as bits over :data:`WALL_NORMALS`."""
        return ((x < self.xmin + margin_m) * 1 + (x > self.xmax - margin_m) * 2
                + (y < self.ymin + margin_m) * 4 + (y > self.ymax - margin_m) * 8)

    def clamp_array(self, x: FloatArray, y: FloatArray, inset_m: float = 0.0
                    ) -> tuple[FloatArray, FloatArray]:
        """:meth:`clamp` of every point."""
        ix = min(inset_m, 0.5 * (self.xmax - self.xmin))
        iy = min(inset_m, 0.5 * (self.ymax - self.ymin))
        return (np.minimum(np.maximum(x, self.xmin + ix), self.xmax - ix),
                np.minimum(np.maximum(y, self.ymin + iy), self.ymax - iy))

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


WALL_NORMALS: tuple[Normal, ...] = ((-1.0, 0.0), (1.0, 0.0), (0.0, -1.0), (0.0, 1.0))
"""The outward normals in :meth:`OpArea.walls_beyond`'s order; bit k of a wall mask is the k-th."""


def normals_of_bits(bits: int) -> tuple[Normal, ...]:
    """The outward normals of a wall mask (:meth:`OpArea.walls_beyond_bits`)."""
    return tuple(w for k, w in enumerate(WALL_NORMALS) if bits >> k & 1)


@dataclass(frozen=True, slots=True)
class WallExit:
    """A safety take-over at the OpArea boundary, as safety reports it to the plume behaviours.

    Attributes:
        t: planner time at which safety handed control back, s.
        point: estimated position where safety took over (planning frame).
        normals: outward normals of the walls that position was beyond.
    """

    t: float
    point: Point
    normals: tuple[Normal, ...]


def _clip(
    poly: list[tuple[float, float]], ax: float, ay: float, b: float
) -> list[tuple[float, float]]:
    """Sutherland–Hodgman: the part of a convex polygon where ``ax*x + ay*y >= b``."""
    out: list[tuple[float, float]] = []
    for i, p in enumerate(poly):
        q = poly[(i + 1) % len(poly)]
        fp, fq = ax * p[0] + ay * p[1] - b, ax * q[0] + ay * q[1] - b
        if fp >= 0.0:
            out.append(p)
        if (fp >= 0.0) != (fq >= 0.0):
            r = fp / (fp - fq)
            out.append((p[0] + r * (q[0] - p[0]), p[1] + r * (q[1] - p[1])))
    return out


def _polygon_area(poly: list[tuple[float, float]]) -> float:
    """Shoelace area of a simple polygon (0 for fewer than three vertices)."""
    if len(poly) < 3:
        return 0.0
    twice = sum(
        p[0] * q[1] - q[0] * p[1] for p, q in zip(poly, poly[1:] + poly[:1], strict=True)
    )
    return abs(twice) / 2.0


def room(area: OpArea, at: Point, dx: float, dy: float, inset_m: float = 0.0) -> float:
    """How far from ``at`` (inside the OpArea) along the unit direction (dx, dy) the wall is,
    or the OpArea shrunk by ``inset_m`` (limited to half its width on each axis, as
    :meth:`~cptbt.frames.OpArea.clamp`) if given."""
    out = math.inf
    ix = min(inset_m, 0.5 * (area.xmax - area.xmin))
    iy = min(inset_m, 0.5 * (area.ymax - area.ymin))
    for c, d, lo, hi in ((at.x, dx, area.xmin + ix, area.xmax - ix),
                         (at.y, dy, area.ymin + iy, area.ymax - iy)):
        if d > 1e-12:
            out = min(out, (hi - c) / d)
        elif d < -1e-12:
            out = min(out, (lo - c) / d)
    return max(out, 0.0)
