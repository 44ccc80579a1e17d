"""Reacquire-plume: a local search around the last detection (SPEC §6; TRO IV-C, OMAE).

Both variants are waypoint tours laid out when they start, centred on the last detection, and
steered by bearing to the current waypoint. They have an output only while contact is lost (a
detection was made, but not within λ); any detection gives control back to maintain-plume. A
finished tour stays finished for that lost contact: it has no output, so find-plume takes
over, until a new contact is made and lost again. A tour interrupted (by a detection or by
safety) starts afresh on its next activation.

**(clarified) Walls.** The papers lay their tours around the last detection whatever the
OpArea; near a wall, or in a small OpArea, that sends the vehicle out and safety takes over at
every leaf. Every point of a tour (the cloverleaf's centre and tips, the three points) is moved
to the nearest point at least ``wall_inset_m`` inside the OpArea (the inset clipped to half the
OpArea's width on each axis); the tips of a squeezed tour may lie closer together than
``d_leaf``, and the tour still circles the last detection as far as the OpArea allows. A
waypoint that falls inside the vehicle's turning circle cannot be closed to
``arrive_radius_m``: it would be orbited, in loops of diameter 2R that reach past any inset. A
waypoint passed within ``pass_radius_m`` (the distance growing again) therefore counts as
visited too. Stated bound: a vehicle turning at radius R, commanded every T s at speed V, turns
for the next point no farther than ``pass_radius_m`` from one, so it leaves the OpArea by at
most ``R + V*T - (wall_inset_m - pass_radius_m)`` plus its navigation error: 7 m for the REMUS
(7.5 m, 1.5 m/s, 1 Hz) with the defaults (10 m, 8 m), 2 m for one that reaches its points
(``arrive_radius_m`` 3 m in place of ``pass_radius_m``).
"""

from __future__ import annotations

import math
from typing import ClassVar

from py_trees.common import Access
from pydantic import Field

from cptbt.angles import unit
from cptbt.frames import OpArea
from cptbt.node import BehaviourParams, Contract, PlanBehaviour
from cptbt.registry import BehaviourSpec
from cptbt.types import Command, FlowEstimate, Percept, Point


class TourParams(BehaviourParams):
    """Parameters every waypoint tour has."""

    arrive_radius_m: float = Field(
        default=3.0, gt=0, description="A waypoint counts as reached within this distance, m"
    )
    pass_radius_m: float = Field(
        default=8.0,
        ge=0,
        description="A waypoint passed within this distance (the distance then growing by "
        "more than 1 m) also counts as reached, so one inside the turning circle is not "
        "orbited, m",
    )
    wall_inset_m: float = Field(
        default=10.0,
        ge=0,
        description="Every point of the tour is kept this far inside the OpArea walls, m",
    )


def pattern_advice(params: BehaviourParams, area: OpArea) -> list[tuple[str, str]]:
    """A triangle tour the OpArea cannot hold (a review's ``d_leaf_m: 400`` in a 100-m-wide
    box validated silently): its three points lie 120° apart at ``d_leaf_m`` (``radius_m``)
    from C (:meth:`_WaypointTour.triangle`), so it spans 1.5 times that along the flow and
    1.73 times across. When no orientation of it fits inside the OpArea less ``wall_inset_m``
    each side (checked every degree: in a square it needs 1.67 times the distance, a reading
    of 1.5 had passed 19 m in 30 m of room, an attacker's), points are moved inside the walls
    wherever it is centred, so the tour flown is not the one drawn."""
    key, size, (room_x, room_y) = tour_size(params, area)
    if any(tour_fits(params, area, deg) for deg in range(120)):
        return []
    return [(key, f"{size:g} m: the tour's points, 120° apart at that distance from its centre, "
                  f"fit in no orientation inside the OpArea less wall_inset_m each side "
                  f"({max(room_x, 0):.0f} × {max(room_y, 0):.0f} m): wherever it is centred, "
                  "points are moved inside the walls, so the tour flown is not the one drawn")]


def tour_size(params: BehaviourParams, area: OpArea) -> tuple[str, float, tuple[float, float]]:
    """(the size's key, the tour's size, the room for it: the OpArea less ``wall_inset_m`` each
    side, along x and y) of a triangle tour's parameters."""
    assert isinstance(params, TourParams)
    key = "d_leaf_m" if isinstance(params, CloverleafParams) else "radius_m"
    inset = 2.0 * params.wall_inset_m
    return key, float(getattr(params, key)), (area.xmax - area.xmin - inset,
                                              area.ymax - area.ymin - inset)


