"""Warnings only a simulated world shows: settings of the simulator (or the mission against
it) that are valid but likely not what the author means, as (key path, message) for
:func:`cptbt.batch.scenario.advisories`: a cloverleaf no wider than the vehicle's turn, a
cycle the simulator cannot keep, a current too strong or too weak, a box or a move the turn
does not fit (the sensors' warnings: :mod:`cptbt.batch.sensing_advice`)."""

from __future__ import annotations

import math
from decimal import Decimal

from cptbt.mission import MissionBase, Problem
from cptbt.policy import RELINQUISH_OUTSIDE_M
from cptbt.sim.world import EnvironmentParams
from cptbt.types import Point


def plain(v: float) -> str:
    """A number as a user writes it, without an exponent between 1e-6 and 1e15 (1000000,
    0.00002; a noise of 1e6 had printed as 1e+06), with an exponent beyond."""
    if not math.isfinite(v) or not 1e-6 <= abs(v) < 1e15:
        return f"{v:g}"
    text = format(Decimal(repr(float(v))), "f")  # the shortest digits that read back as v
    return text.rstrip("0").rstrip(".") if "." in text else text


def two_figures(v: float) -> str:
    """Two significant figures, without an exponent (260, 0.39, 3.7, 1,200,000)."""
    r = float(f"{v:.2g}")
    return f"{r:,.0f}" if 100 <= r < 1e15 else plain(r)


def two_figures_up(v: float) -> str:
    """``v`` rounded *up* to two significant figures (a threshold to set must be enough)."""
    if v <= 0.0 or not math.isfinite(v):
        return plain(v)
    step = 10.0 ** (math.floor(math.log10(v)) - 1)
    return two_figures(math.ceil(v / step - 1e-9) * step)


WEAK_CURRENT_MPS = 0.02
"""A mean current below this, with behaviours that steer by the flow, is warned of."""


def pace_advice(mission: MissionBase, params: EnvironmentParams) -> list[Problem]:
    """A planning cycle faster than the simulator's step, which the simulated planner cannot
    keep (it ticks at most once a step: a review's 10 Hz ran at 9 Hz); a current that
    carries the vehicle at half its cruise speed or more: the behaviours steer through the
    water, not over ground, so legs across the flow drift down-flow (a review's 1 m/s current
    against 1.5 m/s: find-plume swept the down-flow wall, a declaration fell 181 m off); and a
    current too weak to lay a plume down-flow while behaviours steer by it (a review's 0 m/s
    validated silently and declared 19.7 m off)."""
    out: list[Problem] = []
    step_hz = 1.0 / params.dt_s
    if mission.cycle_hz > step_hz * (1 + 1e-9):
        out.append((("cycle_hz",), f"{plain(mission.cycle_hz)} Hz is faster than the "
                    f"simulator's step ({two_figures(params.dt_s)} s, the fluorometer's rate): "
                    f"simulated, the planner ticks once a step, {two_figures(step_hz)} Hz; "
                    "raise environment.fluorometer.rate_hz (or lower dt_s) to fly it"))
    current = params.flow.mean_speed_mps
    steer = [f"{e.family} {e.variant}" for e in mission.entries() if e.contract.needs_flow]
    if current < WEAK_CURRENT_MPS and steer:
        out.append((("environment", "flow_speed_mps"), f"a mean current of {plain(current)} "
                    f"m/s hardly carries the plume from its source: it pools about it, and "
                    f"{', '.join(steer)} steer by a flow estimate that is then its meander "
                    "alone (TRO MSN007 at 0 m/s, seeds 1-5: 2 false declarations 30-54 m off "
                    "and 3 none; at 0.05 m/s all 5 within 15 m)"))
    if params.vehicle.advected and current >= mission.speed_mps:  # a review read "half"
        out.append((("environment", "flow_speed_mps"), f"the mean current ({plain(current)} "
                    f"m/s) is as fast as the cruise speed ({plain(mission.speed_mps)} m/s) or "
                    "faster: the vehicle cannot make way up-flow at all, so nothing up-flow of "
                    "where it starts is reached, and it is carried down-flow whatever it "
                    "commands"))
    elif params.vehicle.advected and current >= 0.5 * mission.speed_mps:
        out.append((("environment", "flow_speed_mps"), f"the mean current ({plain(current)} "
                    f"m/s) is half the cruise speed ({plain(mission.speed_mps)} m/s) or more: "
                    "the behaviours steer through the water, not over ground, so legs across "
                    "the flow drift down-flow and find-plume may never reach up-flow water"))
    return out


