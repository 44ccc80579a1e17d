"""trajectory.png draws a north only where the mission says where north is."""

from __future__ import annotations

from pathlib import Path

import pytest

pytest.importorskip("matplotlib")

from matplotlib.figure import Figure

from cptbt.batch.engine import VehicleRun, simulate
from cptbt.batch.figures import plume_grid, trajectory_figure
from cptbt.batch.scenario import launch_pose, to_sim_params
from cptbt.cli.inspect_cmds import load
from cptbt.mission import MissionBase
from cptbt.types import Point

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.parametrize(("name", "north"), [("ab2001_strategy3.yaml", False),    # planning
                                             ("oblique_flow.yaml", True)])
def test_north_arrow_only_with_a_compass(name: str, north: bool, tmp_path: Path,
                                         monkeypatch: pytest.MonkeyPatch) -> None:
    from matplotlib.figure import Figure

    mission = load(str(ROOT / "missions" / name), simulate=True)
    mission = mission.model_copy(update={"mission_a": None, "time_limit_s": 5.0})
    params = to_sim_params(mission)
    grid = plume_grid(mission.op_area_geometry())
    (run,), _, _ = simulate(mission, params, [launch_pose(mission)], trace=True, plume_grid=grid)
    seen: list[Figure] = []
    monkeypatch.setattr(Figure, "savefig", lambda self, *a, **k: seen.append(self))
    trajectory_figure(tmp_path / "t.png", run, mission, Point(*params.source_xy_m), "t",
                      threshold=mission.perception.threshold)
    ax = seen[0].axes[0]
    texts = {t.get_text() for t in ax.texts}
    assert ("N" in texts) == north
    assert ("compass bearing " in ax.get_xlabel()) == north  # "... bearing 0.0°" or none given


def test_a_long_thin_area_gets_a_page_of_its_shape(tmp_path: Path,
                                                   monkeypatch: pytest.MonkeyPatch) -> None:
    """A 300 x 30 m box fills the page's width at a fraction of its height: the page shrinks
    to it instead of leaving most of it blank (an ordinary box keeps the usual height)."""
    from matplotlib.figure import Figure

    base = load(str(ROOT / "missions" / "oblique_flow.yaml"), simulate=True)
    heights = {}
    seen: list[Figure] = []
    monkeypatch.setattr(Figure, "savefig", lambda self, *a, **k: seen.append(self))
    for name, corners in (("usual", None),
                          ("thin", [[150, 15], [-150, 15], [-150, -15], [150, -15]])):
        mission = base.model_copy(update={"time_limit_s": 5.0})
        if corners is not None:
            area = mission.op_area.model_copy(update={"corners": corners})
            mission = mission.model_copy(update={"op_area": area, "start": [-100, 0],
                                                 "home": [-120, 0]})
        params = to_sim_params(mission)
        grid = plume_grid(mission.op_area_geometry())
        (run,), _, _ = simulate(mission, params, [launch_pose(mission)], trace=True,
                                plume_grid=grid)
        trajectory_figure(tmp_path / "t.png", run, mission, Point(*params.source_xy_m), "t")
        heights[name] = float(seen[-1].get_size_inches()[1])
    assert heights["usual"] == pytest.approx(5.6)
    assert heights["thin"] < 4.0


@pytest.mark.parametrize("centre_lon", [179.9995, -179.9995, 0.0])
def test_longitude_lines_across_the_antimeridian(centre_lon: float) -> None:
    """The graticule took min/max of the corners' longitudes: across +-180 that spanned the
    globe and no longitude line was drawn. Lines and labels on both sides of it now."""
    import matplotlib.pyplot as plt

    from cptbt.batch.compass import _graticule

    base = load(str(ROOT / "missions" / "oblique_flow.yaml"), simulate=True)
    area_spec = base.op_area.model_copy(update={"geodetic_centre_deg": (-20.0, centre_lon)})
    mission = base.model_copy(update={"op_area": area_spec})
    fig, ax = plt.subplots()
    _graticule(ax, mission, mission.op_area_geometry())
    labels = [t.get_text() for t in ax.texts]
    plt.close(fig)
    lon_labels = [s for s in labels if s.endswith(("E", "W", "180°00.000'"))]
    assert len(ax.lines) >= 4 and len(lon_labels) >= 2, labels
    if centre_lon == 179.9995:  # the 120 m E-W box reaches 0.0011 deg past 180
        # the line past 180 is labelled by the 180° meridian itself, neither E nor W
        assert {s[-1] for s in lon_labels} == {"E", "'"} and "180°00.000'" in labels, labels
    assert not any("60.000'" in s for s in labels), labels  # 180°00.000', not 179°60.000'E


