"""The base class of every plan behaviour, its parameter base model and its collaborators.

A plan behaviour is a py_trees leaf that maps the cycle's :class:`~cptbt.types.Percept` to a
:class:`~cptbt.types.Command` or to nothing. Having an output means RUNNING (and writing the
command); having none means FAILURE, so a memory-less priority selector over such leaves is the
subsumption network of TRO Fig. 2 (SPEC §3).
"""

from __future__ import annotations

import inspect
import math
import traceback
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, ClassVar, Protocol

import py_trees
from py_trees.common import Access, Status
from pydantic import BaseModel, ConfigDict, Field

from cptbt.frames import OpArea
from cptbt.types import Command, Percept, Point

if TYPE_CHECKING:
    from cptbt.fleet import FleetRule


@dataclass(frozen=True, slots=True)
class Contract:
    """What a behaviour variant needs from the rest of its mission, checked by ``validate``.

    Attributes:
        needs_flow: it steers by the flow estimate, so the mission's perception must have one.
        pairs_with: ``(family, variant)`` pairs: if the mission lists that family, it must use
            that variant (the two halves of an AB strategy share state).
        check: ``check(params, perception_settings)`` returns why the pair cannot work, or None.
        advise: ``advise(params, op_area)`` returns ``(parameter, why)`` for each setting that,
            valid, is likely not what the mission means (a warning at that parameter's line).
        min_cycle_hz: the planning rate its timings need (AB's strategies switch within
            fractions of a second: SPEC §2); a slower ``cycle_hz`` is warned of.
    """

    needs_flow: bool = True
    pairs_with: tuple[tuple[str, str], ...] = ()
    check: Callable[[BehaviourParams, Any], str | None] | None = None
    advise: Callable[[BehaviourParams, OpArea], list[tuple[str, str]]] | None = None
    min_cycle_hz: float | None = None


class BehaviourParams(BaseModel):
    """Base of every behaviour's parameter model: frozen, unknown keys rejected.

    Subclasses declare each parameter once, with its unit in the name (``lambda_s``, ``d_leaf_m``,
    ``beta_deg``); the model is at once the YAML schema, the documentation and the validation.
    """

    model_config = ConfigDict(frozen=True, extra="forbid", allow_inf_nan=False)
    contract: ClassVar[Contract | None] = None
    """Set on the mission schema's per-variant models from the registry spec."""

    speed_mps: float | None = Field(
        default=None, gt=0, le=20,
        description="Speed command while active, m/s (default: mission speed)",
    )


def planner_keys(field_reached: bool) -> dict[str, Any]:
    """The blackboard keys the planner owns, with their values at mission start.

    ``command`` is the active behaviour's output; ``field_reached`` lets find-plume drive (False
    only while move-to-field has work to do); ``declared_source``, ``go_home`` and
    ``mission_done`` carry the mission's end game; ``homeward`` says the AMP is on its way home
    (the declaration is done with the source, or home was asked for), so safety lets it leave
    the OpArea toward a home the mission places outside it.
    """
    return {"command": None, "field_reached": field_reached, "declared_source": None,
            "go_home": False, "homeward": False, "mission_done": False}


class PerceptSource(Protocol):
    """Where a behaviour reads the current cycle's percept."""

    @property
    def percept(self) -> Percept:
        """The percept of the current cycle."""
        ...


@dataclass(slots=True)
class MissionContext:
    """Collaborators a behaviour binds in ``setup()``: the percept and the mission's geometry.

    The planner owns one per vehicle and replaces ``percept`` every cycle before it ticks.
    ``threshold`` is the perception's detection threshold (for behaviours that read the
    concentration's level, not only the detection flag); None when unknown.
    """

    op_area: OpArea
    home: Point
    start: Point | None
    speed_mps: float
    percept: Percept | None = None
    threshold: float | None = None


WAIT_FOR_FIELD = frozenset({"find_plume"})
"""Families with no output until the vehicle has reached the field (``field_reached``): move-to-
field, below find-plume in priority, drives first (TRO III)."""


