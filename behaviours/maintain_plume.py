"""Maintain-plume: keep contact with the plume while moving up-flow (SPEC §5; TRO IV-B, OMAE).

Every variant writes the sign of its last cross-flow offset to the blackboard key ``beta_sign``
(int, ±1), which the cloverleaf reacquire reads to pick its first leaf. Contact is lost after
the mission's ``perception.lambda_s`` without a detection (TRO Table I: λ = 8.5 s), which is what
hands control to reacquire-plume; λ is the perception's, shared by every behaviour, so it is set
there and not on a maintain entry.

**(clarified) Walls.** The papers track up-flow until contact is lost, wherever that leads; in a
small OpArea, or with the source near a wall, that drives the vehicle out and safety takes over
again and again. Every variant therefore keeps its heading inside: within ``wall_margin_m`` of a
wall (estimated position), a heading out through that wall is turned along it (its outward
component removed), and beyond the wall it is turned back in (the component reversed); see
:meth:`~cptbt.frames.OpArea.heading_inside`. A vehicle that turns at most at radius R and is
commanded every T s at speed V then leaves the OpArea by at most ``R + V*T - wall_margin_m``
(plus its navigation error): 4 m for the REMUS (7.5 m, 1.5 m/s, 1 Hz) and the default 5 m.
Detections are only made inside the OpArea (SPEC §2), so the source the vehicle tracks toward
is never beyond the wall. ``beta_sign`` is the offset's side before the wall changes it.
"""

from __future__ import annotations

import math
from typing import Any, ClassVar

import py_trees
from py_trees.common import Access
from pydantic import Field

from cptbt.angles import bearing_deg, sign, wrap_deg
from cptbt.node import BehaviourParams, Contract, PlanBehaviour
from cptbt.registry import BehaviourSpec
from cptbt.types import Command, Percept


class WallMarginParams(BehaviourParams):
    """The wall margin every maintain variant keeps (module docstring, "Walls")."""

    wall_margin_m: float = Field(
        default=5.0,
        ge=0,
        description="Within this distance of a wall a heading out through it is turned along "
        "the wall (beyond the wall, back in), m",
    )


def _inside(node: PlanBehaviour, p: Percept, heading_deg: float, margin_m: float) -> float:
    """``heading_deg`` kept from driving out of the OpArea near a wall (module docstring)."""
    assert node.context is not None
    return node.context.op_area.heading_inside(heading_deg, p.pose.x, p.pose.y, margin_m)


class TrackParams(WallMarginParams):
    """Parameters of TRO track-in / track-out (TRO Table I), shared by both leaves."""

    beta_deg: float = Field(
        default=10.0, ge=0, lt=90, description="|beta|: track-out offset from upflow, deg"
    )


class TrackIn(PlanBehaviour):
    """Track-in of TRO IV-B: while detecting, head straight up-flow (``flow_dir + 180``)."""

    family: ClassVar[str] = "maintain_plume"
    variant: ClassVar[str] = "track_in"
    Params: ClassVar[type[BehaviourParams]] = TrackParams
    params: TrackParams

    def decide(self, p: Percept) -> Command | None:
        """Up-flow while this cycle is a detection."""
        if not p.detected or p.flow is None:
            return None
        return self.command(_inside(self, p, p.flow.upflow_deg, self.params.wall_margin_m))


class TrackOut(PlanBehaviour):
    """Track-out of TRO IV-B: detected within λ but not now; head up-flow, bent toward the plume.

    ``phi = atan2(y_last - y, x_last - x)``, ``dphi = wrap(flow_dir - phi)``,
    ``beta = beta_mag*sign(dphi)``, ``theta = flow_dir + 180 + beta``: the offset turns the
    vehicle toward the side of the flow axis through the last detection where it lies. Writes
    ``sign(beta)`` to ``beta_sign`` on every output.
    """

    family: ClassVar[str] = "maintain_plume"
    variant: ClassVar[str] = "track_out"
    Params: ClassVar[type[BehaviourParams]] = TrackParams
    params: TrackParams

    def __init__(self, params: BehaviourParams | None = None, **kwargs: str) -> None:
        super().__init__(params, **kwargs)
        self.bb.register_key("beta_sign", access=Access.WRITE)

    def decide(self, p: Percept) -> Command | None:
        """Up-flow plus ``beta`` toward the last detection's side, while in the plume."""
        last = p.last_detection
        if p.detected or not p.in_plume or last is None or p.flow is None:
            return None
        flow_dir = p.flow.toward_deg
        phi = bearing_deg(last.x - p.pose.x, last.y - p.pose.y)
        beta_sign = sign(wrap_deg(flow_dir - phi))
        heading = flow_dir + 180.0 + beta_sign * self.params.beta_deg
        cmd = self.command(_inside(self, p, heading, self.params.wall_margin_m))
        if cmd is not None:
            self.bb.beta_sign = beta_sign
        return cmd


