"""``cptbt batch``'s starts: from its flags or the mission's ``study:`` section, in the planning
frame, each checked to lie in the OpArea."""

from __future__ import annotations

import argparse

from cptbt.batch.starts import grid_starts
from cptbt.cli.argtypes import UsageError
from cptbt.mission import MissionBase
from cptbt.policy import metres_text
from cptbt.study_spec import StudySpec


def study_starts(args: argparse.Namespace, mission: MissionBase,
                 spec: StudySpec | None) -> list[tuple[float, float]]:
    """The study's starts (planning frame): the flags, else the study section, else the
    mission's start."""
    if args.grid:
        return grid_starts(mission, *args.grid)
    if args.starts_x:
        return [(x, args.y) for x in args.starts_x]
    if args.starts:
        return [_planning(mission, c) for c in args.starts]
    if spec is not None and spec.grid is not None:
        return grid_starts(mission, *spec.grid)
    if spec is not None and spec.line is not None:
        line = spec.line
        n = int((line.x_to_m - line.x_from_m) / line.step_m + 1e-9) + 1
        return [(line.x_from_m + k * line.step_m, line.y_m) for k in range(n)]
    if spec is not None and spec.starts:
        return [_planning(mission, c) for c in spec.starts]
    return [_planning(mission, mission.start or mission.home)]


def check_starts(mission: MissionBase, starts: list[tuple[float, float]]) -> None:
    """Every start inside the OpArea, as ``validate`` asks of the mission's own start.

    A start typed in the wrong frame (N-E metres for a geodetic mission's lat, lon) lands
    thousands of km away and would fly a silent 0 % study.
    """
    if "start" in mission.allow_outside:
        return
    area = mission.op_area_geometry()
    for x, y in starts:
        if not area.contains(x, y):
            frame = {"geodetic": "lat, lon in degrees", "ne": "north, east in m"}.get(
                str(mission.frame), "x, y in m (planning frame)")
            raise UsageError(
                f"batch: the start at planning ({x:.1f}, {y:.1f}) m is "
                f"{metres_text(area.distance_outside(x, y))} m outside the OpArea (starts are "
                f"given as {frame}; list 'start' in the mission's allow_outside if that is "
                "intended)")


def _planning(mission: MissionBase, coord: tuple[float, float]) -> tuple[float, float]:
    p = mission.to_xy(coord)
    return p.x, p.y
