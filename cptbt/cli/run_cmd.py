"""``cptbt run``: fly one mission in the simulator and write its summary, trace and figure."""

from __future__ import annotations

import argparse
import hashlib
import json
import math
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Any

from cptbt.batch.engine import PlumeSnapshot, VehicleRun, simulate
from cptbt.batch.errors import BatchError
from cptbt.batch.figures import plume_grid, trajectory_figure
from cptbt.batch.outcome import ERROR_OUTCOME
from cptbt.batch.phased import phase_summary, simulate_phased
from cptbt.batch.runs import Partial, partial_runs
from cptbt.batch.scenario import (
    Environment,
    launch_pose,
    mean_flow,
    to_sim_params,
    true_sources,
)
from cptbt.batch.summary import summarise
from cptbt.cli import argtypes
from cptbt.cli.argtypes import UsageError
from cptbt.cli.inspect_cmds import load
from cptbt.cli.output import (
    command_faults_line,
    fmt,
    fresh_folder,
    outside_line,
    sensor_faults_line,
    time_share,
    times_line,
)
from cptbt.cli.run_text import (
    declaration_lines,
    short_verdict,
    sources_line,
    upflow_check_line,
    verdict_text,
    why_ended,
)
from cptbt.loader import MissionError, dump_mission, loads_mission
from cptbt.mission import MissionBase, dotted
from cptbt.registry import default_registry
from cptbt.types import Point

if TYPE_CHECKING:
    from cptbt.logs import CycleLog

# The study table (pyarrow), the group worker and the cycle log (mcap) are imported where they
# are used: a plain `cptbt run` needs none of them (issue 15: imports are part of a run's cost).


def north_up_note(args: argparse.Namespace, mission: MissionBase) -> None:
    """``--north-up`` where it changes nothing is said, not passed over."""
    if not args.north_up or args.quiet:
        return
    why = ("no trajectory.png is drawn (--no-figure)" if args.no_figure else
           "the mission has no compass (frame: planning): trajectory.png is drawn in the "
           "planning frame" if mission.frame == "planning" else None)
    if why:
        print(f"cptbt run: warning: --north-up: {why}", file=sys.stderr)


def add_parsers(sub: Any) -> None:
    """Register ``run``."""
    p = sub.add_parser("run", help="simulate a mission", description=cmd_run.__doc__)
    p.add_argument("mission", metavar="MISSION", nargs="?", help="mission YAML file")
    p.add_argument("--from", dest="results", metavar="RESULTS",
                   help="fly one row of a study again (a results folder from cptbt batch)")
    p.add_argument("--row", type=argtypes.non_negative_int, default=None, metavar="N",
                   help="with --from: the row of the results table (0-based)")
    p.add_argument("--seed", type=argtypes.seed, default=None,
                   help="override the environment seed")
    p.add_argument("--out", metavar="DIR", default=None, type=argtypes.out_dir,
                   help="output folder (default: a new runs/<mission>-<digest>-seed<N>)")
    p.add_argument("--quiet", action="store_true", help="print nothing but errors")
    p.add_argument("--no-figure", action="store_true", help="skip trajectory.png")
    p.add_argument("--north-up", action="store_true",
                   help="draw trajectory.png in east and north metres, north up (default: the "
                        "planning frame, +x along the OpArea's long axis, as TRO's figures)")
    p.add_argument("--log", metavar="FILE.mcap", default=None,
                   help="write every AMP cycle to an MCAP log (needs cptbt[logs]; missions with "
                        "a mission_a section)")
    p.set_defaults(func=cmd_run)


def write_trace(run: VehicleRun, out: Path) -> Path:
    """The per-tick trace as Parquet (with pyarrow) or CSV."""
    assert run.trace is not None
    try:
        import pyarrow.parquet as pq
    except ImportError:
        path = out / "trace.csv"
        cols = list(run.trace)
        with path.open("w", encoding="utf-8") as f:
            f.write(",".join(cols) + "\n")
            for row in zip(*run.trace.values(), strict=True):
                f.write(",".join("" if v is None else str(v) for v in row) + "\n")
        return path
    path = out / "trace.parquet"
    pq.write_table(arrow_table(run.trace), path)
    return path


