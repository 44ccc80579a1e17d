"""Flying one group of a study: what a worker process (local or Dask) runs."""

from __future__ import annotations

import ctypes
import dataclasses
import json
import os
import signal
import sys
import threading
import time
import traceback
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

from cptbt.batch.engine import VehicleRun, simulate
from cptbt.batch.errors import BatchError
from cptbt.batch.integrity import code_identity
from cptbt.batch.journal import JournalFile
from cptbt.batch.outcome import ERROR_OUTCOME
from cptbt.batch.scenario import (
    Environment,
    launch_pose,
    planning_angle,
    to_sim_params,
    true_sources,
)
from cptbt.batch.study import GroupTask, config_label, group_seeds
from cptbt.batch.summary import place, summarise
from cptbt.loader import loads_mission
from cptbt.mission import MissionBase
from cptbt.node import blame
from cptbt.registry import default_registry
from cptbt.types import Point

if TYPE_CHECKING:
    from cptbt.logs import CycleLog

PR_SET_PDEATHSIG = 1  # linux/prctl.h
WATCHDOG_PERIOD_S = 0.5


def init_worker(main_pid: int) -> None:
    """Initializer of a local worker process: make it die with the study's main process.

    The main process can die without stopping its pool (``kill -9``, the out-of-memory killer);
    a worker left behind would fly its groups for nobody and hold a core. On Linux the kernel
    kills the worker when its parent dies (``PR_SET_PDEATHSIG``); everywhere, a watchdog thread
    exits the worker once its parent or the main process is gone (the parent is a fork server
    under the ``forkserver`` start method, which itself exits with the main process).

    Args:
        main_pid: the process id of the study's main process.
    """
    # Ctrl-C reaches the whole process group: the main process alone handles it (it stops the
    # pool), so a worker waiting for work does not print a traceback.
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    # SIGTERM kills a worker outright: the main process turns its own SIGTERM into Ctrl-C
    # (cli.argtypes.sigterm_as_interrupt), and a worker that inherited that handler stopped at
    # random points when the whole group was sent SIGTERM (timeout, systemd, Slurm), could hold
    # the pool's queue lock, and hung the study for good (a review); the main process stops the
    # pool by SIGTERM too.
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    if sys.platform.startswith("linux"):
        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0)
    parent = os.getppid()
    if not _alive(main_pid):  # it died before the line above took effect
        os._exit(1)
    threading.Thread(target=_watch, args=(parent, main_pid), daemon=True,
                     name="cptbt-parent-watchdog").start()


def _watch(parent: int, main_pid: int) -> None:
    while os.getppid() == parent and _alive(main_pid):
        time.sleep(WATCHDOG_PERIOD_S)
    os._exit(1)


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # it exists, owned by someone else
        return True
    return True


def flatten(summary: dict[str, Any]) -> dict[str, Any]:
    """One flat row of a run summary (nested places become ``<name>_<axis>`` columns)."""
    row: dict[str, Any] = {}
    # a place's axes, as the mission gives them (x, y; north, east; lat, lon when geodetic)
    truth = summary.get("true_source")
    axes = tuple(truth) if isinstance(truth, dict) else ("x", "y", "north", "east")
    for key, value in summary.items():
        if key in ("time_in_behaviour_s", "time_share", "declared_sources", "true_sources",
                   "home", "mission_start"):  # the mission's, the same in every row of a study
            continue
        if isinstance(value, dict):
            for sub, v in value.items():
                row[f"{key}_{sub}"] = v
        elif value is None and key in ("declared_source", "held_candidate",
                                       "verifying_candidate"):
            # a place that may be absent: its columns all the same (one schema for every study)
            for sub in axes:
                row[f"{key}_{sub}"] = None
        else:
            row[key] = value
    # Every declared point (planning x, y and its error to the nearest true source), as JSON
    # text: declared_source_* is the last one alone, and a multi-source study needs them all.
    row["declared_points"] = json.dumps(
        [[q["x"], q["y"], q.get("error_m")] for q in summary.get("declared_sources") or [] if q])
    # Seconds in each behaviour leaf (time_maintain_plume.track_in_s) and in each family
    # (time_maintain_plume_s: track-in and track-out together).
    for name, seconds in summary.get("time_in_behaviour_s", {}).items():
        row[f"time_{name}_s"] = seconds
        family = f"time_{name.split('.')[0]}_s"
        if name.count(".") >= 1:
            row[family] = row.get(family, 0.0) + seconds
    return row


def worker_code(task: GroupTask) -> str:
    """The code identity this process has for a task's study (over the behaviours the whole
    study flies, as the study's own was computed)."""
    return code_identity(task.flies or None)


