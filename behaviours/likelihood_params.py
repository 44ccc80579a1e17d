"""Parameters of the likelihood-map declaration (:mod:`cptbt.behaviours.likelihood`): the map's
model as measured on the TRO ocean, the declaration rule, the up-flow check and the fly-by, with
how each default was measured or chosen."""

from __future__ import annotations

from typing import Any

from pydantic import Field

from cptbt.behaviours.declare_source import DeclareParams
from cptbt.behaviours.map_model import MapModelParams
from cptbt.behaviours.source_map import grid_advice
from cptbt.frames import OpArea
from cptbt.node import BehaviourParams


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

    How the rule's other defaults were chosen, on tuning seeds 77 and 78 and after inspecting the
    study's failures, and every idea measured and dropped, with its figures, is recorded in
    ``benchmarks/results/likelihood_map_tuning.md``. In short: ``detection_weight`` 0.6 and
    ``nondetection_weight`` 1 (the meander state carries the misses' correlation; a run of
    strong detections from one filament patch is still tempered); the up-flow check's
    ``upflow_check_m`` 10 m and ``upflow_band_m`` 5 m, its trace veto at 0.25 of the
    threshold, its veto from 5 m up-flow (``upflow_veto_near_m``) and the visit
    (``upflow_seen_near``), each made from the study's declarations beyond 15 m; the early
    leg (``upflow_early_fraction`` 0.7) and a fan of 20° (``upflow_fan_deg``) together. A fan
    alone removes more of those declarations but costs more T_D share than issue 13's 25%
    allows; flying the check while the map gathers its last evidence, rather than after, pays
    for it. With both, every one of the twelve declarations beyond 15 m known (seeds 2024,
    2026, 2027 and 77) is declared within 9.3 m; on seeds 2026-2028 (2028 flown once after the
    rule was fixed) 5 of 3000 lie beyond 15 m, none farther than 16.9 m (before: 10 of 4000,
    up to 33 m), at a T_D share of 24.3-24.6%; the price is about 0.2 m of median error (3.8 m
    against the up-flow cluster's 3.6 m on seed 2028). Both serve a single source: with
    ``max_sources`` above 1 neither is flown (behaviours/upflow_check.py's docstring).
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
    same_source_m: float | None = Field(
        default=18.0, gt=0, le=100, description="A declaration within this of a declared source "
        "is taken for that source again: it replaces it (superseded), and both points go on "
        "explaining its plume. It compares declared points, which can be ~12 m off: real sources "
        "up to ~30 m apart can be merged (None: only a declared source in the new one's plume is "
        "the same source), m"
    )
    same_plume_m: float | None = Field(
        default=50.0, gt=0, description="A declaration whose plume reaches a declared source "
        "(at least explained_prob) is taken for that source declared short only within this "
        "of it: it replaces it (the short declarations seen fell 16-36 m from the source, 46 m "
        "without the up-flow check); a declared source farther down its plume is another "
        "source (None: at any distance), m"
    )
    known_plume_max_prob: float | None = Field(
        default=0.2, gt=0, le=1, description="A candidate where a declared source's plume "
        "would give a detection in at least this share of cycles is held, not declared: there "
        "the up-flow check cannot tell that plume from the candidate's (SeveralSources' "
        "docstring; None: no hold)"
    )
    upflow_known_veto: bool = Field(
        default=False, description="A detection a declared source's plume explains still "
        "vetoes a candidate down-flow of it, as plume seen up-flow does: fewer false "
        "declarations near a known plume, more sources in its edge never declared (measured: "
        "SeveralSources' docstring; False: only unexplained plume vetoes)"
    )
    upflow_check_m: float | None = Field(
        default=10.0, gt=0, description="The up-flow check's reach: declare only once the track "
        "(since this source's search began) has crossed the candidate's flow line this far "
        "up-flow of it (give or take arrive_radius_m), reaching upflow_band_m to both sides; "
        "until then the vehicle flies there. Plume seen between radius_m and three times this "
        "up-flow of the candidate, within upflow_band_m of its line, vetoes it. None: no "
        "check, m"
    )
    upflow_window_m: float | None = Field(
        default=None, gt=0, description="A crossing counts for the up-flow check from "
        "upflow_check_m less arrive_radius_m up to this far up-flow of the candidate: an empty "
        "crossing rules out only sources farther up-flow than it (upflow_check.py's "
        "docstring; None: upflow_check_m plus arrive_radius_m), m"
    )
    upflow_crossings: int | None = Field(
        default=None, ge=1, le=5, description="How many passes over the candidate's flow line, "
        "inside the crossing window and more than 15 s apart, the up-flow check asks for: a "
        "plume near its source is intermittent, and one empty pass can miss it (measured: "
        "upflow_check.py's docstring; None: 1 with max_sources 1, 2 with several)"
    )
    upflow_crossing_gap_s: float = Field(
        default=15.0, gt=0, description="Passes over the candidate's flow line less than this "
        "apart count as one (upflow_crossings); 40 moved the two-source false declarations to "
        "other runs and delayed the second declaration ~100 s (measured: "
        "benchmarks/results/likelihood_map_two_passes.md), s"
    )
    upflow_early_fraction: float | None = Field(
        default=0.7, gt=0, lt=1, description="Fly the up-flow check's leg (or visit) as soon as "
        "the map holds this fraction of confidence within radius_m of a candidate, before it is "
        "sure of it: the leg overlaps the time the map takes to become sure. With max_sources "
        "1 only (measured: class docstring; None: only once it is sure, the rule before)"
    )
    upflow_band_m: float = Field(
        default=5.0, gt=0, description="How far to each side of the candidate's flow line the "
        "crossing must reach, and the half-width of the band in which plume vetoes it, m"
    )
    upflow_fan_deg: float = Field(
        default=20.0, ge=0, le=60, description="The band widens up-flow by tan(this) per metre "
        "(the flow estimate's direction error): at a up-flow of the candidate its half-width is "
        "upflow_band_m + a·tan(upflow_fan_deg); 20 with the early leg, with max_sources 1 only "
        "(measured: class docstring; 0: a band of constant width, the rule before), deg"
    )
    upflow_veto_near_m: float | None = Field(
        default=5.0, gt=0, description="Plume seen more than this up-flow of the candidate "
        "(within upflow_band_m of its line) vetoes it; 5 rather than radius_m: a source is "
        "not down-flow of plume seen 5-10 m up-flow of the candidate either (measured: class "
        "docstring; None: radius_m), m"
    )
    upflow_trace_fraction: float | None = Field(
        default=0.25, gt=0, le=1, description="With the up-flow check, a reading above this "
        "fraction of the perception's threshold in the veto band (and above three times the "
        "median reading of the track's cycles without a detection: a noise floor) vetoes like "
        "a detection: up-flow of a source there is no dye at all. A sensor with rare spikes or "
        "a slow filter wants None (upflow_check.py's docstring; None: only detections veto)"
    )
    upflow_seen_near: bool = Field(
        default=True, description="A candidate needs plume seen within radius_m of it (since "
        "this source's search began) before the up-flow check's crossing is looked for; until "
        "then the vehicle visits it; a visit not done in upflow_timeout_s holds it back while "
        "the tree searches on (upflow_check.py's docstring)"
    )
    upflow_memory_s: float | None = Field(
        default=None, gt=0, description="Plume seen up-flow of a candidate vetoes it if seen "
        "within this long (None: since the search for this source began), s"
    )
    upflow_timeout_s: float = Field(
        default=120.0, gt=0, description="A check leg or visit that has not got there after "
        "this long ends: a leg's candidate is declared unchecked, a visit's is held back while "
        "the tree searches on (both counted in declaration_report), s"
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
    flyby_wall_inset_m: float = Field(
        default=10.0, ge=0, description="A pass is kept this far inside the OpArea's walls "
        "(shortened, still across the flow): the turn at its end (REMUS: 7.5 m radius) then "
        "stays inside, m"
    )
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
    search_sweep_spacing_m: float | None = Field(
        default=40.0, gt=0, description="Between declarations, until a detection no declared "
        "source explains: the vehicle sweeps the OpArea in legs across the flow this far apart "
        "along it, at most half the OpArea's extent along the flow (100 found the second source "
        "of two_sources_wide sooner, median 1824 s against 2534 s, but missed sources 20 m "
        "beside a declared one, whose plume is told from the known one only near them; None: "
        "it heads for the map's most probable unexplored cell, which before such a detection "
        "lies along the walls), m"
    )
    search_map_s: float = Field(
        default=300.0, gt=0, description="With the sweep: for this long after a detection no "
        "declared source explains, the plume behaviours lead (maintain, reacquire, find; across "
        "a known plume, the map's most probable unexplored cell); then the sweep resumes from "
        "where the vehicle is (a false alarm or a plume lost for good does not end it), s"
    )
    search_sweep_inset_m: float = Field(
        default=10.0, ge=0, description="The sweep's legs end this far inside the OpArea's "
        "walls (its turns then stay inside), and the search's map-led targets lie at least "
        "this far inside, m"
    )
    search_give_up_s: float | None = Field(
        default=None, gt=0, description="With max_sources > 1: the search for another source "
        "ends after this long without a detection no declared source explains, or once "
        "candidates were held (known_plume_max_prob) or vetoed this long in all, and "
        "the vehicle goes home with the sources found (search_end_t in the summary; None: it "
        "searches on to the time limit), s"
    )



DISC_SHARE = 0.1
"""A declaration disc (``radius_m``) covering more of the OpArea than this is warned of."""
MASK_SHARE = 0.25
"""With several sources to find, a declared source's mask (``mask_radius_m``) covering more of
the OpArea than this is warned of."""


def advise(params: BehaviourParams, area: OpArea) -> list[tuple[str, str]]:
    """Warnings, ``(parameter, why)``: a declaration disc covering much of the OpArea (the
    posterior mass within it starts at its share of the area, a uniform prior, so
    ``confidence`` is reached on little evidence, and the declared point, the disc's posterior
    mean, can be off by up to about ``radius_m``: a 30 x 30 m box with the default 10 m, a disc
    of 35%, declared one of six runs 9.7 m off); with several sources to find, a mask ruling out
    much of the OpArea for the next; a give-up time with one source to find."""
    assert isinstance(params, LikelihoodMapParams)
    out = grid_advice(params, area)
    share = area.disc_share(params.radius_m)
    off = min(params.radius_m, area.diagonal_m)  # no farther than across the OpArea
    if share > DISC_SHARE:
        out.append(("radius_m", f"{params.radius_m:g} m: the declaration disc covers "
                    f"{100 * share:.0f}% of the OpArea, so the map holds the confidence mass "
                    "in it on little evidence, and the declared point (the disc's mean) can be "
                    f"off by up to about {off:.3g} m (a radius of "
                    f"{area.disc_radius(DISC_SHARE):.1f} m covers a tenth)"))
    mask = area.disc_share(params.mask_radius_m)
    if params.max_sources > 1 and mask > MASK_SHARE:
        out.append(("mask_radius_m", f"{params.mask_radius_m:g} m: a declared source rules "
                    f"out a disc covering up to {100 * mask:.0f}% of the OpArea (centred in "
                    "it) as the place of another, so a source within "
                    f"{params.mask_radius_m:g} m of a declared one is never declared (the "
                    "search ends only if the masks leave no cell)"))
    several = params.max_sources > 1
    for name in ("upflow_early_fraction", "upflow_fan_deg"):
        # a value other than the default (a swept configuration, built from the dumped
        # mission, has every field set: the defaults said nothing)
        value = getattr(params, name)
        if several and value and value != LikelihoodMapParams.model_fields[name].default:
            out.append((name, "has no effect with max_sources above 1 (the early leg and the "
                        "fan serve a single source: upflow_check.py's docstring)"))
    if params.search_give_up_s is not None and params.max_sources == 1:
        out.append(("search_give_up_s", "has no effect with max_sources 1 (it bounds the "
                    "search for a further source)"))
    if params.max_sources > 1:
        out += _sweep_advice(params, area)
    return out


TURN_RADIUS_M = 7.5
"""REMUS's turning radius (TRO II): what the sweep's spacing and inset are judged against."""


def _sweep_advice(params: LikelihoodMapParams, area: OpArea) -> list[tuple[str, str]]:
    """The search sweep's settings unlikely to be meant: a spacing shorter than a turn (the
    vehicle circles each lane's end), an inset shorter than a turn's radius (the turns cross the
    walls and safety takes over), an inset leaving no lane either way (no sweep at all; a
    corridor narrower than a turn is swept along its length, :mod:`~cptbt.behaviours.sweep`)."""
    out: list[tuple[str, str]] = []
    spacing = params.search_sweep_spacing_m
    if spacing is None:
        return out
    if spacing < 2 * TURN_RADIUS_M:
        out.append(("search_sweep_spacing_m", f"{spacing:g} m is shorter than a turn across "
                    f"({2 * TURN_RADIUS_M:g} m for REMUS): the vehicle circles each lane's end "
                    "instead of stepping to the next lane"))
    inset = params.search_sweep_inset_m
    if inset < TURN_RADIUS_M:
        out.append(("search_sweep_inset_m", f"{inset:g} m is less than a turn's radius "
                    f"({TURN_RADIUS_M:g} m for REMUS): the turns at the lanes' ends cross the "
                    "walls, where safety takes over"))
    room = max(area.xmax - area.xmin, area.ymax - area.ymin) - 2 * inset
    if room <= 2 * TURN_RADIUS_M:
        out.append(("search_sweep_inset_m", f"{inset:g} m from every wall leaves "
                    f"{max(room, 0.0):g} m across the OpArea's long side: lanes no longer "
                    f"than a turn ({2 * TURN_RADIUS_M:g} m for REMUS) are not flown, so there "
                    "is no sweep and the search heads for the map's most probable cell instead "
                    "(before any plume, one by the walls, which no miss rules out)"))
    return out


def settings_fit(params: BehaviourParams, perception: Any) -> str | None:
    """Why the settings cannot work together (the contract's check), or None."""
    assert isinstance(params, LikelihoodMapParams)
    if params.radius_m < 0.5 * params.cell_m:
        return (f"radius_m {params.radius_m:g} is smaller than half a cell (cell_m "
                f"{params.cell_m:g}): the declaration mass would be one cell's")
    window, reach = params.upflow_window_m, params.upflow_check_m
    if window is not None and reach is not None and window < reach:
        return (f"upflow_window_m {window:g} is shorter than upflow_check_m {reach:g}: the "
                "check leg's own crossing would not count, and every candidate would wait for "
                "the leg's timeout and be declared unchecked")
    spacing = params.search_sweep_spacing_m
    if params.max_sources > 1 and spacing is not None and spacing <= params.arrive_radius_m:
        return (f"search_sweep_spacing_m {spacing:g} is not longer than arrive_radius_m "
                f"{params.arrive_radius_m:g}: the sweep could never step along the flow")
    return None
