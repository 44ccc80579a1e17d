"""Doubles and helpers for the over-the-wire tests (loopback only, every wait bounded)."""

from __future__ import annotations

import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from cptbt.batch.frontseat import Codec, FrontSeatDouble, FrontSeatReport, WireFaults
from cptbt.mission import MissionBase

MISSIONS = Path(__file__).resolve().parents[2] / "missions"
CLOCK_SCALE = 50.0
"""Vehicle seconds per wall second in the wire tests: MSN007 (1424 s) flies in ~30 s; the
vehicle's 30 s watchdog is then 0.6 s of wall time, enough margin on a loaded CI machine."""


@contextmanager
def double_running(mission: MissionBase, codec: Codec, *, faults: WireFaults | None = None,
                   max_time_s: float | None = None, **kw: Any
                   ) -> Iterator[tuple[tuple[str, int], Callable[[], FrontSeatReport]]]:
    """A front-seat double flying in a thread; yields its address and a way to get its report."""
    double = FrontSeatDouble(mission, codec, clock_scale=CLOCK_SCALE, faults=faults, **kw)
    stop = threading.Event()
    box: dict[str, FrontSeatReport] = {}
    thread = threading.Thread(
        target=lambda: box.setdefault("r", double.run(max_time_s, stop, connect_timeout_s=10)),
        daemon=True)
    thread.start()

    def report() -> FrontSeatReport:
        thread.join(timeout=60)
        assert not thread.is_alive(), "the double did not stop"
        return box["r"]

    try:
        yield double.address, report
    finally:
        stop.set()
        thread.join(timeout=60)