def leaf_advice(mission: MissionBase, params: EnvironmentParams) -> list[Problem]:
    """A cloverleaf whose leaves (``d_leaf_m``) are no longer than the simulated vehicle's
    tightest turn: its waypoints cannot be flown as drawn (a review's ``d_leaf_m: 1``
    validated; the parameter's own description asks for more than the turning radius)."""
    radius = params.vehicle.turning_radius_m
    out: list[Problem] = []
    for i, e in enumerate(mission.entries()):
        leaf = getattr(e.params, "d_leaf_m", None)
        if leaf is not None and leaf <= radius:
            out.append((("behaviours", i, e.family, "d_leaf_m"),
                        f"{plain(leaf)} m is not beyond the simulated vehicle's turning radius "
                        f"({plain(radius)} m, environment.vehicle.turning_radius_m): the vehicle "
                        "cannot fly its leaves as drawn (each turn is wider than a leaf)"))
    return out


def tour_flow_advice(mission: MissionBase, params: EnvironmentParams) -> list[Problem]:
    """A cloverleaf or three-point tour that fits the OpArea in some orientation, but not in
    the one the simulated mean flow gives it: points are moved inside the walls wherever it is
    centred (a review's 40-m channel with the flow along it and ``radius_m: 12`` was warned of
    by nothing: the behaviour's own advice checks every orientation, not knowing the flow).
    The tour is laid out along the flow estimate, which the meander turns a little either way:
    the warning judges the mean. With (almost) no mean current the estimate reads any
    direction, and the share of directions the tour fits in is said (a diff review)."""
    from cptbt.behaviours.reacquire import pattern_advice, tour_fits, tour_size

    area = mission.op_area_geometry()
    toward = params.flow.mean_dir_deg
    weak = params.flow.mean_speed_mps < WEAK_CURRENT_MPS
    # in the file's own terms: a compass bearing unless the mission is in the planning frame
    where = (f"toward {plain(round(toward % 360.0, 1))}° from the OpArea's x axis"
             if mission.frame == "planning" else
             f"toward compass {(area.frame.x_bearing_deg + toward) % 360.0:.1f}°")
    out: list[Problem] = []
    for i, e in enumerate(mission.entries()):
        if e.contract.advise is not pattern_advice:  # a triangle tour (cloverleaf, three-point)
            continue
        key, size, (room_x, room_y) = tour_size(e.params, area)
        # over 120°: the triangle repeats every 120° (pattern_advice's range)
        share = sum(tour_fits(e.params, area, deg) for deg in range(120)) / 120
        room = (f"inside the OpArea less wall_inset_m each side ({max(room_x, 0):.0f} × "
                f"{max(room_y, 0):.0f} m)")
        if not 0 < share < 1:  # fits every way, or none (the behaviour's own advice says so)
            continue
        if weak:
            why = (f"with (almost) no mean current the tour is laid out along the flow "
                   f"estimate's direction, and fits {room} in {share:.0%} of directions: "
                   "otherwise points")
        elif not tour_fits(e.params, area, toward):
            why = (f"laid out for the simulated mean flow ({where}), the tour's points do not "
                   f"fit {room}: wherever it is centred, points")
        else:
            continue
        out.append((("behaviours", i, e.family, key), f"{plain(size)} m: {why} are moved "
                    "inside the walls, so the tour flown is not the one drawn"
                    + ("" if weak else " (the meander turns it a little either way)")))
    return out


