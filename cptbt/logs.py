"""Cycle logs: every planning cycle of a run in an MCAP file that Foxglove opens (``cptbt[logs]``).

Channels (message encoding ``json``, schema encoding ``jsonschema``, log time = the vehicle's
clock, kept non-decreasing):

- ``/cptbt/mission`` — once: the mission (normalised YAML), where the run came from, the version,
  and (``start_xy``) the move-to-field goal the planner was given when it was not the mission's
  start (a batch study's start point).
- ``/cptbt/cycle`` — one per planner tick: the phase, the planner's inputs since the previous tick
  (``inputs``: ``["s", t, value]`` samples, ``["f", t, vx, vy]`` flow samples, ``["p", x, y,
  heading]`` poses, in the order they were given), the percept (with the flow estimate), the
  active behaviour, the command, the declared source and the planner's blackboard keys.
- ``/cptbt/phase`` — one per phase change.

Numbers are written with Python's shortest round-trip repr, and non-finite ones as the strings
``"nan"``, ``"inf"``, ``"-inf"`` (JSON has no such numbers), so the inputs read back bit for bit:
:mod:`cptbt.replay` feeds them to a fresh planner and compares.
"""

from __future__ import annotations

import dataclasses
import io
import json
import math
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, BinaryIO

import py_trees

from cptbt.loader import dump_mission
from cptbt.mission import MissionBase
from cptbt.planner import Planner
from cptbt.session import AmpSession
from cptbt.types import Command, Point

PROFILE = "cptbt"
TOPICS = ("/cptbt/mission", "/cptbt/cycle", "/cptbt/phase")

_NUM: dict[str, Any] = {"type": ["number", "string", "null"],
                        "description": "a number; 'nan'/'inf'/'-inf' when not finite"}
_XY = {"type": ["object", "null"], "properties": {"x": _NUM, "y": _NUM}}
SCHEMAS: dict[str, dict[str, Any]] = {
    "/cptbt/mission": {
        "title": "cptbt.Mission", "type": "object",
        "properties": {"name": {"type": "string"}, "yaml": {"type": "string"},
                       "source": {"type": "string"}, "cptbt_version": {"type": "string"},
                       "start_xy": {"type": "array", "items": _NUM,
                                    "description": "the planner's move-to-field goal, planning "
                                    "frame (when not the mission's start)"}},
    },
    "/cptbt/cycle": {
        "title": "cptbt.Cycle", "type": "object",
        "properties": {
            "seq": {"type": "integer", "description": "cycle number from 0"},
            "t": _NUM, "phase": {"type": "string"},
            "inputs": {"type": "array", "description": "planner inputs since the last tick: "
                       "[s,t,value] | [f,t,vx,vy] | [p,x,y,heading]"},
            "percept": {"type": ["object", "null"], "properties": {
                "t": _NUM, "x": _NUM, "y": _NUM, "heading_deg": _NUM, "concentration": _NUM,
                "detected": {"type": "boolean"}, "in_plume": {"type": "boolean"},
                "in_op_area": {"type": "boolean"}, "contact_count": {"type": "integer"},
                "flow": {"type": ["object", "null"], "properties": {"vx": _NUM, "vy": _NUM}},
                "last_detection": _XY}},
            "active": {"type": ["string", "null"], "description": "behaviour that commanded"},
            "command": {"type": ["object", "null"], "properties": {
                "heading_deg": _NUM, "speed_mps": _NUM}},
            "declared_source": _XY, "done": {"type": "boolean"},
            "blackboard": {"type": "object"},
        },
    },
    "/cptbt/phase": {
        "title": "cptbt.PhaseChange", "type": "object",
        "properties": {"t": _NUM, "from": {"type": "string"}, "to": {"type": "string"},
                       "trigger": {"type": "string"}, "detail": {"type": "string"}},
    },
}


CHUNK_BYTES = 64 * 1024
"""The cycle log's MCAP chunk size: what a killed writer can lose at most."""


class LogError(RuntimeError):
    """A log cannot be written or read (missing ``mcap``, not a cptbt log)."""


def num(x: float) -> float | str:
    """A float as JSON can hold it, exactly."""
    if math.isfinite(x):
        return float(x)
    return "nan" if math.isnan(x) else ("inf" if x > 0 else "-inf")


def unnum(v: Any) -> float:
    """The float :func:`num` wrote (None reads as NaN)."""
    return math.nan if v is None else float(v)


def _jsonable(v: Any) -> Any:
    if isinstance(v, float):
        return num(v)
    if v is None or isinstance(v, bool | int | str):
        return v
    if dataclasses.is_dataclass(v) and not isinstance(v, type):
        return {f.name: _jsonable(getattr(v, f.name)) for f in dataclasses.fields(v)}
    if isinstance(v, list | tuple):
        return [_jsonable(x) for x in v]
    if isinstance(v, dict):
        return {str(k): _jsonable(x) for k, x in v.items()}
    return repr(v)


