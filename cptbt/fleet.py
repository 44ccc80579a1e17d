"""The fleet planner: one mission's tree evaluated for N vehicles at once (issue 15).

The per-vehicle :class:`~cptbt.planner.Planner` walks a py_trees tree per vehicle per cycle; at
AB's scale (100 searchers sharing a plume, 10,000 missions) that Python walk, the behaviours'
scalar arithmetic, the blackboard and the perception cost about twice the vectorised simulator.
:class:`FleetPlanner` evaluates the same tree for every vehicle of a group with numpy arrays:

- **perception**: :class:`FleetPerception` condenses each cycle's samples into one
  :class:`FleetPercept` of arrays, by the rules of :class:`~cptbt.perception.Perception`;
- **behaviours**: each behaviour class that supports it names its array form, a
  :class:`FleetRule` (``PlanBehaviour.fleet_rule``), evaluated over the vehicles the selector
  reaches it for;
- **the memory-less priority selector** as masks: a behaviour is ticked for the vehicles every
  higher behaviour left without output; the first with an output wins;
- **initialise / terminate** as index sets on activation changes: a behaviour's ``initialise``
  runs for the vehicles it is ticked for and was not RUNNING for on the previous cycle (py_trees
  calls ``initialise`` whenever a node ticks while not RUNNING); ``terminate`` for the vehicles
  it was RUNNING for and now is not (it failed, or a higher behaviour won);
- **the blackboard** as :class:`FleetBoard`: one array per key, one element per vehicle.

It is chosen only when every behaviour of the mission supports it (:func:`fleet_support`); any
other tree (a plug-in without an array form, nested composites, watchers) keeps the per-vehicle
planner, unchanged.

Reading chosen (one source of truth): the scalar ``decide`` stays the rule the per-vehicle path
runs, bit for bit as before; the array form is a second writing of it, so
:func:`cptbt.testing.check_fleet_rule` and :func:`cptbt.testing.check_fleet_mission` compare
the two tick by tick on random percept streams and whole missions (tests/core/test_fleet.py).
The rarely taken branches (a wall reflection, a (re)start) call the scalar helpers per vehicle
instead of being written again. Every float is computed as the scalar code computes it
(``math.atan2``/``math.hypot`` element by element, Python's ``round`` near the thresholds it
decides, ``math.fsum`` for flow windows of more than two samples), so the two paths agree bit
for bit, not just closely.

Limits: the planner clock is the simulator's, so cycle times must increase (a clock that steps
back, which :class:`~cptbt.perception.Perception` repairs, is refused).
"""

from __future__ import annotations

import math
import os
from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import Any, ClassVar, Literal

import numpy as np
from numpy.typing import NDArray

from cptbt.angles import bearing_deg_array, wrap_deg_array
from cptbt.fleet_perception import (
    BoolArray,
    FleetPercept,
    FleetPerception,
    FloatArray,
    Index,
    IntArray,
)
from cptbt.mission import MissionBase
from cptbt.node import (
    WAIT_FOR_FIELD,
    BehaviourParams,
    MissionContext,
    PlanBehaviour,
    Watch,
    planner_keys,
)
from cptbt.perception import PerceptionSettings
from cptbt.planner import field_reached_at_start, mission_context
from cptbt.registry import Registry, default_registry
from cptbt.tree import build_tree, plan_leaves

PlannerChoice = Literal["auto", "fleet", "tree"]
PLANNER_ENV = "CPTBT_PLANNER"
"""Environment variable forcing the batch engine's planner: ``auto`` (default), ``fleet`` or
``tree`` (per-vehicle py_trees)."""


def planner_choice(value: str | None = None) -> PlannerChoice:
    """The planner choice: ``value`` if given, else ``$CPTBT_PLANNER``, else ``auto``.

    Raises:
        ValueError: not one of auto, fleet, tree.
    """
    choice = value if value is not None else os.environ.get(PLANNER_ENV, "auto") or "auto"
    if choice not in ("auto", "fleet", "tree"):
        raise ValueError(f"{PLANNER_ENV}={choice!r}: use auto, fleet or tree")
    return choice  # type: ignore[return-value]


def round9_near(values: FloatArray, *thresholds: float) -> FloatArray:
    """``round(v, 9)`` for the values within 1e-6 of a threshold, the values as they are otherwise.

    The scalar rules compare ``round(t - T, 9)`` with thresholds; rounding moves a value by at
    most 5e-10, so only values near a threshold can compare differently, and those few go
    through Python's ``round`` (numpy's rounds by another method).
    """
    near = np.zeros(len(values), dtype=bool)
    for th in thresholds:
        near |= np.abs(values - th) < 1e-6
    if not np.count_nonzero(near):
        return values
    out = values.copy()
    out[near] = [round(v, 9) for v in values[near].tolist()]
    return out


