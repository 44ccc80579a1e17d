"""The fleet planner's differential conformance (issue 15): a behaviour's array form
(:class:`cptbt.fleet.FleetRule`) against its py_trees node, tick by tick. Also reached as
``cptbt.testing.check_fleet_rule`` and ``check_fleet_mission``."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import py_trees
from numpy.typing import NDArray

from cptbt.angles import unit
from cptbt.fleet import FleetPercept, FleetPlanner, FleetRule
from cptbt.frames import OpArea
from cptbt.mission import MissionBase
from cptbt.node import (
    BehaviourParams,
    PlanBehaviour,
)
from cptbt.perception import Perception, PerceptionSettings
from cptbt.registry import BehaviourSpec, Registry, default_registry
from cptbt.testing import (
    FakeVehicle,
    TreeHarness,
    fresh_namespace,
    make_context,
    same_value,
    square_area,
)
from cptbt.tree import plan_leaves
from cptbt.types import Command, Percept, Pose


def fleet_capable_specs(registry: Registry | None = None) -> list[BehaviourSpec]:
    """The registered behaviours that have an array form (:mod:`cptbt.fleet`)."""
    registry = registry or default_registry()
    out = []
    for spec in registry.specs():
        node = spec.build(spec.params(), fresh_namespace())
        try:
            rule = type(node).fleet_rule if isinstance(node, PlanBehaviour) else None
            if rule is not None and type(node) in rule.covers:
                out.append(spec)
        finally:
            for leaf in plan_leaves(node):
                for client in leaf.blackboards:
                    client.unregister(clear=True)
    return out


class _Preempt(PlanBehaviour):
    """A scripted higher-priority leaf: an output (heading 0) while ``on``."""

    family, variant = "test", "preempt"

    def __init__(self, params: BehaviourParams | None = None, **kwargs: str) -> None:
        super().__init__(params, **kwargs)
        self.on = False

    def decide(self, p: Percept) -> Command | None:
        """Heading 0 while switched on."""
        return self.command(0.0) if self.on else None


class _PreemptFleet(FleetRule):
    covers = (_Preempt,)

    def prepare(self) -> None:
        self.on = np.zeros(self.n, dtype=bool)

    def decide(self, p: FleetPercept, running: NDArray[np.bool_]) -> NDArray[np.float64]:
        return np.where(self.on[p.ids], 0.0, np.nan)


_Preempt.fleet_rule = _PreemptFleet


@dataclass
class _Scalar:
    """One vehicle's per-vehicle planner as the differential check drives it."""

    perception: Perception
    tick: Callable[[Percept], tuple[Command | None, str | None]]
    close: Callable[[], None]