def arrow_table(columns: dict[str, Any]) -> Any:
    """A pyarrow table of float, bool and string columns, built from their buffers.

    ``pa.table(dict)`` asks pyarrow's pandas shim whether each column is a pandas object, which
    imports pandas (~0.2 s of a 1.5 s run, issue 15) when it is installed. The buffers give the
    same table: float64 with NaN as a value (not null, as ``pa.table`` does for numpy arrays),
    bool bit-packed, strings as UTF-8 with int32 offsets.
    """
    import numpy as np
    import pyarrow as pa

    names, arrays = [], []
    for name, values in columns.items():
        if isinstance(values, np.ndarray) and values.dtype == np.bool_:
            bits = np.packbits(values, bitorder="little")
            arr = pa.Array.from_buffers(pa.bool_(), len(values), [None, pa.py_buffer(bits)])
        elif isinstance(values, np.ndarray):
            data = np.ascontiguousarray(values, dtype=np.float64)
            arr = pa.Array.from_buffers(pa.float64(), len(data), [None, pa.py_buffer(data)])
        else:
            encoded = [str(v).encode("utf-8") for v in values]
            offsets = np.zeros(len(encoded) + 1, dtype=np.int32)
            np.cumsum([len(b) for b in encoded], out=offsets[1:])
            arr = pa.Array.from_buffers(
                pa.string(), len(encoded),
                [None, pa.py_buffer(offsets), pa.py_buffer(b"".join(encoded))],
            )
        names.append(name)
        arrays.append(arr)
    return pa.Table.from_arrays(arrays, names=names)


def run_folder(mission: MissionBase, seed: int, root: Path = Path("runs")) -> Path:
    """A new folder ``runs/<mission>-<digest>-seed<N>`` that no earlier run wrote.

    The digest is of the normalised mission (behaviours, variants, parameters and settings),
    so swapping a variant writes beside the baseline, never over it; a repeat of the same run
    gets a ``-2``, ``-3``... suffix. The mission name is a safe slug (validated), so the folder
    is always inside ``root``.
    """
    digest = hashlib.sha256(dump_mission(mission).encode("utf-8")).hexdigest()[:8]
    return fresh_folder(root / f"{mission.name}-{digest}-seed{seed}")


def _open_log(args: argparse.Namespace, mission: MissionBase, seed: int) -> CycleLog | None:
    """The cycle log ``--log`` asks for (None without it)."""
    if not getattr(args, "log", None):
        return None
    from cptbt.logs import CycleLog, LogError

    try:
        if mission.mission_a is None:
            raise LogError("--log records the AMP session: the mission needs a mission_a section")
        return CycleLog.open(Path(args.log), mission, source=f"cptbt run, seed {seed}")
    except LogError as exc:
        raise UsageError(str(exc)) from None


