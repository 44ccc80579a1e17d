"""Declaring more than one source with the likelihood map (``max_sources`` > 1).

:class:`SeveralSources` is the part of :class:`~cptbt.behaviours.likelihood.LikelihoodMapDeclare`
that keeps the sources declared so far, tells a declaration of a source already declared from a
new one, searches on between declarations and decides when that search ends. The map, the rule,
the up-flow check and the fly-by are the subclass's.
"""

from __future__ import annotations

import math
from typing import Any

from cptbt.behaviours.declare_source import SourceDeclaration
from cptbt.behaviours.likelihood_params import TURN_RADIUS_M, LikelihoodMapParams
from cptbt.behaviours.map_guided import best_target
from cptbt.behaviours.source_map import SourceMap
from cptbt.behaviours.sweep import CrossFlowSweep
from cptbt.behaviours.upflow_check import UpflowCheck
from cptbt.node import BehaviourParams
from cptbt.types import Command, Percept, Point, SourceBelief


class SeveralSources(SourceDeclaration):
    """The several-source search of the likelihood-map declaration (its subclass sets up the
    map, the up-flow check and the rule, and publishes ``declaration_report``).

    With ``max_sources > 1`` each confirmed source is added to ``declared_sources``, its
    neighbourhood ruled out and its plume explained away in the map (rebuilt from the history),
    and the search resumes; after the last, the vehicle goes to it and home (TRO IV-D).
    ``declared_source`` is written once, at the last declaration. Where fewer sources may be
    there than ``max_sources`` allows, ``search_give_up_s`` bounds the search between
    declarations: that long after the latest declaration, withdrawn fly-by or detection no
    declared source explains (and with no check leg, visit or fly-by under way), the search
    ends, ``declared_source`` is the latest point, and the vehicle heads home
    (``search_given_up`` in ``declaration_report``; the planner's ``declared_source`` is
    written then, and the run summary's ``search_end_t`` is that time, while its t3 is the
    last declaration's). It ends so too when the declared sources' masks cover every cell
    (``search_end`` says which).
    Without it, the vehicle searches on to the time limit (sweeping the OpArea across the flow
    while nothing unexplained is seen: :meth:`_search_on`); a source lying
    in a declared one's plume is never found (its detections are explained away: three seeds
    of the two-source mission with a third source 110 m down-flow of one, in its plume).
    A declaration whose plume
    would reach an already declared source (the model's chance of a detection there is at
    least ``explained_prob``) *replaces* that source instead of adding one, and the search goes
    on (``superseded`` in ``declaration_report``): the earlier point lies down-flow in this
    one's plume, so it was the same source declared short on the approach, whose detections
    farther up-flow it could not explain; only within ``same_plume_m`` (50 m) of it, though:
    the model's plume reaches some 40 m to either side of its axis 100 m down-flow, and a
    review saw a correct declaration of a source 98 m down-flow and 40 m aside replaced so
    (the short declarations seen fell 16-36 m from their source). On tuning replicates
    (two-source mission, root seeds 77 and 78, 200 runs) this was the mode of 5 of the 6 false
    declarations, each a second
    declaration 15-18 m up-flow of the first, just outside the 15-m mask. So is a declaration
    within ``same_source_m`` (18 m) of a declared source (the nearest), wherever it lies: a
    source declared up to ~12 m off leaves detections next to the true one that its plume does
    not explain, and their mass settles just outside the mask (the two-source studies' double
    declarations fell 15.5-17.8 m from the first point; a wider mask only moves them to its
    edge). Either way the later point replaces the earlier in ``declared_sources`` (it was
    made from what the earlier one left unexplained), and the replaced point is listed in
    ``declaration_report["superseded_at"]``. A point replaced for being near goes on
    explaining that source's plume in the map beside the new one, so the search moves on to
    plume neither explains; a point replaced for lying in the new one's plume is forgotten,
    with the points it had itself replaced (the new one explains it, and far down a wide plume
    the rule can take another source for this one's: forgotten, that source is found again).

    Strong detections far down a known plume are not explained by it (strong ones are rare
    there: :meth:`~cptbt.behaviours.plume_likelihood.PlumeLikelihood._miss_known`), so a source
    lying in the edge of a declared one's plume is found by them; its weak detections still are the
    known plume's, and there the up-flow check cannot tell the known plume from the
    candidate's own. A candidate where a declared source's plume would give a detection in
    at least ``known_plume_max_prob`` (0.2) of cycles is therefore held, not declared, and the
    search goes on (``held_in_known_plume`` counts the cycles). The chance does not tell a
    short candidate from a right one; the hold only keeps the rule from declaring where it is
    blind, at the price of some sources it would have declared right. Chosen on a review's
    runs: in a 30-m corridor with the second source 80 m down-flow of the first and 10 m
    aside, two candidates 23 and 95 m short of it (chances 0.21 and 0.22) were declared
    without the hold and are held with it (those runs time out, 1 of 2 found), while a third
    source 20 m aside of the first's axis, 90 m down (0.38), is held though it would have been
    declared 6 m off. Measured in batches, the hold against none (12 runs each; an earlier
    claim that it changed no run came from batches that had silently flown the hold both
    times, a null setting being lost when the mission was written out): sources 90 m apart
    along the flow and 30 or 40 m across, 12 of 12 both found either way (the hold slower,
    mean 781 s against 604 s at 30 m); the corridor, 6 of 12 all found, none false, 6 timed
    out, against 5 of 12 and 7 false (18-89 m off); three sources, 7 of 12, 3 false against 9
    and 3; two sources in line along the flow 80 m apart, 3 of 12, 1 false, 9 timed out,
    against 5 and 8 false (15-36 m); 50 m apart, 1 of 12, 1 false, 10 timed out, against 1
    and 11 false (44-128 m). A lower hold trades sources found for false declarations: on 48
    three-source runs (root seed 5), 0.2: all found in 37, 7 false, 4 timed out; 0.1: 27, 4,
    18; 0.05 (``explained_prob``, where weak detections stop counting for the candidate): 24,
    1, 23. Without the hold a candidate in a known plume lands at its
    source's short distance or ~100 m down-flow of the declared source, where that source's
    strong detections are no longer explained.

    The latest held candidate is reported (``held_at``; ``held_candidate`` in the summary): a
    probable source the rule could not confirm, never a declaration. A vehicle holding one
    circles it, drawn by its strong detections, which are new plume (so the give-up clock of
    plume unexplained never runs out): with ``search_give_up_s``, confident candidates held
    or vetoed that long in all since the latest declaration end the search too (cycles
    without a confident candidate do not count: the map is still learning), and the vehicle
    goes home (``search_end`` says so; a candidate more than ``same_plume_m`` from the last
    one blocked starts the count again); without it the vehicle holds to the time limit (in
    line 80 m apart, 9 of 12 runs held for most of 3 600 s). A veto counts because with
    ``upflow_known_veto`` a candidate in a known plume is vetoed rather than held, and the
    vehicle circled it the same way; a veto by the candidate's own plume seen up-flow lasts
    only until the vehicle follows that plume up.

    ``upflow_known_veto`` (off by default) makes a detection the known plume explains veto a
    candidate down-flow of it as unexplained plume does, closing the check's blind band
    between ``explained_prob`` (0.05) and the hold's 0.2. On the two-source mission it
    changed none of 200 runs of seed 2024 and one of seed 2025 (declared 21 s later); with
    the hold, in the batches above: three sources 2 false against 3, in line 50 m apart 0
    against 1, the others as without, but one pair 30 m aside timed out; on 48 further
    three-source runs (root seed 5) 5 false against 7, but 30 all found against 37 (13
    timed out against 4): a source in the edge of another's plume is vetoed by that plume.
    A user who would rather lose a source than declare one falsely can set it; without the
    hold it cut the false declarations from 7 to 2 (corridor), 11 to 2 and
    8 to 2 (in line), at the same price in timeouts.

    The rule compares *declared points*, not sources: two real sources farther apart than
    ``same_source_m`` are still merged when a declaration of each falls within it (a correct
    declaration can be ~12 m off). With sources 20 m apart across the flow a review saw that
    in 2 of 10 runs, the correct first point replaced and the search run to the time limit;
    where sources may lie within ~30 m of each other, ``same_source_m: null`` keeps every
    declaration apart (and declares a source twice more often).
    """

    params: LikelihoodMapParams
    map: SourceMap | None  # laid in the subclass's setup()
    upflow: UpflowCheck
    detections_used: int  # the map's unexplained detections the latest declaration used
    last_level: int  # the latest detection's level (2: strong; SourceMap.level)
    cycle_s: float  # this cycle's length
    held_in_known_plume: int  # cycles a confident candidate was held in a known plume
    groups: tuple[tuple[Point, ...], ...] = ()
    evidence_count: int = 0

    def __init__(self, params: BehaviourParams | None = None, **kwargs: Any) -> None:
        super().__init__(params, **kwargs)
        # per declared source, the points explaining its plume: those it replaced as near, then it
        self.groups = ()
        # time since the latest declaration a confident candidate was held or vetoed while
        # searching for a further source (search_give_up_s)
        self.blocked_s = 0.0
        self.blocked_at: Point | None = None  # the latest candidate held or vetoed
        self.at_declaration: SourceBelief | None = None
        self.search_target: Point | None = None
        self.search_t = -math.inf
        self.sweeping = False  # the last search-on cycle flew the sweep
        self.sweep = CrossFlowSweep(self.params.search_sweep_spacing_m or math.inf,
                                    self.params.search_sweep_inset_m, self.params.arrive_radius_m,
                                    min_lane_m=2 * TURN_RADIUS_M)
        # the latest declaration, withdrawal or unexplained detection (search_give_up_s's clock)
        self.evidence_t = -math.inf
        self.evidence_count = 0  # the map's unexplained detections at evidence_t
        self.search_given_up = False
        self.search_end: str | None = None  # why the search for more sources ended early

    def _give_up(self, p: Percept) -> bool:
        """``search_give_up_s`` since the latest declaration or unexplained detection, with no
        check leg or visit under way, or no cell left outside the declared sources' masks
        (``mask_radius_m`` covering the OpArea): the search ends with the sources found, and
        the vehicle heads home (each source was reached when it was declared)."""
        if self.search_given_up:
            return True
        assert self.map is not None
        limit = self.params.search_give_up_s
        if not self.sources:
            return False
        held = limit is not None and self.blocked_s >= limit
        if not self.map.exhausted and not held and (
                limit is None or self.upflow.target is not None or p.t - self.evidence_t < limit):
            return False
        source = self.sources[-1]
        self.declared = source
        self.bb.declared_source = source
        self.heading_home = True
        self.search_given_up = True
        # which of the two blocked them (a review read "held ..., vetoed ..." on a run with no
        # veto): the run's counts, as the report has them
        why = [w for w, n in (("held in a declared source's plume", self.held_in_known_plume),
                              ("vetoed by plume seen up-flow of them", self.upflow.vetoes)) if n]
        self.search_end = (
            "no cell left outside the declared sources' masks (mask_radius_m)"
            if self.map.exhausted else
            f"candidates held or vetoed {limit:g} s in all, none confirmed ("
            + "; ".join([*why, "search_give_up_s"]) + ")" if held else
            f"{limit:g} s without plume the declared sources do not explain (search_give_up_s)")
        self.at_declaration = self.map.belief()  # the map the search ended on (t3)
        self.bb.set("source_map_at_declaration", self.at_declaration)
        return True

    def _blocked(self, candidate: Point) -> None:
        """A cycle the confident ``candidate`` was held or vetoed (``search_give_up_s``'s other
        clock); a candidate more than ``same_plume_m`` (or 50 m) from the last one blocked
        starts the clock again: a review saw a third source's candidate, 10 m from it, cut off
        by the time spent on another 80 m away."""
        far = self.params.same_plume_m or 50.0
        if self.blocked_at is not None and self.blocked_at.distance_to(candidate) > far:
            self.blocked_s = 0.0
        self.blocked_at = candidate
        self.blocked_s += self.cycle_s

    @property
    def sources(self) -> tuple[Point, ...]:
        """The sources declared so far (each group's latest point)."""
        return tuple(group[-1] for group in self.groups)

    @property
    def explainers(self) -> tuple[Point, ...]:
        """Every point whose plume the map explains away: the declared sources and the points
        each replaced for being near it."""
        return tuple(q for group in self.groups for q in group)

    def _same(self, source: Point) -> tuple[int | None, int | None]:
        """Which declared source a new declaration at ``source`` is again (class docstring):
        the nearest within ``same_source_m`` of it, and the first in its plume within
        ``same_plume_m`` of it (None: none)."""
        assert self.map is not None
        limit = self.params.same_source_m
        d = [source.distance_to(q) for q in self.sources]
        near = (min(range(len(d)), key=d.__getitem__)
                if limit is not None and d and min(d) < limit else None)
        reach = self.params.same_plume_m
        plume = next((j for j, q in enumerate(self.sources)
                      if (reach is None or d[j] < reach)
                      and self.map.expected_detection(source, q.x, q.y)
                      >= self.params.explained_prob), None)
        return near, plume

    def _search_on(self, p: Percept) -> Command | None:
        """Between declarations: while the latest detection is one a declared source explains,
        search on rather than let maintain-plume follow a known plume back to its source; an
        unexplained detection hands control back (to maintain-plume, reacquire, find-plume)
        until ``search_map_s`` after it with the sweep, for good without.

        Until a detection no declared source explains is made, the map holds nothing but
        misses and the known plumes since the declaration, and its most probable cell is
        merely the one no miss reached (the walls' cells): the vehicle sweeps the OpArea
        across the flow (:class:`~cptbt.behaviours.sweep.CrossFlowSweep`,
        ``search_sweep_spacing_m``), which crosses the plume of any source up-flow of each leg.
        Once one is made, the plume behaviours lead, and across a known plume the vehicle
        steers for the map's most probable unexplored cell (as it does without a sweep), for
        ``search_map_s``; that long after the latest such detection (a false alarm, a plume
        lost for good) it sweeps again, from where it is."""
        assert self.map is not None
        last = p.last_detection
        here = p.pose.point
        sweeps = self.params.search_sweep_spacing_m is not None
        if last is not None and not self._explained(last.point, self.last_level) and (
                not sweeps or p.t - last.t < self.params.search_map_s):
            self.search_target, self.sweeping = None, False  # the sweep resumes from anew
            return None
        fresh = (self.map.unexplained != self.detections_used
                 and p.t - self.evidence_t < self.params.search_map_s)
        if sweeps and p.flow is not None and self.context is not None and not fresh:
            if not self.sweeping:
                self.sweep.reset()
            waypoint = self.sweep.target(here, p.flow.toward_deg, self.context.op_area)
            self.sweeping = waypoint is not None
            if waypoint is not None:
                return self.command(here.bearing_to(waypoint))
        self.sweeping = False
        if (self.search_target is None or p.t - self.search_t >= self.params.search_replan_s
                or here.distance_to(self.search_target) <= self.params.arrive_radius_m):
            self.search_target = best_target(self.map.belief(), here, explored_weight=0.1,
                                             min_distance_m=self.params.arrive_radius_m)
            if self.search_target is not None and self.context is not None:
                # not to the wall's own cells: safety would turn the vehicle back outside
                self.search_target = self.context.op_area.clamp(
                    self.search_target.x, self.search_target.y, self.params.search_sweep_inset_m)
            self.search_t = p.t
        if self.search_target is None:
            return None
        return self.command(here.bearing_to(self.search_target))

    def _explained(self, at: Point, level: int = 1) -> bool:
        assert self.map is not None
        return self.map.explained_by_known(at.x, at.y, level=level)
