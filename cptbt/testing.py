"""Test doubles for behaviour authors: scripted perception, a fake vehicle, and conformance.

Test your own variant tick by tick in three lines::

    script = ScriptedPerception(op_area=square_area(100), flow=(1.0, 0.0))
    node = MyFindPlume(namespace=fresh_namespace())
    ticks = run_script(node, [script.step(t, x=10, y=5) for t in range(5)])
    assert [tk.command.heading_deg for tk in ticks] == [...]

(``fresh_namespace()`` gives the node a blackboard of its own: with the default ``/`` every
node shares py_trees' global one, and a key one test leaves reaches the next), and check it
against the rules every behaviour must keep with :func:`check_behaviour`.
"""

from __future__ import annotations

import copy
import math
import reprlib
from collections.abc import Callable, Iterable
from dataclasses import dataclass

import numpy as np
import py_trees
from py_trees.common import Access, Status

from cptbt.angles import unit
from cptbt.frames import OpArea
from cptbt.mission import MissionBase
from cptbt.node import (
    BehaviourParams,
    MissionContext,
    PlanBehaviour,
    Watch,
    active_name,
    overrides_watch,
    planner_keys,
)
from cptbt.perception import Perception, PerceptionSettings
from cptbt.planner import field_reached_at_start, mission_context
from cptbt.registry import (
    BehaviourSpec,
    Registry,
    RegistryError,
    check_params,
    default_registry,
)
from cptbt.tree import build_tree, plan_leaves
from cptbt.types import Command, Percept, Point, Pose

_namespaces = iter(range(10**12))

_SHORT = reprlib.Repr()  # a value in a message: a class's 20 000-character list had buried it
_SHORT.maxstring = _SHORT.maxother = 80
_SHORT.maxlist = _SHORT.maxtuple = _SHORT.maxdict = _SHORT.maxset = 6


def square_area(side_m: float = 100.0) -> OpArea:
    """An OpArea ``[0, side] × [-side/2, side/2]`` (AB's 100 × 100 m area by default)."""
    return OpArea(0.0, side_m, -side_m / 2, side_m / 2)


def make_context(
    op_area: OpArea | None = None,
    home: tuple[float, float] = (0.0, 0.0),
    start: tuple[float, float] | None = None,
    speed_mps: float = 1.0,
    threshold: float | None = None,
) -> MissionContext:
    """A mission context for a behaviour tested alone, with these settings (a whole mission's
    own context: :meth:`TreeHarness.from_mission`, or :func:`cptbt.planner.mission_context`)."""
    return MissionContext(
        op_area=op_area or square_area(),
        home=Point(*home),
        start=Point(*start) if start else None,
        speed_mps=speed_mps,
        threshold=threshold,
    )


