"""Closed-loop speed of one TRO mission: simulator + planner, simulated seconds per wall second.

Flies missions/tro2006_msn007.yaml's AMP (no Mission A) for up to 1800 s with one vehicle and
reports the real-time factor of the mission loop, with the plume warm-up (spin-up before t = 0)
timed apart. Target (issue 3): >= 1000x real time on one core.

    python benchmarks/closed_loop_speed.py [--seeds 1 2 3]
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
import time
from pathlib import Path

from cptbt.batch.engine import simulate
from cptbt.batch.scenario import launch_pose, to_sim_params
from cptbt.cli.inspect_cmds import load
from cptbt.sim.world import World

ROOT = Path(__file__).resolve().parents[1]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--mission", default=str(ROOT / "missions/tro2006_msn007.yaml"))
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3])
    ap.add_argument("--seconds", type=float, default=1800.0)
    args = ap.parse_args()
    print(f"machine: {platform.platform()}, {os.cpu_count()} CPUs, Python "
          f"{platform.python_version()}")
    mission = load(args.mission)
    # The AMP alone (no Mission A); a run ends when declared and home, or at --seconds.
    mission = mission.model_copy(update={"time_limit_s": args.seconds, "mission_a": None})
    warm = {"s": 0.0}
    original = World.warm_up

    def timed_warm_up(self: World, seconds: float | None = None) -> None:
        t0 = time.perf_counter()
        original(self, seconds)
        warm["s"] = time.perf_counter() - t0

    World.warm_up = timed_warm_up  # type: ignore[method-assign]
    for seed in args.seeds:
        params = to_sim_params(mission, seed)
        (run,), _, wall = simulate(mission, params, [launch_pose(mission)])
        loop = wall - warm["s"]
        print(f"seed {seed}: {run.t_end:.0f} s simulated, outcome {run.outcome}: mission loop "
              f"{loop:.2f} s wall = {run.t_end / loop:.0f}x real time; warm-up {warm['s']:.2f} s; "
              f"with warm-up {run.t_end / wall:.0f}x")
    return 0


if __name__ == "__main__":
    sys.exit(main())
