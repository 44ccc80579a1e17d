"""``cptbt phases``: print a mission's phase machine and (optionally) write it as Graphviz dot."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from cptbt.cli.argtypes import not_the_mission
from cptbt.cli.inspect_cmds import load
from cptbt.cli.output import frame_line
from cptbt.phases import describe, to_dot


def add_parsers(sub: Any) -> None:
    """Register ``phases``."""
    p = sub.add_parser("phases", help="show a mission's phase machine",
                       description=cmd_phases.__doc__)
    p.add_argument("mission", metavar="MISSION", help="mission YAML file")
    p.add_argument("--dot", metavar="FILE", help="also write the machine as Graphviz dot")
    p.set_defaults(func=cmd_phases)


def cmd_phases(args: argparse.Namespace) -> int:
    """Print the mission phases (states, transitions, triggers) and this mission's settings."""
    not_the_mission("--dot", args.dot, args.mission)
    mission = load(args.mission)
    spec = mission.mission_a
    print(f"{mission.name}: mission phases (SPEC §9)")
    if spec is None:  # said first: a review read the whole machine before learning this
        print("  this mission has no mission_a section: the AMP drives from launch, and "
              "cptbt run uses no phases; the machine a mission_a section would fly:")
    print(describe())
    print("settings:")
    if spec is None:
        print("  no mission_a section: the AMP drives from launch (cptbt run uses no phases)")
    else:
        k = spec.amp_enable_waypoint
        enable = (f"{spec.amp_enable_s:g} s after the launch (timed from the vehicle's last "
                  "report at the dock; a session that did not see the launch never takes over)"
                  if spec.amp_enable_s is not None else
                  f"on reaching waypoint {k} (0-based: the {_ordinal((k or 0) + 1)} of the list)")
        ending = "loops" if spec.loop else "ends at the last waypoint"
        lim = spec.limits
        print(f"  Mission A: {len(spec.waypoints)} waypoints at {spec.speed_mps:g} m/s, {ending}"
              f" (or at {spec.duration_limit_s:g} s)")
        print(f"  amp_enable: {enable}")
        print(f"  amp_time_limit: {mission.time_limit_s:g} s after the take-over")
        print("  outside_op_area: more than 30 m outside the OpArea")
        print(f"  watchdog_timeout: no accepted command for {spec.watchdog_s:g} s")
        print(f"  command_refused: speed outside [{lim.min_speed_mps:g}, {lim.max_speed_mps:g}]"
              f" m/s, depth outside [0, {lim.max_depth_m:g}] m, or a heading not finite")
        nav = max(5.0, 3.0 / mission.cycle_hz)
        print("  amp_abort: the operator stops, the link falls silent, an internal error, "
              f"{nav:g} s of the vehicle's reports without a usable position, or {nav:g} s of "
              "planning cycles without a command")
    print(frame_line(mission))
    if args.dot:
        Path(args.dot).write_text(to_dot(), encoding="utf-8")
        print(f"wrote {args.dot}")
    return 0


def _ordinal(n: int) -> str:
    """1st, 2nd, 3rd, 4th ... 11th, 12th, 13th, 21st."""
    suffix = "th" if 10 <= n % 100 <= 20 else {1: "st", 2: "nd", 3: "rd"}.get(n % 10, "th")
    return f"{n}{suffix}"
