"""Closed-loop simulation: one world, N vehicles, one planner each.

The simulator steps every vehicle and puff as arrays; the only per-vehicle Python work is feeding
and ticking each vehicle's planner at its cycle rate, which is where the planner's own cost lies.
Vehicles that share a world share one plume realisation, as AB's 100 searchers did. Each run ends
by the one stop policy (:func:`cptbt.policy.give_back_trigger`) or, under the ``arrival``
criterion, on reaching the true source; rows are kept by a :class:`Recorder`.
"""

from __future__ import annotations

import contextlib
import math
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from functools import partial
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from cptbt.angles import hypot_array
from cptbt.batch.outcome import Outcome, contact_ended, outcome_of
from cptbt.batch.recorder import PATH_COLUMNS, TRACE_COLUMNS, Recorder
from cptbt.fleet import FleetPlanner, FleetSupport, fleet_support, planner_choice
from cptbt.mission import MissionBase
from cptbt.planner import Planner
from cptbt.policy import TIME_EPS_S, give_back_trigger
from cptbt.sim.world import EnvironmentParams, StepOutput, World
from cptbt.types import Point

if TYPE_CHECKING:
    from cptbt.logs import CycleLog

TRACE = ("t", "x", "y", "heading", "x_est", "y_est", "heading_est", "concentration", "detected",
         "flow_vx", "flow_vy", "active", "cmd_heading", "cmd_speed")
"""Columns of a run's trace, in order."""
assert set(TRACE) == {*PATH_COLUMNS, *TRACE_COLUMNS, "detected", "active"}

FLEET_MIN_VEHICLES = 8
"""The fewest vehicles ``auto`` flies with the fleet planner. Measured on an AB Strategy III
tree: the fleet tick costs ~130 µs + ~1.9 µs per vehicle, a py_trees planner ~15 µs per vehicle,
so one vehicle (``cptbt run``) is cheaper per vehicle and the two break even near 9."""


def run_loop(world: World, prepare: Callable[[], None],
             observe: Callable[[StepOutput], bool]) -> None:
    """The one stepping loop of every simulated run: prepare, step the world, observe.

    ``prepare`` sets the vehicles' commands (the planner's, or the vehicle executive's over the
    link); ``observe`` takes the step's samples — feeding and ticking planners, recording rows,
    applying the stop policy — and says whether to go on. The batch engine (N vehicles, planners
    fed directly) and the phased run (one vehicle over the vehicle link) are two pairs of these.
    """
    while True:
        prepare()
        if not observe(world.step()):
            return


@dataclass(frozen=True)
class PlumeSnapshot:
    """The plume's concentration on a grid at one moment (for figures).

    Attributes:
        xs, ys: grid axes, planning frame, m.
        conc: concentration, (len(ys), len(xs)).
        t_s: mission time of the snapshot.
    """

    xs: NDArray[np.float64]
    ys: NDArray[np.float64]
    conc: NDArray[np.float64]
    t_s: float

    @classmethod
    def of(cls, world: World, grid: tuple[NDArray[np.float64], NDArray[np.float64]]
           ) -> PlumeSnapshot:
        """The world's plume now, on the grid ``(xs, ys)``."""
        xs, ys = grid
        gx, gy = np.meshgrid(xs, ys)
        conc = world.concentration_at(np.column_stack([gx.ravel(), gy.ravel()]))
        return cls(xs, ys, conc.reshape(gx.shape), world.t_s)


