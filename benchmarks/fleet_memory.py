"""Peak memory of one world with many vehicles: AB Strategy III, N vehicles × the time limit.

Flies ``simulate`` (the batch engine, no trace) with N vehicles on a grid over AB's area in one
shared plume and reports the process's peak resident set (``ru_maxrss``) before and after, the
recorder's preallocated arrays, and CPU time. Target (issue 15): ≤ 300 MB at 1,000 vehicles ×
300 s::

    python benchmarks/fleet_memory.py [--vehicles 1000] [--seconds 300] [--planner tree]
    CPTBT_KERNELS=numpy python benchmarks/fleet_memory.py

Measured (benchmarks/results/fleet_memory.txt): the numba kernels cost ~100 MB of resident
memory whatever N (numba and LLVM loaded into the process: 114 MB before the run against 55 MB
without them); the simulator's per-vehicle noise bank ~47 MB at 1,000 vehicles (512 draws
buffered per vehicle); the recorder's rows are paid for as they are written.
"""

from __future__ import annotations

import argparse
import os
import platform
import resource
import sys
import time
from pathlib import Path

import numpy as np

from cptbt.batch.engine import simulate
from cptbt.batch.scenario import to_sim_params
from cptbt.cli.inspect_cmds import load
from cptbt.sim import kernels

ROOT = Path(__file__).resolve().parents[1]


def _rss_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def main() -> int:
    """Fly N vehicles once and print peak memory and CPU time."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--mission", default=str(ROOT / "missions/ab2001_strategy3.yaml"))
    ap.add_argument("--vehicles", type=int, default=1000)
    ap.add_argument("--seconds", type=float, default=300.0)
    ap.add_argument("--planner", choices=["auto", "fleet", "tree"], default="auto")
    args = ap.parse_args()
    mission = load(args.mission, simulate=True)
    mission = mission.model_copy(update={"time_limit_s": args.seconds})
    params = to_sim_params(mission, None)
    side = int(np.ceil(np.sqrt(args.vehicles)))
    gx, gy = np.meshgrid(np.linspace(2.5, 97.5, side), np.linspace(-47.5, 47.5, side))
    starts = [(float(x), float(y), 0.0) for x, y in zip(gx.ravel(), gy.ravel(), strict=True)]
    starts = starts[: args.vehicles]
    before = _rss_mb()
    c0 = time.process_time()
    runs, _, _ = simulate(mission, params, starts, planner=args.planner)
    cpu = time.process_time() - c0
    rec_mb = runs[0].recorder.allocated_bytes() / 2**20
    ended = np.array([r.t_end for r in runs])
    print(f"machine: {platform.platform()}, {os.cpu_count()} CPUs, load average "
          f"{os.getloadavg()[0]:.1f}; kernels {kernels.tier()}; planner {args.planner}")
    print(f"{len(starts)} vehicles, limit {args.seconds:.0f} s: peak RSS {_rss_mb():.0f} MB "
          f"(before the run {before:.0f} MB; recorder arrays {rec_mb:.0f} MB allocated); {cpu:.0f} CPU s "
          f"= {len(starts) / cpu:.2f} missions/CPU s; mean end {np.nanmean(ended):.0f} s "
          f"(target ≤ 300 MB)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
