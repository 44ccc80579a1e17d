"""Simulated seconds per wall-clock second for the two reference setups.

1. TRO ocean (``EnvironmentParams.preset("tro_ocean")``): 1 vehicle, 1800 s simulated, 9 Hz
   fluorometer, vehicle commands held constant. Target: ≥ 1000× real time on one core.
2. AB large meander: 100 vehicles on a 10 × 10 start grid, 300 s simulated, 20 Hz sampling.

Warm-up (plume spin-up) is timed separately. Run::

    python benchmarks/sim_speed.py [--profile]

``--profile`` prints a pyinstrument profile of the TRO run (``pip install pyinstrument``).
"""

from __future__ import annotations

import argparse
import os
import platform
import time

import numpy as np

from cptbt.sim import EnvironmentParams, World


def run(
    name: str, xy: np.ndarray, heading: float, seconds: float
) -> tuple[float, float, float, World]:
    """Warm up, then step ``seconds`` with held commands.

    Returns:
        (warm-up wall s, run wall s, run CPU s, world). CPU time is reported too because wall
        time on a shared machine includes other processes' turns.
    """
    params = EnvironmentParams.preset(name)  # type: ignore[arg-type]
    world = World(params, xy=xy, heading_deg=heading)
    t0 = time.perf_counter()
    world.warm_up()
    t1 = time.perf_counter()
    c1 = time.process_time()
    world.set_commands(np.full(world.n, heading), np.full(world.n, 1.5))
    steps = round(seconds / params.dt_s)
    for _ in range(steps):
        world.step()
    t2 = time.perf_counter()
    return t1 - t0, t2 - t1, time.process_time() - c1, world


def main() -> None:
    """Run both setups and print the speed-ups."""
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--profile", action="store_true", help="profile the TRO run")
    args = ap.parse_args()
    print(
        f"machine: {platform.platform()}, {platform.processor() or platform.machine()}, "
        f"{os.cpu_count()} CPUs, Python {platform.python_version()}, numpy {np.__version__}"
    )

    if args.profile:
        from pyinstrument import Profiler

        profiler = Profiler()
        profiler.start()
        run("tro_ocean", np.array([[100.0, 0.0]]), 180.0, 1800.0)
        profiler.stop()
        print(profiler.output_text(unicode=True, color=False))
        return

    warm, wall, cpu, world = run("tro_ocean", np.array([[100.0, 0.0]]), 180.0, 1800.0)
    print(
        f"TRO ocean, 1 vehicle, 1800 s at dt {world.params.dt_s:.3f} s: {wall:.2f} s wall "
        f"({cpu:.2f} s CPU) → {1800.0 / wall:.0f}× real time by wall, {1800.0 / cpu:.0f}× by "
        f"CPU (target ≥ 1000×); warm-up {world.default_warm_up_s():.0f} s simulated in "
        f"{warm:.2f} s; {world.plume.n} puffs"
    )

    gx, gy = np.meshgrid(np.linspace(5, 95, 10), np.linspace(-45, 45, 10))
    xy = np.column_stack([gx.ravel(), gy.ravel()])
    warm, wall, cpu, world = run("ab_large_meander", xy, 180.0, 300.0)
    print(
        f"AB large meander, 100 vehicles, 300 s at dt {world.params.dt_s:.3f} s: {wall:.2f} s "
        f"wall ({cpu:.2f} s CPU) → {300.0 / wall:.0f}× real time by wall, {300.0 / cpu:.0f}× by "
        f"CPU ({300.0 * 100 / cpu:.0f} vehicle-seconds per CPU second); warm-up {warm:.2f} s; "
        f"{world.plume.n} puffs"
    )


if __name__ == "__main__":
    main()
