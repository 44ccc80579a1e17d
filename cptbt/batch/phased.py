"""A phased single-vehicle run: Mission A, the AMP override, the give-back and the resumed
Mission A (SPEC §9; TRO Fig. 1), the AMP talking to the simulator only through the vehicle link.

The AMP portion is recorded as a :class:`cptbt.batch.engine.VehicleRun` (times are the mission
clock; ``t0`` is the take-over), so :func:`cptbt.batch.summary.summarise` and the figures work on
it unchanged; the whole run's trace carries a ``phase`` column.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from cptbt.batch.engine import (
    PlumeSnapshot,
    VehicleRun,
    collect_declarations,
    keep_partial,
    note_declarations,
    run_loop,
)
from cptbt.batch.outcome import Outcome, outcome_of
from cptbt.batch.outside import is_home_leg, outside_away_from
from cptbt.batch.recorder import Recorder
from cptbt.batch.scenario import environment_of, planning_angle
from cptbt.batch.sim_link import LinkFaults, SimVehicleLink
from cptbt.batch.summary import where
from cptbt.mission import MissionBase
from cptbt.phases import GIVE_BACK_TRIGGERS, PhaseChange
from cptbt.planner import Planner
from cptbt.session import AmpSession
from cptbt.sim.world import EnvironmentParams, StepOutput, World
from cptbt.types import Point


@dataclass
class PhasedRun:
    """A whole phased run.

    Attributes:
        amp: the AMP portion (for the TRO measures).
        timeline: the phase changes.
        t_amp_start: take-over time (None if the AMP never took over).
        break_off: where the vehicle was when the override began (planning, navigation frame).
        resumed_at: where the vehicle was when it resumed Mission A (None if it never did).
        end_phase: the phase when the run stopped.
        t_end: the mission clock when the run stopped.
        refusals: commands the vehicle refused.
        waypoints: Mission A's waypoints, planning frame.
        time_in_phase_s: time spent in each phase.
    """

    amp: VehicleRun
    timeline: list[PhaseChange]
    t_amp_start: float | None
    break_off: tuple[float, float] | None
    resumed_at: tuple[float, float] | None
    end_phase: str
    t_end: float
    refusals: int
    waypoints: list[Point]
    time_in_phase_s: dict[str, float] = field(default_factory=dict)

    def triggers(self) -> list[str]:
        """The timeline's triggers in order."""
        return [c.trigger for c in self.timeline]


def launch_pose_phased(mission: MissionBase) -> tuple[float, float, float]:
    """Where a phased run starts: ``environment.launch``, else home (the boat), planning frame."""
    env = environment_of(mission)
    p = mission.to_xy(env.launch or mission.home)
    return p.x, p.y, planning_angle(mission, env.launch_heading_deg)


