"""Running a study's groups: local processes by default, or a Dask cluster; with progress."""

from __future__ import annotations

import dataclasses
import os
import sys
import threading
import time
from collections.abc import Callable, Generator
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from typing import Any

from cptbt.batch.errors import BatchError
from cptbt.batch.store import ResultStore
from cptbt.batch.study import GroupTask
from cptbt.batch.worker import init_worker, run_group

Rows = list[dict[str, Any]]
Groups = Generator[tuple[GroupTask, Rows], None, None]
SCHEDULER_TIMEOUT_S = 10.0


def _local(tasks: list[GroupTask], workers: int) -> Groups:
    workers = min(workers, len(tasks))
    if workers <= 1:
        for task in tasks:
            yield task, run_group(task)
        return
    # Each worker dies with this process, even when it is killed outright (see init_worker).
    pool = ProcessPoolExecutor(max_workers=workers, initializer=init_worker,
                               initargs=(os.getpid(),))
    try:
        pending: dict[Future[Rows], GroupTask] = {
            pool.submit(run_group, t): t for t in tasks[: 2 * workers]}
        queue = list(tasks[2 * workers :])
        while pending:
            finished, _ = wait(pending, return_when=FIRST_COMPLETED)
            for fut in finished:
                task = pending.pop(fut)
                if queue:
                    nxt = queue.pop(0)
                    pending[pool.submit(run_group, nxt)] = nxt
                try:
                    rows = fut.result()
                except BrokenProcessPool:
                    raise BatchError("a worker process died (out of memory?); the finished "
                                     "groups are kept: run the same command again to go on"
                                     ) from None
                yield task, rows
    except BaseException:  # an error or Ctrl-C: stop now, not after the groups already queued
        _kill_workers(pool)
        raise
    finally:
        pool.shutdown(wait=True, cancel_futures=True)


def _rest(task: GroupTask, kept: Rows, store: ResultStore, journal: bool) -> GroupTask:
    """The part of ``task`` still to fly: the starts whose runs ``kept`` lacks (each start's
    seeds are its own, so flown without the others it is the same run), journalled to the
    store when ``journal`` (local workers: a Dask worker's files are not the study's)."""
    done = {r["start"] for r in kept}
    if done:
        left = [(i, s) for i, s in zip(task.ids, task.starts, strict=True) if i not in done]
        task = dataclasses.replace(task, starts=tuple(s for _, s in left),
                                   start_ids=tuple(i for i, _ in left))
    if journal:
        task = dataclasses.replace(task, journal=str(store.journal_path(task.key)),
                                   journal_tag=store.fingerprint)
    return task


def _kill_workers(pool: ProcessPoolExecutor) -> None:
    terminate = getattr(pool, "terminate_workers", None)  # Python >= 3.14
    if terminate is not None:
        terminate()
        return
    for process in list((getattr(pool, "_processes", None) or {}).values()):
        process.terminate()


def _dask(tasks: list[GroupTask], address: str,
          timeout_s: float) -> Groups:
    try:
        from distributed import Client, as_completed
    except ImportError:  # pragma: no cover - depends on the install
        raise BatchError("--scheduler needs Dask: pip install 'cptbt[cluster]'") from None
    if not tasks:
        return
    try:
        client = Client(address, timeout=timeout_s)
    except (OSError, TimeoutError, ValueError) as exc:
        reason = " ".join(str(exc).split()) or type(exc).__name__
        raise BatchError(f"cannot reach the Dask scheduler at {address}: {reason}") from None
    with client:
        futures = client.map(run_group, tasks, pure=False)
        by_future = dict(zip(futures, tasks, strict=True))
        for fut in as_completed(futures):
            yield by_future[fut], fut.result()


