"""Go-to-goal behaviours: move-to-field at mission start and return-home (SPEC §8)."""

from __future__ import annotations

from typing import ClassVar

from py_trees.common import Access
from pydantic import Field

from cptbt.node import BehaviourParams, Contract, PlanBehaviour
from cptbt.registry import BehaviourSpec
from cptbt.types import Command, Percept, Point


class GoToParams(BehaviourParams):
    """Parameters of a go-to-goal behaviour."""

    arrive_radius_m: float = Field(
        default=10.0, gt=0, description="The goal counts as reached within this distance, m"
    )


class MoveToField(PlanBehaviour):
    """Drive to the mission's start point; lowest priority, and only at mission start (TRO III).

    Reading chosen: it has an output while the blackboard's ``field_reached`` is False. It sets
    ``field_reached`` itself on arrival; any other behaviour sets it the first time it has an
    output (``PlanBehaviour.ends_move_to_field``), which blocks move-to-field for good — "the
    output commands from this behavior are blocked once the vehicle activates any other
    behaviors". Find-plume waits for ``field_reached``, which is what lets move-to-field, below it
    in priority, drive first. A mission without a start point has no field to move to.
    """

    family: ClassVar[str] = "move_to_field"
    variant: ClassVar[str] = "go_to"
    contract: ClassVar[Contract] = Contract(needs_flow=False)
    Params: ClassVar[type[BehaviourParams]] = GoToParams
    params: GoToParams
    ends_move_to_field: ClassVar[bool] = False

    def __init__(self, params: BehaviourParams | None = None, **kwargs: str) -> None:
        super().__init__(params, **kwargs)

    def decide(self, p: Percept) -> Command | None:
        """Head for the start point until reached or blocked."""
        assert self.context is not None
        start = self.context.start
        if self.bb.field_reached or not p.pose.located:  # no position yet: no bearing
            return None
        if start is None or p.pose.point.distance_to(start) <= self.params.arrive_radius_m:
            self.bb.field_reached = True
            return None
        return self.command(p.pose.point.bearing_to(start))


class ReturnHome(PlanBehaviour):
    """Drive home once asked to (``go_home`` on the blackboard); ``mission_done`` on arrival.

    The planner's ``request_home()`` (time limit, operator, mission phase) sets ``go_home``; after
    a declaration the declare-source behaviour drives home itself (SPEC §7).
    """

    family: ClassVar[str] = "return_home"
    variant: ClassVar[str] = "go_to"
    contract: ClassVar[Contract] = Contract(needs_flow=False)
    Params: ClassVar[type[BehaviourParams]] = GoToParams
    params: GoToParams

    def __init__(self, params: BehaviourParams | None = None, **kwargs: str) -> None:
        super().__init__(params, **kwargs)
        self.bb.register_key("go_home", access=Access.READ)
        self.bb.register_key("mission_done", access=Access.WRITE)

    def decide(self, p: Percept) -> Command | None:
        """Head home while asked to; report arrival."""
        assert self.context is not None
        if not self.bb.go_home or not p.pose.located:  # no position yet: no bearing
            return None
        home: Point = self.context.home
        if p.pose.point.distance_to(home) <= self.params.arrive_radius_m:
            self.bb.mission_done = True
        return self.command(p.pose.point.bearing_to(home))


BEHAVIOURS = [
    BehaviourSpec.of(MoveToField, default=True),
    BehaviourSpec.of(ReturnHome, default=True),
]
