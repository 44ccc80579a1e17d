"""Behaviours built on the source-likelihood map (:mod:`cptbt.behaviours.source_map`).

- ``declare_source: {variant: likelihood_map}`` keeps the map, declares when its posterior is
  concentrated and the candidate passes the up-flow check (:mod:`cptbt.behaviours.upflow_check`),
  optionally verifies the declaration with a fly-by (TRO VI's future work), and may declare
  several sources one after another (its parameters and how they were measured:
  :mod:`cptbt.behaviours.likelihood_params`);
- ``reacquire_plume: {variant: map_guided}`` (:mod:`cptbt.behaviours.map_guided`) heads for
  the most likely unexplored source region up-flow after losing contact, instead of flying a
  fixed pattern.

Blackboard keys (STYLE 4): the declaration writes ``source_map`` (a
:class:`~cptbt.types.SourceBelief`, every cycle), ``source_map_at_declaration`` (the belief at the
latest declaration, or when the search for more sources gave up), ``declared_sources`` (every
source declared so far) and ``declaration_report`` (fly-bys, withdrawals, up-flow checks and
vetoes), besides the planner's ``declared_source``; map-guided reacquire reads ``source_map``.
"""

from __future__ import annotations

import math
from typing import Any, ClassVar

import numpy as np
from py_trees.common import Access

from cptbt.angles import unit
from cptbt.behaviours.likelihood_params import (
    LikelihoodMapParams,
    advise,
    settings_fit,
)
from cptbt.behaviours.map_guided import MapGuidedReacquire
from cptbt.behaviours.several_sources import SeveralSources
from cptbt.behaviours.source_map import SOURCE_MAP_KEY, SourceMap
from cptbt.behaviours.upflow_check import UpflowCheck
from cptbt.frames import room
from cptbt.node import BehaviourParams, Contract
from cptbt.registry import BehaviourSpec
from cptbt.types import Command, Percept, Point