@dataclass
class VehicleRun:
    """What one vehicle did: its planner, events, and its rows in a :class:`Recorder`.

    Attributes:
        planner: the vehicle's planner (closed when the run ends); None when the group was flown
            by the fleet planner.
        start: where the recorded part of the run began (planning frame, true position).
        recorder: the rows the measures use (the AMP's cycles).
        index: this vehicle's row in ``recorder``.
        period_s: the planning cycle.
        trace_recorder: every row of a traced run (for phased runs, Mission A's too).
        outcome: how the AMP's part ended.
        t_end: when it ended (mission clock).
        t1: first detection; t3: declaration (the planner's ``declared_source`` first set:
            with several sources, when the last was declared or the search for more ended).
        declared_at: when each point of ``declared_sources`` was first published (see
            :meth:`note_declarations`).
        distance_at_end_m: the vehicle's true distance to the true source when it ended.
        closest_m: its closest true approach to the true source during the recorded part.
        declared: the declared source (planning frame).
        lost_contacts: the perception's lost-contact points at the end.
        sensor_faults: what the perception dropped or corrected (its ``faults()``) at the end.
        plume: the plume when the source was declared (or the run ended), if asked for.
    """

    planner: Planner | None
    start: tuple[float, float]
    recorder: Recorder
    index: int
    period_s: float
    trace_recorder: Recorder | None = None
    outcome: Outcome | None = None
    t_end: float = math.nan
    t1: float | None = None
    t3: float | None = None
    distance_at_end_m: float = math.nan
    closest_m: float = math.inf
    outside_m: float = 0.0
    """How far outside the OpArea the true track went at steps no row records (a phased run's
    give-back step: the AMP's last command took it there, but the planner did not tick)."""
    declared: Point | None = None
    declared_all: tuple[Point, ...] = ()
    declared_at: dict[Point, float] = field(default_factory=dict)
    source_map: Any = None
    declaration_report: dict[str, Any] | None = None
    lost_contacts: tuple[Point, ...] = ()
    sensor_faults: dict[str, int] = field(default_factory=dict)
    nonfinite_commands: dict[str, int] = field(default_factory=dict)
    """Each behaviour that asked ``command()`` for a non-finite heading or speed, how often
    (:meth:`~cptbt.planner.Planner.nonfinite_commands`)."""
    unflyable_speeds: dict[str, tuple[int, float, float]] = field(default_factory=dict)
    """Each behaviour whose command's speed the simulated vehicle cannot fly (outside its
    ``min_speed_mps``, ``max_speed_mps``; it flew the nearest): the cycles, the slowest and the
    fastest such speed commanded."""
    plume: PlumeSnapshot | None = None
    error: Exception | None = None
    """The error this run's planner raised, which ended it (:func:`simulate`'s ``isolate``)."""

    @property
    def path_t(self) -> NDArray[np.float64]:
        """Time of each recorded cycle."""
        return self.recorder.column("t", self.index)

    @property
    def path_true(self) -> NDArray[np.float64]:
        """True positions, (k, 2)."""
        return self.recorder.xy(self.index)

    @property
    def path_est(self) -> NDArray[np.float64]:
        """Navigation estimates, (k, 2)."""
        return self.recorder.xy(self.index, estimated=True)

    @property
    def detections(self) -> NDArray[np.float64]:
        """Estimated positions of the detecting cycles, (m, 2)."""
        return self.path_est[self.recorder.column("detected", self.index)]

    @property
    def time_in(self) -> dict[str, float]:
        """Seconds in each behaviour ('none': no output)."""
        return self.recorder.time_in(self.index)

    @property
    def trace(self) -> dict[str, Any] | None:
        """Every traced row as columns, or None when not traced."""
        rec = self.trace_recorder
        if rec is None:
            return None
        table = rec.table(self.index, extra=("phase",) if len(rec.phases) > 1 else ())
        return {c: table[c] for c in (*TRACE, *(["phase"] if "phase" in table else []))}


def note_declarations(run: VehicleRun, planner: Planner, t: float) -> None:
    """A cycle's declarations: t3 when ``declared_source`` is first set, and the time each
    declared point first appears among ``declared_sources`` (a several-source run's measures
    end at the declaration that completed its set, not when its search ended)."""
    if run.t3 is None and planner.declared_source is not None:
        run.t3 = t
    for q in planner.declared_sources:
        run.declared_at.setdefault(q, t)


def note_unflyable(run: VehicleRun, active: str | None, speed: float) -> None:
    """A cycle whose command's speed the simulated vehicle cannot fly, counted against the
    behaviour that drove (a review's plug-in commanded 0.1 m/s: the vehicle flew 0.25 and a
    study credited the variant with it, saying nothing)."""
    name = active or "no behaviour"
    n, lo, hi = run.unflyable_speeds.get(name, (0, math.inf, -math.inf))
    run.unflyable_speeds[name] = (n + 1, min(lo, speed), max(hi, speed))


