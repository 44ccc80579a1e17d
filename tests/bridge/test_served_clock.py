"""A served run's measures on the planner's clock: a vehicle clock stepped back gives no
negative time (a review: T_T -6.4 s, a behaviour's share -151%)."""

from __future__ import annotations

from pathlib import Path

from cptbt.batch.served import AmpCycles, served_summary
from cptbt.bridge.serve import ServeResult
from cptbt.link import ConcentrationSample, FlowSample, OverrideEnded, VehicleState
from cptbt.loader import load_mission
from cptbt.planner import Planner
from cptbt.session import AmpSession

ROOT = Path(__file__).resolve().parents[2]


class Link:
    def __init__(self) -> None:
        self.inbox: list[object] = []

    def receive(self) -> list[object]:
        out, self.inbox = self.inbox, []
        return out

    def send(self, message: object) -> None:
        pass


def _served():  # type: ignore[no-untyped-def]
    """MSN007 served through the scripted link: the mission, link, session, cycle observer,
    and ``report(t, mode, conc)``, one vehicle report (navigation, flow, a sample) handled."""
    mission = load_mission(ROOT / "missions" / "tro2006_msn007.yaml")  # take-over at 240 s
    link = Link()
    session = AmpSession(mission, Planner(mission), link)
    cycles = AmpCycles(mission)

    def report(t: float, mode: str, conc: float = 0.0) -> None:
        link.inbox += [VehicleState(t, -60.0 + 0.01 * t, 10.0, 180.0, 1.5, 3.0, mode, 1),
                       FlowSample(t, 0.1, 0.0), ConcentrationSample(t, conc)]
        session.update()
        cycles(session)

    return mission, link, session, cycles, report


def test_a_clock_stepped_back_gives_no_negative_time() -> None:
    mission, _, session, cycles, report = _served()

    report(0.0, "pre_launch")
    for k in range(1, 2410):  # to 241 s, in Mission A, then the take-over
        report(k / 10, "mission")
    assert session.in_override
    for k in range(2410, 3000):  # detections from 250 s: t1 there
        report(k / 10, "override", conc=1.0 if k >= 2500 else 0.0)
    for k in range(2000, 2600):  # the vehicle clock steps back 100 s at 300 s
        report(k / 10, "override")
    summary = served_summary(ServeResult(session, "stopped"), cycles, mission, None)
    assert summary["t1"] is not None and summary["t1"] >= summary["t0"]
    assert summary["T_F"] >= 0 and summary["sim_time_s"] >= summary["t0"]
    assert all(v >= 0 for v in summary["time_in_behaviour_s"].values())
    assert summary["clock_corrections"] >= 1


def test_the_phase_timeline_keeps_the_planners_clock_across_a_step_back() -> None:
    """A field review: a vehicle clock stepped back 100 s, and the timeline gave back "declared
    and home" 58 s before the declaration's t3; the phases are now stamped on the planner's
    clock, as t0-t3 are, so the timeline never runs backwards and gives back after t3."""
    mission, link, session, cycles, report = _served()

    report(0.0, "pre_launch")
    for k in range(1, 2410):
        report(k / 10, "mission")
    assert session.in_override
    for k in range(2410, 3000):
        report(k / 10, "override")
    for k in range(2000, 2100):  # the vehicle clock steps back 100 s at 300 s ...
        report(k / 10, "override")
    link.inbox.append(OverrideEnded(210.0, "watchdog", (0.0, 0.0)))  # ... then the vehicle
    session.update()  # takes control back
    cycles(session)
    times = [c.t_s for c in session.phases.timeline]
    assert times == sorted(times), times
    assert times[-1] >= 300.0  # after the step: the planner's clock, not the vehicle's 210 s
    # and the summary reads the end once, on that clock (a diff review: converted twice, the
    # end read 410 s and the AMP's 70 s read 170 s)
    for t in (211.0, 212.0):  # the vehicle returns to its break-off ...
        report(t, "returning")
    for t in (12.0, 13.0):  # ... its clock steps back 200 s more, and it resumes its mission
        report(t, "mission")
    times = [c.t_s for c in session.phases.timeline]
    # after the give-back too, when the planner no longer cycles (an attacker's 700-s step
    # back had the timeline run backwards there)
    assert times == sorted(times) and times[-1] >= 312.0, times
    assert [c.trigger for c in session.phases.timeline][-2:] == [
        "vehicle_returning", "break_off_reached"]
    summary = served_summary(ServeResult(session, "stopped"), cycles, mission, None)
    assert summary["phases"]["run_time_s"] >= times[-1]
    assert summary["sim_time_s"] == times[-3] == 310.0
    assert summary["T_total"] == summary["sim_time_s"] - summary["t0"] == 70.0
    assert abs(sum(summary["time_in_behaviour_s"].values()) - 70.0) <= 1.0


def test_a_clock_step_before_the_take_leaves_the_override_its_own_length() -> None:
    """A diff review: with the vehicle's clock stepped back 100 s during Mission A (or
    restarted at the launch, which the session supports), a corrected phase clock stood still
    through the override and a 30-s override read T_total 99.8 s. Until the take the timeline
    reads the vehicle's clock as it is, as t0 does."""
    mission, link, session, cycles, report = _served()

    report(0.0, "pre_launch")
    for k in range(1, 1000):  # 100 s of Mission A ...
        report(k / 10, "mission")
    k = 0
    while not session.in_override:  # ... then the clock steps back 100 s: the take 140 s later
        report(k / 10, "mission")
        k += 1
    take = session.t
    for j in range(1, 301):  # a 30-s override, then the vehicle takes control back
        report(take + j / 10, "override")
    link.inbox.append(OverrideEnded(take + 30.0, "watchdog", (0.0, 0.0)))
    session.update()
    cycles(session)
    summary = served_summary(ServeResult(session, "stopped"), cycles, mission, None)
    assert abs(summary["T_total"] - 30.0) < 0.5, summary["T_total"]
    assert summary["phases"]["time_in_phase_s"]["amp.override"] > 29.0
