"""The vehicle's side of the MAVLink link: the simulated REMUS executive dressed as ArduSub.

Plugs into :class:`cptbt.batch.frontseat.FrontSeatDouble` (which flies :mod:`cptbt.sim` and
injects the wire faults) as a :class:`~cptbt.batch.frontseat.Codec`; the message mapping is the
adapter's (:mod:`cptbt.bridge.mavlink_link`), the constants and frames are shared
(:mod:`cptbt.bridge.mavlink_wire`).

Every vehicle step goes out as one datagram: ATTITUDE, VFR_HUD, GLOBAL_POSITION_INT (missions with
a geodetic anchor) or LOCAL_POSITION_NED (without), and the step's named values; a HEARTBEAT and
MISSION_CURRENT precede it whenever the mode changes, and go out once a vehicle second anyway.
The executive's modes show as ArduSub modes (:data:`~cptbt.bridge.mavlink_wire.WIRE_MODES`):
Mission A is AUTO, the override GUIDED, the transit back to the break-off point AUTO with the
mission PAUSED, the end SURFACE with the mission COMPLETE.

From the AMP: ``DO_SET_MODE`` to GUIDED is the override request (acknowledged; DENIED when
``refuse_guided``), to any other mode the release; a ``SET_POSITION_TARGET_GLOBAL_INT`` or
``_LOCAL_NED`` is a heading/speed/depth command — the double flies the velocity's direction
(the yaw if the velocity is zero) and magnitude from wherever it is, at the set-point's depth.
A command the executive refuses is said in a STATUSTEXT (``cptbt refused: …``).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

from cptbt.bridge import mavlink_wire as mw
from cptbt.bridge.mavlink_wire import mavlink
from cptbt.link import (
    CommandRefused,
    ConcentrationSample,
    FlowSample,
    HeadingSpeedCommand,
    InMessage,
    OutMessage,
    OverrideEnded,
    OverrideRelease,
    OverrideRequest,
    VehicleState,
)
from cptbt.mission import MissionBase


def _junk() -> tuple[bytes, ...]:
    """Malformed datagrams for ``WireFaults.junk_every``: garbage, a frame with a bad CRC, a
    frame cut short, a message id outside the dialect, and JSON sent to the wrong port."""
    mav = mw.encoder(mw.VEHICLE_SYSTEM, mw.VEHICLE_COMPONENT)
    good = mav.named_value_float_encode(1, mw.CONCENTRATION.encode(), 99.0).pack(mav)
    bad_crc = bytearray(good)
    bad_crc[-1] ^= 0xFF
    unknown = bytearray(good)
    unknown[7:10] = (60000).to_bytes(3, "little")  # msgid nobody defines (CRC then fails too)
    return (b"\xff\xfe\x00garbage\n", bytes(bad_crc), good[:9], bytes(unknown),
            b'{"v":1,"seq":1,"type":"nav"}\n', bytes(range(256)))


class MavlinkCodec:
    """ArduSub's side of the MAVLink link for the front-seat double.

    Args:
        mission: the mission (its frames place positions on the wire).
        refuse_guided: answer every mode change to GUIDED with MAV_RESULT_DENIED (a vehicle that
            will not hand over control).
    """

    junk: Sequence[bytes] = _junk()

    def __init__(self, mission: MissionBase, refuse_guided: bool = False) -> None:
        self.frames = mw.WireFrames(mission)
        self.refuse_guided = refuse_guided
        self.parser = mw.DatagramParser(mw.VEHICLE_SYSTEM, mw.VEHICLE_COMPONENT)
        self.mav = mw.encoder(mw.VEHICLE_SYSTEM, mw.VEHICLE_COMPONENT)
        self.modes_shown: list[str] = []
        # none said yet: the first state goes out with a HEARTBEAT, as an ArduSub's 1-Hz one
        # precedes its positions (the AMP takes no position before a HEARTBEAT's mode)
        self._mode: str | None = None
        self._reached = 0
        self._pending: list[bytes] = []
        self._extra: dict[str, int] = {"set_mode_refused": 0, "setpoints": 0}

    # -- Codec ------------------------------------------------------------------------------
    def decode(self, datagram: bytes) -> list[OutMessage]:
        """The AMP's mode changes and set-points; its heartbeats only show it is alive."""
        out: list[OutMessage] = []
        for m in self.parser.feed(datagram):
            kind = m.get_type()
            if kind == "COMMAND_LONG" and m.command == mavlink.MAV_CMD_DO_SET_MODE:
                out += self._set_mode(int(m.param2))
            elif kind == "SET_MODE":
                out += self._set_mode(int(m.custom_mode))
            elif kind == "SET_POSITION_TARGET_GLOBAL_INT":
                out.append(self._command(m.vx, m.vy, m.yaw, m.type_mask, -m.alt))
            elif kind == "SET_POSITION_TARGET_LOCAL_NED":
                out.append(self._command(m.vx, m.vy, m.yaw, m.type_mask, m.z))
        return out

    def encode(self, messages: Sequence[InMessage]) -> list[bytes]:
        """One datagram with the step's messages (acks and a mode change first)."""
        parts, self._pending = self._pending, []
        for m in messages:
            if isinstance(m, VehicleState):
                self._reached = m.waypoints_reached
                if m.mode != self._mode:
                    self._mode = m.mode
                    self.modes_shown.append(m.mode)
                    parts.append(self.heartbeat(m.t_s, m.mode))
                parts += self._nav(m)
            elif isinstance(m, ConcentrationSample):
                parts.append(self._named(m.t_s, mw.CONCENTRATION, m.value))
            elif isinstance(m, FlowSample):
                vn, ve = self.frames.vector_ne(m.vx_mps, m.vy_mps)
                parts += [self._named(m.t_s, mw.FLOW_N, vn), self._named(m.t_s, mw.FLOW_E, ve)]
            elif isinstance(m, CommandRefused):
                parts.append(self._text(mavlink.MAV_SEVERITY_WARNING, mw.REFUSED + m.reason))
            elif isinstance(m, OverrideEnded):
                parts.append(self._text(mavlink.MAV_SEVERITY_NOTICE,
                                        f"cptbt override ended: {m.reason}"))
        return [b"".join(parts)] if parts else []

    def heartbeat(self, t_s: float, mode: str) -> bytes:
        """HEARTBEAT (an ArduSub) and MISSION_CURRENT, one datagram's worth of bytes."""
        custom, armed, state = mw.WIRE_MODES[mode]
        base = mw.CUSTOM | (mw.ARMED if armed else 0)
        hb = self.mav.heartbeat_encode(mavlink.MAV_TYPE_SUBMARINE,
                                       mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA, base, custom,
                                       mavlink.MAV_STATE_ACTIVE)
        cur = self.mav.mission_current_encode(self._reached + 1, 0, state, 0)
        return hb.pack(self.mav) + cur.pack(self.mav)

    def counts(self) -> dict[str, int]:
        """The parser's counters and the set-points and refused mode changes."""
        return dict(self.parser.counts) | self._extra

    # -- internals --------------------------------------------------------------------------
    def _set_mode(self, custom: int) -> list[OutMessage]:
        if custom == mw.GUIDED and self.refuse_guided:
            self._extra["set_mode_refused"] += 1
            self._ack(mavlink.MAV_RESULT_DENIED)
            return []
        self._ack(mavlink.MAV_RESULT_ACCEPTED)
        return [OverrideRequest() if custom == mw.GUIDED else OverrideRelease()]

    def _ack(self, result: int) -> None:
        ack = self.mav.command_ack_encode(mavlink.MAV_CMD_DO_SET_MODE, result, 0, 0, 0, 0)
        self._pending.append(ack.pack(self.mav))

    def _command(self, vn: float, ve: float, yaw: float, mask: int, depth: float
                 ) -> HeadingSpeedCommand:
        self._extra["setpoints"] += 1
        speed = math.hypot(vn, ve)
        if speed > 1e-6:
            compass = math.degrees(math.atan2(ve, vn))
        elif not mask & mavlink.POSITION_TARGET_TYPEMASK_YAW_IGNORE:
            compass = math.degrees(yaw)
        else:
            compass = math.nan
        return HeadingSpeedCommand(self.frames.planning_deg(compass), speed,
                                   depth if math.isfinite(depth) else None)

    def _nav(self, s: VehicleState) -> list[bytes]:
        compass = self.frames.compass_deg(s.heading_deg) if math.isfinite(s.heading_deg) else 0.0
        yaw = math.radians(compass if compass <= 180.0 else compass - 360.0)
        ms = _ms(s.t_s)
        depth = s.depth_m if s.depth_m is not None else 0.0
        speed = s.speed_mps if math.isfinite(s.speed_mps) else 0.0
        vn, ve = (speed * math.cos(math.radians(compass)), speed * math.sin(math.radians(compass)))
        out: list[Any] = [
            self.mav.attitude_encode(ms, 0.0, 0.0, yaw, 0.0, 0.0, 0.0),
            self.mav.vfr_hud_encode(speed, speed, round(compass) % 360, 0, -depth, 0.0),
        ]
        if self.frames.geodetic:
            lat, lon = self.frames.latlon_of_xy(s.x_m, s.y_m)
            out.append(self.mav.global_position_int_encode(
                ms, round(lat * 1e7), round(lon * 1e7), round(-depth * 1000),
                round(-depth * 1000), round(vn * 100), round(ve * 100), 0,
                round(compass * 100) % 36000))
        else:
            n, e = self.frames.ne_of_xy(s.x_m, s.y_m)
            out.append(self.mav.local_position_ned_encode(ms, n, e, depth, vn, ve, 0.0))
        return [m.pack(self.mav) for m in out]

    def _named(self, t_s: float, name: str, value: float) -> bytes:
        return self.mav.named_value_float_encode(_ms(t_s), name.encode(), value).pack(self.mav)

    def _text(self, severity: int, text: str) -> bytes:
        return self.mav.statustext_encode(severity, text[:50].encode(), 0, 0).pack(self.mav)


def _ms(t_s: float) -> int:
    """The vehicle clock as ``time_boot_ms``."""
    return max(0, round(t_s * 1000.0)) & 0xFFFFFFFF
