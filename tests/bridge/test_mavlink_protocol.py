"""The MAVLink mapping, one datagram at a time over loopback: what the simulated vehicle says, the
AMP's adapter reads back in the planning frame; what the AMP commands, the vehicle reads back;
nothing that arrives from the wire can raise."""

from __future__ import annotations

import math
import socket
from collections.abc import Iterator

import pytest
from wire_doubles import MISSIONS

from cptbt.batch.frontseat_mavlink import MavlinkCodec
from cptbt.bridge import LinkURIError, open_link
from cptbt.bridge import mavlink_wire as mw
from cptbt.bridge.base import parse_uri
from cptbt.bridge.mavlink_link import MavlinkLink
from cptbt.bridge.mavlink_wire import mavlink
from cptbt.link import (
    CommandRefused,
    ConcentrationSample,
    FlowSample,
    HeadingSpeedCommand,
    InMessage,
    OverrideEnded,
    OverrideRelease,
    OverrideRequest,
    VehicleState,
)
from cptbt.loader import load_mission, loads_mission
from cptbt.mission import MissionBase

MSN007 = load_mission(MISSIONS / "tro2006_msn007.yaml")
_TEXT = (MISSIONS / "tro2006_msn007.yaml").read_text(encoding="utf-8")
_ANCHOR = "  geodetic_centre_deg: [32.980725, -118.536875]"
assert _ANCHOR in _TEXT
LOCAL = loads_mission(_TEXT.replace(_ANCHOR, ""))  # N-E metres, no geodetic anchor


class Wire:
    """The adapter listening on loopback, and a socket standing in for the vehicle."""

    def __init__(self, mission: MissionBase, codec: MavlinkCodec) -> None:
        self.link = MavlinkLink(parse_uri("mavlink:udpin:127.0.0.1:0", listen=True), mission)
        self.codec = codec
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.bind(("127.0.0.1", 0))
        self.sock.settimeout(5.0)
        self._sent = 0

    def vehicle_says(self, *datagrams: bytes) -> list[InMessage]:
        for d in datagrams:
            self.sock.sendto(d, self.link.udp.address)
        out: list[InMessage] = []
        for _ in range(50):  # loopback delivers at once; the bound is for a loaded machine
            self.link.wait(0.1)
            out += self.link.receive()
            if self.link.parser.counts["received"] >= self.sent_total:
                break
        return out

    @property
    def sent_total(self) -> int:
        return self._sent

    def send(self, *messages: InMessage) -> list[InMessage]:
        data = self.codec.encode(list(messages))
        self._sent = self.link.parser.counts["received"] + len(data)
        return self.vehicle_says(*data)

    def raw(self, *datagrams: bytes) -> list[InMessage]:
        self._sent = self.link.parser.counts["received"] + len(datagrams)
        return self.vehicle_says(*datagrams)

    def amp_sent(self, datagrams: int) -> list:
        """What the AMP sent to the vehicle (that many datagrams), as the vehicle reads it."""
        out = []
        self.sock.settimeout(5.0 if datagrams else 0.2)
        try:
            for _ in range(max(datagrams, 1)):
                data, _ = self.sock.recvfrom(65535)
                out += self.codec.decode(data)
        except TimeoutError:
            assert not datagrams, "the AMP's datagram did not arrive"
        return out

    def close(self) -> None:
        self.link.close()
        self.sock.close()


@pytest.fixture(params=["geodetic", "local"])
def wire(request: pytest.FixtureRequest) -> Iterator[Wire]:
    mission = MSN007 if request.param == "geodetic" else LOCAL
    w = Wire(mission, MavlinkCodec(mission))
    yield w
    w.close()


def test_navigation_and_sensors_arrive_in_the_planning_frame(wire: Wire) -> None:
    assert wire.link.frames.geodetic == (wire.link.frames.local is not None)
    s = VehicleState(250.5, 61.3, -22.8, 137.25, 1.5, 3.0, "mission", 3)
    got = wire.send(s, ConcentrationSample(250.5, 0.42), FlowSample(250.0, 0.11, -0.04))
    nav = [m for m in got if isinstance(m, VehicleState)]
    assert len(nav) == 1
    n = nav[0]
    assert n.t_s == 250.5 and n.mode == "mission" and n.waypoints_reached == 3
    assert math.hypot(n.x_m - 61.3, n.y_m - -22.8) < 0.03  # 1e-7 degrees is about a centimetre
    assert abs(n.heading_deg - 137.25) < 0.011 and n.speed_mps == pytest.approx(1.5)
    assert n.depth_m == pytest.approx(3.0)
    assert [m for m in got if isinstance(m, ConcentrationSample)] == [
        ConcentrationSample(250.5, pytest.approx(0.42))]
    flow = [m for m in got if isinstance(m, FlowSample)]
    assert len(flow) == 1 and flow[0].t_s == 250.0
    assert (flow[0].vx_mps, flow[0].vy_mps) == (pytest.approx(0.11, abs=1e-6),
                                                pytest.approx(-0.04, abs=1e-6))


