"""Every registered behaviour keeps the rules of ``cptbt.testing.check_behaviour``."""

from __future__ import annotations

import pytest

from cptbt.registry import FAMILIES, default_registry
from cptbt.testing import check_behaviour

SPECS = default_registry().specs()


@pytest.mark.parametrize("spec", SPECS, ids=[s.key for s in SPECS])
def test_registered_behaviour_conforms(spec) -> None:  # type: ignore[no-untyped-def]
    check_behaviour(spec)


def test_every_tro_family_has_exactly_one_default() -> None:
    reg = default_registry()
    for family in FAMILIES:
        defaults = [s.variant for s in reg.variants(family) if s.default]
        assert len(defaults) == 1, (family, defaults)


def test_registry_holds_every_variant_of_the_papers() -> None:
    keys = {s.key for s in SPECS}
    expected = {
        "safety.oparea",
        "move_to_field.go_to",
        "return_home.go_to",
        "find_plume.billiard",
        "find_plume.billiard_ab",
        "maintain_plume.track_in_out",
        "maintain_plume.counter_turn",
        "maintain_plume.strategy_1",
        "maintain_plume.strategy_2",
        "maintain_plume.strategy_3",
        "reacquire_plume.cloverleaf",
        "reacquire_plume.three_point",
        "reacquire_plume.strategy_1",
        "reacquire_plume.strategy_2",
        "reacquire_plume.strategy_3",
        "maintain_plume.constant_beta",
        "reacquire_plume.constant_beta",
        "declare_source.upflow_cluster",
        "declare_source.recent_box",
        "declare_source.upflow_spread",
    }
    assert expected <= keys, sorted(expected - keys)


def test_a_behaviour_class_can_be_checked_as_it_is() -> None:
    """A review passed its own class (as the README then said: check_behaviour(spec)) and met
    AttributeError: 'ZigZag' has no attribute 'params'."""
    from cptbt.behaviours.maintain_plume import TrackOut

    check_behaviour(TrackOut)


def test_the_readmes_tick_by_tick_example_runs_as_written() -> None:
    """The README's example is what a behaviour author copies first: it must run, and with a
    blackboard of its own (a review's copies shared the global one between tests)."""
    from pathlib import Path

    text = (Path(__file__).resolve().parents[2] / "README.md").read_text(encoding="utf-8")
    block = text.split("**Test a behaviour node alone**", 1)[1].split("```python\n", 1)[1]
    code = block.split("```", 1)[0]
    assert "fresh_namespace()" in code
    exec(compile(code, "README.md", "exec"), {})


def test_the_check_fails_a_behaviour_that_falls_silent_on_a_nan_heading() -> None:
    """A review's variant asked command() for NaN after 600 s: the helper sent nothing, lower
    behaviours drove, and check_behaviour passed it."""
    import math
    from typing import ClassVar

    from cptbt.node import PlanBehaviour
    from cptbt.types import Command, Percept

    class NanLater(PlanBehaviour):
        family: ClassVar[str] = "find_plume"
        variant: ClassVar[str] = "nan_later"

        def decide(self, p: Percept) -> Command | None:
            return self.command(math.nan if p.t >= 100.0 else 30.0)

    with pytest.raises(AssertionError, match="asked command\\(\\) for a non-finite heading"):
        check_behaviour(NanLater)


def test_the_check_flies_a_behaviour_without_a_flow_estimate() -> None:
    """The scripted perception always had a flow, so a variant that reads p.flow unguarded
    passed the check and failed on a vehicle whose flow sensor never worked."""
    from typing import ClassVar

    from cptbt.node import PlanBehaviour
    from cptbt.types import Command, Percept

    class NeedsFlow(PlanBehaviour):
        family: ClassVar[str] = "find_plume"
        variant: ClassVar[str] = "needs_flow"

        def decide(self, p: Percept) -> Command | None:
            return self.command(p.flow.upflow_deg)  # type: ignore[union-attr]

    with pytest.raises(AssertionError, match=r"needs_flow \(no flow estimate\) tick 0 .*: "
                       "raised AttributeError"):
        check_behaviour(NeedsFlow)


