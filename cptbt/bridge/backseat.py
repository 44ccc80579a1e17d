"""The backseat protocol: JSON lines over UDP between the AMP and a vehicle's front-seat computer.

Version 1. Every datagram holds one or more lines; every line is one JSON object with the
protocol version ``v`` (1), a message ``type`` and the sender's sequence number ``seq`` (an
integer that grows by one per message). Units are in the field names; positions and headings are
in the mission's planning frame (metres; degrees from +x toward +y), times on the vehicle's clock.
The JSON Schema is ``cptbt/bridge/schemas/backseat-v1.schema.json``; the README has the table.

=============  ==========  ===================================================================
type           direction   fields
=============  ==========  ===================================================================
``nav``        vehicle →   ``t_s x_m y_m heading_deg speed_mps`` [``depth_m``] ``mode``
                           ``waypoints_reached``
``sample``     vehicle →   ``t_s value`` (one fluorometer sample; a null value: none, a dropout)
``flow``       vehicle →   ``t_s vx_mps vy_mps`` (flow over ground; null: none)
``refused``    vehicle →   ``t_s heading_deg speed_mps`` [``depth_m``] ``reason``
``ended``      vehicle →   ``t_s reason`` (released/watchdog/mission_end) ``break_off_m``
``take``       → vehicle   (the AMP asks for the override)
``command``    → vehicle   ``heading_deg speed_mps`` [``depth_m``]
``give``       → vehicle   (the AMP gives control back)
``heartbeat``  both        [``t_s``] [``mode``]: "I am alive"; carries no command
=============  ==========  ===================================================================

A receiver ignores, and counts, every line it cannot use: not JSON, not an object, another
version, an unknown type, a missing or mistyped field, a non-finite number, a datagram larger
than :data:`MAX_DATAGRAM` bytes. It never raises on what arrives from the wire. A ``nav`` older
(by ``seq``) than one already handled is a delayed packet: it is dropped (and counted), so a late
datagram cannot look like the vehicle's clock stepping back. A ``seq`` that falls back by more
than :data:`SEQ_RESTART_GAP` is taken as the sender restarting, and so is a rising run of
:data:`RESTART_RUN` late navs whose clock is not behind the last nav's, or that counts from
:data:`RESTART_FROM` or less, :data:`RESTART_DROP` or more below the last (a backlog of delayed
navs, flushed in order, is neither).
"""

from __future__ import annotations

import json
import logging
import math
from collections import Counter
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Any, get_args

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
    VehicleMode,
    VehicleState,
)

VERSION = 1
"""The protocol version this module speaks."""

log = logging.getLogger(__name__)

MAX_DATAGRAM = 8192
"""Datagrams larger than this many bytes are ignored (and counted as ``oversized``)."""

SEQ_RESTART_GAP = 1000
"""A ``seq`` this far below the last one means the sender restarted, not a late packet."""
RESTART_RUN = 5
"""This many navs in a row below the last one, each above the one before, also mean the sender
restarted, when its clock is not behind the last nav's, or it counts from a small number
(:data:`RESTART_FROM`) far below the last (:data:`RESTART_DROP`): a backlog of delayed navs
flushed in order (a serial or radio buffer) rises too, but from near the last count and on older
times (a review's 10-s backlog had been taken for a restart, and the AMP had steered by a
10-s-old fix)."""
RESTART_FROM = 100
"""A rising run of late navs that starts at or below this ``seq``, at least :data:`RESTART_DROP`
below the last, is a count started again (its clock restarted with it)."""
RESTART_DROP = 200
"""How far below the last ``seq`` a run from :data:`RESTART_FROM` must start to be a restart: a
backlog flushed early in a mission also counts from a small number, but from near the last (a
diff review's 60..79 after 80, 10 Hz, had been taken for a restart). A sender restarted within
its first 200 navs is heard again once its count passes the old one."""

MODES: tuple[str, ...] = get_args(VehicleMode)
END_REASONS = ("released", "watchdog", "mission_end")


@dataclass(frozen=True, slots=True)
class Heartbeat:
    """A sign of life (either direction); the vehicle's carries its clock and mode."""

    t_s: float | None = None
    mode: str | None = None


