"""Which way to turn: a large heading change started on the side that keeps the vehicle inside.

A vehicle's autopilot turns the short way to a new heading, at its tightest radius R. A behaviour
that takes over from another near a wall, with the vehicle heading at that wall, can ask for a
turn of more than 90° whose short way sweeps the turning circle past the wall before the new leg
begins: in a 50 m OpArea the three-point tour, taking over from the tracker 0.8 m from one wall
and heading at the other, went 5.6 m outside (``missions/small_oparea.yaml``, seed 7). No single
behaviour sees this (the hand-over is the tree's), so the planner applies the rule to whatever the
tree commands, when the mission gives ``turn_guard_radius_m``:

- a command needing at most 90° of turn, or with no heading estimate, passes unchanged;
- otherwise both ways round are swept as circular arcs of radius R from the estimated pose, and
  if the short way leaves the OpArea farther than the long way, the command this cycle is the
  present heading turned 90° the long way, so the autopilot starts that way; the next cycles
  carry on (the rest of the turn is then the short way) or give the behaviour's heading back.

Reading chosen (SPEC is silent): the arcs ignore the current and the distance run before the
turn starts, and only the side of the turn is changed, never the heading the behaviour asks for.
"""

from __future__ import annotations

import math

from cptbt.angles import wrap_deg
from cptbt.frames import OpArea

ARC_POINTS = 24
"""Points per swept arc (a 270° arc of 7.5 m is sampled every 1.5 m)."""


def arc_excursion(x: float, y: float, heading_deg: float, turn_deg: float, radius_m: float,
                  area: OpArea) -> float:
    """How far outside ``area`` a turn of ``turn_deg`` (signed; planning degrees, positive
    toward +y from +x) at radius ``radius_m`` from pose (x, y, heading) goes; 0 if it stays in.
    """
    if turn_deg == 0.0:
        return area.distance_outside(x, y)
    k = math.copysign(1.0 / radius_m, turn_deg)  # signed curvature
    psi0 = math.radians(heading_deg)
    s0, c0 = math.sin(psi0), math.cos(psi0)
    worst = 0.0
    for i in range(1, ARC_POINTS + 1):
        psi = psi0 + math.radians(turn_deg) * i / ARC_POINTS
        px = x + (math.sin(psi) - s0) / k
        py = y + (c0 - math.cos(psi)) / k
        worst = max(worst, area.distance_outside(px, py))
    return worst


def guard_heading(x: float, y: float, heading_deg: float, command_deg: float, radius_m: float,
                  area: OpArea) -> float:
    """The heading to command this cycle so that a large turn starts on the inside side.

    Returns ``command_deg`` unless it needs more than 90° of turn and the short way round
    leaves ``area`` farther than the long way; then the present heading turned 90° the long way.
    """
    if not (math.isfinite(heading_deg) and math.isfinite(x) and math.isfinite(y)):
        return command_deg
    short = wrap_deg(command_deg - heading_deg)
    if abs(short) <= 90.0:
        return command_deg
    long = short - math.copysign(360.0, short)
    out_short = arc_excursion(x, y, heading_deg, short, radius_m, area)
    if out_short <= 0.0:
        return command_deg
    out_long = arc_excursion(x, y, heading_deg, long, radius_m, area)
    if out_long >= out_short:
        return command_deg
    return wrap_deg(heading_deg + math.copysign(90.0, long))
