"""Any OpArea, any flow (issue 11): the TRO planner with the current at every angle to the OpArea.

Protocol. The base is missions/tro2006_msn007.yaml (TRO ocean preset: ~0.1 m/s current whose
direction wanders by tens of degrees, LBL navigation with jumps, REMUS turning radius 7.5 m),
flown by the AMP alone from the mission's start point. The mean current is set toward each
planning angle 0°, 30°, ..., 330° from the OpArea's +x axis. Seed k places the source uniformly
in one corner quarter of the OpArea (quarter drawn at random), at least ``--margin`` m inside
the walls, and seeds the simulator; the same five sources are used at every angle.

Measured per angle: declarations within 15 m of the true source, declarations beyond 15 m
(false), runs without a declaration; safety take-overs per run (median, max); the farthest the
true vehicle went outside the OpArea (true position: navigation error included); and find-plume
coverage — a separate run per seed with no detectable plume, in which find-plume searches for
the whole time limit, and the fraction of the OpArea within 20 m of its path, also relative to
the along-x (0°) case. The search-only runs' take-overs are shown apart (30 minutes of wall
bounces each); "max outside" covers both kinds of run.

A second table flies missions/small_oparea.yaml (50 x 50 m, OMAE variants) with the current at
the same angles: the same outcomes, take-overs and excursions.

``--reference flow`` flies find-plume with TRO's letter (legs off the flow estimate itself) to
show why that is not the default.

    python benchmarks/any_flow.py [--quick] [--seeds 5] [--workers 2] [--reference flow]
"""

from __future__ import annotations

import argparse
import math
import os
import platform
import statistics
import sys
import time
from collections.abc import Iterable, Sequence
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np

from cptbt.batch.engine import VehicleRun, simulate
from cptbt.batch.scenario import Environment, environment_of, launch_pose, to_sim_params
from cptbt.frames import OpArea
from cptbt.loader import load_mission
from cptbt.mission import MissionBase, mission_model, mission_to_data
from cptbt.registry import default_registry
from cptbt.types import Point

ROOT = Path(__file__).resolve().parents[1]
TRO = ROOT / "missions/tro2006_msn007.yaml"
SMALL = ROOT / "missions/small_oparea.yaml"
FALSE_M = 15.0
COVER_M = 20.0


def load(path: Path) -> MissionBase:
    """A shipped mission with its simulated environment."""
    return load_mission(path, default_registry(), Environment)


def with_reference(mission: MissionBase, reference: str) -> MissionBase:
    """``mission`` with its find-plume offsets measured from ``reference``."""
    data = mission_to_data(mission)
    for item in data["behaviours"]:
        if "find_plume" in item:
            item["find_plume"]["reference"] = reference
    return mission_model(default_registry(), Environment).model_validate(data)


def corner_source(area: OpArea, seed: int, margin_m: float) -> Point:
    """A source uniform in a random corner quarter of ``area``, ``margin_m`` inside its walls."""
    rng = np.random.default_rng([11, seed])
    c = area.centre
    qx, qy = rng.integers(0, 2, size=2)
    x0, x1 = (area.xmin + margin_m, c.x) if qx == 0 else (c.x, area.xmax - margin_m)
    y0, y1 = (area.ymin + margin_m, c.y) if qy == 0 else (c.y, area.ymax - margin_m)
    return Point(float(rng.uniform(x0, x1)), float(rng.uniform(y0, y1)))


def variant(
    base: MissionBase, angle_deg: float, source: Point, *, plume: bool = True
) -> MissionBase:
    """``base`` with the mean current toward planning angle ``angle_deg`` and the source moved.

    Without ``plume`` the puffs carry no mass a sensor can detect: find-plume searches alone.
    """
    env = environment_of(base)
    area = base.op_area_geometry()
    if base.frame == "planning":
        where: tuple[float, float] = (source.x, source.y)
        toward = angle_deg
    else:
        where = base.to_ne(source)
        toward = area.frame.compass_deg(angle_deg)
    update: dict[str, Any] = {"source": where, "flow_toward_deg": toward}
    if not plume:
        update["plume"] = {**env.plume, "puff_mass": 1e-12}
    new_env = env.model_copy(update=update)
    return base.model_copy(update={"environment": new_env, "mission_a": None})


def take_overs(active: Sequence[str]) -> int:
    """Number of times safety took the vehicle over."""
    count, before = 0, ""
    for name in active:
        if name.startswith("safety") and not before.startswith("safety"):
            count += 1
        before = name
    return count


def coverage(area: OpArea, path: Iterable[tuple[float, float]], radius_m: float = COVER_M,
             cell_m: float = 2.0) -> float:
    """Fraction of ``area`` within ``radius_m`` of the points of ``path`` (densified to 1 m)."""
    xs = np.arange(area.xmin + cell_m / 2, area.xmax, cell_m)
    ys = np.arange(area.ymin + cell_m / 2, area.ymax, cell_m)
    gx, gy = np.meshgrid(xs, ys)
    covered = np.zeros(gx.shape, dtype=bool)
    pts = np.asarray(list(path), dtype=float).reshape(-1, 2)
    if len(pts) > 1:
        seg = np.diff(pts, axis=0)
        n = np.maximum(1, np.ceil(np.hypot(seg[:, 0], seg[:, 1]))).astype(int)
        dense = [pts[i] + seg[i] * (np.arange(n[i])[:, None] / n[i]) for i in range(len(seg))]
        pts = np.vstack([*dense, pts[-1:]])
    r2 = radius_m * radius_m
    for x, y in pts:
        i0, i1 = np.searchsorted(xs, [x - radius_m, x + radius_m])
        j0, j1 = np.searchsorted(ys, [y - radius_m, y + radius_m])
        if i0 < i1 and j0 < j1:
            sub = (gx[j0:j1, i0:i1] - x) ** 2 + (gy[j0:j1, i0:i1] - y) ** 2 <= r2
            covered[j0:j1, i0:i1] |= sub
    return float(covered.mean())