@pytest.mark.parametrize(("value", "hemispheres", "text"), [
    (32.98083333, "NS", "32°58.850'N"),
    (32.9999999, "NS", "33°00.000'N"),     # rounded before it is split: not 32°60.000'N
    (179.99999999, "EW", "180°00.000'"),   # the antimeridian: neither E nor W
    (-180.0, "EW", "180°00.000'"),
    (-179.9999, "EW", "179°59.994'W"),
    (-118.0875, "EW", "118°05.250'W"),     # minutes keep two digits
    (-0.0000001, "NS", "0°00.000'N"),      # nothing south of the equator to name
    (-33.9, "NS", "33°54.000'S"),
])
def test_degrees_and_minutes(value: float, hemispheres: str, text: str) -> None:
    from cptbt.batch.compass import _dm

    assert _dm(value, hemispheres) == text


def test_the_mean_current_is_drawn_when_given(tmp_path: Path,
                                              monkeypatch: pytest.MonkeyPatch) -> None:
    from matplotlib.figure import Figure

    mission = load(str(ROOT / "missions" / "oblique_flow.yaml"), simulate=True)
    mission = mission.model_copy(update={"time_limit_s": 5.0})
    params = to_sim_params(mission)
    (run,), _, _ = simulate(mission, params, [launch_pose(mission)], trace=True,
                            plume_grid=plume_grid(mission.op_area_geometry()))
    seen: list[Figure] = []
    monkeypatch.setattr(Figure, "savefig", lambda self, *a, **k: seen.append(self))
    for flow in (None, params.flow.mean_dir_deg):
        trajectory_figure(tmp_path / "t.png", run, mission, Point(*params.source_xy_m), "t",
                          flow_deg=flow)
    texts = [{t.get_text() for t in fig.axes[0].texts} for fig in seen]
    assert "mean current" not in texts[0] and "mean current" in texts[1]
    arrow = next(c for c in seen[1].axes[0].texts if c.get_text() == "")  # the annotation
    (x0, y0), (x1, y1) = arrow.xyann, arrow.xy
    # Toward 240 deg compass in a box with x north: mostly west (-y), partly south (-x).
    assert x1 < x0 and y1 < y0 and abs(y1 - y0) > abs(x1 - x0)


def drawn(mission: MissionBase, monkeypatch: pytest.MonkeyPatch, tmp_path: Path,
          title: str = "t", seed: int | None = None, flow: bool = True,
          ) -> tuple[Figure, VehicleRun]:
    """The mission flown from its launch, and its trajectory figure (not saved)."""
    from matplotlib.figure import Figure

    params = to_sim_params(mission, seed)
    (run,), _, _ = simulate(mission, params, [launch_pose(mission)], trace=True,
                            plume_grid=plume_grid(mission.op_area_geometry()))
    seen: list[Figure] = []
    monkeypatch.setattr(Figure, "savefig", lambda self, *a, **k: seen.append(self))
    trajectory_figure(tmp_path / "t.png", run, mission, Point(*params.source_xy_m), title,
                      flow_deg=params.flow.mean_dir_deg if flow else None)
    return seen[0], run


def arrow_tail(fig: Figure) -> tuple[float, float]:
    """Where the mean current's arrow starts (the annotation without text)."""
    arrow = next(c for c in fig.axes[0].texts if c.get_text() == "")
    return arrow.xyann  # type: ignore[no-any-return]


