"""Peak memory of one world with many vehicles: AB Strategy III, N vehicles × the time limit.

Flies ``simulate`` (the batch engine, no trace) with N vehicles on a grid over AB's area in one
shared plume and reports the process's peak resident set (``ru_maxrss``) before and after, the
recorder's preallocated arrays, and CPU time. Target (issue 15): ≤ 300 MB at 1,000 vehicles ×
300 s::

    python benchmarks/fleet_memory.py [--vehicles 1000] [--seconds 300] [--planner tree]
    CPTBT_KERNELS=numpy python benchmarks/fleet_memory.py

Measured (benchmarks/results/fleet_memory.txt; 2-core VM, load average ~5 from other sessions):
peak RSS 221 MB with the numba kernels (fleet planner; 248 MB with the py_trees planner), 119 MB
(145 MB) with numpy alone — 345 (371) and 242 (269) MB before issue 15's memory work. Where it
goes, fleet planner, numba kernels:

- numba: ~60 MB to import, ~45 MB more when the first kernel is loaded from its on-disk cache
  (numba's CPU target and LLVM): 114 MB before the run, ~165 MB once the world is built. A run
  that compiles the kernels (an empty cache: the first run after install or a change to
  ``sim/kernels.py``) peaks ~20 MB higher (240 MB).
- noise: the fluorometer's bank holds 512 draws × 3 numbers per vehicle (12 MB at 1,000
  vehicles: a bank of normals and uniforms must hold its whole block to keep its stream); the
  ADCP's banks of normals only hold 128 draws (3 MB); error-free navigation (AB) draws nothing.
  It was 48 MB (every bank held 512 draws; navigation 24 MB).
- the recorder: 54 MB allocated (x, y, detected, behaviour codes; a shared time per row; the
  estimates are not stored while equal to the truth), resident only as rows are written, in
  4 kB pages: ~40 MB here (mean end 120 s). It was 129 MB allocated and all of it resident:
  numpy backs arrays ≥ 4 MB with 2 MB transparent huge pages, and a huge page spans the rows of
  ~85 vehicles, so the pages of vehicles that had ended were paid for too.

The recorder's and the noise's changes read back and draw the same numbers bit for bit
(``tests/batch/test_recorder_memory.py``, ``tests/sim/test_sim_noise_bank.py``); throughput is
unchanged within the noise of a shared machine (the results file).
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
          f"(before the run {before:.0f} MB; recorder arrays {rec_mb:.0f} MB allocated); "
          f"{cpu:.0f} CPU s "
          f"= {len(starts) / cpu:.2f} missions/CPU s; mean end {np.nanmean(ended):.0f} s "
          f"(target ≤ 300 MB)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