class ProtocolError(ValueError):
    """One line that is not a valid message; ``kind`` names the counter it goes to."""

    def __init__(self, kind: str, detail: str) -> None:
        super().__init__(f"{kind}: {detail}")
        self.kind = kind


# -- encoding ---------------------------------------------------------------------------------
def _finite(x: float | None) -> float | None:
    if x is None:
        return None
    return float(x) if math.isfinite(x) else None


def to_data(msg: InMessage | OutMessage | Heartbeat) -> dict[str, Any]:
    """A message as a protocol object (without ``v`` and ``seq``)."""
    if isinstance(msg, VehicleState):
        return {"type": "nav", "t_s": msg.t_s, "x_m": msg.x_m, "y_m": msg.y_m,
                "heading_deg": msg.heading_deg, "speed_mps": msg.speed_mps,
                "depth_m": _finite(msg.depth_m), "mode": msg.mode,
                "waypoints_reached": msg.waypoints_reached}
    if isinstance(msg, ConcentrationSample):  # no reading (NaN): null, a dropout
        return {"type": "sample", "t_s": msg.t_s, "value": _finite(msg.value)}
    if isinstance(msg, FlowSample):
        return {"type": "flow", "t_s": msg.t_s, "vx_mps": _finite(msg.vx_mps),
                "vy_mps": _finite(msg.vy_mps)}
    if isinstance(msg, CommandRefused):
        c = msg.command
        return {"type": "refused", "t_s": msg.t_s, "heading_deg": c.heading_deg,
                "speed_mps": c.speed_mps, "depth_m": _finite(c.depth_m), "reason": msg.reason}
    if isinstance(msg, OverrideEnded):
        return {"type": "ended", "t_s": msg.t_s, "reason": msg.reason,
                "break_off_m": list(msg.break_off)}
    if isinstance(msg, HeadingSpeedCommand):
        return {"type": "command", "heading_deg": msg.heading_deg, "speed_mps": msg.speed_mps,
                "depth_m": _finite(msg.depth_m)}
    if isinstance(msg, OverrideRequest):
        return {"type": "take"}
    if isinstance(msg, OverrideRelease):
        return {"type": "give"}
    if isinstance(msg, Heartbeat):
        out: dict[str, Any] = {"type": "heartbeat"}
        if msg.t_s is not None:
            out["t_s"] = msg.t_s
        if msg.mode is not None:
            out["mode"] = msg.mode
        return out
    raise TypeError(f"not a protocol message: {msg!r}")


def encode(msg: InMessage | OutMessage | Heartbeat, seq: int) -> bytes:
    """One message as one line (UTF-8, ``\\n``-terminated).

    Non-finite numbers cannot be written in JSON: an optional field becomes null; a required one
    is an error (the sender must not send it).
    """
    data = {"v": VERSION, "seq": seq, **to_data(msg)}
    return (json.dumps(data, allow_nan=False, separators=(",", ":")) + "\n").encode("utf-8")


# -- decoding ---------------------------------------------------------------------------------
def _reject_constant(name: str) -> Any:
    raise ProtocolError("malformed", f"non-finite number {name}")


def _num(d: dict[str, Any], key: str, optional: bool = False) -> Any:
    v = d.get(key)
    if v is None and optional:
        return None
    return _number(v, d.get("type"), key)


def _number(v: Any, kind: Any, key: str) -> float:
    """A JSON number as a finite float, else a ProtocolError naming the message and key."""
    if isinstance(v, bool) or not isinstance(v, int | float):
        raise ProtocolError("invalid", f"{kind}: {key} must be a number")
    # A literal beyond the float range (1e400 reads as inf, a 400-digit integer overflows):
    # a non-finite number as NaN/Infinity are (a review: such fields had been decoded).
    try:
        f = float(v)
    except OverflowError:
        f = math.inf
    if not math.isfinite(f):
        raise ProtocolError("malformed", f"{kind}: non-finite number {key}")
    return f


