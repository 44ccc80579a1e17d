"""The declaration criterion when a mission declares several sources (``max_sources``)."""

from __future__ import annotations

from pathlib import Path

import pytest

from cptbt.batch.engine import simulate
from cptbt.batch.outcome import Verdict
from cptbt.batch.scenario import Environment, launch_pose, to_sim_params
from cptbt.batch.summary import _judge_set, summarise
from cptbt.cli import main
from cptbt.loader import loads_mission
from cptbt.registry import default_registry
from cptbt.types import Point

ROOT = Path(__file__).resolve().parents[2]
A, B = Point(0, 0), Point(100, 0)


def test_every_true_source_declared_and_nothing_false_is_a_success() -> None:
    assert _judge_set([Point(3, 4)], [A], 1) == Verdict(True, False, 5.0)
    ok = _judge_set([Point(1, 0), Point(98, 0)], [A, B], 2)
    assert ok.success and not ok.false_declaration and ok.error_m == 2.0
    one_missing = _judge_set([Point(1, 0)], [A, B], 1)
    assert not one_missing.success and not one_missing.false_declaration
    one_false = _judge_set([Point(1, 0), Point(50, 0)], [A], 1)
    assert not one_false.success and one_false.false_declaration and one_false.error_m == 50.0
    assert _judge_set([], [A], 0) == Verdict(False, False, None)


def msn007_asking_for_two(extra: str = "") -> dict:  # type: ignore[type-arg]
    """MSN007 (one source) with a likelihood-map declaration asking for two, 900 s."""
    text = (ROOT / "missions/tro2006_msn007.yaml").read_text(encoding="utf-8")
    start = text.index("declare_source:")
    end = text.index("\n", start)
    text = text[:start] + (f"declare_source: {{variant: likelihood_map, max_sources: 2{extra}}}"
                           ) + text[end:]
    mission = loads_mission(text, "m.yaml", default_registry(), Environment)
    mission = mission.model_copy(update={"mission_a": None, "time_limit_s": 900.0})
    params = to_sim_params(mission, 1)
    (run,), _, wall = simulate(mission, params, [launch_pose(mission)])
    return summarise(run, mission, Point(*params.source_xy_m), 1, wall).to_dict()


def test_asking_for_two_sources_where_there_is_one() -> None:
    """max_sources 2 over one real source: the AMP declares it, searches on to the time limit
    (outcome timeout) and is judged on what it declared: a success, not a failure."""
    s = msn007_asking_for_two()
    assert s["outcome"] == "timeout" and s["sources_declared"] == 1
    assert not s["search_given_up"]
    assert s["sources_found"] == 1 and s["false_declarations"] == 0
    assert s["success"] and s["error_m"] is not None and s["error_m"] <= 15.0


def test_the_measures_end_at_the_declaration_not_at_the_time_limit_or_the_give_up() -> None:
    """A review saw a success's time to source, T_D and path efficiency measure the time limit
    (or the give-up) when max_sources was above the sources there are; the declared point
    was the same as with max_sources 1, and so must its measures be."""
    one = msn007_asking_for_two().copy()
    text = (ROOT / "missions/tro2006_msn007.yaml").read_text(encoding="utf-8")
    start = text.index("declare_source:")
    # without the early leg and the fan, which serve a single source only (with max_sources 2
    # neither is flown), and with the two crossings several sources ask for: the same rule for
    # the first declaration
    text = text[:start] + ("declare_source: {variant: likelihood_map, upflow_early_fraction: "
                           "null, upflow_fan_deg: 0, upflow_crossings: 2}"
                           ) + text[text.index("\n", start):]
    mission = loads_mission(text, "m.yaml", default_registry(), Environment)
    mission = mission.model_copy(update={"mission_a": None, "time_limit_s": 900.0})
    params = to_sim_params(mission, 1)
    (run,), _, wall = simulate(mission, params, [launch_pose(mission)])
    alone = summarise(run, mission, Point(*params.source_xy_m), 1, wall).to_dict()
    gave_up = msn007_asking_for_two(", search_give_up_s: 120")
    assert alone["outcome"] == "declared" and alone["t3"] is not None
    for s in (one, gave_up):
        assert s["declared_sources"][0] == alone["declared_sources"][0]
        for key in ("t2", "t3", "T_D", "D0", "D1", "D2", "D3", "path_m", "path_efficiency",
                    "T_total"):
            assert s[key] == pytest.approx(alone[key]), key
    assert one["search_end_t"] is None and alone["search_end_t"] is None
    assert gave_up["search_end_t"] is not None
    assert gave_up["search_end_t"] >= gave_up["t3"] + 120.0


def test_a_search_that_gives_up_goes_home_with_the_sources_found() -> None:
    """The same with search_give_up_s: 120 s without a detection the declared source does not
    explain, the search ends, and the vehicle goes home (outcome declared)."""
    s = msn007_asking_for_two(", search_give_up_s: 120")
    assert s["outcome"] == "declared" and s["search_given_up"]
    assert s["sources_declared"] == 1 and s["sources_found"] == 1 and s["success"]
    assert s["sim_time_s"] < 900.0


def test_cptbt_run_says_the_search_gave_up_and_when(tmp_path: Path,
                                                    capsys: pytest.CaptureFixture[str]) -> None:
    text = (ROOT / "missions/tro2006_msn007.yaml").read_text(encoding="utf-8")
    start = text.index("declare_source:")
    text = text[:start] + ("declare_source: {variant: likelihood_map, max_sources: 2, "
                           "search_give_up_s: 120}") + text[text.index("\n", start):]
    mission = tmp_path / "two.yaml"
    mission.write_text(text, encoding="utf-8")
    assert main(["run", str(mission), "--out", str(tmp_path / "o"), "--no-figure"]) == 0
    out = capsys.readouterr().out
    assert "the search for more sources gave up at " in out
    assert "with 1 point, declared at t3 = " in out and ": source N " in out
    assert "the last of 1 points" not in out
