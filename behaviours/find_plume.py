"""Find-plume: billiard-ball search of the OpArea (SPEC §4; TRO IV-A, AB appendix, OMAE).

Both variants head at a fixed offset from the flow direction, ``flow_dir ± offset``, and reflect
off the OpArea walls: leaving through a y wall turns the cross-flow component back inside;
leaving through an x wall picks the offset that points the along-flow component back inside
(the small, down-flow offset after the up-flow wall; the large, up-flow offset after the
down-flow wall). They differ in their offsets and in how they start.
"""

from __future__ import annotations

import math
from typing import ClassVar

from pydantic import Field

from cptbt.angles import sign
from cptbt.frames import OpArea
from cptbt.node import BehaviourParams, PlanBehaviour
from cptbt.registry import BehaviourSpec
from cptbt.types import Command, FlowEstimate, Percept


class BilliardParams(BehaviourParams):
    """Parameters of the TRO billiard find-plume (TRO Table I)."""

    dtheta_up_deg: float = Field(
        default=125.0,
        gt=90,
        lt=180,
        description="Offset from flow_dir after leaving the down-flow x wall (heads up-flow), deg",
    )
    dtheta_down_deg: float = Field(
        default=60.0,
        gt=0,
        lt=90,
        description="Offset from flow_dir after leaving the up-flow x wall (heads down-flow), deg",
    )


class AppendixBilliardParams(BehaviourParams):
    """Parameters of the AB-appendix billiard find-plume."""

    initial_offset_deg: float = Field(
        default=70.0, gt=0, lt=180, description="|theta_0|: offset from flow_dir at start, deg"
    )
    offset_after_upflow_deg: float = Field(
        default=70.0,
        gt=0,
        lt=90,
        description="|theta| after leaving through the up-flow x wall (heads down-flow), deg",
    )
    offset_after_downflow_deg: float = Field(
        default=110.0,
        gt=90,
        lt=180,
        description="|theta| after leaving through the down-flow x wall (heads up-flow), deg",
    )


class _Billiard(PlanBehaviour):
    """Shared bounce mechanics; subclasses give the offsets.

    State (kept across pre-emption on purpose, see ``persistent_state``): the cross-flow side to
    head for (``+1`` toward +y), the offset magnitude, and the contact count at the last
    (re)start. A reflection sets the state from which wall the vehicle is beyond, not by
    toggling it, so ticks spent beyond a wall repeat the same reflection: one excursion can
    never flip the heading back and forth.
    """

    persistent_state: ClassVar[tuple[str, ...]] = ("toward_y", "offset_deg", "started_at_contact")

    def __init__(self, params: BehaviourParams | None = None, **kwargs: str) -> None:
        super().__init__(params, **kwargs)
        self.toward_y = 1
        self.offset_deg = math.nan
        self.started_at_contact: int | None = None

    def start_offset_deg(self, x: float, area: OpArea, flow: FlowEstimate) -> float:
        """The offset magnitude on (re)start."""
        raise NotImplementedError

    def offset_after_x_exit_deg(self, upflow_wall: bool) -> float:
        """The offset magnitude after leaving through the up-flow or the down-flow x wall."""
        raise NotImplementedError

    def decide(self, p: Percept) -> Command | None:
        """Reflect off the walls; head ``flow_dir ± offset`` toward the chosen cross-flow side."""
        assert self.context is not None
        if not self.bb.field_reached or p.flow is None:
            return None
        area = self.context.op_area
        x, y = p.pose.x, p.pose.y
        if self.started_at_contact != p.contact_count:
            # (Re)start: first activation, or find-plume again after a plume contact.
            self.started_at_contact = p.contact_count
            self.toward_y = sign(area.centre.y - y)
            self.offset_deg = self.start_offset_deg(x, area, p.flow)
        else:
            if y < area.ymin or y > area.ymax:
                self.toward_y = sign(area.centre.y - y)
            if x < area.xmin or x > area.xmax:
                upflow_wall = (x < area.xmin) == (sign(p.flow.vx) > 0)
                self.offset_deg = self.offset_after_x_exit_deg(upflow_wall)
        return self.command(self._heading(p.flow.toward_deg))

    def _heading(self, flow_dir: float) -> float:
        """``flow_dir + s*offset`` with s making the cross-flow (y) motion go ``toward_y``."""
        plus = flow_dir + self.offset_deg
        minus = flow_dir - self.offset_deg
        toward = self.toward_y
        if toward * math.sin(math.radians(plus)) >= toward * math.sin(math.radians(minus)):
            return plus
        return minus