def move_advice(mission: MissionBase, params: EnvironmentParams) -> list[Problem]:
    """An information-seeking search whose candidate moves (``step_m``) are shorter than the
    simulated vehicle's turning circle: it asks for headings the vehicle cannot reach before
    it plans again (a review swapped in infotaxis and SAI at their defaults on MSN007: the
    vehicle was over 45° off the command in 49-69% of cycles, and the two flew the same track
    bit for bit, the vehicle turning at its limit whichever way was asked)."""
    if params.vehicle.heading_mode != "turn_radius":
        return []
    circle = 2.0 * params.vehicle.turning_radius_m
    out: list[Problem] = []
    for i, e in enumerate(mission.entries()):
        step = getattr(e.params, "step_m", None)
        if step is None or getattr(e.params, "replan_s", None) is None or step >= circle:
            continue
        out.append((("behaviours", i, e.family, "step_m"),
                    f"{plain(step)} m is shorter than the simulated vehicle's turning circle "
                    f"({plain(circle)} m): {e.variant} scores moves to points the vehicle "
                    "cannot turn onto before it reaches them, so the track is the turn's more "
                    "than the policy's (missions/tro2006_msn007_infotaxis.yaml flies "
                    "step_m: 15, replan_s: 6)"))
    return out


def launch_turn_advice(mission: MissionBase, params: EnvironmentParams,
                       pose: tuple[float, float, float]) -> list[Problem]:
    """A vehicle launched outside the OpArea heading away from it whose turn back carries it
    past the give-back line (``RELINQUISH_OUTSIDE_M`` outside; TRO II): the AMP gives control
    back within seconds and the run ends (a review's start 25 m outside a 50-m box, heading
    north away from it, ended at 4 s). Only without a ``mission_a``: there the AMP takes over
    where the vehicle's own mission brings it.

    The farthest the turn reaches: at distance ``d`` outside, heading ``φ`` off the outward
    normal (from the nearest point of the OpArea), a turn at radius ``R`` toward the OpArea
    reaches ``d + R(1 - sin φ)`` outside for ``φ < 90°`` (``d + R`` heading straight away),
    plus what the current's outward part ``c`` carries it while it turns to head straight in,
    ``c (π - φ) R / v``. Checked against flown runs (the small OpArea, speed 1 m/s, 6 seeds):
    heading straight out 20 m outside in a 0.1 m/s outward current (bound 29.9 m) flew on in
    all 6, 21 m outside (30.9 m) gave back in 5 (a review's case: the bound without the
    current, 28.5 m, had said nothing); with the current inward, 25 m outside heading 20° off
    the normal (29.9 m) flew on, 15° off (30.6 m) gave back."""
    if mission.mission_a is not None or params.vehicle.heading_mode != "turn_radius":
        return []
    area = mission.op_area_geometry()
    x, y, heading = pose
    d = area.distance_outside(x, y)
    if d <= 0.0:
        return []
    edge = area.clamp(x, y)  # the OpArea's nearest point
    nx, ny = (x - edge.x) / d, (y - edge.y) / d
    h = math.radians(heading)
    away = math.cos(h) * nx + math.sin(h) * ny  # cos φ
    if away <= 0.0:
        return []
    r = params.vehicle.turning_radius_m
    phi = math.acos(min(1.0, away))
    flow = math.radians(params.flow.mean_dir_deg)
    drift = max(0.0, params.flow.mean_speed_mps * (math.cos(flow) * nx + math.sin(flow) * ny))
    turn_s = (math.pi - phi) * r / max(mission.speed_mps, 1e-9)  # until it heads straight in
    reach = d + r * (1.0 - math.sin(phi)) + drift * turn_s
    if reach <= RELINQUISH_OUTSIDE_M:
        return []
    given = plain(getattr(mission.environment, "launch_heading_deg", 0.0))
    toward = math.degrees(math.atan2(-ny, -nx))
    if mission.frame != "planning":
        toward = area.frame.compass_deg(toward)
    key = (("environment", "launch") if getattr(mission.environment, "launch", None)
           else ("start",) if mission.start is not None else ("home",))
    return [(key, f"the vehicle starts {d:.1f} m outside the OpArea heading away from it "
                  f"(environment.launch_heading_deg {given}): "
                  f"its turn back ({plain(r)}-m turning radius) reaches about {reach:.1f} m "
                  f"outside, past the {RELINQUISH_OUTSIDE_M:g} m at which the AMP gives control "
                  f"back (TRO II), and the run ends within seconds; set "
                  f"environment.launch_heading_deg toward the OpArea (about "
                  f"{toward % 360.0:.0f}°), or start nearer to it")]


SOURCE_WALL_RADII = 2.0
"""A source closer to an OpArea wall than this many of the vehicle's turning radii is warned of
(:func:`source_wall_advice`)."""

TURN_GUARD_RADII = 10.0
"""An OpArea narrower than this many of the vehicle's turning radii, without
``turn_guard_radius_m``, is warned of."""

