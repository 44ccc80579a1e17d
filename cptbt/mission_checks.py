"""The mission's cross-field rules: what no single section can check alone (coordinates, the
OpArea's rectangle, places inside it, speed and depth limits, the cycle against the time limits,
study starts, behaviour pairings and needs). :meth:`cptbt.mission.MissionBase.problems` returns
them as (key path, message) and the loader reports each at its key's line; warnings for valid
missions are :mod:`cptbt.advice`'s.
"""

from __future__ import annotations

import logging
import math

from cptbt.frames import OpArea
from cptbt.geodesy import PoleError
from cptbt.mission import (
    RECTANGLE_TOL_FRACTION,
    Coord,
    Loc,
    MissionBase,
    Problem,
    latlon_problem,
)
from cptbt.policy import RELINQUISH_OUTSIDE_M, metres_text

log = logging.getLogger("cptbt.mission")


def problems(m: MissionBase) -> list[Problem]:
    """Every cross-field problem, as (key path, message); empty for a sound mission."""
    out = _coordinate_problems(m)
    if out:
        return out  # the geometry below needs sound coordinates
    try:
        area = m.op_area_geometry()
    except PoleError as exc:
        return [(("op_area", "corners"), f"{exc}: {pole_text(exc.pole)}")]
    except ValueError as exc:
        return [(("op_area", "corners"), str(exc))]
    out += _size_problems(m, area) or _rectangle_problems(m, area) + _pole_problems(m, area)
    if out:
        return out  # places are judged against a sound OpArea
    for key in ("start", "home"):
        coord = getattr(m, key)
        if coord is None:
            continue
        p = m.to_xy(coord)
        outside = area.distance_outside(p.x, p.y)
        if outside > RELINQUISH_OUTSIDE_M:  # allowed or not: the AMP cannot drive there
            out.append(((key,), f"{metres_text(outside)} m outside the OpArea: the AMP gives "
                         f"control back {RELINQUISH_OUTSIDE_M:g} m outside it (TRO II), so it "
                         "could never fly there; place it within that distance"))
        elif outside > 0 and key not in m.allow_outside:
            out.append(((key,), f"{metres_text(outside)} m outside the OpArea "
                         f"(list '{key}' in allow_outside if that is intended)"))
    out += _limit_problems(m)
    out += _rate_problems(m)
    out += _study_problems(m, area)
    out += _behaviour_problems(m)
    return out


def _coordinate_problems(m: MissionBase) -> list[Problem]:
    if m.frame != "geodetic":
        centre = m.op_area.geodetic_centre_deg
        if m.frame == "ne" and centre is not None and (why := latlon_problem(centre)):
            # a review's [91, 0] validated and the run ended in an internal error
            return [(("op_area", "geodetic_centre_deg"), why)]
        if len({tuple(c) for c in m.op_area.corners}) != 4:
            return [(("op_area", "corners"), "the four corners must be distinct")]
        return []
    out: list[Problem] = []
    places: list[tuple[Loc, Coord | None]] = [
        (("op_area", "corners", i), c) for i, c in enumerate(m.op_area.corners)
    ]
    places += [(("home",), m.home), (("start",), m.start),
               (("op_area", "geodetic_centre_deg"), m.op_area.geodetic_centre_deg)]
    for loc, c in places:
        why = latlon_problem(c) if c is not None else None
        if why:
            out.append((loc, why))
    if not out and len({tuple(c) for c in m.op_area.corners}) != 4:
        out.append((("op_area", "corners"), "the four corners must be distinct"))
    return out


def _rectangle_problems(m: MissionBase, area: OpArea) -> list[Problem]:
    if m.frame == "planning":
        return []
    ne = m.corners_ne()
    tol = max(1.0, RECTANGLE_TOL_FRACTION * area.diagonal_m)
    misfit = area.corner_misfit_m(ne)
    if misfit <= tol:
        if misfit > 0.01:
            log.info("%s: op_area corners lie up to %.1f m off a rectangle (tolerance %.1f "
                     "m); the OpArea is the rectangle that encloses them", m.name,
                     misfit, tol)
        return []
    sides = "/".join(f"{b:.1f}°" for b in sorted({round(b, 1) for b in area.side_bearings(ne)}))
    given = m.op_area.x_axis_bearing_deg
    if given is not None:
        own = OpArea.from_ne_corners(ne)
        if own.corner_misfit_m(ne) <= tol:
            return [(("op_area", "x_axis_bearing_deg"),
                     f"{given:g}° is not parallel to the corners' sides ({sides}): the "
                     f"OpArea would reach {misfit:.1f} m beyond them (tolerance {tol:.1f} m); "
                     "give a side's bearing or leave it out")]
    return [(("op_area", "corners"),
             f"not a rectangle: a corner lies {misfit:.1f} m off the fitted rectangle "
             f"(tolerance {tol:.1f} m, 1% of the diagonal); sides at {sides}")]


