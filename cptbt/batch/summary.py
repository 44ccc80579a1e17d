"""The measures of one run (SPEC §11; TRO V, Tables III–IV; AB 3), as one typed summary."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from cptbt.batch.engine import VehicleRun
from cptbt.batch.outcome import Verdict, judge
from cptbt.batch.outside import farthest_outside, home_legs, safety_entering
from cptbt.mission import MissionBase
from cptbt.types import Point

NEAR_SOURCE_M = 13.0
"""TRO V: t2 is the first time within 13 m of the declared source."""


def _path_length(points: NDArray[np.float64]) -> float:
    if len(points) < 2:
        return 0.0
    return float(np.hypot(*np.diff(points, axis=0).T).sum())


def where(mission: MissionBase, p: Point | None) -> dict[str, float] | None:
    """A planning point in planning, N-E and (when the mission has a geodetic anchor) lat/lon.

    A planning-frame mission has no compass: its points have ``x`` and ``y`` only (they were
    copied into ``north`` and ``east``, which said a bearing nobody gave).
    """
    return None if p is None else place(mission, p)


def place(mission: MissionBase, p: Point) -> dict[str, float]:
    """:func:`where` of a point that is there."""
    out = {"x": p.x, "y": p.y}
    if mission.frame != "planning":
        n, e = mission.to_ne(p)
        out |= {"north": n, "east": e}
    geo = mission.to_geodetic(p)
    if geo is not None:
        out |= {"lat": geo.lat_deg, "lon": geo.lon_deg}
    return out


@dataclass
class RunSummary:
    """One run's summary: outcome and verdict, times t0–t3, T_F T_T T_D, paths D0–D3, errors.

    ``success`` and ``false_declaration`` judge the run by the mission's ``evaluation`` section
    (:func:`cptbt.batch.outcome.judge`); every time is the mission clock, s; every distance m.
    Places (``start``, the sources) are given as :func:`where` gives them; ``start`` is where
    the recorded run began: the launch point of the AMP alone, the AMP's take-over point of a
    phased run. ``mission_start`` is the mission's own ``start:`` (move-to-field's goal, TRO
    Table III's start column; None when the mission has none): a review set ``start`` against
    Table III and compared two different points.
    """

    mission: str
    seed: int | None
    outcome: str
    success: bool
    false_declaration: bool
    criterion: str
    success_radius_m: float
    start: dict[str, float]
    mission_start: dict[str, float] | None
    home: dict[str, float]
    declared_source: dict[str, float] | None
    true_source: dict[str, float] | None
    error_m: float | None
    t0: float
    t1: float | None
    t2: float | None
    t3: float | None
    T_F: float | None
    T_T: float | None
    T_D: float | None
    T_total: float | None
    D0: float | None
    D1: float | None
    D2: float | None
    D3: float | None
    D1_over_D0: float | None
    detections: int
    lost_contacts: int
    sim_time_s: float
    wall_time_s: float
    time_in_behaviour_s: dict[str, float] = field(default_factory=dict)
    time_share: dict[str, float] = field(default_factory=dict)
    sources_true: int = 1
    sources_declared: int = 0
    sources_found: int = 0
    false_declarations: int = 0
    declared_sources: list[dict[str, float] | None] = field(default_factory=list)
    true_sources: list[dict[str, float] | None] = field(default_factory=list)
    flybys: int | None = None
    withdrawn: int | None = None
    superseded: int | None = None
    superseded_points: list[dict[str, float] | None] = field(default_factory=list)
    upflow_checks: int | None = None
    upflow_vetoes: int | None = None
    trace_vetoes: int | None = None
    visits: int | None = None
    visits_ended: int | None = None
    search_given_up: bool | None = None
    search_end: str | None = None
    search_end_t: float | None = None
    held_in_known_plume: int | None = None
    held_candidate: dict[str, float] | None = None
    verifying_candidate: dict[str, float] | None = None
    unchecked: int | None = None
    closest_approach_m: float | None = None
    farthest_outside_m: float = 0.0
    safety_entering_s: float = 0.0
    T_M: float | None = None
    path_m: float | None = None
    start_to_source_m: float | None = None
    path_efficiency: float | None = None
    missing_samples: int = 0
    stuck_samples: int = 0
    late_samples: int = 0
    rejected_fixes: int = 0
    rejected_flow_samples: int = 0
    clock_corrections: int = 0
    flow_held_cycles: int = 0
    blind_cycles: int = 0
    nonfinite_commands: int = 0
    unflyable_commands: int = 0
    command_faults: str | None = None

    def to_dict(self) -> dict[str, Any]:
        """Plain data for ``summary.json`` and the results table."""
        return asdict(self)


def summarise(
    run: VehicleRun,
    mission: MissionBase,
    source: Point,
    seed: int | None,
    wall_time_s: float,
    t0: float = 0.0,
    *,
    sources: Sequence[Point] | None = None,
    success_radius_m: float | None = None,
) -> RunSummary:
    """One run's :class:`RunSummary`.

    Readings chosen where SPEC is silent: times and D0 use the navigation estimate, as the AMP
    saw it (the declared source is in that frame); path lengths D1–D3 use the true track, so LBL
    jumps do not count as distance travelled; ``error_m`` is the declared source against the true
    source (under the arrival criterion with no declaration, the vehicle's distance to the source
    when it stopped). ``t0`` is the start of Mission B (the AMP take-over; 0 when the AMP drives
    from launch).

    Every declared point (a multi-source declaration makes several) is matched one-to-one to the
    nearest unmatched true source in ``sources`` (default: ``source`` alone): ``sources_found``
    counts true sources with a declared point within ``success_radius_m`` (default: the
    mission's), ``false_declarations`` the declared points matched to none; ``flybys`` and
    ``withdrawn`` count a likelihood-map declaration's fly-bys and withdrawn declarations,
    ``superseded`` its declarations that replaced an earlier one taken for the same source,
    ``superseded_points`` the points replaced;
    ``upflow_checks``, ``upflow_vetoes`` and ``unchecked`` its up-flow check legs flown, the
    candidates vetoed by plume seen up-flow of them (``trace_vetoes`` of them by sub-threshold
    traces alone), ``visits`` the candidates it flew to for want of plume seen near them
    (``visits_ended`` of those visits timed out, the candidate held back), and the declarations
    made unchecked (a check leg that timed out, or no flow direction to check along);
    ``search_given_up`` that the search for another source ended (``search_give_up_s``, or no
    cell left outside the declared sources' masks) before ``max_sources`` were declared, and
    ``search_end`` which of the two; ``held_in_known_plume`` the cycles a confident candidate
    was held where a declared source's plume blinds the up-flow check, ``held_candidate``
    the latest such candidate not resolved by a later declaration (a probable source the rule
    could not confirm; not a declaration, and not judged); ``verifying_candidate`` the
    candidate a fly-by was verifying when the run ended (a review: a run out of time mid-fly-by
    said nothing of where it was verifying; not a declaration, and not judged).
    ``missing_samples``, ``stuck_samples``, ``late_samples``, ``rejected_fixes``,
    ``rejected_flow_samples`` and ``clock_corrections`` count what the perception dropped or
    corrected (fluorometer samples that were not finite, a dropout; a fluorometer reading stuck
    away from zero; samples stamped more than 5 s, or a planning period, before the previous
    cycle; navigation
    fixes more than 1000 km outside the OpArea; impossible
    flow samples, cycle times not after the previous one) up to the end of the AMP's part;
    ``flow_held_cycles`` the cycles planned on a held flow estimate (no usable flow sample in
    ``perception.flow_window_s``: the last estimate stands in for the current);
    ``blind_cycles`` the cycles with no fluorometer reading (a dropout, stuck samples dropped,
    or a sensor that stopped sending; before the first reading, once it is 10 s late: a field
    review's dead fluorometer had read as a plume not found).
    ``nonfinite_commands`` counts the cycles a behaviour asked ``command()`` for a non-finite
    heading or speed (none was sent: the behaviour below drove), ``unflyable_commands`` those
    whose speed the simulated vehicle cannot fly (it flew the nearest it can), and
    ``command_faults`` names the behaviours (a plug-in's bugs, which had passed as the work
    of the behaviours that covered for them).
    With several sources or declared points, the single-source fields keep their single
    meaning: ``true_source`` is the mission's ``source``, ``declared_source`` the declaration
    that ended the search, the last point (which may be another source's; None when the run
    ended still searching for more, ``declared_sources`` then listing those found), and
    ``error_m`` the worst declared point's distance to its nearest true source;
    ``true_sources`` lists every true source (the mission's ``source`` first), and each entry
    of ``declared_sources`` carries its own ``error_m`` to its nearest true source and that
    source's index in ``true_sources`` (``nearest_source``): the top-level three are not one
    pair when the worst point is not the last (read the pairs there). ``t3``,
    and with it T_D, D0-D3, ``path_m`` and ``path_efficiency``, is the declaration that
    completed the declared set (the latest first published of the points in
    ``declared_sources``), even when the run then searched on for more to its time limit or
    until the search gave up: a review saw the time limit, or the give-up time, measured as
    the time to source of runs that had found every source (``max_sources`` above the sources
    there are); ``search_end_t`` is when the search for more ended (``search_given_up``: when
    ``declared_source`` was written). ``closest_approach_m`` and ``start_to_source_m`` are
    about the mission's ``source``.
    ``farthest_outside_m`` is how far outside the OpArea the vehicle's true track went while
    the AMP drove (0 when it stayed inside; a review missed it, the README quoting it).
    ``closest_approach_m`` is the vehicle's closest true approach to the true source while the
    AMP drove; ``T_M`` (``evaluation.criterion: maintain`` only, AB Fig. 9) is AB eq. 3's
    maintain time ``T_Last - T_First`` of each contact, summed over the contacts until contact
    was lost for good (or the time limit): the time in the plume, the time reacquiring between
    contacts left out (:func:`_maintain_time`).

    Path efficiency (issue 14; OTTO's and olfactory-navigation's measure, for any criterion):
    ``path_m`` is the true path flown from ``t0`` to success (the declaration, or the arrival)
    or to the end of an unsuccessful run, ``start_to_source_m`` the straight line from the true
    position at ``t0`` to the true source, and ``path_efficiency`` their ratio for a successful
    run (None otherwise, and under ``maintain``). TRO's D0/D3 measures the same from the first
    detection to the declared point, and exists only for declarations.
    """
    t1, t3 = run.t1, run.t3
    declared = run.declared
    report = run.declaration_report or {}
    truth = list(sources) if sources else [source]
    declared_all = list(run.declared_all) or ([declared] if declared is not None else [])
    several = mission.evaluation.criterion == "declaration" and (
        len(truth) > 1 or len(declared_all) > 1 or bool(declared_all and declared is None))
    # the measures' declaration: with several, the one that completed the declared set
    last, search_end_t = declared, t3 if report.get("search_given_up") else None
    times = [run.declared_at.get(q) for q in declared_all]
    if declared_all and all(x is not None for x in times):
        k = max(range(len(times)), key=lambda j: times[j] or 0.0)
        t3, last = times[k], declared_all[k]
    path_t, est, true = run.path_t, run.path_est, run.path_true
    t2 = None
    i1 = i2 = i3 = None
    if t1 is not None:
        i1 = int(np.searchsorted(path_t, t1))
    if last is not None and i1 is not None and t3 is not None:
        i3 = int(np.searchsorted(path_t, t3))
        near = np.hypot(est[i1 : i3 + 1, 0] - last.x, est[i1 : i3 + 1, 1] - last.y)
        hits = np.flatnonzero(near <= NEAR_SOURCE_M)
        # Declared before ever passing within 13 m of the spot: t2 = t3.
        i2 = i1 + int(hits[0]) if len(hits) else i3
        t2 = float(path_t[i2])

    def span(a: float | None, b: float | None) -> float | None:
        return None if a is None or b is None else b - a

    d0 = d1 = d2 = None
    if last is not None and i1 is not None:
        d0 = math.hypot(last.x - est[i1, 0], last.y - est[i1, 1])
    if i1 is not None and i2 is not None and i3 is not None:
        d1 = _path_length(true[i1 : i2 + 1])
        d2 = _path_length(true[i2 : i3 + 1])
    assert run.outcome is not None, "summarise a finished run"
    verdict = judge(run.outcome, declared, source, run.distance_at_end_m, mission.evaluation,
                    run.closest_m)
    radius = success_radius_m or mission.evaluation.success_radius_m
    found = _match(declared_all, truth, radius)
    if several:
        verdict = _judge_set(declared_all, truth, found)
    i0 = int(np.searchsorted(path_t, t0)) if len(path_t) else 0
    i_end = int(np.searchsorted(path_t, t3)) + 1 if t3 is not None else len(path_t)
    path_m = _path_length(true[i0:i_end]) if len(true) else None
    straight = (math.hypot(source.x - true[i0, 0], source.y - true[i0, 1])
                if i0 < len(true) else None)
    time_in = run.time_in
    active = run.recorder.active_names(run.index)
    total_time = sum(time_in.values()) or 1.0
    return RunSummary(
        mission=mission.name,
        seed=seed,
        outcome=str(run.outcome),
        success=verdict.success,
        false_declaration=verdict.false_declaration,
        criterion=mission.evaluation.criterion,
        success_radius_m=mission.evaluation.success_radius_m,
        start=place(mission, Point(*run.start)),
        mission_start=(None if mission.start is None
                       else place(mission, mission.to_xy(mission.start))),
        home=place(mission, mission.to_xy(mission.home)),
        declared_source=where(mission, declared),
        true_source=where(mission, source),
        error_m=verdict.error_m,
        t0=t0, t1=t1, t2=t2, t3=t3,
        T_F=span(t0, t1), T_T=span(t1, t2), T_D=span(t2, t3),
        T_total=span(t0, t3) if t3 is not None else span(t0, run.t_end),
        D0=d0, D1=d1, D2=d2,
        D3=None if d1 is None or d2 is None else d1 + d2,
        D1_over_D0=None if not d0 or d1 is None else d1 / d0,
        detections=len(run.detections),
        lost_contacts=len(run.lost_contacts),
        sim_time_s=run.t_end,
        wall_time_s=wall_time_s,
        time_in_behaviour_s=dict(sorted(time_in.items())),
        time_share={k: v / total_time for k, v in sorted(time_in.items())},
        sources_true=len(truth),
        sources_declared=len(declared_all),
        sources_found=found,
        false_declarations=len(declared_all) - found,
        declared_sources=[_with_error(where(mission, p), p, truth) for p in declared_all],
        true_sources=[where(mission, q) for q in truth],
        flybys=report.get("flybys"),
        withdrawn=report.get("withdrawn"),
        superseded=report.get("superseded"),
        superseded_points=[where(mission, Point(*q)) for q in report.get("superseded_at") or []],
        upflow_checks=report.get("upflow_checks"),
        upflow_vetoes=report.get("upflow_vetoes"),
        trace_vetoes=report.get("trace_vetoes"),
        visits=report.get("visits"),
        visits_ended=report.get("visits_ended"),
        search_given_up=report.get("search_given_up"),
        search_end=report.get("search_end"),
        search_end_t=search_end_t,
        held_in_known_plume=report.get("held_in_known_plume"),
        held_candidate=(where(mission, Point(*report["held_at"])) if report.get("held_at")
                        else None),
        verifying_candidate=(where(mission, Point(*report["verifying_at"]))
                             if report.get("verifying_at") else None),
        unchecked=report.get("unchecked"),
        closest_approach_m=run.closest_m if math.isfinite(run.closest_m) else None,
        farthest_outside_m=max(farthest_outside(mission, true, home_legs(mission, active)),
                               run.outside_m),
        safety_entering_s=safety_entering(mission, run, true),
        T_M=(_maintain_time(run, mission.perception.lambda_s, 1.0 / mission.cycle_hz)
             if mission.evaluation.criterion == "maintain" else None),
        path_m=path_m,
        start_to_source_m=straight,
        path_efficiency=(straight / path_m if verdict.success and path_m and straight is not None
                         and mission.evaluation.criterion != "maintain" else None),
        **run.sensor_faults,
        nonfinite_commands=sum(run.nonfinite_commands.values()),
        unflyable_commands=sum(n for n, _, _ in run.unflyable_speeds.values()),
        command_faults=_command_faults(run),
    )


def _command_faults(run: VehicleRun) -> str | None:
    """The behaviours whose commands were not flown as asked, in one line (None: none)."""
    parts = [f"{name} asked command() for a non-finite heading or speed in {n} "
             f"cycle{'s' * (n != 1)} (none sent: the behaviour below drove)"
             for name, n in sorted(run.nonfinite_commands.items())]
    parts += [f"{name} commanded {lo:g}" + (f" to {hi:g}" if hi != lo else "")
              + f" m/s in {n} cycle{'s' * (n != 1)}, outside the simulated vehicle's speeds "
              "(environment.vehicle min_speed_mps, max_speed_mps): flown at the nearest"
              for name, (n, lo, hi) in sorted(run.unflyable_speeds.items())]
    return "; ".join(parts) or None


def _with_error(out: dict[str, float] | None, p: Point,
                truth: Sequence[Point]) -> dict[str, float] | None:
    """A declared point's entry with ``error_m``, its distance to the nearest true source, and
    ``nearest_source``, that source's index in ``true_sources`` (0: the mission's ``source``),
    so that each point reads with the source it is judged against."""
    if out is None:
        return None
    d = [math.hypot(p.x - q.x, p.y - q.y) for q in truth]
    k = min(range(len(d)), key=d.__getitem__)
    return out | {"error_m": d[k], "nearest_source": k}


def _maintain_time(run: VehicleRun, lambda_s: float, period_s: float) -> float | None:
    """AB's maintain time, "the total time in the plume": eq. 3's ``T_Lost - T_First - λ``
    (the last detection of a contact less its first) summed over the contacts; None without a
    detection. A contact ends as the perception ends it: at a planning cycle more than
    ``lambda_s`` after the last detection, so detections more than λ plus a cycle
    (``period_s``) apart (a diff review: split at λ, a gap the planner never left the plume in
    was dropped).

    Reading chosen (a review, AB §3 and §4.2): AB keeps the time spent reacquiring, ``T_R``,
    apart from ``T_M`` ("the total amount of time in contact with the plume, i.e. the time
    duration that (9) and (10) are used"), so "T_M kept accumulating" after a reacquisition
    within λ adds the new contact's time; the waits and casts between contacts are not
    counted (they had been: 8.9 s of a run's 37.8 s, in favour of the strategy that
    reacquires more often)."""
    if run.t1 is None:
        return None
    hits = run.path_t[run.recorder.column("detected", run.index)]
    if not len(hits):
        return 0.0
    breaks = np.flatnonzero(np.diff(hits) > lambda_s + period_s + 1e-9)
    firsts = np.concatenate([hits[:1], hits[breaks + 1]])
    lasts = np.concatenate([hits[breaks], hits[-1:]])
    return float(np.sum(lasts - firsts))


def _judge_set(declared: Sequence[Point], truth: Sequence[Point], found: int) -> Verdict:
    """The declaration criterion for several sources, or several declarations: success when
    every true source has a declared point within the radius and no declared point is false;
    the error is the worst declared point's distance to its nearest true source.

    Reading chosen: a run that declared every true source but was still searching for more
    (``max_sources`` above the sources there are) at its time limit is a success with outcome
    ``timeout``; judging only the declaration that ends the search (the planner's
    ``declared_source``, set once ``max_sources`` are declared) called it a failure while it
    reported "1 of 1 found, 0 false".
    """
    errors = [min(d.distance_to(s) for s in truth) for d in declared]
    return Verdict(success=found == len(truth) and found == len(declared),
                   false_declaration=found < len(declared),
                   error_m=max(errors) if errors else None)


def _match(declared: Sequence[Point], truth: Sequence[Point], radius_m: float) -> int:
    """True sources matched one-to-one, nearest pairs first, to a declared point within reach."""
    pairs = sorted((d.distance_to(s), i, j) for i, d in enumerate(declared)
                   for j, s in enumerate(truth))
    used_d: set[int] = set()
    used_s: set[int] = set()
    for dist, i, j in pairs:
        if dist > radius_m:
            break
        if i not in used_d and j not in used_s:
            used_d.add(i)
            used_s.add(j)
    return len(used_s)
