"""Figures of runs and studies (matplotlib, imported lazily: it is the ``plot`` extra)."""

from __future__ import annotations

import math
import textwrap
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from cptbt.batch.compass import (
    _graticule,
    _north_arrow,
    _north_points,
    _place_labels,
    north_corner,
    north_up_turn,
    turn_north_up,
)
from cptbt.batch.engine import VehicleRun
from cptbt.batch.map_figure import (
    VERIFYING_COLOUR,
    VERIFYING_LABEL,
    map_panel,
    source_markers,
)
from cptbt.frames import OpArea
from cptbt.mission import MissionBase
from cptbt.types import Point, SourceBelief

BEHAVIOUR_COLOURS = {
    "safety": "#d62728",
    "declare_source": "#9467bd",
    "maintain_plume": "#2ca02c",
    "track_in": "#2ca02c",
    "track_out": "#98df8a",
    "reacquire_plume": "#ff7f0e",
    "find_plume": "#1f77b4",
    "move_to_field": "#7f7f7f",
    "return_home": "#8c564b",
    "none": "#bbbbbb",
}


PHASE_STYLES = {
    "mission_a": ("#555555", "--", "Mission A (vehicle)"),
    # resumed after the AMP: lighter, so the two halves read apart (a review)
    "mission_a.resumed": ("#9a9a9a", "--", "Mission A resumed (vehicle)"),
    "return_to_break_off": ("#8c564b", ":", "return to break-off"),
    "amp.give_back": ("#8c564b", ":", "return to break-off"),
    "pre_launch": ("#555555", "--", "Mission A (vehicle)"),
    "post_mission": ("#9a9a9a", "--", "Mission A resumed (vehicle)"),
}
"""How the phases outside the AMP override are drawn (trace column ``phase``)."""


def _phase_style(phase: str) -> tuple[str, str, str] | None:
    return PHASE_STYLES.get(phase) or PHASE_STYLES.get(phase.split(".")[0])


ACTIVITY_COLOURS = {
    "check leg": "#e377c2",
    "visit": "#393b79",
    "search on": "#bcbd22",
    "fly-by": "#8c6d31",
    "to source": "#9467bd",
    "home": "#8c564b",
}
"""Colours of what a behaviour with several jobs is doing (the active name's "(...)" part)."""

DASHED_ACTIVITIES = frozenset({"visit", "home"})
"""Jobs drawn dashed, apart from a solid track of a like colour (and from the dotted trip back
to the break-off point)."""

LEGEND_CHARS = 42
"""trajectory.png's legend entries wrap at this many characters (about the 3.5 in its page
leaves the legend, at 8 pt)."""


def _split(active: str) -> tuple[str, str]:
    """An active name's behaviour and job: ``"a.b (check leg)"`` → ``("a.b", "check leg")``."""
    name, _, activity = active.partition(" (")
    return name, activity.removesuffix(")")


def _line_style(active: str) -> str:
    return "--" if _split(active)[1] in DASHED_ACTIVITIES else "-"


def _colour(active: str) -> str:
    name, activity = _split(active)
    if activity in ACTIVITY_COLOURS:
        return ACTIVITY_COLOURS[activity]
    for key in (name, name.split(".")[-1], name.split(".")[0]):
        if key in BEHAVIOUR_COLOURS:
            return BEHAVIOUR_COLOURS[key]
    return "#17becf"