def simulate_phased(
    mission: MissionBase,
    params: EnvironmentParams,
    *,
    faults: LinkFaults | None = None,
    trace: bool = False,
    max_time_s: float | None = None,
    plume_grid: tuple[Any, Any] | None = None,
    planner: Planner | None = None,
    observers: Sequence[Callable[[AmpSession], None]] = (),
) -> tuple[PhasedRun, World, float]:
    """Fly a mission with a ``mission_a`` section until post-mission (or ``max_time_s``).

    ``planner`` replaces the default one (e.g. a :class:`cptbt.logs.RecordingPlanner`);
    each of ``observers`` is called after every session update (e.g. a cycle log).

    Returns:
        The run, the world at the end and the wall time spent.
    """
    spec = mission.mission_a
    if spec is None:
        raise ValueError(f"mission {mission.name!r} has no mission_a section")
    wall0 = time.perf_counter()
    x0, y0, h0 = launch_pose_phased(mission)
    world = World(params, np.array([[x0, y0]]), h0)
    world.warm_up()
    source = Point(*params.source_xy_m)
    area = mission.op_area_geometry()
    home_outside, home = "home" in mission.allow_outside, mission.to_xy(mission.home)
    waypoints = [mission.to_xy(w) for w in spec.waypoints]
    link = SimVehicleLink(world, spec, waypoints, faults)
    planner = planner or Planner(mission)
    session = AmpSession(mission, planner, link)
    arrival = mission.evaluation.criterion == "arrival"
    radius = mission.evaluation.success_radius_m
    cap = spec.duration_limit_s if max_time_s is None else min(max_time_s, spec.duration_limit_s)
    period = 1.0 / mission.cycle_hz
    amp_rows = Recorder(1, math.ceil(mission.time_limit_s / period) + 4)
    rows = Recorder(1, math.ceil(cap / period) + 4, trace=True) if trace else None
    run = VehicleRun(planner, (x0, y0), amp_rows, 0, period, rows)
    one = np.zeros(1, dtype=np.intp)
    phase_time: dict[str, float] = {}
    next_row = 0.0
    resumed_at = None
    ended: PhaseChange | None = None
    session.update()
    phase_before = session.phases.state

    def prepare() -> None:
        nonlocal phase_before
        phase_before = session.phases.state
        link.prepare()

    def observe(out: StepOutput) -> bool:
        nonlocal ended, next_row, resumed_at
        link.observe(out)
        session.update()
        for watcher in observers:
            watcher(session)
        t = out.t_s
        tx, ty = float(out.true_xy[0, 0]), float(out.true_xy[0, 1])
        ex, ey = float(out.nav_xy[0, 0]), float(out.nav_xy[0, 1])
        phase_time[phase_before] = phase_time.get(phase_before, 0.0) + world.params.dt_s
        ticked = session.ticked
        values: dict[str, Any] = {"t": t, "x": tx, "y": ty, "x_est": ex, "y_est": ey}
        if session.t_amp_start is not None and ended is None:
            run.closest_m = min(run.closest_m, math.hypot(tx - source.x, ty - source.y))
            # every step, the give-back one too (a review: a row-less step had been left out),
            # on the way to a home the mission puts outside, through the other walls only
            far = (area.distance_outside(tx, ty) if not (home_outside and is_home_leg(
                planner.active)) else float(outside_away_from(
                    area, np.array([tx]), np.array([ty]), home)[0]))
            run.outside_m = max(run.outside_m, far)
            if ticked:
                _record_amp(run, planner, t, values, world, plume_grid)
        if ended is None:
            ended = _amp_end(session.phases.timeline)
            if (ended is None and arrival and session.in_override
                    and math.hypot(tx - source.x, ty - source.y) <= radius):
                # AB appendix: success on reaching the source (the AMP is not told; it flies on).
                ended = PhaseChange(t, session.phases.state, session.phases.state, "arrival")
            if ended is not None:
                run.outcome = outcome_of(ended.trigger, planner.declared_source is not None)
                run.t_end = ended.t_s
                run.distance_at_end_m = math.hypot(tx - source.x, ty - source.y)
                run.declared = planner.declared_source
                run.lost_contacts = planner.percept.lost_contacts if planner.percept else ()
                run.sensor_faults = planner.perception.faults()
                if plume_grid is not None and run.plume is None:
                    run.plume = PlumeSnapshot.of(world, plume_grid)
        if resumed_at is None and session.phases.state == "mission_a.resumed":
            resumed_at = (ex, ey)
        grid_due = t + 1e-9 >= next_row
        if grid_due:
            next_row += period * max(1, math.floor((t + 1e-9 - next_row) / period) + 1)
        if rows is not None and (ticked or (grid_due and not session.in_override)):
            # under override a row per planner tick; otherwise one per cycle period
            _record_row(rows, one, out, planner if ticked else None, session.phases.state, values)
        return not (session.phases.state == "post_mission" or t + 1e-9 >= cap)

    try:
        run_loop(world, prepare, observe)
    except Exception as exc:  # cptbt run writes the trace up to the error, drawn as a run's
        keep_partial(exc, [run], world, waypoints)
        raise
    finally:  # where the AMP took over (an error's partial run too)
        if amp_rows.count[0]:
            run.start = (float(run.path_true[0, 0]), float(run.path_true[0, 1]))
    if run.outcome is None:
        amp_on = session.t_amp_start is not None
        run.outcome = Outcome.AMP_RUNNING if amp_on else Outcome.AMP_NOT_ENABLED
        run.t_end = session.t
        run.declared = planner.declared_source
    collect_declarations(run, planner)
    run.nonfinite_commands = planner.nonfinite_commands()  # the AMP's, ticked only in override
    planner.close()
    result = PhasedRun(
        amp=run,
        timeline=list(session.phases.timeline),
        t_amp_start=session.t_amp_start,
        break_off=link.break_off,
        resumed_at=resumed_at,
        end_phase=session.phases.state,
        t_end=session.t,
        refusals=session.refusals,
        waypoints=waypoints,
        time_in_phase_s=phase_time,
    )
    return result, world, time.perf_counter() - wall0


def _amp_end(timeline: list[PhaseChange]) -> PhaseChange | None:
    """The change that ended the override (a give-back, or the vehicle's mission ending)."""
    for c in timeline:
        if c.trigger in GIVE_BACK_TRIGGERS or (
            c.trigger == "mission_a_complete" and c.source.startswith("amp.")
        ):
            return c
    return None


def _record_amp(run: VehicleRun, planner: Planner, t: float, values: dict[str, Any],
                world: World, grid: tuple[Any, Any] | None) -> None:
    p = planner.percept
    assert p is not None
    rec = run.recorder
    rec.add(np.zeros(1, dtype=np.intp), values, p.detected, rec.code(planner.active))
    if p.detected and run.t1 is None:
        run.t1 = t
    if run.t3 is None and planner.declared_source is not None and grid is not None:
        run.plume = PlumeSnapshot.of(world, grid)
    note_declarations(run, planner, t)


def _record_row(
    rows: Recorder,
    one: Any,
    out: Any,
    planner: Planner | None,
    phase: str,
    values: dict[str, Any],
) -> None:
    p = planner.percept if planner is not None else None
    cmd = planner.command if planner is not None else None
    flow = p.flow if p is not None else None
    row = values | {
        "heading": float(out.true_heading_deg[0]),
        "heading_est": float(out.nav_heading_deg[0]),
        "concentration": p.concentration if p is not None else math.nan,
        "flow_vx": flow.vx if flow else math.nan,
        "flow_vy": flow.vy if flow else math.nan,
        "cmd_heading": cmd.heading_deg if cmd else math.nan,
        "cmd_speed": cmd.speed_mps if cmd else math.nan,
    }
    active = rows.code(planner.active) if planner is not None else 0
    rows.add(one, row, bool(p.detected) if p is not None else False, active,
             rows.phase_code(phase))


def phase_summary(result: PhasedRun, mission: MissionBase) -> dict[str, Any]:
    """The ``phases`` section of summary.json: the timeline and where the hand-overs happened."""

    def at(p: tuple[float, float] | None) -> dict[str, float] | None:
        return where(mission, None if p is None else Point(*p))

    return {
        "timeline": [c.to_data() for c in result.timeline],
        "end_phase": result.end_phase,
        "run_time_s": result.t_end,
        "t_amp_start": result.t_amp_start,
        "break_off": at(result.break_off),
        "resumed_at": at(result.resumed_at),
        "command_refusals": result.refusals,
        "time_in_phase_s": dict(sorted(result.time_in_phase_s.items())),
    }
