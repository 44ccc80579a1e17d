"""The per-cycle record of every vehicle of a run, in preallocated numpy arrays.

One :class:`Recorder` serves the batch engine (N vehicles that stop at different times) and the
phased run (one vehicle, Mission A rows too). A row is written for many vehicles at once with
fancy indexing; behaviour and phase names are stored as small integer codes. Arrays grow by
doubling if a run outlasts the capacity it was given.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

PATH_COLUMNS = ("t", "x", "y", "x_est", "y_est")
"""Always recorded: what the measures of SPEC §11 need."""

TRACE_COLUMNS = ("heading", "heading_est", "concentration", "flow_vx", "flow_vy",
                 "cmd_heading", "cmd_speed")
"""Recorded for traces (``cptbt run``) as well."""


class Recorder:
    """Rows of ``n`` vehicles, each with its own count.

    Args:
        n: vehicles.
        capacity: rows to preallocate per vehicle.
        trace: record the :data:`TRACE_COLUMNS` too.
    """

    def __init__(self, n: int, capacity: int, trace: bool = False) -> None:
        self.n = n
        self.trace = trace
        self.count = np.zeros(n, dtype=np.int64)
        cap = max(int(capacity), 8)
        columns = PATH_COLUMNS + (TRACE_COLUMNS if trace else ())
        # np.empty: the pages of rows never written (vehicles that end early) are never
        # touched, so they cost no memory; readers stop at each vehicle's count, and add()
        # writes NaN into the columns a row does not give.
        self.floats: dict[str, NDArray[np.float64]] = {
            c: np.empty((n, cap)) for c in columns
        }
        self.detected = np.zeros((n, cap), dtype=bool)
        self.active = np.zeros((n, cap), dtype=np.int16)
        self.phase = np.zeros((n, cap), dtype=np.int16)
        self.names: list[str] = [""]
        self.phases: list[str] = [""]
        self._codes: dict[str, int] = {"": 0}
        self._phase_codes: dict[str, int] = {"": 0}

    @property
    def capacity(self) -> int:
        """Rows available per vehicle before the arrays grow."""
        return self.detected.shape[1]

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
        for col, a in self.floats.items():
            a[idx, rows] = values.get(col, np.nan)
        self.detected[idx, rows] = detected
        self.active[idx, rows] = active
        self.phase[idx, rows] = phase
        self.count[idx] = rows + 1

    def _grow(self) -> None:
        def wider(a: NDArray[Any], fill: Any) -> NDArray[Any]:
            out = np.full((a.shape[0], 2 * a.shape[1]), fill, dtype=a.dtype)
            out[:, : a.shape[1]] = a
            return out

        def wider_lazy(a: NDArray[np.float64]) -> NDArray[np.float64]:
            out = np.empty((a.shape[0], 2 * a.shape[1]))
            out[:, : a.shape[1]] = a
            return out

        self.floats = {c: wider_lazy(a) for c, a in self.floats.items()}
        self.detected = wider(self.detected, False)
        self.active = wider(self.active, 0)
        self.phase = wider(self.phase, 0)

    # -- reading ----------------------------------------------------------------------------
    def column(self, name: str, i: int) -> NDArray[Any]:
        """Vehicle ``i``'s recorded values of one column (a view)."""
        k = int(self.count[i])
        if name == "detected":
            return self.detected[i, :k]
        return self.floats[name][i, :k]

    def xy(self, i: int, estimated: bool = False) -> NDArray[np.float64]:
        """Vehicle ``i``'s track, (k, 2): true, or as navigation estimated it."""
        x, y = ("x_est", "y_est") if estimated else ("x", "y")
        return np.column_stack([self.column(x, i), self.column(y, i)])

    def active_names(self, i: int) -> list[str]:
        """Vehicle ``i``'s active behaviour per row ('' for none)."""
        return [self.names[c] for c in self.active[i, : int(self.count[i])]]

    def time_in(self, i: int, period_s: float, where: NDArray[np.bool_] | None = None
                ) -> dict[str, float]:
        """Seconds vehicle ``i`` spent in each behaviour ('none' for no output)."""
        codes = self.active[i, : int(self.count[i])]
        if where is not None:
            codes = codes[where]
        counts = np.bincount(codes, minlength=len(self.names))
        return {(self.names[c] or "none"): float(n) * period_s for c, n in enumerate(counts) if n}

    def table(self, i: int, extra: Sequence[str] = ()) -> dict[str, Any]:
        """Vehicle ``i``'s rows as columns (numpy arrays; names as strings), for Parquet/CSV."""
        k = int(self.count[i])
        out: dict[str, Any] = {c: a[i, :k].copy() for c, a in self.floats.items()}
        out["detected"] = self.detected[i, :k].copy()
        out["active"] = self.active_names(i)
        if "phase" in extra:
            out["phase"] = [self.phases[c] for c in self.phase[i, :k]]
        return out
