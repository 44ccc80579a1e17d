"""Where T_D goes: the time each behaviour drove between t2 and t3 on MSN007 (issue 13).

T_D = t3 - t2 (SPEC §11) is the time from the first pass within 13 m of the declared point to
the declaration. This script flies ``--runs`` replicates of ``missions/tro2006_msn007.yaml``
with the likelihood-map declaration (and any ``--set`` settings), the AMP alone as
``benchmarks/likelihood_map.py`` flies it (same seeds, so the rows pair with that study's), and
sums, over the runs that declared, the cycles each behaviour leaf drove in [t2, t3). Printed:
the mean T_D, the mean of the runs' T_D shares, and each leaf's seconds per run and share of
T_D. Measured in session 29: ``benchmarks/results/likelihood_map_tuning.md``, "A stronger
level" (session 20's "Where T_D goes" there was measured by hand the same way).

Usage::

    python benchmarks/likelihood_map_td_parts.py --runs 40 --seed 77      # ~2 min, 1 core
    python benchmarks/likelihood_map_td_parts.py --set declare_source.strong_factor=10
"""

from __future__ import annotations

import argparse
import collections
import sys
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from cptbt.batch.comparison import td_share
from cptbt.batch.engine import simulate
from cptbt.batch.scenario import launch_pose, to_sim_params
from cptbt.batch.study import group_seeds
from cptbt.batch.summary import summarise
from cptbt.types import Point

sys.path.insert(0, str(Path(__file__).resolve().parent))
from likelihood_map import FALSE_M, MSN007, mission_with


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=40)
    ap.add_argument("--seed", type=int, default=77)
    ap.add_argument("--set", default="", metavar="KEY=VALUE,...",
                    help="settings on top of declare_source.variant=likelihood_map")
    args = ap.parse_args()
    settings: dict[str, Any] = {"declare_source.variant": "likelihood_map"}
    for item in filter(None, args.set.split(",")):
        key, _, value = item.partition("=")
        settings[key.strip()] = yaml.safe_load(value)
    mission = mission_with(MSN007, settings)
    cycle = 1.0 / mission.cycle_hz
    spent: collections.Counter[str] = collections.Counter()
    td: list[float] = []
    t3: list[float] = []
    shares: list[float] = []
    for r in range(args.runs):
        params = to_sim_params(mission, args.seed)
        env_rng, vehicle_rngs = group_seeds(args.seed, r, 1)
        (run,), _, wall = simulate(mission, params, [launch_pose(mission)], env_rng=env_rng,
                                   vehicle_rngs=vehicle_rngs, trace=True)
        source = Point(*params.source_xy_m)
        s = summarise(run, mission, source, args.seed, wall, sources=[source],
                      success_radius_m=FALSE_M).to_dict()
        if s["t3"] is None or s["T_D"] is None:
            continue
        trace = run.trace
        assert trace is not None
        t, active = np.asarray(trace["t"]), np.asarray(trace["active"])
        inside = (t >= s["t3"] - s["T_D"]) & (t < s["t3"])
        spent.update(str(a) for a in active[inside])
        td.append(s["T_D"])
        t3.append(s["t3"])
        shares.append(td_share(s))  # T_D / (t3 - t0), as the study's tables
    n = len(td)
    print(f"{n} of {args.runs} runs declared (root seed {args.seed}, {settings}): mean T_D "
          f"{np.mean(td):.1f} s, mean time to declaration {np.mean(t3):.1f} s, mean T_D share "
          f"{100 * np.mean(shares):.1f}%")
    total = sum(spent.values())
    print("| behaviour in [t2, t3) | s per run | share of T_D |")
    print("|---|---:|---:|")
    for name, cycles in spent.most_common():
        print(f"| {name} | {cycles * cycle / n:.1f} | {100 * cycles / total:.1f}% |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
