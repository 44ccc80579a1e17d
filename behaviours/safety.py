"""Safety: keep the vehicle in the OpArea (TRO V; SPEC §3, §8)."""

from __future__ import annotations

from typing import ClassVar

from py_trees.common import Access, Status
from pydantic import Field

from cptbt.frames import Normal, WallExit
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
    release_m: float = Field(
        default=5.0,
        ge=0,
        description="Hand back once the vehicle is this far inside the OpArea, m (at most "
        "inset_m and a quarter of the OpArea's smaller side)",
    )


class OpAreaSafety(PlanBehaviour):
    """Return the vehicle into the OpArea when a behaviour drives it out (TRO V).

    Reading chosen: the plume behaviours handle the boundary themselves (find-plume reflects off
    it, the maintain and reacquire patterns are kept inside), so safety only takes over once
    the vehicle is ``trigger_m`` outside. It then steers for the nearest point ``inset_m``
    inside the boundary — along the wall's inward normal, or toward the interior diagonally at
    a corner — and keeps its output until the vehicle is ``release_m`` *inside* the OpArea.
    The gap between taking over outside and handing back inside is the hysteresis that stops
    safety and the behaviour below from trading control at the wall every cycle; handing back
    with room to turn means a behaviour that still heads for the wall is reflected by its own
    rule (or by the plume behaviours' wall margins) before it reaches the trigger again. Both
    insets are clipped to what a small OpArea allows (``inset_m`` to half its width on each
    axis, ``release_m`` to ``inset_m`` and to a quarter of the smaller side).

    On handing back it writes a :class:`~cptbt.frames.WallExit` to the blackboard key
    ``oparea_exit`` (where it took over and the walls the vehicle was beyond during the
    excursion), so that find-plume's next leg leaves that wall instead of driving out again.
    """

    family: ClassVar[str] = "safety"
    variant: ClassVar[str] = "oparea"
    contract: ClassVar[Contract] = Contract(needs_flow=False)
    Params: ClassVar[type[BehaviourParams]] = OpAreaSafetyParams
    params: OpAreaSafetyParams

    def __init__(self, params: BehaviourParams | None = None, **kwargs: str) -> None:
        super().__init__(params, **kwargs)
        self.bb.register_key("oparea_exit", access=Access.WRITE)
        self.taken_over_at: Point | None = None
        self.walls: tuple[Normal, ...] = ()

    def initialise(self) -> None:
        """A new take-over: forget the previous excursion."""
        self.taken_over_at = None
        self.walls = ()

    def decide(self, p: Percept) -> Command | None:
        """Head back in from beyond the trigger distance until ``release_m`` inside."""
        assert self.context is not None
        a = self.context.op_area
        x, y = p.pose.x, p.pose.y
        active = self.status == Status.RUNNING
        if not active:
            if a.distance_outside(x, y) <= self.params.trigger_m:
                return None
            self.taken_over_at = p.pose.point
            self.walls = ()
        release = min(self.params.release_m, self.params.inset_m,
                      0.25 * min(a.xmax - a.xmin, a.ymax - a.ymin))
        if a.depth_inside(x, y) >= release:
            self._report(p.t)
            return None
        self.walls = (*self.walls, *(w for w in a.walls_beyond(x, y) if w not in self.walls))
        goal = a.clamp(x, y, self.params.inset_m)
        return self.command(p.pose.point.bearing_to(goal))

    def _report(self, t: float) -> None:
        if self.taken_over_at is not None and self.walls:
            self.bb.oparea_exit = WallExit(t, self.taken_over_at, self.walls)
        self.taken_over_at = None


BEHAVIOURS = [BehaviourSpec.of(OpAreaSafety, default=True)]
