"""Fault injection for the infotaxis searchers (issue 14): the cases of
``test_fault_injection`` on the MSN007 setting flown by space-aware infotaxis and by infotaxis,
each declared by the likelihood map. Never a crash, never an invalid command (``fly`` asserts
both), never a declaration more than 15 m off."""

from __future__ import annotations

import math
from pathlib import Path

import pytest
import yaml
from test_fault_injection import CASES, FALSE_DECLARATION_M, fly

from cptbt.batch.scenario import to_sim_params
from cptbt.batch.sweeps import apply_setting
from cptbt.cli.inspect_cmds import load
from cptbt.loader import loads_mission
from cptbt.mission import MissionBase, mission_to_data
from cptbt.registry import default_registry

ROOT = Path(__file__).resolve().parents[2]
MISSION = ROOT / "missions" / "tro2006_msn007_infotaxis.yaml"


def with_variant(base: MissionBase, variant: str) -> MissionBase:
    data = mission_to_data(base)
    apply_setting(data, "find_plume.variant", variant)
    text = yaml.safe_dump(data, sort_keys=False)
    return loads_mission(text, str(MISSION), default_registry(), type(base.environment))


@pytest.fixture(scope="module")
def missions() -> dict[str, MissionBase]:
    base = load(str(MISSION), simulate=True)
    return {"space_aware_infotaxis": base, "infotaxis": with_variant(base, "infotaxis")}


@pytest.mark.parametrize("variant", ["space_aware_infotaxis", "infotaxis"])
@pytest.mark.parametrize("name", list(CASES))
def test_infotaxis_under_faults(missions: dict[str, MissionBase], variant: str,
                                name: str) -> None:
    mission = missions[variant]
    faults = CASES[name]()  # type: ignore[operator]
    source = to_sim_params(mission, 7).source_xy_m
    declared = fly(mission, faults, 7, limit_s=900.0)
    assert faults.commands, "the planner never commanded anything"
    if declared is not None:
        error = math.hypot(declared.x - source[0], declared.y - source[1])
        assert error <= FALSE_DECLARATION_M, f"{name}: declared {error:.1f} m off"