def tour_fits(params: BehaviourParams, area: OpArea, toward_deg: float) -> bool:
    """Whether a triangle tour laid out for a flow toward ``toward_deg`` (planning frame; its
    points toward the flow and 120° either side, :meth:`_WaypointTour.triangle`) fits inside
    the OpArea less ``wall_inset_m`` each side, somewhere."""
    _, size, (room_x, room_y) = tour_size(params, area)
    points = [unit(toward_deg + 120.0 * k) for k in range(3)]
    xs, ys = [size * x for x, _ in points], [size * y for _, y in points]
    return max(xs) - min(xs) <= room_x and max(ys) - min(ys) <= room_y


class _WaypointTour(PlanBehaviour):
    """A tour of waypoints laid out on activation around the last detection point."""

    persistent_state: ClassVar[tuple[str, ...]] = ("finished_detection_t",)
    params: TourParams

    def __init__(self, params: BehaviourParams | None = None, **kwargs: str) -> None:
        super().__init__(params, **kwargs)
        self.bb.register_key("beta_sign", access=Access.READ)
        self.finished_detection_t: float | None = None
        self.waypoints: tuple[Point, ...] = ()
        self.next_index = 0
        self.closest_m = math.inf

    def initialise(self) -> None:
        """A new activation lays out a new tour."""
        self.waypoints = ()
        self.next_index = 0
        self.closest_m = math.inf

    def lay_out(self, centre: Point, flow: FlowEstimate) -> tuple[Point, ...]:
        """The waypoints of one whole tour around ``centre``."""
        raise NotImplementedError

    def passable(self, waypoint: Point, centre: Point) -> bool:
        """Whether passing ``waypoint`` within ``pass_radius_m`` counts as visiting it."""
        return True

    def triangle(self, centre: Point, flow: FlowEstimate, radius_m: float) -> tuple[Point, ...]:
        """Three points 120° apart at ``radius_m`` from ``centre``, in visiting order.

        First the up-flow point at ``upflow + 60°·beta_sign`` (blackboard ``beta_sign`` from
        maintain-plume, +1 when absent), then the other up-flow point at ``upflow - 60°·beta_sign``,
        then the down-flow point along ``flow_dir``. A point beyond the OpArea, or within
        ``wall_inset_m`` of its walls, is moved to the nearest point ``wall_inset_m`` inside
        (module docstring), so the tour never drives safety to take over again and again.
        """
        assert self.context is not None
        a = self.context.op_area
        beta_sign = -1 if self.bb.exists("beta_sign") and self.bb.get("beta_sign") == -1 else 1
        bearings = (
            flow.upflow_deg + 60.0 * beta_sign,
            flow.upflow_deg - 60.0 * beta_sign,
            flow.toward_deg,
        )
        inset = self.params.wall_inset_m
        return tuple(
            a.clamp(centre.x + radius_m * ux, centre.y + radius_m * uy, inset)
            for ux, uy in map(unit, bearings)
        )

    def inside(self, point: Point) -> Point:
        """``point`` moved ``wall_inset_m`` inside the OpArea if it is nearer the walls."""
        assert self.context is not None
        return self.context.op_area.clamp(point.x, point.y, self.params.wall_inset_m)

    def decide(self, p: Percept) -> Command | None:
        """Steer for the current waypoint while contact is lost and the tour is unfinished."""
        last = p.last_detection
        if p.in_plume or last is None or p.flow is None or last.t == self.finished_detection_t:
            return None
        if not self.waypoints:
            self.waypoints = self.lay_out(last.point, p.flow)
        here = p.pose.point
        while self.next_index < len(self.waypoints):
            d = here.distance_to(self.waypoints[self.next_index])
            passed = (
                self.closest_m <= self.params.pass_radius_m
                and d > self.closest_m + 1.0
                and self.passable(self.waypoints[self.next_index], last.point)
            )
            if d > self.params.arrive_radius_m and not passed:
                self.closest_m = min(self.closest_m, d)
                break
            self.next_index += 1
            self.closest_m = math.inf
        if self.next_index == len(self.waypoints):
            self.finished_detection_t = last.t
            return None
        return self.command(here.bearing_to(self.waypoints[self.next_index]))


class CloverleafParams(TourParams):
    """Parameters of the TRO cloverleaf (TRO Table I)."""

    d_leaf_m: float = Field(
        default=15.0,
        gt=0,
        description="Distance from the centre to each leaf tip; must exceed the turning radius, m",
    )
    repeats: int = Field(
        default=3, ge=1, le=100,
        description="N_re: times the cloverleaf is flown (TRO: 3). At most 100: the tour is laid "
        "out in full at activation (6 waypoints a repeat; 1e9 repeats ran out of memory), and "
        "100 repeats of 15 m leaves already fly for hours",
    )


