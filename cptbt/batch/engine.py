"""Closed-loop simulation: one world, N vehicles, one planner each.

The simulator steps every vehicle and puff as arrays; the only per-vehicle Python work is feeding
and ticking each vehicle's planner at its cycle rate, which is where the planner's own cost lies.
Vehicles that share a world share one plume realisation, as AB's 100 searchers did.
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from cptbt.mission import MissionBase
from cptbt.planner import Planner
from cptbt.sim.world import EnvironmentParams, World
from cptbt.types import Point

RELINQUISH_OUTSIDE_M = 30.0
"""TRO II: the AMP gives control back when the vehicle is this far outside the OpArea."""

TRACE_COLUMNS = (
    "t", "x", "y", "heading", "x_est", "y_est", "heading_est", "concentration", "detected",
    "flow_vx", "flow_vy", "active", "cmd_heading", "cmd_speed",
)


@dataclass
class VehicleRun:
    """What one vehicle did: its planner, events and (optionally) its per-tick trace."""

    planner: Planner
    start: tuple[float, float]
    outcome: str | None = None
    t_end: float = math.nan
    t1: float | None = None
    t3: float | None = None
    error_at_end_m: float = math.nan
    declared: Point | None = None
    lost_contacts: tuple[Point, ...] = ()
    time_in: dict[str, float] = field(default_factory=dict)
    trace: dict[str, list[Any]] | None = None
    path_t: list[float] = field(default_factory=list)
    path_true: list[tuple[float, float]] = field(default_factory=list)
    path_est: list[tuple[float, float]] = field(default_factory=list)
    detections: list[tuple[float, float]] = field(default_factory=list)


def simulate(
    mission: MissionBase,
    params: EnvironmentParams,
    starts: Sequence[tuple[float, float, float]],
    *,
    env_rng: np.random.Generator | None = None,
    vehicle_rngs: Sequence[np.random.Generator] | None = None,
    trace: bool = False,
    time_limit_s: float | None = None,
) -> tuple[list[VehicleRun], World, float]:
    """Fly one planner per start pose (x, y, heading; planning frame) in one shared world.

    Returns:
        The runs, the world at the end (for plume snapshots) and the wall time spent.
    """
    wall0 = time.perf_counter()
    xy = np.array([[s[0], s[1]] for s in starts], dtype=float)
    heading = np.array([s[2] for s in starts], dtype=float)
    world = World(params, xy, heading, env_rng=env_rng, vehicle_rngs=vehicle_rngs)
    world.warm_up()
    source = Point(*params.source_xy_m)
    arrival = mission.evaluation.criterion == "arrival"
    radius = mission.evaluation.success_radius_m
    runs = [
        VehicleRun(Planner(mission), (s[0], s[1]),
                   trace={c: [] for c in TRACE_COLUMNS} if trace else None)
        for s in starts
    ]
    limit = mission.time_limit_s if time_limit_s is None else time_limit_s
    period = 1.0 / mission.cycle_hz
    area = runs[0].planner.op_area
    n = len(runs)
    cmd_heading = np.full(n, np.nan)
    cmd_speed = np.full(n, np.nan)
    active = list(range(n))
    next_tick = 0.0
    while active:
        out = world.step()
        t = out.t_s
        if out.fluorometer is not None:
            for i in active:
                runs[i].planner.add_sample(t, float(out.fluorometer[i]))
        if out.adcp_flow is not None:
            for i in active:
                runs[i].planner.add_flow(t, float(out.adcp_flow[i, 0]), float(out.adcp_flow[i, 1]))
        if t + 1e-9 < next_tick:
            continue
        next_tick += period
        still = []
        for i in active:
            run = runs[i]
            pl = run.planner
            ex, ey = float(out.nav_xy[i, 0]), float(out.nav_xy[i, 1])
            pl.set_pose(ex, ey, float(out.nav_heading_deg[i]))
            cmd = pl.tick(t)
            p = pl.percept
            assert p is not None
            if cmd is not None:
                cmd_heading[i], cmd_speed[i] = cmd.heading_deg, cmd.speed_mps
            name = pl.active or "none"
            run.time_in[name] = run.time_in.get(name, 0.0) + period
            tx, ty = float(out.true_xy[i, 0]), float(out.true_xy[i, 1])
            run.path_t.append(t)
            run.path_true.append((tx, ty))
            run.path_est.append((ex, ey))
            if p.detected:
                run.detections.append((ex, ey))
                if run.t1 is None:
                    run.t1 = t
            if run.trace is not None:
                flow = p.flow
                row = (t, tx, ty, float(out.true_heading_deg[i]), ex, ey, p.pose.heading_deg,
                       p.concentration, p.detected, flow.vx if flow else math.nan,
                       flow.vy if flow else math.nan, pl.active or "",
                       cmd.heading_deg if cmd else math.nan, cmd.speed_mps if cmd else math.nan)
                for col, value in zip(TRACE_COLUMNS, row, strict=True):
                    run.trace[col].append(value)
            if run.t3 is None and pl.declared_source is not None:
                run.t3 = t
            outcome = None
            if arrival and math.hypot(tx - source.x, ty - source.y) <= radius:
                outcome = "found"  # AB appendix: success on reaching the source
            elif pl.done:
                outcome = "declared"
            elif area.distance_outside(ex, ey) > RELINQUISH_OUTSIDE_M:
                outcome = "relinquished"
            elif t >= limit:
                outcome = "declared" if pl.declared_source is not None else "timeout"
            if outcome is not None:
                run.outcome, run.t_end = outcome, t
                run.error_at_end_m = math.hypot(tx - source.x, ty - source.y)
                run.declared = pl.declared_source
                run.lost_contacts = p.lost_contacts
                cmd_speed[i] = 0.0
            else:
                still.append(i)
        active = still
        world.set_commands(cmd_heading, cmd_speed)
    for run in runs:
        run.planner.close()
    return runs, world, time.perf_counter() - wall0
