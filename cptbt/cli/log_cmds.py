"""``cptbt log summary LOG`` and ``cptbt replay LOG [--mission OTHER.yaml]``."""

from __future__ import annotations

import argparse
import sys
from typing import Any

from cptbt.cli.inspect_cmds import load
from cptbt.logs import LogData, LogError, read_log
from cptbt.mission import MissionBase
from cptbt.replay import replay, story

EXIT_USAGE = 2


def add_parsers(sub: Any) -> None:
    """Register ``log`` (with ``summary``) and ``replay``."""
    p = sub.add_parser("log", help="read a cycle log (MCAP)", description="Read a cycle log.")
    logsub = p.add_subparsers(dest="log_command", required=True, metavar="ACTION")
    s = logsub.add_parser("summary", help="the mission's story from a log",
                          description=cmd_log_summary.__doc__)
    s.add_argument("log", metavar="LOG", help="an MCAP cycle log (cptbt run/serve --log)")
    s.set_defaults(func=cmd_log_summary)

    r = sub.add_parser("replay", help="re-run a planner on a log's recorded inputs",
                       description=cmd_replay.__doc__)
    r.add_argument("log", metavar="LOG", help="an MCAP cycle log")
    r.add_argument("--mission", metavar="OTHER.yaml", default=None,
                   help="replay with this mission (e.g. another variant); default: the log's")
    r.set_defaults(func=cmd_replay)


_BAD_RECORD = (KeyError, IndexError, ValueError, TypeError, AttributeError)
"""What reading a record that is not what cptbt writes raises (in a valid MCAP file)."""


def _bad_record(path: str, exc: Exception) -> int:
    """Say that a record of the log at ``path`` is not one cptbt writes; the exit status."""
    print(f"cptbt: {path}: a record is not what cptbt writes ({type(exc).__name__}: {exc})",
          file=sys.stderr)
    return EXIT_USAGE


def _read(path: str) -> LogData:
    """The log, with a warning when its writer never finished it (read up to the damage)."""
    data = read_log(path)
    if data.truncated:
        print(f"cptbt: warning: {path}: read up to where {data.truncated}: "
              f"{len(data.cycles)} cycles (the process writing it was stopped short)",
              file=sys.stderr)
    return data


def _replay_notes(data: LogData, other: MissionBase | None) -> list[str]:
    """What makes a replay compare unlike things: other code than the log's, or another
    mission whose OpArea, frame or cycle rate differ (the logged inputs are fed regardless)."""
    from cptbt import __version__
    from cptbt.replay import logged_mission

    out = []
    made = data.mission.get("cptbt_version")
    if made and made != __version__:
        out.append(f"the log was written by cptbt {made}, this is {__version__}")
    if other is not None:
        logged = logged_mission(data)
        differ = [what for what, a, b in (
            ("OpArea", logged.op_area, other.op_area), ("frame", logged.frame, other.frame),
            ("cycle rate", logged.cycle_hz, other.cycle_hz)) if a != b]
        if differ:
            out.append(f"{', '.join(differ)} differ from the logged mission's: "
                       "the logged inputs are fed to it as they are, so the comparison is of "
                       "unlike missions")
    return out


def cmd_log_summary(args: argparse.Namespace) -> int:
    """Print a log's mission story: phases, behaviour changes, first detection, declaration."""
    try:
        data = _read(args.log)
        lines = story(data)
    except LogError as exc:
        print(f"cptbt: {exc}", file=sys.stderr)
        return EXIT_USAGE
    except _BAD_RECORD as exc:
        return _bad_record(args.log, exc)
    print("\n".join(lines))
    return 0


def cmd_replay(args: argparse.Namespace) -> int:
    """Feed a log's recorded planner inputs to a planner and compare its commands with the log's:
    bit for bit for the logged mission; with another mission, where they first diverge. Exits 1
    if the logged mission itself does not replay identically."""
    try:
        data = _read(args.log)
    except LogError as exc:
        print(f"cptbt: {exc}", file=sys.stderr)
        return EXIT_USAGE
    if not data.cycles:  # "identical" would say nothing was compared
        print(f"cptbt: {args.log}: holds no planning cycle: nothing to replay", file=sys.stderr)
        return EXIT_USAGE
    other = load(args.mission) if args.mission else None
    for note in _replay_notes(data, other):
        print(f"cptbt: note: {note}", file=sys.stderr)
    try:
        rep = replay(data, other)
    except LogError as exc:
        print(f"cptbt: {args.log}: {exc}", file=sys.stderr)
        return EXIT_USAGE
    except _BAD_RECORD as exc:
        return _bad_record(args.log, exc)
    with_ = f" with {args.mission}" if args.mission else " with the logged mission"
    print(f"replayed {rep.cycles} cycles of {args.log}{with_} ({rep.mission})")
    if rep.divergence is None:
        print("  identical: every command, active behaviour and declaration, bit for bit")
        return 0
    d = rep.divergence
    print(f"  first divergence at cycle {d.seq} (t {d.t:.1f} s): {d.field} logged "
          f"{d.recorded!r}, replayed {d.replayed!r}")
    print(f"  {rep.commands_differing} of {rep.cycles} commands differ (open loop: after the "
          "first divergence the logged poses are the logged planner's)")
    return 0 if args.mission else 1
