"""The planner facade: feed it samples and vehicle state, tick it, read the command.

One :class:`Planner` drives one vehicle. It owns the perception, the mission context its
behaviours are bound to, and a blackboard namespace of its own, so many planners can run side by
side in one process (Monte Carlo batches).
"""

from __future__ import annotations

import itertools
import math

import py_trees
from py_trees.common import Access, Status

from cptbt import ticking
from cptbt.mission import MissionBase
from cptbt.node import MissionContext, active_name, planner_keys
from cptbt.perception import Perception
from cptbt.registry import Registry, default_registry
from cptbt.tree import build_tree, plan_leaves
from cptbt.turns import guard_heading
from cptbt.types import Command, Percept, Point, Pose

_ids = itertools.count()

def mission_context(mission: MissionBase, start: Point | None = None) -> MissionContext:
    """The context a mission's behaviours fly with: its OpArea, home, start (``start``, or the
    mission's), cruise speed and detection threshold, in the planning frame."""
    return MissionContext(
        op_area=mission.op_area_geometry(),
        home=mission.to_xy(mission.home),
        start=start if start is not None else (
            mission.to_xy(mission.start) if mission.start is not None else None),
        speed_mps=mission.speed_mps,
        threshold=mission.perception.threshold,
    )


def field_reached_at_start(mission: MissionBase) -> bool:
    """Whether the field counts as reached before the first cycle: only without a
    move-to-field behaviour (with one, find-plume waits for it: TRO III)."""
    return not any(e.family == "move_to_field" for e in mission.entries())


class Planner:
    """The Adaptive Mission Planner for one vehicle.

    Args:
        mission: a validated mission.
        registry: where its behaviours are found (default: installed entry points).
        namespace: blackboard namespace (default: a fresh one).
        start: the move-to-field goal, planning frame (default: the mission's ``start``); a study
            gives each vehicle its own.
    """

    def __init__(
        self,
        mission: MissionBase,
        registry: Registry | None = None,
        *,
        namespace: str | None = None,
        start: Point | None = None,
    ) -> None:
        self.mission = mission
        self.registry = registry or default_registry()
        entries = mission.entries()
        self.context = mission_context(mission, start)
        self.op_area = self.context.op_area
        self.perception = Perception(self.op_area, mission.perception,
                                     nominal_period_s=1.0 / mission.cycle_hz)
        self.namespace = namespace or f"/cptbt/p{next(_ids)}"
        self.root = build_tree(entries, self.registry, self.namespace)
        self.leaves = plan_leaves(self.root)
        self.bb = py_trees.blackboard.Client(name="planner", namespace=self.namespace)
        for key, value in planner_keys(field_reached=field_reached_at_start(mission)).items():
            self.bb.register_key(key, access=Access.WRITE)
            self.bb.set(key, value)
        for node in self.root.iterate():
            node.setup(context=self.context)
        self._direct = ticking.supports(self.root)
        # The keys were declared above with their access; the hot path reads and writes the
        # storage directly, skipping the client's per-access bookkeeping.
        self._storage = py_trees.blackboard.Blackboard.storage
        self._key = {k: f"{self.namespace}/{k}" for k in ("command", "declared_source",
                                                         "mission_done")}
        self.command: Command | None = None
        self.active: str | None = None
        self.percept: Percept | None = None

    # -- inputs ---------------------------------------------------------------------------
    def add_sample(self, t: float, concentration: float) -> None:
        """One concentration sample (any rate; condensed per cycle)."""
        self.perception.add_sample(t, concentration)

    def add_flow(self, t: float, vx: float, vy: float) -> None:
        """One flow-over-ground sample, planning frame, m/s."""
        self.perception.add_flow(t, vx, vy)

    def set_pose(self, x: float, y: float, heading_deg: float = math.nan) -> None:
        """The latest navigation estimate (planning frame)."""
        self.perception.set_pose(Pose(x, y, heading_deg))

    def request_home(self) -> None:
        """Ask the return-home behaviour (if the mission has one) to take over."""
        self.bb.go_home = True
        self.bb.homeward = True

    # -- the cycle ------------------------------------------------------------------------
    def tick(self, t: float) -> Command | None:
        """Run one planning cycle at time ``t``; returns the command, or None (no output).

        Any ``t`` is accepted: a time stamp that is not finite, repeats or steps back is handled
        by the perception's monotonic clock (see :class:`~cptbt.perception.Perception`).
        """
        return self.step(self.perception.cycle(t))

    def step(self, percept: Percept) -> Command | None:
        """Run the tree once on ``percept`` (made by this planner's perception, or by a check
        that feeds several planners the same percepts); returns the command, or None."""
        self.percept = self.context.percept = percept
        storage = self._storage
        storage[self._key["command"]] = None
        if self._direct:
            ticking.tick(self.root)
        else:
            self.root.tick_once()
        cmd = storage[self._key["command"]] if self.root.status == Status.RUNNING else None
        radius = self.mission.turn_guard_radius_m
        if cmd is not None and radius is not None:
            pose = percept.pose
            heading = guard_heading(pose.x, pose.y, pose.heading_deg, cmd.heading_deg, radius,
                                    self.op_area)
            if heading != cmd.heading_deg:
                cmd = Command(heading, cmd.speed_mps)
        self.command = cmd
        tip = self.root.tip() if cmd is not None else None
        self.active = active_name(tip)
        return cmd

    def silence(self) -> str:
        """Why the latest cycle gave no command, as far as the planner can tell (for a
        give-back's detail)."""
        percept = self.percept
        if percept is not None and percept.flow is None:
            return "no flow estimate (no usable flow sample has arrived)"
        return f"no behaviour drove (the tree's status {self.root.status.value})"

    # -- outputs --------------------------------------------------------------------------
    @property
    def declared_source(self) -> Point | None:
        """The declared source (planning frame), once declared."""
        return self._storage[self._key["declared_source"]]

    @property
    def declared_sources(self) -> tuple[Point, ...]:
        """Every source declared so far (a multi-source declaration publishes them all)."""
        many = self.read("declared_sources")
        if isinstance(many, tuple) and many:
            return many
        one = self.declared_source
        return () if one is None else (one,)

    def read(self, key: str) -> object:
        """A behaviour-published blackboard key of this planner (None when unset).

        For reports after a run (``source_map``, ``declaration_report``); behaviours declare
        their own keys with their access.
        """
        return self._storage.get(f"{self.namespace}/{key}")

    @property
    def done(self) -> bool:
        """Declared and home: the AMP has finished its job."""
        return bool(self._storage[self._key["mission_done"]])

    def nonfinite_commands(self) -> dict[str, int]:
        """Each behaviour that asked ``command()`` for a non-finite heading or speed, and how
        often: no command was sent for those (the next behaviour down drove), a bug the run's
        summary names rather than letting another behaviour's work pass as its own."""
        return {leaf.name: leaf.nonfinite_commands for leaf in self.leaves
                if leaf.nonfinite_commands}

    def close(self) -> None:
        """Release this planner's blackboard keys (long batches create many planners)."""
        for leaf in self.leaves:
            for client in leaf.blackboards:
                client.unregister(clear=True)
        self.bb.unregister(clear=True)