def test_the_check_flies_a_behaviour_before_the_first_navigation_fix() -> None:
    """A review: safety and move-to-field asked command() for NaN headings until the first fix,
    and the check, whose pose was always known, passed them. A variant that heads for the start
    unguarded fails in that run; the same guarded by ``p.pose.located`` passes."""
    from typing import ClassVar

    from cptbt.node import PlanBehaviour
    from cptbt.types import Command, Percept

    class HeadStart(PlanBehaviour):
        family: ClassVar[str] = "move_to_field"
        variant: ClassVar[str] = "head_start"

        def decide(self, p: Percept) -> Command | None:
            assert self.context is not None and self.context.start is not None
            if self.bb.field_reached:
                return None
            if p.pose.point.distance_to(self.context.start) < 3.0:
                self.bb.field_reached = True
                return None
            return self.command(p.pose.point.bearing_to(self.context.start))

    class GuardedHeadStart(HeadStart):
        variant: ClassVar[str] = "guarded_head_start"

        def decide(self, p: Percept) -> Command | None:
            return super().decide(p) if p.pose.located else None

    with pytest.raises(AssertionError, match=r"head_start \(before the first navigation fix\) "
                       r"tick 0 .*non-finite heading"):
        check_behaviour(HeadStart)
    check_behaviour(GuardedHeadStart)


def test_the_check_fails_a_behaviour_that_keeps_state_on_its_class() -> None:
    """State kept on the class is shared by every instance: in a batch worker one run's
    history leaks into the next run's decisions. A review's variant appended its detections to
    a class-level list, and passed the check."""
    from typing import ClassVar

    from cptbt.node import PlanBehaviour
    from cptbt.types import Command, Percept

    class SharedHistory(PlanBehaviour):
        family: ClassVar[str] = "find_plume"
        variant: ClassVar[str] = "shared_history"
        seen: ClassVar[list[float]] = []

        def decide(self, p: Percept) -> Command | None:
            if p.detected:
                self.seen.append(p.t)
            return self.command(0.0)

    with pytest.raises(AssertionError, match=r"class data .*SharedHistory\.seen changed"):
        check_behaviour(SharedHistory)

    class SetsOnClass(PlanBehaviour):
        family: ClassVar[str] = "find_plume"
        variant: ClassVar[str] = "sets_on_class"

        def decide(self, p: Percept) -> Command | None:
            type(self).last_t = p.t  # type: ignore[attr-defined]
            return self.command(0.0)

    with pytest.raises(AssertionError, match=r"set class attributes .*SetsOnClass\.last_t"):
        check_behaviour(SetsOnClass)


def test_the_class_data_message_names_the_tick_and_gives_its_advice_first() -> None:
    """The check looks after every tick, so it names the first tick that changed the class;
    the advice comes before the values, which are shortened (a review's message printed a
    20 000-character list first, the advice after it, and no tick though the README says
    every message names one)."""
    from typing import ClassVar

    from cptbt.node import PlanBehaviour
    from cptbt.types import Command, Percept

    class LongHistory(PlanBehaviour):  # a family of its own: no slot's rule of when it drives
        family: ClassVar[str] = "survey"
        variant: ClassVar[str] = "long_history"
        seen: ClassVar[list[float]] = [0.0] * 5000

        def decide(self, p: Percept) -> Command | None:
            if p.t >= 3.0:  # from tick 6 (2 Hz)
                self.seen.append(p.t)
            return self.command(0.0)

    with pytest.raises(AssertionError) as err:
        check_behaviour(LongHistory)
    text = str(err.value).splitlines()[0]
    assert text.startswith("survey.long_history tick 6 (t=3.0): a leaf changed its "
                           "class's "
                           "data: class-level state is shared by every instance"), text
    assert ("LongHistory.seen changed (was 5000 items, [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, ...], "
            "now 5001 items, [0.0, " in text), text
    assert len(text) < 600, len(text)  # not the 5 000-item list


def test_the_check_fails_a_behaviour_that_writes_undeclared_blackboard_keys() -> None:
    """A key written through Blackboard.storage bypasses the declared-keys contract."""
    from typing import ClassVar

    import py_trees

    from cptbt.node import PlanBehaviour
    from cptbt.types import Command, Percept

    class Sneaky(PlanBehaviour):
        family: ClassVar[str] = "find_plume"
        variant: ClassVar[str] = "sneaky"

        def decide(self, p: Percept) -> Command | None:
            py_trees.blackboard.Blackboard.storage[f"{self.namespace.rstrip('/')}/hint"] = p.t
            return self.command(0.0)

    with pytest.raises(AssertionError, match=r"no client declared for writing \(/test\d+/hint\)"):
        check_behaviour(Sneaky)


