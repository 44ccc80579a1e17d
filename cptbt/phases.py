"""The mission phases: Mission A, the AMP override, the give-back and the resumed Mission A.

A ``transitions`` hierarchical state machine (SPEC §9; TRO II, Fig. 1; OMAE "AMP-REMUS
protocols" and "Field tests")::

    pre_launch → mission_a.waypoints → amp.override → amp.give_back → return_to_break_off
               → mission_a.resumed → post_mission

It holds no timers: every trigger is fired by :class:`cptbt.session.AmpSession` from the vehicle's
reported clock, so a simulated mission runs on simulated time. Nested names use ``.`` (the
library's default ``_`` would split snake_case names such as ``return_to_break_off``).

Reading chosen for a refused command (OMAE: "the vehicle may ignore the commands ... such as a
command to go to a depth greater than some preset vehicle maximum"): the refusal is recorded in the
timeline as an internal transition of ``amp.override`` (the AMP keeps control and the vehicle
keeps its last accepted command). A refused command is not an accepted one, so it does not feed
the vehicle's command watchdog: an AMP that only sends commands the vehicle refuses loses control
at the watchdog timeout (trigger ``watchdog_timeout``), exactly as a silent one does. The AMP
also fires ``watchdog_timeout`` itself when the vehicle's reported mode has not been
``override`` for ``watchdog_s``: a take it never granted (the take is sent again every 2 s
meanwhile), or an override it left without an ``ended`` message.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from transitions.extensions.nesting import HierarchicalMachine, NestedState

from cptbt.perception import MAX_CLOCK_JUMP_S


class _DotState(NestedState):
    separator = "."


class _Machine(HierarchicalMachine):
    state_cls = _DotState


STATES: list[Any] = [
    "pre_launch",
    {"name": "mission_a", "children": ["waypoints", "resumed"], "initial": "waypoints"},
    {"name": "amp", "children": ["override", "give_back"], "initial": "override"},
    "return_to_break_off",
    "post_mission",
]

_LIVE = [
    "pre_launch", "mission_a.waypoints", "mission_a.resumed", "amp.override", "amp.give_back",
    "return_to_break_off",
]

TRANSITIONS: list[dict[str, Any]] = [
    {"trigger": "launch", "source": "pre_launch", "dest": "mission_a",
     "doc": "the vehicle reports it is in its mission"},
    {"trigger": "amp_enable", "source": "mission_a.waypoints", "dest": "amp",
     "doc": "amp_enable_s after launch, or on reaching waypoint amp_enable_waypoint; "
            "the AMP sends an override request"},
    {"trigger": "declared_home", "source": "amp.override", "dest": "amp.give_back",
     "doc": "the planner has declared the source and reached home"},
    {"trigger": "amp_time_limit", "source": "amp.override", "dest": "amp.give_back",
     "doc": "time_limit_s since the take-over"},
    {"trigger": "outside_op_area", "source": "amp.override", "dest": "amp.give_back",
     "doc": "the vehicle is more than 30 m outside the OpArea"},
    {"trigger": "watchdog_timeout", "source": "amp.override", "dest": "amp.give_back",
     "doc": "the vehicle heard no accepted command for watchdog_s and left the override"},
    {"trigger": "amp_abort", "source": "amp.override", "dest": "amp.give_back",
     "doc": "the AMP computer stops driving (operator stop, link lost, internal error); "
            "it sends the release so the vehicle is never left with a stale command"},
    {"trigger": "command_refused", "source": "amp.override", "dest": None,
     "doc": "the vehicle ignored a command beyond its limits (recorded; AMP keeps control)"},
    {"trigger": "vehicle_returning", "source": "amp.give_back", "dest": "return_to_break_off",
     "doc": "the vehicle is transiting back to the break-off point"},
    {"trigger": "break_off_reached", "source": "return_to_break_off", "dest": "mission_a.resumed",
     "doc": "the vehicle is back at the break-off point and resumes Mission A"},
    {"trigger": "never_granted", "source": "amp.give_back", "dest": "mission_a.resumed",
     "doc": "the vehicle never granted the override: it stayed in Mission A, and has no "
            "break-off point to return to"},
    {"trigger": "mission_a_complete", "source": _LIVE, "dest": "post_mission",
     "doc": "the vehicle's own mission ended (last waypoint or its duration limit)"},
]

GIVE_BACK_TRIGGERS = (
    "declared_home", "amp_time_limit", "outside_op_area", "watchdog_timeout", "amp_abort",
)


@dataclass(frozen=True, slots=True)
class PhaseChange:
    """One entry of the phase timeline.

    Attributes:
        t_s: when the trigger fired, s, on the session's :class:`PhaseClock`.
        source: phase before.
        dest: phase after (equal to ``source`` for an internal transition).
        trigger: the trigger's name.
        detail: a note (e.g. why a command was refused).
    """

    t_s: float
    source: str
    dest: str
    trigger: str
    detail: str = ""

    def to_data(self) -> dict[str, Any]:
        """JSON-ready form."""
        return {"t": self.t_s, "from": self.source, "to": self.dest, "trigger": self.trigger,
                "detail": self.detail}


class _Model:
    state: str


class MissionPhases:
    """The phase machine of one mission run, with its timeline."""

    def __init__(self) -> None:
        self._model = _Model()
        self.machine = _Machine(
            model=self._model,
            states=STATES,
            transitions=[{k: v for k, v in t.items() if k != "doc"} for t in TRANSITIONS],
            initial="pre_launch",
            auto_transitions=False,
            ignore_invalid_triggers=False,
        )
        self.timeline: list[PhaseChange] = []

    @property
    def state(self) -> str:
        """The current phase, e.g. ``amp.override``."""
        return self._model.state

    def is_in(self, phase: str) -> bool:
        """Whether the current phase is ``phase`` or one of its children."""
        return self.state == phase or self.state.startswith(phase + ".")

    def fire(self, trigger: str, t_s: float, detail: str = "") -> None:
        """Fire ``trigger`` at vehicle time ``t_s`` and record it.

        Raises:
            transitions.MachineError: the trigger is not valid in the current phase.
        """
        source = self.state
        getattr(self._model, trigger)()
        self.timeline.append(PhaseChange(t_s, source, self.state, trigger, detail))

    def can_fire(self, trigger: str) -> bool:
        """Whether ``trigger`` is valid in the current phase."""
        return trigger in self.machine.get_triggers(self.state)


class PhaseClock:
    """The clock a phase timeline is stamped on: the vehicle's as it reads until the AMP takes
    over (:meth:`raw`), the planner's while the AMP drives (so the timeline and t0-t3 agree),
    and after the give-back the vehicle's with its steps back and its leaps beyond
    :data:`~cptbt.perception.MAX_CLOCK_JUMP_S` each continued from the previous report. A field
    review's clock stepped back 100 s had the timeline give back "declared and home" 58 s
    before ``t3``, a 2-h leap had made a 900-s override last 7 478 s, and an attacker's step
    after the give-back, when the planner no longer cycles, had run the timeline backwards."""

    def __init__(self) -> None:
        self.offset = 0.0  # the phase clock less the vehicle's
        self.prev = -math.inf  # the phase clock at the latest report

    def track(self, t: float, planner_t: float | None = None) -> None:
        """A vehicle report at ``t``; ``planner_t``: the planner's clock then, while it drives."""
        if planner_t is not None:
            self.offset = planner_t - t
        now = t + self.offset
        if math.isfinite(self.prev) and (now < self.prev or now - self.prev > MAX_CLOCK_JUMP_S):
            self.offset += self.prev - now
            now = self.prev
        self.prev = now

    def raw(self, t: float) -> None:
        """A vehicle report at ``t`` taken as it reads: before the AMP's take-over (t0 is on
        the vehicle's clock; a diff review's front seat restarting its clock at the launch had
        stood a corrected clock still through the whole override)."""
        self.offset, self.prev = 0.0, t if math.isfinite(t) else self.prev

    def stamp(self, t: float) -> float:
        """An event at vehicle time ``t`` on this clock (never before the latest report)."""
        return max(t + self.offset if math.isfinite(t) else self.prev, self.prev)

    @property
    def now(self) -> float:
        """The clock at the latest report (0 before any)."""
        return self.prev if math.isfinite(self.prev) else 0.0