class RecordingPlanner(Planner):
    """A :class:`Planner` that keeps the inputs it was given since its last tick."""

    def __init__(self, mission: MissionBase, **kw: Any) -> None:
        super().__init__(mission, **kw)
        self.pending: list[list[Any]] = []
        self.last_inputs: list[list[Any]] = []

    def add_sample(self, t: float, concentration: float) -> None:
        """Record, then pass on."""
        self.pending.append(["s", num(t), num(concentration)])
        super().add_sample(t, concentration)

    def add_flow(self, t: float, vx: float, vy: float) -> None:
        """Record, then pass on."""
        self.pending.append(["f", num(t), num(vx), num(vy)])
        super().add_flow(t, vx, vy)

    def set_pose(self, x: float, y: float, heading_deg: float = math.nan) -> None:
        """Record, then pass on."""
        self.pending.append(["p", num(x), num(y), num(heading_deg)])
        super().set_pose(x, y, heading_deg)

    def tick(self, t: float) -> Command | None:
        """Tick; the inputs since the previous tick move to :attr:`last_inputs`."""
        self.last_inputs, self.pending = self.pending, []
        return super().tick(t)


def feed(planner: Planner, inputs: list[list[Any]]) -> None:
    """Give a planner recorded inputs, in order."""
    for e in inputs:
        if e[0] == "s":
            planner.add_sample(unnum(e[1]), unnum(e[2]))
        elif e[0] == "f":
            planner.add_flow(unnum(e[1]), unnum(e[2]), unnum(e[3]))
        elif e[0] == "p":
            planner.set_pose(unnum(e[1]), unnum(e[2]), unnum(e[3]))
        else:
            raise LogError(f"unknown input record {e[0]!r}")


def cycle_record(planner: Planner, seq: int, t: float, phase: str,
                 inputs: list[list[Any]]) -> dict[str, Any]:
    """One ``/cptbt/cycle`` message for a planner that just ticked."""
    p = planner.percept
    percept = None
    if p is not None:
        percept = {
            "t": num(p.t), "x": num(p.pose.x), "y": num(p.pose.y),
            "heading_deg": num(p.pose.heading_deg), "concentration": num(p.concentration),
            "detected": p.detected, "in_plume": p.in_plume, "in_op_area": p.in_op_area,
            "contact_count": p.contact_count,
            "flow": None if p.flow is None else {"vx": num(p.flow.vx), "vy": num(p.flow.vy)},
            "last_detection": None if p.last_detection is None else {
                "x": num(p.last_detection.x), "y": num(p.last_detection.y)},
        }
    cmd = planner.command
    src = planner.declared_source
    prefix = planner.namespace + "/"
    board = {k[len(prefix):]: _jsonable(v)
             for k, v in py_trees.blackboard.Blackboard.storage.items() if k.startswith(prefix)}
    return {
        "seq": seq, "t": num(t), "phase": phase, "inputs": inputs, "percept": percept,
        "active": planner.active,
        "command": None if cmd is None else {"heading_deg": num(cmd.heading_deg),
                                             "speed_mps": num(cmd.speed_mps)},
        "declared_source": None if src is None else {"x": num(src.x), "y": num(src.y)},
        "done": planner.done, "blackboard": board,
    }


def _mcap() -> Any:
    try:
        from mcap.writer import Writer
    except ImportError:
        raise LogError("cycle logs need the mcap package: pip install 'cptbt[logs]'") from None
    return Writer