CORNER_NOTE_M = 0.5
"""Corners this far or more off their rectangle are told of by ``cptbt validate`` (a note):
within the tolerance the OpArea flown is the rectangle enclosing them, and a corner typed a
few metres off moves a wall out (a review's, 8 m off in an 800-m box, was fitted silently)."""


def corner_fit_note(m: MissionBase) -> str | None:
    """Where the OpArea flown differs from the corners as written (within the rectangle
    tolerance, else it is an error): how far off they lie and the corners flown, in the
    mission's own frame; None when they fit a rectangle within :data:`CORNER_NOTE_M`."""
    if m.frame == "planning":
        return None
    try:
        area = m.op_area_geometry()
    except ValueError:
        return None
    written = m.corners_ne()
    misfit = area.corner_misfit_m(written)
    if misfit < CORNER_NOTE_M:
        return None
    fitted = [area.frame.xy_to_ne(x, y) for x, y in ((area.xmax, area.ymin),
                                                     (area.xmin, area.ymin),
                                                     (area.xmin, area.ymax),
                                                     (area.xmax, area.ymax))]
    # in the file's order, each beside the corner it replaces (a diff review could not match
    # them one by one)

    def nearest(c: tuple[float, float]) -> tuple[float, float]:
        return min(fitted, key=lambda f: math.hypot(f[0] - c[0], f[1] - c[1]))

    ne = [nearest(c) for c in written]
    local = m.local_frame() if m.frame == "geodetic" else None
    if local is not None:
        flown = ", ".join(f"[{g.lat_deg:.6f}, {g.lon_deg:.6f}]"
                          for g in (local.to_geodetic(n, e) for n, e in ne))
    else:
        flown = ", ".join(f"[{n:.1f}, {e:.1f}]" for n, e in ne)
    return (f"the corners lie up to {misfit:.1f} m off a rectangle (within the tolerance, "
            f"1% of the diagonal): the OpArea flown is the rectangle enclosing them, corners "
            f"{flown} (in the file's order)")


MIN_SIDE_M = 1.0
"""An OpArea side shorter than this is refused: no vehicle turns in it."""

MAX_SIDE_M = 100_000.0
"""An OpArea side longer than this (100 km) is refused: plume tracing by AUV works in areas of
hundreds of metres (TRO: 254 x 112 m)."""


def _size(v: float) -> str:
    if v >= 1e9:  # a million km and more: 3 significant figures (corners of ±1e200 had printed
        return f"{v / 1000:.3g} km"  # 300 digits, a review)
    return f"{v / 1000:,.0f} km".replace(",", " ") if v >= 10_000 else f"{v:.3g} m"


def _size_problems(m: MissionBase, area: OpArea) -> list[Problem]:
    """An OpArea of millimetres or of thousands of kilometres: coordinates of one frame
    written under another (a review's [latitude, longitude] under frame 'ne' validated as a box
    millimetres across, and metres under 'geodetic' as one 6 700 km long)."""
    w, h = area.xmax - area.xmin, area.ymax - area.ymin
    size = f"{_size(max(w, h))} x {_size(min(w, h))}"
    if min(w, h) < MIN_SIDE_M:
        hint = ("; [latitude, longitude] written under frame "
                f"'{m.frame}', which reads metres? (frame: geodetic reads degrees)"
                if m.frame != "geodetic" else "")
        return [(("op_area", "corners"), f"the OpArea is {size}, narrower than "
                 f"{MIN_SIDE_M:g} m{hint}")]
    if max(w, h) > MAX_SIDE_M:
        hint = ("; metres written under frame 'geodetic', which reads [latitude, longitude] "
                "degrees? (frame: ne reads metres)" if m.frame == "geodetic" else "")
        return [(("op_area", "corners"), f"the OpArea is {size}, longer than an AUV's plume "
                 f"search covers ({_size(MAX_SIDE_M)} at most){hint}")]
    return []


def pole_text(name: str) -> str:
    """Why an OpArea may not hold the ``name`` ("North" or "South") Pole."""
    away = "south" if name == "North" else "north"
    return (f"at the {name} Pole every direction is {away}, so the compass bearings a mission "
            "is written in (the flow, headings, x_axis_bearing_deg) turn through 360° across "
            "the OpArea; write the mission in frame 'ne', metres about a grid north of your "
            "choosing, without geodetic_centre_deg")


