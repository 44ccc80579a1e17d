"""What both ends of the MAVLink link agree on: modes, named values, frames, datagram parsing.

Shared by the AMP's adapter (:mod:`cptbt.bridge.mavlink_link`) and the simulated front seat
(:mod:`cptbt.batch.frontseat_mavlink`), so the two cannot drift apart. Needs ``pymavlink``
(the ``mavlink`` extra); the messages are those of the ``ardupilotmega`` MAVLink 2 dialect,
which includes ``common``.

Frames (the mission's, :mod:`cptbt.frames` and :mod:`cptbt.geodesy`): a mission with a geodetic
anchor (``frame: geodetic``, or ``op_area.geodetic_centre_deg``) is flown in latitude/longitude —
positions come from ``GLOBAL_POSITION_INT`` and set-points go out as
``SET_POSITION_TARGET_GLOBAL_INT``; a mission without one is flown in the vehicle's local NED
frame — ``LOCAL_POSITION_NED`` and ``SET_POSITION_TARGET_LOCAL_NED`` — and the vehicle's EKF
origin must then be the mission's N-E origin (the OpArea centre). Headings on the wire are compass
headings (ArduPilot's yaw, ``hdg``); the planning frame's are rotated by the OpArea's bearing.
Velocities on the wire are NED; the AMP's are planning-frame.
"""

from __future__ import annotations

import math
from collections import Counter
from typing import Any

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from cptbt.frames import PlanningFrame
from cptbt.geodesy import LocalFrame
from cptbt.link import VehicleMode
from cptbt.mission import MissionBase
from cptbt.types import Point

# -- ArduSub's flight modes (ArduSub/mode.h, ``Mode::Number``): HEARTBEAT.custom_mode ----------
STABILIZE, ACRO, ALT_HOLD, AUTO, GUIDED, CIRCLE, SURFACE, POSHOLD, MANUAL = (
    0, 1, 2, 3, 4, 7, 9, 16, 19)
MODE_NAMES = {STABILIZE: "STABILIZE", ACRO: "ACRO", ALT_HOLD: "ALT_HOLD", AUTO: "AUTO",
              GUIDED: "GUIDED", CIRCLE: "CIRCLE", SURFACE: "SURFACE", POSHOLD: "POSHOLD",
              MANUAL: "MANUAL"}

# -- the named values (NAMED_VALUE_FLOAT.name, at most 10 characters) ---------------------------
CONCENTRATION = "CPT_CONC"
"""One fluorometer sample (the sensor's units); ``time_boot_ms`` is the sample's time."""
FLOW_N = "CPT_FLOW_N"
"""Flow over ground, north component, m/s (sent with :data:`FLOW_E` at the same time_boot_ms)."""
FLOW_E = "CPT_FLOW_E"
"""Flow over ground, east component, m/s."""
REFUSED = "cptbt refused: "
"""STATUSTEXT prefix with which the front-seat double says it ignored a set-point (a real
ArduSub drops an unusable set-point silently; then only its own command timeout tells)."""

MAX_DATAGRAM = 8192
"""Datagrams larger than this many bytes are ignored (and counted as ``oversized``)."""

RESTART_GAP_S = 60.0
"""A ``time_boot_ms`` this far (in seconds) below the last one means the vehicle rebooted, not
a late packet."""

AMP_SYSTEM, AMP_COMPONENT = 1, mavlink.MAV_COMP_ID_ONBOARD_COMPUTER
"""The AMP speaks as a companion computer on the vehicle's own system id."""

VEHICLE_SYSTEM, VEHICLE_COMPONENT = 1, mavlink.MAV_COMP_ID_AUTOPILOT1

ARMED = mavlink.MAV_MODE_FLAG_SAFETY_ARMED
CUSTOM = mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED

# Set-point type mask: position, velocity and yaw used; acceleration and yaw rate ignored.
# ArduSub's GUIDED then runs its position-velocity controller (``guided_set_destination_posvel``):
# the target moves from the given position at the given velocity, at the given depth.
TYPE_MASK_POSVEL_YAW = (mavlink.POSITION_TARGET_TYPEMASK_AX_IGNORE
                        | mavlink.POSITION_TARGET_TYPEMASK_AY_IGNORE
                        | mavlink.POSITION_TARGET_TYPEMASK_AZ_IGNORE
                        | mavlink.POSITION_TARGET_TYPEMASK_YAW_RATE_IGNORE)


def vehicle_mode(custom_mode: int | None, base_mode: int, mission_state: int | None,
                 begun: bool = True) -> VehicleMode:
    """The AMP's reading of the vehicle's mode.

    ``MISSION_CURRENT.mission_state`` COMPLETE is ``post_mission``; disarmed before that is
    ``pre_launch``, and so is armed in a pilot's mode (neither AUTO nor GUIDED) while the
    mission has not ``begun``: the launch is the vehicle starting its mission, and a pilot
    driving it off the dock in MANUAL had counted as launched, so that ``amp_enable_s`` later
    the AMP switched it to GUIDED out of the pilot's hands (a review). ``begun`` is the link's
    (:class:`~cptbt.bridge.mavlink_link.MavlinkLink`): the mission running (ACTIVE or PAUSED,
    or armed in AUTO) heard since the link opened, or a waypoint reached (MISSION_CURRENT seq
    of 2 or more). Not the mission state alone: ArduSub stops its mission whenever it leaves
    AUTO, and a stopped mission reads NOT_STARTED, so a pilot mid-mission read as the dock (a
    diff review: a serve restarted then took the vehicle over once the pilot gave AUTO back).
    GUIDED is ``override``; AUTO with the mission PAUSED is ``returning`` (the vehicle transits
    back to the break-off point before resuming, as the REMUS does; a vehicle that resumes at
    once is simply ``mission``); any other armed mode is the vehicle flying on its own,
    ``mission`` (a pilot's mode once the mission has begun too: the AMP cannot tell a pilot
    from a failsafe there). Left: a serve started while a pilot drives a vehicle that had
    reached no waypoint reads it at the dock.
    """
    if mission_state == mavlink.MISSION_STATE_COMPLETE:
        return "post_mission"
    if not base_mode & ARMED:
        return "pre_launch"
    if not begun and custom_mode not in (AUTO, GUIDED):
        return "pre_launch"
    if custom_mode == GUIDED:
        return "override"
    if custom_mode == AUTO and mission_state == mavlink.MISSION_STATE_PAUSED:
        return "returning"
    return "mission"


