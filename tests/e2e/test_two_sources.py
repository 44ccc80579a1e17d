"""The shipped two-source mission end to end: both sources declared, none falsely (issue 13)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from cptbt.batch.engine import simulate
from cptbt.batch.scenario import Environment, launch_pose, to_sim_params
from cptbt.batch.summary import summarise
from cptbt.cli import main
from cptbt.loader import load_mission
from cptbt.registry import default_registry
from cptbt.types import Point

ROOT = Path(__file__).resolve().parents[2]
TWO = ROOT / "missions/two_sources.yaml"


def fly(seed: int) -> dict:  # type: ignore[type-arg]
    mission = load_mission(TWO, default_registry(), Environment)
    params = to_sim_params(mission, seed)
    (run,), _, wall = simulate(mission, params, [launch_pose(mission)])
    sources = [Point(*params.source_xy_m), *(Point(*xy) for xy in params.extra_sources_xy_m)]
    return summarise(run, mission, sources[0], seed, wall, sources=sources).to_dict()


def test_the_shipped_run_declares_both_sources_and_draws_the_map(tmp_path: Path) -> None:
    assert main(["run", str(TWO), "--out", str(tmp_path), "--quiet"]) == 0
    summary = json.loads((tmp_path / "summary.json").read_text(encoding="utf-8"))
    assert summary["sources_true"] == 2
    assert summary["sources_found"] == 2 and summary["false_declarations"] == 0
    assert len(summary["declared_sources"]) == 2
    assert (tmp_path / "trajectory.png").stat().st_size > 10_000
    # every true source is listed (the mission's own first), each declared point with its
    # error to its nearest true source; error_m is the worst of those
    truth = [Point(q["x"], q["y"]) for q in summary["true_sources"]]
    assert len(truth) == 2 and truth[0] == Point(summary["true_source"]["x"],
                                                 summary["true_source"]["y"])
    errors = [q["error_m"] for q in summary["declared_sources"]]
    for q, e in zip(summary["declared_sources"], errors, strict=True):
        assert e == pytest.approx(min(Point(q["x"], q["y"]).distance_to(t) for t in truth))
    assert summary["error_m"] == pytest.approx(max(errors))
    # each point names the source it is judged against, so the pairs read without the
    # top-level three (the last point, the mission's source, the worst error)
    for q in summary["declared_sources"]:
        t = truth[q["nearest_source"]]
        assert q["error_m"] == pytest.approx(Point(q["x"], q["y"]).distance_to(t))
    assert {q["nearest_source"] for q in summary["declared_sources"]} == {0, 1}


def test_the_printed_run_names_every_declared_point(tmp_path: Path,
                                                   capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["run", str(TWO), "--out", str(tmp_path), "--no-figure"]) == 0
    out = capsys.readouterr().out.splitlines()
    lines = [ln for ln in out if "declared points, numbered" in ln]
    assert len(lines) == 1 and lines[0].count("x ") == 2, lines
    # each point with its own error and the source it is judged against
    assert "from source)" in lines[0] and "from extra_sources[0])" in lines[0], lines
    # the error is the worst point's: it is not printed as the last point's own
    (t3,) = [ln for ln in out if "declared at t3" in ln]
    assert "the last of 2 points" in t3 and "worst error" in t3, t3


@pytest.mark.parametrize("seed", [1, 2])
def test_two_source_runs_never_declare_falsely(seed: int) -> None:
    s = fly(seed)
    assert s["false_declarations"] == 0
    assert s["sources_found"] == s["sources_declared"] >= 1


@pytest.mark.slow
def test_two_source_study() -> None:
    # A guard against regression, not issue 13's target (0 false declarations, missed: 3 in
    # 200 runs with same_source_m, 5 before it, 11 before the up-flow check;
    # benchmarks/results/likelihood_map.md).
    # Measured on these 20 seeds with the up-flow check (and before it, with the meander state
    # and the same-source replacement): 20 runs found both sources, none made a false
    # declaration (the independent-cycle map: 19 and 1; before it: 14 and 2).
    runs = [fly(seed) for seed in range(20)]
    assert sum(s["false_declarations"] for s in runs) == 0
    assert sum(s["sources_found"] == 2 for s in runs) >= 19


@pytest.mark.parametrize("seed", [1, 3])
def test_sources_20_m_apart_across_the_flow_are_two_sources(tmp_path: Path, seed: int) -> None:
    # same_source_m (18 m) merges a source declared twice; on these seeds it keeps two real
    # ones 20 m apart (with 25 m both seeds merged them). It can still merge such a pair when
    # a declaration is off, which the docstring says: seeds 1-10 found both in 8 (with the
    # cross-flow sweep between declarations; 6 before it, seed 2 among them then, not now).
    close = tmp_path / "close.yaml"
    close.write_text(TWO.read_text(encoding="utf-8").replace(
        "extra_sources: [[-10, -25]]", "extra_sources: [[-70, 5]]"), encoding="utf-8")
    assert main(["run", str(close), "--seed", str(seed), "--out", str(tmp_path / "o"),
                 "--quiet", "--no-figure"]) == 0
    summary = json.loads((tmp_path / "o" / "summary.json").read_text(encoding="utf-8"))
    assert summary["sources_found"] == 2 and summary["false_declarations"] == 0


def test_an_extra_source_outside_the_op_area_is_one_line_at_its_key(tmp_path: Path) -> None:
    text = TWO.read_text(encoding="utf-8").replace("extra_sources: [[-10, -25]]",
                                                   "extra_sources: [[-10, -25], [300, 0]]")
    bad = tmp_path / "bad.yaml"
    bad.write_text(text, encoding="utf-8")
    out = subprocess.run([sys.executable, "-m", "cptbt", "run", str(bad), "--out",
                          str(tmp_path / "o")], capture_output=True, text=True, check=False)
    assert out.returncode == 2, out.stderr
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1 and "environment.extra_sources[1]" in lines[0]
    assert "outside the OpArea" in lines[0]


@pytest.mark.parametrize(("edit", "where", "says"), [
    (("max_sources: 2}", "max_sources: 1}"), "behaviours[1].declare_source.max_sources",
     "max_sources 1, but the world has 2 sources"),
    (("variant: likelihood_map, max_sources: 2}", "variant: upflow_cluster}"),
     "behaviours[1].declare_source", "the upflow_cluster rule declares one source"),
    (("extra_sources: [[-10, -25]]", "extra_sources: [[-65, 20]]"),
     "environment.extra_sources[0]", "7.1 m from source, within the success radius (15 m)"),
])
def test_a_world_no_run_can_succeed_in_is_warned_of(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], edit: tuple[str, str], where: str,
    says: str
) -> None:
    text = TWO.read_text(encoding="utf-8")
    assert edit[0] in text
    path = tmp_path / "m.yaml"
    path.write_text(text.replace(*edit), encoding="utf-8")
    assert main(["validate", str(path)]) == 0  # valid: a warning, exit 0
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert f": {where}: warning: " in line and says in line, line
    assert main(["validate", str(TWO)]) == 0 and capsys.readouterr().err == ""


def test_a_run_that_ends_searching_reports_the_map_it_ended_on(tmp_path: Path) -> None:
    # three sources to find where two are: the search runs to the time limit, and the map
    # drawn is the one at the end (it had been the last declaration's, captioned so)
    text = TWO.read_text(encoding="utf-8")
    more = tmp_path / "three.yaml"
    more.write_text(text.replace("max_sources: 2}", "max_sources: 3}").replace(
        "time_limit_s: 3600", "time_limit_s: 1200"), encoding="utf-8")
    for path, ends_searching in ((more, True), (TWO, False)):
        mission = load_mission(path, default_registry(), Environment)
        (run,), _, _ = simulate(mission, to_sim_params(mission, 1), [launch_pose(mission)])
        assert run.source_map is not None and run.declaration_report is not None
        assert len(run.declared_all) == 2
        if ends_searching:
            assert str(run.outcome) == "timeout" and run.source_map.t >= 1190.0
            assert run.declaration_report["map_at"] == "end"
        else:
            assert "map_at" not in run.declaration_report and run.t3 is not None
            assert run.source_map.t == pytest.approx(run.t3)