def pyplot() -> Any:
    """matplotlib.pyplot on a non-interactive backend, or a clear error without the extra."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError as exc:  # pragma: no cover - depends on the install
        raise RuntimeError("figures need matplotlib: pip install 'cptbt[plot]'") from exc
    return plt


def plume_grid(area: OpArea, margin_m: float = 10.0,
               cover: Sequence[Point] = ()) -> tuple[np.ndarray, np.ndarray]:
    """A grid over the OpArea and the points ``cover`` (the true sources: one allowed outside
    had its star in blank water, a review), with a margin, for plume snapshots, about 1-2 m
    per cell (at most 400 x 300)."""
    xs = [area.xmin, area.xmax, *(p.x for p in cover)]
    ys = [area.ymin, area.ymax, *(p.y for p in cover)]
    x0, x1 = min(xs) - margin_m, max(xs) + margin_m
    y0, y1 = min(ys) - margin_m, max(ys) + margin_m
    nx = int(min(400, max(80, x1 - x0)))
    ny = int(min(300, max(60, y1 - y0)))
    return np.linspace(x0, x1, nx), np.linspace(y0, y1, ny)


def trajectory_figure(
    path: Path,
    run: VehicleRun,
    mission: MissionBase,
    source: Point,
    title: str,
    *,
    threshold: float | None = None,
    waypoints: Sequence[Point] | None = None,
    sources: Sequence[Point] = (),
    goal: Point | None = None,
    flow_deg: float | None = None,
    north_up: bool = False,
) -> None:
    """The run in the planning frame, drawn as TRO Figs. 10–12 (y positive down); with
    ``north_up`` (and a compass: not a ``planning``-frame mission), in east and north metres of
    the mission's N-E frame instead, north up.

    Drawn: the plume when the source was declared (``run.plume``, with its colour bar and time),
    the OpArea, the track coloured by the active behaviour, detections and lost contacts, the
    run's start, the mission's start point and home, the true and declared sources, a north arrow
    with the bearing of +x, and for missions with a geodetic anchor a latitude/longitude
    graticule. With a ``phase`` column in the trace (a phased run) the parts outside the AMP
    override are drawn dashed (Mission A) or dotted (return to the break-off point), and the
    planned Mission A ``waypoints`` as a light dashed line (TRO Fig. 1). ``sources`` are every
    true source (default: ``source``); ``goal`` is the run's move-to-field goal when it is not
    the mission's start point (a study row's start); ``flow_deg`` (planning angle the mean
    current flows toward) draws an arrow in the OpArea's corner. When the run's declaration kept a
    source-likelihood map, a second panel draws its posterior at the (last) declaration (or when
    the search for more sources gave up) with the declared points, the withdrawn fly-by
    candidates and the true sources.
    """
    plt = pyplot()
    area = mission.op_area_geometry()
    belief = run.source_map if isinstance(run.source_map, SourceBelief) else None
    truth = list(sources) or [source]
    # As wide as the OpArea's shape needs (a square AB area would leave half the page blank),
    # plus room for the legend on the right.
    turn = north_up_turn(area) if north_up and mission.frame != "planning" else None
    if turn is None:
        aspect = (area.xmax - area.xmin) / max(area.ymax - area.ymin, 1e-9)
    else:  # the turned OpArea's bounding box
        box = turn.transform(np.array([(q.x, q.y) for q in area.corners]))
        aspect = float(np.ptp(box[:, 0]) / max(float(np.ptp(box[:, 1])), 1e-9))
    # North up, a turned OpArea is seldom wide: up to 6 in of drawing high, not 3 (a first
    # north-up MSN007 drew its 13-m current arrow as a speck)
    tall = 4.6 if turn is None else 6.0
    width = min(12.5, max(8.0, 3.8 + tall * aspect))
    # A long thin area (10:1) fills the width at a fraction of the usual height: the page
    # shrinks to it (title, axis labels and colour bar need ~2.6 in) rather than leaving most
    # of it blank between the panels.
    panel = min(tall + 1.0, max(3.4, (width - 3.8) / aspect + 2.6))
    if belief is None:
        fig, ax = plt.subplots(figsize=(width, panel), layout="constrained")
    else:
        fig, (ax, ax_map) = plt.subplots(2, 1, figsize=(width, 2 * panel - 0.8),
                                         layout="constrained", sharex=True, sharey=True)
    snap = run.plume
    if snap is not None:
        vmax = max(float(np.percentile(snap.conc, 99.7)), (threshold or 0.0) * 2, 1e-9)
        mesh = ax.pcolormesh(snap.xs, snap.ys, snap.conc, cmap="Greys", shading="auto",
                             vmin=0, vmax=vmax, alpha=0.75, rasterized=True)
        given_up = bool((run.declaration_report or {}).get("search_given_up"))
        several = len(run.declared_all) > 1  # t3 is the last declaration's (a review)
        when = (("the search gave up" if given_up else
                 "last declaration" if several else "declaration")
                if run.t3 is not None and abs(snap.t_s - run.t3) < 1e-6 else "end")
        bar = fig.colorbar(mesh, ax=ax, location="bottom", shrink=0.5, aspect=40, pad=0.02)
        label = f"plume concentration at t = {snap.t_s:.0f} s ({when})"
        if threshold is not None:
            bar.ax.axvline(threshold, color="#d62728", lw=1.5)
            label += f"; red: detection threshold {threshold:g}"
        bar.set_label(label, fontsize=8)
    ax.add_patch(plt.Rectangle((area.xmin, area.ymin), area.xmax - area.xmin,
                               area.ymax - area.ymin, fill=False, lw=1.5, ec="black"))
    graticule = _graticule(ax, mission, area)
    _track(ax, run, waypoints)
    det = run.detections
    if len(det):
        # Thin and translucent: a long run of detections must not hide the track beneath it.
        ax.plot(det[:, 0], det[:, 1], "x", color="black", ms=3.5, mew=0.7, alpha=0.45,
                label="detection (est.)", zorder=1.5)
    if run.lost_contacts:
        lc = np.asarray([(p.x, p.y) for p in run.lost_contacts])
        ax.plot(lc[:, 0], lc[:, 1], "s", mfc="none", mec="#ff7f0e", ms=6, label="lost contact")
    ax.plot(*run.start, "o", mfc="white", mec="black", ms=8, label="vehicle at AMP start")
    st = goal if goal is not None else (
        mission.to_xy(mission.start) if mission.start is not None else None)
    if st is not None:
        ax.plot(st.x, st.y, "D", mfc="none", mec="#1f77b4", ms=8, mew=1.5,
                label="study start (move-to-field goal)" if goal is not None
                else "mission start (move-to-field goal)")
    home = mission.to_xy(mission.home)
    ax.plot(home.x, home.y, "^", mfc="#8c564b", mec="black", ms=9, label="home")
    reach = _home_radius(mission) if run.t3 is not None else None
    if reach is not None:  # a review read the line home stopping short as a fault
        ax.add_patch(plt.Circle((home.x, home.y), reach, fill=False, ls=(0, (3, 2)), lw=1.0,
                                ec="#8c564b",
                                label=f"home radius {reach:g} m (by nav. estimate)"))
    declared = list(run.declared_all) or ([run.declared] if run.declared is not None else [])
    source_markers(ax, truth, declared)
    verifying = (run.declaration_report or {}).get("verifying_at")
    if verifying:  # where a fly-by cut short was looking, beside its loop (a diff review)
        ax.plot(*verifying, "D", mfc="none", mec=VERIFYING_COLOUR, mew=2.0, ms=12, ls="none",
                zorder=10, label=VERIFYING_LABEL)
    marks = [home, *truth, *declared, *([st] if st is not None else []),
             *([Point(*verifying)] if verifying else [])]
    # every marker whole, with room around it: one at the plot's edge (a start outside the
    # OpArea, at the plume grid's corner) had been half cut off (a review)
    pad = 0.04 * max(area.xmax - area.xmin, area.ymax - area.ymin)
    for x, y in [(q.x, q.y) for q in marks] + [tuple(run.start)]:
        if math.isfinite(x) and math.isfinite(y):
            ax.update_datalim([(x - pad, y - pad), (x + pad, y + pad)])
    ax.autoscale_view()
    trace = run.trace or {}
    track = np.column_stack([trace.get("x", run.path_true[:, 0]),
                             trace.get("y", run.path_true[:, 1])])
    spots = np.array([(q.x, q.y) for q in marks] + [tuple(run.start)]).reshape(-1, 2)
    north = (north_corner(area, spots, np.concatenate([track, det.reshape(-1, 2)]))
             if mission.frame != "planning" else None)
    if flow_deg is not None:
        drawn = np.concatenate([track, det.reshape(-1, 2), spots])
        flow_arrow(ax, area, flow_deg, drawn,
                   _north_points(area, north) if north is not None else None, turn, spots)
    if belief is not None:
        map_panel(ax_map, belief, area, truth, declared, run.declaration_report or {}, plt)
        ax.tick_params(labelbottom=True)  # shared x: the top panel's numbers too
    if mission.frame != "planning":
        _north_arrow(ax, area, north or 0)
    ax.set_aspect("equal")
    if turn is not None:  # every panel turned; the limits as the planning frame's, turned
        for panel_ax in [ax] + ([ax_map] if belief is not None else []):
            turn_north_up(panel_ax, turn)
            panel_ax.set_xlabel("east (m)")
            panel_ax.set_ylabel("north (m)")
        for x, y in [(q.x, q.y) for q in marks] + [tuple(run.start)]:  # as above, turned
            if math.isfinite(x) and math.isfinite(y):
                ax.update_datalim(turn.transform([(x - pad, y - pad), (x + pad, y + pad),
                                                  (x - pad, y + pad), (x + pad, y - pad)]))
        ax.autoscale_view()
        ax.set_xlabel("east (m), " + ("about the OpArea's centre" if mission.local_frame()
                                      else "the mission's N-E frame") + "; north up")
    else:
        ax.invert_yaxis()  # TRO draws the planning y axis positive downward
        if mission.frame == "planning":  # no compass: drawing a north would invent one
            ax.set_xlabel("x (m), planning frame (no compass given)")
        else:
            bearing = area.frame.x_bearing_deg % 360
            side = ("the OpArea's long axis" if area.xmax - area.xmin > area.ymax - area.ymin
                    else "the OpArea's x axis")
            ax.set_xlabel(f"x (m): {side}, compass bearing {bearing:.1f}°")
        ax.set_ylabel("y (m), 90° clockwise from x")
        if belief is not None:  # the map's panel says the same (it read "x (m)": a review)
            ax_map.set_xlabel(ax.get_xlabel())
    # A study row's title names its sweep: wrapped to the panel (~13 characters an inch at
    # 10 pt; the legend takes ~3.5 in), it was cut off at the page's left edge.
    chars = max(40, int(13 * (width - 3.5)))
    ax.set_title("\n".join(textwrap.fill(line, chars) for line in title.split("\n")),
                 fontsize=10)
    # the page's width allows ~3.5 in for the legend: a longer entry (a plug-in's long name)
    # shrank the panel, or pushed its y label off the page, so long entries wrap instead
    handles, labels = [], []
    for a in fig.axes:  # both panels' entries, as fig.legend() collects them, each once
        for h, t in zip(*a.get_legend_handles_labels(), strict=True):
            if t not in labels:
                handles.append(h)
                labels.append(t)
    fig.legend(handles, [textwrap.fill(t, LEGEND_CHARS) for t in labels],
               loc="outside right upper", fontsize=8, frameon=False)
    # one layout pass at the saving resolution first: the constrained layout, settled in a
    # single pass at saving, had left the y label off the page's edge (a review's 300 x 120 m
    # box at 45°; measured on its own it fitted)
    fig.set_dpi(150)
    fig.canvas.draw()
    _place_labels(fig, ax, graticule, area, turn)
    fig.savefig(path, dpi=150)
    plt.close(fig)


def _home_radius(mission: MissionBase) -> float | None:
    """How near home the declaration's return ends the run (its ``home_radius_m``)."""
    for e in mission.entries():
        if e.family == "declare_source" and hasattr(e.params, "home_radius_m"):
            return float(e.params.home_radius_m)
    return None


