"""Closed-loop simulation: one world, N vehicles, one planner each.

The simulator steps every vehicle and puff as arrays; the only per-vehicle Python work is feeding
and ticking each vehicle's planner at its cycle rate, which is where the planner's own cost lies.
Vehicles that share a world share one plume realisation, as AB's 100 searchers did. Each run ends
by the one stop policy (:func:`cptbt.policy.give_back_trigger`) or, under the ``arrival``
criterion, on reaching the true source; rows are kept by a :class:`Recorder`.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Mapping, Sequence
from functools import partial
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from cptbt.angles import hypot_array
from cptbt.batch.outcome import Outcome, contact_ended, outcome_of
from cptbt.batch.recorder import Recorder
from cptbt.batch.runs import (
    PlumeSnapshot,
    VehicleRun,
    collect_declarations,
    keep_partial,
    note_declarations,
    note_unflyable,
)
from cptbt.fleet import FleetPlanner, FleetSupport, fleet_support, planner_choice
from cptbt.mission import MissionBase
from cptbt.planner import Planner
from cptbt.policy import TIME_EPS_S, give_back_trigger
from cptbt.sim.world import EnvironmentParams, StepOutput, World
from cptbt.types import Point

if TYPE_CHECKING:
    from cptbt.logs import CycleLog


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
                # on the estimate the planner took (a fix it threw away as broken had ended
                # the run here and not in serve: an attacker's)
                px, py = pl.perception.pose.x, pl.perception.pose.y
                far = area.distance_outside(px, py) if math.isfinite(px + py) else 0.0
                due = give_back_trigger(pl.done, t, limit, far)
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
        px, py = fleet.perception.poses(active)  # the estimates the planner took, as above
        outside = np.where(np.isfinite(px + py), area.distance_outside_array(
            np.nan_to_num(px), np.nan_to_num(py)), 0.0)
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
