"""How far outside the OpArea a run went, less the legs the mission itself puts outside.

``farthest_outside_m`` and ``safety_entering_s`` of :class:`~cptbt.batch.summary.RunSummary`
(``tables.md``'s "Left the OpArea"): the way in from a start or launch outside, and the way to
a home the mission puts outside (``allow_outside: [home]``), are the mission's, not
excursions.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from cptbt.batch.comparison import OUTSIDE_NOTED_M
from cptbt.batch.engine import VehicleRun
from cptbt.frames import OpArea
from cptbt.mission import MissionBase
from cptbt.types import Point


def is_home_leg(active: str | None) -> bool:
    """Whether a behaviour (its recorded name) is driving home: ``return_home``, or a declaration
    behaviour on its way home after declaring."""
    return active is not None and (active.startswith("return_home.")
                                   or active.endswith(" (home)"))


def outside_away_from(area: OpArea, x: NDArray[np.float64], y: NDArray[np.float64],
                      home: Point) -> NDArray[np.float64]:
    """How far outside the OpArea each point is through the walls ``home`` is not beyond: the
    way to a home outside crosses its own walls, an overshoot through another is still an
    excursion (a diff review: the turn after a declaration had gone 2.7 m out of the far
    wall, hidden with the whole leg home)."""
    lo_x, hi_x = np.maximum(area.xmin - x, 0.0), np.maximum(x - area.xmax, 0.0)
    lo_y, hi_y = np.maximum(area.ymin - y, 0.0), np.maximum(y - area.ymax, 0.0)
    dx = np.maximum(lo_x * (home.x >= area.xmin), hi_x * (home.x <= area.xmax))
    dy = np.maximum(lo_y * (home.y >= area.ymin), hi_y * (home.y <= area.ymax))
    return np.hypot(dx, dy)


def home_legs(mission: MissionBase, active: Sequence[str]) -> NDArray[np.bool_] | None:
    """The rows driving to a home the mission puts outside the OpArea on purpose
    (``allow_outside: [home]``); None when home is not allowed outside."""
    if "home" not in mission.allow_outside:
        return None
    return np.array([is_home_leg(a) for a in active], dtype=bool)


def safety_entering(mission: MissionBase, run: VehicleRun, true: NDArray[np.float64]) -> float:
    """Seconds the safety behaviour drove before the true track first got inside the OpArea:
    bringing the vehicle in from a launch or start outside, the mission's way in rather than a
    guard against an excursion (a review's dock 18 m out read "safety drove 5.1%")."""
    if not len(true):
        return 0.0
    far = mission.op_area_geometry().distance_outside_array(true[:, 0], true[:, 1])
    inside = np.flatnonzero(far == 0.0)
    entry = int(inside[0]) if len(inside) else len(far)
    if entry == 0:
        return 0.0
    before = np.arange(len(far)) < entry
    return sum(s for name, s in run.recorder.time_in(run.index, before).items()
               if name.split(".")[0] == "safety")


def farthest_outside(mission: MissionBase, true: NDArray[np.float64],
                      skip: NDArray[np.bool_] | None = None) -> float:
    """How far outside the OpArea a true track went, m (0: it stayed inside), once it was in:
    the way in from a start placed outside (``allow_outside: [start]``) is the mission's, not
    an excursion (a review's start 20 m out read "left the OpArea: 19.8 m"). Going farther out
    than the start before getting in, or without ever getting in, is one (a detour), and
    counts as far out as the track went: a review's start 25 m out, turned away and given
    back 30 m out, had read "at most 4.5 m outside it" (the detour's depth beyond its start,
    not a distance outside). Rows in ``skip`` (:func:`home_legs`: the way to a home the mission
    puts outside) count only through the walls home is not beyond (:func:`outside_away_from`):
    a review's dock 18 m out read "left the OpArea: 10.9 m" for the leg home after the
    declaration."""
    if not len(true):
        return 0.0
    far = mission.op_area_geometry().distance_outside_array(true[:, 0], true[:, 1])
    known = np.flatnonzero(np.isfinite(far))
    if not len(known):
        return 0.0
    inside = np.flatnonzero(far == 0.0)
    entry = int(inside[0]) if len(inside) else len(far)
    if skip is not None and len(skip) == len(far):
        away = outside_away_from(mission.op_area_geometry(), true[:, 0], true[:, 1],
                                 mission.to_xy(mission.home))
        far = np.where(skip, away, far)
    before = float(np.nanmax(far[:entry], initial=0.0))
    # from the first known point (a diff review: a NaN first one made every detour 0)
    detour = before if before - far[known[0]] >= OUTSIDE_NOTED_M else 0.0
    return max(detour, float(np.nanmax(far[entry:], initial=0.0)), 0.0)
