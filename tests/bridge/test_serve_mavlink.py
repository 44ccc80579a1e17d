"""Faults over MAVLink: the AMP served in real time against the simulated ArduSub front seat.

(The whole MSN007 mission over MAVLink flies in ``test_serve_mavlink_cli.py``, as a user runs it.)
To stay short, the faults are flown on MSN007 with the take-over 30 s after launch (not 240 s),
and the vehicle stops early (``max_time_s``): 120 s of vehicle time is 2.4 s of wall time at the
test clock scale.
"""

from __future__ import annotations

import pytest
from wire_doubles import CLOCK_SCALE, MISSIONS, double_running

from cptbt.batch.frontseat import WireFaults
from cptbt.batch.frontseat_mavlink import MavlinkCodec
from cptbt.bridge import open_link
from cptbt.bridge.serve import ServeOptions, ServeResult, serve
from cptbt.loader import loads_mission
from cptbt.mission import MissionBase
from cptbt.session import AmpSession


@pytest.fixture(scope="module")
def msn007() -> MissionBase:
    text = (MISSIONS / "tro2006_msn007.yaml").read_text(encoding="utf-8")
    assert "amp_enable_s: 240" in text
    return loads_mission(text.replace("amp_enable_s: 240", "amp_enable_s: 30"))


def _serve(mission: MissionBase, address: tuple[str, int], **kw) -> ServeResult:
    link = open_link(f"mavlink:udp:{address[0]}:{address[1]}", mission)
    try:
        return serve(mission, link, options=ServeOptions(clock_scale=CLOCK_SCALE,
                                                         connect_timeout_s=10,
                                                         max_wall_s=60, **kw.pop("opts", {})),
                     **kw)
    finally:
        link.close()


def triggers(result: ServeResult) -> list[str]:
    return [c.trigger for c in result.session.phases.timeline]


def test_dropped_delayed_and_junk_datagrams_are_survived_and_counted(msn007) -> None:
    codec = MavlinkCodec(msn007)
    faults = WireFaults(drop_to_amp=0.1, drop_from_amp=0.1, delay_p=0.1, delay_s=2.0,
                        junk_every=20, seed=3)
    with double_running(msn007, codec, faults=faults, max_time_s=120) as (a, report):
        result = _serve(msn007, a)
        vehicle = report()
    stats = result.link_stats
    assert vehicle.dropped > 50 and vehicle.delayed > 50 and vehicle.junk > 50
    assert stats["oversized"] > 25 and stats["malformed"] > 25  # counted, never raised
    assert stats["late"] > 25  # delayed positions dropped, not taken for a clock step back
    assert triggers(result)[:2] == ["launch", "amp_enable"]
    # the first HEARTBEAT says the dock; the lost take was not fatal
    assert codec.modes_shown[:3] == ["pre_launch", "mission", "override"]
    assert vehicle.commands_heard > 40 and "watchdog" not in vehicle.override_ended
    # The double stopped at 120 s: its heartbeat fell silent, and the AMP gave back.
    assert result.stop_reason == "link_lost" and result.handed_back
    assert triggers(result)[-1] == "amp_abort"


def test_a_silent_amp_loses_control_to_the_vehicle_watchdog(msn007) -> None:
    faults = WireFaults(silent_from_s=60.0)  # the vehicle stops hearing the AMP
    with double_running(msn007, MavlinkCodec(msn007), faults=faults,
                        max_time_s=120) as (a, report):
        result = _serve(msn007, a, opts={"until": "return_to_break_off"})
        vehicle = report()
    assert vehicle.override_ended == ["watchdog"]
    assert "watchdog_timeout" in triggers(result) and result.stop_reason == "given_back"
    t = next(c.t_s for c in result.session.phases.timeline if c.trigger == "watchdog_timeout")
    assert 89 <= t <= 92  # 30 s after the last command heard (just before 60 s)


def test_a_cut_link_is_lost_on_the_heartbeat_and_given_back_on_both_sides(msn007) -> None:
    faults = WireFaults(silent_from_s=60.0, silent_both=True)
    with double_running(msn007, MavlinkCodec(msn007), faults=faults,
                        max_time_s=100) as (a, report):
        result = _serve(msn007, a)
        vehicle = report()
    assert result.stop_reason == "link_lost" and result.handed_back
    assert triggers(result)[-1] == "amp_abort"
    assert vehicle.override_ended == ["watchdog"]  # the vehicle's own watchdog took over
    # one a vehicle second (and one per mode change) until 60 s, then none
    assert 55 <= result.link_stats["vehicle_heartbeats"] <= 65


def test_a_vehicle_that_refuses_every_command_ends_the_override(msn007) -> None:
    faults = WireFaults(refuse_speed_above_mps=1.0)  # the AMP commands 1.5 m/s
    with double_running(msn007, MavlinkCodec(msn007), faults=faults,
                        max_time_s=100) as (a, report):
        result = _serve(msn007, a, opts={"until": "return_to_break_off"})
        vehicle = report()
    assert vehicle.refusals > 20 and result.session.refusals == vehicle.refusals
    assert "command_refused" in triggers(result) and "watchdog_timeout" in triggers(result)
    assert vehicle.override_ended == ["watchdog"]


def test_a_vehicle_that_refuses_guided_never_flies_the_amp(msn007) -> None:
    codec = MavlinkCodec(msn007, refuse_guided=True)
    with double_running(msn007, codec, max_time_s=90) as (a, report):
        result = _serve(msn007, a)
        vehicle = report()
    assert "override" not in codec.modes_shown and vehicle.override_ended == []
    assert codec.counts()["set_mode_refused"] > 10  # asked again every 2 vehicle seconds
    assert result.session.refusals > 10 and "command_refused" in triggers(result)
    reason = next(c.detail for c in result.session.phases.timeline
                  if c.trigger == "command_refused")
    assert "refused GUIDED" in reason
    # never in override for watchdog_s: the AMP gives back as the vehicle's watchdog would,
    # rather than believe it drives (it sat in amp.override until the link was lost)
    (gave_back,) = [c for c in result.session.phases.timeline
                    if c.trigger == "watchdog_timeout"]
    assert gave_back.detail.startswith("the vehicle did not grant the override: mode mission")
    assert gave_back.t_s - result.session.t_amp_start == pytest.approx(
        msn007.mission_a.watchdog_s, abs=1.5)


def test_an_internal_error_hands_back_and_the_vehicle_restores_its_mode(msn007) -> None:
    def explode(session: AmpSession) -> None:
        if session.in_override and session.t > 60:
            raise RuntimeError("boom")

    codec = MavlinkCodec(msn007)
    with double_running(msn007, codec, max_time_s=100) as (a, report):
        result = _serve(msn007, a, observers=[explode])
        vehicle = report()
    assert result.stop_reason == "error" and result.handed_back
    assert "RuntimeError: boom" in result.error and triggers(result)[-1] == "amp_abort"
    assert vehicle.override_ended == ["released"]  # the mode change back reached the vehicle
    assert codec.modes_shown[:4] == ["pre_launch", "mission", "override", "returning"]