def cmd_run(args: argparse.Namespace) -> int:
    """Simulate a mission with one vehicle; write summary.json, a trace and trajectory.png.

    With ``--from RESULTS --row N``, fly row N of a study again, alone, with that row's plume,
    seeds and start, and say whether it came out the same, bit for bit.
    """
    if args.results is not None or args.row is not None:
        if args.results is not None and args.mission is not None:
            raise UsageError("run: give MISSION, or --from RESULTS with --row N (not both)")
        if args.results is None:
            raise UsageError("run: --row N picks a row of a study: give --from RESULTS too")
        if args.row is None:
            raise UsageError("run: --from RESULTS needs --row N (0-based) to say which row")
        return refly(args)
    if args.mission is None:
        raise UsageError("run: give a MISSION file (or --from RESULTS --row N)")
    argtypes.not_the_mission("--log", getattr(args, "log", None), args.mission)
    mission = load(args.mission, simulate=True, warn=not args.quiet)
    north_up_note(args, mission)
    params = to_sim_params(mission, args.seed)
    seed = params.seed
    assert seed is not None, "to_sim_params always sets the seed"
    out = Path(args.out) if args.out else run_folder(mission, seed)
    if getattr(args, "log", None) and Path(args.log).resolve() in {
            (out / name).resolve() for name in ("summary.json", "trace.parquet",
                                                "trace.csv", "trajectory.png")}:
        raise UsageError(f"run: --log {args.log} is one of the files the run writes in {out}")
    # the log first: a bad --log leaves no empty output folder behind
    cycle_log = _open_log(args, mission, seed)  # a bad --log: UsageError, exit 2
    # made before the flight, so an unusable --out is said at once (a diff review: after a
    # whole flight), and taken away again if the run stops on an error: no empty folder
    made = not out.exists()
    out.mkdir(parents=True, exist_ok=True)
    try:
        source = Point(*params.source_xy_m)
        sources = [source, *(Point(*xy) for xy in params.extra_sources_xy_m)]
        waypoints = None
        grid = plume_grid(mission.op_area_geometry(), cover=sources) \
            if not args.no_figure else None
        if mission.mission_a is not None:  # the AMP as a guest inside the vehicle's Mission A
            try:
                phased, world, wall = simulate_phased(
                    mission, params, trace=True, plume_grid=grid,
                    planner=cycle_log.planner if cycle_log else None,
                    observers=[cycle_log] if cycle_log else ())
            finally:
                if cycle_log is not None:
                    cycle_log.close()
            run, waypoints = phased.amp, phased.waypoints
            summary = summarise(run, mission, source, seed, wall, t0=phased.t_amp_start or 0.0,
                                sources=sources).to_dict()
            summary["phases"] = phase_summary(phased, mission)
        else:
            (run,), world, wall = simulate(mission, params, [launch_pose(mission)], trace=True,
                                           plume_grid=grid)
            summary = summarise(run, mission, source, seed, wall, sources=sources).to_dict()
    except BaseException as exc:
        flown = partial_runs(exc) if isinstance(exc, Exception) else None
        if flown is not None and out.is_dir():  # what was flown, to look at
            _write_partial(flown, out, mission, params, grid, args)
        if made and out.is_dir() and not any(out.iterdir()):
            out.rmdir()
        raise
    summary["mean_flow"] = mean_flow(mission)
    (out / "summary.json").write_text(json.dumps(summary, indent=2) + "\n", encoding="utf-8")
    trace_path = write_trace(run, out)
    figure = None
    if grid is not None:
        if run.plume is None:
            run.plume = PlumeSnapshot.of(world, grid)
        figure = out / "trajectory.png"
        trajectory_figure(figure, run, mission, source,
                          f"{mission.name} (seed {seed}): {summary['outcome']}, "
                          f"{short_verdict(summary)}\n{_variants(mission)}"
                          + _faults_note(run),
                          threshold=mission.perception.threshold, waypoints=waypoints,
                          sources=sources, flow_deg=params.flow.mean_dir_deg,
                          north_up=args.north_up)
    if not args.quiet:
        s = summary
        print(f"{mission.name}, seed {seed}: {s['outcome']} ({verdict_text(s)}); the AMP "
              f"ended at {fmt(s['sim_time_s'], ' s')} "
              f"({wall:.2f} s wall, {s['sim_time_s'] / max(wall, 1e-9):.0f}x real time)")
        why = why_ended(s)
        if why:
            print(f"  {s['outcome']}: {why}")
        for text in declaration_lines(s):
            print(text)
        for line in (sources_line(s), upflow_check_line(s), sensor_faults_line(s),
                     command_faults_line(s), outside_line(s)):
            if line:
                print(line)
        if s["criterion"] == "maintain":
            print(f"  first detection {fmt(s['t1'], ' s')}; maintain time T_M "
                  f"{fmt(s['T_M'], ' s')} (AB eq. 3); closest to the source "
                  f"{fmt(s['closest_approach_m'], ' m')}")
        else:
            print(times_line(s))
        for c in s.get("phases", {}).get("timeline", []):
            # the detail too (a review read "(command_refused)" and had to open summary.json
            # to learn the speed its plug-in had sent), as cptbt serve prints it
            print(f"  t {c['t']:7.1f} s  {c['from']} -> {c['to']}  ({c['trigger']})"
                  + (f" {c['detail']}" if c.get("detail") else ""))
        share = time_share(s["time_share"])
        print(f"  time in behaviours: {share}")
        print(f"  wrote {out / 'summary.json'}, {trace_path}" + (f", {figure}" if figure else "")
              + (f", {args.log}" if args.log else ""))
    return 0