def _reading(d: dict[str, Any], key: str) -> float:
    """A sensor reading: a number, or null for none (a dropout: NaN, which the planner drops
    and counts, ``missing_samples`` or ``rejected_flow_samples``; a field review's NaN values
    had been ignored as malformed lines, and counted nowhere the summary shows). The key must
    be there."""
    if key not in d:
        raise ProtocolError("invalid", f"{d.get('type')}: {key} must be a number or null")
    v = _num(d, key, optional=True)
    return math.nan if v is None else float(v)


def _int(d: dict[str, Any], key: str) -> int:
    v = d.get(key)
    if isinstance(v, bool) or not isinstance(v, int) or v < 0:
        raise ProtocolError("invalid", f"{d.get('type')}: {key} must be an integer >= 0")
    return v


def _choice(d: dict[str, Any], key: str, allowed: Sequence[str]) -> str:
    v = d.get(key)
    if v not in allowed:
        raise ProtocolError("invalid", f"{d.get('type')}: {key} must be one of {list(allowed)}")
    return str(v)


def parse_line(line: bytes | str) -> tuple[int, InMessage | OutMessage | Heartbeat]:
    """One line as ``(seq, message)``.

    Raises:
        ProtocolError: the line is not a valid version-1 message (``kind`` says why:
            ``malformed``, ``version``, ``unknown_type`` or ``invalid``).
    """
    try:
        d = json.loads(line, parse_constant=_reject_constant)
    except ProtocolError:
        raise
    except (ValueError, UnicodeDecodeError, RecursionError) as exc:
        raise ProtocolError("malformed", str(exc)[:80]) from None
    if not isinstance(d, dict):
        raise ProtocolError("malformed", "not a JSON object")
    if d.get("v") != VERSION or isinstance(d.get("v"), bool):  # true == 1 in Python
        raise ProtocolError("version", f"version {d.get('v')!r}, this side speaks {VERSION}")
    seq = _int(d, "seq")
    kind = d.get("type")
    msg: InMessage | OutMessage | Heartbeat
    if kind == "nav":
        msg = VehicleState(
            t_s=_num(d, "t_s"), x_m=_num(d, "x_m"), y_m=_num(d, "y_m"),
            heading_deg=_num(d, "heading_deg"), speed_mps=_num(d, "speed_mps"),
            depth_m=_num(d, "depth_m", optional=True),
            mode=_choice(d, "mode", MODES),  # type: ignore[arg-type]
            waypoints_reached=_int(d, "waypoints_reached"),
        )
    elif kind == "sample":  # a null value is the sensor's dropout, counted by the planner
        msg = ConcentrationSample(_num(d, "t_s"), _reading(d, "value"))
    elif kind == "flow":
        msg = FlowSample(_num(d, "t_s"), _reading(d, "vx_mps"), _reading(d, "vy_mps"))
    elif kind == "refused":
        cmd = HeadingSpeedCommand(_num(d, "heading_deg"), _num(d, "speed_mps"),
                                  _num(d, "depth_m", optional=True))
        reason = d.get("reason")
        if not isinstance(reason, str):
            raise ProtocolError("invalid", "refused: reason must be a string")
        msg = CommandRefused(_num(d, "t_s"), cmd, reason)
    elif kind == "ended":
        b = d.get("break_off_m")
        if not (isinstance(b, list) and len(b) == 2):
            raise ProtocolError("invalid", "ended: break_off_m must be [x, y]")
        # each through _num's checks: a 400-digit integer had raised OverflowError out of
        # the decoder and ended a served mission (an attacker's), and 1e400 read as inf
        xy = [_number(v, "ended", f"break_off_m[{i}]") for i, v in enumerate(b)]
        msg = OverrideEnded(_num(d, "t_s"),
                            _choice(d, "reason", END_REASONS),  # type: ignore[arg-type]
                            (float(xy[0]), float(xy[1])))
    elif kind == "command":
        msg = HeadingSpeedCommand(_num(d, "heading_deg"), _num(d, "speed_mps"),
                                  _num(d, "depth_m", optional=True))
    elif kind == "take":
        msg = OverrideRequest()
    elif kind == "give":
        msg = OverrideRelease()
    elif kind == "heartbeat":
        mode = d.get("mode")
        msg = Heartbeat(_num(d, "t_s", optional=True), mode if isinstance(mode, str) else None)
    else:
        raise ProtocolError("unknown_type", f"type {kind!r}")
    return seq, msg


