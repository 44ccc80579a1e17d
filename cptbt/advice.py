"""Warnings for missions that are valid but likely not what their author means.

:meth:`cptbt.mission.MissionBase.advisories` returns them as (key path, message) and the CLI
prints each at its key's line, exit 0: a success radius whose disc covers much of a small
OpArea, each behaviour's own (:attr:`cptbt.node.Contract.advise`), and Mission A settings under
which the AMP never takes over or never gets back. Those only a simulated world shows are in
:func:`cptbt.batch.scenario.advisories`.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from cptbt.policy import RELINQUISH_OUTSIDE_M, metres_text

if TYPE_CHECKING:
    from cptbt.frames import OpArea
    from cptbt.mission import MissionBase, Problem

SUCCESS_DISC_SHARE = 1 / 3
"""A success radius whose disc covers more of the OpArea than this is warned of."""


def advisories(mission: MissionBase) -> list[Problem]:
    """The mission's warnings, as (key path, message); empty for a mission with problems."""
    try:
        area = mission.op_area_geometry()
    except ValueError:
        return []
    out: list[Problem] = []
    r = mission.evaluation.success_radius_m
    share = area.disc_share(r)
    if share > SUCCESS_DISC_SHARE:
        given = ("evaluation" in mission.model_fields_set
                 and "success_radius_m" in mission.evaluation.model_fields_set)
        what = ("a declaration drawn at random would count as a success" if
                mission.evaluation.criterion == "declaration" else
                "a vehicle at a random point would count as having reached the source")
        out.append((("evaluation", "success_radius_m"),
                    f"{r:g} m{'' if given else ' (the default)'}: a disc this size covers "
                    f"{100 * share:.0f}% of the OpArea, so {what} about that often (a "
                    f"radius of {area.disc_radius(SUCCESS_DISC_SHARE):.1f} m covers a third)"))
    for i, e in enumerate(mission.entries()):
        for key, why in e.contract.advise(e.params, area) if e.contract.advise else []:
            out.append((("behaviours", i, e.family, key), why))
        need = e.contract.min_cycle_hz
        if need is not None and mission.cycle_hz < need:  # a review's AB strategy at 1 Hz
            out.append((("cycle_hz",), f"{mission.cycle_hz:g} Hz is slower than the "
                        f"{need:g} Hz {e.family} {e.variant} needs: its timings are fractions "
                        "of a second (SPEC §2), which a slower cycle only meets late"))
    out += order_advice(mission) + family_advice(mission) + start_advice(mission)
    out += allowed_inside_advice(mission, area)
    cycle, lam = 1.0 / mission.cycle_hz, mission.perception.lambda_s
    if cycle > lam:  # a review's AB strategy at 0.2 Hz never reacquired
        out.append((("cycle_hz",), f"{mission.cycle_hz:g} Hz is a cycle of {cycle:g} s, "
                    f"longer than perception.lambda_s ({lam:g} s): contact is lost between any "
                    "two cycles, so maintain-plume hands over at once and timed behaviours "
                    "act late"))
    return out + mission_a_advice(mission) + centre_advice(mission)


FAR_WAYPOINT_M = 5_000.0
"""A Mission A waypoint farther than this outside the OpArea is warned of: a slip of one digit
in the second decimal of a degree (1.1 km) is not caught, one in the first (11 km: a re-test's,
which validated at 20 km) is; a transit of 5 km to the OpArea is warned of, and may be meant."""

CENTRE_OFF_SHARE = 0.5
"""A ``geodetic_centre_deg`` farther from the corners' own centre than this share of the
OpArea's diagonal is warned of."""


