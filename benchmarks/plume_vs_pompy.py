"""cptbt's puff plume against pompy 0.1.1 on pompy's README configuration.

Configuration (pompy README): wind region 100 × 100 m (x 0–100, y -50–50) on a 21 × 21 grid,
mean wind 1 m/s; plume region x 0–50, y -12.5–12.5 m, source (5, 0); 10 puffs/s, initial radius
sqrt(0.001) m, r² growth 0.001 m²/s, at most 1000 puffs; dt = 0.01 s; the wind is spun up for
2000 steps, then wind + plume are stepped for 300 s (30 000 steps). Both sides time only the
model updates (no concentration images).

The two models are not numerically identical — both use second-order boundary noise (cptbt's
``large_meander`` preset since the AB rebuild), but pompy's random walk is per-step white
velocity noise where cptbt uses a diffusivity. pompy's centre-relative walk (2 m/s^0.5 × dt per
step) is matched by cptbt's K_c = 2² · dt / 2 = 0.02 m²/s, so the puff counts should agree
closely.

pompy goes in its own environment (it pins old numpy/scipy APIs)::

    python -m venv /tmp/pompy-env
    /tmp/pompy-env/bin/pip install pompy 'numpy<2.4' scipy

then::

    python benchmarks/plume_vs_pompy.py --pompy-python /tmp/pompy-env/bin/python

pompy's part runs in a subprocess with that interpreter; it is skipped, with a message, if the
interpreter or pompy is missing.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import subprocess
import sys
import time

import numpy as np

from cptbt.sim import FlowParams, MeanderingFlow, PlumeParams, PuffPlume

DT = 0.01
WARM_STEPS = 2000

POMPY_SCRIPT = """
import json, sys, time
import numpy as np
from pompy import models
steps = int(sys.argv[1])
rng = np.random.RandomState(20180517)
wind_region = models.Rectangle(x_min=0., x_max=100., y_min=-50., y_max=50.)
wind = models.WindModel(wind_region, n_x=21, n_y=21, u_av=1., v_av=0., k_x=10., k_y=10.,
                        noise_gain=20., noise_damp=0.1, noise_bandwidth=0.2,
                        use_original_noise_updates=True, rng=rng)
sim_region = models.Rectangle(x_min=0., x_max=50., y_min=-12.5, y_max=12.5)
plume = models.PlumeModel(sim_region=sim_region, source_pos=(5., 0., 0.), wind_model=wind,
                          model_z_disp=True, centre_rel_diff_scale=2., puff_init_rad=0.001**0.5,
                          puff_spread_rate=0.001, puff_release_rate=10, init_num_puffs=10,
                          max_num_puffs=1000, rng=rng)
for _ in range(2000):
    wind.update(0.01)
counts = []
t0 = time.perf_counter()
for k in range(steps):
    wind.update(0.01)
    plume.update(0.01)
    if k % 100 == 0:
        counts.append(len(plume.puffs))
wall = time.perf_counter() - t0
print(json.dumps({"wall_s": wall, "counts": counts, "final": len(plume.puffs)}))
"""


def run_cptbt(steps: int) -> dict[str, object]:
    """Time cptbt's flow + plume on the pompy README configuration."""
    rng = np.random.default_rng(20180517)
    params = FlowParams(
        preset="large_meander", grid_n=21, margin_m=0.0, diffusivity_m2ps=5.0, max_substep_s=0.5
    )
    flow = MeanderingFlow(params, (0.0, 100.0, -50.0, 50.0), rng)
    plume_params = PlumeParams(
        preset="ab",
        release_rate_hz=10.0,
        initial_radius_m=math.sqrt(0.001),
        spread_rate_m2ps=0.001,
        centre_rel_diffusivity_m2ps=2.0**2 * DT / 2.0,
        max_puffs=1000,
    )
    plume = PuffPlume(plume_params, (5.0, 0.0), flow, rng, domain=(0.0, 50.0, -12.5, 12.5))
    for _ in range(WARM_STEPS):
        flow.step(DT)
    counts = []
    t0 = time.perf_counter()
    for k in range(steps):
        flow.step(DT)
        plume.step(DT)
        if k % 100 == 0:
            counts.append(plume.n)
    wall = time.perf_counter() - t0
    return {"wall_s": wall, "counts": counts, "final": plume.n}


def run_pompy(python: str, steps: int) -> dict[str, object] | None:
    """Time pompy in a subprocess; None (with a message) if it cannot run."""
    if not os.path.exists(python):
        print(f"pompy skipped: no interpreter at {python} (see the module docstring)")
        return None
    proc = subprocess.run(
        [python, "-c", POMPY_SCRIPT, str(steps)], capture_output=True, text=True, check=False
    )
    if proc.returncode != 0:
        print(f"pompy skipped: it failed to run:\n{proc.stderr.strip()[-800:]}")
        return None
    return json.loads(proc.stdout.strip().splitlines()[-1])


def _summary(name: str, res: dict[str, object], steps: int) -> float:
    counts = np.asarray(res["counts"])
    ms = 1000.0 * float(res["wall_s"]) / steps  # type: ignore[arg-type]
    settled = counts[len(counts) // 3 :]
    print(
        f"{name:6s}: {ms:8.3f} ms/step, {float(res['wall_s']):7.2f} s total; puffs after "
        f"spin-up mean {settled.mean():.0f} (min {settled.min()}, max {settled.max()}), "
        f"final {res['final']}"
    )
    return ms


def main() -> None:
    """Run both models and print ms/step, puff counts and the speed ratio."""
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--pompy-python", default="/tmp/pompy-env/bin/python")
    ap.add_argument("--seconds", type=float, default=300.0, help="simulated time (default 300)")
    args = ap.parse_args()
    steps = round(args.seconds / DT)
    print(
        f"machine: {platform.platform()}, {platform.machine()}, {os.cpu_count()} CPUs; "
        f"cptbt side: Python {platform.python_version()}, numpy {np.__version__}"
    )
    print(f"pompy README configuration, dt {DT} s, {steps} steps ({args.seconds:.0f} s simulated)")
    ms_cptbt = _summary("cptbt", run_cptbt(steps), steps)
    res = run_pompy(args.pompy_python, steps)
    if res is not None:
        ms_pompy = _summary("pompy", res, steps)
        print(f"cptbt is {ms_pompy / ms_cptbt:.0f}× faster than pompy per step (target ≥ 20×)")
    sys.stdout.flush()


if __name__ == "__main__":
    main()
