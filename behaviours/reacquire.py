"""Reacquire-plume: a local search around the last detection (SPEC §6; TRO IV-C, OMAE).

Both variants are waypoint tours laid out when they start, centred on the last detection, and
steered by bearing to the current waypoint. They have an output only while contact is lost (a
detection was made, but not within λ); any detection gives control back to maintain-plume. A
finished tour stays finished for that lost contact: it has no output, so find-plume takes
over, until a new contact is made and lost again. A tour interrupted (by a detection or by
safety) starts afresh on its next activation.
"""

from __future__ import annotations

from typing import ClassVar

from py_trees.common import Access
from pydantic import Field

from cptbt.angles import unit, wrap_deg
from cptbt.node import BehaviourParams, PlanBehaviour
from cptbt.registry import BehaviourSpec
from cptbt.types import Command, FlowEstimate, Percept, Point


class _WaypointTour(PlanBehaviour):
    """A tour of waypoints laid out on activation around the last detection point."""

    persistent_state: ClassVar[tuple[str, ...]] = ("finished_detection_t",)

    def __init__(self, params: BehaviourParams | None = None, **kwargs: str) -> None:
        super().__init__(params, **kwargs)
        self.finished_detection_t: float | None = None
        self.waypoints: tuple[Point, ...] = ()
        self.next_index = 0

    def initialise(self) -> None:
        """A new activation lays out a new tour."""
        self.waypoints = ()
        self.next_index = 0

    def lay_out(self, centre: Point, flow: FlowEstimate) -> tuple[Point, ...]:
        """The waypoints of one whole tour around ``centre``."""
        raise NotImplementedError

    def decide(self, p: Percept) -> Command | None:
        """Steer for the current waypoint while contact is lost and the tour is unfinished."""
        last = p.last_detection
        if p.in_plume or last is None or p.flow is None or last.t == self.finished_detection_t:
            return None
        if not self.waypoints:
            self.waypoints = self.lay_out(last.point, p.flow)
            self.next_index = 0
        here = p.pose.point
        while (
            self.next_index < len(self.waypoints)
            and here.distance_to(self.waypoints[self.next_index]) <= self.params.arrive_radius_m
        ):
            self.next_index += 1
        if self.next_index == len(self.waypoints):
            self.finished_detection_t = last.t
            return None
        return self.command(here.bearing_to(self.waypoints[self.next_index]))


class CloverleafParams(BehaviourParams):
    """Parameters of the TRO cloverleaf (TRO Table I)."""

    d_leaf_m: float = Field(
        default=15.0,
        gt=0,
        description="Distance from the centre to each leaf tip; must exceed the turning radius, m",
    )
    repeats: int = Field(default=3, ge=1, description="N_re: times the cloverleaf is flown")
    arrive_radius_m: float = Field(
        default=3.0, gt=0, description="A waypoint counts as reached within this distance, m"
    )


class CloverleafReacquire(_WaypointTour):
    """Cloverleaf reacquire of TRO IV-C (SPEC §6a), flown ``repeats`` times.

    Centre C = the last detection when the behaviour activates. Tips at ``d_leaf`` from C: leaves
    1 and 2 up-flow at ``upflow ± 60°``, leaf 3 down-flow along ``flow_dir``. The first leaf is
    the up-flow one at ``upflow + 60°·beta_sign`` (blackboard ``beta_sign`` from maintain-plume,
    +1 when absent), then the other up-flow leaf, then leaf 3.

    Reading chosen: a leaf is C → tip → C, so the tour starts by returning to C and consecutive
    leaves share C: ``C, a, C, b, C, c, C`` and so on, ending at C. The tips are fixed by the
    flow estimate at activation. ``arrive_radius_m`` (3 m) is well under ``d_leaf`` so each
    leaf is flown out and back; it must stay below the distance the vehicle can close on a
    waypoint while turning, or a waypoint can be orbited.
    """

    family: ClassVar[str] = "reacquire_plume"
    variant: ClassVar[str] = "cloverleaf"
    Params: ClassVar[type[BehaviourParams]] = CloverleafParams

    def __init__(self, params: BehaviourParams | None = None, **kwargs: str) -> None:
        super().__init__(params, **kwargs)
        self.bb.register_key("beta_sign", access=Access.READ)

    def lay_out(self, centre: Point, flow: FlowEstimate) -> tuple[Point, ...]:
        """``C`` then ``repeats`` × (tip a, C, tip b, C, tip c, C)."""
        beta_sign = self.bb.get("beta_sign") if self.bb.exists("beta_sign") else 1
        side = -1 if beta_sign == -1 else 1
        d = self.params.d_leaf_m
        bearings = (
            wrap_deg(flow.upflow_deg + 60.0 * side),
            wrap_deg(flow.upflow_deg - 60.0 * side),
            flow.toward_deg,
        )
        leaf: list[Point] = []
        for b in bearings:
            ux, uy = unit(b)
            leaf += [Point(centre.x + d * ux, centre.y + d * uy), centre]
        return (centre, *leaf * self.params.repeats)


BEHAVIOURS = [BehaviourSpec.of(CloverleafReacquire, default=True)]
