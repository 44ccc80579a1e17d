"""Safety: keep the vehicle in the OpArea (TRO V; SPEC §3, §8)."""

from __future__ import annotations

from typing import ClassVar

from py_trees.common import Status
from pydantic import Field

from cptbt.node import BehaviourParams, Contract, PlanBehaviour
from cptbt.registry import BehaviourSpec
from cptbt.types import Command, Percept, Point


class OpAreaSafetyParams(BehaviourParams):
    """Parameters of the OpArea safety behaviour."""

    trigger_m: float = Field(
        default=5.0,
        ge=0,
        description="Take over once the vehicle is this far outside the OpArea, m",
    )
    inset_m: float = Field(
        default=10.0,
        ge=0,
        description="Steer for the point this far inside the boundary nearest the vehicle, m",
    )


class OpAreaSafety(PlanBehaviour):
    """Return the vehicle into the OpArea when a behaviour drives it out (TRO V).

    Reading chosen: the plume behaviours handle the boundary themselves (find-plume reflects off
    it), so safety only takes over once the vehicle is ``trigger_m`` outside, and then steers for
    the nearest point ``inset_m`` inside the boundary until the vehicle is back inside. Once
    triggered it keeps its output until the vehicle is inside again (hysteresis), so it does not
    chatter on the trigger line. The OpArea's ``inset_m`` is clipped to half its width.
    """

    family: ClassVar[str] = "safety"
    variant: ClassVar[str] = "oparea"
    contract: ClassVar[Contract] = Contract(needs_flow=False)
    Params: ClassVar[type[BehaviourParams]] = OpAreaSafetyParams
    params: OpAreaSafetyParams

    def initialise(self) -> None:
        """A new activation: nothing to reset (the hysteresis is the RUNNING status itself)."""

    def decide(self, p: Percept) -> Command | None:
        """Head back in while outside (beyond the trigger distance on first taking over)."""
        assert self.context is not None
        a = self.context.op_area
        outside = a.distance_outside(p.pose.x, p.pose.y)
        active = self.status == Status.RUNNING
        if outside <= 0.0 or (not active and outside <= self.params.trigger_m):
            return None
        inset_x = min(self.params.inset_m, 0.5 * (a.xmax - a.xmin))
        inset_y = min(self.params.inset_m, 0.5 * (a.ymax - a.ymin))
        goal = Point(
            min(max(p.pose.x, a.xmin + inset_x), a.xmax - inset_x),
            min(max(p.pose.y, a.ymin + inset_y), a.ymax - inset_y),
        )
        return self.command(p.pose.point.bearing_to(goal))


BEHAVIOURS = [BehaviourSpec.of(OpAreaSafety, default=True)]