def flow_arrow(ax: Any, area: OpArea, flow_deg: float,
               track: NDArray[np.float64] | None = None,
               avoid: NDArray[np.float64] | None = None, turn: Any = None,
               marks: NDArray[np.float64] | None = None) -> None:
    """The mean current's direction, in the OpArea corner that covers least of what else is
    drawn (``track``: the track, detections and markers as points), never the north arrow
    (``avoid``) if a corner is clear of it, and a marker (``marks``: start, home, sources)
    counted as ten track points (a new user's label sat on the start markers, the corner having
    fewer track points than the others); among equals, the one farthest from the track
    (the plume alone can mislead: the meander bends it; in a small area a fixed corner put the
    arrow and its label on the track). Dark with a white halo: readable on white and on a
    colour map alike. The axes draw y downward; the label sits on the side of the tail the
    head does not reach (below it had covered the head of a current with a downward part);
    ``turn``: the figure is drawn north up (:func:`north_up_turn`), and "below" is south."""
    from matplotlib import patheffects

    w, h = area.xmax - area.xmin, area.ymax - area.ymin
    short, long = min(w, h), max(w, h)
    # a thin area's short side alone made a speck of it (3.6 m in a 200 x 30 m box)
    size = min(max(0.12 * short, 0.05 * long), 0.3 * short)
    th = math.radians(flow_deg)
    m = 1.4 * size
    corners = [(area.xmin + m, area.ymax - m), (area.xmax - m, area.ymax - m),
               (area.xmin + m, area.ymin + m), (area.xmax - m, area.ymin + m)]
    pts = track[np.isfinite(track).all(axis=1)] if track is not None else np.empty((0, 2))
    keep_off = avoid if avoid is not None else np.empty((0, 2))
    spots = marks[np.isfinite(marks).all(axis=1)] if marks is not None else np.empty((0, 2))

    # the arrow spans about a size from its tail, the label below it: the box they fill
    def gaps(c: tuple[float, float], p: NDArray[np.float64]) -> NDArray[np.float64]:
        dx = np.maximum(np.abs(p[:, 0] - c[0]) - size, 0.0)
        dy = np.maximum(np.abs(p[:, 1] - c[1]) - size, 0.0)
        return np.hypot(dx, dy)

    def rank(c: tuple[float, float]) -> tuple[int, int, float]:
        g = gaps(c, pts)
        # a marker near the box is under the label, which reaches past it, and weighs as ten
        # track points: first the marker's (a new user's north-up figure), but not the arrow on
        # a stretch of track either (a small OpArea's corners all have one or the other)
        covered = 10 * int(np.count_nonzero(gaps(c, spots) < 0.4 * size))
        return (int(np.count_nonzero(gaps(c, keep_off) == 0.0)),
                covered + int(np.count_nonzero(g == 0.0)), -float(g.min()) if len(g) else 0.0)

    # drawn bottom left (y down) unless something else is there: the first of the best
    cx, cy = min(corners, key=rank)
    halo = [patheffects.withStroke(linewidth=3.0, foreground="white")]
    arrow = ax.annotate("", xy=(cx + size * math.cos(th), cy + size * math.sin(th)),
                        xytext=(cx, cy),
                        arrowprops={"arrowstyle": "-|>", "color": "#1f3b73", "lw": 1.8},
                        zorder=4, gid="mean current")  # one block with its label (compass)
    arrow.arrow_patch.set_path_effects(halo)
    if turn is None:  # y drawn down: screen-up is -y
        down = math.sin(th) > 0.2  # the head ends below the tail
        up = (0.0, -1.0)
    else:  # north up: screen-up is north, the turn's second row
        linear = np.asarray(turn.get_matrix())[:2, :2]
        down = float(linear[1] @ (math.cos(th), math.sin(th))) < -0.2
        ux, uy = np.linalg.solve(linear, (0.0, 1.0))
        up = (float(ux), float(uy))
    lift = 0.35 * size if down else -0.35 * size  # the label on the side the head leaves
    ax.text(cx + lift * up[0], cy + lift * up[1], "mean current",
            color="#1f3b73", fontsize=7, ha="center", va="bottom" if down else "top",
            path_effects=halo, zorder=4, gid="mean current")


