"""cptbt's puff plume against pompy 0.1.1 on pompy's README configuration, like for like.

Configuration (pompy README): wind region 100 × 100 m (x 0–100, y -50–50) on a 21 × 21 grid,
mean wind 1 m/s; plume region x 0–50, y -12.5–12.5 m, source (5, 0); 10 puffs/s, initial radius
sqrt(0.001) m, r² growth 0.001 m²/s; dt = 0.01 s. pompy's stronger wind noise carries puffs
out of the ±12.5 m plume region sooner, so at pompy's cap of 1000 it settles near 310 puffs and
cptbt near 490; both sides are therefore capped at the same ``--max-puffs`` (default 300), which
both reach, so each step moves the same number of puffs. Each side spins its wind
up for 2000 steps and its plume up for ``--spin-up`` seconds (untimed; the plume is then
near its steady puff count), then wind + plume are stepped for ``--seconds`` (timed, CPU time
of that process, ``time.process_time``). Neither side computes concentration images.

Two cptbt configurations are timed, both in the same run as pompy, with the numpy code and
(if numba is installed, ``pip install ".[fast]"``) with the kernels of ``cptbt.sim.kernels``,
which give the same numbers:

- **like for like**: the flow PDE is sub-stepped every 0.01 s, as pompy's wind is
  (``max_substep_s = dt``), same grid, same puff count;
- **as configured**: cptbt's own flow step (the CFL-limited sub-step of the preset, ≈ 0.495 s
  here), so the flow costs ~50× less per plume step.

pompy's ``velocity_at_pos`` calls ``float()`` on a 1 × 1 array, which emits a NumPy
DeprecationWarning on every puff and step; the warning machinery costs time, so the benchmark
replaces that method by one returning the same numbers with ``.item()`` (no warning).

The two models are not numerically identical — both use second-order boundary noise (cptbt's
``large_meander`` preset since the AB rebuild), but pompy's wind is read through a bicubic
spline and its random walk is per-step white velocity noise, where cptbt uses bilinear
interpolation and a diffusivity. pompy's centre-relative walk (2 m/s^0.5 × dt per step) is
matched by cptbt's K_c = 2² · dt / 2 = 0.02 m²/s, so the puff counts agree closely (both are
printed).

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

from cptbt.sim import FlowParams, MeanderingFlow, PlumeParams, PuffPlume, kernels

DT = 0.01
WARM_STEPS = 2000

POMPY_SCRIPT = """
import json, sys, time
import numpy as np
from pompy import models

def velocity_at_pos(self, x, y):
    # pompy's own method with .item() for float(): same numbers, no DeprecationWarning per call.
    if not self._interp_set:
        self._set_interpolators()
    return np.array([self._interp_u(x, y).item(), self._interp_v(x, y).item()])

models.WindModel.velocity_at_pos = velocity_at_pos
spin_steps, steps = int(sys.argv[1]), int(sys.argv[2])
rng = np.random.RandomState(20180517)
wind_region = models.Rectangle(x_min=0., x_max=100., y_min=-50., y_max=50.)
wind = models.WindModel(wind_region, n_x=21, n_y=21, u_av=1., v_av=0., k_x=10., k_y=10.,
                        noise_gain=20., noise_damp=0.1, noise_bandwidth=0.2,
                        use_original_noise_updates=True, rng=rng)
sim_region = models.Rectangle(x_min=0., x_max=50., y_min=-12.5, y_max=12.5)
plume = models.PlumeModel(sim_region=sim_region, source_pos=(5., 0., 0.), wind_model=wind,
                          model_z_disp=True, centre_rel_diff_scale=2., puff_init_rad=0.001**0.5,
                          puff_spread_rate=0.001, puff_release_rate=10, init_num_puffs=10,
                          max_num_puffs=int(sys.argv[3]), rng=rng)
for _ in range(2000):
    wind.update(0.01)
for _ in range(spin_steps):
    wind.update(0.01)
    plume.update(0.01)
counts = []
c0 = time.process_time()
for k in range(steps):
    wind.update(0.01)
    plume.update(0.01)
    if k % 100 == 0:
        counts.append(len(plume.puffs))
