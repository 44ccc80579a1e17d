"""``cptbt batch`` and ``cptbt plot``: Monte Carlo studies and their figures."""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
from pathlib import Path
from typing import Any

from cptbt import __version__
from cptbt.batch.errors import BatchError, CodeChanged
from cptbt.batch.integrity import code_identity
from cptbt.batch.scenario import environment_of
from cptbt.batch.store import ResultStore, StudyMismatch, load_results
from cptbt.batch.study import Study, Sweep, configurations, grid_starts
from cptbt.cli import argtypes
from cptbt.cli.argtypes import UsageError
from cptbt.cli.inspect_cmds import load


def _sweep(text: str) -> Sweep:
    try:
        return Sweep.parse(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def add_parsers(sub: Any) -> None:
    """Register ``batch`` and ``plot``."""
    p = sub.add_parser("batch", help="run a Monte Carlo study", description=cmd_batch.__doc__)
    p.add_argument("mission", metavar="MISSION")
    where = p.add_mutually_exclusive_group()
    where.add_argument("--grid", type=argtypes.grid, metavar="NXxNY",
                       help="starts at the cell centres of a grid over the OpArea, e.g. 10x10 "
                       "(AB Fig. 11)")
    where.add_argument("--starts-x", type=argtypes.start_range, metavar="X0:X1:STEP",
                       help="starts along y = --y, e.g. 0:100:5 (AB Fig. 10)")
    where.add_argument("--starts", type=argtypes.starts, metavar="X,Y;X,Y",
                       help="explicit starts (planning frame)")
    p.add_argument("--y", type=argtypes.finite_float, default=0.0,
                   help="y of --starts-x (default 0)")
    p.add_argument("--runs-per-start", type=argtypes.positive_int, default=1, metavar="R",
                   help="plume realisations per start (default 1)")
    p.add_argument("--sweep", type=_sweep, action="append", default=[], metavar="PATH=V1,V2",
                   help="compare settings, e.g. maintain_plume.variant+reacquire_plume.variant="
                   "strategy_1,strategy_3 (repeatable: the product is run)")
    p.add_argument("--seed", type=argtypes.non_negative_int, default=None,
                   help="root seed (default: the mission's)")
    p.add_argument("--time-limit", type=argtypes.positive_float, default=None, metavar="S",
                   help="override the mission's time limit, s")
    p.add_argument("--out", required=True, metavar="DIR", help="results folder")
    p.add_argument("--workers", type=argtypes.positive_int, default=os.cpu_count() or 1,
                   help="local worker processes (default: all cores)")
    p.add_argument("--scheduler", metavar="ADDRESS",
                   help="run on a Dask distributed cluster instead (needs cptbt[cluster])")
    p.add_argument("--scheduler-timeout", type=argtypes.positive_float, default=10.0,
                   metavar="S", help="give up connecting to --scheduler after S s (default 10)")
    p.add_argument("--restart", action="store_true",
                   help="discard the folder's finished runs (e.g. made by other code), start over")
    p.add_argument("--no-plots", action="store_true", help="skip the figures")
    p.add_argument("--quiet", action="store_true", help="no progress bar or summary")
    p.set_defaults(func=cmd_batch)

    p = sub.add_parser("plot", help="figures and tables of a study", description=cmd_plot.__doc__)
    p.add_argument("results", metavar="RESULTS", help="a results folder or table")
    p.add_argument("--out", metavar="DIR", help="where to write (default: beside the results)")
    p.set_defaults(func=cmd_plot)


def _git_version() -> str:
    try:
        rev = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True,
                             text=True, cwd=Path(__file__).parent, timeout=5)
        return f"{__version__}+{rev.stdout.strip()}" if rev.returncode == 0 else __version__
    except (OSError, subprocess.SubprocessError):
        return __version__


def _starts(args: argparse.Namespace, mission: Any) -> list[tuple[float, float]]:
    if args.grid:
        return grid_starts(mission, *args.grid)
    if args.starts_x:
        return [(x, args.y) for x in args.starts_x]
    if args.starts:
        return list(args.starts)
    start = mission.start or mission.home
    p = mission.to_xy(start)
    return [(p.x, p.y)]


def cmd_batch(args: argparse.Namespace) -> int:
    """Fly a mission from many starts and plume realisations; resumable, reproducible."""
    mission = load(args.mission, simulate=True)
    sweeps: list[Sweep] = args.sweep
    try:
        configs = configurations(mission, sweeps, args.mission)
    except ValueError as exc:
        raise UsageError(f"batch: {exc}") from None
    starts = _starts(args, mission)
    env = environment_of(mission)
    seed = env.seed if args.seed is None else args.seed
    study = Study(configs, starts, args.runs_per_start, seed, env.launch_heading_deg,
                  args.time_limit)
    code = code_identity()
    store = ResultStore(Path(args.out))
    metadata = {
        "mission": str(args.mission), "mission_name": mission.name,
        "sweeps": {s.name: list(s.values) for s in sweeps},
        "configs": [c.coords for c in configs],
        "starts": starts, "runs_per_start": args.runs_per_start, "root_seed": seed,
        "time_limit_s": args.time_limit, "total_runs": study.total_runs,
        "code_version": _git_version(),
        "seeding": "SeedSequence(root_seed, spawn_key=(replicate, 0)) for the plume; "
                   "(replicate, 1, start) for each vehicle",
    }
    try:
        store.open(metadata, study=study.identity(), code=code, restart=args.restart)
    except CodeChanged as exc:
        raise BatchError(f"{exc}: rerun with --restart to discard its results, or choose a "
                         "new --out") from None
    except StudyMismatch as exc:
        raise BatchError(f"{exc}: choose another --out or remove it") from None
    from cptbt.batch.runner import run_study

    def rerun(key: str, reason: str) -> None:
        print(f"cptbt: re-running part {key}: {reason}", file=sys.stderr)

    tasks = study.tasks(code)
    stats = run_study(tasks, store, workers=args.workers, scheduler=args.scheduler,
                      scheduler_timeout_s=args.scheduler_timeout, quiet=args.quiet,
                      on_rerun=rerun)
    table = store.consolidate(tasks)
    if not args.quiet:
        rate = stats["runs"] / max(stats["wall_time_s"], 1e-9) if stats["groups_run"] else 0
        print(f"{stats['runs']} missions ({stats['groups_skipped']} groups resumed from disk): "
              f"success {stats['successes'] / max(stats['runs'], 1):.1%}; "
              f"{stats['wall_time_s']:.1f} s wall, {rate:.1f} missions/s")
        print(f"  wrote {table}")
    if not args.no_plots:
        _plots(table, Path(args.out), args.quiet)
    return 0


def _plots(results: Path, out: Path, quiet: bool) -> None:
    from cptbt.batch.report import write_report

    written = write_report(load_results(results), out)
    if not quiet:
        for path in written:
            print(f"  wrote {path}")


def cmd_plot(args: argparse.Namespace) -> int:
    """Rebuild a study's figures and Markdown tables from its results table."""
    results = Path(args.results)
    rows = load_results(results)  # before making any folder: a bad input writes nothing
    out = Path(args.out) if args.out else (results if results.is_dir() else results.parent)
    from cptbt.batch.report import write_report

    for path in write_report(rows, out):
        print(f"  wrote {path}")
    return 0
