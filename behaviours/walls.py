"""How a billiard search reflects off the OpArea's walls, in any OpArea and any flow.

Used by both find-plume billiards (:mod:`cptbt.behaviours.find_plume`) and their fleet forms.
Terms: ``u`` is the reference direction the billiard's offsets are measured from, ``n`` its
normal (``ref + 90°``), s the cross-flow side to head for (``s = +1`` moves toward ``+n``).

- **Side and ends.** s is the cross-flow side to head for: ``s = +1`` moves toward ``+n``;
  ``eta`` of SPEC §4a is ``(centre - p)·n``. A wall exit at point p is classified by where p
  lies in the OpArea's projection, normalised by its half-extents:
  ``u' = (p - centre)·u / half_extent_u`` and ``v'`` likewise along n. ``|v'| > |u'|`` is a
  cross-flow side (s becomes ``sign(eta)``: head for the other side); otherwise the down-flow
  end (``u' > 0``) or the up-flow end. With the reference along an OpArea axis this is exactly
  "which wall", as TRO and AB write it: beyond a y wall ``|v'| > 1 >= |u'|``, beyond an x wall
  ``|u'| > 1 >= |v'|``. With ``reference: flow`` and an oblique flow a wall can be part side,
  part end.
- **Never back out through the wall just left.** The wall crossed is known by its outward
  normal w (both normals, beyond a corner). A heading that already points back in through
  every wall crossed is kept (the vehicle is still turning back). Otherwise the papers' change
  above is made; if that heading would still leave through a wall crossed (only possible with
  ``reference: flow`` and an oblique flow, or in a corner), the other half of the state is set
  from w instead — s to move away from the wall (``-sign(w·n)``), or the offset whose along-flow
  motion moves away from it (the up-flow offset if ``w·u > 0``) — and failing both, both. The
  last choice always points inward (``heading·w < 0``), so no heading chosen at an exit drives
  back out through the wall just left.
- **Turning before the wall.** TRO reflects once the vehicle has left through a wall. A REMUS
  turns at a 7.5 m radius and is commanded once a second, so a reflection begun at the wall
  carries it up to ``R(1 - sin φ) + V·T`` outside (φ between heading and wall normal: about 5 m
  at a cross-flow side with TRO's angles), which is where safety takes over. A wall within
  ``wall_margin_m`` (default 5 m) with the heading pointing out through it therefore counts as
  left: the same reflection, begun that much earlier. ``wall_margin_m: 0`` is the letter;
  script-level tests that place the vehicle beyond a wall see the same headings either way.
- **Safety's report.** When safety has taken over at the boundary it reports the walls
  (blackboard ``oparea_exit``, a :class:`~cptbt.frames.WallExit`); find-plume treats the report
  as one more exit through those walls at the point safety took over, applied if its own
  heading would drive back out through them, so its next leg leaves that wall.
"""

from __future__ import annotations

import math
from collections.abc import Callable

from cptbt.angles import sign, unit, wrap_deg
from cptbt.frames import Normal, OpArea
from cptbt.types import Point


def reflect(side: int, offset_deg: float, point: Point, walls: tuple[Normal, ...], area: OpArea,
            ref: float, after_end: Callable[[bool], float]) -> tuple[int, float]:
    """The billiard's side and offset after an exit at ``point`` through ``walls``.

    ``after_end(upflow_end)`` is the offset after leaving through an end. Shared by the
    per-vehicle leaf and its fleet form (module docstring, "Never back out").
    """
    if _inward(ref + side * offset_deg, walls):
        return side, offset_deg
    role, v_side = boundary_role(area, point, ref)
    wx, wy = _mean_normal(walls)
    ux, uy = unit(ref)
    along, across = wx * ux + wy * uy, -wx * uy + wy * ux
    by_wall_side = -sign(across)
    by_wall_offset = after_end(along <= 0.0)
    if role == "side":
        first = (-v_side, offset_deg)
        second = (side, by_wall_offset)
    else:
        first = (side, after_end(role == "up"))
        second = (by_wall_side, offset_deg)
    for new_side, offset in (first, second):
        if _inward(ref + new_side * offset, walls):
            return new_side, offset
    return by_wall_side, by_wall_offset


def boundary_role(area: OpArea, point: Point, ref_deg: float) -> tuple[str, int]:
    """Which part of the boundary ``point`` lies on, seen along ``ref_deg`` and across it.

    Returns:
        ``("side", sign(v'))`` for a cross-flow side, else ``("down", ...)`` or ``("up", ...)``
        for the down-flow or the up-flow end; the second item is the cross-flow side of the
        point (``sign(v')``, +1 toward ``ref_deg + 90``). ``u'`` and ``v'`` are the point's
        offsets from the centre along ``ref_deg`` and across it, divided by the OpArea's
        half-extents in those directions; ``|v'| > |u'|`` is a side.
    """
    c = area.centre
    dx, dy = point.x - c.x, point.y - c.y
    ux, uy = unit(ref_deg)
    umin, umax = area.extent_along(ref_deg)
    vmin, vmax = area.extent_along(ref_deg + 90.0)
    u = (dx * ux + dy * uy) / (0.5 * (umax - umin))
    v = (-dx * uy + dy * ux) / (0.5 * (vmax - vmin))
    if abs(v) > abs(u):
        return "side", sign(v)
    return ("down" if u > 0.0 else "up"), sign(v)


def _mean_normal(walls: tuple[Normal, ...]) -> Normal:
    sx, sy = sum(w[0] for w in walls), sum(w[1] for w in walls)
    norm = math.hypot(sx, sy)
    if norm < 1e-9:  # opposite walls (a navigation jump across the area): the latest one
        return walls[-1]
    return sx / norm, sy / norm


def _inward(heading_deg: float, walls: tuple[Normal, ...]) -> bool:
    """Whether the heading points back in through every one of ``walls``."""
    hx, hy = unit(heading_deg)
    return all(hx * w[0] + hy * w[1] < 0.0 for w in walls)


def eta_side(here: Point, area: OpArea, ref_deg: float) -> int:
    """``sign(eta)``, ``eta = (centre - here)·n``: the larger cross-flow side (sign(0) = +1).

    ``n`` is the normal of the OpArea axis nearest to ``ref_deg``, not of ``ref_deg`` itself: with
    ``reference: flow`` the reference is the instantaneous, noisy flow, and a few degrees of it
    times the along-flow distance to the centre would outweigh the cross-flow offset and send
    the vehicle away from the centre line (AB's ``sign((ymin+ymax)/2 - y0)``). Measured: that
    sent 6 of 64 paired AB searchers the wrong way.
    """
    axis = min((0.0, 90.0, 180.0, -90.0), key=lambda a: abs(wrap_deg(ref_deg - a)))
    sense = 1.0 if math.cos(math.radians(ref_deg - axis)) >= 0 else -1.0
    nx, ny = unit(axis + 90.0)
    nx, ny = sense * nx, sense * ny
    c = area.centre
    return sign((c.x - here.x) * nx + (c.y - here.y) * ny)
