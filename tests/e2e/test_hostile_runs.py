"""Missions that validate must fly in bounded time: the time limit holds off the cycle grid,
and the simulator's own spin-up is bounded (the review of 2026-11-22, F3 and F4)."""

from __future__ import annotations

from pathlib import Path

import pytest

from cptbt.batch.engine import simulate
from cptbt.batch.scenario import Environment, launch_pose, to_sim_params
from cptbt.loader import load_mission
from cptbt.registry import default_registry

ROOT = Path(__file__).resolve().parents[2]
MSN007 = ROOT / "missions/tro2006_msn007.yaml"
AB3 = ROOT / "missions/ab2001_strategy3.yaml"


@pytest.mark.parametrize(("path", "planner"), [(MSN007, "tree"), (AB3, "fleet")])
def test_a_run_ends_at_the_time_limit_when_the_cycle_does_not_divide_it(
    path: Path, planner: str
) -> None:
    # A 30 s cycle against a 50 s limit: ticks at 0 and 30 s, the next at 60 s is past the
    # limit. The run ends at 50 s (the first vehicle step there), not at the next cycle.
    mission = load_mission(path, default_registry(), Environment)
    mission = mission.model_copy(update={"cycle_hz": 1 / 30, "mission_a": None})
    params = to_sim_params(mission, 1).model_copy(update={"warm_up_s": 10.0})
    x, y, h = launch_pose(mission)
    runs, world, _ = simulate(mission, params, [(x, y, h)] * 8, time_limit_s=50.0,
                              planner=planner)
    dt = world.params.dt_s
    for run in runs:
        assert run.outcome is not None and run.outcome.value == "timeout", run.outcome
        assert run.t_end is not None and 50.0 <= run.t_end < 50.0 + dt + 1e-9, run.t_end


@pytest.mark.parametrize(("path", "planner"), [(MSN007, "tree"), (AB3, "fleet")])
def test_a_fix_the_planner_throws_away_does_not_end_the_run(path: Path, planner: str) -> None:
    """An attacker's navigation drift of 1e300 m: the planner ignored every fix (more than
    1000 km outside), and the simulated run still ended at once as "more than 30 m outside",
    where ``cptbt serve`` keeps the AMP in control; the fleet planner had taken the fixes."""
    mission = load_mission(path, default_registry(), Environment)
    mission = mission.model_copy(update={"mission_a": None})
    params = to_sim_params(mission, 1).model_copy(update={"warm_up_s": 10.0})
    params = params.model_copy(update={"navigation": params.navigation.model_copy(
        update={"drift_std_m": 1e300})})
    runs, _, _ = simulate(mission, params, [launch_pose(mission)] * 8, time_limit_s=20.0,
                          planner=planner)
    for run in runs:
        assert run.outcome is not None and run.outcome.value == "timeout", run.outcome
        assert run.sensor_faults["rejected_fixes"] > 0, run.sensor_faults
