"""``cptbt batch`` and ``cptbt plot``: Monte Carlo studies and their figures."""

from __future__ import annotations

import argparse
import importlib.util
import os
import re
import subprocess
import sys
from pathlib import Path
from typing import Any

from cptbt import __version__
from cptbt.batch.comparison import command_faults, excursions
from cptbt.batch.errors import BatchError, CodeChanged
from cptbt.batch.integrity import code_identity, digest
from cptbt.batch.report import StudyGeometry
from cptbt.batch.scenario import environment_of, starts_at_a_source
from cptbt.batch.store import ResultStore, StudyMismatch, load_results
from cptbt.batch.study import GroupTask, Study, log_sample
from cptbt.batch.sweeps import Sweep, study_notes
from cptbt.cli import argtypes
from cptbt.cli.argtypes import UsageError, sigterm_as_interrupt
from cptbt.cli.batch_rounds import next_replicates, worst_rel_sem
from cptbt.cli.batch_starts import check_starts, study_starts
from cptbt.cli.batch_sweeps import study_configs
from cptbt.cli.inspect_cmds import load
from cptbt.cli.plot_cmd import cmd_plot, saved_study
from cptbt.mission import MissionBase
from cptbt.registry import plugin_provenance
from cptbt.study_spec import study_size_problem

BIG_STUDY_RUNS = 1000
"""A study of at least this many runs is announced with its size before it flies."""


