"""The AMP's end of a MAVLink link (ArduSub-class vehicles) over UDP, with pymavlink.

The AMP is a companion computer (system 1, component ``MAV_COMP_ID_ONBOARD_COMPUTER``) that
drives the vehicle in GUIDED mode. Sources, read for this adapter:

* ArduSub flight modes and their numbers (HEARTBEAT ``custom_mode``): ``ArduSub/mode.h``
  (``Mode::Number``: STABILIZE 0, ALT_HOLD 2, AUTO 3, GUIDED 4, SURFACE 9, POSHOLD 16, MANUAL 19).
* Guided-mode set-points: ArduSub's ``GCS_Mavlink.cpp`` handles ``SET_POSITION_TARGET_LOCAL_NED``
  (frames LOCAL_NED/OFFSET/BODY; position, velocity or position+velocity, each with a yaw or yaw
  rate; acceleration is not supported) and ``SET_POSITION_TARGET_GLOBAL_INT`` (GUIDED, AUTO's
  NAV_GUIDED, or depth only in ALT_HOLD; its yaw fields are "for future use"), and drops them in
  any other mode. ``ArduSub/mode_guided.cpp``: the position-velocity controller times out after
  3 s without a new set-point (``GUIDED_POSVEL_TIMEOUT_MS``) — the AMP's 1 Hz cycle stays well
  inside. The type-mask bits are those of the ArduPilot developer pages "Copter/Rover Commands
  in Guided Mode" (ardupilot.org/dev/docs/copter-commands-in-guided-mode.html;
  POSITION_TARGET_TYPEMASK bits 1-3 position, 4-6 velocity, 7-9 acceleration, 11 yaw, 12 yaw
  rate: "ignore this field").
* Mode changes: ``COMMAND_LONG`` ``MAV_CMD_DO_SET_MODE`` (param1
  ``MAV_MODE_FLAG_CUSTOM_MODE_ENABLED``, param2 the custom mode), answered by ``COMMAND_ACK``
  (mavlink.io, common message set).
* Telemetry ArduSub streams: HEARTBEAT (1 Hz), GLOBAL_POSITION_INT and LOCAL_POSITION_NED
  (``SRn_POSITION``), ATTITUDE (``SRn_EXTRA1``), VFR_HUD (``SRn_EXTRA2``), MISSION_CURRENT
  (``SRn_EXT_STAT``); NAMED_VALUE_FLOAT carries any named float (a companion's sensor).

=========================  =====================================================================
MAVLink (vehicle → AMP)    read as
=========================  =====================================================================
HEARTBEAT                  mode (see :func:`cptbt.bridge.mavlink_wire.vehicle_mode`); the link
                           watchdog runs on it (:attr:`last_heard`)
GLOBAL_POSITION_INT        a :class:`~cptbt.link.VehicleState`: lat/lon → planning x/y, depth
                           = −relative_alt, heading = hdg (else ATTITUDE.yaw); missions with a
                           geodetic anchor
LOCAL_POSITION_NED         the same from north/east/down metres; missions without an anchor
ATTITUDE, VFR_HUD          heading (yaw) and through-water speed (VFR_HUD.airspeed: "vehicle
                           speed in form appropriate for vehicle type")
MISSION_CURRENT            waypoints reached (seq − 1; item 0 is home), mission state
NAMED_VALUE_FLOAT          ``CPT_CONC`` a concentration sample; ``CPT_FLOW_N``/``CPT_FLOW_E``
                           a flow-over-ground sample (same time_boot_ms)
COMMAND_ACK                DO_SET_MODE to GUIDED refused → every command until GUIDED is refused
STATUSTEXT                 ``cptbt refused: …`` → the last command refused
=========================  =====================================================================

=========================  =====================================================================
AMP → vehicle              when
=========================  =====================================================================
HEARTBEAT                  every cycle (type ONBOARD_CONTROLLER, autopilot INVALID)
COMMAND_LONG DO_SET_MODE   take control: GUIDED (the mode it was in is remembered); give back:
                           that mode again (AUTO if it was unknown or GUIDED already)
SET_POSITION_TARGET_*      each command: the latest fix as position, velocity = speed along the
                           compass heading (vz 0), z/alt = the depth, yaw = the heading
=========================  =====================================================================

Readings chosen: the vehicle's clock is ``time_boot_ms`` (millisecond resolution). A position
message older than one already handled is a late datagram and is dropped (counted ``late``),
unless it is older by :data:`~cptbt.bridge.mavlink_wire.RESTART_GAP_S` (a reboot). The vehicle
leaving GUIDED while the AMP holds control, without the AMP's give-back, is reported as an
:class:`~cptbt.link.OverrideEnded` with reason ``watchdog`` (the vehicle's failsafe, or its
pilot, took control back — the AMP cannot tell which and must stop either way), ``mission_end``
if the vehicle's mission is complete. UDP may lose a mode change: while the AMP wants control
and the vehicle is not in GUIDED (the take was lost, or refused), the take is sent again every
:data:`RETAKE_S` vehicle seconds; while the vehicle stays in GUIDED after a give-back, so is the
give-back.
"""

