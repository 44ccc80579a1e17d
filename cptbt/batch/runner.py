"""Running a study's groups: local processes by default, or a Dask cluster; with progress."""

from __future__ import annotations

import sys
import time
from collections.abc import Callable, Iterator
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from typing import Any

from cptbt.batch.store import ResultStore
from cptbt.batch.study import GroupTask
from cptbt.batch.worker import run_group

Rows = list[dict[str, Any]]


def _local(tasks: list[GroupTask], workers: int) -> Iterator[tuple[GroupTask, Rows]]:
    if workers <= 1:
        for task in tasks:
            yield task, run_group(task)
        return
    with ProcessPoolExecutor(max_workers=workers) as pool:
        pending = {pool.submit(run_group, t): t for t in tasks[: 2 * workers]}
        queue = list(tasks[2 * workers :])
        while pending:
            finished, _ = wait(pending, return_when=FIRST_COMPLETED)
            for fut in finished:
                task = pending.pop(fut)
                if queue:
                    nxt = queue.pop(0)
                    pending[pool.submit(run_group, nxt)] = nxt
                yield task, fut.result()


def _dask(tasks: list[GroupTask], address: str) -> Iterator[tuple[GroupTask, Rows]]:
    try:
        from distributed import Client, as_completed
    except ImportError as exc:  # pragma: no cover - depends on the install
        raise RuntimeError("--scheduler needs Dask: pip install 'cptbt[cluster]'") from exc
    with Client(address) as client:
        futures = client.map(run_group, tasks, pure=False)
        by_future = dict(zip(futures, tasks, strict=True))
        for fut in as_completed(futures):
            yield by_future[fut], fut.result()


class Progress:
    """A progress bar with runs done, success so far and ETA; silent when not on a terminal."""

    def __init__(self, total: int, done: int, successes: int, quiet: bool) -> None:
        self.successes = successes
        self.done = done
        self.bar: Any = None
        if quiet or not sys.stderr.isatty():
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
        self.done += len(rows)
        self.successes += sum(bool(r.get("success")) for r in rows)
        if self.bar is not None:
            self.bar.update(len(rows))
            self._postfix()

    def close(self) -> None:
        """Finish the bar."""
        if self.bar is not None:
            self.bar.close()


def run_study(
    tasks: list[GroupTask],
    store: ResultStore,
    *,
    workers: int = 1,
    scheduler: str | None = None,
    quiet: bool = False,
    on_group: Callable[[GroupTask, Rows], None] | None = None,
) -> dict[str, Any]:
    """Run every group not already on disk; each finished group is written at once.

    Returns:
        Counts: groups skipped (resumed) and run, runs, successes, and the wall time.
    """
    done = store.done()
    todo = [t for t in tasks if t.key not in done]
    previous = store.rows() if done else []
    runs_per_group = len(tasks[0].starts) if tasks else 0
    progress = Progress(len(tasks) * runs_per_group, len(previous),
                        sum(bool(r.get("success")) for r in previous), quiet)
    t0 = time.perf_counter()
    source = _dask(todo, scheduler) if scheduler else _local(todo, workers)
    try:
        for task, rows in source:
            store.write_group(task.key, rows)
            progress.update(rows)
            if on_group is not None:
                on_group(task, rows)
    finally:
        progress.close()
    return {
        "groups_skipped": len(tasks) - len(todo),
        "groups_run": len(todo),
        "runs": progress.done,
        "successes": progress.successes,
        "wall_time_s": time.perf_counter() - t0,
    }
