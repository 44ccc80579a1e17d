"""AB Fig. 11 protocol at scale: missions per second, and where the time goes.

Runs ``cptbt batch`` on a Strategy III mission over a 10 x 10 start grid (AB: 100 runs per start
= 10,000 missions, 300 s limit) and reports throughput, the projected wall time of the full
protocol, and a profile of one 100-vehicle group split into flow, plume, sensors, vehicles,
planner ticks (tree + behaviours), perception and the engine loop.

    python benchmarks/batch_fig11.py                      # 4 runs per start (400 missions)
    python benchmarks/batch_fig11.py --runs-per-start 100 # the full protocol
"""

from __future__ import annotations

import argparse
import cProfile
import os
import platform
import pstats
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
CATEGORIES = [  # (label, substring of the file path), first match wins
    ("flow", "/sim/flow.py"),
    ("plume", "/sim/plume.py"),
    ("sensors", "/sim/sensors.py"),
    ("vehicles", "/sim/vehicle.py"),
    ("world", "/sim/world.py"),
    ("perception", "/cptbt/perception.py"),
    ("tree ticks + behaviours", "/behaviours/"),
    ("tree ticks + behaviours", "/cptbt/ticking.py"),
    ("tree ticks + behaviours", "/cptbt/node.py"),
    ("tree ticks + behaviours", "py_trees"),
    ("planner facade", "/cptbt/planner.py"),
    ("engine loop", "/cptbt/batch/engine.py"),
    ("summaries", "/cptbt/batch/summary.py"),
]


def profile_group(mission: str) -> dict[str, float]:
    """Self time by category for one 100-vehicle group."""
    from cptbt.batch.study import Study, configurations, grid_starts
    from cptbt.batch.worker import run_group
    from cptbt.cli.inspect_cmds import load

    m = load(mission)
    task = Study(configurations(m, [], mission), grid_starts(m, 10, 10), 1, 1, 0.0,
                 None).tasks()[0]
    prof = cProfile.Profile()
    prof.enable()
    run_group(task)
    prof.disable()
    stats = pstats.Stats(prof)
    totals: dict[str, float] = {}
    for (path, _, _), (_, _, self_time, _, _) in stats.stats.items():  # type: ignore[attr-defined]
        label = next((lab for lab, key in CATEGORIES if key in path), "numpy/other")
        totals[label] = totals.get(label, 0.0) + self_time
    return totals


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--mission", default=str(ROOT / "missions/ab2001_strategy3.yaml"))
    ap.add_argument("--runs-per-start", type=int, default=4)
    ap.add_argument("--workers", type=int, default=os.cpu_count() or 1)
    ap.add_argument("--no-profile", action="store_true")
    args = ap.parse_args()
    print(f"machine: {platform.platform()}, {os.cpu_count()} CPUs, Python "
          f"{platform.python_version()}")
    out = Path(tempfile.mkdtemp(prefix="cptbt-fig11-"))
    cmd = [str(Path(sys.executable).parent / "cptbt"), "batch", args.mission, "--grid", "10x10",
           "--runs-per-start", str(args.runs_per_start), "--workers", str(args.workers),
           "--out", str(out), "--quiet"]
    t0 = time.perf_counter()
    subprocess.run(cmd, check=True)
    wall = time.perf_counter() - t0
    runs = 100 * args.runs_per_start
    from cptbt.batch.store import load_results

    rows = load_results(out)
    success = sum(bool(r["success"]) for r in rows) / len(rows)
    rate = runs / wall
    mean_sim = sum(r["sim_time_s"] for r in rows) / runs
    print(f"{runs} missions with {args.workers} workers: {wall:.1f} s wall, {rate:.2f} missions/s,"
          f" success {success:.1%}, mean simulated {mean_sim:.0f} s")
    print(f"projected full AB Fig. 11 protocol (10,000 missions): {10_000 / rate / 60:.1f} min "
          f"(target <= 10 min)")
    shutil.rmtree(out, ignore_errors=True)
    if not args.no_profile:
        totals = profile_group(args.mission)
        total = sum(totals.values())
        print("where the time goes in one 100-vehicle group (cProfile self time):")
        for label, seconds in sorted(totals.items(), key=lambda kv: -kv[1]):
            print(f"  {label:26s} {seconds:7.2f} s  {seconds / total:5.1%}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
