"""How often a planning cycle reads k times the detection threshold, by range down the plume.

The likelihood map's two-level model (``strong_factor``, ``strong_prob``, ``strong_decay_m`` in
:mod:`cptbt.behaviours.likelihood_params`) reads a detection at 3 × the threshold as *strong*
evidence of a source near by. This script measures, on the TRO ocean plume alone (MSN007's
source, calibration seeds 7001–7002, no vehicle), how the chance of a reading above k × the
threshold (0.2) falls with the range ``a`` down the back-trajectory of the 100-s flow estimate
(``likelihood_map_meander.back_trajectory``): every ``--every`` s, 20 points near that axis
(offset across it drawn from N(0, 1 m)) per range, each read as a planning cycle reads it (the
largest of 9 samples along 1.5 m of track in a random direction). Negative ranges lie up-flow
of the source along the flow estimate. Used in session 29 to try a 10 × level
(``benchmarks/results/likelihood_map_tuning.md``, "A stronger level").

Usage::

    python benchmarks/likelihood_map_levels.py            # ~10 s
"""

from __future__ import annotations

import argparse
import math
import sys

import numpy as np

sys.path.insert(0, str(__import__("pathlib").Path(__file__).resolve().parent))
from likelihood_map_meander import frames

RANGES = (-3.0, -1.0, 2.0, 5.0, 10.0, 15.0, 20.0, 30.0, 50.0, 80.0, 120.0)
FACTORS = (1, 3, 6, 10, 20, 40)
THRESHOLD = 0.2  # TRO Table I
PER_RANGE = 20
TRACK = np.linspace(-0.75, 0.75, 9)


def measure(seed: int, duration: float, every: float) -> tuple[np.ndarray, np.ndarray]:
    """(readings above each factor, readings) per range, from one plume realisation."""
    rng = np.random.default_rng(seed)
    hits = np.zeros((len(RANGES), len(FACTORS)))
    seen = np.zeros(len(RANGES))
    for _, world, src, (ux, uy, along, disp) in frames(seed, duration, every):
        for j, a in enumerate(RANGES):
            if a < 0:  # up-flow of the source: along the flow estimate
                base = src + a * np.array([ux, uy])
            else:
                base = src + np.array([np.interp(a, along, disp[:, 0]),
                                       np.interp(a, along, disp[:, 1])])
            pts = base + rng.normal(0.0, 1.0, PER_RANGE)[:, None] * np.array([-uy, ux])
            th = rng.uniform(0.0, 2.0 * math.pi, PER_RANGE)
            heading = np.stack([np.cos(th), np.sin(th)], axis=1)
            q = pts[:, None, :] + TRACK[None, :, None] * heading[:, None, :]
            conc = world.plume.concentration(q.reshape(-1, 2)).reshape(PER_RANGE, -1).max(axis=1)
            hits[j] += [np.count_nonzero(conc > THRESHOLD * k) for k in FACTORS]
            seen[j] += PER_RANGE
    return hits, seen


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", default="7001,7002")
    ap.add_argument("--duration", type=float, default=1200.0, help="s after the spin-up")
    ap.add_argument("--every", type=float, default=3.0, help="sampling interval, s")
    args = ap.parse_args()
    hits = np.zeros((len(RANGES), len(FACTORS)))
    seen = np.zeros(len(RANGES))
    for seed in (int(s) for s in args.seeds.split(",")):
        h, n = measure(seed, args.duration, args.every)
        hits += h
        seen += n
    print(f"chance per cycle of a reading above k × {THRESHOLD:g}, seeds {args.seeds} "
          f"({int(seen[0])} readings per range)")
    print("| range a (m) | " + " | ".join(f"> {k} ×" for k in FACTORS) + " |")
    print("|---:|" + "---:|" * len(FACTORS))
    for a, row, n in zip(RANGES, hits, seen, strict=True):
        print(f"| {a:g} | " + " | ".join(f"{v / n:.3f}" for v in row) + " |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