class Decoder:
    """Datagrams in, messages out, with a count of everything ignored.

    Attributes:
        counts: ``received`` (datagrams), ``messages``, and one counter per reason a datagram or
            line was ignored (``oversized``, ``malformed``, ``version``, ``unknown_type``,
            ``invalid``, ``late``), and ``restarts`` (the vehicle's nav count restarted).
        last_problem: the latest reason text (for logs).
    """

    def __init__(self) -> None:
        self.counts: Counter[str] = Counter()
        self.last_problem = ""
        self._last_nav_seq: int | None = None
        self._late_seq: int | None = None  # the latest nav taken as late, ...
        self._late_run = 0  # ... how many rising such in a row, ...
        self._late_from = 0  # ... the seq the run began at
        self._last_nav_t = -math.inf  # the time stamp of the latest nav handled

    @property
    def ignored(self) -> int:
        """Lines or datagrams ignored, all reasons."""
        return sum(v for k, v in self.counts.items()
                   if k not in ("received", "messages", "restarts"))

    def feed(self, datagram: bytes) -> list[InMessage | OutMessage | Heartbeat]:
        """The messages of one datagram, in order."""
        self.counts["received"] += 1
        if len(datagram) > MAX_DATAGRAM:
            self._problem("oversized", f"{len(datagram)} bytes")
            return []
        out: list[InMessage | OutMessage | Heartbeat] = []
        for line in datagram.splitlines():
            if not line.strip():
                continue
            try:
                seq, msg = parse_line(line)
            except ProtocolError as exc:
                self._problem(exc.kind, str(exc))
                continue
            if isinstance(msg, VehicleState) and not self._fresh_nav(seq, msg.t_s):
                self._problem("late", f"nav seq {seq} after {self._last_nav_seq}")
                continue
            self.counts["messages"] += 1
            out.append(msg)
        return out

    def _fresh_nav(self, seq: int, t: float) -> bool:
        last = self._last_nav_seq
        if last is not None and last - SEQ_RESTART_GAP < seq <= last:
            # late, unless it is the RESTART_RUN-th of a rising run of such that counts from a
            # small number or runs on the clock: a sender that restarted its count (all its
            # navs were dropped as late until the old count came round again, and the AMP's
            # clock froze); delayed packets scattered among fresh ones make no run, and a
            # backlog flushed in order rises from near the last count on older times
            rising = self._late_seq is not None and seq > self._late_seq
            self._late_run = self._late_run + 1 if rising else 1
            if not rising:
                self._late_from = seq
            self._late_seq = seq
            anew = t >= self._last_nav_t or (self._late_from <= RESTART_FROM
                                              and last - self._late_from >= RESTART_DROP)
            if self._late_run < RESTART_RUN or not anew:
                return False
            self.counts["restarts"] += 1
            log.warning("backseat: the vehicle's nav seq restarted (%d after %d)", seq, last)
        self._late_seq, self._late_run = None, 0
        self._last_nav_seq = seq
        self._last_nav_t = t
        return True

    def _problem(self, kind: str, detail: str) -> None:
        self.counts[kind] += 1
        self.last_problem = detail
        # the 1st, 10th, 100th... of each kind said (a review's vehicle sent navs without a
        # field: 1 971 were dropped, the run ended "link_lost", and nothing said why)
        n = self.counts[kind]
        loud = kind != "late" and n == 10 ** int(math.log10(n) + 1e-9)
        log.log(logging.WARNING if loud else logging.DEBUG,
                "backseat: line ignored (%s, %d so far): %s", kind, n, detail)


def pack(lines: Iterable[bytes], limit: int = MAX_DATAGRAM) -> list[bytes]:
    """Lines gathered into as few datagrams as fit under ``limit`` bytes each."""
    out: list[bytes] = []
    buf = b""
    for line in lines:
        if buf and len(buf) + len(line) > limit:
            out.append(buf)
            buf = b""
        buf += line
    if buf:
        out.append(buf)
    return out
