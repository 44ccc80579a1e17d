"""The compass on a run's figure: the north arrow and the latitude/longitude graticule with
its labels, placed so that none sits on another or on the OpArea's border."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from cptbt.frames import OpArea
from cptbt.mission import MissionBase
from cptbt.types import Point


def _north_geometry(area: OpArea, corner: int = 0) -> tuple[float, float, float, float]:
    """The north arrow's tail (x0, y0), length and direction (radians, planning frame), in one
    of the OpArea's corners: 0 upper left (as drawn, y down), 1 upper right, 2 lower left,
    3 lower right."""
    size = 0.07 * area.diagonal_m
    inset = 1.3 * size
    x0 = area.xmin + inset if corner in (0, 2) else area.xmax - inset
    y0 = area.ymin + inset if corner in (0, 1) else area.ymax - inset
    return x0, y0, size, math.radians(area.frame.planning_deg(0.0))


def _north_points(area: OpArea, corner: int = 0) -> NDArray[np.float64]:
    """Points along the north arrow and on its label (for what must keep clear of it)."""
    x0, y0, size, north = _north_geometry(area, corner)
    r = np.linspace(0.0, 1.5 * size, 16)
    return np.column_stack([x0 + r * math.cos(north), y0 + r * math.sin(north)])


def north_corner(area: OpArea, marks: NDArray[np.float64],
                 track: NDArray[np.float64]) -> int:
    """The corner for the north arrow (:func:`_north_geometry`): of those where the arrow and
    its label stay inside the OpArea, the one with the fewest markers (``marks``: start, home,
    sources) near them, then the fewest ``track`` points; the upper left among equals. A
    review's start marker sat under the arrow in the fixed upper-left corner."""
    size = 0.07 * area.diagonal_m

    def near(pts: NDArray[np.float64], arrow: NDArray[np.float64], r: float) -> int:
        pts = pts[np.isfinite(pts).all(axis=1)]
        if not len(pts):
            return 0
        d = np.hypot(pts[:, None, 0] - arrow[None, :, 0], pts[:, None, 1] - arrow[None, :, 1])
        return int(np.count_nonzero(d.min(axis=1) < r))

    best: tuple[int, int, int] | None = None
    choice = 0
    for k in range(4):
        arrow = _north_points(area, k)
        inside = area.contains_array(arrow[:, 0], arrow[:, 1]).all()
        score = (0 if inside else 1, near(marks, arrow, 0.6 * size),
                 near(track, arrow, 0.25 * size))
        if best is None or score < best:
            best, choice = score, k
    return choice


def _north_arrow(ax: Any, area: OpArea, corner: int = 0) -> None:
    """A north arrow in an OpArea corner (:func:`north_corner`; planning frame, y drawn
    down)."""
    x0, y0, size, north = _north_geometry(area, corner)
    tip = (x0 + size * math.cos(north), y0 + size * math.sin(north))
    ax.annotate("", xy=tip, xytext=(x0, y0),
                arrowprops={"arrowstyle": "-|>", "color": "black", "lw": 1.5})
    ax.text(x0 + 1.35 * size * math.cos(north), y0 + 1.35 * size * math.sin(north), "N",
            ha="center", va="center", fontsize=10, fontweight="bold")