def _differential(
    scalars: list[_Scalar],
    fleet: FleetPlanner,
    area: OpArea,
    *,
    ticks: int,
    seed: int,
    label: str,
    on_tick: Callable[[int, np.random.Generator], None] | None = None,
) -> dict[str, int]:
    """Drive both forms in closed loop through one seeded random script; assert they agree.

    Returns how many (vehicle, tick) pairs each leaf drove ('' for none), all compared.
    """
    rng = np.random.default_rng(seed)
    n = len(scalars)
    ids = np.arange(n)
    cx, cy = area.centre.x, area.centre.y
    w, h = area.xmax - area.xmin, area.ymax - area.ymin
    vehicles = [FakeVehicle(float(rng.uniform(area.xmin, area.xmax)),
                            float(rng.uniform(area.ymin, area.ymax)),
                            float(rng.uniform(-180, 180))) for _ in range(n)]
    flow_dir = float(rng.uniform(-180, 180))
    dt, sub = 0.1, 2
    drove: dict[str, int] = {}
    for k in range(ticks):
        t0 = k * dt
        if on_tick is not None:
            on_tick(k, rng)
        if rng.random() < 0.01:  # the current swings
            flow_dir += float(rng.normal(0.0, 60.0))
        for v in vehicles:
            v.current = (0.3 * math.cos(math.radians(flow_dir + 180.0)),
                         0.3 * math.sin(math.radians(flow_dir + 180.0))) \
                if rng.random() < 0.001 else v.current
        dropout = rng.random() < 0.05
        for s in range(1, sub + 1):
            t = t0 - dt + s * dt / sub if k else t0 + (s - sub) * dt / sub
            ux, uy = unit(flow_dir + float(rng.normal(0.0, 10.0)))
            speed = float(rng.uniform(0.2, 1.2))
            vx, vy = np.full(n, speed * ux), np.full(n, speed * uy)
            bad = rng.random(n) < 0.02
            vx[bad] = rng.choice([np.nan, 9.97e36, 6.0], size=int(bad.sum()))
            # Hits near the line through the centre along the flow, like a plume; NaN faults.
            xs = np.array([v.x for v in vehicles])
            ys = np.array([v.y for v in vehicles])
            across = np.abs(-(xs - cx) * uy + (ys - cy) * ux)
            conc = np.where(across < 0.2 * h, rng.choice([0.0, 0.5, 0.19, 0.21], size=n), 0.0)
            conc[rng.random(n) < 0.05] = np.nan
            for i, sc in enumerate(scalars):
                sc.perception.add_sample(t, float(conc[i]))
            fleet.add_samples(ids, conc, t)
            if not dropout:
                for i, sc in enumerate(scalars):
                    sc.perception.add_flow(t, float(vx[i]), float(vy[i]))
                fleet.add_flows(t, ids, vx, vy)
        px = np.array([v.x for v in vehicles]) + np.where(rng.random(n) < 0.02,
                                                          rng.normal(0.0, 0.1 * w, n), 0.0)
        py = np.array([v.y for v in vehicles])
        # a fix across the area, beyond the far wall (safety's walls then face each other)
        across = rng.random(n) < 0.005
        py[across] = np.where(py[across] < cy, area.ymax + 15.0, area.ymin - 15.0)
        heading = np.array([v.heading_deg for v in vehicles])
        py[rng.random(n) < 0.01] = np.nan  # a bad fix: the last one is kept
        for i, sc in enumerate(scalars):
            sc.perception.set_pose(Pose(float(px[i]), float(py[i]), float(heading[i])))
        fleet.set_poses(ids, px, py, heading)
        out = fleet.tick(t0, ids)
        fp = out.percept
        for i, sc in enumerate(scalars):
            p = sc.perception.cycle(t0)
            cmd, active = sc.tick(p)
            where = f"{label}: vehicle {i} tick {k} (t={t0:g})"
            flow = (math.nan, math.nan) if p.flow is None else (p.flow.vx, p.flow.vy)
            last = p.last_detection
            got_percept = (bool(fp.detected[i]), bool(fp.in_plume[i]), int(fp.contact_count[i]),
                           bool(fp.has_flow[i]), float(fp.vx[i]), float(fp.vy[i]),
                           float(fp.last_t[i]), float(fp.x[i]))
            want_percept = (p.detected, p.in_plume, p.contact_count, p.flow is not None, *flow,
                            math.nan if last is None else last.t, p.pose.x)
            assert all(same_value(a, b) for a, b in zip(got_percept, want_percept, strict=True)), (
                f"{where}: percept {got_percept} != {want_percept}")
            got_active = fleet.names[out.active[i]] if out.active[i] >= 0 else None
            assert got_active == active, f"{where}: fleet ran {got_active}, the tree {active}"
            if cmd is None:
                assert not out.has_command[i], f"{where}: the fleet commanded, the tree did not"
            else:
                got = (float(out.heading[i]), float(out.speed[i]))
                assert got == (cmd.heading_deg, cmd.speed_mps), f"{where}: {got} != {cmd}"
            drove[active or ""] = drove.get(active or "", 0) + 1
            vehicles[i].apply(cmd, dt)
            # Keep the fake vehicles in play, up to 20 m outside (safety's ground).
            v = vehicles[i]
            v.x = min(max(v.x, area.xmin - 20.0), area.xmax + 20.0)
            v.y = min(max(v.y, area.ymin - 20.0), area.ymax + 20.0)
    for i, sc in enumerate(scalars):
        want = sc.perception.latest.lost_contacts if sc.perception.latest else ()
        assert fleet.perception.lost_contacts(i) == want, f"{label}: vehicle {i} lost contacts"
        sc.close()
    return drove


