"""The per-cycle record of every vehicle of a run, in preallocated numpy arrays.

One :class:`Recorder` serves the batch engine (N vehicles that stop at different times) and the
phased run (one vehicle, Mission A rows too). A row is written for many vehicles at once with
fancy indexing; behaviour and phase names are stored as small integer codes. Arrays grow by
doubling if a run outlasts the capacity it was given.

Memory (issue 15: 1,000 vehicles × 300 s ≤ 300 MB). The arrays are (vehicles, rows), so each
vehicle's rows of a column are contiguous and the pages of rows never written (vehicles that end
early) cost nothing — provided the arrays are not backed by 2 MB transparent huge pages, which
numpy asks the kernel for on any allocation ≥ 4 MB (a vehicle's row of a column is 24 kB at
3,000 rows, so one huge page spans ~85 vehicles' rows and the whole array became resident).
They are therefore allocated as anonymous private memory mapped page by page
(:func:`lazy_zeros`). What is stored, and what is not, with every value read back bit for bit
as it was written (``tests/batch/test_recorder_memory.py``):

- ``t``: one shared time per row index while every vehicle's k-th row was written at the same
  time (the batch engine's rows: all vehicles start together and record every cycle); the first
  row that breaks this turns it into a column per vehicle, filled from the shared times.
- ``x_est``, ``y_est`` (and ``heading_est``): not stored while equal to ``x``, ``y``
  (``heading``) bit for bit — navigation without error, as in AB's setup; the first row that
  differs turns them into columns of their own, copied from their twins.
- ``phase``: not stored while every phase written is 0 (the batch engine writes none).

All float columns stay float64: the measures read positions and times at full precision.
"""

from __future__ import annotations

import contextlib
import math
import mmap
from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import DTypeLike, NDArray

PATH_COLUMNS = ("t", "x", "y", "x_est", "y_est")
"""Always recorded: what the measures of SPEC §11 need."""

TRACE_COLUMNS = ("heading", "heading_est", "concentration", "flow_vx", "flow_vy",
                 "cmd_heading", "cmd_speed")
"""Recorded for traces (``cptbt run``) as well."""

TWINS = {"x_est": "x", "y_est": "y", "heading_est": "heading"}
"""Columns stored only once they differ from their twin (the estimate from the truth)."""


def lazy_zeros(shape: tuple[int, ...], dtype: DTypeLike = np.float64) -> NDArray[Any]:
    """A zero-filled array whose memory pages are paid for only as they are written.

    Anonymous private memory in 4 kB pages (``MADV_NOHUGEPAGE`` where the kernel knows it), not
    numpy's allocator, which asks for transparent huge pages on large arrays. Elsewhere (no
    ``MAP_PRIVATE``: Windows) ``numpy.zeros``.
    """
    dt = np.dtype(dtype)
    count = math.prod(shape)
    if not hasattr(mmap, "MAP_PRIVATE"):  # pragma: no cover - not POSIX
        return np.zeros(shape, dtype=dt)
    buf = mmap.mmap(-1, max(count * dt.itemsize, 1), flags=mmap.MAP_PRIVATE | mmap.MAP_ANONYMOUS)
    advice = getattr(mmap, "MADV_NOHUGEPAGE", None)
    if advice is not None:
        with contextlib.suppress(OSError):  # a kernel without transparent huge pages
            buf.madvise(advice)
    return np.frombuffer(buf, dtype=dt, count=count).reshape(shape)


def _same_bits(a: NDArray[np.float64], b: NDArray[np.float64]) -> bool:
    """Equal bit for bit (NaN equal to the same NaN; 0.0 unequal to -0.0)."""
    return bool(np.array_equal(a.view(np.uint64), b.view(np.uint64)))


MAX_PREALLOCATED_ROWS = 1 << 16
"""Most rows a recorder preallocates per vehicle (a 1800 s run at 10 Hz needs 18,000); a longer
run grows its arrays by doubling. A week-long limit at 100 Hz would otherwise preallocate 6e7."""


