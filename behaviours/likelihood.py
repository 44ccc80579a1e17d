"""Behaviours built on the source-likelihood map (:mod:`cptbt.behaviours.source_map`).

- ``declare_source: {variant: likelihood_map}`` keeps the map, declares when its posterior is
  concentrated, optionally verifies the declaration with a fly-by (TRO VI's future work), and
  may declare several sources one after another;
- ``reacquire_plume: {variant: map_guided}`` (:mod:`cptbt.behaviours.map_guided`) heads for
  the most likely unexplored source region up-flow after losing contact, instead of flying a
  fixed pattern.

Blackboard keys (STYLE 4): the declaration writes ``source_map`` (a
:class:`~cptbt.types.SourceBelief`, every cycle), ``source_map_at_declaration`` (the belief at the
latest declaration), ``declared_sources`` (every source declared so far) and
``declaration_report`` (fly-bys and withdrawals), besides the planner's ``declared_source``;
map-guided reacquire reads ``source_map``.
"""

from __future__ import annotations

import math
from typing import Any, ClassVar

import numpy as np
from py_trees.common import Access
from pydantic import Field

from cptbt.angles import unit
from cptbt.behaviours.declare_source import DeclareParams, SourceDeclaration
from cptbt.behaviours.map_guided import MapGuidedReacquire, best_target
from cptbt.behaviours.source_map import SOURCE_MAP_KEY, MapModelParams, SourceMap
from cptbt.frames import OpArea
from cptbt.node import BehaviourParams, Contract
from cptbt.registry import BehaviourSpec
from cptbt.types import Command, Percept, Point, SourceBelief


