"""The whole MSN007 mission over MAVLink, as a user runs it: ``cptbt frontseat --link mavlink:…``
in one process, ``cptbt serve --link mavlink:…`` in another (take control → declare → give back
→ the vehicle finishes its rows), then the log's story and its replay."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

from wire_doubles import MISSIONS

MSN007 = str(MISSIONS / "tro2006_msn007.yaml")


def _cptbt(*args: str) -> list[str]:
    return [sys.executable, "-m", "cptbt", *args]


def test_msn007_flies_over_mavlink_end_to_end(tmp_path: Path) -> None:
    vehicle = subprocess.Popen(
        _cptbt("frontseat", MSN007, "--link", "mavlink:udp:127.0.0.1:0", "--clock-scale", "50",
               "--report", str(tmp_path / "vehicle.json")),
        stdout=subprocess.PIPE, text=True)
    try:
        assert vehicle.stdout is not None
        banner = vehicle.stdout.readline()  # "...speaking mavlink on 127.0.0.1:PORT at..."
        assert "speaking mavlink" in banner
        port = banner.split(" on 127.0.0.1:")[1].split()[0]
        log = tmp_path / "served.mcap"
        served = subprocess.run(
            _cptbt("serve", MSN007, "--link", f"mavlink:udp:127.0.0.1:{port}",
                   "--clock-scale", "50", "--judge", "--log", str(log),
                   "--out", str(tmp_path / "run")),
            capture_output=True, text=True, timeout=180)
        vehicle.wait(timeout=60)
    finally:
        vehicle.kill()
    assert served.returncode == 0, served.stderr
    assert "declared (success); stopped: post_mission" in served.stdout, served.stdout
    s = json.loads((tmp_path / "run" / "summary.json").read_text())
    assert [c["trigger"] for c in s["phases"]["timeline"]] == [
        "launch", "amp_enable", "declared_home", "vehicle_returning", "break_off_reached",
        "mission_a_complete"]
    assert s["outcome"] == "declared" and s["success"] and s["error_m"] < 15
    assert 240.0 <= s["t0"] <= 241.0 and s["t1"] is not None and s["t3"] > s["t1"]
    assert s["link"]["ignored"] == 0 and s["link"]["vehicle_heartbeats"] > 500
    v = json.loads((tmp_path / "vehicle.json").read_text())
    assert v["override_ended"] == ["released"] and v["mode"] == "post_mission"
    assert v["commands_heard"] > 300 and v["decoder"]["setpoints"] == v["commands_heard"]
    story = subprocess.run(_cptbt("log", "summary", str(log)), capture_output=True, text=True,
                           timeout=60)
    assert "declared_home" in story.stdout and "source declared" in story.stdout
    again = subprocess.run(_cptbt("replay", str(log)), capture_output=True, text=True,
                           timeout=60)
    assert again.returncode == 0 and "identical" in again.stdout
