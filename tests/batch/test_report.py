"""The study report alone: tables, Wilson intervals, and which figures mean something."""

from __future__ import annotations

import json
import math
import re
import statistics
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from cptbt.batch.intervals import wilson
from cptbt.batch.report import StudyGeometry, compared, td_share, write_report
from cptbt.batch.study import config_label

BASE: dict[str, Any] = {
    "config": 0, "replicate": 0, "mission": "m", "start_y": 0.0, "error_m": None, "T_F": None,
    "T_T": None, "T_D": None, "t2": None, "t3": None, "D0": None, "D1": None, "D2": None,
    "D3": None, "D1_over_D0": None, "sim_time_s": 300.0, "success_radius_m": 15.0,
}


def line_rows() -> list[dict[str, Any]]:
    return [
        {**BASE, "start": 0, "start_x": 10.0, "success": True, "t3": 42.0, "error_m": 0.8},
        {**BASE, "start": 1, "start_x": 50.0, "success": False},
        {**BASE, "start": 0, "start_x": 10.0, "replicate": 1, "success": True, "t3": 40.0,
         "t2": 30.0, "T_D": 10.0, "error_m": 0.5},
    ]


def grid_rows(configs: int = 2) -> list[dict[str, Any]]:
    rows = []
    for c in range(configs):
        for k, (x, y) in enumerate([(x, y) for x in (20.0, 60.0) for y in (-20.0, 20.0)]):
            for r in range(3):
                ok = (k + r + c) % 3 != 0
                rows.append({**BASE, "variant": f"v{c}", "config": c, "replicate": r, "start": k,
                             "start_x": x, "start_y": y, "success": ok,
                             "false_declaration": not ok and r == 1,
                             "t3": 100.0 + 10 * k if ok else None,
                             "error_m": 3.0 if ok else (40.0 if r == 1 else None)})
    return [{"configuration": f"variant={r.pop('variant')}", **r} for r in rows]


@pytest.mark.parametrize(("k", "n", "lo", "hi"), [(2, 3, 0.2077, 0.9385), (0, 10, 0.0, 0.2775),
                                                   (10, 10, 0.7225, 1.0)])
def test_wilson_interval(k: int, n: int, lo: float, hi: float) -> None:
    a, b = wilson(k, n)
    assert a == pytest.approx(lo, abs=1e-4) and b == pytest.approx(hi, abs=1e-4)
    assert all(math.isnan(v) for v in wilson(0, 0))


def test_starts_along_a_line_give_a_line_plot_and_no_map(tmp_path: Path) -> None:
    names = {p.name for p in write_report(line_rows(), tmp_path)}
    assert {"tables.md", "time_vs_start.png", "error_and_td_share.png"} == names
    table = (tmp_path / "tables.md").read_text()
    # 42 s and 40 s successes, one 300 s failure; 2 of 3 with its interval over two plumes
    # (Student's t on 1 degree of freedom: all but the whole range); no false; the sample
    # standard deviation of 42 and 40 (√2, not the population's 1.0), as the standard error
    # beside it in the protocol table uses.
    assert "| m | 3 | 66.7% (0.8%–99.8%) | 0 | 41.0 | 1.4 | 127.3 |" in table


def test_a_grid_of_two_configs_gives_maps_rates_and_counts_false_declarations(
    tmp_path: Path,
) -> None:
    geometry = StudyGeometry((0.0, 100.0, -50.0, 50.0), (20.0, 0.0), 0.0)
    names = {p.name for p in write_report(grid_rows(), tmp_path, geometry)}
    assert {"time_to_source_map.png", "success_and_false_declarations.png"} <= names
    assert "time_vs_start.png" not in names
    table = (tmp_path / "tables.md").read_text()
    for config in ("v0", "v1"):  # 8 of 12 succeed; one failure per config is a false one
        row = next(line for line in table.splitlines() if line.startswith(f"| variant={config} |"))
        cells = [c.strip() for c in row.strip("|").split("|")]
        # over 3 plumes of 4 starts: wider than 12 independent runs' 39.1%–86.2%
        assert cells[1:4] == ["12", "66.7% (18.5%–94.6%)", "1"], cells