class LikelihoodMapParams(DeclareParams, MapModelParams):
    """Parameters of the likelihood-map declaration: the map's model, the rule, the fly-by.

    The model's defaults here differ from :class:`MapModelParams`' (which infotaxis shares),
    measured on the TRO ocean preset (MSN007's plume; calibration seeds 7001–7003, none of the
    study's): every 3 s of 1200 s, 3 000 random points, each read as a planning cycle reads it
    (the maximum of 9 samples along 1.5 m of track), placed by their range ``a`` up-flow and
    offset ``c`` across the flow from the true source along the back-trajectory of the 100-s
    flow estimate. On the axis, a cycle has a concentration above the threshold in 74% of
    cycles within 10 m of the source, 55% at 25–50 m, 34% at 80–120 m and 26% at 120–230 m
    (``detection_prob`` 0.72, ``detection_decay_m`` 150); above 3 × the threshold (a *strong*
    detection) in 63%, 29%, 4.3% and 1–2% (``strong_prob`` 0.68, ``strong_decay_m`` 40). The
    rms cross-flow offset of the hits grows as the 12° meander cone predicts to ~100 m (3.0,
    5.6, 9.5, 16, 21 m) and then stays at 19–22 m (``max_spread_m`` 20). Up-flow of the
    source the chance falls from 38% within 1 m to 8% at 1–2 m and under 1% beyond
    (``behind_spread_m`` 1.5, where the one-sided σ0 of 3 m had placed declarations 3 m
    down-flow of the source, median, on tuning replicates). The former defaults
    (0.6, 1000 m, no cap, one level) expected two to three times the hits seen 150 m down-flow,
    so misses there ruled out true sources, and counted a plume 50 m to the side of a declared
    source's as that source's (the two-source search ignored the second plume); a single level
    cannot tell a detection next to the source from one 150 m down-flow, which a strong one
    nearly does.

    The meander state (``meander_memory_s``; :mod:`cptbt.behaviours.source_map`, "Correlated
    meander"), measured on the same plume and seeds by ``benchmarks/likelihood_map_meander.py``
    (every 3 s of 1200 s, the puffs within 3 m of a range ``a`` placed across the flow from the
    back-trajectory of the 100-s flow estimate, true positions, no vehicle): their mean, the
    axis's offset, has an rms of 0.9, 1.5, 1.8, 6.0, 16 and 27 m at 10, 25, 50, 100, 150 and
    200 m, and their rms spread about it (the plume's instantaneous width) 2.7, 4.2, 5.5, 7.5,
    9.1 and 10.9 m, i.e. ``σi(a)² ≈ 1 m² + 0.55 m · a`` (``instant_near_spread_m`` 1,
    ``instant_spread_m`` 0.55; 2 K_c / U of the puff model is 0.6 m). The lag at which the
    axis offset's autocorrelation falls to 1/e is 70–220 s within 50 m of the source and
    120–260 s beyond (nine values each; ``meander_memory_s`` 150). The meander's share of the
    spread is small near the source; the kernel's σ0 of 3 m there is kept, and what of it is
    not ``σi(0)`` is made persistent too (the vehicle's navigation drift, absent from the
    measurement, is of that size and persists for minutes between fixes).

    Weights, chosen on tuning replicates (root seeds 77 and 78, 40 MSN007 runs each, 20 two-source
    runs each) with the meander state: ``nondetection_weight`` 1 (no tempering; the previous 0.3 was
    the independent-cycle model's stand-in for the misses' correlation) and ``detection_weight``
    0.6. Seed 77 / 78: T_D share 25.7% / 25.5% against the independent-cycle model's 36.2% / 32.5%
    (weights 0.3 / 0.3), 0 / 0 declarations beyond 15 m (largest errors 10.4 / 8.2 m against 12.7 /
    9.1 m), median error 3.8 / 4.1 m against 2.6 / 3.0 m (upflow_cluster on seed 78: 3.6 m); both
    sources found in 40 of 40 two-source runs, none falsely. ``detection_weight`` 0.5: T_D 27.7% /
    27.5%, the same two-source result; 0.7: 23.7% / 23.9%, one false declaration in the 40
    two-source runs (a first declaration 15.6 m short of the down-flow source, on the strength of a
    run of strong detections on the approach); 1: 23.3% / 24.1%, two false in 20 (seed 78). A run of
    strong detections from one filament patch says "close" several times over and the state does not
    carry that correlation, hence the remaining tempering. ``σi(0)`` 1 m against 1.5 m or all of σ0
    (3 m, ``None``), with detection tempering 0.5 on seed 77: T_D 27.7% / 27.2% / 26.0%, largest
    errors 10.9 / 12.9 / 16.4 m (the last one beyond 15 m); τ 60 s against 150 s: T_D 29.1% against
    27.7%, τ 300 s: 25.6% against 25.7%. Widening σi near the source so that the average over the
    meander reproduces the measured chance there exactly (instead of capping ``p_in``) gave largest
    errors of 15.0 and 14.6 m on seed 77 (detection tempering 0.5 and 0.6). The study
    (``benchmarks/likelihood_map.py``) flies the independent-cycle model (weights 0.3 / 0.3, the
    previous default, and 0.5 / 0.3) and ``detection_weight`` 0.7 as rows of their own.

    The independent-cycle model's own tuning (``meander_memory_s`` None): with the sharper
    model a run of correlated detections made the map confident on the first approach, some
    15-50 m short of the source when the meander then carried the plume off the axis the
    100-s flow gives and the misses of the reacquire pattern ruled out the true source;
    ``detection_weight`` 0.3 against 0.5 gave 0 against 0 and 0 against 1 declarations beyond
    15 m on seeds 77 and 78, at the price of a T_D share of 36% and 33% against 30% and 25%.
    """

    detection_prob: float = Field(
        default=0.72, gt=0, lt=1, description="p0: chance of a detection per cycle on the "
        "plume's mean axis next to the source (measured: class docstring)"
    )
    detection_decay_m: float = Field(
        default=150.0, gt=0, description="L: range over which that chance falls by a factor e, "
        "m (measured: class docstring)"
    )
    max_spread_m: float | None = Field(
        default=20.0, gt=0, description="σmax: the meander's cross-flow spread stops growing at "
        "this (measured: class docstring), m"
    )
    behind_spread_m: float | None = Field(
        default=1.5, gt=0, description="σb: how fast K falls off for sources down-flow of the "
        "observer (measured: class docstring), m"
    )
    detection_weight: float = Field(
        default=0.6, gt=0, le=1, description="Tempering exponent of a detection's likelihood "
        "(0.6 rather than the map's 0.5: class docstring)"
    )
    nondetection_weight: float = Field(
        default=1.0, gt=0, le=1, description="Tempering exponent of a non-detection's "
        "likelihood (1, none: the meander state models the misses' correlation; class "
        "docstring)"
    )
    meander_memory_s: float | None = Field(
        default=150.0, gt=0, description="τ: correlation time of the plume's meander, with "
        "which each cell carries a meander state (measured: class docstring; None: the "
        "independent-cycle model), s"
    )
    instant_near_spread_m: float | None = Field(
        default=1.0, gt=0, description="σi(0): the plume's width about its instantaneous axis "
        "at the source; the rest of σ0 persists (measured: class docstring), m"
    )
    mask_radius_m: float = Field(
        default=15.0, gt=0, description="Cells within this of a declared source are ruled out "
        "as another source (15 m, TRO's bound: two sources closer than that cannot be told "
        "apart by the declaration's own criterion), m"
    )
    strong_factor: float | None = Field(
        default=3.0, gt=1, description="A detection at least this many times the perception's "
        "threshold is a strong one (None: one level of detection)"
    )

    radius_m: float = Field(
        default=10.0, gt=0, description="Declare when the posterior mass within this of the "
        "map's maximum exceeds the confidence (10 rather than 8 with the up-flow check: class "
        "docstring), m"
    )
    confidence: float = Field(default=0.9, gt=0, lt=1, description="Posterior mass to declare")
    min_detections: int = Field(
        default=10, ge=0, description="Detections no declared source explains needed (since "
        "the last declaration or withdrawal) before declaring"
    )
    min_lost_contacts: int = Field(
        default=0, ge=0, description="Lost contacts (SPEC §2) needed before declaring"
    )
    max_sources: int = Field(
        default=1, ge=1, le=20, description="Sources to declare before heading home"
    )
    upflow_check_m: float | None = Field(
        default=10.0, gt=0, description="Declare only once the track has passed at least this "
        "far up-flow of the candidate, within upflow_band_m of the flow line through it; until "
        "then the vehicle flies there (the OpArea's wall permitting). None: off, m"
    )
    upflow_band_m: float = Field(
        default=5.0, gt=0, description="Half-width across the flow of the up-flow check, m"
    )
    upflow_memory_s: float | None = Field(
        default=None, gt=0, description="Plume seen up-flow of a candidate vetoes it if seen "
        "within this long (None: since the search for this source began), s"
    )
    upflow_timeout_s: float = Field(
        default=120.0, gt=0, description="A check leg that has not got there after this long "
        "ends, and the candidate is declared unchecked (counted in declaration_report), s"
    )
    flyby: bool = Field(
        default=False, description="Verify each declaration with a pass across the flow "
        "down-flow of it (TRO VI)"
    )
    flyby_offset_m: float = Field(
        default=8.0, gt=0, description="How far down-flow of the declared point the pass runs, m"
    )
    flyby_half_width_m: float = Field(
        default=15.0, gt=0, description="Half the length of a pass, across the flow, m"
    )
    flyby_passes: int = Field(default=2, ge=1, le=10, description="Passes across the flow")
    flyby_min_expected: float = Field(
        default=1.0, ge=0, description="A pass that saw nothing withdraws the declaration only "
        "if the map expected at least this many detections on it"
    )
    flyby_keep_fraction: float = Field(
        default=0.5, gt=0, le=1, description="After the fly-by, the map must still hold this "
        "fraction of the confidence within radius_m of the declared point, or it is withdrawn"
    )
    flyby_timeout_s: float = Field(
        default=300.0, gt=0, description="The fly-by ends (and is judged) after this long, s"
    )
    arrive_radius_m: float = Field(
        default=3.0, gt=0, description="A fly-by or search waypoint counts as reached within "
        "this, m"
    )
    search_replan_s: float = Field(
        default=20.0, gt=0, description="Between declarations, the search target is re-chosen "
        "at least this often, s"
    )


