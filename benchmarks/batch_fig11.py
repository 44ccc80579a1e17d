"""AB Fig. 11 protocol at scale: missions per CPU-second, per planner, and where the time goes.

Runs ``cptbt batch`` on a Strategy III mission over a 10 x 10 start grid (AB: 100 runs per start
= 10,000 missions, 300 s limit) once per planner (``CPTBT_PLANNER=tree``: one py_trees planner
per vehicle; ``fleet``: the fleet planner, what ``auto`` picks for the AB missions) and reports
wall time, the CPU time of the whole command (workers included), missions per CPU-second, the
projected wall time of the full protocol on two quiet cores (10,000 / (2 x missions per
CPU-second): on a shared machine the wall clock measures the neighbours), and a profile of one
100-vehicle group per planner split into simulator parts, planner parts and the engine loop.

    python benchmarks/batch_fig11.py                      # 4 runs per start (400 missions)
    python benchmarks/batch_fig11.py --runs-per-start 100 # the full protocol
"""

from __future__ import annotations

import argparse
import cProfile
import os
import platform
import pstats
import resource
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
    ("fleet planner (perception, selector)", "/cptbt/fleet.py"),
    ("fleet planner (perception, selector)", "/cptbt/angles.py"),
    ("fleet planner (perception, selector)", "/cptbt/frames.py"),
    ("tree ticks + behaviours", "/behaviours/"),
    ("tree ticks + behaviours", "/cptbt/ticking.py"),
    ("tree ticks + behaviours", "/cptbt/node.py"),
    ("tree ticks + behaviours", "py_trees"),
    ("planner facade", "/cptbt/planner.py"),
    ("engine loop", "/cptbt/batch/engine.py"),
    ("summaries", "/cptbt/batch/summary.py"),
]


def profile_group(mission: str, planner: str) -> dict[str, float]:
    """Self time by category for one 100-vehicle group (after a warm-up group)."""
    from cptbt.batch.starts import grid_starts
    from cptbt.batch.study import Study, configurations
    from cptbt.batch.worker import run_group
    from cptbt.cli.inspect_cmds import load

    m = load(mission)
    os.environ["CPTBT_PLANNER"] = planner
    warm, task = Study(configurations(m, [], mission), grid_starts(m, 10, 10), 2, 1, 0.0,
                       None).tasks()
    run_group(warm)  # imports, numba's kernels
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


def run_batch(args: argparse.Namespace, planner: str) -> dict[str, float]:
    """One ``cptbt batch`` with ``CPTBT_PLANNER=planner``: wall, CPU, success."""
    from cptbt.batch.store import load_results

    out = Path(tempfile.mkdtemp(prefix="cptbt-fig11-"))
    cmd = [str(Path(sys.executable).parent / "cptbt"), "batch", args.mission, "--grid", "10x10",
           "--runs-per-start", str(args.runs_per_start), "--workers", str(args.workers),
           "--out", str(out), "--quiet", "--no-plots"]
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    subprocess.run(cmd, check=True, env={**os.environ, "CPTBT_PLANNER": planner})
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    rows = load_results(out)
    shutil.rmtree(out, ignore_errors=True)
    return {"wall": wall, "cpu": cpu, "n": len(rows),
            "success": sum(bool(r["success"]) for r in rows) / len(rows),
            "sim": sum(r["sim_time_s"] for r in rows) / len(rows)}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--mission", default=str(ROOT / "missions/ab2001_strategy3.yaml"))
    ap.add_argument("--runs-per-start", type=int, default=4)
    ap.add_argument("--workers", type=int, default=os.cpu_count() or 1)
    ap.add_argument("--planners", nargs="+", default=["tree", "fleet"])
    ap.add_argument("--no-profile", action="store_true")
    args = ap.parse_args()
    print(f"machine: {platform.platform()}, {os.cpu_count()} CPUs, Python "
          f"{platform.python_version()}")
    runs = 100 * args.runs_per_start
    rate: dict[str, float] = {}
    for planner in args.planners:
        load0 = os.getloadavg()[0]
        r = run_batch(args, planner)
        rate[planner] = r["n"] / r["cpu"]
        print(f"{planner:5s}: {r['n']} missions with {args.workers} workers: {r['wall']:.1f} s "
              f"wall, {r['cpu']:.1f} s CPU = {rate[planner]:.2f} missions per CPU-second; "
              f"success {r['success']:.1%}, mean simulated {r['sim']:.0f} s; load average "
              f"{load0:.1f} -> {os.getloadavg()[0]:.1f}")
        print(f"       projected full protocol (10,000 missions) on 2 quiet cores: "
              f"{10_000 / (2 * rate[planner]) / 60:.1f} min (target <= 2.5 min); at this run's "
              f"wall rate {10_000 / (runs / r['wall']) / 60:.1f} min")
    if "tree" in rate and "fleet" in rate:
        print(f"fleet / tree CPU throughput: {rate['fleet'] / rate['tree']:.2f}x")
    if not args.no_profile:
        for planner in args.planners:
            totals = profile_group(args.mission, planner)
            total = sum(totals.values())
            print(f"where the time goes in one 100-vehicle group, {planner} planner "
                  f"(cProfile self time, {total:.2f} s):")
            for label, seconds in sorted(totals.items(), key=lambda kv: -kv[1]):
                print(f"  {label:38s} {seconds:7.2f} s  {seconds / total:5.1%}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