def collect_declarations(run: VehicleRun, planner: Planner) -> None:
    """Copy what map-keeping declarations publish into the run (absent for the others).

    Every source declared, the belief at the final declaration (or when the search gave up),
    else the latest one (a run that ended searching: the map it ended on, ``map_at`` "end" in
    the report), and the fly-by report.
    """
    run.declared_all = planner.declared_sources
    final = planner.declared_source is not None
    run.source_map = ((planner.read("source_map_at_declaration") if final else None)
                      or planner.read("source_map"))
    report = planner.read("declaration_report")
    run.declaration_report = dict(report) if isinstance(report, dict) else None
    if run.declaration_report is not None and not final:
        run.declaration_report["map_at"] = "end"


_PARTIAL = "cptbt_partial_runs"


@dataclass(frozen=True)
class Partial:
    """A flight stopped by an error: its runs (their rows up to the last whole cycle), its
    world, and Mission A's waypoints (a phased run's; None otherwise)."""

    runs: list[VehicleRun]
    world: World
    waypoints: list[Point] | None = None


def keep_partial(exc: BaseException, runs: list[VehicleRun], world: World,
                 waypoints: list[Point] | None = None) -> None:
    """Attach the flight ``exc`` stopped to it, for :func:`partial_runs`."""
    if getattr(exc, _PARTIAL, None) is None:
        with contextlib.suppress(AttributeError, TypeError):
            setattr(exc, _PARTIAL, Partial(runs, world, waypoints))


def partial_runs(exc: BaseException) -> Partial | None:
    """The flight that stopped on ``exc`` (:func:`simulate`,
    :func:`~cptbt.batch.phased.simulate_phased`): ``cptbt run`` writes its trace and figure (a
    review's plug-in raised at t = 319 s and the run wrote nothing to look at). None: not a
    flight's error."""
    got = getattr(exc, _PARTIAL, None)
    return got if isinstance(got, Partial) else None