def upflow_array(vx: FloatArray, vy: FloatArray) -> FloatArray:
    """:attr:`~cptbt.types.FlowEstimate.upflow_deg` of every flow."""
    return wrap_deg_array(bearing_deg_array(vx, vy) + 180.0)


# -- the blackboard and the rules ---------------------------------------------------------------


class FleetBoard:
    """The fleet's blackboard: one array per key, one element per vehicle.

    Each rule documents the encoding of the keys it shares (e.g. 0 for an unset sign).
    """

    def __init__(self, n: int) -> None:
        self.n = n
        self._arrays: dict[str, NDArray[Any]] = {}

    def array(self, key: str, dtype: Any = float, fill: Any = np.nan) -> NDArray[Any]:
        """The array of ``key``, created filled with ``fill`` on first use."""
        a = self._arrays.get(key)
        if a is None:
            a = self._arrays[key] = np.full(self.n, fill, dtype=dtype)
        return a

    def has(self, key: str) -> bool:
        """Whether any rule created ``key``."""
        return key in self._arrays


class FleetRule:
    """The array form of a :class:`~cptbt.node.PlanBehaviour`'s rule.

    A behaviour class supports the fleet planner by naming its rule in ``fleet_rule``; the rule
    lists the exact classes it reproduces in ``covers`` (a subclass that changes the rule is not
    covered and falls back to the per-vehicle planner). State is kept in arrays over the fleet.

    Args:
        params: the behaviour's parameters (the mission entry's).
        context: the mission context (OpArea, home, speed); ``percept`` is unused.
        board: the fleet's blackboard.
    """

    covers: ClassVar[tuple[type[PlanBehaviour], ...]] = ()

    def __init__(self, params: BehaviourParams, context: MissionContext, board: FleetBoard
                 ) -> None:
        self.params = params
        self.context = context
        self.board = board
        self.n = board.n
        self.speed = params.speed_mps or context.speed_mps
        # the scalar form's, one source of truth (safety's is False: session 27)
        self.ends_move_to_field = all(c.ends_move_to_field for c in self.covers)
        self.prepare()

    def prepare(self) -> None:
        """Create the state arrays (called at the end of ``__init__``)."""

    def initialise(self, ids: Index) -> None:
        """A new activation for the vehicles ``ids`` (the leaf's ``initialise``)."""

    def terminate(self, ids: Index) -> None:
        """The vehicles ``ids`` stopped RUNNING this behaviour (the leaf's ``terminate``)."""

    def decide(self, p: FleetPercept, running: BoolArray) -> FloatArray:
        """The commanded heading for each vehicle of ``p``; NaN where there is no output.

        ``running``: the behaviour was RUNNING for that vehicle on the previous cycle (the
        leaf's ``status`` when its ``update`` runs).
        """
        raise NotImplementedError


# -- which missions, and the planner -----------------------------------------------------------


@dataclass(frozen=True)
class FleetSupport:
    """Whether a mission's tree can be evaluated by the fleet planner, and why not."""

    ok: bool
    reason: str = ""
    leaves: tuple[tuple[str, type[FleetRule], BehaviourParams], ...] = ()


def fleet_support(mission: MissionBase, registry: Registry | None = None) -> FleetSupport:
    """Whether every behaviour of ``mission`` has an array form (and the tree is flat)."""
    if mission.turn_guard_radius_m is not None:
        return FleetSupport(False, "turn_guard_radius_m (cptbt.turns) has no array form")
    registry = registry or default_registry()
    namespace = f"/cptbt/fleetcheck{next(_check_ids)}"
    root = build_tree(mission.entries(), registry, namespace)
    try:
        children = root.children
        watchers = [c.behaviour.name for c in children if isinstance(c, Watch)]
        if watchers:
            return FleetSupport(False, f"{', '.join(watchers)} watch every cycle (a map, a "
                                "declaration rule), which has no array form")
        if len(children) != 1:
            return FleetSupport(False, "the tree is not one priority selector")
        leaves: list[tuple[str, type[FleetRule], BehaviourParams]] = []
        for node in children[0].children:
            if not isinstance(node, PlanBehaviour):
                return FleetSupport(False, f"{node.name} is a sub-tree, not one behaviour")
            rule = type(node).fleet_rule
            if rule is None or type(node) not in rule.covers:
                return FleetSupport(False, f"{node.name} has no array form")
            leaves.append((node.name, rule, node.params))
        return FleetSupport(True, "", tuple(leaves))
    finally:
        for leaf in plan_leaves(root):
            for client in leaf.blackboards:
                client.unregister(clear=True)


_check_ids = iter(range(10**12))


@dataclass(frozen=True, slots=True)
class FleetTick:
    """What one fleet cycle produced, for the vehicles it ticked (in ``percept.ids`` order).

    Attributes:
        heading, speed: the command (NaN where there is none).
        has_command: the tree had an output.
        active: index of the leaf that drove (into ``FleetPlanner.names``), -1 for none.
        percept: the cycle's percepts.
    """

    heading: FloatArray
    speed: FloatArray
    has_command: BoolArray
    active: IntArray
    percept: FleetPercept