class ScriptedPerception:
    """Builds percepts from a script of poses and concentrations, through the real perception.

    Each :meth:`step` is one planning cycle: the pose, the concentration (one sample) and
    optionally a flow sample. Because the real :class:`~cptbt.perception.Perception` condenses
    them, last detection, contact count and lost-contact list are consistent with the script.
    A script repeats readings exactly (``conc=1.0`` cycle after cycle), which only a frozen
    sensor does, so the stuck-sensor check is off unless ``stuck_after_s`` is given.
    ``flow=None``: no flow sample at all (a vehicle without a working flow sensor: the percept's
    flow is None).
    """

    def __init__(
        self,
        op_area: OpArea | None = None,
        flow: tuple[float, float] | None = (1.0, 0.0),
        threshold: float = 0.2,
        lambda_s: float = 8.5,
        flow_window_s: float = 100.0,
        stuck_after_s: float | None = None,
    ) -> None:
        settings = PerceptionSettings(
            threshold=threshold, lambda_s=lambda_s, flow_window_s=flow_window_s,
            stuck_after_s=stuck_after_s,
        )
        self.perception = Perception(op_area or square_area(), settings)
        self.flow = flow

    def context(self, home: tuple[float, float] = (0.0, 0.0),
                start: tuple[float, float] | None = None, speed_mps: float = 1.0,
                threshold: float | None = None) -> MissionContext:
        """A mission context on this script's OpArea (:func:`make_context`): the node under
        test must see the OpArea its percepts were made in (a review's script on a 200-m
        square and a node on the default 100-m one steered differently, and nothing said so)."""
        return make_context(self.perception.op_area, home, start, speed_mps,
                            threshold if threshold is not None
                            else self.perception.settings.threshold)

    def step(
        self,
        t: float,
        x: float,
        y: float,
        heading_deg: float = 0.0,
        conc: float = 0.0,
        flow: tuple[float, float] | None = None,
    ) -> Percept:
        """One cycle at time ``t``: returns its percept."""
        sample = flow if flow is not None else self.flow
        if sample is not None:
            self.perception.add_flow(t, *sample)
        self.perception.add_sample(t, conc)
        self.perception.set_pose(Pose(x, y, heading_deg))
        return self.perception.cycle(t)

    def lost_contacts(self, points: Iterable[tuple[float, float]], at: tuple[float, float],
                      t0: float = 0.0) -> list[Percept]:
        """Contacts made and lost: per point, a detection at it, then a cycle at ``at`` in
        clean water ``lambda_s`` + 1 s later (the point joins ``p.lost_contacts``)."""
        lam = self.perception.settings.lambda_s
        percepts: list[Percept] = []
        t = t0
        for x, y in points:
            percepts.append(self.step(t, x, y, conc=1.0))
            percepts.append(self.step(t + lam + 1.0, *at))
            t += lam + 2.0
        return percepts


@dataclass(frozen=True)
class Tick:
    """What one tick produced."""

    t: float
    status: Status
    command: Command | None
    active: str | None


class TreeHarness:
    """Ticks one behaviour or a whole tree against scripted percepts.

    It owns a blackboard namespace of its own and the keys the planner provides, so nodes run
    exactly as they do in the planner.
    """

    def __init__(
        self,
        root: py_trees.behaviour.Behaviour,
        context: MissionContext | None = None,
        *,
        field_reached: bool = True,
    ) -> None:
        self.root = root
        self.context = context or make_context()
        self.watchers = [
            Watch(n)
            for n in root.iterate()
            if isinstance(n, PlanBehaviour)
            and overrides_watch(type(n))
            and not any(isinstance(w, Watch) and w.behaviour is n for w in root.iterate())
        ]
        self.bb = py_trees.blackboard.Client(name="harness")
        for key, value in planner_keys(field_reached).items():
            self.bb.register_key(f"{_namespace(root)}/{key}", access=Access.WRITE)
            self.set(key, value)
        for node in root.iterate():
            node.setup(context=self.context)

    @classmethod
    def from_mission(cls, mission: MissionBase, registry: Registry | None = None, *,
                     start: Point | None = None) -> TreeHarness:
        """The mission's whole tree, in a fresh namespace, with the context and keys the
        planner gives it (:func:`~cptbt.planner.mission_context`): what ``cptbt run`` flies
        (a review's, built with :func:`make_context`, had flown find-plume first)."""
        root = build_tree(mission.entries(), registry or default_registry(), fresh_namespace())
        return cls(root, mission_context(mission, start),
                   field_reached=field_reached_at_start(mission))

    def set(self, key: str, value: object) -> None:
        """Write a planner-owned blackboard key (``field_reached``, ``go_home``, ...)."""
        self.bb.set(f"{_namespace(self.root)}/{key}", value)

    def get(self, key: str) -> object:
        """Read any key of the tree's namespace (None when unset)."""
        name = f"{_namespace(self.root)}/{key}"
        return py_trees.blackboard.Blackboard.storage.get(name)

    def tick(self, p: Percept) -> Tick:
        """One cycle with percept ``p``."""
        self.context.percept = p
        for w in self.watchers:
            w.tick_once()
        self.set("command", None)
        self.root.tick_once()
        running = self.root.status == Status.RUNNING
        cmd = self.get("command") if running else None
        tip = self.root.tip() if running else None
        return Tick(p.t, self.root.status, cmd, active_name(tip))  # type: ignore[arg-type]

    def run(self, percepts: Iterable[Percept]) -> list[Tick]:
        """Tick through a script; one :class:`Tick` per percept."""
        return [self.tick(p) for p in percepts]


