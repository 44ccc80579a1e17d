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