class Recorder:
    """Rows of ``n`` vehicles, each with its own count.

    Args:
        n: vehicles.
        capacity: rows to preallocate per vehicle (at most :data:`MAX_PREALLOCATED_ROWS`).
        trace: record the :data:`TRACE_COLUMNS` too.
    """

    def __init__(self, n: int, capacity: int, trace: bool = False) -> None:
        self.n = n
        self.trace = trace
        self.count = np.zeros(n, dtype=np.int64)
        cap = min(max(int(capacity), 8), MAX_PREALLOCATED_ROWS)
        self.columns = PATH_COLUMNS + (TRACE_COLUMNS if trace else ())
        # Stored columns; "t" and the TWINS join them only when they must (see the module's
        # docstring). add() writes NaN into the columns a row does not give.
        self.floats: dict[str, NDArray[np.float64]] = {
            c: lazy_zeros((n, cap)) for c in self.columns if c != "t" and c not in TWINS
        }
        self.t_shared: NDArray[np.float64] | None = np.full(cap, np.nan)
        """The time of row k of every vehicle, while shared (else None: ``floats["t"]``)."""
        self.detected = lazy_zeros((n, cap), bool)
        self.active = lazy_zeros((n, cap), np.int16)
        self.phase: NDArray[np.int16] | None = None
        self._cap = cap
        self.names: list[str] = [""]
        self.phases: list[str] = [""]
        self._codes: dict[str, int] = {"": 0}
        self._phase_codes: dict[str, int] = {"": 0}

    @property
    def capacity(self) -> int:
        """Rows available per vehicle before the arrays grow."""
        return self._cap

    def code(self, name: str | None) -> int:
        """The integer code of a behaviour name ('' for none)."""
        key = name or ""
        if key not in self._codes:
            self._codes[key] = len(self.names)
            self.names.append(key)
        return self._codes[key]

    def phase_code(self, name: str) -> int:
        """The integer code of a phase name."""
        if name not in self._phase_codes:
            self._phase_codes[name] = len(self.phases)
            self.phases.append(name)
        return self._phase_codes[name]

    def add(
        self,
        idx: NDArray[np.intp],
        values: dict[str, Any],
        detected: NDArray[np.bool_] | bool = False,
        active: NDArray[np.int16] | int = 0,
        phase: int = 0,
    ) -> None:
        """One row for each vehicle in ``idx``; ``values`` maps columns to scalars or arrays."""
        if len(idx) == 0:
            return
        rows = self.count[idx]
        if int(rows.max()) >= self.capacity:
            self._grow()
        self._add_time(rows, values.get("t", np.nan))
        for col, twin in TWINS.items():
            if col in self.columns and col not in self.floats:
                mine = np.asarray(values.get(col, np.nan), dtype=float)
                theirs = np.asarray(values.get(twin, np.nan), dtype=float)
                if mine.shape != theirs.shape:
                    mine, theirs = (np.broadcast_to(a, rows.shape) for a in (mine, theirs))
                if not _same_bits(mine, theirs):
                    self.floats[col] = self._copy_of(self.floats[twin])
        for col, a in self.floats.items():
            a[idx, rows] = values.get(col, np.nan)
        self.detected[idx, rows] = detected
        self.active[idx, rows] = active
        if phase != 0 and self.phase is None:
            self.phase = lazy_zeros((self.n, self.capacity), np.int16)
        if self.phase is not None:
            self.phase[idx, rows] = phase
        self.count[idx] = rows + 1

    def _add_time(self, rows: NDArray[np.int64], t: Any) -> None:
        """Keep ``t`` in the shared times while every vehicle's row k has the same time."""
        shared = self.t_shared
        if shared is None:
            return  # the "t" column is written with the others
        k = int(self.count.max())  # rows 0..k-1 have been written (by the longest vehicle)
        if np.ndim(t) == 0:
            old = rows < k
            if np.all(shared[rows[old]].view(np.uint64) == np.float64(t).view(np.uint64)):
                shared[rows] = t  # rows ≥ k are all row k, new
                return
        # another time for a row some vehicle already has: one column per vehicle from now on
        col = lazy_zeros((self.n, self.capacity))
        col[:, :k] = shared[:k]
        self.floats = {"t": col, **self.floats}
        self.t_shared = None

    def _copy_of(self, a: NDArray[np.float64]) -> NDArray[np.float64]:
        out = lazy_zeros(a.shape)
        k = int(self.count.max())
        out[:, :k] = a[:, :k]
        return out

    def _grow(self) -> None:
        cap = 2 * self.capacity

        def wider(a: NDArray[Any]) -> NDArray[Any]:
            out = lazy_zeros((a.shape[0], cap), a.dtype)
            out[:, : a.shape[1]] = a
            return out

        self.floats = {c: wider(a) for c, a in self.floats.items()}
        self.detected = wider(self.detected)
        self.active = wider(self.active)
        if self.phase is not None:
            self.phase = wider(self.phase)
        if self.t_shared is not None:
            t = np.full(cap, np.nan)
            t[: self._cap] = self.t_shared
            self.t_shared = t
        self._cap = cap

    def allocated_bytes(self) -> int:
        """Bytes of the arrays as allocated (resident only as far as rows were written)."""
        arrays = [*self.floats.values(), self.detected, self.active, self.count]
        arrays += [a for a in (self.t_shared, self.phase) if a is not None]
        return sum(a.nbytes for a in arrays)

    # -- reading ----------------------------------------------------------------------------
    def column(self, name: str, i: int) -> NDArray[Any]:
        """Vehicle ``i``'s recorded values of one column (a view; read-only where shared)."""
        k = int(self.count[i])
        if name == "detected":
            return self.detected[i, :k]
        if name == "t" and self.t_shared is not None:
            view = self.t_shared[:k]
        elif name in TWINS and name in self.columns and name not in self.floats:
            view = self.floats[TWINS[name]][i, :k]
        else:
            return self.floats[name][i, :k]
        view.flags.writeable = False
        return view

    def xy(self, i: int, estimated: bool = False) -> NDArray[np.float64]:
        """Vehicle ``i``'s track, (k, 2): true, or as navigation estimated it."""
        x, y = ("x_est", "y_est") if estimated else ("x", "y")
        return np.column_stack([self.column(x, i), self.column(y, i)])

    def active_names(self, i: int) -> list[str]:
        """Vehicle ``i``'s active behaviour per row ('' for none)."""
        return [self.names[c] for c in self.active[i, : int(self.count[i])]]

    def time_in(self, i: int, where: NDArray[np.bool_] | None = None) -> dict[str, float]:
        """Seconds vehicle ``i`` spent in each behaviour ('none' for no output): each cycle
        holds until the next one (the last, when the run ended, for no time), so the times add
        up to the span of the cycles. Crediting each cycle a nominal period had counted the
        last one past the end, and under-counted a 10 Hz cycle that the simulator's 9 Hz step
        could only tick every 0.111 s (two reviews)."""
        k = int(self.count[i])
        codes = self.active[i, :k]
        t = self.column("t", i)
        held = np.diff(t, append=t[-1]) if k else np.zeros(0)
        if where is not None:
            codes, held = codes[where], held[where]
        seconds = np.bincount(codes, weights=held, minlength=len(self.names))
        counts = np.bincount(codes, minlength=len(self.names))
        return {(self.names[c] or "none"): float(seconds[c]) for c, n in enumerate(counts) if n}

    def table(self, i: int, extra: Sequence[str] = ()) -> dict[str, Any]:
        """Vehicle ``i``'s rows as columns (numpy arrays; names as strings), for Parquet/CSV."""
        k = int(self.count[i])
        out: dict[str, Any] = {c: self.column(c, i).copy() for c in self.columns}
        out["detected"] = self.detected[i, :k].copy()
        out["active"] = self.active_names(i)
        if "phase" in extra:
            codes = self.phase[i, :k] if self.phase is not None else np.zeros(k, dtype=np.int16)
            out["phase"] = [self.phases[c] for c in codes]
        return out
