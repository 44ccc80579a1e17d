"""The MSN007 runs the likelihood map declared far short of the source, flown again (issue 13).

Replicates 208, 348, 760, 874 and 918 of the 1000-run declaration study (root seed 2024,
``benchmarks/likelihood_map.py``) declared 19-46 m down-flow of the source before the up-flow
check: the map was sure of a point the vehicle had not crossed up-flow of (208: one cloverleaf leaf
on one side only), or whose plume it had just seen farther up-flow (760). Each must now declare
within 15 m; with the check turned off each still declares beyond it (so this test can fail).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest
import yaml

from cptbt.batch.engine import simulate
from cptbt.batch.scenario import Environment, launch_pose, to_sim_params
from cptbt.batch.study import apply_setting, group_seeds
from cptbt.loader import load_mission, loads_mission
from cptbt.mission import mission_to_data
from cptbt.registry import default_registry
from cptbt.types import Point

ROOT = Path(__file__).resolve().parents[2]
MSN007 = ROOT / "missions/tro2006_msn007.yaml"
SHORT = (208, 348, 760, 874, 918)


def declaration_error(replicate: int, **settings: Any) -> float:
    """Fly one study replicate (the AMP alone, as the study does) with the map's declaration."""
    data = mission_to_data(load_mission(MSN007, default_registry(), Environment))
    data["mission_a"] = None
    for key, value in {"declare_source.variant": "likelihood_map", **settings}.items():
        apply_setting(data, key, value)
    mission = loads_mission(yaml.safe_dump(data, sort_keys=False), str(MSN007),
                            default_registry(), Environment)
    params = to_sim_params(mission, 2024)
    env_rng, vehicle_rngs = group_seeds(2024, replicate, 1)
    (run,), _, _ = simulate(mission, params, [launch_pose(mission)], env_rng=env_rng,
                            vehicle_rngs=vehicle_rngs)
    assert run.declared is not None, f"replicate {replicate}: no declaration"
    return run.declared.distance_to(Point(*params.source_xy_m))


@pytest.mark.parametrize("replicate", SHORT)
def test_a_run_once_declared_short_is_now_declared_at_the_source(replicate: int) -> None:
    assert declaration_error(replicate) < 15.0
    # the same plume without the check: still short (the check is what changed the outcome)
    assert declaration_error(replicate, **{"declare_source.upflow_check_m": None,
                                           "declare_source.radius_m": 8.0}) > 15.0
