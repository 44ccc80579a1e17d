"""study.json says which planner flew each configuration's groups (provenance)."""

from __future__ import annotations

from pathlib import Path

import pytest

from cptbt.batch.study import configurations
from cptbt.cli.batch_cmd import _planner_record
from cptbt.cli.inspect_cmds import load

ROOT = Path(__file__).resolve().parents[2]
AB3 = str(ROOT / "missions/ab2001_strategy3.yaml")
TRO = str(ROOT / "missions/tro2006_msn007.yaml")


def record(path: str, n: int) -> dict:
    mission = load(path, simulate=True).model_copy(update={"mission_a": None})
    return _planner_record(configurations(mission, [], path), n, path)


@pytest.mark.parametrize(("env", "path", "n", "want"), [
    ("auto", AB3, 9, "fleet"),
    ("auto", AB3, 4, "tree"),       # below FLEET_MIN_VEHICLES
    ("tree", AB3, 100, "tree"),     # forced
    ("fleet", AB3, 2, "fleet"),     # forced
])
def test_planner_per_configuration(monkeypatch: pytest.MonkeyPatch, env: str, path: str, n: int,
                                   want: str) -> None:
    monkeypatch.setenv("CPTBT_PLANNER", env)
    rec = record(path, n)
    assert rec["per_config"] == [want] and rec["choice"] == env
    assert rec["vehicles_per_group"] == n


def test_a_tree_the_fleet_cannot_fly_says_why(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("CPTBT_PLANNER", "auto")
    (flown,) = record(TRO, 25)["per_config"]
    assert flown.startswith("tree (") and "declare_source" in flown