def test_a_late_position_is_dropped_not_taken_for_the_clock_stepping_back(wire: Wire) -> None:
    wire.send(VehicleState(300.0, 1.0, 2.0, 0.0, 1.5, 3.0, "mission", 0))
    late = wire.send(VehicleState(299.0, 1.0, 2.0, 0.0, 1.5, 3.0, "mission", 0))
    assert not [m for m in late if isinstance(m, VehicleState)]
    assert wire.link.stats()["late"] == 1
    reboot = wire.send(VehicleState(5.0, 1.0, 2.0, 0.0, 1.5, 3.0, "mission", 0))
    assert [m.t_s for m in reboot if isinstance(m, VehicleState)] == [5.0]


def test_a_command_reaches_the_vehicle_as_the_same_heading_speed_and_depth(wire: Wire) -> None:
    wire.send(VehicleState(10.0, 5.0, 5.0, 0.0, 1.5, 3.0, "mission", 0))
    for heading in (-170.0, -45.0, 0.0, 33.3, 179.0):
        wire.link.send(HeadingSpeedCommand(heading, 1.5, 4.0))
        (cmd,) = wire.amp_sent(1)
        assert isinstance(cmd, HeadingSpeedCommand)
        assert abs((cmd.heading_deg - heading + 180) % 360 - 180) < 1e-3
        assert cmd.speed_mps == pytest.approx(1.5, abs=1e-6)
        assert cmd.depth_m == pytest.approx(4.0, abs=1e-6)


def test_take_control_is_guided_and_giving_back_restores_the_mission() -> None:
    w = Wire(MSN007, MavlinkCodec(MSN007))
    try:
        w.send(VehicleState(10.0, 5.0, 5.0, 0.0, 1.5, 3.0, "mission", 0))  # AUTO
        w.link.send(OverrideRequest())
        w.link.send(OverrideRelease())
        raw = [w.sock.recvfrom(65535)[0] for _ in range(2)]
        parser = mw.DatagramParser(1, 1)
        sent = [(m.command, m.param2) for d in raw for m in parser.feed(d)
                if m.get_type() == "COMMAND_LONG"]
        assert sent == [(mavlink.MAV_CMD_DO_SET_MODE, mw.GUIDED),
                        (mavlink.MAV_CMD_DO_SET_MODE, mw.AUTO)]
    finally:
        w.close()


def test_a_vehicle_a_pilot_or_failsafe_has_is_not_taken() -> None:
    """A field re-test: at the take-over time the AMP took a vehicle out of a failsafe SURFACE
    (or from its pilot in MANUAL) mid-mission and dived it to amp_depth_m. The take waits for
    the vehicle's own mission (AUTO); meanwhile every command is refused saying why."""
    w = Wire(MSN007, MavlinkCodec(MSN007))
    try:
        w.send(VehicleState(10.0, 5.0, 5.0, 0.0, 1.5, 3.0, "mission", 2))  # AUTO, under way
        hb = w.codec.mav.heartbeat_encode(mavlink.MAV_TYPE_SUBMARINE,
                                          mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA,
                                          mw.CUSTOM | mw.ARMED, mw.SURFACE, 0).pack(w.codec.mav)
        w.raw(hb)  # a failsafe
        w.link.send(OverrideRequest())
        assert w.amp_sent(0) == []  # no mode change
        w.link.send(HeadingSpeedCommand(30.0, 1.5, 3.0))
        refused = [m for m in w.link.receive() if isinstance(m, CommandRefused)]
        assert refused and "in SURFACE, not its mission (AUTO)" in refused[0].reason
        w.amp_sent(0)  # (the set-point went out: the vehicle ignores it outside GUIDED)
        w.link.send(OverrideRelease())
        assert w.amp_sent(0) == []  # nothing to give back
    finally:
        w.close()