def _namespace(root: py_trees.behaviour.Behaviour) -> str:
    for node in root.iterate():
        if isinstance(node, PlanBehaviour):
            return node.namespace.rstrip("/")
    return ""


def fresh_namespace() -> str:
    """A blackboard namespace no other test uses."""
    return f"/test{next(_namespaces)}"


def run_script(
    node: py_trees.behaviour.Behaviour,
    percepts: Iterable[Percept],
    context: MissionContext | None = None,
    *,
    field_reached: bool = True,
) -> list[Tick]:
    """Tick one node (or tree) through scripted percepts; see :class:`TreeHarness`."""
    return TreeHarness(node, context, field_reached=field_reached).run(percepts)


class FakeVehicle:
    """A point vehicle that turns instantly and moves at the commanded speed plus a current."""

    def __init__(
        self,
        x: float,
        y: float,
        heading_deg: float = 0.0,
        current: tuple[float, float] = (0.0, 0.0),
    ) -> None:
        self.x, self.y, self.heading_deg = x, y, heading_deg
        self.current = current

    def apply(self, cmd: Command | None, dt: float) -> None:
        """Move for ``dt`` seconds under ``cmd`` (None holds the heading)."""
        speed = 0.0
        if cmd is not None:
            self.heading_deg, speed = cmd.heading_deg, cmd.speed_mps
        ux, uy = unit(self.heading_deg)
        self.x += (speed * ux + self.current[0]) * dt
        self.y += (speed * uy + self.current[1]) * dt


def _state(node: PlanBehaviour, base: set[str]) -> dict[str, object]:
    keep = set(getattr(node, "persistent_state", ()))
    return {k: v for k, v in vars(node).items() if k not in base and k not in keep}


_BASE_ATTRS: set[str] | None = None


def _base_attrs() -> set[str]:
    global _BASE_ATTRS
    if _BASE_ATTRS is None:

        class _Probe(PlanBehaviour):
            family, variant = "probe", "probe"

        _BASE_ATTRS = set(vars(_Probe(namespace=fresh_namespace())))
        _BASE_ATTRS.add("context")
    return _BASE_ATTRS


