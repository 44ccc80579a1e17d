"""Safety bringing the vehicle in does not end move-to-field (a review: a study launched from a
dock outside the OpArea never flew to its starts, every run filed under a start it never
left from)."""

from __future__ import annotations

from pathlib import Path

from cptbt.cli.inspect_cmds import load
from cptbt.planner import Planner

ROOT = Path(__file__).resolve().parents[2]


def test_move_to_field_drives_after_safety_brings_the_vehicle_in() -> None:
    mission = load(str(ROOT / "missions/small_oparea.yaml"))
    area = mission.op_area_geometry()
    start = mission.to_xy(mission.start) if mission.start is not None else None
    assert start is not None
    planner = Planner(mission)
    x, y = area.xmin - 10.0, area.centre.y  # 10 m outside: safety's
    active = []
    for k in range(60):
        t = float(k + 1)
        planner.add_flow(t, 0.1, 0.0)
        planner.add_sample(t, 0.0)
        x = min(x + 1.5, area.centre.x) if k < 30 else x  # brought in, then holding inside
        planner.set_pose(x, y, 0.0)
        planner.tick(t)
        active.append(planner.active)
    planner.close()
    assert active[0] == "safety.oparea"
    assert "move_to_field.go_to" in active[active.index("safety.oparea"):], active
    assert not any(a is not None and a.startswith("find_plume") for a in active[:5]), active