def test_the_mean_current_keeps_off_the_track(tmp_path: Path,
                                              monkeypatch: pytest.MonkeyPatch) -> None:
    """In small_oparea (50 x 50 m), started in the usual corner (bottom left, y drawn down),
    the arrow goes to the corner farthest from the track, never the north arrow's (top left)."""
    mission = load(str(ROOT / "missions" / "small_oparea.yaml"), simulate=True)
    corner = mission.to_ne(Point(-17.0, 17.0))
    mission = mission.model_copy(update={"start": list(corner), "time_limit_s": 120.0})
    fig, run = drawn(mission, monkeypatch, tmp_path, seed=3)
    tail = arrow_tail(fig)
    trace = run.trace
    assert trace is not None
    gap = min(((x - tail[0]) ** 2 + (y - tail[1]) ** 2) ** 0.5
              for x, y in zip(trace["x"], trace["y"], strict=True))
    assert gap > 3.0, gap  # the usual corner: the track starts at the tail
    assert not (tail[0] < 0 and tail[1] < 0)  # not top left (y drawn down): the north's
    assert mission.op_area_geometry().contains(*tail)


def test_both_panels_have_their_numbers(tmp_path: Path,
                                        monkeypatch: pytest.MonkeyPatch) -> None:
    """With the map panel below, the top panel's x axis keeps its tick labels."""
    mission = load(str(ROOT / "missions" / "two_sources.yaml"), simulate=True)
    fig, _ = drawn(mission.model_copy(update={"time_limit_s": 30.0}), monkeypatch, tmp_path,
                   flow=False)
    top, bottom = (a for a in fig.axes if a.get_label() != "<colorbar>")
    fig.canvas.draw()
    for ax in (top, bottom):
        assert any(t.get_visible() and t.get_text() for t in ax.get_xticklabels()), ax


def test_a_long_title_is_wrapped_to_the_panel(tmp_path: Path,
                                              monkeypatch: pytest.MonkeyPatch) -> None:
    """A study row's title names its sweep; one long line ran off the page's left edge."""
    words = ("two_sources [declare_source.upflow_known_veto=True, "
             "declare_source.known_plume_max_prob=0.2]")
    title = (f"{words}, study row 26 (c002-r00002, start 0): declared, 2 of 3 sources found, "
             "1 false")
    mission = load(str(ROOT / "missions" / "two_sources.yaml"), simulate=True)
    fig, _ = drawn(mission.model_copy(update={"time_limit_s": 5.0}), monkeypatch, tmp_path,
                   title=f"{title}\nsecond line", flow=False)
    assert fig.axes[0].get_title().replace("\n", " ") == f"{title} second line"
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    renderer = FigureCanvasAgg(fig).get_renderer()  # at the figure's own resolution
    fig.draw(renderer)
    box = fig.axes[0].title.get_window_extent(renderer)
    assert box.x0 >= 0 and box.x1 <= fig.bbox.x1, (box, fig.bbox)  # on the page


def test_the_mean_current_keeps_off_the_north_arrow(tmp_path: Path,
                                                    monkeypatch: pytest.MonkeyPatch) -> None:
    """A strip whose x points west draws north downward, from the top-left corner into the
    bottom-left one: with the track all over the strip, the arrow had gone there, onto the N."""
    mission = load(str(ROOT / "tests/e2e/data/north_down_strip.yaml"), simulate=True)
    fig = drawn(mission, monkeypatch, tmp_path)[0]
    tail = arrow_tail(fig)
    (label,) = [t.get_position() for t in fig.axes[0].texts if t.get_text() == "N"]
    north = [t.xyann for t in fig.axes[0].texts if t.get_text() == ""][1]  # drawn second
    for x, y in (label, north):
        assert ((x - tail[0]) ** 2 + (y - tail[1]) ** 2) ** 0.5 > 15.0, (tail, x, y)