class Progress:
    """Runs done, success so far and ETA: a bar on a terminal; a line every
    :attr:`LINE_EVERY_S` otherwise (a review: a study under nohup printed nothing until its
    end, and a plug-in that hung was not to be told from a slow study). Between the groups'
    ends, the runs their journals hold count (:meth:`show`): a group is every start of one
    plume, and a bar that moved per group stood at 0 of 5 000 000 with 1 157 runs saved."""

    LINE_EVERY_S = 60.0

    def __init__(self, total: int, done: int, successes: int, quiet: bool) -> None:
        self.successes = successes
        self.done = done
        self.total = total
        self.bar: Any = None
        self.lines = False  # a line now and then (not on a terminal)
        self.lock = threading.Lock()
        self.t0 = time.monotonic()
        self.last_line = self.t0
        self.shown = -1
        if quiet:
            return
        if not sys.stderr.isatty():
            self.lines = True
            return
        try:
            from tqdm import tqdm
        except ImportError:  # without the extra: no bar, just the final line
            return
        self.bar = tqdm(total=total, initial=done, unit="run", dynamic_ncols=True,
                        desc="missions", smoothing=0.05)
        self._postfix()

    def _postfix(self) -> None:
        if self.bar is not None and self.done:
            self.bar.set_postfix_str(f"success {self.successes / self.done:.0%}")

    def update(self, rows: Rows) -> None:
        """Count a finished group."""
        with self.lock:
            self.done += len(rows)
            self.successes += sum(bool(r.get("success")) for r in rows)
            if self.bar is not None:
                self.bar.n = self.done
                self._postfix()
                self.bar.refresh()
        self.show(0)

    def show(self, under_way: int) -> None:
        """Show the count with ``under_way`` runs of groups not finished (their journals')."""
        with self.lock:
            n = min(self.done + under_way, self.total)
            if self.bar is not None and n != self.bar.n:
                self.bar.n = n
                self.bar.refresh()
            now = time.monotonic()
            if self.lines and now - self.last_line >= self.LINE_EVERY_S:
                self.last_line = now
                said = "no run has ended since the last line" if n == self.shown else (
                    f"success {self.successes / self.done:.0%} of the {self.done} runs of "
                    "groups written or resumed" if self.done else "no group written yet")
                self.shown = n
                print(f"cptbt batch: {n} of {self.total} runs done after "
                      f"{(now - self.t0) / 60:.0f} min ({said})", file=sys.stderr, flush=True)

    def close(self) -> None:
        """Finish the bar."""
        if self.bar is not None:
            self.bar.close()


def _watch(progress: Progress, live: dict[str, tuple[str, int]], stop: threading.Event) -> None:
    """Until ``stop``: every second, count the runs the journals of the groups under way hold
    (``live``: key → (journal, runs it held before this command)), for :meth:`Progress.show`."""
    while not stop.wait(1.0):
        under_way = 0
        for path, before in list(live.values()):
            try:
                with open(path, "rb") as f:  # whole lines (a torn one has no "}" before "\n")
                    under_way += max(f.read().count(b"}\n") - before, 0)
            except OSError:  # not yet written, or removed as its part was written
                continue
        progress.show(under_way)


def run_study(
    tasks: list[GroupTask],
    store: ResultStore,
    *,
    workers: int = 1,
    scheduler: str | None = None,
    scheduler_timeout_s: float = SCHEDULER_TIMEOUT_S,
    quiet: bool = False,
    on_group: Callable[[GroupTask, Rows], None] | None = None,
    on_rerun: Callable[[str, str], None] | None = None,
) -> dict[str, Any]:
    """Run every group not already on disk; each finished group is written at once.

    A part on disk that fails a check (``ResultStore.check``) is run again; ``on_rerun`` hears
    of each such group, with the reason, before anything runs.

    Returns:
        Counts: groups skipped (resumed), run and re-run, runs (all, those resumed from disk,
        and those of them kept from groups under way when the study stopped), successes, and
        the wall time.
    """
    resume = store.check(tasks)
    for key, reason in resume.rerun.items():
        if on_rerun is not None:
            on_rerun(key, reason)
    whole = {t.key: t for t in tasks}
    for key, kept in list(resume.partial.items()):
        if len(kept) == len(whole[key].starts):  # killed between its last run and its part
            store.write_group(whole[key], kept)
            resume.done.add(key)
            del resume.partial[key]
    todo = [_rest(t, resume.partial.get(t.key, []), store, journal=not scheduler)
            for t in tasks if t.key not in resume.done]
    runs_per_group = len(tasks[0].starts) if tasks else 0
    progress = Progress(len(tasks) * runs_per_group, resume.runs, resume.successes, quiet)
    t0 = time.perf_counter()
    live = {t.key: (t.journal, len(resume.partial.get(t.key, []))) for t in todo if t.journal}
    stop = threading.Event()
    watcher = threading.Thread(target=_watch, args=(progress, live, stop), daemon=True)
    watcher.start()
    source = (_dask(todo, scheduler, scheduler_timeout_s) if scheduler
              else _local(todo, workers))
    try:
        for task, rows in source:
            live.pop(task.key, None)
            kept = resume.partial.get(task.key, [])
            full = whole[task.key]
            # the runs kept from an interrupted flight of the group, and the rest just flown
            # (a run that raised is an error row alone, flown whole or resumed: run_group)
            merged = sorted(kept + rows, key=lambda r: full.ids.index(r["start"]))
            store.write_group(full, merged)
            progress.update(rows)
            if on_group is not None:
                on_group(full, merged)
    finally:
        stop.set()
        source.close()  # stops the pool now, not when the traceback is freed
        progress.close()
    return {
        "groups_skipped": len(tasks) - len(todo),
        "groups_run": len(todo),
        "groups_rerun": len(resume.rerun),
        "runs": progress.done,
        "runs_resumed": resume.runs,
        "runs_partial": sum(len(rows) for rows in resume.partial.values()),
        "successes": progress.successes,
        "wall_time_s": time.perf_counter() - t0,
    }
