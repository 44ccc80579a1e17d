"""A behaviour's faults are named as its own: an error it raises, a value that is no command,
commands it asked for and could not send, speeds the vehicle cannot fly (a plug-in author's
review: each had read "internal error", or passed silently as results)."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import ClassVar

import pytest

import cptbt.registry as registry_module
from cptbt import cli
from cptbt.batch.comparison import command_fault_table
from cptbt.node import PlanBehaviour, blame
from cptbt.registry import load_entry_points
from cptbt.testing import check_behaviour
from cptbt.types import Command, Percept

ROOT = Path(__file__).resolve().parents[2]


class Raises(PlanBehaviour):
    family: ClassVar[str] = "find_plume"
    variant: ClassVar[str] = "test_raises"

    def decide(self, p: Percept) -> Command | None:
        return self.context.op_area.no_such_helper()  # type: ignore[union-attr,attr-defined]


class RaisesLater(PlanBehaviour):
    family: ClassVar[str] = "find_plume"
    variant: ClassVar[str] = "test_raises_later"

    def decide(self, p: Percept) -> Command | None:
        if p.t >= 60.0:
            raise RuntimeError("a plug-in's bug, a minute in")
        return self.command(p.pose.heading_deg)


class Tuple(PlanBehaviour):
    family: ClassVar[str] = "find_plume"
    variant: ClassVar[str] = "test_tuple"

    def decide(self, p: Percept) -> Command | None:
        return (90.0, 1.5)  # type: ignore[return-value]


class NaN(PlanBehaviour):
    family: ClassVar[str] = "find_plume"
    variant: ClassVar[str] = "test_nan"

    def decide(self, p: Percept) -> Command | None:
        return self.command(math.nan)


class Slow(PlanBehaviour):
    family: ClassVar[str] = "find_plume"
    variant: ClassVar[str] = "test_slow"

    def decide(self, p: Percept) -> Command | None:
        return self.command(p.pose.heading_deg, 0.1)  # the simulated REMUS flies 0.25 at least


@pytest.fixture
def faulty(monkeypatch: pytest.MonkeyPatch) -> None:
    """The installed behaviours and the four faulty ones, as the default registry."""
    registry = load_entry_points()
    for cls in (Raises, RaisesLater, Tuple, NaN, Slow):
        registry.register(cls)
    monkeypatch.setattr(registry_module, "_DEFAULT", registry)


def mission(tmp_path: Path, variant: str) -> str:
    """oblique_flow with find-plume replaced by ``variant``, for 120 s."""
    text = (ROOT / "missions" / "oblique_flow.yaml").read_text(encoding="utf-8")
    lines, skip = [], False
    for line in text.splitlines():  # the find-plume entry, its parameters dropped
        if line.startswith("  - find_plume:"):
            lines.append(f"  - find_plume: {{variant: {variant}}}")
            skip = True
        elif not (skip and line.startswith("      ")):
            lines.append(line)
            skip = False
    lines = ["time_limit_s: 120" if line.startswith("time_limit_s:") else line
             for line in lines]
    assert any(variant in line for line in lines)
    path = tmp_path / f"{variant}.yaml"
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return str(path)


def test_an_error_a_behaviour_raises_names_it_and_its_line(
        faulty: None, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "run"
    assert cli.main(["run", mission(tmp_path, "test_raises"), "--out", str(out)]) == 1
    err = capsys.readouterr().err.strip()
    line = Raises.decide.__code__.co_firstlineno + 1
    assert err.startswith("cptbt: behaviour find_plume.test_raises raised AttributeError: "), err
    assert f"(at {Path(__file__).name}:{line}) at t = " in err, err
    assert "internal error" not in err and len(err.splitlines()) == 1
    # the vehicle's own mission until the AMP's first tick raised: written, not an empty folder
    assert any(out.glob("trace.*")) and not (out / "summary.json").exists()


def test_a_run_that_stops_on_an_error_writes_what_it_flew(
        faulty: None, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """A plug-in author's review: a behaviour raised at t = 319 s and the run wrote nothing
    (no trace, no figure) to see what it had done until then."""
    out = tmp_path / "run"
    assert cli.main(["run", mission(tmp_path, "test_raises_later"), "--out", str(out)]) == 1
    said = capsys.readouterr()
    assert "behaviour find_plume.test_raises_later raised RuntimeError" in said.err
    assert "the run to its last whole cycle (t = 59 s) before the error" in said.out
    assert (out / "trajectory.png").exists() and not (out / "summary.json").exists()
    trace = next(out.glob("trace.*"))
    if trace.suffix == ".parquet":
        import pyarrow.parquet as pq

        t = pq.read_table(trace).column("t").to_pylist()
    else:
        t = [float(line.split(",")[0]) for line in trace.read_text().splitlines()[1:]]
    assert 50.0 <= max(t) < 60.0 + 1e-9


def test_a_phased_run_that_stops_on_an_error_is_drawn_as_a_phased_run(
        faulty: None, tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
        capsys: pytest.CaptureFixture[str]) -> None:
    """A diff review: the partial figure of a run with Mission A drew the vehicle at the AMP's
    start at the launch point, and no Mission A plan."""
    from cptbt.cli import run_cmd

    drawn: list[tuple[object, dict[str, object]]] = []
    monkeypatch.setattr(run_cmd, "trajectory_figure",
                        lambda path, run, mission, source, title, **kw: drawn.append((run, kw)))
    text = (ROOT / "missions" / "tro2006_msn007.yaml").read_text(encoding="utf-8")
    text = text.replace("  - find_plume: {variant: billiard, dtheta_up_deg: 125, "
                        "dtheta_down_deg: 60}", "  - find_plume: {variant: test_raises_later}")
    assert "test_raises_later" in text
    path = tmp_path / "m.yaml"
    path.write_text(text, encoding="utf-8")
    (tmp_path / "out").mkdir()
    (tmp_path / "out" / "summary.json").write_text("{}")  # an earlier run's, not this one's
    assert cli.main(["run", str(path), "--out", str(tmp_path / "out")]) == 1
    assert "raised RuntimeError" in capsys.readouterr().err
    ((run, kw),) = drawn
    assert kw["waypoints"]  # Mission A's plan
    launch = run.trace["x"][0], run.trace["y"][0]  # type: ignore[attr-defined]
    assert run.start != launch  # type: ignore[attr-defined]  # where the AMP took over
    assert not (tmp_path / "out" / "summary.json").exists()


def test_a_value_that_is_no_command_is_named_at_its_tick(faulty: None, tmp_path: Path,
                                                         capsys: pytest.CaptureFixture[str]
                                                         ) -> None:
    with pytest.raises(AssertionError, match=r"tick \d+ .*decide\(\) returned tuple"):
        check_behaviour(Tuple)  # it had crashed inside check_behaviour, with no tick named
    assert cli.main(["run", mission(tmp_path, "test_tuple"), "--no-figure",
                     "--out", str(tmp_path / "out")]) == 1  # not into the checkout's runs/
    err = capsys.readouterr().err
    assert "behaviour find_plume.test_tuple raised TypeError: decide() returned tuple" in err


def test_the_error_keeps_its_type_and_says_where() -> None:
    """Code that catches the behaviour's own error type still does."""
    with pytest.raises(AssertionError) as info:
        check_behaviour(Raises)
    cause = info.value.__cause__
    assert isinstance(cause, AttributeError)
    said = blame(cause)
    assert said is not None and said.startswith("behaviour find_plume.test_raises raised ")