def _track(ax: Any, run: VehicleRun, waypoints: Sequence[Point] | None) -> None:
    """The true track in segments coloured by the active behaviour (or styled by phase)."""
    trace = run.trace or {}
    xs_true = np.asarray(trace.get("x", run.path_true[:, 0]))
    ys_true = np.asarray(trace.get("y", run.path_true[:, 1]))
    actives = list(trace.get("active", run.recorder.active_names(run.index)))
    phases = trace.get("phase")
    if phases is not None:
        actives = [f"phase:{ph}" if _phase_style(ph) else a
                   for a, ph in zip(actives, phases, strict=True)]
    if waypoints:
        ax.plot([w.x for w in waypoints], [w.y for w in waypoints], "--", color="#aaaaaa", lw=0.8,
                marker=".", label="Mission A plan")
    seen: set[str] = set()
    start = 0
    for i in range(1, len(xs_true) + 1):
        if i == len(xs_true) or actives[i] != actives[start]:
            name = actives[start] or "none"
            style = _phase_style(name.removeprefix("phase:")) if name.startswith("phase:") else None
            colour, ls, shown = style if style else (_colour(name), _line_style(name), name)
            if shown == "none":
                shown = "no behaviour output"
            label = None if shown in seen else shown
            seen.add(shown)
            seg = slice(start, min(i + 1, len(xs_true)))
            ax.plot(xs_true[seg], ys_true[seg], color=colour, ls=ls, lw=1.6, label=label)
            start = i
