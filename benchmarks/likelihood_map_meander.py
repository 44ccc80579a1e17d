"""Measure the TRO ocean plume's meander: how far and how persistently its axis strays (issue 13).

The likelihood map's correlated-meander model (``meander_memory_s`` in
:mod:`cptbt.behaviours.source_map`) splits the cross-flow spread of the plume about the
back-trajectory of the planner's 100-s flow estimate into a slowly varying offset of the plume's
axis (the *meander*) and the width of the plume around that axis at one instant. This script
measures that split and the meander's correlation time on the plume alone (TRO ocean preset,
MSN007's source, calibration seeds 7001–7003, the seeds the map's kernel was measured on; no
vehicle): every ``--every`` s of ``--duration`` s after the spin-up, the puffs within a few metres
of a range ``a`` up-flow... down-flow of the source along the back-trajectory are placed by their
cross-flow offset ``c`` from it; their mean is the axis offset ``μ(a, t)`` and their spread about
it the instantaneous half-width. Printed per range: the rms of ``c`` over all puffs, the rms of
``μ``, the rms instantaneous width, the share of the variance that is the meander's, and the lag
at which the autocorrelation of ``μ`` falls to 1/e (the correlation time τ).

The flow estimate stands where the planner's would: the vector mean over the last 100 s of the
true current at a point 40 m down-flow of the source (the vehicle's ADCP reads the current at
the vehicle, which is on the plume; ADCP noise averages out over 100 samples).

Usage::

    python benchmarks/likelihood_map_meander.py            # ~1 min
"""

from __future__ import annotations

import argparse
import math
import sys

import numpy as np

from cptbt.sim.world import EnvironmentParams, World, env_rng_from_seed

RANGES = (10.0, 25.0, 50.0, 100.0, 150.0, 200.0)
WINDOW_S = 100.0


def back_trajectory(cum: np.ndarray, k: int, max_range: float = 260.0):  # type: ignore[no-untyped-def]
    """The map's back-trajectory (``PlumeLikelihood.back_trajectory``) from a cumulative
    history."""
    disp = cum[k] - cum[: k + 1][::-1]
    along_total = np.hypot(disp[:, 0], disp[:, 1])
    stop = int(np.searchsorted(np.maximum.accumulate(along_total), max_range)) + 1
    disp = disp[: min(stop, len(disp))]
    end = disp[-1]
    norm = math.hypot(end[0], end[1])
    ux, uy = end[0] / norm, end[1] / norm
    along = np.maximum.accumulate(disp[:, 0] * ux + disp[:, 1] * uy)
    return ux, uy, along, disp


def frames(seed: int, duration: float, every: float):  # type: ignore[no-untyped-def]
    """The plume alone (TRO ocean preset, spun up), stepped 1 s at a time: every ``every`` s
    after the first flow window, ``(i, world, src, (ux, uy, along, disp))``, the last the
    back-trajectory of the 100-s flow estimate (:func:`back_trajectory`)."""
    params = EnvironmentParams()
    world = World(params, np.array([[0.0, 0.0]]), env_rng=env_rng_from_seed(seed))
    world.warm_up()
    src = np.asarray(params.source_xy_m)
    mean = world.flow.mean_velocity
    probe = (src + 40.0 * mean / np.hypot(*mean))[None, :]
    steps = int(duration + WINDOW_S)
    vel = np.empty((steps, 2))
    cum = np.zeros((steps, 2))
    for i in range(steps):
        world.flow.step(1.0)
        world.plume.step(1.0)
        vel[i] = world.flow.velocity_at(probe)[0]
        est = vel[max(0, i - int(WINDOW_S) + 1): i + 1].mean(axis=0)
        if i:
            cum[i] = cum[i - 1] + est
        if i >= WINDOW_S and not (i - WINDOW_S) % every:
            yield i, world, src, back_trajectory(cum, i)


def measure(seed: int, duration: float, every: float, half: float) -> dict[float, np.ndarray]:
    """Per range, rows (t, μ, within-variance, n) every ``every`` s."""
    out: dict[float, list[tuple[float, float, float, int]]] = {a: [] for a in RANGES}
    for i, world, src, (ux, uy, along, disp) in frames(seed, duration, every):
        xy = world.plume.positions
        a = (xy[:, 0] - src[0]) * ux + (xy[:, 1] - src[1]) * uy
        dx = np.interp(a, along, disp[:, 0])
        dy = np.interp(a, along, disp[:, 1])
        c = (src[0] - (xy[:, 0] - dx)) * -uy + (src[1] - (xy[:, 1] - dy)) * ux
        for r in RANGES:
            sel = c[np.abs(a - r) <= half]
            if len(sel) >= 5:
                out[r].append((float(i), float(sel.mean()), float(sel.var()), len(sel)))
    return {r: np.array(v) for r, v in out.items()}


def corr_time(t: np.ndarray, mu: np.ndarray, every: float) -> float:
    """Lag at which the autocorrelation of ``mu`` (sampled every ``every`` s, gaps allowed)
    falls to 1/e, linearly interpolated; NaN if it never does within the record's third."""
    idx = np.round((t - t[0]) / every).astype(int)
    full = np.full(idx[-1] + 1, np.nan)
    full[idx] = mu - mu.mean()
    var = np.nanmean(full**2)
    prev = 1.0
    for lag in range(1, len(full) // 3):
        prod = full[lag:] * full[:-lag]
        r = float(np.nanmean(prod) / var)
        if r <= math.exp(-1):
            frac = (prev - math.exp(-1)) / (prev - r)
            return (lag - 1 + frac) * every
        prev = r
    return math.nan


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", default="7001,7002,7003")
    ap.add_argument("--duration", type=float, default=1200.0, help="s after the spin-up")
    ap.add_argument("--every", type=float, default=3.0, help="sampling interval, s")
    ap.add_argument("--half", type=float, default=3.0, help="half-width of a range bin, m")
    args = ap.parse_args()
    seeds = [int(s) for s in args.seeds.split(",")]
    runs = [measure(s, args.duration, args.every, args.half) for s in seeds]
    print("| range a (m) | rms c, all puffs (m) | rms axis offset μ (m) | rms width about μ (m) "
          "| meander share of variance | τ per seed (s) |")
    print("|---|---|---|---|---|---|")
    for r in RANGES:
        rows = [run[r] for run in runs if len(run[r])]
        if not rows:
            continue
        mu = np.concatenate([x[:, 1] for x in rows])
        w = np.concatenate([x[:, 2] for x in rows])
        n = np.concatenate([x[:, 3] for x in rows])
        total = float(np.average(mu**2 + w, weights=n))
        m2 = float(np.average(mu**2, weights=n))
        taus = [corr_time(x[:, 0], x[:, 1], args.every) for x in rows]
        print(f"| {r:.0f} | {math.sqrt(total):.1f} | {math.sqrt(m2):.1f} | "
              f"{math.sqrt(total - m2):.1f} | {m2 / total:.2f} | "
              + ", ".join(f"{t:.0f}" for t in taus) + " |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
