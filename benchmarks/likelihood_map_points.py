"""Where a declaration rule's declared points fall (issue 13): MSN007 runs with the declared
point, the true source, the navigation's offset from the truth over the last 60 s before the
declaration and the flow estimate then, one JSON line a run (``--detections`` adds every
detection up to the declaration, as (t, x, y, concentration) in the navigation frame, for trying
other estimators of the declared point offline).

The runs are :mod:`likelihood_map`'s (``benchmarks/likelihood_map.py``'s ``mission_with`` and
seeds: replicate ``r`` of root seed ``s`` is the same plume and vehicle noise there), so a row
here pairs with a row there. Usage::

    python benchmarks/likelihood_map_points.py --label lm --seed 77 --runs 300 --out pts.jsonl
    python benchmarks/likelihood_map_points.py --label lm_w18 --seed 77 --runs 300 \
        --set declare_source.upflow_window_m=18 --out pts.jsonl
    python benchmarks/likelihood_map_points.py --label cluster --rule upflow_cluster ...

Session 26's rows and what they showed: ``results/likelihood_map_tuning.md``, "Where the
error is".
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np
import yaml

sys.path.insert(0, str(Path(__file__).resolve().parent))
import likelihood_map as lm

from cptbt.batch.engine import simulate
from cptbt.batch.scenario import launch_pose, to_sim_params
from cptbt.batch.study import group_seeds
from cptbt.batch.summary import summarise
from cptbt.types import Point


def fly(job: tuple[str, dict[str, Any], int, int, bool]) -> dict[str, Any]:
    """One run: (label, settings, replicate, root seed, with detections) → its row."""
    label, settings, r, seed, with_detections = job
    mission = lm.mission_with(lm.MSN007, settings)
    params = to_sim_params(mission, seed)
    env_rng, vehicle_rngs = group_seeds(seed, r, 1)
    (run,), _, wall = simulate(mission, params, [launch_pose(mission)], env_rng=env_rng,
                               vehicle_rngs=vehicle_rngs, trace=True)
    src = Point(*params.source_xy_m)
    s = summarise(run, mission, src, seed, wall, sources=[src],
                  success_radius_m=lm.FALSE_M).to_dict()
    row: dict[str, Any] = {"label": label, "r": r, "seed": seed, "error_m": s["error_m"],
                           "t3": s["t3"], "T_D": s["T_D"], "D3": s["D3"],
                           "src": [src.x, src.y]}
    if run.declared is None or s["t3"] is None:
        return row
    rec, i = run.recorder, run.index
    t = rec.column("t", i)
    true, est = rec.xy(i), rec.xy(i, estimated=True)
    last = (t <= s["t3"]) & (t >= s["t3"] - 60.0)
    off = (est[last] - true[last]).mean(axis=0) if last.any() else [math.nan, math.nan]
    at = min(int(np.searchsorted(t, s["t3"])), len(t) - 1)
    row |= {"decl": [run.declared.x, run.declared.y], "nav_off": [float(v) for v in off],
            "flow": [float(rec.column("flow_vx", i)[at]), float(rec.column("flow_vy", i)[at])]}
    if with_detections:
        c = rec.column("concentration", i)
        hit = (t <= s["t3"]) & (c >= mission.perception.threshold)
        row["det"] = np.round(np.column_stack([t[hit], est[hit], c[hit]]), 2).tolist()
    return row


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--label", required=True)
    ap.add_argument("--rule", default="likelihood_map", help="declare_source variant")
    ap.add_argument("--set", default="", help="KEY=VALUE,... (values read as YAML)")
    ap.add_argument("--seed", type=int, required=True)
    ap.add_argument("--first", type=int, default=0, help="first replicate")
    ap.add_argument("--runs", type=int, required=True)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--detections", action="store_true")
    ap.add_argument("--out", required=True, help="JSON lines, appended to")
    a = ap.parse_args()
    settings: dict[str, Any] = {} if a.rule == "upflow_cluster" else {
        "declare_source.variant": a.rule}
    for item in filter(None, a.set.split(",")):
        key, value = item.split("=", 1)
        settings[key] = yaml.safe_load(value)
    jobs = [(a.label, settings, r, a.seed, a.detections)
            for r in range(a.first, a.first + a.runs)]
    with ProcessPoolExecutor(a.workers) as ex, open(a.out, "a", encoding="utf-8") as f:
        for row in ex.map(fly, jobs, chunksize=4):
            f.write(json.dumps(row) + "\n")
            f.flush()


if __name__ == "__main__":
    main()
