"""One TRO MSN007 run in simulated seconds per CPU second, warm-up included.

Three measures, each with the numpy code and (if numba is installed) the bit-for-bit kernels of
``cptbt.sim.kernels``, and each with the default spin-up and with the opt-in coarse spin-up
(``environment.warm_up_step_s``, default here 10 s: same plume statistics, another realisation):

- ``phased``: ``simulate_phased`` (what ``cptbt run`` flies: Mission A, AMP, give-back, Mission A
  resumed, with the trace), simulated time to post-mission / CPU time, warm-up included;
- ``amp``: the planner-only ``simulate`` of the same mission (no Mission A), to the AMP's end;
- ``cli``: the whole command ``cptbt run MISSION --no-figure`` in a child process (CPU time of
  the child from ``getrusage``: interpreter start, imports, numba's cached kernels, writing the
  trace), simulated time to post-mission / that CPU time.

Target (issue 15): ≥ 1000× real time. CPU time, not wall, because the machine is shared::

    python benchmarks/tro_run_speed.py [--repeats 3] [--warm-up-step 10]
    python benchmarks/tro_run_speed.py --breakdown   # where one whole run's CPU time goes

What ``--breakdown`` shows (benchmarks/results/tro_run_speed.txt): the 1068 simulated seconds
allow 1.07 CPU s for the whole command, and the work that is not the simulation already takes
about that much — interpreter and imports ~0.35 s (numpy, pydantic, py_trees, transitions,
yaml), numba's import and first kernel call ~0.45 s (what buys the spin-up's 4× and the run's
~1.3×), mission validation ~0.08 s, summary (pyproj) and trace ~0.1 s. The simulation itself
(spin-up and run) is the ``phased`` figure: ~1,400× with the kernels. Without numba the spin-up
costs ~0.65 s instead of ~0.16 s, so no kernel tier gets the whole command to 1000× with the
default spin-up.
"""

from __future__ import annotations

import argparse
import os
import platform
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import yaml

from cptbt.batch.engine import simulate
from cptbt.batch.phased import simulate_phased
from cptbt.batch.scenario import launch_pose, to_sim_params
from cptbt.cli.inspect_cmds import load
from cptbt.loader import MissionLoader
from cptbt.sim import kernels

ROOT = Path(__file__).resolve().parents[1]


def _child_cpu() -> float:
    ru = resource.getrusage(resource.RUSAGE_CHILDREN)
    return ru.ru_utime + ru.ru_stime


BREAKDOWN = r"""
import sys, time
T = [("interpreter start", 0.0)]
def mark(name):
    T.append((name, time.process_time()))
import numpy
mark("import numpy")
import cptbt.cli
mark("import cptbt (pydantic, py_trees, transitions, yaml)")
import cptbt.cli.run_cmd as rc
mark("import the simulator (numba if the tier needs it)")
from cptbt.batch.phased import simulate_phased
from cptbt.batch.scenario import to_sim_params
from cptbt.batch.summary import summarise
from cptbt.cli.inspect_cmds import load
from cptbt.sim import world as W
from cptbt.types import Point
mission = load(sys.argv[1], simulate=True)
params = to_sim_params(mission)
mark("load and validate the mission")
init, warm = W.World.__init__, W.World.warm_up
def _init(self, *a, **k):
    init(self, *a, **k)
    mark("world set-up (numba: first kernel call)")
def _warm(self, *a, **k):
    warm(self, *a, **k)
    mark("plume spin-up")
W.World.__init__, W.World.warm_up = _init, _warm
res, world, wall = simulate_phased(mission, params, trace=True)
mark(f"the run: {world.steps} steps of {params.dt_s:.3f} s")
summarise(res.amp, mission, Point(*params.source_xy_m), 0, wall, t0=res.t_amp_start or 0.0)
import tempfile, pathlib
rc.write_trace(res.amp, pathlib.Path(tempfile.mkdtemp()))
mark("summary (pyproj) and trace")
prev = 0.0
for name, t in T[1:]:
    print(f"  {name:55s} {t - prev:6.3f} CPU s")
    prev = t
print(f"  {'total in the process':55s} {T[-1][1]:6.3f} CPU s; {world.t_s:.0f} s simulated")
"""
"""A child process timing the phases of what ``cptbt run`` does, in CPU seconds."""


