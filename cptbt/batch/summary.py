"""The measures of one run (SPEC §11; TRO V, Tables III–IV; AB 3)."""

from __future__ import annotations

import itertools
import math
from typing import Any

from cptbt.batch.engine import VehicleRun
from cptbt.mission import MissionBase
from cptbt.types import Point

NEAR_SOURCE_M = 13.0
"""TRO V: t2 is the first time within 13 m of the declared source."""


def _path_length(points: list[tuple[float, float]]) -> float:
    return sum(math.dist(a, b) for a, b in itertools.pairwise(points))


def _where(mission: MissionBase, p: Point | None) -> dict[str, float] | None:
    """A planning point in planning, N-E and (when the mission has a geodetic anchor) lat/lon."""
    if p is None:
        return None
    n, e = mission.to_ne(p)
    out = {"x": p.x, "y": p.y, "north": n, "east": e}
    geo = mission.to_geodetic(p)
    if geo is not None:
        out |= {"lat": geo.lat_deg, "lon": geo.lon_deg}
    return out


def summarise(
    run: VehicleRun,
    mission: MissionBase,
    source: Point,
    seed: int | None,
    wall_time_s: float,
    t0: float = 0.0,
) -> dict[str, Any]:
    """One run's summary: outcome, times t0–t3, T_F T_T T_D, path lengths D0–D3, errors.

    Readings chosen where SPEC is silent: times and D0 use the navigation estimate, as the AMP
    saw it (the declared source is in that frame); path lengths D1–D3 use the true track, so LBL
    jumps do not count as distance travelled; ``error_m`` is the declared source against the true
    source (for the oracle, the vehicle's distance to the source when it stopped). ``t0`` is the
    start of Mission B (the AMP take-over; 0 when the AMP drives from launch).
    """
    t1, t3 = run.t1, run.t3
    declared = run.declared
    t2 = None
    i1 = i2 = i3 = None
    if t1 is not None:
        i1 = run.path_t.index(t1)
    if declared is not None and i1 is not None and t3 is not None:
        i3 = run.path_t.index(t3)
        for i in range(i1, i3 + 1):
            x, y = run.path_est[i]
            if math.hypot(x - declared.x, y - declared.y) <= NEAR_SOURCE_M:
                i2, t2 = i, run.path_t[i]
                break
        if i2 is None:  # declared before ever passing within 13 m of the spot
            i2, t2 = i3, t3

    def span(a: float | None, b: float | None) -> float | None:
        return None if a is None or b is None else b - a

    d0 = d1 = d2 = None
    if declared is not None and i1 is not None:
        ex, ey = run.path_est[i1]
        d0 = math.hypot(declared.x - ex, declared.y - ey)
    if i1 is not None and i2 is not None and i3 is not None:
        d1 = _path_length(run.path_true[i1 : i2 + 1])
        d2 = _path_length(run.path_true[i2 : i3 + 1])
    if run.outcome == "found":
        error = run.error_at_end_m
    elif declared is not None:
        error = math.hypot(declared.x - source.x, declared.y - source.y)
    else:
        error = None
    total_time = sum(run.time_in.values()) or 1.0
    return {
        "mission": mission.name,
        "seed": seed,
        "outcome": run.outcome,
        "start": {"x": run.start[0], "y": run.start[1]},
        "declared_source": _where(mission, declared),
        "true_source": _where(mission, source),
        "error_m": error,
        "t0": t0, "t1": t1, "t2": t2, "t3": t3,
        "T_F": span(t0, t1), "T_T": span(t1, t2), "T_D": span(t2, t3),
        "T_total": span(t0, t3) if t3 is not None else span(t0, run.t_end),
        "D0": d0, "D1": d1, "D2": d2,
        "D3": None if d1 is None or d2 is None else d1 + d2,
        "D1_over_D0": None if not d0 or d1 is None else d1 / d0,
        "detections": len(run.detections),
        "lost_contacts": len(run.lost_contacts),
        "sim_time_s": run.t_end,
        "wall_time_s": wall_time_s,
        "time_in_behaviour_s": dict(sorted(run.time_in.items())),
        "time_share": {k: v / total_time for k, v in sorted(run.time_in.items())},
    }