class PlanBehaviour(py_trees.behaviour.Behaviour):
    """A leaf of the arbitration tree: percept in, command or nothing out.

    Subclasses set ``family``, ``variant`` and ``Params`` and implement :meth:`decide`; those that
    keep state across ticks reset it in :meth:`initialise` (called on every new activation, in
    particular after pre-emption) — the lifecycle py_trees defines.

    Class attributes:
        family: the behaviour slot it fills (``find_plume``, ``maintain_plume``, ...).
        variant: its name within the family (``billiard``, ``track_in_out``, ...).
        Params: its frozen parameter model.
        ends_move_to_field: once this behaviour has had an output, move-to-field stops for good.
            A find-plume variant has no output until then (:data:`WAIT_FOR_FIELD`; the base
            class holds it, so a variant's ``decide`` need not know).
        persistent_state: (optional) attribute names kept on purpose across pre-emption (a
            reacquire pattern's progress, a sign that belongs to a detection); every other
            per-activation attribute must be reset in :meth:`initialise`, which
            :func:`cptbt.testing.check_behaviour` checks.
        contract: what it needs from the rest of the mission (checked by ``validate``).
        fleet_rule: its array form for the fleet planner (a :class:`cptbt.fleet.FleetRule`
            whose ``covers`` lists this class), or None: a mission using it then keeps one
            py_trees planner per vehicle.
    """

    family: ClassVar[str] = ""
    variant: ClassVar[str] = ""
    Params: ClassVar[type[BehaviourParams]] = BehaviourParams
    ends_move_to_field: ClassVar[bool] = True
    contract: ClassVar[Contract] = Contract()
    fleet_rule: ClassVar[type[FleetRule] | None] = None
    """Its array form for the fleet planner (:mod:`cptbt.fleet`), if it has one."""

    def __init__(
        self,
        params: BehaviourParams | None = None,
        *,
        name: str | None = None,
        namespace: str = "/",
    ) -> None:
        super().__init__(name or f"{self.family}.{self.variant}")
        self.params = params if params is not None else self.Params()
        self.namespace = namespace
        self.bb = self.attach_blackboard_client(name=self.name, namespace=namespace)
        self.bb.register_key("command", access=Access.WRITE)
        self.bb.register_key("field_reached", access=Access.WRITE)
        self.context: MissionContext | None = None
        self.last_command: Command | None = None
        # what a behaviour with several jobs is doing this cycle (set in decide(); the planner
        # appends it to the active behaviour's name, and the figures colour it apart)
        self.activity: str | None = None
        # requests to command() with a non-finite heading or speed (sent as no output; a
        # behaviour that falls silent so is a bug: check_behaviour fails on any)
        self.nonfinite_commands = 0

    def setup(self, **kwargs: Any) -> None:
        """Bind the collaborators: ``context`` (a :class:`MissionContext`) is required."""
        context = kwargs.get("context")
        if not isinstance(context, MissionContext):
            raise KeyError(f"{self.name}: setup() needs context=MissionContext(...)")
        self.context = context

    @property
    def speed(self) -> float:
        """This behaviour's speed command: its own override or the mission speed."""
        assert self.context is not None
        return self.params.speed_mps or self.context.speed_mps

    def command(self, heading_deg: float, speed_mps: float | None = None) -> Command | None:
        """Build a command, or None when the heading is not finite (never emit a bad command)."""
        speed = self.speed if speed_mps is None else speed_mps
        if not (math.isfinite(heading_deg) and math.isfinite(speed)):
            self.nonfinite_commands += 1  # check_behaviour fails on it: a bug, not "no output"
            return None
        return Command(heading_deg, speed)

    def decide(self, p: Percept) -> Command | None:
        """Return this cycle's command, or None when the behaviour has no output."""
        raise NotImplementedError

    def update(self) -> Status:
        """Tick: RUNNING with the command written to the blackboard, or FAILURE."""
        assert self.context is not None and self.context.percept is not None, "call setup()"
        self.activity = None
        if self.family in WAIT_FOR_FIELD and not self.bb.field_reached:
            # find-plume waits while move-to-field, below it, drives to the start point (TRO
            # III): held here for every variant (a review's plug-in, not told, drove at once)
            self.last_command = None
            return Status.FAILURE
        try:
            cmd = self.decide(self.context.percept)
        except Exception as exc:
            blamed(exc, self, self.context.percept.t)
            raise  # as raised, its own chain kept (a diff review: "from None" had cut it)
        if cmd is not None and not isinstance(cmd, Command):
            raise blamed(TypeError(f"decide() returned {type(cmd).__name__} {cmd!r:.60}: return "
                                   "a Command (self.command(heading_deg, speed_mps)) or None"),
                         self, self.context.percept.t, where=False)
        self.last_command = cmd
        if cmd is None:
            return Status.FAILURE
        self.bb.command = cmd
        if self.ends_move_to_field:
            self.bb.field_reached = True
        return Status.RUNNING

    def watch(self, p: Percept) -> None:
        """Perceptual work that must run every cycle, even while a higher behaviour drives.

        The default does nothing; the tree builder adds a watcher node for classes that override
        it (declare-source uses it to keep checking the lost-contact list).
        """