def _write_partial(flown: Partial, out: Path, mission: MissionBase, params: Any, grid: Any,
                   args: argparse.Namespace) -> None:
    """The trace and figure of a run that stopped on an error, up to its last whole cycle (a
    review's plug-in raised at t = 319 s, and nothing was written to see what it had done);
    a summary of an earlier run in the folder is removed (it is not this run's)."""
    run, world = flown.runs[0], flown.world
    if run.trace_recorder is None or not run.trace_recorder.count[run.index]:
        return
    (out / "summary.json").unlink(missing_ok=True)
    trace_path = write_trace(run, out)
    t = float(run.trace_recorder.column("t", run.index)[-1])
    figure = None
    if grid is not None:
        run.plume = PlumeSnapshot.of(world, grid)
        figure = out / "trajectory.png"
        trajectory_figure(figure, run, mission, Point(*params.source_xy_m),
                          f"{mission.name} (seed {params.seed}): stopped on an error, drawn to "
                          f"its last whole cycle (t = {t:.0f} s)\n{_variants(mission)}",
                          threshold=mission.perception.threshold, waypoints=flown.waypoints,
                          sources=true_sources(mission), flow_deg=params.flow.mean_dir_deg,
                          north_up=args.north_up)
    if not args.quiet:
        print(f"  wrote {trace_path}" + (f", {figure}" if figure else "")
              + f": the run to its last whole cycle (t = {t:.0f} s) before the error")


def _faults_note(run: VehicleRun) -> str:
    """The title's word on behaviours whose commands were not flown as asked (a review: a
    plug-in that only ever asked for NaN headings was named as the variant flown)."""
    bad = dict(run.nonfinite_commands)
    for name, (n, _, _) in run.unflyable_speeds.items():
        bad[name] = bad.get(name, 0) + n
    if not bad:
        return ""
    return "\nbehaviour faults: " + ", ".join(
        f"{name} not flown as asked in {n} cycle{'s' * (n != 1)}"
        for name, n in sorted(bad.items()))


def _variants(mission: MissionBase) -> str:
    """The variants the figure names (the finders, trackers, reacquirers and declarers)."""
    return ", ".join(f"{e.family.split('_')[0]} {e.variant}" for e in mission.entries()
                     if e.family in ("declare_source", "maintain_plume", "reacquire_plume",
                                     "find_plume"))


COMPARED_AWAY = ("wall_time_s",)
"""Columns a re-flown row may differ in: how long the computer took."""


def _other_code(meta: dict[str, Any], folder: Path) -> str:
    """``; the study was flown by other code ...`` when this code is not the study's (a
    review's edited plug-in read as "DIFFERENT", as if a run were not reproducible); else ""."""
    from cptbt.batch.comparison import code_change

    change = code_change(meta, f"{folder}/study.json")
    if change is None:
        return ""
    return (f"; the study was flown by cptbt {change[0]}, this is {change[1]} (its source, a "
            "plug-in's or a result dependency changed since): a run of other code may differ")