def check_fleet_rule(
    spec: BehaviourSpec,
    params: BehaviourParams | None = None,
    *,
    vehicles: int = 16,
    ticks: int = 400,
    seed: int = 0,
    lambda_s: float = 1.0,
    flow_window_s: float = 0.3,
    home: tuple[float, float] = (5.0, 0.0),
    homeward_rate: float = 0.0,
) -> dict[str, int]:
    """A behaviour's array form against its py_trees leaf, tick by tick, on random percepts.

    Each of ``vehicles`` vehicles flies its own leaf in closed loop (a :class:`FakeVehicle`),
    under a scripted higher-priority leaf that pre-empts it at random (so ``initialise`` and
    kept state are exercised); the fleet form flies all of them at once through the same
    samples. Asserts, per vehicle and tick, the same percept, the same active leaf and the same
    command bit for bit. ``home`` is the mission's home (OpArea ``square_area(100)``); with
    ``homeward_rate`` > 0 the planner key ``homeward`` flips at that rate per vehicle and tick.

    Returns:
        How many (vehicle, tick) pairs each leaf drove ('' for none); every pair is compared.

    Raises:
        AssertionError: naming the vehicle, the tick and what differed.
    """
    params = params if params is not None else spec.params()
    area = square_area(100.0)
    context = make_context(area, home=home, start=(50.0, 10.0))
    settings = PerceptionSettings(lambda_s=lambda_s, flow_window_s=flow_window_s)
    scalars: list[_Scalar] = []
    preempts: list[_Preempt] = []
    harnesses: list[TreeHarness] = []
    for _ in range(vehicles):
        ns = fresh_namespace()
        leaf = spec.build(params, ns)
        pre = _Preempt(namespace=ns)
        root = py_trees.composites.Selector("subsumption", memory=False, children=[pre, leaf])
        ctx = make_context(area, home=home, start=(50.0, 10.0))
        harness = TreeHarness(root, ctx)
        preempts.append(pre)
        harnesses.append(harness)

        def tick(p: Percept, harness: TreeHarness = harness) -> tuple[Command | None, str | None]:
            tk = harness.tick(p)
            return tk.command, tk.active

        def close(root: py_trees.behaviour.Behaviour = root, harness: TreeHarness = harness
                  ) -> None:
            for node in plan_leaves(root):
                for client in node.blackboards:
                    client.unregister(clear=True)
            harness.bb.unregister(clear=True)

        scalars.append(_Scalar(Perception(area, settings), tick, close))
    leaf_probe = spec.build(params, fresh_namespace())
    assert isinstance(leaf_probe, PlanBehaviour) and leaf_probe.fleet_rule is not None, (
        f"{spec.key} has no array form")
    fleet = FleetPlanner([("test.preempt", _PreemptFleet, BehaviourParams()),
                          (leaf_probe.name, leaf_probe.fleet_rule, params)],
                         context, settings, vehicles)
    for client in leaf_probe.blackboards:
        client.unregister(clear=True)
    pre_rule = fleet.rules[0]
    assert isinstance(pre_rule, _PreemptFleet)

    homeward = fleet.board.array("homeward", bool, False)

    def on_tick(k: int, rng: np.random.Generator) -> None:
        flip = rng.random(vehicles) < 0.03
        for i in np.flatnonzero(flip):
            preempts[i].on = not preempts[i].on
            pre_rule.on[i] = preempts[i].on
        if homeward_rate > 0:
            for i in np.flatnonzero(rng.random(vehicles) < homeward_rate):
                homeward[i] = not homeward[i]
                harnesses[i].set("homeward", bool(homeward[i]))

    return _differential(scalars, fleet, area, ticks=ticks, seed=seed, label=spec.key,
                         on_tick=on_tick)


def check_fleet_mission(
    mission: MissionBase,
    *,
    vehicles: int = 16,
    ticks: int = 600,
    seed: int = 0,
    registry: Registry | None = None,
) -> dict[str, int]:
    """A whole mission's fleet planner against one :class:`~cptbt.planner.Planner` per vehicle.

    The same closed loop as :func:`check_fleet_rule`, with the mission's own tree, OpArea and
    perception: same percepts, active behaviour and commands on every tick.

    Returns:
        How many (vehicle, tick) pairs each leaf drove ('' for none); every pair is compared.
    """
    from cptbt.planner import Planner

    fleet = FleetPlanner.for_mission(mission, vehicles, registry)
    scalars = []
    for _ in range(vehicles):
        pl = Planner(mission, registry)

        def tick(p: Percept, pl: Planner = pl) -> tuple[Command | None, str | None]:
            cmd = pl.step(p)  # the planner's own tick, on the percept the check's perception made
            return cmd, pl.active

        scalars.append(_Scalar(pl.perception, tick, pl.close))
    return _differential(scalars, fleet, fleet.op_area, ticks=ticks, seed=seed,
                         label=mission.name)