def leaf_states() -> list[str]:
    """Every phase a run can be in, dotted names."""
    out: list[str] = []
    for s in STATES:
        if isinstance(s, str):
            out.append(s)
        else:
            out += [f"{s['name']}.{c}" for c in s["children"]]
    return out


def describe() -> str:
    """The machine as text: states (nested) and transitions with their triggers."""
    lines = ["states:"]
    for s in STATES:
        if isinstance(s, str):
            lines.append(f"  {s}")
        else:
            lines.append(f"  {s['name']} (enters {s['name']}.{s['initial']})")
            lines += [f"    {s['name']}.{c}" for c in s["children"]]
    lines.append("transitions:")
    initial = {s["name"]: f"{s['name']}.{s['initial']}" for s in STATES if isinstance(s, dict)}
    for t in TRANSITIONS:
        sources = t["source"] if isinstance(t["source"], list) else [t["source"]]
        dest = initial.get(t["dest"], t["dest"]) if t["dest"] else "(internal)"
        # named by what it leaves out: "any live phase" had read as excluding pre_launch
        rest = [x for x in leaf_states() if x not in sources]
        src = sources[0] if len(sources) == 1 else f"any phase but {', '.join(rest)}"
        lines.append(f"  {src} --{t['trigger']}--> {dest}")
        lines.append(f"      {t['doc']}")
    return "\n".join(lines)


def to_dot() -> str:
    """The machine as Graphviz dot text (no graphviz package needed to write it)."""
    lines = ["digraph mission_phases {", "  rankdir=LR;", "  node [shape=box, style=rounded];",
             "  compound=true;"]
    for s in STATES:
        if isinstance(s, str):
            lines.append(f'  "{s}";')
            continue
        lines.append(f'  subgraph "cluster_{s["name"]}" {{')
        lines.append(f'    label="{s["name"]}";')
        lines += [f'    "{s["name"]}.{c}" [label="{c}"];' for c in s["children"]]
        lines.append("  }")
    initial = {s["name"]: f"{s['name']}.{s['initial']}" for s in STATES if isinstance(s, dict)}
    for t in TRANSITIONS:
        sources = t["source"] if isinstance(t["source"], list) else [t["source"]]
        for src in sources:
            dest = t["dest"] or src
            dest = initial.get(dest, dest)
            lines.append(f'  "{src}" -> "{dest}" [label="{t["trigger"]}"];')
    lines.append("}")
    return "\n".join(lines) + "\n"