def breakdown(mission: str, tier: str) -> None:
    """Print where the CPU time of one whole run goes (a child process, kernel tier ``tier``)."""
    print(f"where the time of one run goes, kernels {tier} (process CPU time at each mark):")
    subprocess.run([sys.executable, "-c", BREAKDOWN, mission],
                   env={**os.environ, "CPTBT_KERNELS": tier}, check=True)


def main() -> int:
    """Print the real-time factors of each measure, tier and spin-up."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--mission", default=str(ROOT / "missions/tro2006_msn007.yaml"))
    ap.add_argument("--repeats", type=int, default=3, help="best of this many (CPU time)")
    ap.add_argument("--warm-up-step", type=float, default=10.0)
    ap.add_argument("--breakdown", action="store_true",
                    help="only print where one run's CPU time goes, per kernel tier")
    args = ap.parse_args()
    print(f"machine: {platform.platform()}, {os.cpu_count()} CPUs, load average "
          f"{os.getloadavg()[0]:.1f}, Python {platform.python_version()}")
    if args.breakdown:
        for tier in (["numpy", "exact"] if kernels.HAVE_NUMBA else ["numpy"]):
            breakdown(args.mission, tier)
        return 0
    mission = load(args.mission, simulate=True)
    amp_only = mission.model_copy(update={"mission_a": None})
    raw = yaml.load(Path(args.mission).read_text(encoding="utf-8"), Loader=MissionLoader)
    tiers = ["numpy", "exact"] if kernels.HAVE_NUMBA else ["numpy"]
    with tempfile.TemporaryDirectory() as tmp:
        coarse_file = Path(tmp) / "mission_coarse_warm_up.yaml"
        raw.setdefault("environment", {})["warm_up_step_s"] = args.warm_up_step
        coarse_file.write_text(yaml.safe_dump(raw), encoding="utf-8")
        for tier in tiers:
            kernels.use(tier)  # type: ignore[arg-type]
            for step in (None, args.warm_up_step):
                params = to_sim_params(mission, None)
                params = params.model_validate({**params.model_dump(), "warm_up_step_s": step})
                best: dict[str, float] = {}
                sim_s: dict[str, float] = {}
                for _ in range(args.repeats):
                    c0 = time.process_time()
                    _, world, _ = simulate_phased(mission, params, trace=True)
                    c1 = time.process_time()
                    (run,), _, _ = simulate(amp_only, params, [launch_pose(amp_only)], trace=True)
                    c2 = time.process_time()
                    sim_s["phased"], sim_s["amp"] = world.t_s, run.t_end
                    for key, cpu in (("phased", c1 - c0), ("amp", c2 - c1)):
                        best[key] = min(best.get(key, float("inf")), cpu)
                    mission_file = args.mission if step is None else str(coarse_file)
                    env = {**os.environ, "CPTBT_KERNELS": tier}
                    u0 = _child_cpu()
                    subprocess.run([sys.executable, "-m", "cptbt", "run", mission_file,
                                    "--no-figure", "--quiet", "--out", str(Path(tmp) / "run")],
                                   env=env, check=True)
                    best["cli"] = min(best.get("cli", float("inf")), _child_cpu() - u0)
                sim_s["cli"] = sim_s["phased"]
                spin = "default spin-up" if step is None else f"spin-up step {step:g} s"
                print(f"kernels {tier:5s}, {spin:20s}: " + "; ".join(
                    f"{k} {sim_s[k]:.0f} s in {best[k]:.2f} CPU s = {sim_s[k] / best[k]:.0f}×"
                    for k in ("phased", "amp", "cli")))
    return 0


if __name__ == "__main__":
    sys.exit(main())