def simulate(
    mission: MissionBase,
    params: EnvironmentParams,
    starts: Sequence[tuple[float, float, float]],
    *,
    env_rng: np.random.Generator | None = None,
    vehicle_rngs: Sequence[np.random.Generator] | None = None,
    trace: bool = False,
    time_limit_s: float | None = None,
    plume_grid: tuple[NDArray[np.float64], NDArray[np.float64]] | None = None,
    goals: Sequence[Point | None] | None = None,
    logs: Mapping[int, CycleLog] | None = None,
    planner: str | None = None,
    on_end: Callable[[int, VehicleRun], None] | None = None,
    isolate: bool = False,
) -> tuple[list[VehicleRun], World, float]:
    """Fly one planner per start pose (x, y, heading; planning frame) in one shared world.

    ``goals`` gives each vehicle's move-to-field goal (default: the mission's start). ``logs``
    maps a vehicle's index to a cycle log: that vehicle flies the log's (recording) planner, made
    with the same goal, and every cycle it ticks is logged (the caller closes the logs).

    ``planner``: ``auto`` (default; also ``$CPTBT_PLANNER``) flies a group of at least
    :data:`FLEET_MIN_VEHICLES` with the fleet planner (:mod:`cptbt.fleet`, the tree evaluated
    for all vehicles at once) when every behaviour of the mission has an array form and no run
    is logged, else with one py_trees planner per vehicle; ``fleet`` or ``tree`` forces one
    (``fleet`` raises ValueError when it cannot). Both give the same runs bit for bit.

    With ``plume_grid`` (xs, ys), each run keeps a :class:`PlumeSnapshot` taken when it declared
    (or, without a declaration, when it ended).

    ``on_end(i, run)`` hears of each vehicle's run as soon as it is complete (its last cycle
    recorded), while the others fly on: a study keeps it then (an interrupted group had lost
    the runs already done in it).

    ``isolate``: an error one vehicle's planner raises ends that run alone (``run.error``, its
    outcome None; ``on_end`` hears of it) while the others fly on: they are the runs they would
    be without it (each vehicle's seeds are its own, and a vehicle that ends, however, only
    stops). A study flies its groups so (a review's plug-in raised in one run, and every run
    of its group, every start of one plume, had become an error row); ``cptbt run`` does not,
    and the error stops the flight, with its runs so far attached (:func:`partial_runs`). The
    fleet planner ticks every vehicle at once: its errors stop the group either way.

    Returns:
        The runs, the world at the end (for plume snapshots) and the wall time spent.
    """
    wall0 = time.perf_counter()
    n = len(starts)
    xy = np.array([[s[0], s[1]] for s in starts], dtype=float).reshape(n, 2)
    heading = np.array([s[2] for s in starts], dtype=float)
    world = World(params, xy, heading, env_rng=env_rng, vehicle_rngs=vehicle_rngs)
    world.warm_up()
    source = Point(*params.source_xy_m)
    arrival = mission.evaluation.criterion == "arrival"
    maintain = mission.evaluation.criterion == "maintain"
    radius = mission.evaluation.success_radius_m
    limit = mission.time_limit_s if time_limit_s is None else time_limit_s
    period = 1.0 / mission.cycle_hz
    rec = Recorder(n, math.ceil(limit / period) + 4, trace=trace)
    goal = list(goals) if goals is not None else [None] * n
    choice = planner_choice(planner)
    logs = logs or {}
    if choice == "fleet" or (choice == "auto" and n >= FLEET_MIN_VEHICLES and not logs):
        support = fleet_support(mission)
        if logs:  # a cycle log records one py_trees planner
            support = FleetSupport(False, "its runs are logged (--log-runs)")
        if support.ok:
            runs = [VehicleRun(None, (s[0], s[1]), rec, i, period, rec if trace else None)
                    for i, s in enumerate(starts)]
            _fly_fleet(world, mission, runs, rec, limit, trace, plume_grid, on_end)
            return runs, world, time.perf_counter() - wall0
        if choice == "fleet":
            raise ValueError(f"the fleet planner cannot run {mission.name}: {support.reason}")
    planners = [logs[i].planner if i in logs else Planner(mission, start=goal[i])
                for i in range(n)]
    runs = [VehicleRun(planners[i], (s[0], s[1]), rec, i, period, rec if trace else None)
            for i, s in enumerate(starts)]
    area = planners[0].op_area if runs else None
    slowest, fastest = params.vehicle.min_speed_mps, params.vehicle.max_speed_mps
    cmd_heading = np.full(n, np.nan)
    cmd_speed = np.full(n, np.nan)
    active = np.arange(n)
    next_tick = 0.0
    commanded = False  # the planners ticked: their commands go to the world before its next step

    def prepare() -> None:
        nonlocal commanded
        if commanded:
            world.set_commands(cmd_heading, cmd_speed)
            commanded = False

    failed: dict[int, Exception] = {}  # isolate: the vehicles whose planner raised, not ended

    def guarded(i: int, call: Callable[[], Any]) -> Any:
        """``call()`` for vehicle ``i``: with ``isolate``, an error it raises ends that run."""
        if not isolate:
            return call()
        try:
            return call()
        except Exception as exc:  # one run's: the others fly on (docstring)
            failed.setdefault(i, exc)
            return None

    def end_failed(t: float) -> None:
        """End the runs whose planner raised (``failed``): ``run.error`` set, heard of."""
        nonlocal active
        for i, exc in sorted(failed.items()):
            run = runs[i]
            run.error, run.t_end = exc, t
            cmd_speed[i] = 0.0
            active = active[active != i]
            if on_end is not None:
                on_end(i, run)
        failed.clear()

    def observe(out: StepOutput) -> bool:
        nonlocal active, next_tick, commanded
        t = out.t_s
        if out.fluorometer is not None:
            for i in active:
                guarded(int(i), partial(planners[i].add_sample, t, float(out.fluorometer[i])))
        if out.adcp_flow is not None:
            for i in active:
                if int(i) not in failed:  # a planner that raised is not called again
                    guarded(int(i), partial(planners[i].add_flow, t,
                                            float(out.adcp_flow[i, 0]),
                                            float(out.adcp_flow[i, 1])))
        if failed:
            end_failed(t)
            if not len(active):
                return False
        if t + TIME_EPS_S < next_tick and t + TIME_EPS_S < limit:
            return True  # no cycle due; at the time limit one is, on the cycle grid or not
        next_tick += period
        m = len(active)
        detected = np.zeros(m, dtype=bool)
        codes = np.zeros(m, dtype=np.int16)
        extra = {c: np.full(m, np.nan) for c in ("concentration", "flow_vx", "flow_vy")} \
            if trace else {}
        keep = np.ones(m, dtype=bool)
        for j, i in enumerate(active):
            run = runs[i]
            pl = planners[i]
            ex, ey = float(out.nav_xy[i, 0]), float(out.nav_xy[i, 1])
            pl.set_pose(ex, ey, float(out.nav_heading_deg[i]))
            cmd = guarded(int(i), partial(pl.tick, t))
            if int(i) in failed:  # ended by its error (isolate): no row for this cycle
                continue
            if logs and int(i) in logs:
                logs[int(i)].record(t, "amp.override")
            p = pl.percept
            assert p is not None
            if cmd is not None:
                cmd_heading[i], cmd_speed[i] = cmd.heading_deg, cmd.speed_mps
                if not slowest <= cmd.speed_mps <= fastest:  # a plug-in's: flown clipped
                    note_unflyable(run, pl.active, cmd.speed_mps)
            detected[j] = p.detected
            codes[j] = rec.code(pl.active)
            if trace:
                extra["concentration"][j] = p.concentration
                if p.flow is not None:
                    extra["flow_vx"][j], extra["flow_vy"][j] = p.flow.vx, p.flow.vy
            if p.detected and run.t1 is None:
                run.t1 = t
            if run.t3 is None and pl.declared_source is not None and plume_grid is not None:
                run.plume = PlumeSnapshot.of(world, plume_grid)
            note_declarations(run, pl, t)
            d_true = math.hypot(float(out.true_xy[i, 0]) - source.x,
                                float(out.true_xy[i, 1]) - source.y)
            run.closest_m = min(run.closest_m, d_true)
            outcome = None
            if arrival and d_true <= radius:
                outcome = Outcome.FOUND  # AB appendix: success on reaching the source
            elif maintain and contact_ended(run.t1, pl.active):
                outcome = Outcome.CONTACT_LOST  # AB Fig. 9: the end of T_M
            else:
                assert area is not None
                due = give_back_trigger(pl.done, t, limit, area.distance_outside(ex, ey))
                if due is not None:
                    outcome = outcome_of(due[0], pl.declared_source is not None)
            if outcome is not None:
                run.outcome, run.t_end, run.distance_at_end_m = outcome, t, d_true
                run.declared = pl.declared_source
                collect_declarations(run, pl)
                run.lost_contacts = p.lost_contacts
                run.sensor_faults = pl.perception.faults()
                run.nonfinite_commands = pl.nonfinite_commands()
                if plume_grid is not None and run.plume is None:
                    run.plume = PlumeSnapshot.of(world, plume_grid)
                keep[j] = False
        values: dict[str, Any] = {
            "t": t, "x": out.true_xy[active, 0], "y": out.true_xy[active, 1],
            "x_est": out.nav_xy[active, 0], "y_est": out.nav_xy[active, 1],
        }
        if trace:
            values |= extra | {
                "heading": out.true_heading_deg[active], "heading_est": out.nav_heading_deg[active],
                "cmd_heading": cmd_heading[active], "cmd_speed": cmd_speed[active],
            }
        if failed:  # the runs ended by an error this cycle have no row for it
            ticked = ~np.isin(active, list(failed))
            rec.add(active[ticked], {k: v[ticked] if isinstance(v, np.ndarray) else v
                                     for k, v in values.items()}, detected[ticked],
                    codes[ticked])
        else:
            rec.add(active, values, detected, codes)
        cmd_speed[active[~keep]] = 0.0
        if on_end is not None:
            for i in active[~keep]:
                on_end(int(i), runs[i])
        active = active[keep]
        if failed:
            end_failed(t)
        commanded = True
        return len(active) > 0

    if n:
        try:
            run_loop(world, prepare, observe)
        except Exception as exc:
            keep_partial(exc, runs, world)
            raise
    for pl in planners:
        pl.close()
    return runs, world, time.perf_counter() - wall0