class LikelihoodMapDeclare(SeveralSources):
    """Declare from a Bayesian source-likelihood map (Pang & Farrell, IEEE SMC-B 36(5), 2006).

    Every cycle (in :meth:`watch`, so also while safety or the fly-by drive) the percept updates the
    map (see :mod:`cptbt.behaviours.source_map` for the map and its assumptions,
    :mod:`cptbt.behaviours.plume_likelihood` for the likelihood model and its own) and
    the posterior is published on ``source_map``. The rule: once ``min_detections`` detections have
    been folded in, take the map's most probable cell; when the posterior mass within ``radius_m``
    of it exceeds ``confidence``, the source is declared at the posterior mean of that
    disc. After a declaration only detections no declared source explains count towards the next
    one's ``min_detections``: a posterior renormalised over what is left once every plume seen is
    explained piles up where no evidence reaches (the OpArea's edge) and would otherwise be declared
    there on the strength of the known plume's detections.

    **The up-flow check** (``upflow_check_m``; None turns it off): a map can be sure of a point
    short of the source, so the candidate must have had plume seen near it (else the vehicle
    visits it), the track must have crossed its flow line up-flow of it (else a *check leg*),
    and no plume may have been seen up-flow of it (a *veto*); the legs and visits are flown
    early, as the map becomes sure. The rule, its readings and how each part was measured:
    :mod:`cptbt.behaviours.upflow_check`'s docstring.

    The checks and vetoes are counted in ``declaration_report`` and the run's summary.

    With ``flyby``, a declaration is first a *candidate*: the vehicle flies ``flyby_passes``
    straight passes across the flow, ``flyby_offset_m`` down-flow of it (TRO VI: "drive the AUV
    past the declared source location in the downflow direction"). A detection on a pass confirms
    it. A pass that saw nothing where the map expected at least ``flyby_min_expected``
    detections (the sum of the model's detection chance over the pass) withdraws it: the search
    resumes, and a new declaration needs ``min_detections`` fresh detections. A pass the map
    expected little of (its waypoints clipped by the OpArea, say) cannot refute, and confirms.
    Seeing plume down-flow does not show that none comes from farther up-flow (a candidate on a
    plume's axis, short of its source, passes that test), so the map itself is asked again at
    the end of the fly-by, with everything the manoeuvre observed folded in: unless it still
    holds ``flyby_keep_fraction`` × ``confidence`` within ``radius_m`` of the candidate, the
    candidate is withdrawn.

    With ``max_sources > 1`` a confirmed source is kept, its plume explained away in the map,
    and the search goes on: :class:`~cptbt.behaviours.several_sources.SeveralSources` (the
    rules for a source declared again, the hold in a known plume, the search between
    declarations and when it ends, each with how it was measured).

    Readings chosen: the declaration time is the confirmation's (the fly-by is part of
    declaring); the map, the fly-by and the declarations persist across pre-emption; two
    sources one in the other's plume (within reach of ``explained_prob``), or declared closer
    than ``same_source_m``, are one source; the up-flow check is part of declaring (its leg counts
    in T_D).
    """

    variant: ClassVar[str] = "likelihood_map"
    Params: ClassVar[type[BehaviourParams]] = LikelihoodMapParams
    params: LikelihoodMapParams
    contract: ClassVar[Contract] = Contract(check=settings_fit, advise=advise)
    persistent_state: ClassVar[tuple[str, ...]] = (
        "declared", "heading_home", "map", "groups", "candidate", "route",
        "route_index", "flyby_seen", "flyby_expected", "flyby_t0", "flybys", "withdrawn",
        "withdrawn_at", "superseded", "superseded_at", "upflow",
        "detections_used", "at_declaration", "search_target", "search_t",
        "evidence_t", "evidence_count", "search_given_up", "search_end", "sweep",
        "sweeping", "last_level", "held_in_known_plume", "held_at", "blocked_s", "blocked_at",
        "watch_t", "cycle_s",
    )

    def __init__(self, params: BehaviourParams | None = None, **kwargs: Any) -> None:
        super().__init__(params, **kwargs)
        for key in (SOURCE_MAP_KEY, "source_map_at_declaration", "declared_sources",
                    "declaration_report"):
            self.bb.register_key(key, access=Access.WRITE)
        self.map: SourceMap | None = None
        self.candidate: Point | None = None
        self.route: tuple[Point, ...] = ()
        self.route_index = 0
        self.flyby_seen = 0
        self.flyby_expected = 0.0
        self.flyby_t0 = math.nan
        self.flybys = 0
        self.withdrawn = 0
        self.withdrawn_at: tuple[Point, ...] = ()
        self.superseded = 0
        self.superseded_at: tuple[Point, ...] = ()
        self.last_level = 1  # the latest detection's level (2: strong; SourceMap.level)
        self.held_in_known_plume = 0  # cycles a confident candidate was held in a known plume
        self.held_at: Point | None = None  # the latest candidate held so
        self.watch_t = -math.inf  # the latest cycle's time
        self.cycle_s = 0.0
        self.upflow = UpflowCheck(
            self.params.upflow_check_m or 0.0, self.params.upflow_band_m, self.params.radius_m,
            self.params.arrive_radius_m, self.params.upflow_memory_s,
            self.params.upflow_timeout_s,
            self.params.upflow_fan_deg if self.params.max_sources == 1 else 0.0,
            near_m=self.params.radius_m if self.params.upflow_seen_near else None,
            veto_near_m=self.params.upflow_veto_near_m, window_m=self.params.upflow_window_m,
            crossings=self.params.upflow_crossings or (1 if self.params.max_sources == 1 else 2),
            crossing_gap_s=self.params.upflow_crossing_gap_s)
        self.upflow.known_veto = self.params.upflow_known_veto
        self.detections_used = 0

    def setup(self, **kwargs: Any) -> None:
        """Bind the context and lay the grid over its OpArea."""
        super().setup(**kwargs)
        assert self.context is not None
        threshold, factor = self.context.threshold, self.params.strong_factor
        strong = threshold * factor if threshold is not None and factor is not None else None
        self.map = SourceMap(self.context.op_area, self.params, strong_concentration=strong)
        trace = self.params.upflow_trace_fraction
        self.upflow.trace_level = threshold * trace if threshold is not None \
            and trace is not None else None
        self.bb.declared_sources = ()
        self._report()

    def _report(self) -> None:
        self.bb.declaration_report = {
            "flybys": self.flybys, "withdrawn": self.withdrawn,
            "withdrawn_at": [(q.x, q.y) for q in self.withdrawn_at],
            "superseded": self.superseded,
            "superseded_at": [(q.x, q.y) for q in self.superseded_at], **self.upflow.report(),
            "search_given_up": self.search_given_up, "search_end": self.search_end,
            "held_in_known_plume": self.held_in_known_plume,
            "held_at": None if self.held_at is None else (self.held_at.x, self.held_at.y),
            "verifying_at": None if self.candidate is None else (self.candidate.x,
                                                                 self.candidate.y),
        }

    def watch(self, p: Percept) -> None:
        """Update the map; run the fly-by's bookkeeping; test the rule; publish the map."""
        assert self.map is not None, "call setup()"
        # this cycle's length (a jump of the clock counts as one minute at most)
        self.cycle_s = min(max(p.t - self.watch_t, 0.0), 60.0) if math.isfinite(
            self.watch_t) else 0.0
        self.watch_t = p.t
        self.map.observe(p)
        level = self.map.level(p)
        if level:
            self.last_level = level
        if self.map.unexplained != self.evidence_count:
            self.evidence_t, self.evidence_count = p.t, self.map.unexplained
        if self.map.detections and self.params.upflow_check_m is not None:
            here = p.pose.point
            reading = p.concentration if p.in_op_area else math.nan
            # a reading in a declared source's plume, 0 or not, says nothing of this source
            explained = math.isfinite(reading) and bool(self.sources) and self._explained(
                here, level)
            self.upflow.record(p.t, here, p.detected and not explained,
                               math.nan if explained else reading, p.detected)
        post = self.map.posterior()
        if self.candidate is not None:
            self._flyby_step(p)
        elif len(self.sources) < self.params.max_sources and not self.search_given_up:
            if self._give_up(p):
                self._report()
            else:
                self._test_rule(p, post)
        self.bb.set(SOURCE_MAP_KEY, self.map.belief(post))

    def _test_rule(self, p: Percept, post: np.ndarray) -> None:
        assert self.map is not None
        if self.map.unexplained - self.detections_used < self.params.min_detections:
            return
        if len(p.lost_contacts) < self.params.min_lost_contacts:
            return
        peak = self.map.peak(post)
        mass, mean = self.map.mass_and_mean(peak, self.params.radius_m, post)
        sure = mass >= self.params.confidence
        early = self.params.upflow_early_fraction if self.params.max_sources == 1 else None
        nearly = sure or (early is not None and self.params.upflow_check_m is not None
                          and mass >= early * self.params.confidence)
        if not nearly or not (math.isfinite(mean.x) and math.isfinite(mean.y)):
            self.upflow.drop()
            return
        limit = self.params.known_plume_max_prob
        if limit is not None and self.map.known and self.map.known_chance(mean) >= limit:
            self.upflow.drop()  # held: the search goes on (class docstring)
            if not sure:  # nor is a leg flown early for it
                return
            self.held_in_known_plume += 1
            self.held_at = mean
            self._blocked(mean)
            self._report()
            return
        if not self._passed_upflow(p, mean, early=not sure):
            if self.upflow.vetoing and self.sources and sure:
                self._blocked(mean)
            return
        if not sure:  # checked early (upflow_early_fraction): declared once the map is sure
            return
        if self.params.flyby and p.flow is not None:
            self._start_flyby(p, mean)
        else:
            self._accept(mean)

    def _passed_upflow(self, p: Percept, candidate: Point, early: bool = False) -> bool:
        """The up-flow check (class docstring); counts it in the report."""
        if self.params.upflow_check_m is None or self.context is None:
            return True
        passed = self.upflow.passed(p, candidate, self.context.op_area, early)
        self._report()
        return passed

    def _accept(self, source: Point) -> None:
        assert self.map is not None
        self.candidate, self.route = None, ()
        near, plume = self._same(source)
        i = near if near is not None else plume
        if i is not None:  # taken for the same source again: the later point replaces it
            # near: both go on explaining its plume; in this one's plume: this one explains it
            group = (*self.groups[i], source) if near is not None else (source,)
            self.superseded_at = (*self.superseded_at, self.sources[i])
            self.groups = (*self.groups[:i], group, *self.groups[i + 1:])
            self.superseded += 1
            self._report()
        else:
            self.groups = (*self.groups, (source,))
        self.detections_used = self.map.unexplained
        self.upflow.restart(self.map.t)
        self.sweep.reset()
        self.evidence_t = self.map.t
        self.blocked_s, self.held_at, self.blocked_at = 0.0, None, None
        self.at_declaration = self.map.belief()
        self.bb.set("source_map_at_declaration", self.at_declaration)
        self.bb.declared_sources = self.sources
        if len(self.sources) >= self.params.max_sources:
            self.declared = source
            self.bb.declared_source = source
        else:
            self.map.explain(self.explainers)

    # -- fly-by ---------------------------------------------------------------------------
    def _start_flyby(self, p: Percept, candidate: Point) -> None:
        assert self.context is not None and p.flow is not None
        a = self.context.op_area
        fx, fy = unit(p.flow.toward_deg)
        off, hw = self.params.flyby_offset_m, self.params.flyby_half_width_m
        inset = self.params.flyby_wall_inset_m
        # the pass's centre kept inset inside the walls, each half shortened to stay so: still
        # straight across the flow (clamping each end's x and y apart bent it in an oblique
        # flow, and ends on a wall sent the turn outside, where safety took over)
        centre = a.clamp(candidate.x + off * fx, candidate.y + off * fy, inset)
        ends = []
        for s in (1.0, -1.0):
            half = min(hw, room(a, centre, -s * fy, s * fx, inset))
            ends.append(Point(centre.x - s * half * fy, centre.y + s * half * fx))
        here = p.pose.point
        ends.sort(key=here.distance_to)  # start at the nearer end
        self.route = tuple(ends[i % 2] for i in range(self.params.flyby_passes + 1))
        self.candidate, self.route_index = candidate, 0
        self.flyby_seen, self.flyby_expected, self.flyby_t0 = 0, 0.0, p.t
        self.flybys += 1
        self._report()

    def _flyby_step(self, p: Percept) -> None:
        assert self.map is not None and self.candidate is not None
        here = p.pose.point
        if self.route_index >= 1 and math.isfinite(p.concentration) and p.in_op_area:
            self.flyby_seen += int(p.detected)
            self.flyby_expected += self.map.expected_detection(self.candidate, here.x, here.y)
        while (self.route_index < len(self.route)
               and here.distance_to(self.route[self.route_index]) <= self.params.arrive_radius_m):
            self.route_index += 1
        timed_out = p.t - self.flyby_t0 >= self.params.flyby_timeout_s
        if self.route_index < len(self.route) and not timed_out:
            return
        mass, _ = self.map.mass_and_mean(self.candidate, self.params.radius_m)
        supported = mass >= self.params.flyby_keep_fraction * self.params.confidence
        if supported and (self.flyby_seen > 0
                          or self.flyby_expected < self.params.flyby_min_expected):
            self._accept(self.candidate)
        else:
            self.withdrawn += 1
            self.withdrawn_at = (*self.withdrawn_at, self.candidate)
            self.detections_used = self.map.unexplained
            self.upflow.restart(self.map.t)
            self.sweep.reset()
            self.evidence_t = self.map.t  # the search restarts: so does its give-up clock
            self.candidate, self.route = None, ()
        self._report()

    def decide(self, p: Percept) -> Command | None:
        """Fly the fly-by while one is under way; search on between declarations; otherwise go
        to the source, then home."""
        if self.candidate is not None and self.route_index < len(self.route):
            self.activity = "fly-by"
            return self.command(p.pose.point.bearing_to(self.route[self.route_index]))
        if self.upflow.target is not None and self.declared is None:
            self.activity = self.upflow.kind
            return self.command(p.pose.point.bearing_to(self.upflow.target))
        if self.sources and self.declared is None:
            self.activity = "search on"
            return self._search_on(p)
        cmd = super().decide(p)
        self.activity = "home" if self.heading_home else "to source"
        return cmd

BEHAVIOURS = [
    BehaviourSpec.of(LikelihoodMapDeclare),
    BehaviourSpec.of(MapGuidedReacquire),
]
