"""Fault injection through the planner's public API, in closed loop with the simulator.

The planner is fed what a faulty vehicle would feed it — flow outliers (the netCDF fill value
9.97e36, spikes, NaN), non-finite position fixes, a clock that steps back or repeats, fluorometer
dropouts and a stuck sensor — and must never raise, never emit an invalid command, and never
declare a source more than 15 m from the true one (SPEC §7: a declaration must never be false).
The AMP session is tested the same way for a clock step and an infinite fix.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pytest

from cptbt.batch.scenario import launch_pose, to_sim_params
from cptbt.cli.inspect_cmds import load
from cptbt.mission import MissionBase
from cptbt.planner import Planner
from cptbt.sim.world import World
from cptbt.types import Command, Point

ROOT = Path(__file__).resolve().parents[2]
MSN007 = ROOT / "missions" / "tro2006_msn007.yaml"
FALSE_DECLARATION_M = 15.0


@dataclass
class Faults:
    """What to do to the samples on their way to the planner (None: leave them alone)."""

    flow: Callable[[float, float, float], tuple[float, float]] | None = None
    conc: Callable[[float, float], float] | None = None
    pose: Callable[[float, float, float], tuple[float, float]] | None = None
    clock: Callable[[float], float] | None = None
    commands: list[Command] = field(default_factory=list)


def fly(mission: MissionBase, faults: Faults, seed: int, limit_s: float = 1500.0) -> Point | None:
    """Fly the planner alone (no Mission A) with faulty inputs; the declared source, if any."""
    params = to_sim_params(mission, seed)
    x, y, h = launch_pose(mission)
    world = World(params, np.array([[x, y]]), np.array([h]))
    world.warm_up()
    planner = Planner(mission)
    period, next_tick = 1.0 / mission.cycle_hz, 0.0
    clock = faults.clock or (lambda t: t)
    while True:
        out = world.step()
        t = out.t_s
        if out.fluorometer is not None:
            c = float(out.fluorometer[0])
            planner.add_sample(clock(t), faults.conc(t, c) if faults.conc else c)
        if out.adcp_flow is not None:
            vx, vy = float(out.adcp_flow[0, 0]), float(out.adcp_flow[0, 1])
            planner.add_flow(clock(t), *(faults.flow(t, vx, vy) if faults.flow else (vx, vy)))
        if t + 1e-9 < next_tick:
            continue
        next_tick += period
        ex, ey = float(out.nav_xy[0, 0]), float(out.nav_xy[0, 1])
        if faults.pose:
            ex, ey = faults.pose(t, ex, ey)
        planner.set_pose(ex, ey, float(out.nav_heading_deg[0]))
        cmd = planner.tick(clock(t))
        if cmd is not None:
            assert math.isfinite(cmd.heading_deg) and -180 < cmd.heading_deg <= 180, cmd
            assert math.isfinite(cmd.speed_mps) and 0 < cmd.speed_mps <= 2.8, cmd
            faults.commands.append(cmd)
            world.set_commands(np.array([cmd.heading_deg]), np.array([cmd.speed_mps]))
        if planner.done or t >= limit_s:
            declared = planner.declared_source
            planner.close()
            return declared


def fill_value_once(t: float, vx: float, vy: float) -> tuple[float, float]:
    return (9.97e36, 9.97e36) if 300 <= t < 302 else (vx, vy)


def spikes(t: float, vx: float, vy: float) -> tuple[float, float]:
    k = int(t / 2)
    if k % 17 == 0:
        return 4.9, -4.9 if k % 2 else 4.9  # just under the 5 m/s gate: a bad, finite sample
    if k % 23 == 0:
        return math.nan, vy
    return vx, vy


def inf_fixes(t: float, x: float, y: float) -> tuple[float, float]:
    if int(t) % 97 == 0:
        return math.inf, y
    return (math.nan, math.nan) if int(t) % 131 == 0 else (x, y)


def clock_steps_back(t: float) -> float:
    return t - 50.0 if t >= 400 else t


def clock_repeats(t: float) -> float:
    return math.floor(t / 3) * 3  # every cycle time stamp seen three times


def dropout(t: float, c: float) -> float:
    return math.nan if 200 <= t < 260 or int(t) % 29 == 0 else c


def stuck(t: float, c: float) -> float:
    return 0.05 if 500 <= t < 620 else c


CASES: dict[str, Faults | Callable[[], Faults]] = {
    "fill value once": lambda: Faults(flow=fill_value_once),
    "flow spikes and NaN": lambda: Faults(flow=spikes),
    "inf and NaN fixes": lambda: Faults(pose=inf_fixes),
    "clock steps back 50 s": lambda: Faults(clock=clock_steps_back),
    "clock repeats": lambda: Faults(clock=clock_repeats),
    "fluorometer dropouts": lambda: Faults(conc=dropout),
    "stuck fluorometer": lambda: Faults(conc=stuck),
}


@pytest.fixture(scope="module")
def msn007() -> MissionBase:
    return load(str(MSN007), simulate=True)


@pytest.mark.parametrize("name", list(CASES))
def test_faults_never_crash_never_mislead(msn007: MissionBase, name: str) -> None:
    faults = CASES[name]()  # type: ignore[operator]
    source = to_sim_params(msn007, 7).source_xy_m
    declarations = 0
    for seed in (7, 8):
        declared = fly(msn007, faults, seed)
        assert faults.commands, "the planner never commanded anything"
        if declared is not None:
            declarations += 1
            error = math.hypot(declared.x - source[0], declared.y - source[1])
            assert error <= FALSE_DECLARATION_M, f"{name}, seed {seed}: declared {error:.1f} m off"
    assert declarations, f"{name}: the faults stopped the planner from ever declaring"


def test_one_fill_value_does_not_bend_the_flow_estimate(msn007: MissionBase) -> None:
    planner = Planner(msn007)
    for k in range(50):
        planner.add_flow(2.0 * k, 0.1, 0.0)
    planner.add_flow(100.0, 9.97e36, 9.97e36)
    planner.set_pose(0.0, 0.0)
    planner.tick(100.0)
    flow = planner.percept.flow if planner.percept else None
    assert flow is not None and flow.vx == pytest.approx(0.1) and flow.vy == pytest.approx(0.0)
    assert planner.perception.rejected_flow_samples == 1
    planner.close()


@pytest.mark.parametrize("t", [-math.inf, math.inf, math.nan, -1e308])
def test_tick_accepts_any_time_stamp(msn007: MissionBase, t: float) -> None:
    planner = Planner(msn007)
    planner.set_pose(-60.0, 10.0)
    planner.tick(10.0)
    cmd = planner.tick(t)
    assert cmd is None or (math.isfinite(cmd.heading_deg) and math.isfinite(cmd.speed_mps))
    assert planner.percept is not None and planner.percept.t > 10.0  # the planner clock moved on
    planner.close()


def test_clock_step_back_keeps_contact_timers_honest(msn007: MissionBase) -> None:
    # A detection, then the vehicle clock steps back 50 s: λ = 8.5 s must still expire after
    # 8.5 s of cycles, not after 58.5 s.
    planner = Planner(msn007)
    planner.add_flow(0.0, 0.1, 0.0)
    planner.set_pose(0.0, 0.0)
    planner.add_sample(100.0, 1.0)
    planner.tick(100.0)
    in_plume = []
    for k in range(1, 15):
        planner.tick(100.0 - 50.0 + k if k > 2 else 100.0 + k)
        assert planner.percept is not None
        in_plume.append(planner.percept.in_plume)
    assert in_plume[:8] == [True] * 8 and not any(in_plume[9:])
    planner.close()