def test_leaving_guided_unasked_ends_the_override_as_the_watchdog() -> None:
    w = Wire(MSN007, MavlinkCodec(MSN007))
    try:
        w.send(VehicleState(10.0, 5.0, 5.0, 0.0, 1.5, 3.0, "mission", 0))
        w.link.send(OverrideRequest())
        got = w.send(VehicleState(11.0, 6.0, 5.0, 0.0, 1.5, 3.0, "override", 0))
        assert [m.mode for m in got if isinstance(m, VehicleState)] == ["override"]
        got = w.send(VehicleState(42.0, 9.0, 5.0, 0.0, 1.5, 3.0, "returning", 0))
        ended = [m for m in got if isinstance(m, OverrideEnded)]
        assert len(ended) == 1 and ended[0].reason == "watchdog"
        assert math.dist(ended[0].break_off, (5.0, 5.0)) < 0.03  # where the AMP took over
        assert [m.mode for m in got if isinstance(m, VehicleState)] == ["returning"]
    finally:
        w.close()


def test_a_refused_mode_change_refuses_the_commands_until_guided() -> None:
    w = Wire(MSN007, MavlinkCodec(MSN007, refuse_guided=True))
    try:
        w.send(VehicleState(10.0, 5.0, 5.0, 0.0, 1.5, 3.0, "mission", 0))
        w.link.send(OverrideRequest())
        assert w.amp_sent(1) == []  # the vehicle denied it
        got = w.send(VehicleState(11.0, 5.0, 5.0, 0.0, 1.5, 3.0, "mission", 0))  # carries the ack
        assert not [m for m in got if isinstance(m, CommandRefused)]
        w.link.send(HeadingSpeedCommand(10.0, 1.5, 3.0))
        refused = w.link.receive()
        assert len(refused) == 1 and isinstance(refused[0], CommandRefused)
        assert "refused GUIDED (MAV_RESULT_DENIED)" in refused[0].reason
        assert w.link.stats()["acks_refused"] == 1
    finally:
        w.close()


def test_garbage_is_ignored_and_counted_never_raised(wire: Wire) -> None:
    junk = [*MavlinkCodec.junk, b"", b"\xfd" * 300, b"\xfe\x09" + bytes(20),
            b"x" * (mw.MAX_DATAGRAM + 1)]
    assert wire.raw(*junk) == []
    stats = wire.link.stats()
    assert stats["oversized"] == 1 and stats["malformed"] >= len(MavlinkCodec.junk) - 1
    assert stats["ignored"] >= len(junk) - 2 and stats["messages"] == 0
    # and the link still works
    ok = wire.send(VehicleState(1.0, 0.0, 0.0, 0.0, 1.5, 3.0, "mission", 0))
    assert [m.t_s for m in ok if isinstance(m, VehicleState)] == [1.0]


def test_a_mavlink_link_needs_its_mission() -> None:
    with pytest.raises(LinkURIError, match="needs the mission"):
        open_link("mavlink:udp:127.0.0.1:14550")


@pytest.mark.parametrize("mode, custom, armed, state, begun", [
    ("pre_launch", mw.MANUAL, False, mavlink.MISSION_STATE_NOT_STARTED, False),
    ("mission", mw.AUTO, True, mavlink.MISSION_STATE_ACTIVE, True),
    # ArduSub stops its mission on leaving AUTO: a pilot mid-mission reads NOT_STARTED
    ("mission", mw.POSHOLD, True, mavlink.MISSION_STATE_NOT_STARTED, True),
    ("mission", mw.SURFACE, True, mavlink.MISSION_STATE_NOT_STARTED, True),
    # armed in a pilot's mode before the mission has begun: a pilot at the dock, no launch
    ("pre_launch", mw.POSHOLD, True, None, False),
    ("pre_launch", mw.MANUAL, True, mavlink.MISSION_STATE_NOT_STARTED, False),
    ("pre_launch", mw.STABILIZE, True, mavlink.MISSION_STATE_UNKNOWN, False),
    ("mission", mw.AUTO, True, None, False),
    ("mission", mw.AUTO, True, mavlink.MISSION_STATE_NOT_STARTED, False),
    ("override", mw.GUIDED, True, mavlink.MISSION_STATE_ACTIVE, True),
    ("returning", mw.AUTO, True, mavlink.MISSION_STATE_PAUSED, True),
    ("post_mission", mw.SURFACE, True, mavlink.MISSION_STATE_COMPLETE, True),
])
def test_the_mode_table(mode: str, custom: int, armed: bool, state: int | None,
                        begun: bool) -> None:
    assert mw.vehicle_mode(custom, mw.CUSTOM | (mw.ARMED if armed else 0), state,
                           begun) == mode
    if mode in mw.WIRE_MODES and (custom, armed, state) == mw.WIRE_MODES[mode]:
        assert begun or mode == "pre_launch"