def _fly_fleet(world: World, mission: MissionBase, runs: list[VehicleRun], rec: Recorder,
               limit: float, trace: bool,
               plume_grid: tuple[NDArray[np.float64], NDArray[np.float64]] | None,
               on_end: Callable[[int, VehicleRun], None] | None = None) -> None:
    """:func:`simulate`'s loop with one :class:`~cptbt.fleet.FleetPlanner` for the group.

    The same steps as the per-vehicle loop, on arrays: feed, tick at the cycle rate, record,
    and end each run by the one stop policy or by arrival.
    """
    n = len(runs)
    fleet = FleetPlanner.for_mission(mission, n)
    area = fleet.op_area
    sx, sy = (float(v) for v in world.params.source_xy_m)
    arrival = mission.evaluation.criterion == "arrival"
    maintain = mission.evaluation.criterion == "maintain"
    radius = mission.evaluation.success_radius_m
    period = 1.0 / mission.cycle_hz
    closest = np.full(n, np.inf)
    # contact_ended (the one rule of criterion maintain) for each leaf, and for none
    let_go = np.array([contact_ended(0.0, name) for name in fleet.names]
                      + [contact_ended(0.0, None)])
    codes_of = np.array([rec.code(name) for name in fleet.names] + [rec.code(None)],
                        dtype=np.int16)
    cmd_heading = np.full(n, np.nan)
    cmd_speed = np.full(n, np.nan)
    seen = np.zeros(n, dtype=bool)  # a first detection was recorded (t1)
    active = np.arange(n)
    next_tick = 0.0
    commanded = False

    def prepare() -> None:
        nonlocal commanded
        if commanded:
            world.set_commands(cmd_heading, cmd_speed)
            commanded = False

    def observe(out: StepOutput) -> bool:
        nonlocal active, next_tick, commanded
        t = out.t_s
        if out.fluorometer is not None:
            fleet.add_samples(active, out.fluorometer[active], t)
        if out.adcp_flow is not None:
            fleet.add_flows(t, active, out.adcp_flow[active, 0], out.adcp_flow[active, 1])
        if t + TIME_EPS_S < next_tick and t + TIME_EPS_S < limit:
            return True  # no cycle due; at the time limit one is, on the cycle grid or not
        next_tick += period
        ex, ey = out.nav_xy[active, 0], out.nav_xy[active, 1]
        fleet.set_poses(active, ex, ey, out.nav_heading_deg[active])
        tick = fleet.tick(t, active)
        p = tick.percept
        has = tick.has_command
        cmd_heading[active[has]] = tick.heading[has]
        cmd_speed[active[has]] = tick.speed[has]
        first = p.detected & ~seen[active]
        for i in active[first]:
            runs[i].t1 = t
        seen[active[first]] = True
        tx, ty = out.true_xy[active, 0], out.true_xy[active, 1]
        d_true = hypot_array(tx - sx, ty - sy)
        closest[active] = np.minimum(closest[active], d_true)
        found = d_true <= radius if arrival else np.zeros(len(active), dtype=bool)
        lost = (seen[active] & let_go[tick.active] & ~found if maintain
                else np.zeros(len(active), dtype=bool))
        # The stop policy: the time trigger is the same for every vehicle; the outside trigger
        # is asked only for vehicles outside the OpArea (give_back_trigger is the one rule).
        due_all = give_back_trigger(False, t, limit, 0.0)
        outside = area.distance_outside_array(ex, ey)
        ended = found | lost
        why: dict[int, tuple[str, str]] = {}
        for j in np.flatnonzero(~ended & ((outside > 0.0) | (due_all is not None))):
            due = give_back_trigger(False, t, limit, float(outside[j]))
            if due is not None:
                ended[j] = True
                why[int(j)] = due
        for j in np.flatnonzero(ended):
            run = runs[active[j]]
            run.outcome = (Outcome.FOUND if found[j] else Outcome.CONTACT_LOST if lost[j]
                           else outcome_of(why[int(j)][0], False))
            run.t_end, run.distance_at_end_m = t, float(d_true[j])
            run.lost_contacts = fleet.perception.lost_contacts(int(active[j]))
            run.sensor_faults = fleet.perception.faults(int(active[j]))
            if plume_grid is not None and run.plume is None:
                run.plume = PlumeSnapshot.of(world, plume_grid)
        values: dict[str, Any] = {"t": t, "x": tx, "y": ty, "x_est": ex, "y_est": ey}
        if trace:
            values |= {
                "concentration": p.concentration,
                "flow_vx": np.where(p.has_flow, p.vx, np.nan),
                "flow_vy": np.where(p.has_flow, p.vy, np.nan),
                "heading": out.true_heading_deg[active], "heading_est": out.nav_heading_deg[active],
                "cmd_heading": cmd_heading[active], "cmd_speed": cmd_speed[active],
            }
        rec.add(active, values, p.detected, codes_of[tick.active])
        cmd_speed[active[ended]] = 0.0
        for i in active[ended]:
            runs[i].closest_m = float(closest[i])  # final: its run is over
            if on_end is not None:
                on_end(int(i), runs[i])
        active = active[~ended]
        commanded = True
        return len(active) > 0

    run_loop(world, prepare, observe)
    for i, run in enumerate(runs):
        run.closest_m = float(closest[i])