class CycleLog:
    """An MCAP cycle log, written as a session observer.

    Use :meth:`open`; give the session :attr:`planner` (it records its inputs) and call the log
    after every session update. :meth:`close` finishes the file.
    """

    def __init__(self, stream: BinaryIO, mission: MissionBase, source: str,
                 planner: RecordingPlanner | None = None, start: Point | None = None) -> None:
        writer_cls = _mcap()
        self._stream = stream
        # Chunks of 64 KiB, flushed with every cycle: a process killed mid-run leaves every
        # finished chunk on disk (1 MiB chunks left a killed serve's log empty), and
        # :func:`read_log` reads such a log up to the damage.
        self.writer = writer_cls(stream, chunk_size=CHUNK_BYTES)
        self.writer.start(profile=PROFILE, library="cptbt")
        self.channels: dict[str, int] = {}
        for topic in TOPICS:
            sid = self.writer.register_schema(
                name=SCHEMAS[topic]["title"], encoding="jsonschema",
                data=json.dumps(SCHEMAS[topic]).encode("utf-8"))
            self.channels[topic] = self.writer.register_channel(
                topic=topic, message_encoding="json", schema_id=sid)
        self.planner = planner or RecordingPlanner(mission, start=start)
        self.cycles = 0
        self._phases_seen = 0
        self._t_ns = 0
        self._closed = False
        from cptbt import __version__

        record: dict[str, Any] = {"name": mission.name, "yaml": dump_mission(mission),
                                  "source": source, "cptbt_version": __version__}
        if start is not None:
            record["start_xy"] = [num(start.x), num(start.y)]
        self._write("/cptbt/mission", 0.0, record)

    @classmethod
    def open(cls, path: Path, mission: MissionBase, source: str = "",
             start: Point | None = None) -> CycleLog:
        """Start a log file at ``path``; ``start``: the planner's move-to-field goal, when not
        the mission's start."""
        _mcap()
        path.parent.mkdir(parents=True, exist_ok=True)
        return cls(path.open("wb"), mission, source, start=start)

    def __call__(self, session: AmpSession) -> None:
        """Log new phase changes, and the cycle if the planner ticked."""
        tl = session.phases.timeline
        while self._phases_seen < len(tl):
            c = tl[self._phases_seen]
            self._write("/cptbt/phase", c.t_s, _jsonable(c.to_data()))
            self._phases_seen += 1
        if session.ticked and session.planner is self.planner:
            self.record(session.t, session.phases.state)

    def phase(self, t: float, source: str, dest: str, trigger: str, detail: str = "") -> None:
        """Log a phase change that no session made (a batch run's start and end)."""
        self._write("/cptbt/phase", t, {"t": num(t), "from": source, "to": dest,
                                        "trigger": trigger, "detail": detail})

    def record(self, t: float, phase: str) -> None:
        """Log the cycle the planner just ran."""
        rec = cycle_record(self.planner, self.cycles, t, phase, self.planner.last_inputs)
        self._write("/cptbt/cycle", t, rec)
        self.cycles += 1
        self._stream.flush()  # a finished chunk reaches the disk, not only Python's buffer

    def _write(self, topic: str, t_s: float, data: dict[str, Any]) -> None:
        if math.isfinite(t_s):
            self._t_ns = max(self._t_ns, round(t_s * 1e9))
        payload = json.dumps(data, allow_nan=False, separators=(",", ":")).encode("utf-8")
        self.writer.add_message(channel_id=self.channels[topic], log_time=self._t_ns,
                                data=payload, publish_time=self._t_ns)

    def close(self) -> None:
        """Finish the file (idempotent)."""
        if self._closed:
            return
        self._closed = True
        self.writer.finish()
        self._stream.close()


@dataclass
class LogData:
    """A cycle log read back.

    Attributes:
        mission: the ``/cptbt/mission`` record.
        cycles: the ``/cptbt/cycle`` records, in the order written.
        phases: the ``/cptbt/phase`` records, in order.
    """

    mission: dict[str, Any]
    cycles: list[dict[str, Any]] = field(default_factory=list)
    phases: list[dict[str, Any]] = field(default_factory=list)
    truncated: str | None = None  # why the log ends early (its writer never finished it)


def _messages(stream: BinaryIO) -> Iterator[tuple[str, dict[str, Any]]]:
    try:
        from mcap.reader import make_reader
    except ImportError:
        raise LogError("reading logs needs the mcap package: pip install 'cptbt[logs]'") from None
    reader = make_reader(stream)
    for _schema, channel, message in reader.iter_messages(topics=list(TOPICS),
                                                          log_time_order=False):
        yield channel.topic, json.loads(message.data)


def _collect(data: LogData | None, topic: str, msg: dict[str, Any]) -> LogData | None:
    """The log read so far with one more record: a mission record starts it afresh."""
    if topic == "/cptbt/mission":
        return LogData(msg)
    if data is not None:
        (data.cycles if topic == "/cptbt/cycle" else data.phases).append(msg)
    return data


def _salvage(raw: bytes) -> LogData | None:
    """The records of a log read in order up to where it is damaged or ends unfinished (a
    writer killed mid-run); None if not even its mission record can be read."""
    from mcap.records import Channel, Message
    from mcap.stream_reader import StreamReader

    topics: dict[int, str] = {}
    data: LogData | None = None
    why = "it ends without the summary a finished log has"  # records intact to the end
    try:
        for record in StreamReader(io.BytesIO(raw)).records:
            if isinstance(record, Channel):
                topics[record.id] = record.topic
            elif isinstance(record, Message) and topics.get(record.channel_id) in TOPICS:
                data = _collect(data, topics[record.channel_id], json.loads(record.data))
    except Exception as exc:  # the torn or missing end
        why = f"it ends unfinished ({type(exc).__name__})"
    if data is not None:
        data.truncated = why
    return data


def read_log(path: Path | str) -> LogData:
    """Read a cycle log.

    Raises:
        LogError: not an MCAP file, or not one cptbt wrote.
    """
    data: LogData | None = None
    try:
        raw = Path(path).read_bytes()
    except OSError as exc:
        raise LogError(f"{path}: {exc.strerror or exc}") from None
    try:
        for topic, msg in _messages(io.BytesIO(raw)):
            data = _collect(data, topic, msg)
    except LogError:
        raise
    except Exception as exc:  # the mcap reader's errors are many and unexported
        data = _salvage(raw)  # a log whose writer was killed: no summary, a torn last chunk
        if data is None:
            raise LogError(f"{path}: not a readable MCAP file ({type(exc).__name__}: {exc})"
                           ) from None
    if data is None:
        raise LogError(f"{path}: no /cptbt/mission record: not a cptbt cycle log")
    return data
