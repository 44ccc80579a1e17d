"""Replay a cycle log through a planner, and tell a log's story.

:func:`replay` feeds the recorded planner inputs of every cycle (samples, flow samples, poses, the
tick time) to a fresh planner for the logged mission — or another mission, e.g. the same one with
``reacquire_plume: {variant: three_point}``; with the log's move-to-field goal when it recorded
one, as a batch study's logs do — and compares its output with the log cycle by cycle:
the command (heading and speed, exactly: bit for bit), the active behaviour and the declared
source. The replay is open loop: once the commands diverge, the recorded poses are those of the
vehicle that followed the logged planner, so the report gives the first divergent cycle rather
than a second mission.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from cptbt.loader import load_mission, loads_mission
from cptbt.logs import LogData, feed, num, read_log, unnum
from cptbt.mission import MissionBase
from cptbt.planner import Planner
from cptbt.policy import share_text
from cptbt.types import Point


@dataclass(frozen=True, slots=True)
class Divergence:
    """The first cycle where the replayed planner did something else.

    Attributes:
        seq: cycle number; t: its time.
        field: what differs first (``command``, ``active`` or ``declared_source``).
        recorded: the logged value; replayed: the replay's.
    """

    seq: int
    t: float
    field: str
    recorded: Any
    replayed: Any


@dataclass(frozen=True, slots=True)
class ReplayReport:
    """A replay's result.

    Attributes:
        mission: the mission replayed; logged_mission: the one in the log.
        cycles: cycles replayed.
        divergence: the first divergent cycle (None: identical, bit for bit).
        commands_differing: cycles whose command differs.
    """

    mission: str
    logged_mission: str
    cycles: int
    divergence: Divergence | None
    commands_differing: int

    @property
    def identical(self) -> bool:
        """Every cycle's outputs equal the log's."""
        return self.divergence is None


def _command(planner: Planner) -> Any:
    c = planner.command
    return None if c is None else {"heading_deg": num(c.heading_deg),
                                   "speed_mps": num(c.speed_mps)}


def _declared(planner: Planner) -> Any:
    s = planner.declared_source
    return None if s is None else {"x": num(s.x), "y": num(s.y)}


def _same(a: Any, b: Any) -> bool:
    # Exact: repr-equal floats, with NaN equal to NaN ("nan" strings compare equal already).
    if isinstance(a, float) and isinstance(b, float):
        return a == b or (math.isnan(a) and math.isnan(b))
    if isinstance(a, dict) and isinstance(b, dict):
        return a.keys() == b.keys() and all(_same(a[k], b[k]) for k in a)
    return bool(a == b)


def logged_mission(log: LogData) -> MissionBase:
    """The mission stored in a log."""
    return loads_mission(log.mission["yaml"], source=f"<log {log.mission.get('name')}>")


def replay(log: LogData | Path | str, mission: MissionBase | Path | str | None = None
           ) -> ReplayReport:
    """Re-run a planner on a log's recorded inputs and compare with what was logged.

    Args:
        log: a read log, or its path.
        mission: the mission to replay with (a loaded one or a YAML path); default: the log's.
    """
    data = log if isinstance(log, LogData) else read_log(log)
    original = logged_mission(data)
    if mission is None:
        m = original
    elif isinstance(mission, MissionBase):
        m = mission
    else:
        m = load_mission(mission)
    start = data.mission.get("start_xy")
    planner = Planner(m, start=None if start is None else Point(unnum(start[0]),
                                                                 unnum(start[1])))
    first: Divergence | None = None
    differing = 0
    try:
        for rec in data.cycles:
            feed(planner, rec["inputs"])
            t = unnum(rec["t"])
            planner.tick(t)
            got = {"command": _command(planner), "active": planner.active,
                   "declared_source": _declared(planner)}
            if not _same(got["command"], rec["command"]):
                differing += 1
            if first is None:
                for key in ("command", "active", "declared_source"):
                    if not _same(got[key], rec[key]):
                        first = Divergence(int(rec["seq"]), t, key, rec[key], got[key])
                        break
    finally:
        planner.close()
    return ReplayReport(m.name, original.name, len(data.cycles), first, differing)


def _t(cycle: dict[str, Any]) -> float:
    """A logged cycle's time on the planner's clock (its percept's), else the vehicle's."""
    return float((cycle.get("percept") or {}).get("t") or cycle["t"])


def story(log: LogData) -> list[str]:
    """A log's mission story, one line per event: phases, behaviour changes (by family, so
    track-in/out flips do not flood it), first detection, declaration; then the share of cycles
    in each behaviour leaf."""
    lines = [f"{log.mission.get('name')}: {len(log.cycles)} AMP cycles"
             + (f" ({log.mission['source']})" if log.mission.get("source") else "")]
    if log.cycles:  # the planner's clock, as the lines below (an attacker's clock step)
        lines[0] += f", t {_t(log.cycles[0]):.1f}–{_t(log.cycles[-1]):.1f} s"
    events: list[tuple[float, int, str]] = []
    try:  # the places in the mission's own frame too (a review read only planning x, y)
        m: MissionBase | None = logged_mission(log)
    except Exception:  # a mission that no longer loads here (a plug-in not installed)
        m = None
    start = log.mission.get("start_xy")
    for c in log.phases:
        detail = f" — {c['detail']}" if c.get("detail") else ""
        if c.get("trigger") == "study_run_start" and start and m is not None:
            # a study's start, in the mission's frame as the places below (a review)
            mode = str(c.get("detail") or "").rpartition(", ")[2]
            detail = f" — start at {_at(m, *start)}" + (f", {mode}" if mode else "")
        events.append((float(c["t"]), 0, f"phase {c['from']} -> {c['to']} "
                                          f"({c['trigger']}){detail}"))
    family: str | None = ""  # behaviour changes by family: track-in/out flips are one story
    active = None
    detected = False
    declared = False
    refs = 0
    cycles_in: dict[str, int] = {}
    for c in log.cycles:
        # on the planner's clock, as the phases are (a vehicle clock that stepped back had
        # sorted the give-back among cycles a hundred seconds earlier)
        t = _t(c)
        active = c["active"]
        cycles_in[active or "no output"] = cycles_in.get(active or "no output", 0) + 1
        fam = active.split(".")[0] if active else None
        if fam != family:
            family = fam
            # The family, not the leaf it happened to start in: a track-in/out story read as
            # "track_in" eleven times while track_out drove a third of the cycles.
            events.append((t, 1, f"  behaviour {fam or 'none (no output)'}"))
        p = c.get("percept") or {}
        if p.get("detected") and not detected:
            detected = True
            events.append((t, 1, f"  first detection at {_at(m, p['x'], p['y'])}, "
                                 f"concentration {float(p['concentration']):.2f}"))
        if c["declared_source"] is not None and not declared:
            declared = True
            s = c["declared_source"]
            events.append((t, 1, f"  source declared at {_at(m, s['x'], s['y'])}"))
        refs += bool(p.get("detected"))
    events.sort(key=lambda e: (e[0], e[1]))
    lines += [f"t {t:7.1f} s  {text}" for t, _, text in events]
    lines.append(f"{refs} detecting cycles; "
                 + ("source declared" if declared else "no source declared"))
    if cycles_in:  # the leaves behind the family-level story (track-in and track-out, ...)
        total = sum(cycles_in.values())
        lines.append("cycles in each behaviour: " + ", ".join(
            f"{name} {share_text(n / total)}" for name, n in sorted(cycles_in.items())))
    return lines


def _at(m: MissionBase | None, x: object, y: object) -> str:
    """A logged planning point as the operator reads it: N-E metres and latitude/longitude
    when the mission has them, then the planning frame's x, y."""
    px, py = float(x), float(y)  # type: ignore[arg-type]
    planning = f"({px:.1f}, {py:.1f}) (planning frame)"
    if m is None or m.frame == "planning":
        return planning
    n, e = m.to_ne(Point(px, py))
    geo = m.to_geodetic(Point(px, py))
    lat_lon = f" ({geo.lat_deg:.6f}, {geo.lon_deg:.6f})" if geo is not None else ""
    return f"N {n:.1f} m, E {e:.1f} m{lat_lon}; {planning}"