def _pole_problems(m: MissionBase, area: OpArea) -> list[Problem]:
    """An OpArea over a pole (a review's corners about the North Pole were refused as "origin
    latitude must be in (-90, 90)", a mission without an origin; a little wider, they were
    accepted, the frame's north an accident of rounding)."""
    frame = m.local_frame()
    if frame is None:
        return []
    for lat, name in ((90.0, "North"), (-90.0, "South")):
        n, e = frame.to_ne(lat, 0.0)
        p = area.frame.ne_to_xy(n, e)
        if area.distance_outside(p.x, p.y) <= 0.0:
            key = ("op_area", "geodetic_centre_deg" if m.op_area.geodetic_centre_deg
                   and m.frame == "ne" else "corners")
            return [(key, f"the OpArea contains the {name} Pole: {pole_text(name)}")]
    return []


def _limit_problems(m: MissionBase) -> list[Problem]:
    a = m.mission_a
    if a is None:
        return []
    lim = a.limits
    out: list[Problem] = []
    for loc, v in m.commanded_speeds():
        if not lim.min_speed_mps <= v <= lim.max_speed_mps:
            out.append((loc, f"{v:g} m/s is outside the vehicle's limits "
                             f"[{lim.min_speed_mps:g}, {lim.max_speed_mps:g}] m/s "
                             "(mission_a.limits): the vehicle would refuse it"))
    for key in ("depth_m", "amp_depth_m"):
        depth = getattr(a, key)
        if depth is not None and depth > lim.max_depth_m:
            out.append((("mission_a", key), f"{depth:g} m is deeper than the vehicle's limit "
                                             f"{lim.max_depth_m:g} m (mission_a.limits)"))
    return out


def _rate_problems(m: MissionBase) -> list[Problem]:
    """A cycle period longer than a time limit: the run would end before a second tick."""
    period = 1.0 / m.cycle_hz
    limits = [("time_limit_s", m.time_limit_s)]
    if m.study is not None and m.study.time_limit_s is not None:
        limits.append(("study.time_limit_s", m.study.time_limit_s))
    for name, limit in limits:
        if period > limit:
            return [(("cycle_hz",), f"{m.cycle_hz:g} Hz is a cycle of {period:g} s, "
                                    f"longer than {name} ({limit:g} s): the planner would "
                                    "tick once before the time limit")]
    return []


def _study_problems(m: MissionBase, area: OpArea) -> list[Problem]:
    if m.study is None or not m.study.starts or "start" in m.allow_outside:
        return []
    out: list[Problem] = []
    for i, c in enumerate(m.study.starts):
        p = m.to_xy(c)
        if not area.contains(p.x, p.y):
            out.append((("study", "starts", i),
                        f"{metres_text(area.distance_outside(p.x, p.y))} m outside the OpArea "
                        "(list 'start' in allow_outside if that is intended)"))
    return out


def _behaviour_problems(m: MissionBase) -> list[Problem]:
    entries = m.entries()
    out: list[Problem] = []
    first: dict[str, int] = {}
    for i, e in enumerate(entries):
        if e.family in first:
            out.append((("behaviours", i, e.family),
                        f"behaviour listed twice (first at behaviours[{first[e.family]}])"))
        first.setdefault(e.family, i)
    chosen = {e.family: e.variant for e in entries}
    paired: set[str] = set()  # a mismatched pair is reported once, at its first half
    for i, e in enumerate(entries):
        loc: Loc = ("behaviours", i, e.family, "variant")
        for family, variant in e.contract.pairs_with:
            if family in chosen and chosen[family] != variant and family not in paired:
                paired.add(e.family)
                out.append((loc, f"{e.family} {e.variant} must be paired with {family} "
                                 f"{variant}, not {chosen[family]}"))
        why = e.contract.check(e.params, m.perception) if e.contract.check else None
        if why:
            out.append((("behaviours", i, e.family), why))
    if m.evaluation.criterion == "maintain":
        if "maintain_plume" not in chosen:
            out.append((("evaluation", "criterion"),
                        "'maintain' measures a maintain_plume behaviour, and there is none"))
        if m.mission_a is not None:
            out.append((("evaluation", "criterion"),
                        "'maintain' studies the AMP alone: remove the mission_a section"))
    needy = [f"{e.family} {e.variant}" for e in entries if e.contract.needs_flow]
    if needy and m.perception.flow_source == "none":
        out.append((("perception", "flow_source"),
                    f"'none', but {', '.join(needy)} steer by the flow estimate"))
    return out