class BilliardFindPlume(_Billiard):
    """Billiard-ball find-plume of TRO IV-A: ``theta = flow_dir + s*dtheta`` (SPEC §4a).

    s makes ``sin(theta)`` take the sign of ``eta = 0.5*(ymin+ymax) - y`` (sign(0) = +1), eta
    being recomputed only when the vehicle leaves through a y wall; ``dtheta`` becomes
    ``dtheta_down`` after leaving through the up-flow x wall and ``dtheta_up`` after the
    down-flow one. The up-flow x wall is the one the flow comes from: ``xmin`` when the flow's
    x component is >= 0, else ``xmax``.

    Reading chosen: "(re)start" is the first tick with an output, and the first one after a
    plume contact was made (``contact_count`` changed); pre-emption by safety alone keeps the
    bounce state. On (re)start the vehicle's position splits the OpArea in four; the largest
    part is the larger y side times the larger x side, so s heads for the larger y side (which
    is sign(eta)) and ``dtheta`` is ``dtheta_down`` when the down-flow side is strictly larger,
    else ``dtheta_up`` (OMAE: toward the farthest corner). "Leaving through a wall" is the
    estimated position being beyond it. s itself
    is recomputed every tick from the current flow, so a turning flow keeps the cross-flow
    motion pointed at the chosen side.
    """

    family: ClassVar[str] = "find_plume"
    variant: ClassVar[str] = "billiard"
    Params: ClassVar[type[BehaviourParams]] = BilliardParams
    params: BilliardParams

    def start_offset_deg(self, x: float, area: OpArea, flow: FlowEstimate) -> float:
        """``dtheta_down`` if the down-flow part of the OpArea is the larger, else ``dtheta_up``."""
        downflow = area.xmax - x if sign(flow.vx) > 0 else x - area.xmin
        upflow = (area.xmax - area.xmin) - downflow
        return self.params.dtheta_down_deg if downflow > upflow else self.params.dtheta_up_deg

    def offset_after_x_exit_deg(self, upflow_wall: bool) -> float:
        """``dtheta_down`` after the up-flow wall, ``dtheta_up`` after the down-flow wall."""
        return self.params.dtheta_down_deg if upflow_wall else self.params.dtheta_up_deg


class AppendixBilliardFindPlume(_Billiard):
    """Billiard find-plume of the AB appendix: ``psi_v = psi_w + theta_i`` (SPEC §4b).

    ``theta_0 = 70°·sign((ymin+ymax)/2 - y0)``; leaving through a y wall, ``theta = -theta``;
    leaving through an x wall, ``|theta|`` becomes 70° at the up-flow wall and 110° at the
    down-flow wall, its sign kept.

    Reading chosen: AB assumes the flow runs toward +x, where the sign of theta is the sign of
    the cross-flow (y) motion. So that the pattern survives any flow direction, the sign is kept
    as the y side to head for (as in :class:`BilliardFindPlume`): the start heads for the larger
    y side, and a y-wall exit turns back inside — which is ``theta = -theta`` whenever the
    vehicle left heading outward. (Re)start and wall exits are read as in the TRO variant.
    """

    family: ClassVar[str] = "find_plume"
    variant: ClassVar[str] = "billiard_ab"
    Params: ClassVar[type[BehaviourParams]] = AppendixBilliardParams
    params: AppendixBilliardParams

    def start_offset_deg(self, x: float, area: OpArea, flow: FlowEstimate) -> float:
        """``|theta_0|``, whatever the position."""
        return self.params.initial_offset_deg

    def offset_after_x_exit_deg(self, upflow_wall: bool) -> float:
        """70° after the up-flow wall, 110° after the down-flow wall (defaults)."""
        if upflow_wall:
            return self.params.offset_after_upflow_deg
        return self.params.offset_after_downflow_deg


BEHAVIOURS = [
    BehaviourSpec.of(BilliardFindPlume, default=True),
    BehaviourSpec.of(AppendixBilliardFindPlume),
]
