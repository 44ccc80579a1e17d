"""The recorder's memory savings read back every value exactly as a plain per-vehicle store.

The :class:`~cptbt.batch.recorder.Recorder` keeps one shared time per row index, does not store
the estimate columns while they equal the truth, nor phases while all are 0, and maps its
arrays page by page. A naive reference (a Python list of rows per vehicle, what the recorder
used to hold in full arrays) is fed the same random rows — shared and diverging times, scalar
and array times, estimates equal to the truth and then not, phases, growth past the capacity —
and every column, track, name and table must come back bit for bit.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest

from cptbt.batch.engine import simulate
from cptbt.batch.recorder import (
    MAX_PREALLOCATED_ROWS,
    PATH_COLUMNS,
    TRACE_COLUMNS,
    Recorder,
    lazy_zeros,
)
from cptbt.batch.scenario import to_sim_params
from cptbt.cli.inspect_cmds import load

MISSIONS = Path(__file__).resolve().parents[2] / "missions"


class Reference:
    """Every row of every vehicle as written: the behaviour the recorder must keep."""

    def __init__(self, n: int, trace: bool) -> None:
        self.columns = PATH_COLUMNS + (TRACE_COLUMNS if trace else ())
        self.rows: list[list[dict[str, Any]]] = [[] for _ in range(n)]

    def add(self, idx: np.ndarray, values: dict[str, Any], detected: Any, active: Any,
            phase: int) -> None:
        for j, i in enumerate(idx):
            row = {c: float(np.broadcast_to(values.get(c, np.nan), idx.shape)[j])
                   for c in self.columns}
            row["detected"] = bool(np.broadcast_to(detected, idx.shape)[j])
            row["active"] = int(np.broadcast_to(active, idx.shape)[j])
            row["phase"] = phase
            self.rows[i].append(row)

    def column(self, name: str, i: int) -> np.ndarray:
        dtype = bool if name == "detected" else float
        return np.array([r[name] for r in self.rows[i]], dtype=dtype)


def _bits(a: np.ndarray) -> bytes:
    return np.ascontiguousarray(a).tobytes()


def _check(rec: Recorder, ref: Reference) -> None:
    for i, rows in enumerate(ref.rows):
        assert rec.count[i] == len(rows)
        for c in (*ref.columns, "detected"):
            assert _bits(rec.column(c, i)) == _bits(ref.column(c, i)), (i, c)
        for est in (False, True):
            x, y = ("x_est", "y_est") if est else ("x", "y")
            want = np.column_stack([ref.column(x, i), ref.column(y, i)])
            assert _bits(rec.xy(i, estimated=est)) == _bits(want)
        assert rec.active_names(i) == [rec.names[r["active"]] for r in rows]
        table = rec.table(i, extra=("phase",))
        assert list(table) == [*ref.columns, "detected", "active", "phase"]
        assert table["phase"] == [rec.phases[r["phase"]] for r in rows]
        for c in ref.columns:
            assert _bits(table[c]) == _bits(ref.column(c, i))


@pytest.mark.parametrize("seed", range(12))
def test_recorder_reads_back_what_a_plain_store_holds(seed: int) -> None:
    rng = np.random.default_rng(seed)
    n = int(rng.integers(1, 7))
    trace = bool(rng.integers(2))
    rec, ref = Recorder(n, capacity=int(rng.integers(1, 12)), trace=trace), Reference(n, trace)
    codes = [rec.code(None), rec.code("a.b"), rec.code("c.d")]
    phases = [0, rec.phase_code("mission_a"), rec.phase_code("amp")]
    alive = np.arange(n)
    diverge_t, diverge_est = int(rng.integers(0, 40)), int(rng.integers(0, 40))
    for k in range(int(rng.integers(1, 40))):
        if len(alive) == 0:
            break
        if rng.random() < 0.1:  # some vehicles end, as in the batch engine
            alive = alive[rng.random(len(alive)) < 0.7]
            continue
        idx = alive if rng.random() < 0.9 else alive[rng.random(len(alive)) < 0.5]
        m = len(idx)
        x = rng.normal(size=m)
        t: Any = k * 0.1
        if k >= diverge_t:  # a row index with another time: t becomes a column per vehicle
            t = k * 0.1 + rng.normal(size=m) if rng.random() < 0.5 else k * 0.1 + rng.random()
        x_est = x if k < diverge_est else x + rng.normal(size=m) * (rng.random(m) < 0.5)
        values: dict[str, Any] = {"t": t, "x": x, "y": -x, "x_est": x_est, "y_est": -x_est}
        if rng.random() < 0.2:  # 0.0 against -0.0: equal, but not the same bits
            x[0] = 0.0
            values["x_est"] = np.where(np.arange(m) == 0, -0.0, values["x_est"])
        if trace:
            values["heading"] = rng.uniform(0, 360, m)
            values["heading_est"] = values["heading"] if rng.random() < 0.8 else 3.0
            if rng.random() < 0.5:
                values["concentration"] = rng.random(m)
        detected = rng.random(m) < 0.3
        active = np.array(codes, dtype=np.int16)[rng.integers(0, 3, m)]
        phase = int(rng.choice(phases)) if rng.random() < 0.2 else 0
        rec.add(idx, values, detected, active, phase)
        ref.add(idx, values, detected, active, phase)
    _check(rec, ref)


def test_shared_and_aliased_views_are_read_only() -> None:
    rec = Recorder(2, capacity=4)
    rec.add(np.array([0, 1]), {"t": 0.0, "x": 1.0, "y": 2.0, "x_est": 1.0, "y_est": 2.0})
    for view in (rec.column("t", 0), rec.column("x_est", 1)):
        with pytest.raises(ValueError):
            view[0] = 5.0
    assert rec.column("x", 0).flags.writeable


def test_a_week_long_run_does_not_preallocate_a_week_of_rows() -> None:
    # A 7-day limit at 100 Hz asked for 6e7 rows up front (480 MB of shared times alone); the
    # preallocation is capped and the arrays grow as rows come.
    rec = Recorder(3, capacity=60_480_004)
    assert rec.capacity == MAX_PREALLOCATED_ROWS
    assert rec.allocated_bytes() < 64 * MAX_PREALLOCATED_ROWS * 8


def test_lazy_zeros_are_zero_and_writable() -> None:
    a = lazy_zeros((3, 5000), np.int16)
    assert a.shape == (3, 5000) and a.dtype == np.int16 and not a.any()
    a[2, 4999] = 7
    assert a.sum() == 7


def test_the_batch_engine_shares_times_and_skips_perfect_estimates() -> None:
    """AB's navigation has no error: a batch stores one time per row and no estimates."""
    mission = load(str(MISSIONS / "ab2001_strategy3.yaml"), simulate=True)
    params = to_sim_params(mission, None)
    starts = [(60.0 + 3 * k, -20.0 + 5 * k, 0.0) for k in range(9)]
    runs, _, _ = simulate(mission, params, starts, time_limit_s=5.0)
    rec = runs[0].recorder
    assert rec.t_shared is not None and set(rec.floats) == {"x", "y"} and rec.phase is None
    assert np.array_equal(runs[3].path_est, runs[3].path_true)
    assert runs[3].path_t[-1] == pytest.approx(5.0) and len(runs[3].path_t) == 51