def test_a_wide_study_maps_y_label_stays_on_the_page(tmp_path: Path) -> None:
    """A review: a 200 x 40 m channel's map had its y label run off the figure's top."""
    from matplotlib.image import imread

    geometry = StudyGeometry((0.0, 200.0, -20.0, 20.0), (40.0, 0.0), 0.0)
    rows = [{**r, "start_x": 2 * r["start_x"], "start_y": r["start_y"] / 2}
            for r in grid_rows(configs=1)]
    write_report(rows, tmp_path, geometry)
    image = imread(tmp_path / "time_to_source_map.png")
    top = image[:3, : image.shape[1] // 10, :3]  # the corner the label reached
    assert (top > 0.95).all(), "something drawn at the figure's top-left edge"


def test_the_study_map_draws_every_true_source_on_one_colour_scale(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A review: a two-source study's map drew the mission's source alone, and each panel had a
    colour scale of its own (0-950 s beside 0-1200 s)."""
    from matplotlib.figure import Figure

    seen: list[Figure] = []
    monkeypatch.setattr(Figure, "savefig", lambda self, *a, **k: seen.append(self))
    geometry = StudyGeometry((0.0, 100.0, -50.0, 50.0), (20.0, 0.0), 0.0, ((70.0, 30.0),))
    rows = grid_rows()
    for r in rows:  # the second configuration's runs end earlier: its own maximum is lower
        r["t3"] = 300.0 if r["config"] == 0 else 200.0
    write_report(rows, tmp_path, geometry)
    fig = seen[0]  # the map
    panels = [ax for ax in fig.axes if ax.get_title()]
    assert len(panels) == 2
    for ax in panels:
        stars = next(line for line in ax.lines if line.get_label() == "sources")
        assert list(stars.get_xdata()) == [20.0, 70.0] and list(stars.get_ydata()) == [0.0, 30.0]
    scales = {(c.norm.vmin, c.norm.vmax) for ax in panels for c in ax.collections
              if getattr(c, "norm", None) is not None and c.get_array() is not None}
    from cptbt.batch.report import by_configuration
    from cptbt.batch.study_figures import colour_top

    # one scale, its top the largest cell of either configuration
    assert scales == {(0.0, colour_top(by_configuration(rows)))}, scales


def test_a_two_source_study_counts_the_sources_found(tmp_path: Path) -> None:
    # A rule that can declare one source alone: every run fails with no false declaration;
    # the sources-found column says why (1 of 2 each time), and a one-source study has none.
    rows = [{**BASE, "configuration": "variant=one", "start": 0, "start_x": 0.0, "replicate": r,
             "success": False, "false_declaration": False, "t3": 50.0, "error_m": 2.0,
             "sources_true": 2, "sources_found": 1, "sources_declared": 1} for r in range(3)]
    rows += [{**r, "configuration": "variant=map", "success": True, "sources_found": 2,
              "sources_declared": 2} for r in rows]
    write_report(rows, tmp_path)
    table = (tmp_path / "tables.md").read_text()
    assert ("| success: every source declared within the radius (95% CI) | sources found / true "
            "| false declarations (runs) |") in table
    assert "| variant=one | 3 | 0.0% (0.0%–56.2%) | 3 / 6 | 0 |" in table, table
    # one point declared of two sources: no error to speak of (a review read 4.8 m as right)
    one = next(line for line in table.splitlines() if line.startswith("| variant=one |"))
    assert one.endswith("| — | — |"), one
    assert "| variant=map | 3 | 100.0% (43.8%–100.0%) | 6 / 6 | 0 |" in table, table
    write_report(line_rows(), tmp_path)
    assert "sources found" not in (tmp_path / "tables.md").read_text()


def test_a_run_that_declared_several_points_lists_each_with_its_own_error(
        tmp_path: Path) -> None:
    # The row's declared_source_* is the last point and its error_m the worst point's: shown
    # side by side they paired a point with another's error.
    points = [[100.0, 5.0, 2.5], [40.0, -30.0, 21.0], [160.0, 20.0, 4.0]]
    row = {**BASE, "configuration": "variant=map", "start": 0, "start_x": 0.0, "success": False,
           "false_declaration": True, "t3": 300.0, "error_m": 21.0, "sources_true": 2,
           "sources_found": 2, "declared_source_x": 160.0, "declared_source_y": 20.0,
           "declared_points": json.dumps(points)}
    one = {**row, "replicate": 1, "success": True, "false_declaration": False, "error_m": 1.5,
           "sources_true": 1, "sources_found": 1, "declared_source_x": 99.0,
           "declared_source_y": 1.0, "declared_points": json.dumps([[99.0, 1.0, 1.5]])}
    searching = {**one, "replicate": 2, "declared_source_x": None, "declared_source_y": None,
                 "declared_points": json.dumps([[98.0, 2.0, 2.0]])}
    write_report([row, one, searching], tmp_path)
    table = (tmp_path / "tables.md").read_text()
    # a false declaration is marked where its error is (a review read it as any other row)
    assert ("| (100.0, 5.0) 2.5 m; (40.0, -30.0) 21.0 m; (160.0, 20.0) 4.0 m | 21.0 (false) |"
            in table), table
    assert "| (99.0, 1.0) | 1.5 |" in table, table
    assert "| (98.0, 2.0) | 1.5 |" in table, table  # ended searching for more: no declared_source
    assert "the error column is the worst of them" in table
    # which declaration the times and paths are (a review could not tell)
    assert "t2 is the first pass within 13 m of the last declared point" in table


def test_places_are_given_in_the_missions_compass_when_it_has_one(tmp_path: Path) -> None:
    # A review typed N-E starts and read the planning-frame table as swapped: a mission in
    # N-E metres or lat/lon now gets its places in North-East metres; a planning one as before.
    from cptbt.frames import PlanningFrame

    row = {**BASE, "configuration": "variant=map", "start": 0, "start_x": 10.0,
           "start_y": 0.0, "success": True, "false_declaration": False, "t3": 300.0,
           "error_m": 2.0, "declared_source_x": 0.0, "declared_source_y": 20.0,
           "declared_points": json.dumps([[0.0, 20.0, 2.0]])}
    east = PlanningFrame(x_bearing_deg=90.0)  # x toward east, y toward south
    geometry = StudyGeometry((-50.0, 50.0, -30.0, 30.0), (0.0, 0.0), 0.0, (), east)
    assert StudyGeometry.from_data(geometry.to_data()) == geometry  # study.json keeps it
    write_report([row], tmp_path, geometry, figures=False)
    table = (tmp_path / "tables.md").read_text()
    assert "| start (N, E) | declared (N, E) |" in table, table
    assert "| (0.0, 10.0) | (-20.0, 0.0) | 2.0 |" in table, table
    assert "North-East metres" in table
    planning = StudyGeometry((-50.0, 50.0, -30.0, 30.0), (0.0, 0.0), 0.0)
    write_report([row], tmp_path, planning, figures=False)
    table = (tmp_path / "tables.md").read_text()
    assert "| (10.0, 0.0) | (0.0, 20.0) | 2.0 |" in table, table
    assert "| start (x, y) | declared (x, y) |" in table and "planning frame" in table
    old = planning.to_data()
    del old["ne_frame"]  # a study.json written before it: the planning frame, as then
    assert StudyGeometry.from_data(old) == planning


def test_arrival_runs_get_no_error_histogram(tmp_path: Path) -> None:
    rows = [{**r, "criterion": "arrival", "t3": None} for r in line_rows()]
    names = {p.name for p in write_report(rows, tmp_path)}
    assert "error_and_td_share.png" not in names
    table = (tmp_path / "tables.md").read_text()
    # Its columns say what its numbers are: no declarations to count, distances at the end.
    assert "success: reached the source (95% CI)" in table
    assert "| mean distance at the end (m) | max distance at the end (m) |" in table
    assert "| m | 3 | 66.7% (0.8%–99.8%) | — |" in table


def test_geometry_round_trips_through_study_json_data() -> None:
    g = StudyGeometry((0.0, 100.0, -50.0, 50.0), (20.0, 0.0), 12.5)
    assert StudyGeometry.from_data(g.to_data()) == g
    two = StudyGeometry((0.0, 100.0, -50.0, 50.0), (20.0, 0.0), 12.5, ((60.0, 10.0),))
    assert StudyGeometry.from_data(two.to_data()) == two
    old = {k: v for k, v in g.to_data().items() if k != "extra_sources"}  # an older study.json
    assert StudyGeometry.from_data(old) == g
    assert StudyGeometry.from_data(None) is None
    assert StudyGeometry.from_data({"area": "x"}) is None


def maintain_rows() -> list[dict[str, Any]]:
    rows = []
    for preset in ("ab_large_meander", "ab_small_meander"):
        for beta in (0.0, 5.0, 10.0):
            for rep in range(3):
                t_m = None if (beta, rep) == (10.0, 2) else beta + rep  # one run never detected
                rows.append({"config": 0, "replicate": rep, "start": 0, "start_x": 60.0,
                             "start_y": 5.0, "criterion": "maintain", "success": False,
                             "outcome": "contact_lost", "T_M": t_m, "T_total": 20.0,
                             "error_m": 30.0, "t3": None, "false_declaration": False,
                             "configuration": f"preset={preset}, beta1_deg={beta:g}"})
    return rows


def test_d1_over_d0_zeros_where_t2_is_t1_are_marked(tmp_path: Path) -> None:
    """A review: runs whose first detection was already within 13 m of the declared point have
    D1/D0 = 0 by SPEC §11's definition, unmarked, and the mean row averaged them in."""
    def declared(rep: int, t_t: float, ratio: float) -> dict[str, Any]:
        return {**BASE, "replicate": rep, "start": 0, "start_x": 10.0, "success": True,
                "t3": 100.0, "error_m": 2.0, "T_F": 20.0, "T_T": t_t, "T_D": 80.0 - t_t,
                "D0": 30.0, "D1": 30.0 * ratio, "D2": 10.0, "D3": 30.0 * ratio + 10.0,
                "D1_over_D0": ratio}

    rows = [declared(0, 0.0, 0.0), declared(1, 30.0, 1.2), declared(2, 40.0, 1.6)]
    write_report(rows, tmp_path, figures=False)
    text = (tmp_path / "tables.md").read_text(encoding="utf-8")
    (first,) = [line for line in text.splitlines() if line.startswith("| r0s0 ")]
    assert first.endswith("| 0.00 (t2 = t1) |"), first
    (mean,) = [line for line in text.splitlines() if line.startswith("| mean of 3 declared ")]
    assert mean.endswith("| 0.93 (1 at 0, t2 = t1; 1.40 without) |"), mean
    assert not [line for line in text.splitlines() if line.startswith("| r1s0 ")
                and "t2 = t1" in line]


def test_a_maintain_study_reports_t_m_against_its_numeric_setting(tmp_path: Path) -> None:
    names = {p.name for p in write_report(maintain_rows(), tmp_path)}
    assert "maintain_time.png" in names
    assert "success_and_false_declarations.png" not in names  # nothing is declared
    text = (tmp_path / "tables.md").read_text(encoding="utf-8")
    assert "TRO Tables III and IV" not in text
    # beta 10: T_M 10 and 11 (the third run made no contact): mean 10.5 ± 0.5, 2 of 3 runs.
    assert "| preset=ab_large_meander, beta1_deg=10 | 3 | 2 | 10.5 ± 0.5 | 10.5 | 0 |" in text
    # T_M first (what the study measures); closest approaches, not "errors", after it.
    assert text.index("## Maintain time") < text.index("## Per configuration")
    assert "mean closest approach (m)" in text and "mean error" not in text


def test_a_single_run_has_no_standard_error_and_the_tables_say_none(tmp_path: Path) -> None:
    """One run's standard deviation is NaN: the tables give "± —" where they had "± nan"."""
    one = [r for r in maintain_rows() if r["replicate"] == 0]  # one run per configuration
    write_report(one, tmp_path, figures=False)
    text = (tmp_path / "tables.md").read_text(encoding="utf-8")
    assert "| preset=ab_large_meander, beta1_deg=10 | 1 | 1 | 10.0 ± — | 10.0 | 0 |" in text
    assert not re.search(r"\bnan\b", text, re.IGNORECASE), text
    write_report(grid_rows()[:1], tmp_path / "g", figures=False)  # a search study's one run
    text = (tmp_path / "g" / "tables.md").read_text(encoding="utf-8")
    assert not re.search(r"\bnan\b", text, re.IGNORECASE), text


@pytest.mark.parametrize("n", [11, 27])
def test_rates_chart_survives_wilson_bounds_a_rounding_error_past_the_rate(
        tmp_path: Path, n: int) -> None:
    # wilson(0, n) gives a lower bound of ~1e-17 for these n (and wilson(n, n) an upper bound
    # just under 1): the error bars must not go negative (matplotlib refuses them).
    rows = [{**BASE, "config": c, "replicate": r, "start": 0, "start_x": 50.0, "start_y": 0.0,
             "criterion": "arrival", "success": True, "false_declaration": False, "t3": None,
             "T_total": 100.0, "error_m": 0.5, "configuration": f"variant=v{c}"}
            for c in range(2) for r in range(n)]
    names = {p.name for p in write_report(rows, tmp_path)}
    assert "success_and_false_declarations.png" in names


def _map_figure(rows: list[dict[str, Any]], tmp_path: Path,
                monkeypatch: pytest.MonkeyPatch, ne_frame: Any = None) -> Any:
    from matplotlib.figure import Figure

    seen: list[Figure] = []
    monkeypatch.setattr(Figure, "savefig", lambda self, *a, **k: seen.append(self))
    write_report(rows, tmp_path, StudyGeometry((0.0, 100.0, -50.0, 50.0), (20.0, 0.0), 0.0,
                                               ne_frame=ne_frame))
    (fig,) = [f for f in seen if f.axes and "start x" in f.axes[0].get_xlabel()]
    return fig.axes[0]



def test_scattered_starts_are_drawn_as_points_not_cells(tmp_path: Path,
                                                       monkeypatch: pytest.MonkeyPatch) -> None:
    from matplotlib.collections import PathCollection, QuadMesh

    rows = [r for r in grid_rows(1) if (r["start_x"], r["start_y"]) != (60.0, 20.0)]
    ax = _map_figure(rows, tmp_path, monkeypatch)
    kinds = {type(c) for c in ax.collections}
    assert PathCollection in kinds and QuadMesh not in kinds  # 3 of a 2 x 2 grid's starts

def test_the_start_map_gives_the_compass_bearing_of_x(tmp_path: Path,
                                                      monkeypatch: pytest.MonkeyPatch) -> None:
    """A review's rotated box: the map's axes said "planning frame" and no bearing."""
    from cptbt.frames import PlanningFrame

    ax = _map_figure(grid_rows(1), tmp_path, monkeypatch, PlanningFrame(30.0))
    assert ax.get_xlabel() == "start x (m), planning frame, compass bearing 30.0°"
    ax = _map_figure(grid_rows(1), tmp_path, monkeypatch)  # a planning-frame mission
    assert ax.get_xlabel() == "start x (m), planning frame"


def test_config_label_names_each_setting_unambiguously() -> None:
    assert config_label({}, "msn") == "msn"
    assert config_label({"maintain_plume.speed_mps": 1.0}, "msn") == "speed_mps=1.0"
    joint = "maintain_plume.variant+reacquire_plume.variant"
    assert config_label({joint: "strategy_1"}, "msn") == "maintain_plume+reacquire_plume=strategy_1"
    # a variant by its family: "variant=three_point" left a reader to guess whose
    assert config_label({"reacquire_plume.variant": "three_point"}, "msn") \
        == "reacquire_plume=three_point"
    # Two sweeps ending in the same key would both read "speed_mps=...": full paths instead.
    two = {"maintain_plume.speed_mps": 1.0, "find_plume.speed_mps": 2.0, "environment.seed": 3}
    assert config_label(two, "msn") == (
        "maintain_plume.speed_mps=1.0, find_plume.speed_mps=2.0, environment.seed=3")
    # a simulator setting keeps its path (a review read flow_speed_mps as the vehicle's)
    assert config_label({"environment.flow_speed_mps": 0.2}, "msn") == \
        "environment.flow_speed_mps=0.2"


def test_rates_chart_gives_each_swept_setting_a_line_and_room(tmp_path: Path,
                                                              monkeypatch: pytest.MonkeyPatch
                                                              ) -> None:
    """Two sweeps' labels ("a.speed_mps=1, b.speed_mps=2") under 1.4 in bars ran into each
    other: one setting per line, and each bar as wide as its longest line."""
    pytest.importorskip("matplotlib")
    from matplotlib.figure import Figure

    from cptbt.batch.figures import pyplot
    from cptbt.batch.study_figures import _rates

    two = {"maintain_plume.speed_mps": 1.0, "find_plume.speed_mps": 1.5}
    label = config_label(two, "m")
    groups = {label.replace("1.5", str(v)): [{**BASE, "success": True, "criterion": "arrival"}]
              for v in (1.5, 2.5, 3.5, 4.5)}
    seen: list[Figure] = []
    monkeypatch.setattr(Figure, "savefig", lambda self, *a, **k: seen.append(self))
    assert _rates(groups, tmp_path / "r.png", pyplot()) is not None
    fig = seen[0]
    ticks = [t.get_text() for t in fig.axes[0].get_xticklabels()]
    assert ticks[0].splitlines() == ["maintain_plume.speed_mps=1.0", "find_plume.speed_mps=1.5",
                                     "n = 1"]
    per_bar_in = (fig.get_size_inches()[0] - 2.5) / len(groups)
    assert per_bar_in >= 0.075 * len("maintain_plume.speed_mps=1.0")


def test_places_print_without_a_negative_zero_and_say_their_frame(tmp_path: Path) -> None:
    """A review saw a start typed on an axis in N-E metres printed as (-50.0, -0.0), with
    nothing saying the table is in the planning frame."""
    from cptbt.batch.comparison import fmt as _fmt

    assert [_fmt(v) for v in (-0.0, -1e-15, -0.5, 2.0)] == ["0.0", "0.0", "-0.5", "2.0"]
    write_report(line_rows(), tmp_path)
    text = (tmp_path / "tables.md").read_text()
    assert "Places in the planning frame" in text and "D1/D0 can be below 1" in text


def test_per_start_counts_are_drawn_only_when_they_differ_and_clear_of_the_current(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A review: on a 3 x 3 grid the current's arrow sat on a corner cell's "n=" label (and a
    source's star on another), while every label said what the title says."""
    rows = grid_rows(1)  # 3 runs at each of 4 starts
    ax = _map_figure(rows, tmp_path, monkeypatch)
    assert not [t for t in ax.texts if t.get_text().startswith("n=")]
    assert "n = 3 per start" in ax.get_title()
    rows = [r for r in rows if not (r["start_x"] == 20.0 and r["start_y"] == 20.0
                                    and r["replicate"] == 2)]
    ax = _map_figure(rows, tmp_path, monkeypatch)
    labels = {t.get_position(): t.get_text() for t in ax.texts if t.get_text().startswith("n=")}
    # at each cell's top edge (y drawn down: its smallest y; cells -40..0 and 0..40), not its
    # centre
    assert {(x, round(y, 6)): n for (x, y), n in labels.items()} == {
        (20.0, -37.6): "n=3", (20.0, 2.4): "n=2", (60.0, -37.6): "n=3", (60.0, 2.4): "n=3"}
    (arrow,) = [a for a in ax.texts if type(a).__name__ == "Annotation"]
    tail = arrow.xyann
    assert all(math.hypot(tail[0] - x, tail[1] - y) > 10.0 for x, y in labels)


def test_an_interrupted_study_is_compared_on_the_runs_every_configuration_has(
        tmp_path: Path) -> None:
    # A review plotted an interrupted study: 144 runs of one variant against 36 of another,
    # not the same plumes, and nothing said so.
    def row(config: str, r: int, success: bool) -> dict[str, Any]:
        return {**BASE, "configuration": config, "replicate": r, "start": 0, "start_x": 0.0,
                "success": success, "false_declaration": False, "t3": 50.0, "error_m": 2.0}

    rows = [row("variant=a", r, r >= 3) for r in range(8)]  # fails its first three
    rows += [row("variant=b", r, True) for r in range(2)]
    groups, notes = compared(rows, planned_runs=16)
    assert [len(g) for g in groups.values()] == [2, 2]
    assert notes[0].startswith("Incomplete study: 10 of 16 planned runs")
    assert "variant=a 8, variant=b 2" in notes[1] and "compares the 2 runs" in notes[1]
    write_report(rows, tmp_path, figures=False, planned_runs=16)
    table = (tmp_path / "tables.md").read_text()
    assert "**Incomplete study: 10 of 16 planned runs" in table
    assert "| variant=a | 2 | 0.0% " in table, table  # its runs 0 and 1, not all 8
    whole = [row(c, r, True) for c in ("variant=a", "variant=b") for r in range(4)]
    assert compared(whole, planned_runs=8)[1] == []  # a finished study: nothing to say
    write_report(whole, tmp_path, figures=False)
    assert "Incomplete" not in (tmp_path / "tables.md").read_text()


def test_a_study_map_of_many_configurations_wraps_at_three_panels_a_row(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Six configurations had made one row of six maps, 36 inches wide: each a sliver."""
    from matplotlib.figure import Figure

    seen: list[Figure] = []
    real = Figure.savefig
    monkeypatch.setattr(Figure, "savefig", lambda self, *a, **k: (seen.append(self),
                                                                   real(self, *a, **k)))
    geometry = StudyGeometry((0.0, 100.0, -50.0, 50.0), (20.0, 0.0), 0.0)
    write_report(grid_rows(configs=5), tmp_path, geometry)
    fig = seen[0]
    panels = [ax for ax in fig.axes if ax.get_title()]
    assert len(panels) == 5
    rows = sorted({round(ax.get_position().y0, 3) for ax in panels}, reverse=True)
    assert len(rows) == 2  # three above, two below
    assert sum(round(ax.get_position().y0, 3) == rows[0] for ax in panels) == 3
    assert fig.get_size_inches()[0] == pytest.approx(18.0)
    assert [ax.get_title().split("\n")[0] for ax in panels] == [
        f"variant=v{c}" for c in range(5)]


def test_the_study_figures_say_what_each_panel_and_bar_is(tmp_path: Path,
                                                          monkeypatch: pytest.MonkeyPatch) -> None:
    """A review: with 0 false declarations the rate chart showed only a floating error bar;
    the error and T_D panels had no titles; maintain_time.png's x axis named the setting
    without its behaviour."""
    pytest.importorskip("matplotlib")
    from matplotlib.figure import Figure

    from cptbt.batch.figures import pyplot
    from cptbt.batch.maintain_report import maintain_figure
    from cptbt.batch.study_figures import _distributions, _rates

    seen: list[Figure] = []
    monkeypatch.setattr(Figure, "savefig", lambda self, *a, **k: seen.append(self))
    rows = {f"variant=v{c}": [{**BASE, "success": r < 3, "false_declaration": False,
                               "criterion": "declaration", "error_m": 2.0 + r, "t3": 100.0,
                               "T_D": 30.0} for r in range(4)] for c in range(2)}
    assert _rates(rows, tmp_path / "r.png", pyplot()) is not None
    shown = [t.get_text() for t in seen[-1].axes[0].texts]
    assert shown == ["3/4", "3/4", "0/4", "0/4"]  # success, then false declarations
    two = {k: [{**r, "sources_true": 2} for r in v] for k, v in rows.items()}
    assert _rates(two, tmp_path / "r2.png", pyplot()) is not None
    fig = seen[-1]
    fig.canvas.draw()
    box, page = fig.axes[0].title.get_window_extent(), fig.bbox
    assert page.x0 <= box.x0 and box.x1 <= page.x1  # the long two-source title lost its start
    assert "false declarations" in fig.axes[0].get_title()
    assert _distributions(rows, tmp_path / "d.png", pyplot()) is not None
    titles = [ax.get_title() for ax in seen[-1].axes if ax.get_title()]
    assert len(titles) == 2 and "off" in titles[0] and "T_D" in titles[1]
    fig = seen[-1]
    fig.canvas.draw()
    page = fig.bbox
    for ax in fig.axes:  # each title whole over its panel (a longer one was cut at the edge)
        box = ax.title.get_window_extent()
        assert page.x0 <= box.x0 and box.x1 <= page.x1, ax.get_title()
        assert box.width <= ax.bbox.width, ax.get_title()
    # several sources: the error is the worst declared source's and T_D ends at the last
    # declaration (a review read them as the first's); legends under the panels, not on the
    # success radius's line
    with_radius = {k: [{**r, "success_radius_m": 15.0} for r in v] for k, v in two.items()}
    assert _distributions(with_radius, tmp_path / "d2.png", pyplot()) is not None
    fig = seen[-1]
    labels = [ax.get_xlabel() for ax in fig.axes]
    assert "worst" in labels[0] and "last declaration" in labels[1]
    bars = [p for p in fig.axes[0].patches if p.get_height() > 0]
    assert bars and all(p.get_linewidth() > 0 for p in bars)  # adjacent bins told apart
    fig.canvas.draw()
    (legend,) = fig.legends  # one for both panels, each configuration once (a review saw
    box = legend.get_window_extent()  # two legends run over each other and off the page)
    for ax in fig.axes:
        assert box.y1 <= ax.bbox.y0  # below the plot areas
    assert fig.bbox.x0 <= box.x0 and box.x1 <= fig.bbox.x1  # on the page
    texts = [t.get_text() for t in legend.get_texts()]
    assert len(texts) == len(set(texts)) == len(with_radius) + 1  # + the success radius
    # counts that differ between the panels: still one entry, saying both (a review saw the
    # configuration twice, once with each count)
    uneven = {k: [*v, {**v[0], "T_D": None}] for k, v in with_radius.items()}
    assert _distributions(uneven, tmp_path / "d3.png", pyplot()) is not None
    (legend,) = seen[-1].legends
    texts = [t.get_text().replace("\n", " ") for t in legend.get_texts()]
    # the count is one unbreakable phrase (a review's label wrapped as "(n = 13 of 16 / runs)")
    assert texts[0] == "variant=v0 " + "(n = 5 errors, 4 T_D shares)".replace(" ", "\u00a0")
    # a run that declared nothing is said (a paper reviewer read "n = 28" of 30 runs)
    silent = {k: [*v, {**v[0], "t3": None, "error_m": None, "T_D": None}]
              for k, v in with_radius.items()}
    assert _distributions(silent, tmp_path / "d4.png", pyplot()) is not None
    texts = [t.get_text().replace("\n", " ").replace("\u00a0", " ")
             for t in seen[-1].legends[0].get_texts()]
    n = len(with_radius["variant=v0"])
    assert texts[0].startswith(f"variant=v0 (n = {n}") and f"of {n + 1} runs)" in texts[0], texts
    groups: dict[str, list[dict[str, Any]]] = {}
    for r in maintain_rows():
        beta = r["configuration"].split("beta1_deg=")[1]
        groups.setdefault(r["configuration"], []).append(
            {**r, "maintain_plume.beta1_deg": float(beta), "environment.preset": "x"})
    assert maintain_figure(groups, tmp_path / "m.png", pyplot()) is not None
    assert seen[-1].axes[0].get_xlabel() == "maintain_plume.beta1_deg"


def test_no_time_figure_when_every_run_stopped_on_an_error(tmp_path: Path) -> None:
    """A review's study of a plug-in that raised: time_vs_start.png had empty axes from -0.04
    to 0.04. The tables say what happened; the figures with nothing to draw are not made."""
    pytest.importorskip("matplotlib")
    from cptbt.batch.outcome import ERROR_OUTCOME

    rows = [{**r, "outcome": ERROR_OUTCOME, "success": False, "sim_time_s": None, "t3": None}
            for r in line_rows()]
    written = {p.name for p in write_report(rows, tmp_path)}
    assert "time_vs_start.png" not in written and "tables.md" in written
    grid = [{**r, "outcome": ERROR_OUTCOME, "success": False, "sim_time_s": None, "t3": None}
            for r in grid_rows(1)]
    assert "time_to_source_map.png" not in {p.name for p in write_report(grid, tmp_path / "g")}
    # one run with a time: drawn
    assert "time_vs_start.png" in {p.name for p in write_report(line_rows(), tmp_path / "l")}


def test_td_share_is_of_the_time_from_t0() -> None:
    # TRO Table III: T_D / T_total, T_total = t3 - t0. A run with the vehicle's own mission
    # first starts its measures at t0 = 240 s (the README's `cptbt run`): 211 / 485, not / 725.
    row = {**BASE, "t0": 240.0, "t3": 725.0, "T_D": 211.0, "T_total": 485.0}
    assert td_share(row) == pytest.approx(211.0 / 485.0)
    # a table without T_total (an older one): t3 - t0, t0 taken as 0 when absent
    assert td_share({**row, "T_total": None}) == pytest.approx(211.0 / 485.0)
    assert td_share({**BASE, "t3": 40.0, "T_D": 10.0}) == pytest.approx(0.25)
    assert td_share({**BASE, "t3": 40.0}) is None


def test_paired_comparisons_count_discordant_runs_within_a_world() -> None:
    """A review: the runs are paired but the tables compared only each configuration's own
    intervals. Each configuration is set against the first of its world, run by run."""
    from cptbt.batch.comparison import mcnemar, paired_table

    def run(config: str, rep: int, ok: bool, t3: float, flow: float) -> dict[str, Any]:
        return {**BASE, "configuration": config, "replicate": rep, "start": 0,
                "start_x": 0.0, "success": ok, "t3": t3 if ok else None,
                "environment.flow_speed_mps": flow, "run_time_limit_s": 300.0}

    groups = {
        "a": [run("a", r, r != 3, 100.0, 0.1) for r in range(6)],
        "b": [run("b", r, r not in (0, 1), 90.0 + r, 0.1) for r in range(6)],
        "c": [run("c", r, True, 50.0, 0.2) for r in range(6)],  # another world: the first there
    }
    lines = paired_table(groups)
    rows = [line for line in lines if line.startswith("| b ")]
    assert len(rows) == 1 and not [line for line in lines if line.startswith("| c ")]
    # b succeeded alone in run 3, a alone in 0 and 1; both in 2, 4, 5: b - a = -8, -6, -5
    d = [-8.0, -6.0, -5.0]
    se = np.std(d, ddof=1) / np.sqrt(3)
    lo, hi = np.mean(d) - 4.303 * se, np.mean(d) + 4.303 * se  # Student's t, 2 df
    # over every pair, a failure at its limit (300 s): b failed 0 and 1, a failed 3
    s = [300.0 - 100, 300.0 - 100, -8.0, 93.0 - 300, -6.0, -5.0]
    s_se = np.std(s, ddof=1) / np.sqrt(6)
    s_lo, s_hi = np.mean(s) - 2.571 * s_se, np.mean(s) + 2.571 * s_se  # 5 df
    assert rows[0] == (f"| b | a | 6 | 1 / 2 | {mcnemar(1, 2):.2g} | "
                       f"3 | {np.mean(d):.1f} ± {se:.1f} ({lo:.1f} to {hi:.1f}, 2 df) | "
                       f"{np.mean(s):.1f} ± {s_se:.1f} ({s_lo:.1f} to {s_hi:.1f}, 5 df) |")
    assert mcnemar(0, 0) == 1.0 and mcnemar(0, 6) == pytest.approx(2 / 64)
    assert paired_table({"a": groups["a"]}) == []
    # a failed run with no time at all (no limit recorded, no end): left out, and said
    groups["b"][0] |= {"run_time_limit_s": None, "sim_time_s": None}
    (row,) = [line for line in paired_table(groups) if line.startswith("| b ")]
    assert row.endswith(" over 5 pairs |"), row


def test_tables_say_what_was_flown(tmp_path: Path) -> None:
    """A review found tables.md silent on the mission, seed, starts, pairing and the sweeps'
    notes (which went to the terminal only)."""
    (tmp_path / "study.json").write_text(json.dumps({
        "mission": "missions/x.yaml", "mission_name": "x", "root_seed": 7,
        "starts": [[0, 0], [1, 0]], "runs_per_start": 3, "time_limit_s": None,
        "sweeps": {"environment.flow_speed_mps": [0.1, 0.2]},
        "notes": ["environment.flow_speed_mps is swept: not the same plume"],
        "warnings": ["m.yaml:23: behaviours[3].reacquire_plume.d_leaf_m: warning: 15 m: ..."]}))
    rows = [{**r, "configuration": f"flow_speed_mps={v}", "environment.flow_speed_mps": v}
            for v in (0.1, 0.2) for r in line_rows()]
    write_report(rows, tmp_path, figures=False)
    text = (tmp_path / "tables.md").read_text(encoding="utf-8")
    assert "- Mission `missions/x.yaml` (x), root seed 7; 2 starts × 3 replicates" in text
    assert "- Swept: `environment.flow_speed_mps` = 0.1, 0.2." in text
    assert "not across the values of a setting of the simulated world" in text
    assert "## Paired comparisons" not in text  # each value a world of its own: none pairs
    assert "- Note: environment.flow_speed_mps is swept: not the same plume" in text
    # validate's warnings too (a new user's met the terminal only, beside a comparison)
    assert ("- Warning (as `cptbt validate` gives it): m.yaml:23: behaviours[3].reacquire_plume."
            "d_leaf_m: warning: 15 m: ...") in text


def test_pairing_follows_what_changes_the_world() -> None:
    """A review: an OpArea sweep (the flow is laid over it) was paired as the same plume, and
    a sensor sweep (its noise has the vehicle's own stream) refused as another world."""
    from cptbt.batch.sweeps import changes_world

    assert changes_world("environment.flow_speed_mps") and changes_world("op_area.corners")
    assert changes_world("environment.plume.release_rate_hz")
    assert not changes_world("environment.fluorometer.noise_std")
    assert not changes_world("environment.navigation.drift_std_m")
    assert not changes_world("declare_source.variant")
    # a joint sweep's column: any of its paths (a review's speed+flow pairs read "same plume")
    assert changes_world("speed_mps+environment.flow_speed_mps")
    assert changes_world("environment.fluorometer.noise_std+environment.flow_speed_mps")
    assert not changes_world("speed_mps+environment.fluorometer.noise_std")


def test_a_joint_sweep_that_changes_the_world_is_not_paired() -> None:
    from cptbt.batch.comparison import paired_table

    key = "speed_mps+environment.flow_speed_mps"
    groups = {f"{key}={v}": [{"replicate": r, "start": 0, key: v, "success": r % 2 == 0,
                              "t3": 10.0 + r} for r in range(6)] for v in (0.8, 1.0)}
    assert paired_table(groups) == []


def test_a_failure_counts_at_its_time_limit_in_the_search_time() -> None:
    """A review: a false declaration counted at its run's end, after the trip home, so a
    setting that never succeeded looked only a little slow on the map."""
    from cptbt.batch.comparison import search_time

    false = {**BASE, "success": False, "t3": 176.0, "sim_time_s": 335.0}
    assert search_time({**false, "run_time_limit_s": 1800.0}) == 1800.0
    assert search_time(false) == 335.0  # rows from before the limit was recorded
    assert search_time({**BASE, "success": True, "t3": 225.0, "sim_time_s": 343.0,
                         "run_time_limit_s": 1800.0}) == 225.0


def test_plot_elsewhere_heads_its_tables_with_the_study(tmp_path: Path) -> None:
    """cptbt plot --out DIR read the study's record in DIR, which has none: it is read beside
    the results."""
    pytest.importorskip("pyarrow")
    import pyarrow as pa
    import pyarrow.parquet as pq

    from cptbt.cli import main

    study = tmp_path / "study"
    study.mkdir()
    rows = line_rows()
    cols = list(dict.fromkeys(k for r in rows for k in r))
    pq.write_table(pa.Table.from_pylist([{c: r.get(c) for c in cols} for r in rows]),
                   study / "results.parquet")
    (study / "study.json").write_text(json.dumps({
        "mission": "missions/x.yaml", "mission_name": "x", "root_seed": 7,
        "starts": [[10, 0], [50, 0]], "runs_per_start": 2, "sweeps": {}}))
    assert main(["plot", str(study), "--out", str(tmp_path / "elsewhere")]) == 0
    text = (tmp_path / "elsewhere" / "tables.md").read_text(encoding="utf-8")
    assert "- Mission `missions/x.yaml` (x), root seed 7; 2 starts × 2 replicates" in text


def test_tables_say_which_runs_left_the_oparea(tmp_path: Path) -> None:
    """A review: every run of a corner-source study went 5-14 m outside, and neither the
    summary nor tables.md said so (only results.parquet)."""
    rows = grid_rows()
    for r in rows:
        inside = r["config"] == 0 or r["start"] != 1
        r |= {"farthest_outside_m": 0.0 if inside else 4.0 + r["replicate"],
              "time_safety_s": 0.0 if inside else 30.0, "time_find_plume_s": 270.0,
              "time_safety.oparea_s": 0.0 if inside else 30.0}  # a leaf column: not summed
    write_report(rows, tmp_path)
    table = (tmp_path / "tables.md").read_text()
    assert "## Left the OpArea" in table
    # config 1: start 1's three runs went 4, 5, 6 m out; safety drove 90 of 12 * 270 + 90 s
    assert "| variant=v0 | 0 of 12 | 0.0 | 0.0% |" in table
    assert f"| variant=v1 | 3 of 12 | 6.0 | {100 * 90 / (12 * 270 + 90):.1f}% |" in table
    for r in rows:
        r["farthest_outside_m"] = 0.01  # under the 0.05 m cptbt run says nothing of
    write_report(rows, tmp_path)
    assert "Left the OpArea" not in (tmp_path / "tables.md").read_text()


def test_plot_says_when_the_study_record_cannot_be_read(tmp_path: Path) -> None:
    """A review: ``cptbt plot`` on a folder whose study.json was ``{garbage`` wrote its tables
    without a word (``cptbt run --from`` said the record did not say how the rows were flown)."""
    import subprocess
    import sys

    import pyarrow as pa
    import pyarrow.parquet as pq

    pq.write_table(pa.Table.from_pylist(line_rows()), tmp_path / "results.parquet")
    (tmp_path / "study.json").write_text("{garbage", encoding="utf-8")
    res = subprocess.run([str(Path(sys.executable).parent / "cptbt"), "plot", str(tmp_path)],
                         capture_output=True, text=True, timeout=120)
    assert res.returncode == 0, res.stderr
    assert f"{tmp_path / 'study.json'} cannot be read as a study's record" in res.stderr
    (tmp_path / "study.json").unlink()  # no record at all: nothing to say
    res = subprocess.run([str(Path(sys.executable).parent / "cptbt"), "plot", str(tmp_path)],
                         capture_output=True, text=True, timeout=120)
    assert res.returncode == 0 and "study.json" not in res.stderr, res.stderr


def test_a_start_at_the_source_is_said_under_the_arrival_criterion() -> None:
    """A review: AB Fig. 10's start at the source made instant successes, unremarked."""
    from cptbt.batch.scenario import starts_at_a_source
    from cptbt.cli.inspect_cmds import load

    root = Path(__file__).resolve().parents[2]
    ab = load(str(root / "missions" / "ab2001_strategy1.yaml"), simulate=True)
    said = starts_at_a_source(ab, [(0.0, 0.0), (20.0, 0.0), (20.5, 0.5)])
    assert said is not None and said.startswith("2 starts within the success radius (1 m)")
    assert starts_at_a_source(ab, [(0.0, 0.0)]) is None
    tro = load(str(root / "missions" / "tro2006_msn007.yaml"), simulate=True)
    src = tro.to_xy(tro.environment.source)  # type: ignore[union-attr]
    assert starts_at_a_source(tro, [(src.x, src.y)]) is None  # a declaration is still to make


def test_a_maintain_study_pairs_t_m_run_by_run() -> None:
    """A review recomputed AB Fig. 9's β differences with paired SEs (smaller than the
    unpaired ones shown): the tables give them."""
    from cptbt.batch.maintain_report import maintain_paired_table

    base = [3.0, 5.0, 7.0, 9.0]
    groups = {f"beta1_deg={b}": [{"replicate": r, "start": 0, "criterion": "maintain",
                                   "T_M": t + (1.0 + 0.1 * r if b else 0.0)}
                                  for r, t in enumerate(base)] for b in (0, 10)}
    groups["beta1_deg=10"][3]["T_M"] = None  # no contact: left out of the pairs
    lines = maintain_paired_table(groups)
    assert "| beta1_deg=10 | beta1_deg=0 | 3 | 1.1 ± 0.1 |" in lines, lines
    assert maintain_paired_table({"a": groups["beta1_deg=0"]}) == []


def test_the_header_counts_the_studys_configurations_not_those_with_runs() -> None:
    """A review: ``cptbt plot`` on a two-configuration sweep stopped before the second had a
    run headed its tables "1 configuration"."""
    from cptbt.batch.comparison import study_header

    meta = {"mission": "m.yaml", "mission_name": "m", "root_seed": 1, "starts": [[0, 0]],
            "runs_per_start": 2, "configs": [{"speed_mps": 1}, {"speed_mps": 2}],
            "sweeps": {"speed_mps": [1, 2]}}
    assert "2 configurations (1 with runs so far);" in study_header(meta, 1)[2]
    assert "2 configurations;" in study_header(meta, 2)[2]
    assert "1 configuration;" in study_header({**meta, "configs": [{}]}, 1)[2]


def test_each_map_panel_draws_its_own_flow_and_the_scale_reaches_every_cell(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A review: a flow-direction sweep's maps drew the mission's current in every panel (in
    one, opposite to the flow flown), and a start of one failure in two (mean 1495 s) was drawn
    in the top colour of a bar ending at 1267 s, its configuration's mean."""
    import matplotlib.pyplot as real_plt

    from cptbt.batch import study_figures
    from cptbt.batch.report import config_geometries

    arrows: list[float] = []
    monkeypatch.setattr(study_figures, "flow_arrow",
                        lambda ax, area, deg, marks: arrows.append(deg))
    kept: list[Any] = []

    class Plt:
        subplots, Rectangle = staticmethod(real_plt.subplots), real_plt.Rectangle

        @staticmethod
        def close(fig: Any) -> None:
            kept.append(fig)

    rows = grid_rows()
    for r in rows:
        r["run_time_limit_s"], r["sim_time_s"] = 1800.0, 600.0
        if r["config"] == 1 and r["start"] == 3:
            r["success"], r["t3"] = r["replicate"] == 0, 1190.0 if r["replicate"] == 0 else None
    study = {"config_geometry": [
        StudyGeometry((0.0, 100.0, -50.0, 50.0), (20.0, 0.0), deg).to_data() for deg in (0, 90)]}
    per = config_geometries(study)
    assert [g.flow_deg for g in per.values()] == [0.0, 90.0]
    groups = compared(rows, None)[0]
    study_figures._map(groups, tmp_path / "m.png", Plt, None, per)
    assert arrows == [0.0, 90.0]
    (fig,) = kept
    vmax = max(c.norm.vmax for ax in fig.axes for c in ax.collections
               if c.norm is not None and c.norm.vmax is not None)
    assert vmax >= (1190.0 + 2 * 1800.0) / 3  # that start's mean, a failure at the limit
    # no compass (a planning-frame study): no north arrow
    assert not [t for ax in fig.axes for t in ax.texts if t.get_text() == "N"]
    real_plt.close(fig)
    from cptbt.frames import PlanningFrame

    rotated = StudyGeometry((0.0, 100.0, -50.0, 50.0), (20.0, 0.0), 0.0, (),
                            PlanningFrame(30.0, 0.0, 0.0))
    study_figures._map(groups, tmp_path / "n.png", Plt, rotated)
    norths = [t for ax in kept[-1].axes for t in ax.texts if t.get_text() == "N"]
    assert len(norths) == 2  # a compass study: a north arrow in each panel
    real_plt.close(kept[-1])
    assert config_geometries({"config_geometry": [{"area": "?"}]}) == {}  # malformed: none


def test_a_swept_list_valued_world_setting_is_tabled(tmp_path: Path) -> None:
    """A review: sweeping ``environment.source`` flew every run, then the report stopped on
    "unhashable type: 'list'" and wrote nothing (the pairing keyed worlds by the values)."""
    rows = grid_rows()
    for r in rows:
        r["environment.source"] = [60, 10] if r["config"] == 0 else [-20, -40]
    names = {p.name for p in write_report(rows, tmp_path, figures=False)}
    assert names == {"tables.md"}
    assert "## Paired comparisons" not in (tmp_path / "tables.md").read_text()  # two worlds


def test_a_report_without_figures_leaves_no_stale_ones(tmp_path: Path) -> None:
    """A review extended a study with ``--no-plots``: the old figures (34 of 40 runs) stood
    beside tables of 48, nothing said."""
    geometry = StudyGeometry((0.0, 100.0, -50.0, 50.0), (20.0, 0.0), 0.0)
    drawn = {p.name for p in write_report(grid_rows(), tmp_path, geometry)}
    assert "success_and_false_declarations.png" in drawn
    assert all((tmp_path / name).exists() for name in drawn)
    assert {p.name for p in write_report(grid_rows(), tmp_path, geometry, figures=False)} == {
        "tables.md"}
    assert not list(tmp_path.glob("*.png"))
    # one configuration now: its rates chart (two or more) is not drawn, and not left either
    write_report(grid_rows(), tmp_path, geometry)
    write_report(grid_rows(configs=1), tmp_path, geometry)
    assert not (tmp_path / "success_and_false_declarations.png").exists()
    assert (tmp_path / "time_to_source_map.png").exists()


def test_a_swept_behaviour_that_drove_little_is_said() -> None:
    """A plug-in author's review: find_plume swept on a study whose vehicle met the plume on
    its way to the start gave rows identical to the decimal (it drove in 1 run of 8), and
    tables.md said nothing of what each behaviour drove."""
    from cptbt.batch.behaviour_times import behaviour_time_table
    from cptbt.batch.study import config_label

    def run(find: float | None, **coords: Any) -> dict[str, Any]:
        return {**coords, "time_find_plume_s": find, "time_maintain_plume_s": 100.0,
                "time_maintain_plume.track_in_s": 60.0, "time_none_s": 5.0}

    def study(path: str, runs: dict[Any, list[dict[str, Any]]]) -> dict[str, list[Any]]:
        """Rows as a study writes them: the sweep's column, the label config_label gives."""
        return {config_label({path: v}, "m"): [{**r, path: v} for r in rows]
                for v, rows in runs.items()}

    groups = study("find_plume.variant", {"billiard": [run(30.0)] + [run(None)] * 3,
                                          "lawnmower": [run(40.0), run(10.0), run(20.0),
                                                        run(30.0)]})
    lines = behaviour_time_table(groups)
    # TRO Fig. 2's priorities order the columns, whatever the rows' order (a review)
    assert "| configuration | maintain_plume | find_plume |" in lines
    assert f"| find_plume=billiard | {400 / 430:.1%} (4/4) | {30 / 430:.1%} (1/4) |" in lines
    assert f"| find_plume=lawnmower | {400 / 500:.1%} (4/4) | {100 / 500:.1%} (4/4) |" in lines
    (note,) = [line for line in lines if line.startswith("**Note")]
    assert note == ("**Note: find_plume, swept here, drove little (find_plume=billiard: 1 of "
                    "4 runs, 30 s in all): the rows compare little of find_plume's settings.**")
    assert behaviour_time_table({"one": groups["find_plume=billiard"]}) == []
    assert not any("Safety's share" in line for line in lines)
    # a setting's label keeps its last key alone (give_up_s=3): still read as find_plume's
    setting = study("find_plume.give_up_s", {3: [run(30.0)] + [run(None)] * 3,
                                             5: [run(None)] * 4})
    assert list(setting) == ["give_up_s=3", "give_up_s=5"]
    assert [line for line in behaviour_time_table(setting) if line.startswith("**Note")]
    # a declaration rule decides rather than drives: a sweep of it is not "drove little"
    # (a review's: 11 runs only the map succeeded in, none the other way)
    rows = {v: [run(30.0) | {"time_declare_source_s": t}] * 4
            for v, t in (("upflow_cluster", None), ("likelihood_map", 3.0))}
    table = behaviour_time_table(study("declare_source.variant", rows))
    assert table[5] == "| configuration | declare_source | maintain_plume | find_plume |", table
    assert not [line for line in table if line.startswith("**Note")]
    # a sweep of one of its settings is noted as any other (a diff review: the fly-by's,
    # labelled flyby=False / flyby=True)
    flyby = study("declare_source.flyby", dict(zip((False, True), rows.values(), strict=True)))
    assert list(flyby) == ["flyby=False", "flyby=True"]
    assert [line for line in behaviour_time_table(flyby) if line.startswith("**Note")]
    # a diff review: the two tables' safety shares differed, and neither said why
    groups["find_plume=billiard"][0] |= {"time_safety_s": 12.0, "safety_entering_s": 10.0}
    assert any(line.startswith("Safety's share here includes bringing the vehicle in")
               for line in behaviour_time_table(groups))


def test_the_maintain_time_se_counts_plumes() -> None:
    """T_M's SE had treated every start of a replicate as independent (left over from the
    session-27 change of the other tables): over 3 plumes of 4 starts whose T_M differ by plume
    the SE is the clustered one, larger than the runs'."""
    from cptbt.batch.intervals import mean_sem
    from cptbt.batch.maintain_report import maintain_table

    rows = [{**BASE, "criterion": "maintain", "replicate": r, "start": i,
             "T_M": 10.0 * r + 0.5 * i} for r in range(3) for i in range(4)]
    values = [float(r["T_M"]) for r in rows]
    iid = statistics.stdev(values) / math.sqrt(len(values))
    se = mean_sem(rows, values)
    assert se > 1.5 * iid
    (line,) = [ln for ln in maintain_table({"a": rows}) if ln.startswith("| a ")]
    assert f"{statistics.fmean(values):.1f} ± {se:.1f}" in line, line


def test_the_map_colour_scale_ends_at_the_largest_cell() -> None:
    """A researcher's review: the scale's top was the longest run's whole time, the drive home
    included (1360 s where no cell passed 564 s), so the map used under half its colours. A
    failure still counts at the time limit, so a failed start tops the scale."""
    from cptbt.batch.study_figures import colour_top

    def run(x: float, t3: float | None, sim: float) -> dict[str, Any]:
        return {**BASE, "start_x": x, "start_y": 0.0, "success": t3 is not None, "t3": t3,
                "sim_time_s": sim, "run_time_limit_s": 1800.0}

    groups = {"a": [run(0.0, 500.0, 1360.0), run(0.0, 600.0, 900.0), run(50.0, 200.0, 300.0)]}
    assert colour_top(groups) == pytest.approx(550.0)
    groups["b"] = [run(0.0, None, 1800.0), run(50.0, 100.0, 200.0)]
    assert colour_top(groups) == pytest.approx(1800.0)