from __future__ import annotations

import logging
import math
import time
from typing import Any

from cptbt.bridge import mavlink_wire as mw
from cptbt.bridge.base import LinkURI
from cptbt.bridge.mavlink_wire import mavlink
from cptbt.bridge.udp import UdpEndpoint
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

log = logging.getLogger(__name__)

RETAKE_S = 2.0
"""A mode change the vehicle has not made (lost or refused) is asked again after this many
vehicle seconds."""

_RESULTS = {v: k for k, v in vars(mavlink).items()
            if k.startswith("MAV_RESULT_") and isinstance(v, int) and k != "MAV_RESULT_ENUM_END"}


class MavlinkLink:
    """A :class:`cptbt.link.VehicleLink` speaking MAVLink 2 over UDP to an ArduSub-class vehicle.

    Args:
        uri: ``mavlink:udp:HOST:PORT`` (send to the vehicle there) or ``mavlink:udpin:HOST:PORT``
            (listen there and answer the latest sender).
        mission: the mission (its frames place the wire's positions).
    """

    def __init__(self, uri: LinkURI, mission: MissionBase) -> None:
        self.uri = uri
        self.frames = mw.WireFrames(mission)
        if uri.transport == "udp":
            local = "127.0.0.1" if uri.host in ("127.0.0.1", "localhost") else "0.0.0.0"
            self.udp = UdpEndpoint((local, 0), (uri.host, uri.port))
        else:
            self.udp = UdpEndpoint((uri.host, uri.port))
        self.parser = mw.DatagramParser(mw.AMP_SYSTEM, mw.AMP_COMPONENT)
        self.mav = mw.encoder(mw.AMP_SYSTEM, mw.AMP_COMPONENT)
        self.counts: dict[str, int] = {"late": 0, "before_heartbeat": 0,
                                       "vehicle_heartbeats": 0, "other_system": 0,
                                       "acks_refused": 0, "mode_requests_repeated": 0}
        self.target = (mw.VEHICLE_SYSTEM, mw.VEHICLE_COMPONENT)
        self._last_heard: float | None = None
        self._boot0 = time.monotonic()
        # what the vehicle last said
        self._custom: int | None = None
        self._base = 0
        self._mission_state: int | None = None
        self._mission_seq = 0
        self._begun = False  # the vehicle's mission seen running, or a waypoint reached
        self._yaw_deg: float | None = None
        self._airspeed = math.nan
        self._t = 0.0
        self._t_nav: float | None = None
        self._xy: tuple[float, float] | None = None
        self._flow: dict[int, dict[str, float]] = {}
        # what the AMP asked
        self._want = False
        self._given = False
        self._previous_mode = mw.AUTO
        self._asked = False  # a take (GUIDED) sent since the AMP last wanted control
        self._heard_state = False  # a vehicle state has been passed on
        self._break_off: tuple[float, float] | None = None
        self._in_guided = False
        self._refused_take = ""
        self._asked_t = -math.inf
        self._last_cmd: HeadingSpeedCommand | None = None
        self._out: list[InMessage] = []

    # -- VehicleLink ------------------------------------------------------------------------
    def receive(self) -> list[InMessage]:
        """Every valid vehicle message waiting now, oldest first."""
        for datagram in self.udp.recv_all():
            for m in self.parser.feed(datagram):
                self._handle(m)
        self._ask_again()
        out, self._out = self._out, []
        return out

    def send(self, message: OutMessage) -> None:
        """Take control (GUIDED), give it back (the previous mode), or send a set-point."""
        if isinstance(message, OverrideRequest):
            self._want, self._given, self._refused_take = True, False, ""
            self._break_off = self._xy
            self._take()
        elif isinstance(message, OverrideRelease):
            if self._asked or self._in_guided:
                self._want, self._given = False, True
                self._set_mode(self._previous_mode)
            self._want = self._asked = False
        elif isinstance(message, HeadingSpeedCommand):
            self._last_cmd = message
            if self._refused_take and not self._in_guided:
                self._out.append(CommandRefused(self._t, message, self._refused_take))
            self._setpoint(message)

    # -- WireLink ---------------------------------------------------------------------------
    def heartbeat(self) -> None:
        """Send the AMP's heartbeat (a companion computer, no autopilot)."""
        self._send(self.mav.heartbeat_encode(mavlink.MAV_TYPE_ONBOARD_CONTROLLER,
                                             mavlink.MAV_AUTOPILOT_INVALID, 0, 0,
                                             mavlink.MAV_STATE_ACTIVE))

    def wait(self, timeout_s: float) -> None:
        """Block until a datagram arrives or ``timeout_s`` passes."""
        self.udp.wait(timeout_s)

    @property
    def last_heard(self) -> float | None:
        """Monotonic time of the vehicle's last HEARTBEAT (the link watchdog runs on it)."""
        return self._last_heard

    def stats(self) -> dict[str, int]:
        """Datagrams in and out, messages decoded, and every kind ignored."""
        out = dict(self.parser.counts) | self.counts
        out |= {"sent": self.udp.sent, "send_errors": self.udp.send_errors,
                "foreign": self.udp.foreign,
                "ignored": self.parser.ignored + self.counts["late"]
                + self.counts["other_system"]}
        return out

    def close(self) -> None:
        """Close the socket."""
        self.udp.close()

    # -- internals --------------------------------------------------------------------------
    def _send(self, msg: Any) -> None:
        if not self.udp.send(msg.pack(self.mav)):
            log.debug("mavlink: could not send to %s", self.udp.peer)

    def _boot_ms(self) -> int:
        return int((time.monotonic() - self._boot0) * 1000) & 0xFFFFFFFF

    def _set_mode(self, custom_mode: int) -> None:
        self._asked_t = self._t
        self._send(self.mav.command_long_encode(
            self.target[0], self.target[1], mavlink.MAV_CMD_DO_SET_MODE, 0,
            mw.CUSTOM, custom_mode, 0, 0, 0, 0, 0))

    def _take(self) -> None:
        """Ask for GUIDED, only from the vehicle's own mission (AUTO): a review's AMP took a
        vehicle out of a failsafe SURFACE, or from its pilot in MANUAL, mid-mission and dived it
        to ``amp_depth_m``. In another mode the take waits (asked again while the AMP wants it,
        :meth:`_ask_again`), and every command is refused saying why, so the session gives
        back after ``watchdog_s`` if the vehicle does not go back to its mission."""
        if self._custom != mw.AUTO and not self._in_guided:
            mode = (mw.MODE_NAMES.get(self._custom, str(self._custom))
                    if self._custom is not None else "an unknown mode")
            self._refused_take = (f"the vehicle is in {mode}, not its mission (AUTO): a pilot or "
                                  "a failsafe has it, and the AMP does not take it")
            return
        if not self._asked and not self._in_guided:
            self._previous_mode = mw.AUTO
        self._asked, self._refused_take = True, ""
        self._set_mode(mw.GUIDED)

    def _ask_again(self) -> None:
        """Repeat a mode change the vehicle has not made after :data:`RETAKE_S`."""
        if self._t - self._asked_t < RETAKE_S:
            return
        if self._want and not self._in_guided:
            self.counts["mode_requests_repeated"] += self._custom == mw.AUTO
            self._take()
        elif self._given and self._in_guided:
            self.counts["mode_requests_repeated"] += 1
            self._set_mode(self._previous_mode)

    def _setpoint(self, cmd: HeadingSpeedCommand) -> None:
        compass = self.frames.compass_deg(cmd.heading_deg)
        vn = cmd.speed_mps * math.cos(math.radians(compass))
        ve = cmd.speed_mps * math.sin(math.radians(compass))
        yaw = math.radians(compass if compass <= 180.0 else compass - 360.0)
        depth = cmd.depth_m if cmd.depth_m is not None and math.isfinite(cmd.depth_m) else 0.0
        x, y = self._xy if self._xy is not None else (0.0, 0.0)
        if self.frames.geodetic:
            lat, lon = self.frames.latlon_of_xy(x, y)
            msg = self.mav.set_position_target_global_int_encode(
                self._boot_ms(), self.target[0], self.target[1],
                mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, mw.TYPE_MASK_POSVEL_YAW,
                round(lat * 1e7), round(lon * 1e7), -depth, vn, ve, 0.0, 0, 0, 0, yaw, 0)
        else:
            n, e = self.frames.ne_of_xy(x, y)
            msg = self.mav.set_position_target_local_ned_encode(
                self._boot_ms(), self.target[0], self.target[1], mavlink.MAV_FRAME_LOCAL_NED,
                mw.TYPE_MASK_POSVEL_YAW, n, e, depth, vn, ve, 0.0, 0, 0, 0, yaw, 0)
        self._send(msg)

    def _handle(self, m: Any) -> None:
        if m.get_srcSystem() != self.target[0] or m.get_srcComponent() != self.target[1]:
            self.counts["other_system"] += 1  # e.g. a ground station, or our own echo
            return
        kind = m.get_type()
        if kind == "HEARTBEAT":
            self.counts["vehicle_heartbeats"] += 1
            self._last_heard = time.monotonic()
            self._custom, self._base = int(m.custom_mode), int(m.base_mode)
            self._mode_changed()
        elif kind == "MISSION_CURRENT":
            self._mission_seq = int(m.seq)
            self._mission_state = int(m.mission_state)
            self._mode_changed()
        elif kind == "ATTITUDE":
            self._yaw_deg = math.degrees(m.yaw) % 360.0
        elif kind == "VFR_HUD":
            self._airspeed = float(m.airspeed)
        elif kind == "GLOBAL_POSITION_INT" and self.frames.geodetic:
            hdg = None if m.hdg == 65535 else m.hdg / 100.0
            xy = self.frames.xy_of_latlon(m.lat / 1e7, m.lon / 1e7)
            self._nav(m.time_boot_ms, xy.x, xy.y, -m.relative_alt / 1000.0, hdg)
        elif kind == "LOCAL_POSITION_NED" and not self.frames.geodetic:
            xy = self.frames.xy_of_ne(m.x, m.y)
            self._nav(m.time_boot_ms, xy.x, xy.y, m.z, None)
        elif kind == "NAMED_VALUE_FLOAT":
            self._named(int(m.time_boot_ms), str(m.name), float(m.value))
        elif kind == "COMMAND_ACK" and m.command == mavlink.MAV_CMD_DO_SET_MODE:
            if m.result != mavlink.MAV_RESULT_ACCEPTED and self._want:
                self.counts["acks_refused"] += 1
                self._refused_take = ("the vehicle refused GUIDED ("
                                      f"{_RESULTS.get(int(m.result), m.result)})")
        elif kind == "STATUSTEXT" and str(m.text).startswith(mw.REFUSED) and self._last_cmd:
            self._out.append(CommandRefused(self._t, self._last_cmd,
                                            str(m.text)[len(mw.REFUSED):]))

    def _mode(self) -> str:
        if not self._begun:
            running = self._mission_state in (mavlink.MISSION_STATE_ACTIVE,
                                              mavlink.MISSION_STATE_PAUSED)
            self._begun = (running or self._mission_seq >= 2
                           or (self._custom == mw.AUTO and self._base & mw.ARMED != 0))
        return mw.vehicle_mode(self._custom, self._base, self._mission_state, self._begun)

    def _mode_changed(self) -> None:
        guided = self._custom == mw.GUIDED and self._mode() == "override"
        if guided and not self._in_guided:
            self._refused_take = ""
            if self._break_off is None:
                self._break_off = self._xy
        if self._in_guided and not guided:
            reason = ("released" if self._given else
                      "mission_end" if self._mode() == "post_mission" else "watchdog")
            self._want = self._given = self._asked = False
            b = self._break_off or self._xy or (math.nan, math.nan)
            self._out.append(OverrideEnded(self._t, reason, b))  # type: ignore[arg-type]
            self._break_off = None
        self._in_guided = guided

    def _nav(self, boot_ms: int, x: float, y: float, depth: float, hdg: float | None) -> None:
        t = boot_ms / 1000.0
        if self._t_nav is not None and self._t_nav - mw.RESTART_GAP_S < t < self._t_nav:
            self.counts["late"] += 1
            return
        self._t_nav = self._t = t
        self._xy = (x, y)
        if self._custom is None:
            # no HEARTBEAT yet: the mode is not known, and read as "disarmed" it said pre_launch,
            # which a session takes for the dock (a diff review: a restarted serve saw a
            # position before the first HEARTBEAT and took over a vehicle already under way)
            self.counts["before_heartbeat"] += 1
            return
        mode = self._mode()
        if not self._heard_state and mode == "pre_launch" and self._base & mw.ARMED:
            # (a field re-test: a serve restarted under a pilot, no waypoint reached yet, read
            # the vehicle at the dock and took over once the pilot gave AUTO back)
            log.warning("the vehicle is armed in %s when first heard: read as at the dock until "
                        "its mission starts; if it is already under way (a restarted serve), "
                        "the AMP would take it over amp_enable_s after AUTO: start serve before "
                        "arming", mw.MODE_NAMES.get(self._custom or 0, str(self._custom)))
        self._heard_state = True
        compass = hdg if hdg is not None else self._yaw_deg
        heading = self.frames.planning_deg(compass) if compass is not None else math.nan
        self._out.append(VehicleState(
            t_s=t, x_m=x, y_m=y, heading_deg=heading, speed_mps=self._airspeed, depth_m=depth,
            mode=mode,  # type: ignore[arg-type]
            waypoints_reached=max(0, self._mission_seq - 1)))

    def _named(self, boot_ms: int, name: str, value: float) -> None:
        t = boot_ms / 1000.0
        if name == mw.CONCENTRATION:
            self._out.append(ConcentrationSample(t, value))
        elif name in (mw.FLOW_N, mw.FLOW_E):
            pair = self._flow.setdefault(boot_ms, {})
            pair[name] = value
            if len(pair) == 2:
                del self._flow[boot_ms]
                vx, vy = self.frames.vector_xy(pair[mw.FLOW_N], pair[mw.FLOW_E])
                self._out.append(FlowSample(t, vx, vy))
            for k in [k for k in self._flow if k < boot_ms - 60_000]:
                del self._flow[k]  # a half pair whose other half was lost