def _graticule(ax: Any, mission: MissionBase, area: OpArea) -> list[tuple[Any, Spots]]:
    """Lines of constant latitude and longitude, for missions with a geodetic anchor; their
    labels, each with the places it may stand (for :func:`_place_labels`)."""
    labels: list[tuple[Any, Spots]] = []
    local = mission.local_frame()
    if local is None:
        return labels
    corners = [mission.to_geodetic(Point(x, y)) for x in (area.xmin, area.xmax)
               for y in (area.ymin, area.ymax)]
    lats = [g.lat_deg for g in corners if g is not None]
    lons = [g.lon_deg for g in corners if g is not None]
    # Across the antimeridian the corners read 179.99 and -179.99: unwrap them about the first
    # so the lines run between them (min/max over the raw values spanned the whole globe).
    lons = [lons[0] + _wrap180(lon - lons[0]) for lon in lons]
    for values, is_lat in ((lats, True), (lons, False)):
        lo, hi = min(values), max(values)
        step = _nice_step((hi - lo) / 4)
        other = (min(lons), max(lons)) if is_lat else (min(lats), max(lats))
        for v in np.arange(math.ceil(lo / step) * step, hi, step):
            pts = []
            for w in np.linspace(*other, 30):
                lat, lon = (v, w) if is_lat else (w, v)
                pts.append(area.frame.ne_to_xy(*local.to_ne(float(lat), float(lon))))
            xs = np.array([p.x for p in pts])
            ys = np.array([p.y for p in pts])
            inside = ((xs >= area.xmin) & (xs <= area.xmax) & (ys >= area.ymin)
                      & (ys <= area.ymax))
            if inside.sum() < 2:
                continue
            ax.plot(xs[inside], ys[inside], color="#4a90d9", lw=0.6, alpha=0.7, zorder=0)
            # Latitudes labelled near where they enter the OpArea, longitudes near where they
            # leave it, so the two sets of labels do not pile up on one edge; _place_labels
            # moves each inward along its line until it clears the border (centred on the
            # border point it had sat on the OpArea's edge) and the labels placed before it.
            idx = np.flatnonzero(inside)
            ends = (idx[0], idx[-1]) if is_lat else (idx[-1], idx[0])
            along = np.linspace(0.0, 1.0, 41)
            spots = [(float(np.interp(f, (0, 1), (xs[ends[0]], xs[ends[1]]))),
                      float(np.interp(f, (0, 1), (ys[ends[0]], ys[ends[1]])))) for f in along]
            text = ax.text(*spots[0], _dm(v if is_lat else _wrap180(v),
                                          "NS" if is_lat else "EW"),
                           fontsize=6, color="#2a6099", ha="center", va="center", zorder=1,
                           bbox={"fc": "white", "ec": "none", "alpha": 0.7, "pad": 0.5})
            labels.append((text, spots))
    return labels


Spots = list[tuple[float, float]]
"""The places along its line a graticule label may stand, best first."""


def _place_labels(fig: Any, ax: Any, labels: list[tuple[Any, Spots]],
                  area: OpArea | None = None, turn: Any = None) -> None:
    """Move each graticule label to the first place along its line where it overlaps no label
    placed before it, nor another text or arrow of the axes (the north arrow and its N, the
    current's arrow and label),
    and stands wholly inside ``area`` (off its border); one with no such place is not drawn.
    ``turn``: the figure is drawn north up (:func:`north_up_turn`), the OpArea turned with it.
    Called once the layout is settled (the figure drawn at its saving resolution): a label's
    size is in points, the spacing of the lines in metres."""
    if not labels:
        return
    renderer = fig.canvas.get_renderer()  # the caller has drawn: the layout is settled
    to_display = ax.transData if turn is None else turn + ax.transData
    back = to_display.inverted()
    # 2 px in metres: a label must stand that far in from the OpArea's drawn edge
    (ax0, ay0), (ax1, ay1) = back.transform([(0.0, 0.0), (2.0, 0.0)])
    inset = math.hypot(ax1 - ax0, ay1 - ay0)
    mine = {id(text) for text, _ in labels}
    taken = [t.get_window_extent(renderer).expanded(1.1, 1.2) for t in ax.texts
             if id(t) not in mine and t.get_visible() and t.get_text()]
    # the arrows too (north, current): a review's label stood on the north arrow's shaft
    taken += [t.arrow_patch.get_window_extent(renderer) for t in ax.texts
              if getattr(t, "arrow_patch", None) is not None and t.get_visible()]
    # and an arrow and its label as one block (a gid they share): another review's label stood
    # between "mean current" and its arrow, read as the current's
    from matplotlib.transforms import Bbox

    blocks: dict[str, list[Any]] = {}
    for t in ax.texts:
        if t.get_gid() and t.get_visible():
            blocks.setdefault(t.get_gid(), []).append(t)
    taken += [Bbox.union([t.get_window_extent(renderer) for t in members]
                         + [t.arrow_patch.get_window_extent(renderer) for t in members
                            if getattr(t, "arrow_patch", None) is not None])
              for members in blocks.values()]
    for text, spots in labels:
        for spot in spots:
            text.set_position(spot)
            box = text.get_window_extent(renderer).expanded(1.1, 1.2)
            if area is not None:  # the box's corners in the planning frame, inside the OpArea
                xy = back.transform(box.corners())
                if not (np.all(xy[:, 0] >= area.xmin + inset)
                        and np.all(xy[:, 0] <= area.xmax - inset)
                        and np.all(xy[:, 1] >= area.ymin + inset)
                        and np.all(xy[:, 1] <= area.ymax - inset)):
                    continue
            if not any(box.overlaps(other) for other in taken):
                taken.append(box)
                break
        else:
            text.set_visible(False)