def blamed(exc: Exception, behaviour: PlanBehaviour, t: float, where: bool = True
           ) -> Exception:
    """``exc`` marked as raised by ``behaviour`` at mission time ``t`` (its type kept, so a test
    expecting it still catches it): :func:`blame` reads the mark, and the command line names the
    behaviour and the line instead of calling the error cptbt's own (a review's plug-in's
    AttributeError read "cptbt: internal error"). ``where``: a line of code says where (not
    for what cptbt found wrong with a returned value)."""
    if getattr(exc, "cptbt_behaviour", None) is None:
        exc.cptbt_where = where  # type: ignore[attr-defined]
        exc.cptbt_behaviour = behaviour.name  # type: ignore[attr-defined]
        exc.cptbt_t = t  # type: ignore[attr-defined]
        exc.cptbt_files = _source_files(type(behaviour))  # type: ignore[attr-defined]
        exc.add_note(f"raised in behaviour {behaviour.name} at t = {t:g} s")
    return exc


def _source_files(cls: type) -> frozenset[str]:
    """The files of a behaviour class and of the behaviour classes it derives from (not this
    module's): where a line of its code can be."""
    files = set()
    for c in cls.__mro__:
        if isinstance(c, type) and issubclass(c, PlanBehaviour) and c is not PlanBehaviour:
            try:
                f = inspect.getsourcefile(c)
            except TypeError:  # a class with no source file (built at run time)
                continue
            if f is not None and f != __file__:
                files.add(f)
    return frozenset(files)


def blame(exc: BaseException) -> str | None:
    """One line naming the behaviour that raised ``exc`` (:func:`blamed`), the mission time and
    the line of code: the innermost in the files of the behaviour's class and its bases (where
    its code called what raised), else the innermost of all; None for an error no behaviour
    raised. A plug-in's declaration rule, failing in its base class's ``decide`` on a missing
    setting, had been placed "at main.py:1110", inside pydantic (a review)."""
    name = getattr(exc, "cptbt_behaviour", None)
    if name is None:
        return None
    frames = traceback.extract_tb(exc.__traceback__) if exc.__traceback__ else []
    frames = [f for f in frames if f.filename != __file__]  # update() itself says nothing
    own = getattr(exc, "cptbt_files", ())
    mine = [f for f in frames if f.filename in own]
    chosen = (mine or frames) if getattr(exc, "cptbt_where", True) else []
    at = f" (at {Path(chosen[-1].filename).name}:{chosen[-1].lineno})" if chosen else ""
    text = " ".join(f"{type(exc).__name__}: {exc}".split())[:300]
    return f"behaviour {name} raised {text}{at} at t = {getattr(exc, 'cptbt_t', math.nan):g} s"


def active_name(tip: py_trees.behaviour.Behaviour | None) -> str | None:
    """The name a run records for the node that drove a cycle: its own, with what it was doing
    when it has several jobs (``declare_source.likelihood_map (check leg)``); None: none drove."""
    if tip is None:
        return None
    activity = getattr(tip, "activity", None)
    return f"{tip.name} ({activity})" if activity else tip.name


def overrides_watch(cls: type[PlanBehaviour]) -> bool:
    """Whether a behaviour class has perceptual work of its own to run every cycle."""
    return cls.watch is not PlanBehaviour.watch


class Watch(py_trees.behaviour.Behaviour):
    """Runs a behaviour's :meth:`PlanBehaviour.watch` every cycle; always SUCCESS."""

    def __init__(self, behaviour: PlanBehaviour) -> None:
        super().__init__(f"watch:{behaviour.name}")
        self.behaviour = behaviour

    def update(self) -> Status:
        """Run the watched behaviour's perception on the current percept."""
        context = self.behaviour.context
        assert context is not None and context.percept is not None, "call setup()"
        try:
            self.behaviour.watch(context.percept)
        except Exception as exc:
            blamed(exc, self.behaviour, context.percept.t)
            raise
        return Status.SUCCESS