class CounterTurnParams(WallMarginParams):
    """Parameters of the OMAE counter-turning tracker.

    OMAE gives no values; the defaults borrow TRO Table I's (the same team's planner a year on):
    ``L = λ = 8.5 s``, ``B = β = 10°``, and ``T_w = 2L`` so that after its reversal the vehicle
    has as long to cross back as it had to cross out.
    """

    hold_s: float = Field(
        default=8.5, gt=0, description="L: the offset's sign reverses every L s without detection"
    )
    beta_deg: float = Field(default=10.0, ge=0, lt=90, description="|B|: offset from upflow, deg")


def _counter_turn_needs_time(params: BehaviourParams, perception: Any) -> str | None:
    hold = getattr(params, "hold_s", 0.0)
    if perception.lambda_s <= hold:
        return (f"counter_turn reverses after hold_s = {hold:g} s without a detection, but "
                f"perception.lambda_s = {perception.lambda_s:g} s ends contact first; set "
                f"perception.lambda_s above hold_s (OMAE: T_w = 2L = {2 * hold:g} s)")
    return None


class CounterTurnTrack(PlanBehaviour):
    """Counter-turning plume tracker of OMAE "Plume Tracking" (SPEC §5b).

    Heads ``F + 180 + s·B``. For L s after a detection s holds; each further L s without a
    detection reverses it (the counter-turn); after ``T_w`` s without a detection (the mission's
    ``perception.lambda_s``; OMAE gives no value, ``missions/omae2003.yaml`` reads it as
    ``2L`` = 17 s: our reading) contact is lost and the behaviour
    has no output. Writes s to ``beta_sign``. ``validate`` refuses ``lambda_s <= hold_s``: the
    tracker would lose contact before it ever counter-turns.

    Reading chosen: "the sign selected to cause the vehicle to cross the plume" keeps the
    cross-flow direction the vehicle was moving in at the detection,
    ``s = sign(wrap(psi - upflow))`` with ``psi`` its heading on the first tick this behaviour
    sees that detection. The sign belongs to the detection, not to the activation, so it is
    kept across pre-emption (``persistent_state``).
    """

    family: ClassVar[str] = "maintain_plume"
    variant: ClassVar[str] = "counter_turn"
    contract: ClassVar[Contract] = Contract(check=_counter_turn_needs_time)
    Params: ClassVar[type[BehaviourParams]] = CounterTurnParams
    params: CounterTurnParams
    persistent_state: ClassVar[tuple[str, ...]] = ("crossing_sign", "signed_detection_t")

    def __init__(self, params: BehaviourParams | None = None, **kwargs: str) -> None:
        super().__init__(params, **kwargs)
        self.bb.register_key("beta_sign", access=Access.WRITE)
        self.crossing_sign = 1
        self.signed_detection_t: float | None = None

    def decide(self, p: Percept) -> Command | None:
        """``upflow + s·B`` while in contact, s reversing every ``hold_s`` without detection."""
        last = p.last_detection
        if not p.in_plume or last is None or p.flow is None:
            return None
        upflow = p.flow.upflow_deg
        if self.signed_detection_t != last.t:
            self.signed_detection_t = last.t
            self.crossing_sign = sign(wrap_deg(p.pose.heading_deg - upflow))
        reversals = math.floor(p.since_detection() / self.params.hold_s)
        beta_sign = -self.crossing_sign if reversals % 2 else self.crossing_sign
        heading = upflow + beta_sign * self.params.beta_deg
        cmd = self.command(_inside(self, p, heading, self.params.wall_margin_m))
        if cmd is not None:
            self.bb.beta_sign = beta_sign
        return cmd


def _build_track_in_out(params: BehaviourParams, namespace: str) -> py_trees.behaviour.Behaviour:
    return py_trees.composites.Selector(
        "maintain_plume",
        memory=False,
        children=[TrackIn(params, namespace=namespace), TrackOut(params, namespace=namespace)],
    )


BEHAVIOURS = [
    BehaviourSpec(
        family="maintain_plume",
        variant="track_in_out",
        params=TrackParams,
        build=_build_track_in_out,
        summary="Track-in / track-out of TRO IV-B: up-flow, bent toward the plume after it.",
        behaviour_classes=(TrackIn, TrackOut),
        default=True,
    ),
    BehaviourSpec.of(CounterTurnTrack),
]
