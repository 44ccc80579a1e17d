"""``cptbt run --north-up``: trajectory.png in east and north metres, north up."""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("matplotlib")

from matplotlib.figure import Figure

from cptbt.batch.compass import north_up_turn
from cptbt.batch.engine import simulate
from cptbt.batch.figures import plume_grid, trajectory_figure
from cptbt.batch.scenario import launch_pose, to_sim_params
from cptbt.cli.inspect_cmds import load
from cptbt.types import Point

ROOT = Path(__file__).resolve().parents[2]
MSN007 = ROOT / "missions" / "tro2006_msn007.yaml"


def test_the_turn_takes_planning_points_to_the_files_north_east() -> None:
    """MSN007's corners and home are given in north-east metres; turned, each is (east,
    north) as the file has it, and +x points along the OpArea's compass bearing."""
    mission = load(str(MSN007), simulate=True)
    area = mission.op_area_geometry()
    turn = north_up_turn(area)
    for n, e in [*mission.op_area.corners, mission.home]:
        q = mission.to_xy([n, e])
        assert turn.transform((q.x, q.y)) == pytest.approx([e, n], abs=1e-6)
    b = math.radians(area.frame.x_bearing_deg)
    step = turn.transform((1.0, 0.0)) - turn.transform((0.0, 0.0))
    assert step == pytest.approx([math.sin(b), math.cos(b)])  # east, north of the bearing


def north_up_figure(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> tuple[Figure, float]:
    """MSN007 flown 5 s and drawn north up (not saved); and its mean current's bearing."""
    mission = load(str(MSN007), simulate=True)
    mission = mission.model_copy(update={"mission_a": None, "time_limit_s": 5.0})
    params = to_sim_params(mission)
    (run,), _, _ = simulate(mission, params, [launch_pose(mission)], trace=True,
                            plume_grid=plume_grid(mission.op_area_geometry()))
    seen: list[Figure] = []
    monkeypatch.setattr(Figure, "savefig", lambda self, *a, **k: seen.append(self))
    trajectory_figure(tmp_path / "t.png", run, mission, Point(*params.source_xy_m), "t",
                      flow_deg=params.flow.mean_dir_deg, north_up=True)
    bearing = mission.op_area_geometry().frame.compass_deg(params.flow.mean_dir_deg)
    return seen[0], bearing


def test_every_mark_is_drawn_at_its_east_and_north(tmp_path: Path,
                                                   monkeypatch: pytest.MonkeyPatch) -> None:
    """Home (a marker), the OpArea (a patch) and the axes: east to the right, north up."""
    fig, _ = north_up_figure(monkeypatch, tmp_path)
    ax = fig.axes[0]
    assert ax.get_ylabel() == "north (m)" and ax.get_xlabel().startswith("east (m)")
    assert not ax.yaxis_inverted()
    mission = load(str(MSN007), simulate=True)
    n, e = mission.home
    (home,) = [ln for ln in ax.lines if ln.get_label() == "home"]
    at = home.get_transform().transform(np.column_stack(home.get_data()))[0]
    assert at == pytest.approx(ax.transData.transform((e, n)), abs=0.5)
    (box,) = [p for p in ax.patches if type(p).__name__ == "Rectangle"]
    drawn = ax.transData.inverted().transform(
        box.get_transform().transform(box.get_path().vertices[:4]))
    for n, e in mission.op_area.corners:  # TRO's corners are a rectangle give or take ~2 m
        assert np.hypot(*(drawn - (e, n)).T).min() < 4.0, (drawn, e, n)


def test_the_current_points_its_compass_way_and_its_label_clears_it(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The arrow runs along the current's bearing on the page; its label stands off the
    arrow (placed for a y-down page, it had hidden the head of MSN007's south-east current)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    fig, bearing = north_up_figure(monkeypatch, tmp_path)
    ax = fig.axes[0]
    renderer = FigureCanvasAgg(fig).get_renderer()
    fig.draw(renderer)
    arrow = next(t for t in ax.texts if t.get_text() == "")  # drawn first: the current's
    tail = np.asarray(arrow.anncoords.transform(arrow.xyann))
    head = np.asarray(arrow.xycoords.transform(arrow.xy))
    dx, dy = head - tail
    assert math.degrees(math.atan2(dx, dy)) % 360 == pytest.approx(bearing, abs=0.5)
    (label,) = [t for t in ax.texts if t.get_text() == "mean current"]
    assert not label.get_window_extent(renderer).overlaps(
        arrow.arrow_patch.get_window_extent(renderer))


@pytest.mark.parametrize(("also", "said"), [
    ((), "--north-up: the mission has no compass (frame: planning): trajectory.png is drawn in "
         "the planning frame"),
    (("--no-figure",), "--north-up: no trajectory.png is drawn (--no-figure)")])
def test_north_up_where_it_changes_nothing_is_said(tmp_path: Path, also: tuple[str, ...],
                                                   said: str) -> None:
    """A planning-frame mission has no north: the figure stays in the planning frame, and
    the command says so rather than passing the option over; so it does without a figure."""
    done = subprocess.run(
        [sys.executable, "-m", "cptbt", "run", str(ROOT / "missions" / "ab2001_strategy3.yaml"),
         "--north-up", *also, "--out", str(tmp_path / "r")],
        capture_output=True, text=True, check=False)
    assert done.returncode == 0, done.stderr
    assert said in done.stderr