def test_the_north_arrow_takes_a_corner_clear_of_the_markers() -> None:
    """A review's start marker sat under the north arrow, drawn always in the upper-left
    corner: the arrow takes the corner with the fewest markers near it (upper left among
    equals), and never one it would leave the OpArea from."""
    import numpy as np

    from cptbt.batch.compass import _north_points, north_corner

    mission = load(str(ROOT / "missions" / "small_oparea.yaml"), simulate=True)
    area = mission.op_area_geometry()
    none = np.empty((0, 2))
    assert north_corner(area, none, none) == 0
    on_upper_left = _north_points(area, 0)[8:9]  # a marker on the arrow's middle
    k = north_corner(area, on_upper_left, none)
    assert k != 0
    arrow = _north_points(area, k)
    assert area.contains_array(arrow[:, 0], arrow[:, 1]).all()
    assert np.hypot(*(arrow - on_upper_left).T).min() > 5.0


def test_a_marker_at_the_plots_edge_is_drawn_whole(tmp_path: Path,
                                                   monkeypatch: pytest.MonkeyPatch) -> None:
    """A review's start outside the OpArea, at the plume grid's corner (10 m out on each
    axis), was half cut off at the plot's edge: every marker gets room around it."""
    mission = load(str(ROOT / "missions" / "small_oparea.yaml"), simulate=True)
    corner = Point(35.0, 35.0)  # planning: 10 m beyond the 50 m square's corner, both ways
    mission = mission.model_copy(update={"start": list(mission.to_ne(corner)),
                                         "time_limit_s": 5.0})
    fig, _ = drawn(mission, monkeypatch, tmp_path, seed=3)
    ax = fig.axes[0]
    x1, y1 = max(ax.get_xlim()), max(ax.get_ylim())  # y drawn down: max is the bottom
    pad = 0.04 * 50.0
    assert x1 >= corner.x + pad - 1e-9 and y1 >= corner.y + pad - 1e-9, (x1, y1)


def test_graticule_labels_do_not_overlap(tmp_path: Path,
                                         monkeypatch: pytest.MonkeyPatch) -> None:
    """On a rotated geodetic box the latitude and longitude lines both leave through the top
    edge: their labels had been drawn over each other (33°54.03… on 151°14.940'E). Each label
    now stands where it meets no other, along its line."""
    mission = load(str(ROOT / "tests/e2e/data/geodetic_rotated.yaml"), simulate=True)
    mission = mission.model_copy(update={"time_limit_s": 5.0})
    params = to_sim_params(mission)
    (run,), _, _ = simulate(mission, params, [launch_pose(mission)], trace=True)
    seen: list[Figure] = []
    monkeypatch.setattr(Figure, "savefig", lambda self, *a, **k: seen.append(self))
    trajectory_figure(tmp_path / "t.png", run, mission, Point(*params.source_xy_m), "t",
                      threshold=mission.perception.threshold)
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    fig = seen[0]
    ax = fig.axes[0]
    canvas = FigureCanvasAgg(fig)  # closed after saving: a canvas of its own to measure on
    canvas.draw()
    renderer = canvas.get_renderer()
    shown = [t for t in ax.texts if t.get_visible() and t.get_text()]
    grid = [t for t in shown if t.get_text()[-1] in "NSEW" and "°" in t.get_text()]
    assert len(grid) >= 8, [t.get_text() for t in grid]  # most of the lines keep a label
    boxes = [t.get_window_extent(renderer) for t in shown]
    area = mission.op_area_geometry()  # and off the OpArea's border (they had sat on it)
    (x0, y0), (x1, y1) = ax.transData.transform([(area.xmin, area.ymin), (area.xmax, area.ymax)])
    for t in grid:
        box = t.get_window_extent(renderer)
        assert min(x0, x1) < box.x0 and box.x1 < max(x0, x1), t.get_text()
        assert min(y0, y1) < box.y0 and box.y1 < max(y0, y1), t.get_text()
    for i, a in enumerate(boxes):
        for j in range(i + 1, len(boxes)):
            assert not a.overlaps(boxes[j]), (shown[i].get_text(), shown[j].get_text())


