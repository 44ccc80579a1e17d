"""Per-cycle cost of space-aware infotaxis per vehicle at a 50 × 50 belief grid (issue 14).

One SAI find-plume node on AB's 100 × 100 m area with ``cell_m: 2`` (50 × 50 = 2 500 cells),
fed a scripted 10 Hz percept stream (flow along +x; a detection every seventh cycle, which
concentrates the belief, or none, which leaves it spread over most of the grid — the scores skip
cells with no posterior mass, so a broad belief is the dearer case) through the real perception;
timed per cycle after a 600-cycle warm-up of the flow history:

- ``belief update``: the node's ``watch`` (the Poisson map folds in one percept);
- ``decision``: one choice of move (the 8 candidates scored at once);
- ``cycle, replanning every cycle``: both, the worst case (the missions replan every 2–6 s, so
  most cycles pay the update only).

Usage::

    python benchmarks/infotaxis_cost.py [--cycles 2000] [--candidates 8]

Writes ``--out`` (default ``runs/infotaxis_cost.md``; the committed table is
``benchmarks/results/infotaxis_cost.md``), the machine and its load included.
"""

from __future__ import annotations

import argparse
import os
import platform
import time
from pathlib import Path

import numpy as np

from cptbt.behaviours.infotaxis import InfotaxisParams, SpaceAwareInfotaxisFindPlume
from cptbt.testing import (
    ScriptedPerception,
    TreeHarness,
    fresh_namespace,
    make_context,
    square_area,
)

ROOT = Path(__file__).resolve().parents[1]


def measure(cycles: int, candidates: int, hit_every: int) -> dict[str, np.ndarray]:
    area = square_area(100.0)
    params = InfotaxisParams(cell_m=2.0, candidates=candidates)
    node = SpaceAwareInfotaxisFindPlume(params, namespace=fresh_namespace())
    harness = TreeHarness(node, make_context(area))
    assert node.map is not None and node.map.posterior().size == 2500
    script = ScriptedPerception(area, flow=(1.0, 0.0), lambda_s=1.0)
    rng = np.random.default_rng(14)
    update, decide, total = [], [], []
    x, y = 80.0, 0.0
    for i in range(600 + cycles):
        t = 0.1 * i
        p = script.step(t, x, y, 180.0, conc=1.0 if hit_every and i % hit_every == 0 else 0.0)
        harness.context.percept = p
        t0 = time.perf_counter()
        node.watch(p)
        t1 = time.perf_counter()
        node.choose(x, y)
        t2 = time.perf_counter()
        if i >= 600:
            update.append(t1 - t0)
            decide.append(t2 - t1)
            total.append(t2 - t0)
        x = float(np.clip(x + rng.normal(-0.05, 0.1), 5, 95))
        y = float(np.clip(y + rng.normal(0.0, 0.1), -45, 45))
    return {"belief update": np.array(update) * 1e3, "decision": np.array(decide) * 1e3,
            "cycle, replanning every cycle": np.array(total) * 1e3}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cycles", type=int, default=2000)
    ap.add_argument("--candidates", type=int, default=8)
    ap.add_argument("--out", type=Path, default=ROOT / "runs/infotaxis_cost.md",
                    help="default: under runs/ (benchmarks/results/infotaxis_cost.md is the "
                    "committed one: name it to replace it)")
    args = ap.parse_args()
    load = os.getloadavg()
    res: dict[str, np.ndarray] = {}
    for label, every in (("hits", 7), ("no hits", 0)):
        for part, v in measure(args.cycles, args.candidates, every).items():
            res[f"{part} ({label})"] = v
    lines = ["# Space-aware infotaxis: cost per cycle per vehicle, 50 × 50 belief", "",
             f"`python benchmarks/infotaxis_cost.py --cycles {args.cycles} --candidates "
             f"{args.candidates} --out {os.path.relpath(args.out, ROOT)}`; {args.cycles} "
             "cycles at 10 Hz after 600 cycles of history.",
             "",
             f"Machine: {platform.machine()}, {os.cpu_count()} cores "
             f"({platform.processor() or 'processor not reported'}), Python "
             f"{platform.python_version()}, numpy {np.__version__}; load average "
             f"{load[0]:.2f} (shared with other sessions).", "",
             "| part | mean (ms) | median (ms) | 99th pct (ms) |", "|---|---:|---:|---:|"]
    for name, v in res.items():
        lines.append(f"| {name} | {v.mean():.3f} | {np.median(v):.3f} | "
                     f"{np.percentile(v, 99):.3f} |")
    for label in ("hits", "no hits"):
        upd, dec = res[f"belief update ({label})"], res[f"decision ({label})"]
        lines.append(f"| cycle as the AB mission runs it, replanning every 2 s at 10 Hz "
                     f"({label}; update + decision / 20) | {upd.mean() + dec.mean() / 20:.3f} | "
                     f"{np.median(upd) + np.median(dec) / 20:.3f} | — |")
    worst = max(float(np.median(v)) for k, v in res.items() if k.startswith("cycle,"))
    lines += ["", f"Target ≤ 2 ms per cycle: {'met' if worst <= 2.0 else 'NOT met'} "
              f"(median {worst:.2f} ms replanning every cycle, the dearer scenario). The "
              "median is the figure to read on a loaded machine: the mean and the 99th "
              "percentile carry the other sessions' time slices."]
    text = "\n".join(lines) + "\n"
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(text, encoding="utf-8")
    print(text)


if __name__ == "__main__":
    main()