def fly_group(task: GroupTask, trace: bool = False, plume_grid: Any = None,
              on_end: Callable[[int, VehicleRun, MissionBase, Point], None] | None = None,
              isolate: bool = False) -> tuple[MissionBase, list[VehicleRun], Point, float]:
    """Fly every start of one group in one shared world (its replicate's plume).

    Under ``start_mode: place`` each vehicle starts at its start point, which is also its
    move-to-field goal; under ``launch`` every vehicle starts at the mission's launch point
    (``environment.launch``, else home) and move-to-field drives it to its start point.
    ``on_end(k, run, mission, source)`` hears of the group's ``k``-th run as soon as it ends
    (its cycle log, if it has one, closed first). ``isolate``: a run whose planner raises
    ends alone, with ``run.error`` (:func:`~cptbt.batch.engine.simulate`).

    Returns:
        The group's mission, its runs, the true source and the wall time.
    """
    mission = loads_mission(task.mission_yaml, f"group {task.key}", default_registry(),
                            Environment)
    params = to_sim_params(mission, task.root_seed)
    env_rng, vehicle_rngs = group_seeds(task.root_seed, task.replicate, task.ids)
    heading = planning_angle(mission, task.heading_deg)
    goals = [Point(x, y) for x, y in task.starts]
    if task.start_mode == "launch":
        lx, ly, lh = launch_pose(mission)
        poses = [(lx, ly, lh) for _ in task.starts]
    else:
        poses = [(x, y, heading) for x, y in task.starts]
    logs = _open_logs(task, mission, goals)
    source = Point(*params.source_xy_m)

    def close_log(k: int, run: VehicleRun) -> None:
        log = logs.pop(k, None)
        if log is not None:
            outcome = run.outcome.value if run.outcome is not None else "not ended"
            log.phase(run.t_end, "amp.override", "amp.give_back", "study_run_end",
                      f"outcome {outcome}")
            log.close()

    def ended(k: int, run: VehicleRun) -> None:
        close_log(k, run)
        if on_end is not None:
            on_end(k, run, mission, source)

    try:
        runs, _, wall = simulate(mission, params, poses, env_rng=env_rng,
                                 vehicle_rngs=vehicle_rngs, time_limit_s=task.time_limit_s,
                                 goals=goals, trace=trace, plume_grid=plume_grid, logs=logs,
                                 on_end=ended, isolate=isolate)
        for k in list(logs):  # a run the loop left without an end (none should be)
            close_log(k, runs[k])
    finally:
        for log in logs.values():
            log.close()
    return mission, runs, source, wall


def _open_logs(task: GroupTask, mission: MissionBase, goals: list[Point]) -> dict[int, CycleLog]:
    """The cycle logs of the group's runs that :func:`cptbt.batch.study.log_sample` chose."""
    if not task.log_ids:
        return {}
    from cptbt.logs import CycleLog

    logs: dict[int, CycleLog] = {}
    for k, i in enumerate(task.ids):
        if i in task.log_ids:
            path = Path(task.log_dir) / f"{task.key}-s{i:04d}.mcap"
            source = (f"cptbt batch: config {task.config}, replicate {task.replicate}, start "
                      f"{i}, root seed {task.root_seed}")
            log = CycleLog.open(path, mission, source=source, start=goals[k])
            log.phase(0.0, "pre_launch", "amp.override", "study_run_start",
                      f"start ({goals[k].x:.1f}, {goals[k].y:.1f}), {task.start_mode}")
            logs[k] = log
    return logs


def run_group(task: GroupTask) -> list[dict[str, Any]]:
    """Fly every start of one group in one world; one flat row per run.

    Each row names everything needed to fly it again alone (``cptbt run --from``): its
    configuration, replicate and start index, the root seed and the start point.

    Raises:
        BatchError: this process runs other code than the study was planned with (a Dask
            worker with another cptbt installed).
    """
    here = worker_code(task) if task.code else ""
    if task.code and task.code != here:
        raise BatchError(f"a worker runs cptbt {here} but the study needs "
                         f"{task.code}: install the same cptbt on every worker")
    journal = Journal(task)
    try:
        mission, runs, source, wall = fly_group(task, on_end=journal.ended, isolate=True)
    except Exception as exc:  # a bug met by the group, not one run's: the study goes on
        return _after_error(task, exc, journal.rows)
    finally:
        journal.close()
    rows = [journal.rows.get(k) or row_of(task, k, run, mission, source, 0.0)
            for k, run in enumerate(runs)]
    for row in rows:  # the group's wall time, shared (as before the journal)
        row["wall_time_s"] = wall / len(runs)
    return rows


def _after_error(task: GroupTask, exc: Exception, finished: dict[int, dict[str, Any]]
                 ) -> list[dict[str, Any]]:
    """The group's rows when flying it raised ``exc``, an error no one run's (the world's, or
    the fleet planner's, which ticks every vehicle at once; a run whose own planner raises
    ends alone: :func:`fly_group`'s ``isolate``): the runs that had ended keep their rows,
    every run still under way is an error row."""
    done = {task.ids[k]: row for k, row in finished.items()}
    stopped = [i for i in task.ids if i not in done]
    rows = list(done.values()) + failed_rows(_only(task, stopped), exc)
    return sorted(rows, key=lambda r: task.ids.index(r["start"]))