def test_the_map_panel_is_titled_and_several_declarations_are_numbered_in_order() -> None:
    """A review could not tell which of two declared sources came first, nor what the second
    panel was."""
    import numpy as np

    from cptbt.batch.figures import pyplot
    from cptbt.batch.map_figure import map_panel
    from cptbt.frames import OpArea
    from cptbt.types import SourceBelief

    area = OpArea(xmin=0.0, xmax=100.0, ymin=-50.0, ymax=50.0)
    xs, ys = np.linspace(5, 95, 10), np.linspace(-45, 45, 10)
    post = np.full((10, 10), 0.01)
    belief = SourceBelief(t=300.0, xs=xs, ys=ys, posterior=post)
    first, second = Point(20.0, 10.0), Point(60.0, -20.0)
    plt = pyplot()
    fig, ax = plt.subplots()
    map_panel(ax, belief, area, [Point(21.0, 9.0), Point(58.0, -22.0)], [first, second], {},
              plt)
    assert ax.get_title().endswith("map at the last declaration")  # not "the declaration's"
    numbers = {t.get_text(): t.xy for t in ax.texts if t.get_text()}
    assert numbers == {"1": (first.x, first.y), "2": (second.x, second.y)}
    fig2, one = plt.subplots()
    map_panel(one, belief, area, [Point(21.0, 9.0)], [first], {}, plt)
    assert not [t for t in one.texts if t.get_text()]  # one declaration: nothing to order
    assert one.get_title().endswith("map at the declaration")
    plt.close(fig)
    plt.close(fig2)


def test_home_is_drawn_with_the_radius_that_ends_the_run(tmp_path: Path,
                                                         monkeypatch: pytest.MonkeyPatch) -> None:
    """A review read the line home stopping 8-12 m short of the marker as a fault: the run
    ends within ``home_radius_m`` of home (by the vehicle's estimate), now drawn."""
    from matplotlib.patches import Circle

    mission = load(str(ROOT / "missions" / "small_oparea.yaml"), simulate=True)
    fig, run = drawn(mission, monkeypatch, tmp_path)
    assert run.t3 is not None
    home = mission.to_xy(mission.home)
    (circle,) = [p for p in fig.axes[0].patches if isinstance(p, Circle)]
    assert circle.get_radius() == 10.0 and tuple(circle.center) == (home.x, home.y)
    assert circle.get_label() == "home radius 10 m (by nav. estimate)"


