"""Shared fixtures: a small registry of scripted behaviours for tree tests."""

from __future__ import annotations

from typing import ClassVar

import pytest

from cptbt.node import BehaviourParams, PlanBehaviour
from cptbt.registry import BehaviourSpec, Registry
from cptbt.types import Command, Percept


class ScriptedParams(BehaviourParams):
    """Which ticks (by percept time) the fake has an output on, and the heading it commands."""

    active_at: tuple[float, ...] = ()
    heading_deg: float = 0.0


class Scripted(PlanBehaviour):
    """A fake behaviour: output at the scripted times; counts its activations."""

    family: ClassVar[str] = "scripted"
    variant: ClassVar[str] = "scripted"
    Params: ClassVar[type[BehaviourParams]] = ScriptedParams

    def __init__(self, params: BehaviourParams | None = None, **kw: str) -> None:
        super().__init__(params, **kw)
        self.activations = 0
        self.terminations: list[str] = []

    def initialise(self) -> None:
        self.activations += 1

    def terminate(self, new_status: object) -> None:
        self.terminations.append(str(new_status))

    def decide(self, p: Percept) -> Command | None:
        if p.t in self.params.active_at:
            return self.command(self.params.heading_deg)
        return None


def scripted_registry(*families: str) -> Registry:
    """A registry with one scripted variant under each of ``families``."""
    reg = Registry()
    for fam in families:
        cls = type(f"Scripted_{fam}", (Scripted,), {"family": fam, "variant": "scripted"})
        reg.register(BehaviourSpec.of(cls, default=True))
    return reg


@pytest.fixture
def tro_families() -> tuple[str, ...]:
    return ("safety", "declare_source", "maintain_plume", "reacquire_plume", "find_plume",
            "move_to_field")
