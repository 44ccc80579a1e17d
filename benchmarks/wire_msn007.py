"""MSN007 over the wire: wall and CPU time of a served run against each front-seat double.

Flies the whole MSN007 mission (take control → declare → give back → the vehicle finishes Mission
A) with ``cptbt.bridge.serve`` against the simulated front seat in a thread of the same process,
over loopback UDP, once per protocol, at ``--clock-scale`` (the wire tests use 50), and reports
the wall time, the process CPU time, the vehicle seconds flown per wall second, the datagrams and
the outcome, with the machine's load. Nothing is asserted: this is a measurement.

Usage::

    python benchmarks/wire_msn007.py                       # both protocols at 50x
    python benchmarks/wire_msn007.py --clock-scale 100 --protocol mavlink
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import threading
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]


def fly(protocol: str, clock_scale: float) -> dict[str, Any]:
    """One served MSN007 run against the double; its measurements."""
    from cptbt.batch.frontseat import BackseatCodec, Codec, FrontSeatDouble
    from cptbt.batch.scenario import environment_of
    from cptbt.batch.served import AmpCycles, served_summary
    from cptbt.bridge import open_link
    from cptbt.bridge.serve import ServeOptions, serve
    from cptbt.loader import load_mission

    mission = load_mission(ROOT / "missions" / "tro2006_msn007.yaml")
    codec: Codec
    if protocol == "mavlink":
        from cptbt.batch.frontseat_mavlink import MavlinkCodec

        codec = MavlinkCodec(mission)
    else:
        codec = BackseatCodec()
    double = FrontSeatDouble(mission, codec, clock_scale=clock_scale)
    box: dict[str, Any] = {}
    thread = threading.Thread(target=lambda: box.setdefault("r", double.run()), daemon=True)
    cpu0, wall0 = time.process_time(), time.perf_counter()
    thread.start()
    host, port = double.address
    link = open_link(f"{protocol}:udp:{host}:{port}", mission)
    cycles = AmpCycles(mission)
    try:
        result = serve(mission, link, options=ServeOptions(clock_scale=clock_scale),
                       observers=[cycles])
    finally:
        link.close()
    thread.join(timeout=120)
    wall, cpu = time.perf_counter() - wall0, time.process_time() - cpu0
    env = environment_of(mission)
    s = served_summary(result, cycles, mission,
                       mission.to_xy(env.source) if env.source is not None else None)
    vehicle = box["r"]
    return {
        "protocol": protocol, "clock_scale": clock_scale, "wall_s": round(wall, 2),
        "serve_wall_s": round(result.wall_s, 2), "cpu_s": round(cpu, 2),
        "vehicle_s": round(vehicle.t_end, 1),
        "vehicle_s_per_wall_s": round(vehicle.t_end / wall, 1),
        "stop_reason": result.stop_reason, "outcome": s["outcome"], "success": s["success"],
        "error_m": None if s["error_m"] is None else round(s["error_m"], 2),
        "datagrams_to_amp": result.link_stats.get("received"),
        "messages_to_amp": result.link_stats.get("messages"),
        "datagrams_from_amp": result.link_stats.get("sent"),
        "ignored": result.link_stats.get("ignored"),
        "triggers": [c.trigger for c in result.session.phases.timeline],
    }


def main() -> int:
    """Measure and print (and write ``--out`` as JSON)."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--clock-scale", type=float, default=50.0)
    ap.add_argument("--protocol", choices=("backseat", "mavlink", "both"), default="both")
    ap.add_argument("--out", default=str(ROOT / "runs" / "wire_msn007.json"),
                    help="default: under runs/ (benchmarks/results/wire_msn007.json is the "
                    "committed one: name it to replace it)")
    args = ap.parse_args()
    protocols = ("backseat", "mavlink") if args.protocol == "both" else (args.protocol,)
    load0 = os.getloadavg()
    rows = [fly(p, args.clock_scale) for p in protocols]
    report = {"machine": {"platform": platform.platform(), "python": sys.version.split()[0],
                          "cpus": os.cpu_count(), "load_avg_before": load0,
                          "load_avg_after": os.getloadavg()},
              "runs": rows}
    for r in rows:
        print(f"{r['protocol']:8s} {r['clock_scale']:g}x: wall {r['wall_s']:.1f} s "
              f"(serve {r['serve_wall_s']:.1f} s), CPU {r['cpu_s']:.1f} s, "
              f"{r['vehicle_s']:.0f} vehicle s = {r['vehicle_s_per_wall_s']:.1f}/wall s; "
              f"{r['outcome']} (error {r['error_m']} m), stopped {r['stop_reason']}; "
              f"{r['datagrams_to_amp']} datagrams in ({r['messages_to_amp']} messages), "
              f"{r['datagrams_from_amp']} out, {r['ignored']} ignored")
    print(f"load average before {load0[0]:.2f}, after {os.getloadavg()[0]:.2f} "
          f"on {os.cpu_count()} CPUs")
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(report, indent=2) + "\n", encoding="utf-8")
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
