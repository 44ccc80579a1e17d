"""Plug-ins registered through entry points: a broken one names itself."""

from __future__ import annotations

from importlib.metadata import EntryPoint
from pathlib import Path

import pytest

import cptbt.registry as registry_module
from cptbt.registry import RegistryError, load_entry_points

PLUGIN = '''
from typing import ClassVar
from cptbt.node import PlanBehaviour

class NotABehaviour:
    family = "reacquire_plume"

class Clover(PlanBehaviour):
    family: ClassVar[str] = "reacquire_plume"
    variant: ClassVar[str] = "cloverleaf"

class Mine(PlanBehaviour):
    family: ClassVar[str] = "reacquire_plume"
    variant: ClassVar[str] = "mine"

BAD = (NotABehaviour,)
CLASH = (Clover,)
GOOD = (Mine,)
ALSO = (Mine,)
TWICE = (Mine, Mine)
'''


@pytest.fixture
def plugin(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> str:
    (tmp_path / "cptbt_test_registry_plugin.py").write_text(PLUGIN, encoding="utf-8")
    monkeypatch.syspath_prepend(str(tmp_path))
    return "cptbt_test_registry_plugin"


def _points(monkeypatch: pytest.MonkeyPatch, *points: tuple[str, str]) -> None:
    eps = [EntryPoint(name, value, "cptbt.behaviours") for name, value in points]
    monkeypatch.setattr(registry_module, "entry_points", lambda group: eps)


def test_an_item_that_is_no_behaviour_names_its_entry_point(
        plugin: str, monkeypatch: pytest.MonkeyPatch) -> None:
    """A review's BEHAVIOURS holding a plain class ended every command in "internal error:
    AttributeError ... has no attribute 'family'"."""
    _points(monkeypatch, ("bad", f"{plugin}:BAD"))
    with pytest.raises(RegistryError, match=rf"entry point {plugin}:BAD: .*NotABehaviour.* is "
                                            "neither a PlanBehaviour subclass nor a "
                                            "BehaviourSpec"):
        load_entry_points()


def test_a_name_taken_twice_names_both_entry_points(
        plugin: str, monkeypatch: pytest.MonkeyPatch) -> None:
    """A review's plug-in reusing 'cloverleaf' was told only "registered twice"."""
    # sorted by name: the built-in reacquire variants ("a") first, then the plug-in ("b")
    _points(monkeypatch, ("a", "cptbt.behaviours.reacquire:BEHAVIOURS"),
            ("b", f"{plugin}:CLASH"))
    told = (f"entry point {plugin}:CLASH registers reacquire_plume.cloverleaf, a built-in's "
            "name (cptbt's cptbt.behaviours.reacquire:BEHAVIOURS): give the plug-in's variant "
            "a name of its own")
    with pytest.raises(RegistryError) as exc:
        load_entry_points()
    assert str(exc.value) == told, str(exc.value)
    # the plug-in read first (a review's entry point sorted before the built-in's): the
    # plug-in is still the one named, not the built-in
    _points(monkeypatch, ("a", f"{plugin}:CLASH"),
            ("b", "cptbt.behaviours.reacquire:BEHAVIOURS"))
    with pytest.raises(RegistryError) as exc:
        load_entry_points()
    assert str(exc.value) == told, str(exc.value)
    # two plug-ins: both named
    _points(monkeypatch, ("a", f"{plugin}:GOOD"), ("b", f"{plugin}:ALSO"))
    with pytest.raises(RegistryError, match=rf"reacquire_plume.mine is registered by both entry "
                                            rf"point {plugin}:GOOD and {plugin}:ALSO: rename"):
        load_entry_points()
    _points(monkeypatch, ("a", f"{plugin}:TWICE"))  # one list naming it twice
    with pytest.raises(RegistryError, match=rf"^entry point {plugin}:TWICE registers "
                                            r"reacquire_plume.mine twice$"):
        load_entry_points()
    _points(monkeypatch, ("a", f"{plugin}:GOOD"))
    assert {s.variant for s in load_entry_points().specs()} == {"mine"}