cpu = time.process_time() - c0
print(json.dumps({"cpu_s": cpu, "counts": counts, "final": len(plume.puffs)}))
"""


def run_cptbt(
    spin_steps: int, steps: int, max_puffs: int, like_for_like: bool
) -> dict[str, object]:
    """Time cptbt's flow + plume (CPU s) on the pompy README configuration."""
    rng = np.random.default_rng(20180517)
    params = FlowParams(
        preset="large_meander",
        grid_n=21,
        margin_m=0.0,
        diffusivity_m2ps=5.0,
        max_substep_s=DT if like_for_like else 0.5,
    )
    flow = MeanderingFlow(params, (0.0, 100.0, -50.0, 50.0), rng)
    plume_params = PlumeParams(
        preset="ab",
        release_rate_hz=10.0,
        initial_radius_m=math.sqrt(0.001),
        spread_rate_m2ps=0.001,
        centre_rel_diffusivity_m2ps=2.0**2 * DT / 2.0,
        max_puffs=max_puffs,
    )
    plume = PuffPlume(plume_params, (5.0, 0.0), flow, rng, domain=(0.0, 50.0, -12.5, 12.5))
    for _ in range(WARM_STEPS):
        flow.step(DT)
    for _ in range(spin_steps):
        flow.step(DT)
        plume.step(DT)
    counts = []
    c0 = time.process_time()
    for k in range(steps):
        flow.step(DT)
        plume.step(DT)
        if k % 100 == 0:
            counts.append(plume.n)
    cpu = time.process_time() - c0
    return {"cpu_s": cpu, "counts": counts, "final": plume.n, "substep_s": flow.substep_s}


def run_pompy(python: str, spin_steps: int, steps: int, max_puffs: int) -> dict[str, object] | None:
    """Time pompy in a subprocess; None (with a message) if it cannot run."""
    if not os.path.exists(python):
        print(f"pompy skipped: no interpreter at {python} (see the module docstring)")
        return None
    proc = subprocess.run(
        [python, "-W", "error::DeprecationWarning", "-c", POMPY_SCRIPT, str(spin_steps),
         str(steps), str(max_puffs)],
        capture_output=True,
        text=True,
        check=False,
    )
    if proc.returncode != 0:
        print(f"pompy skipped: it failed to run:\n{proc.stderr.strip()[-800:]}")
        return None
    return json.loads(proc.stdout.strip().splitlines()[-1])


def _summary(name: str, res: dict[str, object], steps: int) -> float:
    counts = np.asarray(res["counts"])
    ms = 1000.0 * float(res["cpu_s"]) / steps  # type: ignore[arg-type]
    print(
        f"{name:28s}: {ms:8.3f} ms CPU/step, {float(res['cpu_s']):7.2f} s CPU; puffs mean "
        f"{counts.mean():.0f} (min {counts.min()}, max {counts.max()}), final {res['final']}"
    )
    return ms


def main() -> None:
    """Run both models and print CPU ms/step, puff counts and both speed ratios."""
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--pompy-python", default="/tmp/pompy-env/bin/python")
    ap.add_argument("--spin-up", type=float, default=60.0, help="untimed plume spin-up, s")
    ap.add_argument("--seconds", type=float, default=20.0, help="timed simulated time, s")
    ap.add_argument("--max-puffs", type=int, default=300, help="puff cap of both sides")
    args = ap.parse_args()
    spin = round(args.spin_up / DT)
    steps = round(args.seconds / DT)
    print(
        f"machine: {platform.platform()}, {platform.machine()}, {os.cpu_count()} CPUs, "
        f"load average {os.getloadavg()[0]:.1f}; cptbt side: Python "
        f"{platform.python_version()}, numpy {np.__version__}"
    )
    print(
        f"pompy README configuration, dt {DT} s; spin-up {args.spin_up:.0f} s untimed, then "
        f"{steps} steps ({args.seconds:.0f} s simulated) timed in CPU seconds"
    )
    tiers = ["numpy", "exact"] if kernels.HAVE_NUMBA else ["numpy"]
    results = {}
    for tier in tiers:
        kernels.use(tier)  # type: ignore[arg-type]
        results[tier] = (run_cptbt(spin, steps, args.max_puffs, like_for_like=True),
                         run_cptbt(spin, steps, args.max_puffs, like_for_like=False))
    res = run_pompy(args.pompy_python, spin, steps, args.max_puffs)
    ms_pompy = _summary("pompy flow step 0.010 s", res, steps) if res is not None else None
    for tier, (like, conf) in results.items():
        ms_like = _summary(f"cptbt {tier:5s} flow {like['substep_s']:.3f} s", like, steps)
        ms_conf = _summary(f"cptbt {tier:5s} flow {conf['substep_s']:.3f} s", conf, steps)
        if ms_pompy is not None:
            print(
                f"  kernels {tier}: like for like (equal flow step, equal puffs) cptbt is "
                f"{ms_pompy / ms_like:.1f}× faster than pompy (target ≥ 20×); as configured "
                f"{ms_pompy / ms_conf:.1f}×"
            )
    sys.stdout.flush()


if __name__ == "__main__":
    main()
