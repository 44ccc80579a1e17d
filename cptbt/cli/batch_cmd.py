"""``cptbt batch`` and ``cptbt plot``: Monte Carlo studies and their figures."""

from __future__ import annotations

import argparse
import os
import subprocess
from pathlib import Path
from typing import Any

from cptbt import __version__
from cptbt.batch.scenario import environment_of
from cptbt.batch.store import ResultStore, load_results
from cptbt.batch.study import Study, Sweep, configurations, grid_starts, line_starts
from cptbt.cli.inspect_cmds import load


def add_parsers(sub: Any) -> None:
    """Register ``batch`` and ``plot``."""
    p = sub.add_parser("batch", help="run a Monte Carlo study", description=cmd_batch.__doc__)
    p.add_argument("mission", metavar="MISSION")
    where = p.add_mutually_exclusive_group()
    where.add_argument("--grid", metavar="NXxNY", help="starts at the cell centres of a grid "
                       "over the OpArea, e.g. 10x10 (AB Fig. 11)")
    where.add_argument("--starts-x", metavar="X0:X1:STEP",
                       help="starts along y = --y, e.g. 0:100:5 (AB Fig. 10)")
    where.add_argument("--starts", metavar="X,Y;X,Y", help="explicit starts (planning frame)")
    p.add_argument("--y", type=float, default=0.0, help="y of --starts-x (default 0)")
    p.add_argument("--runs-per-start", type=int, default=1, metavar="R",
                   help="plume realisations per start (default 1)")
    p.add_argument("--sweep", action="append", default=[], metavar="PATH=V1,V2",
                   help="compare settings, e.g. maintain_plume.variant+reacquire_plume.variant="
                   "strategy_1,strategy_3 (repeatable: the product is run)")
    p.add_argument("--seed", type=int, default=None, help="root seed (default: the mission's)")
    p.add_argument("--time-limit", type=float, default=None, metavar="S",
                   help="override the mission's time limit, s")
    p.add_argument("--out", required=True, metavar="DIR", help="results folder")
    p.add_argument("--workers", type=int, default=os.cpu_count() or 1,
                   help="local worker processes (default: all cores)")
    p.add_argument("--scheduler", metavar="ADDRESS",
                   help="run on a Dask distributed cluster instead (needs cptbt[cluster])")
    p.add_argument("--restart", action="store_true", help="discard finished runs, start over")
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
    except OSError:
        return __version__


def _starts(args: argparse.Namespace, mission: Any) -> list[tuple[float, float]]:
    if args.grid:
        nx, _, ny = args.grid.lower().partition("x")
        return grid_starts(mission, int(nx), int(ny or nx))
    if args.starts_x:
        return line_starts(args.starts_x, args.y)
    if args.starts:
        return [tuple(float(v) for v in s.split(",")) for s in args.starts.split(";")]  # type: ignore[misc]
    start = mission.start or mission.home
    p = mission.to_xy(start)
    return [(p.x, p.y)]


def cmd_batch(args: argparse.Namespace) -> int:
    """Fly a mission from many starts and plume realisations; resumable, reproducible."""
    mission = load(args.mission, simulate=True)
    try:
        sweeps = [Sweep.parse(s) for s in args.sweep]
        starts = _starts(args, mission)
        configs = configurations(mission, sweeps, args.mission)
    except ValueError as exc:
        raise SystemExit(f"cptbt batch: {exc}") from None
    env = environment_of(mission)
    seed = env.seed if args.seed is None else args.seed
    study = Study(configs, starts, args.runs_per_start, seed, env.launch_heading_deg,
                  args.time_limit)
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
        store.open(metadata, resume=not args.restart)
    except FileExistsError as exc:
        raise SystemExit(f"cptbt batch: {exc}") from None
    from cptbt.batch.runner import run_study

    stats = run_study(study.tasks(), store, workers=args.workers, scheduler=args.scheduler,
                      quiet=args.quiet)
    table = store.consolidate()
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
    if not results.exists():
        raise SystemExit(f"cptbt plot: {results} does not exist")
    out = Path(args.out) if args.out else (results if results.is_dir() else results.parent)
    out.mkdir(parents=True, exist_ok=True)
    _plots(results, out, False)
    return 0