def check_behaviour(
    spec: BehaviourSpec | type[PlanBehaviour],
    params: BehaviourParams | None = None,
    *,
    ticks: int = 400,
    seed: int = 0,
    max_speed_mps: float = 2.8,
) -> None:
    """Conformance check every registered behaviour must pass.

    Drives the behaviour's node in closed loop with a :class:`FakeVehicle` through a seeded random
    script (plume hits, sensor NaNs, navigation jumps, a reversing flow), and asserts that:

    - every status is RUNNING, SUCCESS or FAILURE (never INVALID after a tick);
    - a RUNNING node wrote a command with a finite heading in (-180, 180] and a speed in
      (0, ``max_speed_mps``]; a FAILURE wrote none;
    - no leaf asked :meth:`~cptbt.node.PlanBehaviour.command` for a non-finite heading or
      speed (it sends none, so the behaviour fell silent and lower ones drove: a bug to fix,
      not a way to say "no output", which is returning None);
    - the same holds for a shorter run with no flow estimate at all (a vehicle whose flow
      sensor never worked), and for one whose first ticks have no navigation fix (the pose is
      NaN until the first: a behaviour that needs a position returns None then);
    - after pre-emption (``stop(INVALID)``) and re-activation (``initialise``), every leaf's
      per-activation state equals that of a freshly built leaf; attributes a class lists in
      ``persistent_state`` (kept on purpose across activations) are exempt;
    - no leaf changed its class's data (a list appended to, an attribute set on the class),
      looked for after every tick: such state is shared by every instance, so one run leaks
      into the next run of a worker;
    - its ``Params`` derives from its bases' (as loading checks), and is frozen (the
      settings are read-only, as the mission gave them);
    - a reacquire-plume variant has output only while out of the plume, a maintain-plume
      variant only while in it (``p.in_plume``): the slots' turns (SPEC §3);
    - every blackboard key the node wrote under its namespace was declared (registered by
      some client for writing): a write through ``Blackboard.storage`` bypasses the
      declared-keys contract that isolates nodes.

    ``spec`` is a registered variant's spec, or a single-leaf behaviour class (taken as
    ``BehaviourSpec.of(cls)``: a review passed the class, as a user testing a variant of
    their own would).

    Raises:
        AssertionError: naming the rule broken and, for the rules checked in the closed loop,
            the tick (state reset and blackboard keys are checked after it).
    """
    if isinstance(spec, type):
        spec = BehaviourSpec.of(spec)
    try:  # what registration refuses
        check_params(spec)
    except RegistryError as exc:
        raise AssertionError(str(exc)) from None
    assert spec.params.model_config.get("frozen"), (
        f"{spec.key}: its Params ({spec.params.__name__}) is not frozen: a behaviour's "
        "settings are read-only, as the mission gave them (model_config frozen=True, as "
        "BehaviourParams has)")
    rng = np.random.default_rng(seed)
    params = params if params is not None else spec.params()
    area = square_area(100.0)
    context = make_context(area, home=(5.0, 0.0), start=(50.0, 10.0))
    ns = fresh_namespace()
    node = spec.build(params, ns)
    classes = _class_data(node)
    harness = TreeHarness(node, context, field_reached=False)
    _closed_loop(spec.key, harness, node, ScriptedPerception(area, flow=(1.0, 0.0),
                                                             lambda_s=1.0),
                 ticks, rng, max_speed_mps, area, classes)
    blind = spec.build(params, fresh_namespace())
    _closed_loop(f"{spec.key} (no flow estimate)",
                 TreeHarness(blind, make_context(area, home=(5.0, 0.0), start=(50.0, 10.0)),
                             field_reached=True),
                 blind, ScriptedPerception(area, flow=None, lambda_s=1.0), max(ticks // 5, 1),
                 rng, max_speed_mps, area, classes)
    # before the first navigation fix the pose is NaN: a behaviour that needs a position has
    # no output then (a review: safety and move-to-field asked command() for NaN headings)
    early = spec.build(params, fresh_namespace())
    _closed_loop(f"{spec.key} (before the first navigation fix)",
                 TreeHarness(early, make_context(area, home=(5.0, 0.0), start=(50.0, 10.0)),
                             field_reached=False),
                 early, ScriptedPerception(area, flow=(1.0, 0.0), lambda_s=1.0),
                 max(ticks // 10, 20), rng, max_speed_mps, area, classes, unlocated=10)
    board = py_trees.blackboard.Blackboard
    storage, metadata = board.storage, board.metadata
    undeclared = sorted(k for k in storage if k.startswith(f"{ns}/")
                        and (k not in metadata or not metadata[k].write))
    assert not undeclared, (f"{spec.key}: wrote blackboard keys no client declared for writing "
                            f"({', '.join(undeclared)}): register them in __init__ "
                            "(self.bb.register_key(key, access=Access.WRITE)) and write them "
                            "through self.bb, not Blackboard.storage")
    node.stop(Status.INVALID)
    base = _base_attrs()
    fresh = spec.build(params, fresh_namespace())
    TreeHarness(fresh, make_context(area))
    for old, new in zip(plan_leaves(node), plan_leaves(fresh), strict=True):
        old.initialise()
        new.initialise()
        got, want = _state(old, base), _state(new, base)
        differ = sorted(k for k in got.keys() | want.keys()
                        if k not in got or k not in want or not same_value(got[k], want[k]))
        # the attributes that differ, shortened (a review's message printed every attribute,
        # 645 characters for a 10-point tuple)
        assert not differ, (
            f"{spec.key}: state not reset after pre-emption (reset it in initialise(), or name "
            "it in persistent_state if it is kept on purpose): "
            + "; ".join(f"{k} {_shown(got.get(k, '(not set)'))} after a run, "
                        f"{_shown(want.get(k, '(not set)'))} fresh" for k in differ)
        )


_WHEN: dict[str, tuple[Callable[[Percept], bool], str]] = {
    "reacquire_plume": (lambda p: not p.in_plume,
                        "a reacquire variant has output while in the plume (p.in_plume): "
                        "maintain-plume's time; have output only once contact is lost"),
    "maintain_plume": (lambda p: p.in_plume,
                       "a maintain variant has output out of the plume (not p.in_plume): "
                       "reacquire's time; have output only while p.in_plume"),
}
"""When a TRO slot's variant may have output (SPEC §3): the families whose turn the
perception's contact state decides."""


def _closed_loop(key: str, harness: TreeHarness, node: py_trees.behaviour.Behaviour,
                 script: ScriptedPerception, ticks: int, rng: np.random.Generator,
                 max_speed_mps: float, area: OpArea,
                 classes: dict[tuple[str, str], object], unlocated: int = 0) -> None:
    """:func:`check_behaviour`'s closed loop: ``ticks`` ticks at 2 Hz of a seeded random
    script, each status and command checked, every leaf's requests to ``command``, and the
    leaves' class data against ``classes`` (taken before the node ran). The first
    ``unlocated`` ticks have no navigation fix."""
    vehicle = FakeVehicle(60.0, 0.0, 180.0)
    dt = 0.5
    for i in range(ticks):
        t = i * dt
        if i == ticks // 3:
            harness.set("field_reached", True)
        if i == ticks // 2 and script.flow is not None:
            script.flow = (-0.5, 0.3)
        conc = float(rng.choice([0.0, 0.5, math.nan], p=[0.6, 0.3, 0.1]))
        if abs(vehicle.y) > 15:  # hits only near the axis, like a plume
            conc = 0.0
        jump = rng.normal(0.0, 10.0, 2) if rng.random() < 0.02 else (0.0, 0.0)
        x, y = ((math.nan, math.nan) if i < unlocated
                else (vehicle.x + jump[0], vehicle.y + jump[1]))
        p = script.step(t, x, y, vehicle.heading_deg, conc)
        where = f"{key} tick {i} (t={t})"
        try:
            tk = harness.tick(p)
        except Exception as exc:  # named with its tick (a raw error named none: a review)
            raise AssertionError(f"{where}: raised {type(exc).__name__}: {exc}") from exc
        assert tk.status in (Status.RUNNING, Status.SUCCESS, Status.FAILURE), f"{where}: {tk}"
        if tk.status == Status.RUNNING:
            cmd = tk.command
            assert cmd is not None, f"{where}: RUNNING without a command"
            # the slot's rule of when it has output (README; a review's reacquire variant
            # drove in the plume and passed)
            rule = _WHEN.get(key.split(".")[0])
            if rule is not None:
                allowed, why = rule
                assert allowed(p), f"{where}: {why}"
            assert math.isfinite(cmd.heading_deg) and -180 < cmd.heading_deg <= 180, where
            assert 0 < cmd.speed_mps <= max_speed_mps, f"{where}: speed {cmd.speed_mps}"
        else:
            assert tk.command is None, f"{where}: {tk.status} with a command"
        for leaf in plan_leaves(node):
            bad = leaf.nonfinite_commands
            assert bad == 0, (f"{where}: {leaf.name} asked command() for a non-finite heading "
                              "or speed, which sends none: the behaviour fell silent (return "
                              "None for no output)")
        changed = _class_change(node, classes)
        assert changed is None, f"{where}: {changed}"
        vehicle.apply(tk.command, dt)
        if not area.contains(vehicle.x, vehicle.y):  # keep the fake vehicle in play
            vehicle.x = min(max(vehicle.x, area.xmin + 1), area.xmax - 1)
            vehicle.y = min(max(vehicle.y, area.ymin + 1), area.ymax - 1)


def _shown(value: object) -> str:
    """A value for a message, shortened (with its length: two long lists can look alike)."""
    text = _SHORT.repr(value)
    if isinstance(value, (list, tuple, dict, set, frozenset, np.ndarray)) and "..." in text:
        return f"{len(value)} items, {text}"
    return text


_UNCHECKED = object()  # class data that cannot be copied: its change is not looked for


def _class_items(node: py_trees.behaviour.Behaviour) -> dict[tuple[str, str], object]:
    """The data attributes (not methods, properties or nested classes) of every plan leaf's
    classes below :class:`~cptbt.node.PlanBehaviour`, keyed by (class, name); not copied."""
    out: dict[tuple[str, str], object] = {}
    for leaf in plan_leaves(node):
        for cls in type(leaf).__mro__:
            if cls is PlanBehaviour or not issubclass(cls, PlanBehaviour):
                continue
            for name, value in vars(cls).items():
                if name.startswith("__") or callable(value) or isinstance(
                        value, (property, staticmethod, classmethod, type)) or hasattr(
                        value, "__get__"):
                    continue
                out[cls.__qualname__, name] = value
    return out


def _class_data(node: py_trees.behaviour.Behaviour) -> dict[tuple[str, str], object]:
    """A deep copy of :func:`_class_items` (``_UNCHECKED`` for what cannot be copied)."""
    out: dict[tuple[str, str], object] = {}
    for key, value in _class_items(node).items():
        try:
            out[key] = copy.deepcopy(value)
        except Exception:  # an attribute that cannot be copied: unchecked
            out[key] = _UNCHECKED
    return out


def _class_change(node: py_trees.behaviour.Behaviour,
                  before: dict[tuple[str, str], object]) -> str | None:
    """What of the leaves' class data differs from ``before`` (a :func:`_class_data`), advice
    first and values shortened; None if nothing does. Cheap enough for every tick: the data
    is compared, not copied."""
    now = _class_items(node)
    advice = ("a leaf changed its class's data: class-level state is shared by every instance "
              "(one run leaks into the next run of a batch worker); keep per-run state on self")
    for (cls, name), value in before.items():
        if (cls, name) not in now:
            return f"{advice}: class data {cls}.{name} deleted (was {_shown(value)})"
        if value is not _UNCHECKED and not _same_data(now[cls, name], value):
            return (f"{advice}: class data {cls}.{name} changed (was {_shown(value)}, now "
                    f"{_shown(now[cls, name])})")
    added = sorted(f"{c}.{n}" for c, n in now.keys() - before.keys())
    if added:
        return f"{advice}: the node set class attributes {', '.join(added)}"
    return None


def _same_data(a: object, b: object) -> bool:
    """Equal, for class data of any kind (an array compares element by element)."""
    try:
        return bool(same_value(a, b))
    except (TypeError, ValueError):  # an array's == is an array
        return bool(np.array_equal(np.asarray(a), np.asarray(b), equal_nan=True))


def same_value(a: object, b: object) -> bool:
    """Equal, NaN equal to NaN (a state or percept field compared between two planners)."""
    if isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b):
        return True
    return a == b


def __getattr__(name: str) -> object:
    """The fleet conformance checks, kept in :mod:`cptbt.fleet_testing` (loaded on first use:
    it builds on the doubles here)."""
    if name in ("check_fleet_rule", "check_fleet_mission", "fleet_capable_specs"):
        from cptbt import fleet_testing

        return getattr(fleet_testing, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
