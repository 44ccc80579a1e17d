"""The summary of a served run (``cptbt serve``): the same measures as ``cptbt run``.

:class:`AmpCycles` watches the session after every update and records each AMP cycle in a
:class:`cptbt.batch.recorder.Recorder` (through a :class:`cptbt.batch.engine.VehicleRun`), so
:func:`cptbt.batch.summary.summarise` computes t0–t3, T_F/T_T/T_D, D0–D3 and time in behaviours
exactly as for a simulated run. A real vehicle has no ground truth: the navigation estimate is
the only track (``x``/``y`` are the estimate too), and the verdict is given only when a true
source is known (a double flying the mission's ``environment:``); otherwise it is null.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from cptbt.batch.engine import VehicleRun, note_declarations
from cptbt.batch.outcome import Outcome, outcome_of
from cptbt.batch.phased import PhasedRun, phase_summary
from cptbt.batch.recorder import Recorder
from cptbt.batch.summary import summarise
from cptbt.bridge.serve import ServeResult
from cptbt.mission import MissionBase
from cptbt.phases import GIVE_BACK_TRIGGERS
from cptbt.session import AmpSession
from cptbt.types import Point


class AmpCycles:
    """A session observer that records every AMP cycle and the time spent in each phase."""

    def __init__(self, mission: MissionBase) -> None:
        self.mission = mission
        self.period = 1.0 / mission.cycle_hz
        self.rows = Recorder(1, math.ceil(mission.time_limit_s / self.period) + 4)
        self.run: VehicleRun | None = None
        self.phase_time: dict[str, float] = {}
        self.resumed_at: tuple[float, float] | None = None
        self.break_off: tuple[float, float] | None = None
        self._t_prev: float | None = None
        self._phase_prev = "pre_launch"
        self._one = np.zeros(1, dtype=np.intp)

    def __call__(self, session: AmpSession) -> None:
        """Record the cycle if the planner ticked; account the time in the phase."""
        s = session.state
        if s is None:
            return
        if self._t_prev is not None and s.t_s > self._t_prev:
            dt = s.t_s - self._t_prev
            self.phase_time[self._phase_prev] = self.phase_time.get(self._phase_prev, 0.0) + dt
        if self.break_off is None and session.in_override:
            self.break_off = (s.x_m, s.y_m)  # where the vehicle was at the take-over
        self._t_prev, self._phase_prev = s.t_s, session.phases.state
        if self.resumed_at is None and session.phases.state == "mission_a.resumed":
            self.resumed_at = (s.x_m, s.y_m)
        if not session.ticked or (not session.in_override and not self._ended_now(session)):
            return
        planner = session.planner
        if self.run is None:
            self.run = VehicleRun(planner, (s.x_m, s.y_m), self.rows, 0, self.period)
        p = planner.percept
        assert p is not None
        # on the planner's clock (the vehicle's, shifted by its steps back): a step back of
        # 100 s had given T_T -6.4 s and a behaviour -151% of the time (a review)
        values = {"t": p.t, "x": s.x_m, "y": s.y_m, "x_est": s.x_m, "y_est": s.y_m}
        self.rows.add(self._one, values, p.detected, self.rows.code(planner.active))
        if p.detected and self.run.t1 is None:
            self.run.t1 = p.t
        note_declarations(self.run, planner, p.t)

    @staticmethod
    def _ended_now(session: AmpSession) -> bool:
        tl = session.phases.timeline
        # the timeline is on the phase clock (AmpSession.fire_phase), the session's t not
        return (bool(tl) and tl[-1].trigger in GIVE_BACK_TRIGGERS
                and tl[-1].t_s == session.phase_now)


def served_summary(result: ServeResult, cycles: AmpCycles, mission: MissionBase,
                   source: Point | None) -> dict[str, Any]:
    """``summary.json`` of a served run: RunSummary's fields, ``phases`` and ``link``.

    Args:
        result: the runner's result.
        cycles: the observer that watched the run.
        mission: the mission flown.
        source: the true source if known (a simulated vehicle), else None (no verdict).
    """
    session = result.session
    planner = session.planner
    run = cycles.run or VehicleRun(planner, (math.nan, math.nan), cycles.rows, 0, cycles.period)
    end = next((c for c in session.phases.timeline if c.trigger in GIVE_BACK_TRIGGERS
                or (c.trigger == "mission_a_complete" and c.source.startswith("amp."))), None)
    if end is not None:
        run.outcome = outcome_of(end.trigger, planner.declared_source is not None)
        run.t_end = end.t_s  # on the planner's clock already (AmpSession.fire_phase)
    else:
        run.outcome = (Outcome.AMP_RUNNING if session.t_amp_start is not None
                       else Outcome.AMP_NOT_ENABLED)
        run.t_end = session.phase_now
    run.declared = planner.declared_source
    run.lost_contacts = planner.percept.lost_contacts if planner.percept else ()
    run.sensor_faults = planner.perception.faults()
    run.nonfinite_commands = planner.nonfinite_commands()
    # the session repairs an impossibly far fix before the planner sees it: counted there
    run.sensor_faults["rejected_fixes"] += session.rejected_fixes
    if cycles.rows.count[0]:
        run.start = (float(run.path_true[0, 0]), float(run.path_true[0, 1]))
    truth = source if source is not None else Point(math.nan, math.nan)
    summary = summarise(run, mission, truth, None, result.wall_s,
                        t0=session.t_amp_start or 0.0).to_dict()
    if source is None:
        summary |= {"success": None, "false_declaration": None, "error_m": None,
                    "true_source": None}
    phased = PhasedRun(
        amp=run, timeline=list(session.phases.timeline), t_amp_start=session.t_amp_start,
        break_off=cycles.break_off, resumed_at=cycles.resumed_at,
        end_phase=session.phases.state, t_end=session.phase_now, refusals=session.refusals,
        waypoints=[], time_in_phase_s=cycles.phase_time,
    )
    summary["phases"] = phase_summary(phased, mission)
    # What the AMP saw is all a served run knows of where the vehicle went: D0-D3 are measured
    # on that track, LBL jumps included (cptbt run measures them on the simulator's true one).
    summary["track"] = "navigation estimate (the vehicle's true track is not known here)"
    summary["link"] = {"stop_reason": result.stop_reason, "error": result.error,
                       "handed_back": result.handed_back, "heartbeats": result.heartbeats,
                       **result.link_stats}
    return summary

