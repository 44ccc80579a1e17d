"""Map-guided reacquire: after losing contact, head for the most likely unexplored source region
up-flow of the last detection (``reacquire_plume: {variant: map_guided}``), reading the
likelihood map the declaration publishes on the blackboard (``source_map``, a
:class:`~cptbt.types.SourceBelief`; :mod:`cptbt.behaviours.likelihood`).
"""

from __future__ import annotations

import math
from typing import Any, ClassVar

import numpy as np
from py_trees.common import Access
from pydantic import Field

from cptbt.angles import unit
from cptbt.behaviours.source_map import SOURCE_MAP_KEY
from cptbt.node import BehaviourParams, Contract, PlanBehaviour
from cptbt.types import Command, Percept, Point, SourceBelief


def best_target(
    belief: SourceBelief,
    here: Point,
    *,
    explored_weight: float,
    min_distance_m: float,
    upflow_deg: float | None = None,
    behind: Point | None = None,
    behind_m: float = 0.0,
) -> Point | None:
    """The most promising cell to head for: posterior × (``explored_weight`` where explored).

    Cells within ``min_distance_m`` of ``here`` are skipped (the vehicle is there already), and,
    given ``upflow_deg`` and ``behind``, so are cells more than ``behind_m`` down-flow of
    ``behind``. None when no cell qualifies.
    """
    gx, gy = np.meshgrid(belief.xs, belief.ys)
    score = np.array(belief.posterior, dtype=float)
    if belief.explored is not None:
        score = np.where(belief.explored, score * explored_weight, score)
    keep = (gx - here.x) ** 2 + (gy - here.y) ** 2 > min_distance_m**2
    if upflow_deg is not None and behind is not None:
        ux, uy = unit(upflow_deg)
        keep &= (gx - behind.x) * ux + (gy - behind.y) * uy >= -behind_m
    score = np.where(keep, score, 0.0)
    i = int(np.argmax(score))
    if not score.flat[i] > 0:
        return None
    return Point(float(gx.flat[i]), float(gy.flat[i]))


class MapGuidedParams(BehaviourParams):
    """Parameters of the map-guided reacquire."""

    give_up_s: float = Field(
        default=180.0, gt=0, description="Find-plume takes over after this long without a "
        "detection (the cloverleaf's 3 repeats take about as long), s"
    )
    replan_s: float = Field(
        default=15.0, gt=0, description="The target is re-chosen at least this often, s"
    )
    arrive_radius_m: float = Field(
        default=4.0, gt=0, description="A target counts as reached within this distance, m"
    )
    explored_weight: float = Field(
        default=0.1, ge=0, le=1, description="Weight of cells near the track flown (1: no "
        "preference for unexplored cells)"
    )
    behind_m: float = Field(
        default=5.0, ge=0, description="Cells more than this down-flow of the last detection "
        "are not targets, m"
    )


class MapGuidedReacquire(PlanBehaviour):
    """Reacquire by heading for the most likely unexplored source region up-flow.

    While contact is lost (a detection was made, none within λ), the target is the cell of the
    published ``source_map`` with the highest posterior × (``explored_weight`` for cells near the
    track already flown, else 1), among cells no more than ``behind_m`` down-flow of the last
    detection and outside ``arrive_radius_m`` of the vehicle. It is re-chosen on arrival and
    every ``replan_s``; the non-detections on the way lower the cells it passes up-flow of, so
    the target moves on. After ``give_up_s`` without a detection the behaviour has no output for
    that lost contact and find-plume takes over (like the cloverleaf's last repeat). Without a
    published map (no ``likelihood_map`` declaration in the mission) it has no output.
    """

    family: ClassVar[str] = "reacquire_plume"
    variant: ClassVar[str] = "map_guided"
    Params: ClassVar[type[BehaviourParams]] = MapGuidedParams
    params: MapGuidedParams
    contract: ClassVar[Contract] = Contract(pairs_with=(("declare_source", "likelihood_map"),))
    persistent_state: ClassVar[tuple[str, ...]] = ("gave_up_for",)

    def __init__(self, params: BehaviourParams | None = None, **kwargs: Any) -> None:
        super().__init__(params, **kwargs)
        self.bb.register_key(SOURCE_MAP_KEY, access=Access.READ)
        self.gave_up_for: float | None = None
        self.target: Point | None = None
        self.planned_t = -math.inf

    def initialise(self) -> None:
        """A new activation chooses a new target."""
        self.target = None
        self.planned_t = -math.inf

    def decide(self, p: Percept) -> Command | None:
        """Steer for the target while contact is lost and the give-up time has not passed."""
        last = p.last_detection
        if p.in_plume or last is None or p.flow is None or last.t == self.gave_up_for:
            return None
        if p.since_detection() > self.params.give_up_s:
            self.gave_up_for = last.t
            return None
        belief = self.bb.get(SOURCE_MAP_KEY) if self.bb.exists(SOURCE_MAP_KEY) else None
        if not isinstance(belief, SourceBelief):
            return None
        here = p.pose.point
        if (self.target is None or here.distance_to(self.target) <= self.params.arrive_radius_m
                or p.t - self.planned_t >= self.params.replan_s):
            self.target = self._choose(belief, p)
            self.planned_t = p.t
        if self.target is None:
            return None
        return self.command(here.bearing_to(self.target))

    def _choose(self, belief: SourceBelief, p: Percept) -> Point | None:
        assert p.last_detection is not None and p.flow is not None
        return best_target(belief, p.pose.point, explored_weight=self.params.explored_weight,
                           min_distance_m=self.params.arrive_radius_m,
                           upflow_deg=p.flow.upflow_deg, behind=p.last_detection.point,
                           behind_m=self.params.behind_m)