def centre_advice(mission: MissionBase) -> list[Problem]:
    """A ``geodetic_centre_deg`` far from the corners: every N-E output is measured from it, so
    a typo moves them all (a review's 0.01° slip: "source N 1113.7 m" in a 150-m OpArea)."""
    given = mission.op_area.geodetic_centre_deg
    if given is None or mission.frame != "geodetic":
        return []
    from cptbt.geodesy import LocalFrame

    own = LocalFrame.centred_on([tuple(c) for c in mission.op_area.corners])  # type: ignore[misc]
    n, e = own.to_ne(float(given[0]), float(given[1]))
    off = math.hypot(n, e)
    diagonal = mission.op_area_geometry().diagonal_m
    if off <= CENTRE_OFF_SHARE * diagonal:
        return []
    return [(("op_area", "geodetic_centre_deg"),
             f"{off:.0f} m from the corners' centre (the OpArea's diagonal is {diagonal:.0f} m): "
             "every north-east position printed is measured from it; a typo?")]


ALWAYS_DRIVES = ("find_plume",)
"""Families whose variants have a command every cycle: nothing listed below them drives."""

PLUME_FAMILIES = ("declare_source", "maintain_plume", "reacquire_plume")
"""The families that must stand above find-plume to drive at all (SPEC §3, TRO Fig. 2)."""


def order_advice(mission: MissionBase) -> list[Problem]:
    """Safety missing or not listed first; a plume behaviour listed below one that always
    drives never drives (a review's find_plume above maintain_plume searched for 600 s, its
    plume never tracked)."""
    out: list[Problem] = []
    families = [e.family for e in mission.entries()]
    if families and "safety" not in families:  # a review's flew out to the give-back, silently
        out.append((("behaviours",), "no safety behaviour: nothing turns the vehicle back into "
                    "the OpArea, so a behaviour heading out drives on until the give-back "
                    f"{RELINQUISH_OUTSIDE_M:g} m outside (SPEC §3 and TRO Fig. 2 put safety "
                    "first: - safety: {variant: oparea})"))
    if families and "declare_source" not in families and \
            mission.evaluation.criterion == "declaration":  # a review's: 0% and no word why
        out.append((("behaviours",), "no declare_source behaviour, and runs are judged by "
                    "their declaration (evaluation.criterion: declaration): unless a plug-in "
                    "behaviour of another family declares, every run ends at the time limit "
                    "without one and none can succeed"))
    if "safety" in families[1:]:  # a review's safety listed last validated silently
        k = families.index("safety")
        below = next((f"{f} (behaviours[{i}]), which has a command every cycle: it never "
                      "drives" for i, f in enumerate(families[:k]) if f in ALWAYS_DRIVES),
                     f"{families[0]}: it drives only when no behaviour above it has a command")
        out.append((("behaviours", k, "safety"),
                     f"the OpArea guard is listed below {below}, so the vehicle can leave the "
                     "OpArea unchecked (SPEC §3 and TRO Fig. 2 put safety first)"))
    for i, family in enumerate(families):
        if family not in ALWAYS_DRIVES:
            continue
        for j in range(i + 1, len(families)):
            if families[j] in PLUME_FAMILIES:
                out.append((("behaviours", j, families[j]),
                            f"listed below {family} (behaviours[{i}]), which has a command "
                            "every cycle: it never drives (the list is highest priority "
                            "first; SPEC §3 puts declare_source, maintain_plume and "
                            "reacquire_plume above find_plume)"))
    return out


def start_advice(mission: MissionBase) -> list[Problem]:
    """Move-to-field listed without a ``start:`` (a review's half-typed ``start:`` flew from
    home, move-to-field idle, without a word; an empty ``home:`` is an error)."""
    if mission.start is not None:
        return []
    families = [e.family for e in mission.entries()]
    if "move_to_field" not in families:
        return []
    at = (("start",) if "start" in mission.model_fields_set
          else ("behaviours", families.index("move_to_field"), "move_to_field"))
    return [(at, f"{NO_START}: under cptbt run move_to_field has no goal and the vehicle "
             "starts at home (a study's --grid or --starts gives each run a start of its own)")]


