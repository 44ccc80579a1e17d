"""The simulated vehicle's report (``cptbt frontseat --report``) says where an interrupted
flight stopped (a field review's, stopped after ``--silent-from``, read "pre_launch at t 0.0 s"
beside a break-off mid-area)."""

from __future__ import annotations

from pathlib import Path

import pytest

from cptbt.batch.frontseat import BackseatCodec, FrontSeatDouble
from cptbt.loader import load_mission

ROOT = Path(__file__).resolve().parents[2]


def test_an_interrupted_flight_reports_where_it_stopped() -> None:
    mission = load_mission(ROOT / "missions/tro2006_msn007.yaml")
    double = FrontSeatDouble(mission, BackseatCodec(), wait_for_amp=False, clock_scale=1e9)
    step, calls = double.vehicle.step, []

    def interrupted():  # type: ignore[no-untyped-def]
        calls.append(1)
        if len(calls) > 500:  # Ctrl-C (or SIGTERM) mid-mission
            raise KeyboardInterrupt
        return step()

    double.vehicle.step = interrupted  # type: ignore[method-assign]
    with pytest.raises(KeyboardInterrupt):
        double.run()
    report = double.report
    assert report.t_end > 50.0 and report.mode == double.vehicle.mode != "pre_launch", report