def _sweep(text: str) -> Sweep:
    try:
        return Sweep.parse(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def _fraction(text: str) -> float:
    value = argtypes.positive_float(text)
    if value >= 1:
        raise argparse.ArgumentTypeError(f"{text!r}: a relative standard error below 1, e.g. 0.02")
    return value


def add_parsers(sub: Any) -> None:
    """Register ``batch`` and ``plot``."""
    p = sub.add_parser("batch", help="run a Monte Carlo study", description=cmd_batch.__doc__)
    # "-60,71" (a start south-west of the centre) is a value, not an option: argparse's test
    # for negative numbers, widened to lists of them (X,Y;X,Y and X0:X1:STEP).
    num = r"\d*\.?\d+(?:[eE][-+]?\d+)?"  # exponents too (a review's -40,1e1)
    p._negative_number_matcher = re.compile(rf"^-{num}([,;:]\s*[-+]?{num})*$")
    p.add_argument("mission", metavar="MISSION",
                   help="mission YAML file (its study: section, if any, is the default study)")
    where = p.add_mutually_exclusive_group()
    where.add_argument("--grid", type=argtypes.grid, metavar="NXxNY",
                       help="starts at the cell centres of a grid over the OpArea, e.g. 10x10 "
                       "(AB Fig. 11)")
    where.add_argument("--starts-x", type=argtypes.start_range, metavar="X0:X1:STEP",
                       help="starts along y = --y, e.g. 0:100:5 (AB Fig. 10)")
    where.add_argument("--starts", type=argtypes.starts, metavar="X,Y;X,Y",
                       help="explicit starts, in the mission's frame (N,E m for frame: ne; "
                       "lat,lon for geodetic); a leading minus is fine: --starts -60,71")
    p.add_argument("--y", type=argtypes.finite_float, default=0.0,
                   help="y of --starts-x (default 0)")
    p.add_argument("--runs-per-start", type=argtypes.positive_int, default=None, metavar="R",
                   help="plume realisations per start (default: the study section's, else 1)")
    p.add_argument("--start-mode", choices=("place", "launch"), default=None,
                   help="place: vehicles start at their start points (AB); launch: at the "
                   "mission's launch point, driving to them (default: the study section's, "
                   "else place)")
    p.add_argument("--amp-only", action="store_true",
                   help="for a mission with a mission_a section: study the AMP alone, from each "
                   "start (a study does not fly Mission A)")
    p.add_argument("--sweep", type=_sweep, action="append", default=[], metavar="PATH=V1,V2",
                   help="compare settings, e.g. maintain_plume.variant+reacquire_plume.variant="
                   "strategy_1,strategy_3, or a behaviour whole: 'declare_source=upflow_cluster,"
                   "{variant: likelihood_map, radius_m: 8}' (repeatable: the product is run)")
    p.add_argument("--until-sem", type=_fraction, default=None, metavar="REL",
                   help="keep adding plume realisations (rounds of --runs-per-start, as many "
                   "as the SEM's 1/sqrt(n) fall says are needed) until the "
                   "standard error of every configuration's mean time to source is below REL "
                   "times that mean, e.g. 0.02 (resumable; the folder holds an adaptive study)")
    p.add_argument("--max-runs-per-start", type=argtypes.positive_int, default=None, metavar="N",
                   help="with --until-sem: stop at N realisations per start even if the target "
                   "is not met (default: 50 times --runs-per-start, at most 10000)")
    p.add_argument("--seed", type=argtypes.seed, default=None,
                   help="root seed (default: the mission's)")
    p.add_argument("--time-limit", type=argtypes.positive_float, default=None, metavar="S",
                   help="override the mission's time limit, s")
    p.add_argument("--out", required=True, type=argtypes.out_dir, metavar="DIR",
                   help="results folder")
    p.add_argument("--workers", type=argtypes.positive_int, default=os.cpu_count() or 1,
                   help="local worker processes (default: all cores)")
    p.add_argument("--scheduler", metavar="ADDRESS",
                   help="run on a Dask distributed cluster instead (needs cptbt[cluster])")
    p.add_argument("--scheduler-timeout", type=argtypes.positive_float, default=10.0,
                   metavar="S", help="give up connecting to --scheduler after S s (default 10)")
    p.add_argument("--restart", action="store_true",
                   help="discard the folder's finished runs (e.g. made by other code), start over")
    p.add_argument("--log-runs", type=argtypes.non_negative_int, default=0, metavar="K",
                   help="write an MCAP cycle log for K runs drawn at random (seeded by the root "
                   "seed) to DIR/logs (needs cptbt[logs]); cptbt log summary / replay read them")
    p.add_argument("--no-plots", action="store_true",
                   help="skip the figures (tables.md is still written)")
    p.add_argument("--quiet", action="store_true",
                   help="no progress bar, summary or warnings; the notes on what a --sweep "
                   "changes (values not flown, settings a variant does not take) are still "
                   "printed: they say what the study compares")
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


def _check_planner(mission: MissionBase) -> None:
    """``$CPTBT_PLANNER``: a known value, and ``fleet`` only for a mission it can fly (before any
    folder is made)."""
    from cptbt.fleet import PLANNER_ENV, fleet_support, planner_choice

    try:
        choice = planner_choice()
    except ValueError as exc:
        raise UsageError(f"batch: {exc}") from None
    if choice == "fleet":
        support = fleet_support(mission)
        if not support.ok:
            raise UsageError(f"batch: {PLANNER_ENV}=fleet, but the fleet planner cannot fly "
                             f"{mission.name}: {support.reason} (use auto or tree)")


def _planner_record(configs: list[Any], n_starts: int, source: str) -> dict[str, Any]:
    """What ``study.json`` says of the planner each configuration's groups are flown with.

    Both planners give the same runs bit for bit (``benchmarks/fleet_equivalence.py``); this is
    provenance, so a reader knows which one produced the table.
    """
    from cptbt.batch.engine import FLEET_MIN_VEHICLES
    from cptbt.fleet import fleet_support, planner_choice

    choice = planner_choice()
    flown = []
    for c in configs:
        support = fleet_support(c.mission)
        big = choice == "auto" and n_starts >= FLEET_MIN_VEHICLES
        if support.ok and (choice == "fleet" or big):
            flown.append("fleet")
        else:
            flown.append(f"tree ({support.reason})" if big else "tree")
    return {"choice": choice, "vehicles_per_group": n_starts, "per_config": flown,
            "rule": f"auto: the fleet planner for groups of {FLEET_MIN_VEHICLES} or more "
                    "vehicles when every behaviour has an array form and no run is logged, "
                    "else one py_trees planner per vehicle (groups with a logged run: py_trees)"}


def cmd_batch(args: argparse.Namespace) -> int:
    """Fly a mission from many starts and plume realisations; resumable, reproducible.

    The mission's ``study:`` section says where, how often and what to sweep; each flag
    overrides the matching key.
    """
    mission = load(args.mission, simulate=True, warn=False)  # warned of below, as flown
    if mission.mission_a is not None:
        if not args.amp_only:
            raise UsageError(
                f"batch: {args.mission} has a mission_a section, and a study flies the AMP "
                "alone from each start: pass --amp-only to study it so (or use cptbt run)")
        mission = mission.model_copy(update={"mission_a": None})
    _check_planner(mission)
    spec = mission.study
    sweeps, configs, warnings = study_configs(args, mission)
    starts = study_starts(args, mission, spec)
    check_starts(mission, starts)
    if (at_source := starts_at_a_source(mission, starts)) and not args.quiet:
        print(f"cptbt: note: {at_source}", file=sys.stderr)
    runs_per_start = args.runs_per_start or (spec.runs_per_start if spec else 1)
    time_limit = args.time_limit or (spec.time_limit_s if spec else None)
    if time_limit is not None and any("time_limit_s" in c.coords for c in configs):
        # the study's limit replaced every swept one, rows still labelled with their own (a
        # review's time_limit_s=30,60 sweep flew 45 s each under --time-limit 45)
        given = "--time-limit" if args.time_limit else "the study's time_limit_s"
        raise UsageError(f"batch: {given} ({time_limit:g} s) would replace the swept "
                         "time_limit_s in every configuration: give one or the other")
    start_mode = args.start_mode or (spec.start_mode if spec else "place")
    env = environment_of(mission)
    seed = env.seed if args.seed is None else args.seed

    def study_of(n: int) -> Study:
        return Study(configs, starts, n, seed, env.launch_heading_deg, time_limit, start_mode)

    study = study_of(runs_per_start)
    adaptive = args.until_sem is not None
    if args.log_runs and adaptive:
        raise UsageError("batch: --log-runs and --until-sem do not go together (the runs to log "
                         "are drawn from a study of known size)")
    if args.log_runs and importlib.util.find_spec("mcap") is None:  # before the folder
        raise UsageError("batch: --log-runs needs the mcap package: pip install 'cptbt[logs]'")
    if args.max_runs_per_start is not None and not adaptive:
        raise UsageError("batch: --max-runs-per-start caps --until-sem's rounds; without "
                         "--until-sem give --runs-per-start")
    if args.max_runs_per_start is not None and args.max_runs_per_start < runs_per_start:
        raise UsageError(f"batch: --max-runs-per-start {args.max_runs_per_start} is below the "
                         f"first round's --runs-per-start {runs_per_start}")
    max_runs = (args.max_runs_per_start or min(10_000, 50 * runs_per_start)) if adaptive \
        else runs_per_start
    too_big = study_size_problem(len(starts), max_runs, len(configs))
    if too_big:  # before any task is built (a review's 10^11-run study took 24 GB first)
        raise UsageError(f"batch: {too_big}")
    cpus = os.cpu_count() or 1
    if args.scheduler is None and args.workers > WORKERS_PER_CPU * cpus:
        # a review's --workers 100000 forked 500 processes and the out-of-memory killer fired
        print(f"cptbt: note: --workers {args.workers} is more than {WORKERS_PER_CPU} per CPU "
              f"({cpus} here): {WORKERS_PER_CPU * cpus} workers", file=sys.stderr)
        args.workers = WORKERS_PER_CPU * cpus
    # A replicate's rows do not depend on how many replicates the study has (each is seeded by
    # its number): the identity leaves the count out, so the same folder takes more runs per
    # start (its finished ones kept; a review expected it) and an adaptive study resumes
    # whatever its target. Fewer runs per start tabulate the first ones.
    identity = digest({"study": study_of(1).identity(),
                       "replicates": "until_sem" if adaptive else "any"})
    code = code_identity(study_of(1).flies())
    store = ResultStore(Path(args.out))
    geometry = StudyGeometry.of(mission)
    metadata = {
        "mission": str(args.mission), "mission_name": mission.name,
        "sweeps": {s.name: list(s.values) for s in sweeps},
        "configs": [c.coords for c in configs],
        "config_missions": [c.mission_yaml for c in configs],
        "starts": starts, "runs_per_start": runs_per_start, "root_seed": seed,
        "time_limit_s": time_limit, "start_mode": start_mode, "total_runs": study.total_runs,
        "heading_deg": env.launch_heading_deg, "geometry": geometry.to_data(),
        "config_geometry": [StudyGeometry.of(c.mission).to_data() for c in configs],
        "code_version": _git_version(),
        "plugins": plugin_provenance(study_of(1).flies()),
        "planner": _planner_record(configs, len(starts), str(args.mission)),
        "seeding": "SeedSequence(root_seed, spawn_key=(replicate, 0)) for the plume; "
                   "(replicate, 1, start) for each vehicle",
        "notes": study_notes(mission, sweeps),
        "warnings": warnings,
    }
    if adaptive:
        metadata |= {"until_sem": args.until_sem, "runs_per_round": runs_per_start,
                     "max_runs_per_start": max_runs}
    before = saved_study(Path(args.out)) if Path(args.out).is_dir() else {}
    if args.log_runs and not args.restart and before.get("runs_per_start") not in (
            None, runs_per_start):
        raise UsageError(f"batch: --log-runs with --runs-per-start {runs_per_start} in a folder "
                         f"of {before['runs_per_start']} runs per start: the runs to log are "
                         "drawn from a study of known size, and its finished runs are not flown "
                         "again to log them; choose another --out")
    try:
        store.open(metadata, study=identity, code=code, restart=args.restart)
    except CodeChanged as exc:
        raise BatchError(f"{exc}: rerun with --restart to discard its results, or choose a "
                         "new --out") from None
    except StudyMismatch as exc:
        also = " (--restart discards a study's runs, not another study)" if args.restart else ""
        raise BatchError(f"{exc}: choose another --out or remove it{also}") from None
    from cptbt.batch.runner import run_study

    def rerun(key: str, reason: str) -> None:
        print(f"cptbt: re-running part {key}: {reason}", file=sys.stderr)

    n = runs_per_start
    wall, flown_groups, flown_runs = 0.0, 0, 0  # this command's work, over its rounds
    if (planned := study_of(n).total_runs) >= BIG_STUDY_RUNS and not args.quiet:
        # a review: 5 000 000 missions began without a word (the AB default study: 50 500)
        print(f"cptbt: note: {planned} missions to fly ({len(configs)} configuration"
              f"{'s' * (len(configs) != 1)} x {len(starts)} starts x {n} replicates"
              f"{', a first round' if adaptive else ''}); Ctrl-C keeps every finished run and "
              "the same command flies the rest", file=sys.stderr)
    while True:
        tasks = study_of(n).tasks(code)
        total = sum(len(t.starts) for t in tasks)
        if args.log_runs > total:
            raise UsageError(f"batch: --log-runs {args.log_runs}: the study has {total} "
                             f"run{'s' if total != 1 else ''}")
        if args.log_runs:
            tasks = log_sample(tasks, args.log_runs, seed, str(Path(args.out) / "logs"))
        sigterm_as_interrupt()
        try:
            stats = run_study(tasks, store, workers=args.workers, scheduler=args.scheduler,
                              scheduler_timeout_s=args.scheduler_timeout, quiet=args.quiet,
                              on_rerun=rerun)
        except KeyboardInterrupt:
            raise KeyboardInterrupt(_saved(store, tasks, args)) from None
        wall += stats["wall_time_s"]
        flown_groups += stats["groups_run"]
        flown_runs += stats["runs"] - stats["runs_resumed"]
        if not adaptive:
            break
        worst = worst_rel_sem(store.rows(tasks))
        nxt = next_replicates(n, worst, args.until_sem, runs_per_start, max_runs)
        if not args.quiet:
            print(f"  {n} realisations per start: largest relative SEM of the mean time "
                  f"{worst:.3f} (target {args.until_sem:g})"
                  + ("" if nxt is None else f"; going on to {nxt}"))
        if nxt is None:
            if worst > args.until_sem and not args.quiet:
                print(f"  stopped at --max-runs-per-start {max_runs} above the target")
            break
        n = nxt
    if adaptive:
        metadata |= {"runs_per_start": n, "total_runs": study_of(n).total_runs,
                     "relative_sem": worst}
        store.open(metadata, study=identity, code=code)
    table = store.consolidate(tasks)
    if not args.quiet:
        # Resumed groups are those on disk before this command, not its own earlier rounds
        # (each round's groups include the last's); the rate counts the runs it flew.
        resumed = stats["groups_skipped"] - (flown_groups - stats["groups_run"])
        rate = flown_runs / max(wall, 1e-9) if flown_runs else 0
        if mission.evaluation.criterion == "maintain":
            rows = load_results(table)
            t_m = [r["T_M"] for r in rows if r.get("T_M") is not None]
            outcome = (f"mean maintain time T_M {sum(t_m) / len(t_m):.1f} s over {len(t_m)} "
                       "runs with a contact" if t_m else "no run made contact")
        else:
            outcome = f"success {stats['successes'] / max(stats['runs'], 1):.1%}"
        if len(configs) > 1:  # a review read a pooled 97.7% (96.9% and 98.4%) as the result
            outcome += (f", all {len(configs)} configurations pooled (each: tables.md)")
        runs = stats["runs"]
        # A study found finished on disk flew nothing: "0.0 s wall, 0.0 missions/s" had read
        # as a study flown in no time.
        pace = (f"{wall:.1f} s wall, {rate:.1f} missions/s" if flown_runs else
                f"{f'all {runs} runs were' if runs != 1 else 'the run was'} already on disk; "
                "none flown")
        partial = stats["runs_partial"]
        also = (f", and {partial} run{'s' * (partial != 1)} of groups under way when it "
                "stopped" if partial else "")
        groups = f"{resumed} group{'s' * (resumed != 1)}"
        print(f"{runs} mission{'s' * (runs != 1)} ({groups} resumed from disk{also}): "
              f"{outcome}; {pace}")
        print(f"  wrote {table}")
        if beyond := store.left_out(tasks):
            print(f"  {beyond} runs of this study on disk, beyond its count, are left out of "
                  "the tables (kept in parts/)")
        rows = load_results(table)
        left, flown, far, _ = excursions(rows)
        if left:  # a review: every run 5-14 m outside, and the summary said only "success"
            print(f"  {left} of {flown} run{'s' * (flown != 1)} left the OpArea, the farthest "
                  f"{far:.1f} m outside (tables.md: \"Left the OpArea\")")
        faulty, flown, _, _ = command_faults(rows)
        if faulty:  # a review's plug-in: its faults had passed as results
            print(f"  {faulty} of {flown} run{'s' * (flown != 1)} had behaviour faults, commands "
                  "not flown as asked (tables.md: \"Behaviour faults\")")
        if args.log_runs:
            logged = sorted((Path(args.out) / "logs").glob("*.mcap"))
            n_logs = sum(len(t.log_ids) for t in tasks)
            note = ("; groups resumed from disk are not flown again, so they write no new log"
                    if resumed else "")
            print(f"  cycle logs of {n_logs} run{'s' if n_logs != 1 else ''} in "
                  f"{Path(args.out) / 'logs'} ({len(logged)} file"
                  f"{'s' if len(logged) != 1 else ''}{note})")
    _plots(table, Path(args.out), args.quiet, geometry, figures=not args.no_plots)
    from cptbt.batch.comparison import errors_note
    from cptbt.batch.outcome import ERROR_OUTCOME
    from cptbt.cli import DEBUG_ENV

    rows = load_results(table)
    failed = errors_note(rows)
    if failed:  # every other run is flown and tabulated; a bug met is said, and the exit fails
        row = next(i for i, r in enumerate(rows) if r.get("outcome") == ERROR_OUTCOME)
        print(f"cptbt: error: {failed}; `cptbt run --from {table} --row {row}` flies it "
              f"alone ({DEBUG_ENV}=1: with its traceback)", file=sys.stderr)
        return 1
    return 0


def _saved(store: ResultStore, tasks: list[GroupTask], args: argparse.Namespace) -> str:
    """What an interrupted study kept: every run finished, in whole groups and in the journals
    of the groups under way (with a scheduler, a group under way is flown again whole)."""
    whole = [t for t in tasks if store.path(t.key).exists()]
    runs = sum(len(t.starts) for t in whole)
    runs += sum(len(store.journal_rows(t)) for t in tasks if t not in whole)
    total = sum(len(t.starts) for t in tasks)
    lost = (" (with --scheduler a group is saved when all its runs are done: the runs of a "
            "group under way are flown again)" if args.scheduler else "")
    return (f"{runs} of {total} runs are saved in {args.out}{lost}; the same command flies "
            "the rest")


WORKERS_PER_CPU = 4
"""Most local worker processes per CPU: more only wait for a core, each holding its memory."""


def _plots(results: Path, out: Path, quiet: bool, geometry: StudyGeometry | None,
           figures: bool = True) -> None:
    from cptbt.batch.report import write_report
    from cptbt.batch.study_figures import STUDY_FIGURES

    before = [out / name for name in STUDY_FIGURES if (out / name).exists()]
    written = write_report(load_results(results), out, geometry, figures)
    if not quiet:
        for path in written:
            print(f"  wrote {path}")
        for path in before:
            if not path.exists():
                print(f"  removed {path}, an earlier report's (cptbt plot draws the figures)")