def _only(task: GroupTask, ids: list[int]) -> GroupTask:
    """``task`` with only the starts ``ids``."""
    keep = [task.ids.index(i) for i in ids]
    return dataclasses.replace(task, starts=tuple(task.starts[k] for k in keep),
                               start_ids=tuple(ids))


class Journal:
    """A group's runs, each made a row as soon as it ends and, with ``GroupTask.journal``,
    appended to the study's journal of the group (:class:`~cptbt.batch.journal.JournalFile`),
    so that an interrupted group keeps them (a review's Ctrl-C lost up to a group's worth, 99
    runs of a 10 x 10 grid)."""

    def __init__(self, task: GroupTask) -> None:
        self.task = task
        self.rows: dict[int, dict[str, Any]] = {}
        self.file = JournalFile(task.journal, task.journal_tag, task.key) if task.journal \
            else None
        self.t0 = time.perf_counter()

    def ended(self, k: int, run: VehicleRun, mission: MissionBase, source: Point) -> None:
        """Run ``k`` of the group is over: its row, kept and journalled; an error row for a
        run its planner's error ended, or whose row could not be made."""
        wall = (time.perf_counter() - self.t0) / len(self.task.starts)
        error, row = run.error, None
        if error is None:
            try:
                row = row_of(self.task, k, run, mission, source, wall)
            except Exception as exc:  # this run's alone: the others fly on
                error = exc
        if row is None:
            assert error is not None
            (row,) = failed_rows(_only(self.task, [self.task.ids[k]]), error)
        self.rows[k] = row
        if self.file is not None:
            self.file.write(row)

    def close(self) -> None:
        """Close the journal file (the study removes it once the group's part is written)."""
        if self.file is not None:
            self.file.close()


def failed_rows(task: GroupTask, exc: Exception) -> list[dict[str, Any]]:
    """The rows of a group that stopped on an error: one per start, outcome ``error``, not a
    success, the error and where it was raised in ``error``, and what names the run (as
    :func:`row_of`), so that the rest of the study goes on, the tables count them as failures
    and ``cptbt batch`` says so at the end. Such a group is not flown again on resume: the same
    seed meets the same error (``cptbt run --from`` flies one alone, with its traceback)."""
    text = blame(exc)  # a behaviour's: named, with the line in its own code
    if text is None:
        where = traceback.extract_tb(exc.__traceback__)[-1] if exc.__traceback__ else None
        text = f"{type(exc).__name__}: {exc}".splitlines()[0][:300]
        if where is not None:
            text += f" (at {Path(where.filename).name}:{where.lineno})"
    return error_rows(task, text)


def error_rows(task: GroupTask, text: str) -> list[dict[str, Any]]:
    """:func:`failed_rows` with the error's text given: the rows of a group's starts when the
    group stopped on the error ``text``."""
    limit = task.time_limit_s
    try:
        mission = loads_mission(task.mission_yaml, f"group {task.key}", default_registry(),
                                Environment)
        name = mission.name
        limit = mission.time_limit_s if limit is None else limit
    except Exception:  # the mission itself would not load: name the configuration alone
        name = str(task.config)
    # a failure, counted at the run's time limit in the mean search time and the maps, as
    # every failure is (a review: counted as failures in the success rate, the errors had been
    # left out of the times, so a plug-in that raised looked faster)
    return [{"config": task.config, **task.coords, "replicate": task.replicate, "start": i,
             "mission": name, "outcome": ERROR_OUTCOME, "success": False, "error": text,
             **_placement(task, k, name), "run_time_limit_s": limit}
            for k, i in enumerate(task.ids)]


def _placement(task: GroupTask, k: int, mission_name: str) -> dict[str, Any]:
    """Where and how the group's ``k``-th start flew, and what names its configuration: the
    columns every row ends with."""
    x, y = task.starts[k]
    return {"start_x": x, "start_y": y, "start_mode": task.start_mode,
            "seed_key": f"{task.root_seed}/{task.replicate}/{task.ids[k]}",
            "configuration": config_label(task.coords, mission_name)}


def row_of(task: GroupTask, k: int, run: VehicleRun, mission: MissionBase, source: Point,
           wall_s: float) -> dict[str, Any]:
    """The results row of the group's ``k``-th start: the one table schema of every study."""
    i = task.ids[k]
    row = {"config": task.config, **task.coords, "replicate": task.replicate, "start": i}
    row.update(flatten(summarise(run, mission, source, task.root_seed, wall_s,
                                 sources=true_sources(mission)).to_dict()))
    row.update(_placement(task, k, mission.name))
    # the start's other axes are the study's start too, as start_x, start_y (in launch mode
    # the run begins at the launch: a review read the launch in start_north/east, the grid
    # start in start_x/y and tables.md)
    row.update({f"start_{axis}": v
                for axis, v in place(mission, Point(*task.starts[k])).items()})
    # the limit the run flew under (the study's, else its configuration's): a failure counts
    # as it in the mean search time and the maps
    row["run_time_limit_s"] = (task.time_limit_s if task.time_limit_s is not None
                               else mission.time_limit_s)
    return row