class CloverleafReacquire(_WaypointTour):
    """Cloverleaf reacquire of TRO IV-C (SPEC §6a), flown ``repeats`` times.

    Centre C = the last detection when the behaviour activates. Tips at ``d_leaf`` from C: leaves
    1 and 2 up-flow at ``upflow ± 60°``, leaf 3 down-flow along ``flow_dir``; the up-flow leaf on
    the side of the last track-out offset goes first (see :meth:`_WaypointTour.triangle`).

    Reading chosen: the leaf's size. TRO Table I calls ``d_leaf`` the cloverleaf's "diameter",
    TRO IV-C "the length of each leaf" (10-15 m); the length is taken: each tip lies ``d_leaf``
    from C. And a leaf is C → tip → C, so the tour starts by returning to C and consecutive
    leaves share C: ``C, a, C, b, C, c, C`` and so on, ending at C. The tips are fixed by the
    flow estimate at activation. ``arrive_radius_m`` (3 m) is well under ``d_leaf`` so each leaf
    is flown out and back; it must stay below the distance the vehicle can close on a waypoint
    while turning, or a waypoint can be orbited. A tip passed within ``pass_radius_m`` counts as
    reached (module docstring), C does not: every leaf returns to the last detection itself,
    which is what puts the leaves across the plume where it was last seen (measured: letting C
    be passed too spread the lost-contact points enough that one MSN007 run in 30 never
    declared). The cost of the same clustering: where tracking stalls at a plume edge just at
    the threshold far down-flow, each return to C logs a lost contact about 0.5 m from the
    last, and TRO's up-flow cluster rule declares there (116-131 m off in 2-3 MSN007 runs of
    1000 on three of four seeds; a paper reviewer's replay of root seed 2024, replicate 92).
    """

    family: ClassVar[str] = "reacquire_plume"
    variant: ClassVar[str] = "cloverleaf"
    Params: ClassVar[type[BehaviourParams]] = CloverleafParams
    contract: ClassVar[Contract] = Contract(advise=pattern_advice)
    params: CloverleafParams

    def passable(self, waypoint: Point, centre: Point) -> bool:
        """Only the tips: every leaf returns to C itself (within ``arrive_radius_m``)."""
        return waypoint != self.inside(centre)

    def lay_out(self, centre: Point, flow: FlowEstimate) -> tuple[Point, ...]:
        """``C`` then ``repeats`` × (tip a, C, tip b, C, tip c, C); C kept off the walls."""
        tips = self.triangle(centre, flow, self.params.d_leaf_m)
        hub = self.inside(centre)
        leaves = tuple(p for tip in tips for p in (tip, hub))
        return (hub, *leaves * self.params.repeats)


class ThreePointParams(TourParams):
    """Parameters of the OMAE three-point reacquire (OMAE "Plume Reacquisition")."""

    radius_m: float = Field(
        default=15.0, gt=0, description="Radius of the circle through P1, P2, P3 about C, m"
    )
    visits: int = Field(
        default=10, ge=1, le=1000,
        description="Points visited in turn, P1 P2 P3 P1 ... (OMAE: 10). At most 1000: the tour "
        "is laid out in full at activation, and 1000 legs of 26 m already fly for hours",
    )


class ThreePointReacquire(_WaypointTour):
    """Three-point reacquire of OMAE (SPEC §6b): P1 P2 P3 P1 P2 P3 P1 P2 P3 P1, then find-plume.

    P1, P2, P3 lie 120° apart on a circle of ``radius_m`` about the last detection C.

    Reading chosen: OMAE's Fig. 3 is lost from the text; the points are placed like the
    cloverleaf's tips (SPEC §6a notes the two patterns share their 120° spacing): P1 up-flow at
    ``upflow + 60°·beta_sign`` (+1 when no maintain variant wrote ``beta_sign``), P2 at
    ``upflow - 60°·beta_sign``, P3 straight down-flow. The tour goes point to point without
    returning to C, fixed by the flow estimate at activation.
    """

    family: ClassVar[str] = "reacquire_plume"
    variant: ClassVar[str] = "three_point"
    Params: ClassVar[type[BehaviourParams]] = ThreePointParams
    contract: ClassVar[Contract] = Contract(advise=pattern_advice)
    params: ThreePointParams

    def lay_out(self, centre: Point, flow: FlowEstimate) -> tuple[Point, ...]:
        """``visits`` points cycling through P1, P2, P3."""
        points = self.triangle(centre, flow, self.params.radius_m)
        return tuple(points[i % 3] for i in range(self.params.visits))


BEHAVIOURS = [
    BehaviourSpec.of(CloverleafReacquire, default=True),
    BehaviourSpec.of(ThreePointReacquire),
]
