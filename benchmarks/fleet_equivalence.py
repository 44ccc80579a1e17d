"""The fleet planner against the per-vehicle planner on the AB Fig. 11 protocol: same missions?

Flies AB Fig. 11 groups (10 x 10 start grid, one shared plume per replicate, 300 s, the seeds
``cptbt batch`` uses) once with one py_trees planner per vehicle and once with the fleet
planner, and compares every mission: outcome, end time, distance at the end, declared point,
first detection, lost contacts and the whole true path (a hash). Also reports the CPU time of
each path (missions per CPU-second, simulator included).

    python benchmarks/fleet_equivalence.py                         # S3 x 10 replicates + S1, S2
    python benchmarks/fleet_equivalence.py --replicates 2 --strategies 3

Exit status 1 if any mission differs.
"""

from __future__ import annotations

import argparse
import hashlib
import os
import platform
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]


def _fly(args: tuple[str, int, int]) -> tuple[str, int, list[Any], list[Any], float, float]:
    """One group both ways: (mission, replicate, tree rows, fleet rows, cpu tree, cpu fleet)."""
    import numpy as np

    from cptbt.batch.starts import grid_starts
    from cptbt.batch.study import Study, configurations
    from cptbt.batch.worker import fly_group
    from cptbt.cli.inspect_cmds import load

    path, replicate, seed = args
    m = load(path)
    task = Study(configurations(m, [], path), grid_starts(m, 10, 10), replicate + 1, seed, 0.0,
                 None).tasks()[replicate]
    out: dict[str, list[Any]] = {}
    cpu: dict[str, float] = {}
    for planner in ("tree", "fleet"):
        os.environ["CPTBT_PLANNER"] = planner
        c0 = time.process_time()
        _, runs, _, _ = fly_group(task)
        cpu[planner] = time.process_time() - c0
        out[planner] = [
            (str(r.outcome), r.t_end, r.distance_at_end_m, r.declared, r.t1,
             tuple(r.lost_contacts),
             hashlib.sha1(np.ascontiguousarray(r.path_true).tobytes()).hexdigest())
            for r in runs
        ]
    return Path(path).stem, replicate, out["tree"], out["fleet"], cpu["tree"], cpu["fleet"]


def compare(strategies: list[int], replicates: int, seed: int, workers: int,
            quiet: bool = False) -> dict[str, Any]:
    """Fly and compare; returns the counts and CPU times."""
    jobs = []
    for k in strategies:
        path = str(ROOT / "missions" / f"ab2001_strategy{k}.yaml")
        reps = replicates if k == 3 else max(1, replicates // 5)
        jobs += [(path, r, seed) for r in range(reps)]
    # A warm-up in each worker would hide numba's compile; the first group pays it on both
    # paths alike (the tree path flies first), so it is left in.
    total = same = 0
    cpu_tree = cpu_fleet = 0.0
    diffs: list[str] = []
    found = 0
    with ProcessPoolExecutor(max_workers=workers) as pool:
        for name, rep, tree, fleet, ct, cf in pool.map(_fly, jobs):
            cpu_tree += ct
            cpu_fleet += cf
            for k, (a, b) in enumerate(zip(tree, fleet, strict=True)):
                total += 1
                found += a[0] == "found"
                if a == b:
                    same += 1
                else:
                    diffs.append(f"{name} replicate {rep} start {k}: {a[:5]} vs {b[:5]}")
            if not quiet:
                print(f"  {name} replicate {rep}: {len(tree)} missions, tree {ct:.1f} s CPU, "
                      f"fleet {cf:.1f} s CPU", flush=True)
    return {"missions": total, "identical": same, "diffs": diffs, "cpu_tree": cpu_tree,
            "cpu_fleet": cpu_fleet, "found": found}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--strategies", type=int, nargs="+", default=[3, 1, 2])
    ap.add_argument("--replicates", type=int, default=10,
                    help="plume realisations for Strategy III (I and II get a fifth as many)")
    ap.add_argument("--seed", type=int, default=2001)
    ap.add_argument("--workers", type=int, default=os.cpu_count() or 1)
    args = ap.parse_args()
    from cptbt.sim import kernels

    print(f"machine: {platform.platform()}, {os.cpu_count()} CPUs, Python "
          f"{platform.python_version()}, load average {os.getloadavg()[0]:.1f} at start; "
          f"kernels {kernels.tier()}")
    t0 = time.perf_counter()
    res = compare(args.strategies, args.replicates, args.seed, args.workers)
    wall = time.perf_counter() - t0
    n = res["missions"]
    print(f"{n} missions ({res['found']} found): {res['identical']} identical "
          f"(outcome, end time, end distance, declared point, first detection, lost contacts, "
          f"path hash); wall {wall:.0f} s, load average {os.getloadavg()[0]:.1f} at the end")
    print(f"CPU: per-vehicle planner {res['cpu_tree']:.1f} s ({n / res['cpu_tree']:.1f} "
          f"missions per CPU-second), fleet planner {res['cpu_fleet']:.1f} s "
          f"({n / res['cpu_fleet']:.1f}); ratio {res['cpu_tree'] / res['cpu_fleet']:.2f}x")
    for line in res["diffs"][:20]:
        print("  DIFFERS:", line)
    return 0 if res["identical"] == n else 1


if __name__ == "__main__":
    sys.exit(main())