GUARDED_RADII = 5.0
"""... and one narrower than this many, with it (a new user's 30-m channel, 4 radii: every run
outside; the 50-m box, 6.7 radii: 1% of the time, 4.1 m on average)."""


def turn_guard_advice(mission: MissionBase, params: EnvironmentParams) -> list[Problem]:
    """A small OpArea without ``turn_guard_radius_m`` (a review's 50-m box was not told of
    it). Measured on the OMAE planner of ``missions/small_oparea.yaml`` scaled (8 seeds a
    size; the share of time safety drove, without / with a 7.5-m guard): 50 m 4.4% / 1.3%,
    60 m 3.6% / 1.0%, 70 m 2.7% / 0%, 80 m 0.5% / 0%, 100 m and 200 m 0% / 0%."""
    if params.vehicle.heading_mode != "turn_radius":
        return []
    area = mission.op_area_geometry()
    short = min(area.xmax - area.xmin, area.ymax - area.ymin)
    r = params.vehicle.turning_radius_m
    # no turn-around fits, whichever side it starts on (a review's 60 x 10 m corridor with the
    # guard went 11.7 m outside, safety driving 16% of the time)
    if short <= 2.0 * r * (1 + 1e-9):
        return [(("op_area", "corners"),
                 f"the OpArea is {plain(round(short, 1))} m across, no more than the simulated "
                 f"vehicle's turning circle ({plain(2 * r)} m, twice its {plain(r)}-m radius): "
                 "every turn-around carries it outside, whatever turn_guard_radius_m, and "
                 "safety takes over")]
    if mission.turn_guard_radius_m is not None and short < GUARDED_RADII * r:
        return [(("op_area", "corners"),
                 f"the OpArea is {plain(round(short, 1))} m across, under {GUARDED_RADII:g} of "
                 f"the simulated vehicle's {plain(r)}-m turning radii: even with "
                 "turn_guard_radius_m, turns at the walls carry it outside (a review's 30-m "
                 "channel with the guard: 60 runs of 60 outside, up to 11.7 m); keep a hard "
                 "boundary that far beyond the walls")]
    if mission.turn_guard_radius_m is not None or short >= TURN_GUARD_RADII * r:
        return []
    return [(("op_area", "corners"),
             f"the OpArea is {plain(round(short, 1))} m across, under {TURN_GUARD_RADII:g} of "
             f"the simulated vehicle's {plain(r)}-m turning radii: a turn at a wall carries it "
             f"outside, and safety takes over (4% of the time on a 50-m box); "
             f"turn_guard_radius_m: {plain(r)} starts such turns on the side that keeps the "
             "turning circle inside (1%; missions/small_oparea.yaml)"
             + ("; under 5 radii across not even that keeps every run in (a 30-m channel with "
                "it: 60 runs of 60 outside)" if short < GUARDED_RADII * r else ""))]


def _under(v: float) -> str:
    """A distance found under a mark, shown to 0.1 m without rounding up to it (a review's
    14.99999 m read "15.0 m ... under two of the 7.5-m turning radii")."""
    return f"{math.floor(v * 10) / 10:.1f}"


def flow_direction_advice(mission: MissionBase, params: EnvironmentParams) -> list[Problem]:
    """A compass mission whose simulated current has no compass direction: without
    ``environment.flow_toward_deg`` the direction is the preset's, or
    ``environment.flow.mean_dir_deg``, both from the OpArea's x axis (planning frame), so
    turning the box (or which side is longer) turns the ocean (a review's N-S box flowed toward
    2°, the same box rotated 30° toward 32°, both validated ``ok``; a diff review: the same
    with ``flow.mean_dir_deg`` set)."""
    env = mission.environment
    if mission.frame == "planning" or env is None or getattr(env, "flow_toward_deg", None) \
            is not None:
        return []
    frame = mission.op_area_geometry().frame
    compass = (frame.x_bearing_deg + params.flow.mean_dir_deg) % 360
    given = "mean_dir_deg" in (getattr(env, "flow", None) or {})
    whose = ("environment.flow.mean_dir_deg, a planning-frame angle" if given
             else "its preset's direction")
    return [(("environment",),
             f"no flow_toward_deg: the simulated current takes {whose}, "
             f"{plain(round(params.flow.mean_dir_deg, 1))}° from the OpArea's x axis, which "
             f"here is toward compass {compass:.1f}°, and turns with the box; set "
             "environment.flow_toward_deg (compass) for the ocean you mean")]


