"""The arbitration tree: priority, inhibition and pre-emption (SPEC §3), with scripted leaves."""

from __future__ import annotations

from conftest import ScriptedParams, scripted_registry
from py_trees.common import Status

from cptbt.mission import BehaviourEntry
from cptbt.testing import ScriptedPerception, TreeHarness, fresh_namespace
from cptbt.tree import build_tree, plan_leaves

FAMILIES = ("safety", "declare_source", "maintain_plume", "reacquire_plume", "find_plume",
            "move_to_field")


def harness(schedule: dict[str, tuple[float, ...]]) -> TreeHarness:
    """A tree of scripted behaviours in TRO priority; ``schedule`` says when each has output."""
    reg = scripted_registry(*FAMILIES)
    entries = [
        BehaviourEntry(
            family=f, variant="scripted",
            params=ScriptedParams(active_at=schedule.get(f, ()), heading_deg=10.0 * i),
        )
        for i, f in enumerate(FAMILIES)
    ]
    return TreeHarness(build_tree(entries, reg, fresh_namespace()))


def run(h: TreeHarness, n: int) -> list[str | None]:
    s = ScriptedPerception()
    return [h.tick(s.step(float(t), 50.0, 0.0)).active for t in range(n)]


def leaf(h: TreeHarness, family: str):  # type: ignore[no-untyped-def]
    return next(b for b in plan_leaves(h.root) if b.family == family)


def test_highest_behaviour_with_output_wins_each_tick() -> None:
    h = harness({
        "find_plume": (0, 1, 2, 3, 4, 5),
        "reacquire_plume": (1, 2, 4),
        "maintain_plume": (2,),
        "safety": (4,),
    })
    assert run(h, 7) == [
        "find_plume.scripted",
        "reacquire_plume.scripted",
        "maintain_plume.scripted",
        "find_plume.scripted",
        "safety.scripted",
        "find_plume.scripted",
        None,  # nobody has an output: the tree fails and the planner holds
    ]


def test_command_comes_from_the_winner() -> None:
    h = harness({"find_plume": (0,), "reacquire_plume": (0,)})
    tick = h.tick(ScriptedPerception().step(0.0, 50.0, 0.0))
    assert tick.status == Status.RUNNING
    assert tick.command is not None and tick.command.heading_deg == 30.0  # reacquire's heading


def test_preemption_terminates_the_lower_behaviour_and_it_restarts_fresh() -> None:
    h = harness({"reacquire_plume": (0, 1, 3, 4), "maintain_plume": (2,)})
    run(h, 5)
    re = leaf(h, "reacquire_plume")
    # Activated at t=0, pre-empted at t=2 by maintain, activated afresh at t=3.
    assert re.activations == 2
    assert "Status.INVALID" in re.terminations


def test_lower_behaviours_are_not_ticked_while_inhibited() -> None:
    h = harness({"safety": (0, 1, 2), "find_plume": (0, 1, 2)})
    run(h, 3)
    assert leaf(h, "find_plume").activations == 0


def test_no_output_anywhere_fails_the_tree() -> None:
    h = harness({})
    tick = h.tick(ScriptedPerception().step(0.0, 50.0, 0.0))
    assert tick.status == Status.FAILURE and tick.command is None


def test_a_mission_harness_flies_what_the_planner_flies() -> None:
    """A review's whole-tree test, built with ``make_context``, flew find-plume at 1 m/s toward
    (0, 0) where the planner flew move-to-field at the mission's 1.5 m/s toward its start: the
    harness made from the mission gives the same commands, cycle by cycle, as the planner."""
    from pathlib import Path

    from cptbt.loader import load_mission
    from cptbt.planner import Planner

    mission = load_mission(Path(__file__).resolve().parents[2] / "missions/tro2006_msn007.yaml")
    harness = TreeHarness.from_mission(mission)
    planner = Planner(mission)
    area = mission.op_area_geometry()
    script = ScriptedPerception(area, flow=(0.1, 0.0), lambda_s=mission.perception.lambda_s)
    steps = [script.step(0, 60, -10), script.step(1, 0, 0, conc=1.0), script.step(2, -2, 1),
             script.step(14, -5, 3), script.step(15, -6, 4)]
    got = [harness.tick(p) for p in steps]
    want = [(planner.step(p), planner.active) for p in steps]
    assert [(t.command, t.active) for t in got] == want
    assert got[0].active == "move_to_field.go_to" and got[0].command.speed_mps == 1.5
    assert got[-1].active == "reacquire_plume.cloverleaf"
