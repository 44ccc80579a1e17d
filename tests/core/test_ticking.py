"""The direct ticker makes exactly the calls py_trees' own tick makes, on random trees."""

from __future__ import annotations

import random

import py_trees
import pytest
from py_trees.common import Status

from cptbt import ticking


class Recorder(py_trees.behaviour.Behaviour):
    """A leaf that returns scripted statuses and logs its lifecycle calls."""

    def __init__(self, name: str, script: list[Status], log: list[str]) -> None:
        super().__init__(name)
        self.script, self.log, self.k = script, log, 0

    def initialise(self) -> None:
        self.log.append(f"{self.name}.initialise")

    def update(self) -> Status:
        s = self.script[self.k % len(self.script)]
        self.k += 1
        self.log.append(f"{self.name}.update->{s.name}")
        return s

    def terminate(self, new_status: Status) -> None:
        self.log.append(f"{self.name}.terminate({new_status.name})")


def build(seed: int, log: list[str]) -> py_trees.behaviour.Behaviour:
    rng = random.Random(seed)
    statuses = [Status.RUNNING, Status.FAILURE, Status.SUCCESS]
    counter = iter(range(1000))

    def leaf() -> Recorder:
        script = [rng.choices(statuses, weights=[3, 4, 1])[0] for _ in range(rng.randint(1, 9))]
        return Recorder(f"L{next(counter)}", script, log)

    def node(depth: int) -> py_trees.behaviour.Behaviour:
        if depth == 0 or rng.random() < 0.4:
            return leaf()
        kind = rng.choice([py_trees.composites.Selector, py_trees.composites.Sequence])
        return kind(f"C{next(counter)}", memory=False,
                    children=[node(depth - 1) for _ in range(rng.randint(1, 4))])

    # Shaped like the planner's tree: a sequence of watchers, then a selector of behaviours.
    watchers = [Recorder(f"W{i}", [Status.SUCCESS], log) for i in range(rng.randint(0, 2))]
    arbitrate = py_trees.composites.Selector(
        "arbitrate", memory=False, children=[node(2) for _ in range(rng.randint(1, 6))])
    return py_trees.composites.Sequence("root", memory=False, children=[*watchers, arbitrate])


def snapshot(root: py_trees.behaviour.Behaviour) -> list[tuple[str, str, str | None]]:
    return [(n.name, n.status.name, getattr(getattr(n, "current_child", None), "name", None))
            for n in root.iterate()]


@pytest.mark.parametrize("seed", range(60))
def test_direct_tick_matches_py_trees(seed: int) -> None:
    log_a: list[str] = []
    log_b: list[str] = []
    a, b = build(seed, log_a), build(seed, log_b)
    assert ticking.supports(b)
    for _ in range(25):
        a.tick_once()
        status = ticking.tick(b)
        assert log_a == log_b
        assert snapshot(a) == snapshot(b)
        assert status == a.status
        assert (a.tip().name if a.tip() else None) == (b.tip().name if b.tip() else None)


def test_unsupported_trees_are_detected() -> None:
    leaf = py_trees.behaviours.Success("s")
    assert not ticking.supports(py_trees.composites.Selector("m", memory=True, children=[leaf]))
    inverter = py_trees.decorators.Inverter("inv", child=py_trees.behaviours.Success("t"))
    assert not ticking.supports(inverter)