def test_a_find_plume_variant_waits_for_the_field_without_knowing_it() -> None:
    """A review's plug-in lawnmower ignored ``field_reached`` (told only in go_to.py's
    docstring) and drove at once, so move-to-field never flew to the start: the base class
    holds every find-plume variant until the field is reached."""
    from typing import ClassVar

    from cptbt.node import PlanBehaviour
    from cptbt.testing import ScriptedPerception, TreeHarness, fresh_namespace, square_area
    from cptbt.types import Command, Percept

    class Lawnmower(PlanBehaviour):
        family: ClassVar[str] = "find_plume"
        variant: ClassVar[str] = "lawnmower_test"

        def decide(self, p: Percept) -> Command | None:
            return self.command(90.0)

    harness = TreeHarness(Lawnmower(namespace=fresh_namespace()), field_reached=False)
    script = ScriptedPerception(square_area(100.0), flow=(0.1, 0.0))
    before = harness.tick(script.step(0.0, 10.0, 0.0, 0.0, 0.0))
    assert before.command is None and before.active is None
    harness.set("field_reached", True)
    after = harness.tick(script.step(1.0, 10.0, 0.0, 0.0, 0.0))
    assert after.command is not None and after.command.heading_deg == 90.0


def test_a_scripts_context_is_on_the_scripts_oparea() -> None:
    """A review's script on a 200-m square and node on the default 100-m context steered
    differently, and nothing said so: the script gives the context that matches it."""
    from cptbt.testing import ScriptedPerception, square_area

    script = ScriptedPerception(square_area(200.0), threshold=0.3)
    context = script.context(home=(5.0, 0.0))
    assert context.op_area == square_area(200.0) != square_area()
    assert context.threshold == 0.3 and context.home.x == 5.0


def test_state_not_reset_names_only_what_differs_shortened() -> None:
    """The reset rule had no test, and its message printed every attribute (a review's, 645
    characters for a 10-point tuple): it names the attributes that differ, shortened."""
    from typing import ClassVar

    from cptbt.node import PlanBehaviour
    from cptbt.types import Command, Percept

    class Forgets(PlanBehaviour):
        family: ClassVar[str] = "survey"
        variant: ClassVar[str] = "forgets"

        def initialise(self) -> None:
            self.steady = 1.0
            if not hasattr(self, "trail"):  # set once, never reset: the bug
                self.trail: tuple[float, ...] = ()

        def decide(self, p: Percept) -> Command | None:
            self.trail = (*self.trail, p.t)[-10:]
            return self.command(0.0)

    with pytest.raises(AssertionError) as err:
        check_behaviour(Forgets)
    text = str(err.value)
    assert text.startswith("survey.forgets: state not reset after pre-emption (reset "
                           "it in initialise(), or name it in persistent_state if it is kept "
                           "on purpose): trail 10 items, (")
    assert "after a run, () fresh" in text and "steady" not in text, text
    assert len(text) < 300, text


def test_the_check_holds_each_slot_to_its_turn() -> None:
    """README: a reacquire variant has output only once contact is lost, a maintain variant
    only while in the plume. A review's reacquire drove in the plume too and passed."""
    from typing import ClassVar

    from cptbt.node import PlanBehaviour
    from cptbt.types import Command, Percept

    class Always(PlanBehaviour):
        family: ClassVar[str] = "reacquire_plume"
        variant: ClassVar[str] = "always"

        def decide(self, p: Percept) -> Command | None:
            return self.command(0.0)

    with pytest.raises(AssertionError, match=r"reacquire_plume\.always tick \d+ .*: a "
                       r"reacquire variant has output while in the plume \(p\.in_plume\)"):
        check_behaviour(Always)

    class Lingers(PlanBehaviour):
        family: ClassVar[str] = "maintain_plume"
        variant: ClassVar[str] = "lingers"

        def decide(self, p: Percept) -> Command | None:
            return None if p.last_detection is None else self.command(0.0)

    with pytest.raises(AssertionError, match="a maintain variant has output out of the plume"):
        check_behaviour(Lingers)


def test_the_check_asks_for_frozen_settings() -> None:
    """README: a variant's Params is frozen (its settings read-only, as the mission gave
    them); a review's unfrozen one passed."""
    from typing import ClassVar

    from pydantic import ConfigDict

    from cptbt.node import BehaviourParams, PlanBehaviour
    from cptbt.types import Command, Percept

    class Loose(BehaviourParams):
        model_config = ConfigDict(**{**BehaviourParams.model_config, "frozen": False})

    class Plain(PlanBehaviour):
        family: ClassVar[str] = "survey"
        variant: ClassVar[str] = "plain"
        Params: ClassVar[type[BehaviourParams]] = Loose

        def decide(self, p: Percept) -> Command | None:
            return self.command(0.0)

    with pytest.raises(AssertionError, match=r"survey\.plain: its Params \(Loose\) is not "
                       "frozen"):
        check_behaviour(Plain)
    Plain.Params = BehaviourParams
    check_behaviour(Plain)  # frozen: passes