def test_commands_not_flown_as_asked_are_counted_and_named(
        faulty: None, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    for variant, said in (("test_nan", "find_plume.test_nan asked command() for a non-finite "
                                       "heading or speed in "),
                          ("test_slow", "find_plume.test_slow commanded 0.1 m/s in ")):
        out = tmp_path / variant
        assert cli.main(["run", mission(tmp_path, variant), "--no-figure", "--out",
                         str(out)]) == 0
        shown = capsys.readouterr().out
        assert f"  behaviour faults: {said}" in shown, shown
        summary = json.loads((out / "summary.json").read_text(encoding="utf-8"))
        key = "nonfinite_commands" if variant == "test_nan" else "unflyable_commands"
        assert summary[key] > 0 and said in summary["command_faults"]


def test_the_figure_says_a_behaviour_was_not_flown_as_asked(
        faulty: None, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A review: a plug-in that only asked for NaN headings was named in the figure as the
    variant flown, nothing saying it never drove."""
    from cptbt.cli import run_cmd

    titles: list[str] = []
    monkeypatch.setattr(run_cmd, "trajectory_figure",
                        lambda path, run, mission, source, title, **kw: titles.append(title))
    for variant in ("test_nan", "test_slow"):
        assert cli.main(["run", mission(tmp_path, variant), "--quiet", "--out",
                         str(tmp_path / variant)]) == 0
    assert "\nbehaviour faults: find_plume.test_nan not flown as asked in " in titles[0]
    assert "\nbehaviour faults: find_plume.test_slow not flown as asked in " in titles[1]


def test_a_study_tables_its_behaviour_faults() -> None:
    rows = [{"outcome": "declared", "nonfinite_commands": 0, "unflyable_commands": 0}]
    assert command_fault_table({"a": rows}) == []  # nothing to say: nothing said
    rows.append({"outcome": "timeout", "nonfinite_commands": 3, "unflyable_commands": 0})
    rows.append({"outcome": "error"})  # flew nothing
    lines = command_fault_table({"a": rows})
    assert "## Behaviour faults" in lines and "| a | 1 of 2 | 3 | 0 |" in lines


def test_a_behaviours_error_keeps_its_own_cause() -> None:
    """A diff review: marking the error had cut its chain (``from None``), even in the
    CPTBT_DEBUG traceback."""

    class Chained(PlanBehaviour):
        family: ClassVar[str] = "find_plume"
        variant: ClassVar[str] = "test_chained"

        def decide(self, p: Percept) -> Command | None:
            try:
                {}["calibration"]
            except KeyError as err:
                raise ValueError("no calibration table") from err
            return None

    with pytest.raises(AssertionError) as info:
        check_behaviour(Chained)
    cause = info.value.__cause__
    assert isinstance(cause, ValueError) and isinstance(cause.__cause__, KeyError)
    assert (blame(cause) or "").startswith("behaviour find_plume.test_chained raised ValueError")


def test_a_study_names_the_plug_in_that_flew_its_variant(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
        capsys: pytest.CaptureFixture[str]) -> None:
    """A review: a study's folder did not say which plug-in flew its variant, and flown again
    where the plug-in is not installed, "install the plug-in it came from" could not name it."""
    registry = load_entry_points()
    registry.register(Slow)
    monkeypatch.setattr(registry_module, "_DEFAULT", registry)
    out = tmp_path / "study"
    assert cli.main(["batch", mission(tmp_path, "test_slow"), "--runs-per-start", "1",
                     "--workers", "1", "--no-plots", "--quiet", "--out", str(out)]) == 0
    package = Slow.__module__.split(".")[0]
    record = json.loads((out / "study.json").read_text(encoding="utf-8"))
    assert record["plugins"] == {"find_plume.test_slow": package}
    monkeypatch.undo()  # the plug-in gone
    capsys.readouterr()
    assert cli.main(["run", "--from", str(out / "results.parquet"), "--row", "0",
                     "--no-figure", "--out", str(tmp_path / "again")]) != 0
    assert f"install the plug-in it came from, {package})" in capsys.readouterr().err


def test_an_error_in_the_base_class_code_is_placed_there_not_in_a_library() -> None:
    """A review's declaration rule (its Params not a DeclareParams, refused at registration
    since) failed in ``SourceDeclaration.decide`` on a missing setting, and the line named was
    pydantic's own ``main.py:1110``: the line is now the innermost in the behaviour's class or
    its bases."""
    from cptbt.behaviours.declare_source import SourceDeclaration
    from cptbt.node import BehaviourParams
    from cptbt.types import Point

    class OwnParams(BehaviourParams):
        k: int = 3

    class FirstLost(SourceDeclaration):
        variant: ClassVar[str] = "test_first_lost"
        Params = OwnParams

        def estimate(self, p: Percept) -> Point | None:
            return p.pose.point

    with pytest.raises(AssertionError, match=r"does not derive from cptbt\.behaviours\."
                       r"declare_source\.DeclareParams"):
        check_behaviour(FirstLost)  # said first, as registration says it
    from cptbt.testing import ScriptedPerception, fresh_namespace, run_script

    node = FirstLost(OwnParams(), namespace=fresh_namespace())  # flown all the same
    with pytest.raises(AttributeError) as info:
        run_script(node, [ScriptedPerception().step(0.0, 50.0, 0.0)])
    said = blame(info.value)
    assert said is not None and "no attribute 'source_radius_m'" in said, said
    assert " (at declare_source.py:" in said, said


def test_an_estimate_that_is_no_point_is_named() -> None:
    """A review's rule returned ``(x, y)``: a raw "'tuple' object has no attribute 'x'", where a
    ``decide()`` returning a tuple is told what to return."""
    from cptbt.behaviours.declare_source import SourceDeclaration
    from cptbt.types import Point

    class TupleRule(SourceDeclaration):
        variant: ClassVar[str] = "test_tuple_rule"

        def estimate(self, p: Percept) -> Point | None:
            return (p.pose.x, p.pose.y)  # type: ignore[return-value]

    with pytest.raises(AssertionError) as info:
        check_behaviour(TupleRule)
    said = blame(info.value.__cause__)  # type: ignore[arg-type]
    assert said is not None and said.startswith(
        "behaviour declare_source.test_tuple_rule raised TypeError: estimate() returned "
        "tuple "), said
    assert "return a cptbt.types.Point or None" in said