def allowed_inside_advice(mission: MissionBase, area: OpArea) -> list[Problem]:
    """A ``start`` or ``home`` listed in ``allow_outside`` that lies inside the OpArea (a review:
    a home meant for a dock outside, placed inside by a slip of frame or sign, said nothing)."""
    out: list[Problem] = []
    for i, key in enumerate(mission.allow_outside):
        coord = getattr(mission, key, None) if key in ("start", "home") else None
        if coord is None:
            continue
        if key == "start" and mission.study is not None and mission.study.starts:
            continue  # the listing allows the study's starts outside
        p = mission.to_xy(coord)
        if area.distance_outside(p.x, p.y) <= 0:
            also = ("" if key == "home" else
                    "; a study's starts outside (--starts, --grid) are allowed by it")
            out.append((("allow_outside", i), f"{key!r} is listed but lies inside the OpArea: "
                        f"the listing has no effect on it (a slip in its coordinates or frame?)"
                        f"{also}"))
    return out


NO_START = "the mission has no start"
"""The start advisory's opening: a study, whose runs each have a start, leaves it out."""


def family_advice(mission: MissionBase) -> list[Problem]:
    """A plug-in family one slip from a TRO slot (a review's plug-in registered
    ``reaquire_plume``, and the mission that listed it validated silently)."""
    from cptbt.registry import misspelt_slot

    out: list[Problem] = []
    for i, e in enumerate(mission.entries()):
        slot = misspelt_slot(e.family)
        if slot is not None:
            out.append((("behaviours", i, e.family),
                        f"{e.family!r} is not one of TRO's slots but a plug-in's own family, "
                        f"one slip from {slot!r}: if the plug-in ({e.family} {e.variant}) "
                        f"meant that slot, its family is misspelt, and the rules for "
                        f"{slot} (its place in the order, its reports) do not apply to it"))
    return out


def mission_a_advice(mission: MissionBase) -> list[Problem]:
    """Mission A settings under which the AMP never takes over, or never hands back."""
    a = mission.mission_a
    if a is None:
        return []
    out: list[Problem] = []
    last = len(a.waypoints) - 1
    if a.amp_enable_waypoint is not None:
        from cptbt.policy import RELINQUISH_OUTSIDE_M

        at = mission.to_xy(a.waypoints[a.amp_enable_waypoint])
        outside = mission.op_area_geometry().distance_outside(at.x, at.y)
        if outside > RELINQUISH_OUTSIDE_M:  # a review's AMP took over and gave back at once
            out.append((("mission_a", "waypoints", a.amp_enable_waypoint),
                        f"the take-over waypoint is {metres_text(outside)} m outside the OpArea: "
                        f"the AMP gives control back {RELINQUISH_OUTSIDE_M:g} m outside it (TRO "
                        "II), so it would give back in its first cycle"))
    area = mission.op_area_geometry()
    for i, wp in enumerate(a.waypoints):  # a lost sign or swapped lat/lon (a review's 9 500 km)
        at = mission.to_xy(wp)
        far = area.distance_outside(at.x, at.y)
        if far > FAR_WAYPOINT_M:
            out.append((("mission_a", "waypoints", i),
                        f"{metres_text(far / 1000)} km outside the OpArea: a slip (a sign, lat/lon "
                        "swapped)? The vehicle would spend its mission getting there"))
    if a.amp_enable_waypoint == last and not a.loop:
        out.append((("mission_a", "amp_enable_waypoint"), f"{last} is the last waypoint: "
                    "Mission A ends on reaching it, before the AMP can take over"))
    if a.amp_enable_s is not None and a.amp_enable_s >= a.duration_limit_s:
        out.append((("mission_a", "amp_enable_s"), f"{a.amp_enable_s:g} s is not before "
                    f"Mission A's end (duration_limit_s {a.duration_limit_s:g} s): the AMP "
                    "never takes over"))
    cycle = 1.0 / mission.cycle_hz
    if a.watchdog_s <= cycle:
        out.append((("mission_a", "watchdog_s"), f"{a.watchdog_s:g} s is no longer than a "
                    f"planning cycle ({cycle:g} s): the vehicle's watchdog ends every override "
                    "between two commands"))
    step = a.speed_mps * cycle
    if a.capture_radius_m < 0.5 * step:
        out.append((("mission_a", "capture_radius_m"), f"{a.capture_radius_m:g} m is less than "
                    f"half the {step:g} m Mission A covers in a cycle: the vehicle can pass a "
                    "waypoint, or the break-off point, without coming within it"))
    return out