def north_up_turn(area: OpArea) -> Any:
    """The affine map from the planning frame to (east, north) metres of the mission's N-E
    frame (a matplotlib ``Affine2D``): a figure drawn through it has north up and east to the
    right. It mirrors as well as turns (the planning frame's y is 90° clockwise of x, north is
    90° anticlockwise of east), so nothing is drawn with y inverted."""
    from matplotlib.transforms import Affine2D

    f = area.frame
    b = math.radians(f.x_bearing_deg)
    return Affine2D(np.array([[math.sin(b), math.cos(b), f.origin_e],
                              [math.cos(b), -math.sin(b), f.origin_n],
                              [0.0, 0.0, 1.0]]))


def turn_north_up(ax: Any, turn: Any) -> None:
    """Every artist of ``ax`` drawn in the planning frame (lines, patches, the plume's mesh,
    texts, arrows) drawn through ``turn`` instead (:func:`north_up_turn`); the data limits are
    computed again. Artists placed in axes or offset coordinates are left as they are."""
    from matplotlib.artist import Artist
    from matplotlib.text import Annotation

    data = ax.transData
    turned = turn + data
    for artist in [*ax.lines, *ax.patches, *ax.collections, *ax.images]:
        # Artist's own: a patch's get_transform() has its patch transform (a rectangle's
        # corners, a circle's radius) before the data's
        if Artist.get_transform(artist) is data:
            artist.set_transform(turned)
    for text in ax.texts:
        if isinstance(text, Annotation):
            if text.xycoords == "data":
                text.xycoords = turned
            if text.anncoords == "data":
                text.anncoords = turned
        elif text.get_transform() is data:
            text.set_transform(turned)
    ax.relim()


def _wrap180(deg: float) -> float:
    """An angle in [-180, 180)."""
    return (deg + 180.0) % 360.0 - 180.0


def _nice_step(raw: float) -> float:
    """A step of 1, 2 or 5 times a power of ten, close to ``raw`` (degrees)."""
    if raw <= 0:
        return 1.0
    exp = math.floor(math.log10(raw))
    base = raw / 10**exp
    return float((1 if base < 1.5 else 2 if base < 3.5 else 5) * 10**exp)


def _dm(value: float, hemispheres: str) -> str:
    """Degrees and decimal minutes, as TRO writes positions: 32°58.850'N.

    Rounded to the thousandth of a minute before it is split, so a line a hair below a whole
    degree reads 33°00.000'N, not 32°60.000'N (the 180° meridian read 179°60.000'E); a value
    that rounds to zero takes the first hemisphere, not a "0°00.000'S"; the 180° meridian is
    neither east nor west and takes none (a review read 180°00.000'W)."""
    minutes = round(abs(value) * 60.0, 3)
    hemi = hemispheres[0] if value >= 0 or minutes == 0 else hemispheres[1]
    if hemispheres == "EW" and minutes == 180.0 * 60.0:
        hemi = ""
    d, m = divmod(minutes, 60.0)
    return f"{int(d)}°{m:06.3f}'{hemi}"