def _radius_fits_grid(params: BehaviourParams, perception: Any) -> str | None:
    assert isinstance(params, LikelihoodMapParams)
    if params.radius_m < 0.5 * params.cell_m:
        return (f"radius_m {params.radius_m:g} is smaller than half a cell (cell_m "
                f"{params.cell_m:g}): the declaration mass would be one cell's")
    return None


class LikelihoodMapDeclare(SourceDeclaration):
    """Declare from a Bayesian source-likelihood map (Pang & Farrell, IEEE SMC-B 36(5), 2006).

    Every cycle (in :meth:`watch`, so also while safety or the fly-by drive) the percept updates the
    map (see :mod:`cptbt.behaviours.source_map` for the likelihood model and its assumptions) and
    the posterior is published on ``source_map``. The rule: once ``min_detections`` detections have
    been folded in, take the map's most probable cell; when the posterior mass within ``radius_m``
    of it exceeds ``confidence``, the source is declared at the posterior mean of that
    disc. After a declaration only detections no declared source explains count towards the next
    one's ``min_detections``: a posterior renormalised over what is left once every plume seen is
    explained piles up where no evidence reaches (the OpArea's edge) and would otherwise be declared
    there on the strength of the known plume's detections.

    **The up-flow check** (``upflow_check_m``; None turns it off). A map can be sure of a point
    short of the source: the meander carried the plume off the flow estimate's axis while the
    vehicle's misses ruled out the water up-flow (TRO MSN007, 1000 runs, seed 2024: the five
    declarations beyond 15 m lay 19-46 m down-flow of the source). Two tests stand between the
    rule and the declaration, both along the current flow estimate:

    - *crossing*: the track (since the first detection) must have crossed the candidate's flow
      line between ``upflow_check_m`` and twice that up-flow of it, reaching ``upflow_band_m``
      to either side (less ``arrive_radius_m``). Until it has, the node drives a *check leg* to
      the point that far up-flow and that far to the side not yet reached (the nearer first). A
      side whose point lies outside the OpArea, or a candidate within that reach of the up-flow
      wall, needs no crossing. A leg that has not got there after ``upflow_timeout_s`` (safety
      held the vehicle, say) ends, and the candidate is declared unchecked (counted);
    - *veto*: a detection no declared source explains, made since the search for this source
      began (within ``upflow_memory_s`` if set), lying more than ``radius_m`` up-flow of the
      candidate and within ``upflow_band_m`` of its line, vetoes it: a source is not down-flow of
      its own plume, and the map, having ruled that water out, had put such a detection down to
      a false alarm. No leg is flown; the tree searches on, and crossings made before the latest
      vetoing detection no longer count.

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

    With ``max_sources > 1`` each confirmed source is added to ``declared_sources``, its
    neighbourhood ruled out and its plume explained away in the map (rebuilt from the history),
    and the search resumes; after the last, the vehicle goes to it and home (TRO IV-D).
    ``declared_source`` is written once, at the last declaration. A declaration whose plume
    would reach an already declared source (the model's chance of a detection there is at
    least ``explained_prob``) *replaces* that source instead of adding one, and the search goes
    on (``superseded`` in ``declaration_report``): the earlier point lies down-flow in this
    one's plume, so it was the same source declared short on the approach, whose detections
    farther up-flow it could not explain. On tuning replicates (two-source mission, root seeds
    77 and 78, 200 runs) this was the mode of 5 of the 6 false declarations, each a second
    declaration 15-18 m up-flow of the first, just outside the 15-m mask.

    Readings chosen: the declaration time is the confirmation's (the fly-by is part of
    declaring); the map, the fly-by and the declarations persist across pre-emption; two
    sources one in the other's plume (within reach of ``explained_prob``) are one source; the
    up-flow check is part of declaring (its leg counts in T_D) and measures "up-flow" along the
    current flow estimate, for the track and the detections alike (a flow that has turned since
    a detection was made moves it relative to the candidate; ``upflow_memory_s`` bounds how old
    a vetoing detection may be, for tidal reversals).
    """

    variant: ClassVar[str] = "likelihood_map"
    Params: ClassVar[type[BehaviourParams]] = LikelihoodMapParams
    params: LikelihoodMapParams
    contract: ClassVar[Contract] = Contract(check=_radius_fits_grid)
    persistent_state: ClassVar[tuple[str, ...]] = (
        "declared", "heading_home", "map", "sources", "candidate", "route", "route_index",
        "flyby_seen", "flyby_expected", "flyby_t0", "flybys", "withdrawn", "withdrawn_at",
        "superseded", "check_target", "check_t0", "checks", "unchecked", "vetoed", "veto_t",
        "search_t0", "track_t", "track_x", "track_y", "track_hit",
        "detections_used", "at_declaration", "search_target", "search_t",
    )

    def __init__(self, params: BehaviourParams | None = None, **kwargs: Any) -> None:
        super().__init__(params, **kwargs)
        for key in (SOURCE_MAP_KEY, "source_map_at_declaration", "declared_sources",
                    "declaration_report"):
            self.bb.register_key(key, access=Access.WRITE)
        self.map: SourceMap | None = None
        self.sources: tuple[Point, ...] = ()
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
        self.check_target: Point | None = None
        self.check_t0 = math.nan
        self.checks = 0
        self.unchecked = 0
        self.vetoed = 0
        self.veto_t = -math.inf
        self.search_t0 = -math.inf
        self.track_t: list[float] = []
        self.track_x: list[float] = []
        self.track_y: list[float] = []
        self.track_hit: list[bool] = []
        self.detections_used = 0
        self.at_declaration: SourceBelief | None = None
        self.search_target: Point | None = None
        self.search_t = -math.inf

    def setup(self, **kwargs: Any) -> None:
        """Bind the context and lay the grid over its OpArea."""
        super().setup(**kwargs)
        assert self.context is not None
        threshold, factor = self.context.threshold, self.params.strong_factor
        strong = threshold * factor if threshold is not None and factor is not None else None
        self.map = SourceMap(self.context.op_area, self.params, strong_concentration=strong)
        self.bb.declared_sources = ()
        self._report()

    def _report(self) -> None:
        self.bb.declaration_report = {
            "flybys": self.flybys, "withdrawn": self.withdrawn,
            "withdrawn_at": [(q.x, q.y) for q in self.withdrawn_at],
            "superseded": self.superseded, "upflow_checks": self.checks,
            "unchecked": self.unchecked, "upflow_vetoes": self.vetoed,
        }

    def watch(self, p: Percept) -> None:
        """Update the map; run the fly-by's bookkeeping; test the rule; publish the map."""
        assert self.map is not None, "call setup()"
        self.map.observe(p)
        here = p.pose.point
        if self.map.detections and math.isfinite(here.x) and math.isfinite(here.y):
            self.track_t.append(p.t)
            self.track_x.append(here.x)
            self.track_y.append(here.y)
            self.track_hit.append(p.detected and not self._explained(here))
        post = self.map.posterior()
        if self.candidate is not None:
            self._flyby_step(p)
        elif len(self.sources) < self.params.max_sources:
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
        if mass < self.params.confidence or not (math.isfinite(mean.x) and math.isfinite(mean.y)):
            self.check_target = None
            return
        if not self._passed_upflow(p, mean):
            return
        if self.params.flyby and p.flow is not None:
            self._start_flyby(p, mean)
        else:
            self._accept(mean)

    def _passed_upflow(self, p: Percept, candidate: Point) -> bool:
        """The up-flow check (class docstring): True when the candidate may be declared; else
        aim a check leg (:meth:`decide` flies it) and say no."""
        u = self.params.upflow_check_m
        if u is None or p.flow is None or self.context is None:
            return True
        fx, fy = unit(p.flow.toward_deg)
        slack, w = self.params.arrive_radius_m, self.params.upflow_band_m
        t = np.asarray(self.track_t)
        dx = np.asarray(self.track_x) - candidate.x
        dy = np.asarray(self.track_y) - candidate.y
        upflow, across = -(dx * fx + dy * fy), dy * fx - dx * fy
        # Plume seen up-flow of the candidate while searching for this source: the map put it
        # down to a false alarm or another meander (it had ruled that water out), but the source
        # cannot be down-flow of its own plume. No declaration, nor check leg: the tree searches
        # on; a crossing made before the latest such detection no longer counts.
        seen = np.asarray(self.track_hit) & (t > self.search_t0)
        memory = self.params.upflow_memory_s
        if memory is not None:
            seen &= t >= p.t - memory
        seen &= (upflow > self.params.radius_m) & (np.abs(across) <= w)
        if bool(np.any(seen)):
            self.check_target = None
            newest = float(t[seen].max())
            if newest > self.veto_t:
                self.veto_t = newest
                self.vetoed += 1
                self._report()
            return False
        need = min(u, _room(self.context.op_area, candidate, -fx, -fy) - slack)
        if need <= slack:  # against the up-flow wall: there is nothing up-flow to look at
            self.check_target = None
            return True
        near = across[(upflow >= need - slack) & (upflow <= 2 * need + slack) & (t > self.veto_t)]
        area = self.context.op_area
        ends = [Point(candidate.x - need * fx - s * w * fy, candidate.y - need * fy + s * w * fx)
                for s in (1.0, -1.0)]
        # A side whose end lies outside the OpArea has nothing to show: it counts as reached.
        left = bool(np.any(near >= w - slack)) or not area.contains(ends[0].x, ends[0].y)
        right = bool(np.any(near <= slack - w)) or not area.contains(ends[1].x, ends[1].y)
        if left and right:
            self.check_target = None
            return True
        if self.check_target is None:
            self.check_t0 = p.t
            self.checks += 1
            self._report()
        elif p.t - self.check_t0 >= self.params.upflow_timeout_s:
            self.check_target = None
            self.unchecked += 1
            self._report()
            return True
        side = 1 if left else 0
        if not (left or right):  # neither side yet: the nearer one first
            here = p.pose.point
            side = int(here.distance_to(ends[1]) < here.distance_to(ends[0]))
        self.check_target = ends[side]
        return False

    def _accept(self, source: Point) -> None:
        assert self.map is not None
        self.candidate, self.route = None, ()
        i = next((j for j, known in enumerate(self.sources)
                  if self.map.expected_detection(source, known.x, known.y)
                  >= self.params.explained_prob), None)
        if i is not None:  # a declared source in this one's plume: the same source, short
            self.sources = (*self.sources[:i], source, *self.sources[i + 1:])
            self.superseded += 1
            self._report()
        else:
            self.sources = (*self.sources, source)
        self.detections_used, self.search_t0 = self.map.unexplained, self.map.t
        self.at_declaration = self.map.belief()
        self.bb.set("source_map_at_declaration", self.at_declaration)
        self.bb.declared_sources = self.sources
        if len(self.sources) >= self.params.max_sources:
            self.declared = source
            self.bb.declared_source = source
        else:
            self.map.explain(self.sources)

    # -- fly-by ---------------------------------------------------------------------------
    def _start_flyby(self, p: Percept, candidate: Point) -> None:
        assert self.context is not None and p.flow is not None
        a = self.context.op_area
        fx, fy = unit(p.flow.toward_deg)
        off, hw = self.params.flyby_offset_m, self.params.flyby_half_width_m
        cx, cy = candidate.x + off * fx, candidate.y + off * fy
        ends = [Point(min(max(cx + s * hw * -fy, a.xmin), a.xmax),
                      min(max(cy + s * hw * fx, a.ymin), a.ymax)) for s in (1, -1)]
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
            self.detections_used, self.search_t0 = self.map.unexplained, self.map.t
            self.candidate, self.route = None, ()
        self._report()

    def decide(self, p: Percept) -> Command | None:
        """Fly the fly-by while one is under way; search on between declarations; otherwise go
        to the source, then home."""
        if self.candidate is not None and self.route_index < len(self.route):
            return self.command(p.pose.point.bearing_to(self.route[self.route_index]))
        if self.check_target is not None and self.declared is None:
            return self.command(p.pose.point.bearing_to(self.check_target))
        if self.sources and self.declared is None:
            return self._search_on(p)
        return super().decide(p)

    def _search_on(self, p: Percept) -> Command | None:
        """Between declarations: while the latest detection is one a declared source explains,
        steer for the most probable unexplored cell of the map rather than let maintain-plume
        follow a known plume back to its source; an unexplained detection hands control back."""
        assert self.map is not None
        last = p.last_detection
        here = p.pose.point
        if last is not None and not self._explained(last.point):
            self.search_target = None
            return None
        if (self.search_target is None or p.t - self.search_t >= self.params.search_replan_s
                or here.distance_to(self.search_target) <= self.params.arrive_radius_m):
            self.search_target = best_target(self.map.belief(), here, explored_weight=0.1,
                                             min_distance_m=self.params.arrive_radius_m)
            self.search_t = p.t
        if self.search_target is None:
            return None
        return self.command(here.bearing_to(self.search_target))

    def _explained(self, at: Point) -> bool:
        assert self.map is not None
        return any(self.map.expected_detection(s, at.x, at.y) >= self.params.explained_prob
                   for s in self.sources)


def _room(area: OpArea, at: Point, dx: float, dy: float) -> float:
    """How far from ``at`` (inside the OpArea) along the unit direction (dx, dy) the wall is."""
    room = math.inf
    for c, d, lo, hi in ((at.x, dx, area.xmin, area.xmax), (at.y, dy, area.ymin, area.ymax)):
        if d > 1e-12:
            room = min(room, (hi - c) / d)
        elif d < -1e-12:
            room = min(room, (lo - c) / d)
    return max(room, 0.0)


BEHAVIOURS = [
    BehaviourSpec.of(LikelihoodMapDeclare),
    BehaviourSpec.of(MapGuidedReacquire),
]
