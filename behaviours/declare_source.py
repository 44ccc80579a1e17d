"""Declare-source: find a source in the lost-contact list, then go there and home (SPEC §7).

Every variant keeps checking the lost-contact list every cycle in :meth:`watch` (the tree runs it
even while a higher behaviour such as safety drives) and has no output until it declares; from
then on it is the highest plume behaviour. The variants differ only in the declaration rule
(``estimate``); the go-to-source-then-home action is shared (TRO IV-D).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any, ClassVar

from py_trees.common import Access
from pydantic import Field, model_validator

from cptbt.angles import unit
from cptbt.node import BehaviourParams, PlanBehaviour, blamed
from cptbt.registry import BehaviourSpec
from cptbt.types import Command, Percept, Point


class DeclareParams(BehaviourParams):
    """Parameters of the go-to-source-then-home action shared by the declaration rules."""

    source_radius_m: float = Field(
        default=10.0, gt=0, description="Head home once this close to the declared source, m"
    )
    home_radius_m: float = Field(
        default=10.0, gt=0, description="The mission is done once this close to home, m"
    )


def most_upflow_first(points: Sequence[Point], upflow_deg: float) -> list[Point]:
    """Points sorted by their projection on the upflow unit vector, most up-flow first.

    The sort is stable, so points at equal up-flow position keep their (oldest-first) order.
    """
    ux, uy = unit(upflow_deg)
    return sorted(points, key=lambda q: -(q.x * ux + q.y * uy))


def bounding_box(points: Sequence[Point]) -> tuple[float, float, float, float]:
    """``(xmin, xmax, ymin, ymax)`` of the points, axis-aligned in the planning frame."""
    xs = [q.x for q in points]
    ys = [q.y for q in points]
    return min(xs), max(xs), min(ys), max(ys)


class SourceDeclaration(PlanBehaviour):
    """Base of the declaration rules: declare once, then go to the source and on home (TRO IV-D).

    The rule (:meth:`estimate`) is checked every cycle in :meth:`watch` until it declares, once;
    on declaring it writes ``declared_source`` to the blackboard. After the declaration the
    heading is ``theta = atan2(y_t - y, x_t - x)``, the target being the declared source until
    the vehicle is within ``source_radius_m`` of it, then home. Within ``home_radius_m`` of home
    it writes ``mission_done = True`` and keeps heading home.

    Reading chosen: the switch from source to home is latched (once within ``source_radius_m``,
    the target stays home even if the vehicle is carried away again), otherwise heading home from
    inside the 10-m circle would immediately re-target the source. The declaration and the latch
    are kept across pre-emption (``persistent_state``): a declaration is made once per mission.
    """

    family: ClassVar[str] = "declare_source"
    Params: ClassVar[type[BehaviourParams]] = DeclareParams
    params: DeclareParams
    persistent_state: ClassVar[tuple[str, ...]] = ("declared", "heading_home")

    def __init__(self, params: BehaviourParams | None = None, **kwargs: Any) -> None:
        super().__init__(params, **kwargs)
        self.bb.register_key("declared_source", access=Access.WRITE)
        self.bb.register_key("mission_done", access=Access.WRITE)
        self.bb.register_key("homeward", access=Access.WRITE)
        self.declared: Point | None = None
        self.heading_home = False

    def initialise(self) -> None:
        """A new activation: nothing to reset, every piece of state is persistent on purpose."""

    def estimate(self, p: Percept) -> Point | None:
        """The declaration rule: the source location if the rule is met this cycle, else None."""
        raise NotImplementedError

    def watch(self, p: Percept) -> None:
        """Check the rule every cycle until it declares; publish the declared source."""
        if self.declared is not None:
            return
        source = self.estimate(p)
        if source is not None and not isinstance(source, Point):  # a review's (x, y) tuple
            raise blamed(TypeError(f"estimate() returned {type(source).__name__} "
                                   f"{source!r:.60}: return a cptbt.types.Point or None"),
                         self, p.t, where=False)
        if source is not None and math.isfinite(source.x) and math.isfinite(source.y):
            self.declared = source
            self.bb.declared_source = source

    def decide(self, p: Percept) -> Command | None:
        """No output until declared; then head for the source, and from within reach, home."""
        assert self.context is not None
        if self.declared is None or not p.pose.located:  # no fix yet: no bearing to drive
            return None  # (an attacker's rule declaring a fixed point failed check_behaviour)
        here = p.pose.point
        if not self.heading_home and here.distance_to(self.declared) <= self.params.source_radius_m:
            self.heading_home = True
            self.bb.homeward = True
        # What it is doing, recorded with its name (as likelihood_map's): the trip home had
        # been drawn and timed as the declaration's own behaviour (a review)
        self.activity = "home" if self.heading_home else "to source"
        if not self.heading_home:
            return self.command(here.bearing_to(self.declared))
        home = self.context.home
        if here.distance_to(home) <= self.params.home_radius_m:
            self.bb.mission_done = True
        return self.command(here.bearing_to(home))


class _UpflowWindowParams(DeclareParams):
    """Parameters shared by the rules that test the most up-flow of the recent points."""

    recent_points: int = Field(default=6, ge=1, description="M: lost-contact points considered")
    cluster_points: int = Field(
        default=3, ge=1, description="How many of the most up-flow of them are tested"
    )

    @model_validator(mode="after")
    def _cluster_fits(self) -> _UpflowWindowParams:
        if self.cluster_points > self.recent_points:
            raise ValueError("cluster_points must not exceed recent_points")
        return self


class UpflowClusterParams(_UpflowWindowParams):
    """Parameters of the TRO up-flow cluster rule (TRO IV-D, Table I)."""

    epsilon_m: float = Field(
        default=4.0, gt=0, description="Declare when the box diagonal R is at most this, m"
    )


class UpflowClusterDeclare(SourceDeclaration):
    """Declare at the box of the most up-flow of the recent lost-contact points (TRO IV-D).

    Take the ``M`` most recent lost-contact points, sort them by their projection on the current
    upflow unit vector (most up-flow first), keep the first ``cluster_points``, and declare the
    centre of their axis-aligned bounding box when its diagonal ``R <= epsilon_m``.

    Reading chosen: the rule waits for a full window of ``M`` points. TRO used "the M = 6 most
    recent points" because near the source the last-detection points alternate between near the
    source and further downstream (footnote 1); with fewer points the three most up-flow may all
    be downstream ones, and a declaration must never be false (TRO VI), so speed is given up.
    Without a flow estimate there is no up-flow order and no declaration.
    """

    variant: ClassVar[str] = "upflow_cluster"
    Params: ClassVar[type[BehaviourParams]] = UpflowClusterParams
    params: UpflowClusterParams

    def estimate(self, p: Percept) -> Point | None:
        """Box centre of the most up-flow recent points when the box is small enough."""
        m, k = self.params.recent_points, self.params.cluster_points
        if p.flow is None or len(p.lost_contacts) < m:
            return None
        top = most_upflow_first(p.lost_contacts[-m:], p.flow.upflow_deg)[:k]
        xmin, xmax, ymin, ymax = bounding_box(top)
        if math.hypot(xmax - xmin, ymax - ymin) > self.params.epsilon_m:
            return None
        return Point(0.5 * (xmin + xmax), 0.5 * (ymin + ymax))


class RecentBoxParams(DeclareParams):
    """Parameters of the first OMAE rule (OMAE "Source Declaration Behavior", v1)."""

    points: int = Field(default=3, ge=1, description="N: most recent lost-contact points used")
    max_side_m: float = Field(
        default=4.0, gt=0, description="Declare when the box's length and width are both below, m"
    )


class RecentBoxDeclare(SourceDeclaration):
    """Declare when the last few lost-contact points fit in a small box (OMAE, first version).

    The box of the last ``points`` lost-contact points (axis-aligned in the planning frame) must
    have length and width both strictly below ``max_side_m``; the source is declared at its
    centre.

    Reading chosen: OMAE gives no declared location for this rule; the box centre is TRO's. The
    rule waits for ``points`` points. It does not need the flow. OMAE reports that it never
    declared in the field (the box stays long along the flow); it is kept for comparison.
    Simulated, that depends on the behaviours around it: with OMAE's own
    (``missions/omae2003.yaml``: counter-turning tracking, three-point reacquire) it declared
    in 4 of 60 runs; with TRO's cloverleaf, which brings the vehicle back over the same
    lost-contact point, in every run (``benchmarks/results/omae_rules.md``).
    """

    variant: ClassVar[str] = "recent_box"
    Params: ClassVar[type[BehaviourParams]] = RecentBoxParams
    params: RecentBoxParams

    def estimate(self, p: Percept) -> Point | None:
        """Box centre of the last points when both sides are short enough."""
        n = self.params.points
        if len(p.lost_contacts) < n:
            return None
        xmin, xmax, ymin, ymax = bounding_box(p.lost_contacts[-n:])
        limit = self.params.max_side_m
        if xmax - xmin >= limit or ymax - ymin >= limit:
            return None
        return Point(0.5 * (xmin + xmax), 0.5 * (ymin + ymax))


class UpflowSpreadParams(_UpflowWindowParams):
    """Parameters of the revised OMAE rule (OMAE "Source Declaration Behavior", v2)."""

    max_spread_m: float = Field(
        default=5.0, gt=0, description="Declare when they lie within this along the flow, m"
    )


class UpflowSpreadDeclare(SourceDeclaration):
    """Declare when the most up-flow recent points agree along the flow (OMAE, revised version).

    The last ``recent_points`` lost-contact points are sorted up-flow; when the first
    ``cluster_points`` lie within ``max_spread_m`` of each other along the flow (the range of their
    projections on the upflow unit vector), the source is declared.

    Reading chosen: the declared location is the centroid of those points (OMAE does not say);
    only their along-flow spread is tested, as OMAE writes, so their cross-flow spread may be
    large. "Within" is inclusive. The rule waits for a full window and needs a flow estimate.
    """

    variant: ClassVar[str] = "upflow_spread"
    Params: ClassVar[type[BehaviourParams]] = UpflowSpreadParams
    params: UpflowSpreadParams

    def estimate(self, p: Percept) -> Point | None:
        """Centroid of the most up-flow recent points when their along-flow spread is small."""
        m, k = self.params.recent_points, self.params.cluster_points
        if p.flow is None or len(p.lost_contacts) < m:
            return None
        upflow = p.flow.upflow_deg
        top = most_upflow_first(p.lost_contacts[-m:], upflow)[:k]
        ux, uy = unit(upflow)
        along = [q.x * ux + q.y * uy for q in top]
        if max(along) - min(along) > self.params.max_spread_m:
            return None
        return Point(sum(q.x for q in top) / k, sum(q.y for q in top) / k)


BEHAVIOURS = [
    BehaviourSpec.of(UpflowClusterDeclare, default=True),
    BehaviourSpec.of(RecentBoxDeclare),
    BehaviourSpec.of(UpflowSpreadDeclare),
]
