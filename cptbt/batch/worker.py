"""Flying one group of a study: what a worker process (local or Dask) runs."""

from __future__ import annotations

from typing import Any

from cptbt.batch.engine import simulate
from cptbt.batch.scenario import Environment, planning_angle, to_sim_params
from cptbt.batch.study import GroupTask, group_seeds
from cptbt.batch.summary import summarise
from cptbt.loader import loads_mission
from cptbt.registry import default_registry
from cptbt.types import Point

SUCCESS = ("declared", "found")


def flatten(summary: dict[str, Any]) -> dict[str, Any]:
    """One flat row of a run summary (nested places become ``<name>_<axis>`` columns)."""
    row: dict[str, Any] = {}
    for key, value in summary.items():
        if key in ("time_in_behaviour_s", "time_share"):
            continue
        if isinstance(value, dict):
            for sub, v in value.items():
                row[f"{key}_{sub}"] = v
        elif value is None and key in ("declared_source",):
            for sub in ("x", "y", "north", "east"):
                row[f"{key}_{sub}"] = None
        else:
            row[key] = value
    for name, seconds in summary.get("time_in_behaviour_s", {}).items():
        row[f"time_{name.split('.')[0] if name.count('.') == 1 else name}_s"] = seconds
    return row


def run_group(task: GroupTask) -> list[dict[str, Any]]:
    """Fly every start of one group in one world; one flat row per run."""
    mission = loads_mission(task.mission_yaml, f"group {task.key}", default_registry(),
                            Environment)
    params = to_sim_params(mission, task.root_seed)
    env_rng, vehicle_rngs = group_seeds(task.root_seed, task.replicate, len(task.starts))
    heading = planning_angle(mission, task.heading_deg)
    starts = [(x, y, heading) for x, y in task.starts]
    runs, _, wall = simulate(mission, params, starts, env_rng=env_rng,
                             vehicle_rngs=vehicle_rngs, time_limit_s=task.time_limit_s)
    source = Point(*params.source_xy_m)
    rows = []
    for i, run in enumerate(runs):
        row = {"config": task.config, **task.coords, "replicate": task.replicate, "start": i}
        row.update(flatten(
            summarise(run, mission, source, task.root_seed, wall / len(runs)).to_dict()
        ))
        row["success"] = run.outcome in SUCCESS
        rows.append(row)
    return rows