def source_wall_advice(mission: MissionBase, params: EnvironmentParams,
                       sources: list[Point]) -> list[Problem]:
    """A source whose plume leaves the OpArea at once, or one near a wall (a review: a source
    3 m inside a corner of a 200-m box validated ``ok``; 6 runs went 4.9-14 m outside while
    reacquiring about it, 4.9-8.3 m with a 7.5-m ``turn_guard_radius_m``).

    Near a wall: closer than two turning radii. Measured on a 200-m box, the TRO planner of
    ``missions/tro2006_msn007.yaml``, the source at a depth d inside the up-flow wall, 8 runs
    a depth (runs outside / farthest / share of the AMP's time safety drove): d = 3 m 8 / 8.7 m
    / 4.7%; 8 m 8 / 11.5 m / 4.4%; 13 m 7 / 5.7 m / 1.3%; 20 m 3 / 2.7 m / 0%; 30 m 1 / 0.8 m
    / 0%. The vehicle overshoots the source up-flow by up to λ at speed and turns there.

    The plume's length inside is measured along the mean flow from the source to the wall it
    leaves by: detections outside the OpArea are ignored (TRO V), so a plume that leaves within
    two turning radii is hardly there to be found. Only for a vehicle that turns at a radius
    (the simulator's ``turn_radius`` heading mode; AB's searchers turn otherwise). With
    ``turn_guard_radius_m``, which shortens the excursions but does not end them (a review of
    the change: the 50-m box's guarded mission, its source 3 m inside a corner, 6 of 6 runs
    outside, up to 11.2 m), within one turning radius: ``missions/small_oparea.yaml``'s source,
    13 m in with a guard, leaves the box by 4.1 m on average (README), which is the small box's
    own (:func:`turn_guard_advice`), and is not warned of.
    """
    if params.vehicle.heading_mode != "turn_radius":
        return []
    area = mission.op_area_geometry()
    r = params.vehicle.turning_radius_m
    reach = SOURCE_WALL_RADII * r
    flow = math.radians(params.flow.mean_dir_deg)
    # a component below 1e-9 is along the other axis (cos 90° is 6e-17, not 0: a review's source
    # on a wall, the flow along it, was told its plume left the OpArea at once)
    ux, uy = (c if abs(c) > 1e-9 else 0.0 for c in (math.cos(flow), math.sin(flow)))
    guard = mission.turn_guard_radius_m
    out: list[Problem] = []
    for j, s in enumerate(sources):
        key = ("environment", "source") if j == 0 else ("environment", "extra_sources", j - 1)
        if not area.contains(s.x, s.y):
            continue  # refused elsewhere
        inside = min(((area.xmax if ux > 0 else area.xmin) - s.x) / ux if ux else math.inf,
                     ((area.ymax if uy > 0 else area.ymin) - s.y) / uy if uy else math.inf)
        if params.flow.mean_speed_mps > 0 and inside < reach:
            out.append((key, f"the mean flow carries this source's plume out of the OpArea "
                        f"{_under(inside)} m down-flow of it: detections outside the OpArea are "
                        "ignored (TRO V), so there is hardly a plume to find and track; move "
                        "the source up-flow, or the OpArea's down-flow wall out"))
        depth = area.depth_inside(s.x, s.y)
        if depth < (reach if guard is None else r):
            fix = (f"turn_guard_radius_m: {plain(r)} shortens those turns (5-8 m against 5-14 m "
                   "with a source 3 m inside a corner)" if guard is None else
                   "turn_guard_radius_m shortens those turns but does not keep them in (a "
                   "source 3 m inside a corner of the 50-m box: 6 runs of 6 outside, up to "
                   "11.2 m)")
            out.append((key, f"{_under(depth)} m from an OpArea wall, under two of the simulated "
                        f"vehicle's {plain(r)}-m turning radii: the turns about the source "
                        "carry the vehicle outside and safety takes over (8 runs 3-8 m from "
                        f"the up-flow wall: every one outside, up to 11.5 m); {fix}, or place "
                        "the source farther in"))
    return out