WIRE_MODES: dict[str, tuple[int, bool, int]] = {
    "pre_launch": (MANUAL, False, mavlink.MISSION_STATE_NOT_STARTED),
    "mission": (AUTO, True, mavlink.MISSION_STATE_ACTIVE),
    "override": (GUIDED, True, mavlink.MISSION_STATE_ACTIVE),
    "returning": (AUTO, True, mavlink.MISSION_STATE_PAUSED),
    "post_mission": (SURFACE, True, mavlink.MISSION_STATE_COMPLETE),
}
"""How the simulated vehicle shows each of its modes: (custom mode, armed, mission state)."""


class WireFrames:
    """The mission's frames as the wire needs them: planning ↔ geodetic or local NED.

    Args:
        mission: the mission whose OpArea and geodetic anchor define the frames.
    """

    def __init__(self, mission: MissionBase) -> None:
        self.plan: PlanningFrame = mission.op_area_geometry().frame
        self.local: LocalFrame | None = mission.local_frame()

    @property
    def geodetic(self) -> bool:
        """Whether positions travel as latitude/longitude (the mission has an anchor)."""
        return self.local is not None

    def xy_of_latlon(self, lat_deg: float, lon_deg: float) -> Point:
        """A geodetic position in the planning frame."""
        assert self.local is not None
        n, e = self.local.to_ne(lat_deg, lon_deg)
        return self.plan.ne_to_xy(n, e)

    def latlon_of_xy(self, x: float, y: float) -> tuple[float, float]:
        """A planning-frame point as (lat, lon)."""
        assert self.local is not None
        g = self.local.to_geodetic(*self.plan.xy_to_ne(x, y))
        return g.lat_deg, g.lon_deg

    def xy_of_ne(self, n: float, e: float) -> Point:
        """Local NED north/east metres in the planning frame."""
        return self.plan.ne_to_xy(n, e)

    def ne_of_xy(self, x: float, y: float) -> tuple[float, float]:
        """A planning-frame point as local north/east metres."""
        return self.plan.xy_to_ne(x, y)

    def vector_xy(self, vn: float, ve: float) -> tuple[float, float]:
        """A north/east vector (a velocity) in planning-frame components."""
        b = math.radians(self.plan.x_bearing_deg)
        return vn * math.cos(b) + ve * math.sin(b), -vn * math.sin(b) + ve * math.cos(b)

    def vector_ne(self, vx: float, vy: float) -> tuple[float, float]:
        """A planning-frame vector in north/east components."""
        b = math.radians(self.plan.x_bearing_deg)
        return vx * math.cos(b) - vy * math.sin(b), vx * math.sin(b) + vy * math.cos(b)

    def compass_deg(self, planning_deg: float) -> float:
        """Compass heading of a planning angle."""
        return self.plan.compass_deg(planning_deg)

    def planning_deg(self, compass_deg: float) -> float:
        """Planning angle of a compass heading."""
        return self.plan.planning_deg(compass_deg)


class DatagramParser:
    """MAVLink datagrams in, messages out, with a count of everything ignored.

    Every datagram is parsed on its own (a fresh parser state), so a truncated or corrupt
    datagram cannot swallow the start of the next one. ``counts``: ``received`` (datagrams),
    ``messages``, and per reason ignored: ``oversized`` (datagrams), ``malformed`` (bytes that are
    no valid MAVLink frame: bad CRC, truncated, garbage — one per datagram that had any),
    ``unknown_type`` (a message id outside the dialect).
    """

    def __init__(self, system: int, component: int) -> None:
        self.system, self.component = system, component
        self.counts: Counter[str] = Counter()

    def feed(self, datagram: bytes) -> list[Any]:
        """The valid MAVLink messages of one datagram, in order."""
        self.counts["received"] += 1
        if len(datagram) > MAX_DATAGRAM:
            self.counts["oversized"] += 1
            return []
        mav = mavlink.MAVLink(None, self.system, self.component)
        mav.robust_parsing = True
        try:
            msgs = mav.parse_buffer(datagram) or []
        except Exception:  # pymavlink raises on what it cannot frame; never let it through
            self.counts["malformed"] += 1
            return []
        out = []
        bad = False
        for m in msgs:
            kind = m.get_type()
            if kind == "BAD_DATA":
                bad = True
            elif kind == "UNKNOWN" or isinstance(m, mavlink.MAVLink_unknown):
                self.counts["unknown_type"] += 1
            else:
                out.append(m)
        if bad or (mav.buf_len() > 0 and not msgs):  # garbage, or a frame cut short
            self.counts["malformed"] += 1
        self.counts["messages"] += len(out)
        return out

    @property
    def ignored(self) -> int:
        """Datagrams or messages ignored, all reasons."""
        return sum(v for k, v in self.counts.items() if k not in ("received", "messages"))


def encoder(system: int, component: int) -> mavlink.MAVLink:
    """A MAVLink 2 packer for one sender (its own sequence numbers)."""
    return mavlink.MAVLink(None, system, component)