def test_a_long_legend_entry_wraps(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A longer legend entry squeezed the panel, or pushed the y label off the page's left
    edge (seen on the small OpArea): long entries wrap, and the panel keeps its size."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    from cptbt.batch.figures import LEGEND_CHARS

    mission = load(str(ROOT / "missions" / "small_oparea.yaml"), simulate=True)
    mission = mission.model_copy(update={"time_limit_s": 30.0})
    usual, run = drawn(mission, monkeypatch, tmp_path)
    long_name = "find_plume.a_plug_in_variant_with_a_long_descriptive_name (searching)"
    trace = run.trace
    assert trace is not None
    renamed = {**trace, "active": [long_name] * len(trace["active"])}
    monkeypatch.setattr(type(run), "trace", property(lambda self: renamed))
    seen: list[Figure] = []
    monkeypatch.setattr(Figure, "savefig", lambda self, *a, **k: seen.append(self))
    trajectory_figure(tmp_path / "t.png", run, mission, mission.to_xy(mission.home),
                      "t")
    boxes = []
    for fig in (usual, seen[0]):
        renderer = FigureCanvasAgg(fig).get_renderer()
        fig.draw(renderer)
        boxes.append(fig.axes[0].get_window_extent(renderer))
        assert fig.axes[0].yaxis.label.get_window_extent(renderer).x0 >= 0.0, fig is usual
    assert boxes[1].width == pytest.approx(boxes[0].width, rel=0.02), boxes
    (entry,) = [t.get_text() for t in seen[0].legends[0].get_texts() if "plug_in" in t.get_text()]
    lines = entry.split("\n")
    assert len(lines) > 1 and all(len(x) <= LEGEND_CHARS for x in lines), lines


def test_a_graticule_label_keeps_off_the_arrows() -> None:
    """A review's Svalbard figure drew 14°59.700'E on the north arrow's shaft: a label's
    place must be clear of the arrows as well as of the texts."""
    import matplotlib.pyplot as plt

    from cptbt.batch.compass import _place_labels

    fig, ax = plt.subplots()
    ax.set_xlim(0, 100)
    ax.set_ylim(0, 100)
    ax.annotate("", xy=(50, 90), xytext=(50, 10), arrowprops={"arrowstyle": "-|>", "lw": 1.5})
    label = ax.text(50, 50, "14°59.700'E", ha="center", va="center", fontsize=7)
    fig.canvas.draw()  # as trajectory_figure does before placing the labels
    _place_labels(fig, ax, [(label, [(50.0, 50.0), (80.0, 50.0)])])
    plt.close(fig)
    assert label.get_visible() and label.get_position() == (80.0, 50.0)


def test_a_graticule_label_keeps_off_the_gap_between_an_arrow_and_its_label() -> None:
    """A review's 180°00.000' stood between "mean current" and its arrow, clear of both but
    read as the current's: the two are one block (their shared gid)."""
    import matplotlib.pyplot as plt

    from cptbt.batch.compass import _place_labels

    fig, ax = plt.subplots()
    ax.set_xlim(0, 100)
    ax.set_ylim(0, 100)
    ax.annotate("", xy=(50, 20), xytext=(50, 40), arrowprops={"arrowstyle": "-|>"},
                gid="mean current")
    ax.text(50, 60, "mean current", ha="center", va="bottom", fontsize=7, gid="mean current")
    label = ax.text(50, 50, "180°00.000'", ha="center", va="center", fontsize=7)
    fig.canvas.draw()
    _place_labels(fig, ax, [(label, [(50.0, 50.0), (80.0, 50.0)])])
    plt.close(fig)
    assert label.get_position() == (80.0, 50.0)


def test_the_saved_figure_keeps_its_y_label_on_the_page(tmp_path: Path) -> None:
    """A review's 300 x 120 m box with the current at 45°: the saved trajectory.png had its y
    label cut at the page's left edge (the layout, settled in one pass at saving, had not
    converged). The figure is made as `cptbt run` makes it and its left edge read: nothing
    drawn there."""
    from matplotlib.image import imread

    from cptbt.cli import main

    assert main(["run", str(ROOT / "tests/e2e/data/wide_oblique.yaml"), "--out",
                 str(tmp_path), "--quiet"]) == 0
    image = imread(str(tmp_path / "trajectory.png"))
    edge = image[:, :3, :3]  # the first three columns, RGB
    assert edge.min() > 0.95, "something is drawn at the page's left edge"


def test_mission_a_before_and_after_the_amp_are_drawn_apart() -> None:
    """A review: Mission A before and after the AMP shared one style and one legend entry."""
    from cptbt.batch.figures import _phase_style

    before, after = _phase_style("mission_a.waypoints"), _phase_style("mission_a.resumed")
    assert before is not None and after is not None and before != after
    assert before[2] == "Mission A (vehicle)" and after[2] == "Mission A resumed (vehicle)"
    assert _phase_style("post_mission") == after  # the vehicle's own mission, finished
    assert _phase_style("amp.override") is None   # the AMP's part: coloured by behaviour


def test_the_plume_snapshot_covers_a_source_outside_the_oparea() -> None:
    """A review's source 20 m beyond the up-flow wall (``allow_outside: [source]``) was drawn
    in blank water, its plume starting at the grid's edge 10 m out."""
    from cptbt.batch.figures import plume_grid
    from cptbt.frames import OpArea
    from cptbt.types import Point

    area = OpArea(-120.0, 120.0, -50.0, 50.0)
    xs, ys = plume_grid(area)
    assert (xs[0], xs[-1], ys[0], ys[-1]) == (-130.0, 130.0, -60.0, 60.0)
    xs, ys = plume_grid(area, cover=[Point(-140.0, 15.0), Point(0.0, 75.0)])
    assert (xs[0], xs[-1], ys[0], ys[-1]) == (-150.0, 130.0, -60.0, 85.0)
    assert len(xs) <= 400 and len(ys) <= 300
