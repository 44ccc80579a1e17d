"""Plug-ins registered through entry points: a broken one names itself."""

from __future__ import annotations

from importlib.metadata import EntryPoint
from pathlib import Path

import pytest

import cptbt.registry as registry_module
from cptbt.registry import load_entry_points

PLUGIN = '''
from typing import ClassVar
from pydantic import BaseModel, Field
from cptbt.behaviours.declare_source import SourceDeclaration
from cptbt.node import BehaviourParams, PlanBehaviour

class NotABehaviour:
    family = "reacquire_plume"

class Clover(PlanBehaviour):
    family: ClassVar[str] = "reacquire_plume"
    variant: ClassVar[str] = "cloverleaf"

class Mine(PlanBehaviour):
    family: ClassVar[str] = "reacquire_plume"
    variant: ClassVar[str] = "mine"

class Nameless(PlanBehaviour):
    pass

class PlainParams(BaseModel):
    step_m: float = 3.0

class Plain(PlanBehaviour):
    family: ClassVar[str] = "reacquire_plume"
    variant: ClassVar[str] = "plain"
    Params = PlainParams

class BadDefaultParams(BehaviourParams):
    step_m: float = Field(default=-5.0, gt=0)

class BadDefault(PlanBehaviour):
    family: ClassVar[str] = "reacquire_plume"
    variant: ClassVar[str] = "bad_default"
    Params = BadDefaultParams

class OwnParams(BehaviourParams):
    k: int = 3

class FirstLost(SourceDeclaration):
    variant: ClassVar[str] = "first_lost"
    Params = OwnParams

BAD = (NotABehaviour,)
OWNPARAMS = (FirstLost,)
NAMELESS = (Nameless,)
PLAIN = (Plain,)
BADDEFAULT = (BadDefault,)
SINGLE = Mine
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


def _left_out(said: str) -> set[str]:
    """Load the entry points: the one at fault is left out, named with ``said`` (a regex) in
    ``broken``; the variants that did load are returned."""
    import re

    registry = load_entry_points()
    assert len(registry.broken) == 1 and re.search(said, registry.broken[0]), registry.broken
    return {s.key for s in registry.specs()}


def test_an_item_that_is_no_behaviour_names_its_entry_point(
        plugin: str, monkeypatch: pytest.MonkeyPatch) -> None:
    """A review's BEHAVIOURS holding a plain class ended every command in "internal error:
    AttributeError ... has no attribute 'family'"; now the plug-in alone is left out."""
    _points(monkeypatch, ("bad", f"{plugin}:BAD"), ("good", f"{plugin}:GOOD"))
    assert _left_out(rf"entry point {plugin}:BAD: .*NotABehaviour.* is neither a PlanBehaviour "
                     "subclass nor a BehaviourSpec") == {"reacquire_plume.mine"}


def test_a_name_taken_twice_names_both_entry_points_and_blocks_only_the_second(
        plugin: str, monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture) -> None:
    """A review's plug-in reusing 'cloverleaf' was told only "registered twice"; then it
    stopped every command, the shipped missions' too: now it alone is left out, warned of."""
    builtin = "cptbt.behaviours.reacquire:BEHAVIOURS"
    told = (f"entry point {plugin}:CLASH registers reacquire_plume.cloverleaf, a built-in's "
            f"name (cptbt's {builtin}): give the plug-in's variant a name of its own")
    # the plug-in's entry point sorted before the built-in's or after it: the built-in loads,
    # and the plug-in is the one named
    for points in ((("a", builtin), ("b", f"{plugin}:CLASH")),
                   (("a", f"{plugin}:CLASH"), ("b", builtin))):
        _points(monkeypatch, *points)
        caplog.clear()
        registry = load_entry_points()
        assert registry.broken == [told]
        assert registry.get("reacquire_plume", "cloverleaf").behaviour_classes[0].__module__ \
            == "cptbt.behaviours.reacquire"
        assert told in caplog.text
    # two plug-ins: both named, and neither's flown (a diff review's mission flew whichever
    # entry point's name sorted first, validated "ok")
    _points(monkeypatch, ("a", f"{plugin}:GOOD"), ("b", f"{plugin}:ALSO"))
    assert _left_out(rf"reacquire_plume.mine is registered by both entry point {plugin}:GOOD "
                     rf"and {plugin}:ALSO: rename") == set()
    from cptbt.registry import UnknownBehaviourError

    with pytest.raises(UnknownBehaviourError, match=r"not loaded: behaviour reacquire_plume\.mine "
                                                    r"is registered by both"):
        load_entry_points().get("reacquire_plume", "mine")
    _points(monkeypatch, ("a", f"{plugin}:TWICE"))  # one list naming it twice
    assert _left_out(rf"^entry point {plugin}:TWICE registers reacquire_plume.mine twice$") \
        == set()
    _points(monkeypatch, ("a", f"{plugin}:GOOD"))
    assert {s.variant for s in load_entry_points().specs()} == {"mine"}


def test_a_mission_naming_a_left_out_variant_is_told_why(
        plugin: str, monkeypatch: pytest.MonkeyPatch) -> None:
    from cptbt.registry import UnknownBehaviourError

    _points(monkeypatch, ("a", f"{plugin}:SINGLE"))
    with pytest.raises(UnknownBehaviourError, match=r"not loaded: entry point .*:SINGLE: "
                                                     r"expected a tuple"):
        load_entry_points().get("reacquire_plume", "mine")


@pytest.mark.parametrize(("name", "said"), [
    ("NAMELESS", r"cptbt_test_registry_plugin.Nameless has no family or variant name: set its "
                 r"ClassVars family and variant$"),
    ("PLAIN", r"reacquire_plume.plain: its Params \('PlainParams'\) is not a "
              r"cptbt.node.BehaviourParams subclass"),
    ("BADDEFAULT", r"reacquire_plume.bad_default: the default of step_m \(-5.0\) breaks its own "
                   r"rule: Input should be greater than 0$"),
    # a review: validated, flew 468 s, then "no attribute 'source_radius_m'" at its declaration
    ("OWNPARAMS", r"declare_source.first_lost: its Params \('OwnParams'\) does not derive from "
                  r"cptbt.behaviours.declare_source.DeclareParams, the Params of "
                  r"cptbt.behaviours.declare_source.SourceDeclaration it subclasses"),
    ("SINGLE", r"expected a tuple or list of PlanBehaviour subclasses or BehaviourSpecs, got "
               r"'Mine' \(write \(Mine,\)\)$"),
])
def test_a_plug_in_authors_slips_are_named_at_registration(
        plugin: str, monkeypatch: pytest.MonkeyPatch, name: str, said: str) -> None:
    """A review: a nameless class was told as a 443-character repr, a plain pydantic Params
    registered and then blamed the mission's line 3, a default of -5 under gt=0 flew, and a
    class for a tuple read "'ABCMeta' object is not iterable"."""
    _points(monkeypatch, ("a", f"{plugin}:{name}"), ("b", "cptbt.behaviours.reacquire:BEHAVIOURS"))
    assert "reacquire_plume.cloverleaf" in _left_out(rf"^entry point {plugin}:{name}: {said}")


def test_a_fault_in_a_built_in_entry_point_is_raised(monkeypatch: pytest.MonkeyPatch) -> None:
    _points(monkeypatch, ("a", "cptbt.behaviours.reacquire:NO_SUCH_NAME"))
    with pytest.raises(AttributeError):
        load_entry_points()


def test_a_required_parameter_is_listed_as_required(
        plugin: str, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    from typing import ClassVar

    from pydantic import Field

    from cptbt import cli
    from cptbt.cli import inspect_cmds
    from cptbt.node import BehaviourParams, PlanBehaviour

    class NeedsStep(BehaviourParams):
        step_m: float = Field(gt=0, description="required, no default")

    class Needs(PlanBehaviour):
        family: ClassVar[str] = "reacquire_plume"
        variant: ClassVar[str] = "needs_step"
        Params = NeedsStep

    registry = load_entry_points()
    registry.register(Needs)
    monkeypatch.setattr(inspect_cmds, "default_registry", lambda: registry)
    assert cli.main(["behaviours"]) == 0
    assert "step_m (required)  required, no default" in capsys.readouterr().out
    assert cli.main(["behaviours", "--json"]) == 0
    import json

    (spec,) = [s for s in json.loads(capsys.readouterr().out) if s["variant"] == "needs_step"]
    assert {"name": "step_m", "description": "required, no default", "required": True} in \
        spec["params"]


def test_an_unknown_variant_with_no_close_name_says_how_a_plug_in_is_found() -> None:
    """A review: a colleague without the plug-in installed read only "unknown variant"."""
    from cptbt.registry import UnknownBehaviourError, default_registry

    with pytest.raises(UnknownBehaviourError, match=r"\(a plug-in's\? its package lists it in an "
                                                    r"entry point of the group "
                                                    r"'cptbt.behaviours' and is installed here"):
        default_registry().get("reacquire_plume", "square_spiral")
    with pytest.raises(UnknownBehaviourError) as close:  # a slip gets its suggestion alone
        default_registry().get("reacquire_plume", "cloverlef")
    assert "did you mean 'cloverleaf'?" in str(close.value) and "plug-in" not in str(close.value)


def test_a_params_field_with_an_alias_registers() -> None:
    """A diff review: the defaults were checked by field name, and an aliased field refused."""
    from typing import ClassVar

    from pydantic import Field

    from cptbt.node import BehaviourParams, PlanBehaviour
    from cptbt.registry import Registry

    class AliasedParams(BehaviourParams):
        leg_m: float = Field(10.0, gt=0, alias="leg_length_m")

    class Aliased(PlanBehaviour):
        family: ClassVar[str] = "find_plume"
        variant: ClassVar[str] = "aliased"
        Params = AliasedParams

    assert Registry().register(Aliased).variant == "aliased"


def test_a_plug_ins_variant_is_named_with_its_package(
        plugin: str, monkeypatch: pytest.MonkeyPatch) -> None:
    """A review: a study's folder did not say which plug-in flew its variant, and "install the
    plug-in it came from" could not name it. The built-in's are left out."""
    from cptbt.registry import plugin_provenance

    _points(monkeypatch, ("mine", f"{plugin}:GOOD"))
    registry = load_entry_points()
    got = plugin_provenance([("reacquire_plume", "mine"), ("reacquire_plume", "mine"),
                             ("reacquire_plume", "nowhere")], registry)
    assert got == {"reacquire_plume.mine": plugin}  # not installed: its package's name
    builtin = registry_module.default_registry()
    assert plugin_provenance([("reacquire_plume", "cloverleaf")], builtin) == {}


def test_a_broken_plug_in_blocks_only_its_own_variants(
        plugin: str, monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture) -> None:
    """A review: a package whose entry point failed to import stopped `cptbt validate` of
    every shipped mission. It is said, and its variants are the ones not available."""
    from cptbt.registry import UnknownBehaviourError

    _points(monkeypatch, ("broken", "not_a_module_xyz:BEHAVIOURS"),
            ("mine", f"{plugin}:GOOD"))
    with caplog.at_level("WARNING", logger="cptbt.registry"):
        registry = load_entry_points()
    assert "plug-in behaviours left out: entry point not_a_module_xyz:BEHAVIOURS" in caplog.text
    assert registry.get("reacquire_plume", "mine").variant == "mine"  # the others load
    with pytest.raises(UnknownBehaviourError,
                       match=r"\(not loaded: entry point not_a_module_xyz:BEHAVIOURS: "
                             r"ModuleNotFoundError"):
        registry.get("reacquire_plume", "its_variant")