def fly(mission: MissionBase, seed: int) -> tuple[VehicleRun, Point]:
    """One traced run of ``mission``; the run and the true source (planning frame)."""
    params = to_sim_params(mission, seed)
    (run,), _, _ = simulate(mission, params, [launch_pose(mission)], trace=True)
    return run, Point(*params.source_xy_m)


def one(job: tuple[str, float, int, float, str]) -> dict[str, Any]:
    """Both runs of one (mission, angle, seed): with the plume, and find-plume alone."""
    path, angle, seed, margin, reference = job
    base = with_reference(load(Path(path)), reference)
    area = base.op_area_geometry()
    source = corner_source(area, seed, margin)
    run, src = fly(variant(base, angle, source), seed)
    assert run.trace is not None
    active = run.trace["active"]
    outside = max(area.distance_outside(x, y) for x, y in run.path_true)
    error = None if run.declared is None else run.declared.distance_to(src)
    search, _ = fly(variant(base, angle, source, plume=False), seed)
    assert search.trace is not None
    swept = [xy for xy, a in zip(search.path_true, search.trace["active"], strict=True)
             if a.startswith("find_plume")]
    return {
        "angle": angle, "seed": seed, "error_m": error, "t1": run.t1, "t3": run.t3,
        "take_overs": take_overs(active), "outside_m": outside,
        "coverage": coverage(area, swept),
        "search_take_overs": take_overs(search.trace["active"]),
        "search_outside_m": max(area.distance_outside(x, y) for x, y in search.path_true),
    }


def table(rows: list[dict[str, Any]], angles: Sequence[float]) -> list[str]:
    """The Markdown table of one study, one line per angle and a total."""
    base_cov = statistics.mean(r["coverage"] for r in rows if r["angle"] == 0.0) if any(
        r["angle"] == 0.0 for r in rows) else math.nan
    out = [
        "| flow (deg from +x) | runs | declared <= 15 m | declared > 15 m | none | "
        "take-overs median / max | search take-overs max | max outside (m) | median t1 (s) | "
        "coverage | vs 0 deg |",
        "|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    groups = [(f"{a:.0f}", [r for r in rows if r["angle"] == a]) for a in angles]
    groups.append(("**all**", rows))
    for label, rs in groups:
        good = sum(r["error_m"] is not None and r["error_m"] <= FALSE_M for r in rs)
        bad = sum(r["error_m"] is not None and r["error_m"] > FALSE_M for r in rs)
        none = sum(r["error_m"] is None for r in rs)
        takes = [r["take_overs"] for r in rs]
        search_takes = max(r["search_take_overs"] for r in rs)
        outside = max(max(r["outside_m"], r["search_outside_m"]) for r in rs)
        t1 = [r["t1"] for r in rs if r["t1"] is not None]
        cov = statistics.mean(r["coverage"] for r in rs)
        out.append(
            f"| {label} | {len(rs)} | {good} ({100 * good / len(rs):.0f}%) | {bad} | {none} | "
            f"{statistics.median(takes):.0f} / {max(takes)} | {search_takes} | {outside:.1f} | "
            f"{statistics.median(t1) if t1 else math.nan:.0f} | {cov:.2f} | "
            f"{100 * (cov / base_cov - 1):+.0f}% |"
        )
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="angles 0, 90, 210 and 2 seeds")
    ap.add_argument("--seeds", type=int, default=5)
    ap.add_argument("--margin", type=float, default=15.0,
                    help="least distance of the source from the OpArea walls, m")
    ap.add_argument("--workers", type=int, default=1)
    ap.add_argument("--small", action=argparse.BooleanOptionalAction, default=True,
                    help="also fly missions/small_oparea.yaml")
    ap.add_argument("--tro", action=argparse.BooleanOptionalAction, default=True,
                    help="fly the TRO study")
    ap.add_argument("--reference", choices=["oparea_axis", "flow"], default="oparea_axis",
                    help="what find-plume measures its offsets from")
    args = ap.parse_args()
    angles = [0.0, 90.0, 210.0] if args.quick else [float(a) for a in range(0, 360, 30)]
    seeds = list(range(1, 3 if args.quick else args.seeds + 1))
    print(f"machine: {platform.platform()}, {os.cpu_count()} CPUs, Python "
          f"{platform.python_version()}; {args.workers} worker(s); find-plume reference: "
          f"{args.reference}\n")
    studies = []
    if args.tro:
        studies.append(("TRO ocean, missions/tro2006_msn007.yaml", TRO, args.margin))
    if args.small:
        studies.append(("50 x 50 m, missions/small_oparea.yaml", SMALL, 5.0))
    for title, path, margin in studies:
        jobs = [(str(path), a, s, margin, args.reference) for a in angles for s in seeds]
        t0 = time.perf_counter()
        if args.workers > 1:
            with ProcessPoolExecutor(args.workers) as pool:
                rows = list(pool.map(one, jobs))
        else:
            rows = [one(j) for j in jobs]
        print(f"### {title}: {len(jobs)} runs + {len(jobs)} search-only runs, "
              f"{time.perf_counter() - t0:.0f} s wall\n")
        print("\n".join(table(rows, angles)) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