class FleetPlanner:
    """A tree of fleet rules under one memory-less priority selector, for N vehicles at once.

    Build one for a mission with :meth:`for_mission`; the constructor takes the leaves
    directly (the conformance checks of :mod:`cptbt.testing` put scripted leaves in).

    Args:
        leaves: ``(name, rule class, params)`` per behaviour, highest priority first.
        context: the mission context the rules read (OpArea, home, speed).
        perception: the mission's perception settings.
        n: the number of vehicles.
        field_reached: the planner key's value at start (False only with move-to-field).
    """

    def __init__(self, leaves: Sequence[tuple[str, type[FleetRule], BehaviourParams]],
                 context: MissionContext, perception: PerceptionSettings, n: int,
                 *, field_reached: bool = True) -> None:
        self.n = n
        self.context = context
        self.op_area = context.op_area
        self.perception = FleetPerception(n, self.op_area, perception)
        self.board = FleetBoard(n)
        self.board.array("field_reached", bool, field_reached)
        self.names = [name for name, _, _ in leaves]
        self.rules = [rule(params, context, self.board) for _, rule, params in leaves]
        self.selected = np.full(n, -1, dtype=np.int64)  # the leaf RUNNING on the last cycle

    @classmethod
    def for_mission(cls, mission: MissionBase, n: int, registry: Registry | None = None
                    ) -> FleetPlanner:
        """The fleet planner of ``mission`` for ``n`` vehicles.

        Raises:
            ValueError: a behaviour of the mission has no array form (see :func:`fleet_support`).
        """
        support = fleet_support(mission, registry)
        if not support.ok:
            raise ValueError(f"the fleet planner cannot run {mission.name}: {support.reason}")
        # each vehicle's move-to-field goal is its own (the fleet rule's), not the mission's
        context = replace(mission_context(mission), start=None)
        field = planner_keys(field_reached=field_reached_at_start(mission))["field_reached"]
        return cls(support.leaves, context, mission.perception, n, field_reached=field)

    def add_samples(self, ids: Index, concentration: FloatArray, t: float = math.nan) -> None:
        """One concentration sample per vehicle of ``ids`` at time ``t``."""
        self.perception.add_samples(ids, concentration, t)

    def add_flows(self, t: float, ids: Index, vx: FloatArray, vy: FloatArray) -> None:
        """One flow-over-ground sample per vehicle of ``ids``."""
        self.perception.add_flows(t, ids, vx, vy)

    def set_poses(self, ids: Index, x: FloatArray, y: FloatArray, heading: FloatArray) -> None:
        """The latest navigation estimates of the vehicles ``ids``."""
        self.perception.set_poses(ids, x, y, heading)

    def tick(self, t: float, ids: Index) -> FleetTick:
        """One planning cycle at time ``t`` for the vehicles ``ids``."""
        p = self.perception.cycle(t, ids)
        m = len(ids)
        heading = np.full(m, np.nan)
        speed = np.full(m, np.nan)
        active = np.full(m, -1, dtype=np.int64)
        before = self.selected[ids]
        pos = np.arange(m)
        sub = p
        for k, rule in enumerate(self.rules):
            if not len(pos):
                break
            running = before[pos] == k
            if np.count_nonzero(running) != len(running):
                rule.initialise(sub.ids[~running])
            h = rule.decide(sub, running)
            if any(c.family in WAIT_FOR_FIELD for c in rule.covers):
                # held until the field is reached, as PlanBehaviour.update holds the leaf
                h = np.where(self.board.array("field_reached", bool)[sub.ids], h, np.nan)
            ok = np.isfinite(h)
            if np.count_nonzero(running):
                stopped = running & ~ok
                if np.count_nonzero(stopped):
                    rule.terminate(sub.ids[stopped])
            if np.count_nonzero(ok):
                won = pos[ok]
                heading[won] = wrap_deg_array(h[ok])  # as Command wraps it
                speed[won] = rule.speed
                active[won] = k
                if rule.ends_move_to_field:
                    self.board.array("field_reached", bool)[sub.ids[ok]] = True
                # Lower behaviours that were RUNNING are pre-empted (terminate(INVALID)).
                pre = before[won] > k
                if np.count_nonzero(pre):
                    for j in np.flatnonzero(pre):
                        self.rules[before[won[j]]].terminate(ids[won[j]:won[j] + 1])
                pos = pos[~ok]
                sub = sub.take(~ok)
        self.selected[ids] = active
        return FleetTick(heading, speed, active >= 0, active, p)


__all__ = [
    "FleetBoard",
    "FleetPercept",
    "FleetPerception",
    "FleetPlanner",
    "FleetRule",
    "FleetSupport",
    "FleetTick",
    "fleet_support",
    "planner_choice",
]
