"""What ``cptbt run`` and ``cptbt serve`` share in what they write and print."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from cptbt.batch.comparison import left_oparea
from cptbt.mission import MissionBase
from cptbt.policy import share_text
from cptbt.types import Point


def fresh_folder(base: Path) -> Path:
    """``base``, or ``base-2``, ``base-3``... : the first that does not exist."""
    out, k = base, 1
    while out.exists():
        k += 1
        out = base.with_name(f"{base.name}-{k}")
    return out


def fmt(v: float | None, unit: str = "") -> str:
    """A measure to one decimal, or "—" when it does not exist (None or NaN)."""
    return "—" if v is None or (isinstance(v, float) and math.isnan(v)) else f"{v:.1f}{unit}"


def times_line(s: dict[str, Any]) -> str:
    """TRO's times and path ratio of a run summary (SPEC §11). D1 ends at t2, the first pass
    within 13 m of the declared point, so D1/D0 can fall below 1: said so when it does (a
    review read 0.4 as an impossible efficiency)."""
    ratio = s.get("D1_over_D0")
    return (f"  T_F {fmt(s['T_F'], ' s')}  T_T {fmt(s['T_T'], ' s')}  T_D {fmt(s['T_D'], ' s')}"
            f"  D1/D0 {fmt(ratio)}"
            + ("  (t2 = t1: the first detection was already within 13 m of the declared point, "
               "SPEC §11)" if ratio is not None and s.get("T_T") == 0 else
               "  (D1 ends within 13 m of the declared point: SPEC §11)"
               if ratio is not None and ratio < 1 else ""))


def time_share(shares: dict[str, Any]) -> str:
    """``behaviour 12%, ...`` of a summary's ``time_share``: a share under half a per cent is
    "<1%", not "0%", and ``none`` (no behaviour had output: the first cycles, before a flow
    estimate) reads "no output" and is left out only when it is nothing (a review saw it
    shown at 1% and dropped at 0.4%, while other entries showed 0%)."""
    return ", ".join(f"{'no output' if k == 'none' else k} {share_text(v)}"
                     for k, v in shares.items() if k != "none" or v > 0)


def place(d: dict[str, float]) -> str:
    """A summary's point (``where``): ``N 12.3 m, E -4.5 m`` and lat/lon when known; a
    planning-frame mission has no compass, so its point is ``x 12.3 m, y -4.5 m``."""
    if "north" in d:
        text = f"N {d['north']:.1f} m, E {d['east']:.1f} m"
    else:
        text = f"x {d['x']:.1f} m, y {d['y']:.1f} m"
    if "lat" in d:
        text += f" ({d['lat']:.6f}, {d['lon']:.6f})"
    return text


def outside_line(s: dict[str, Any], track: str = "true track") -> str | None:
    """How far outside the OpArea the vehicle went, when it left it (None: it did not), on
    ``track`` (a served run knows only the navigation track)."""
    far = s.get("farthest_outside_m") or 0.0
    if not left_oparea(far):
        return None
    return f"  left the OpArea: at most {far:.1f} m outside it ({track})"


def command_faults_line(s: dict[str, Any]) -> str | None:
    """The behaviours whose commands were not flown as asked (None: none)."""
    text = s.get("command_faults")
    return f"  behaviour faults: {text}" if text else None


def sensor_faults_line(s: dict[str, Any]) -> str | None:
    """What the perception dropped or corrected in a run summary (None: nothing)."""
    parts = []
    for key, what in (("missing_samples", "fluorometer sample{} missing (not a finite number: "
                       "a dropout)"),
                      ("stuck_samples", "fluorometer sample{} dropped as stuck (the same "
                       "reading for perception.stuck_after_s)"),
                      ("late_samples", "fluorometer sample{} dropped as late (stamped more than "
                       "5 s, or a planning period, before the previous cycle)"),
                      ("rejected_fixes", "navigation position{} ignored (more than 1000 km outside "
                       "the OpArea)"),
                      ("rejected_flow_samples", "flow sample{} rejected (not finite, or faster "
                       "than perception.max_flow_speed_mps)"),
                      ("clock_corrections", "cycle time{} not after the previous one, or "
                       "leaping more than an hour past it, taken as one period later"),
                      ("flow_held_cycles", "cycle{} planned on the last flow estimate, held (no "
                       "usable flow sample for perception.flow_window_s)"),
                      ("blind_cycles", "cycle{} planned with no fluorometer reading (samples "
                       "missing, dropped, or not sent: blind to the plume)")):
        n = s.get(key) or 0
        if n:
            parts.append(f"{n} " + what.format("s" * (n != 1)))
    return "  sensor faults: " + "; ".join(parts) if parts else None


def frame_line(mission: MissionBase, mavlink: bool = False) -> str:
    """Where the planning frame is, for a front seat's integrator: the backseat protocol's
    positions, flows and headings are in it (a review had to recover it from a figure's label);
    over MAVLink (``mavlink``) the AMP converts into it (a review: the line had said "backseat
    link" on a MAVLink serve)."""
    if mission.frame == "planning":
        return ("  planning frame: the mission's own x, y (no compass given); "
                + _frame_use(mavlink))
    area = mission.op_area_geometry()
    origin = Point(0.0, 0.0)
    n, e = mission.to_ne(origin)
    geo = mission.to_geodetic(origin)
    where = (f"{geo.lat_deg:.6f}, {geo.lon_deg:.6f}" if geo is not None
             else f"N {n:.1f} m, E {e:.1f} m")
    b = area.frame.x_bearing_deg % 360
    return (f"  planning frame: origin at {where}; +x toward compass bearing {b:.1f}°, +y toward "
            f"{(b + 90) % 360:.1f}°; a heading h in it is compass bearing h + {b:.1f}°; "
            + _frame_use(mavlink))


def _frame_use(mavlink: bool) -> str:
    """Who speaks in the planning frame: the backseat protocol does; MAVLink speaks
    latitude/longitude or north-east-down, which the AMP turns into it."""
    if mavlink:
        return ("the AMP turns MAVLink's latitude/longitude (or north-east metres) into it, "
                "and plans and logs in it")
    return "the backseat link's positions, flows and headings are in it"