def refly(args: argparse.Namespace) -> int:
    """``cptbt run --from RESULTS --row N``: one study row flown again, alone, and compared."""
    from cptbt.batch.store import load_results
    from cptbt.batch.study import GroupTask
    from cptbt.batch.worker import fly_group, row_of

    results = Path(args.results)
    rows = load_results(results)
    if args.row >= len(rows):
        raise UsageError(f"run: --row {args.row}: the table has {len(rows)} rows (0-based)")
    row = rows[args.row]
    folder = results if results.is_dir() else results.parent
    try:
        meta = json.loads((folder / "study.json").read_text(encoding="utf-8"))
        mission_yaml = meta["config_missions"][int(row["config"])]
        coords = dict(meta.get("configs", [])[int(row["config"])]) if meta.get("configs") \
            else {}
    except (OSError, ValueError, KeyError, IndexError, TypeError):
        raise BatchError(f"{folder}: its study.json does not say how its rows were flown (a "
                         "study from an older cptbt?); run the study again") from None
    task = GroupTask(
        int(row["config"]), int(row["replicate"]), mission_yaml,
        ((float(row["start_x"]), float(row["start_y"])),), int(meta["root_seed"]),
        float(meta.get("heading_deg", 0.0)), meta.get("time_limit_s"), coords=coords,
        start_mode=str(row.get("start_mode") or meta.get("start_mode", "place")),
        start_ids=(int(row["start"]),),
    )
    try:
        mission = loads_mission(mission_yaml, f"{folder}/study.json", default_registry(),
                                Environment)
    except MissionError as exc:  # the stored mission's lines are no lines of study.json
        said = "; ".join(f"{dotted(loc)}: {msg}" for loc, msg in exc.located or []) or str(exc)
        names = ", ".join(sorted(set((meta.get("plugins") or {}).values())))
        plug = (" (a behaviour the study flew is not installed here: install the plug-in it "
                f"came from{f', {names}' if names else ''})"
                if "unknown variant" in said or "unknown behaviour" in said else "")
        raise BatchError(f"{folder}/study.json, configuration {task.config}: its mission no "
                         f"longer loads{plug}: {said}") from None
    north_up_note(args, mission)
    grid = plume_grid(mission.op_area_geometry(), cover=true_sources(mission)) \
        if not args.no_figure else None
    out = Path(args.out) if args.out else fresh_folder(
        Path("runs") / f"{mission.name}-row{args.row}-{task.key}")
    try:
        mission, (run,), source, wall = fly_group(task, trace=True, plume_grid=grid)
    except Exception as exc:  # the row's error again: what it flew, to look at (a review)
        flown = partial_runs(exc)
        if flown is not None:
            out.mkdir(parents=True, exist_ok=True)
            _write_partial(flown, out, mission, to_sim_params(mission, task.root_seed), grid,
                           args)
        raise
    summary = summarise(run, mission, source, task.root_seed, wall,
                        sources=true_sources(mission)).to_dict()
    again = row_of(task, 0, run, mission, source, wall)
    diff = sorted(k for k, v in again.items() if k in row and k not in COMPARED_AWAY
                  and not _same(v, row[k]))
    failed = row.get("outcome") == ERROR_OUTCOME  # the study's row stopped on an error
    if failed:  # and this one did not
        diff = ["outcome"]
    out.mkdir(parents=True, exist_ok=True)
    label = ", ".join(f"{k}={v}" for k, v in coords.items())
    summary["mean_flow"] = mean_flow(mission)
    summary["refly"] = {"results": str(results), "row": args.row, "same_as_study": not diff,
                        "differs_in": diff, "configuration": coords}
    (out / "summary.json").write_text(json.dumps(summary, indent=2) + "\n", encoding="utf-8")
    write_trace(run, out)
    if grid is not None:
        trajectory_figure(out / "trajectory.png", run, mission, source,
                          f"{mission.name}{f' [{label}]' if label else ''}, study row "
                          f"{args.row} ({task.key}, start {row['start']}): "
                          f"{summary['outcome']}, {short_verdict(summary)}",
                          threshold=mission.perception.threshold,
                          sources=true_sources(mission), goal=Point(*task.starts[0]),
                          flow_deg=to_sim_params(mission).flow.mean_dir_deg,
                          north_up=args.north_up)
    if not args.quiet:
        same = "the same as the study's row, bit for bit" if not diff else (
            f"where the study's row stopped on an error ({row.get('error')})"
            if failed else
            f"DIFFERENT from the study's row in {', '.join(diff)}") + (
            _other_code(meta, folder) if diff else "")
        print(f"row {args.row} of {results}{f' ({label})' if label else ''} flown again: "
              f"{summary['outcome']} ({short_verdict(summary)}), {same}")
        why = why_ended(summary)
        for line in ((f"  {summary['outcome']}: {why}" if why else None),
                     *declaration_lines(summary), sources_line(summary),
                     sensor_faults_line(summary),
                     command_faults_line(summary), outside_line(summary)):
            if line:
                print(line)
        print(f"  wrote {out}")
    return 0 if not diff else 1


def _same(a: Any, b: Any) -> bool:
    if isinstance(a, float) and isinstance(b, float):
        return a == b or (math.isnan(a) and math.isnan(b))
    return bool(a == b)