def test_a_pilot_reads_at_the_dock_only_before_the_mission_has_begun(
        caplog: pytest.LogCaptureFixture) -> None:
    """A review: armed in MANUAL at the dock counted as the launch, and the AMP took the
    vehicle to GUIDED from its pilot amp_enable_s later. A diff review: reading a pilot's mode
    as the dock whenever the mission state said NOT_STARTED took ArduSub's mid-mission pilot
    (its mission stops on leaving AUTO) for the dock too, and a restarted serve took over."""
    def says(w: Wire, custom: int, state: int, seq: int) -> str:
        hb = w.codec.mav.heartbeat_encode(mavlink.MAV_TYPE_SUBMARINE,
                                          mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA,
                                          mw.CUSTOM | mw.ARMED, custom, mavlink.MAV_STATE_ACTIVE)
        cur = w.codec.mav.mission_current_encode(seq, 0, state, 0)
        w.raw(hb.pack(w.codec.mav) + cur.pack(w.codec.mav))
        return w.link._mode()

    dock = mavlink.MISSION_STATE_NOT_STARTED
    w = Wire(MSN007, MavlinkCodec(MSN007))
    try:
        assert says(w, mw.MANUAL, dock, 1) == "pre_launch"  # a pilot off the dock
        # armed when first heard: said (a serve restarted under a pilot would read the dock)
        w.codec._mode = "pre_launch"  # a position alone, no HEARTBEAT of the codec's own
        with caplog.at_level("WARNING", logger="cptbt.bridge.mavlink_link"):
            w.send(VehicleState(5.0, 1.0, 1.0, 0.0, 1.5, 0.0, "pre_launch", 0))
        assert "armed in MANUAL when first heard" in caplog.text
        assert says(w, mw.AUTO, mavlink.MISSION_STATE_ACTIVE, 1) == "mission"  # the launch
        assert says(w, mw.MANUAL, dock, 1) == "mission"  # a pilot (or failsafe) mid-mission
    finally:
        w.close()
    w = Wire(MSN007, MavlinkCodec(MSN007))  # a serve started while a pilot drives mid-mission
    try:
        assert says(w, mw.POSHOLD, dock, 3) == "mission"  # waypoints reached: under way
    finally:
        w.close()


def test_a_lost_take_or_give_is_asked_again() -> None:
    w = Wire(MSN007, MavlinkCodec(MSN007))
    try:
        w.send(VehicleState(10.0, 5.0, 5.0, 0.0, 1.5, 3.0, "mission", 0))
        w.link.send(OverrideRequest())
        w.sock.recvfrom(65535)  # the take is lost: the vehicle stays in AUTO
        w.send(VehicleState(11.0, 5.0, 5.0, 0.0, 1.5, 3.0, "mission", 0))
        assert w.amp_sent(0) == []  # not yet: within RETAKE_S
        w.send(VehicleState(12.5, 5.0, 5.0, 0.0, 1.5, 3.0, "mission", 0))
        assert w.amp_sent(1) == [OverrideRequest()]
        w.send(VehicleState(13.0, 5.0, 5.0, 0.0, 1.5, 3.0, "override", 0))
        w.link.send(OverrideRelease())
        w.sock.recvfrom(65535)  # the give is lost: the vehicle stays in GUIDED
        w.send(VehicleState(15.5, 5.0, 5.0, 0.0, 1.5, 3.0, "override", 0))
        assert w.amp_sent(1) == [OverrideRelease()]
        got = w.send(VehicleState(16.0, 5.0, 5.0, 0.0, 1.5, 3.0, "returning", 0))
        assert [m.reason for m in got if isinstance(m, OverrideEnded)] == ["released"]
        w.send(VehicleState(19.0, 5.0, 5.0, 0.0, 1.5, 3.0, "returning", 0))
        assert w.amp_sent(0) == []  # done: nothing more to ask
        assert w.link.stats()["mode_requests_repeated"] == 2
    finally:
        w.close()


def test_a_position_before_the_first_heartbeat_says_no_mode(wire: Wire) -> None:
    """A diff review: positions heard before the vehicle's first HEARTBEAT read as pre_launch
    (base mode 0: disarmed), which a restarted session took for the dock, and so it took over a
    vehicle already under way. They give no vehicle state until a HEARTBEAT says the mode."""
    wire.codec._mode = "mission"  # as if the HEARTBEAT had gone out before the AMP listened
    early = wire.send(VehicleState(5000.0, 1.0, 2.0, 0.0, 1.5, 3.0, "mission", 4))
    assert not [m for m in early if isinstance(m, VehicleState)]
    assert wire.link.stats()["before_heartbeat"] == 1
    heard = wire.raw(wire.codec.heartbeat(5000.5, "mission"))
    later = heard + wire.send(VehicleState(5001.0, 1.0, 2.0, 0.0, 1.5, 3.0, "mission", 4))
    assert [m.mode for m in later if isinstance(m, VehicleState)] == ["mission"]
