"""As a user would: ``cptbt frontseat`` in one process, ``cptbt serve`` in another, then the log."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest
from wire_doubles import MISSIONS

MSN007 = str(MISSIONS / "tro2006_msn007.yaml")


def _cptbt(*args: str) -> list[str]:
    return [sys.executable, "-m", "cptbt", *args]


def test_serve_against_the_frontseat_process_then_replay_the_log(tmp_path: Path) -> None:
    vehicle = subprocess.Popen(
        _cptbt("frontseat", MSN007, "--listen", "127.0.0.1:0", "--clock-scale", "50",
               "--report", str(tmp_path / "vehicle.json")),
        stdout=subprocess.PIPE, text=True)
    try:
        assert vehicle.stdout is not None
        banner = vehicle.stdout.readline()  # "...speaking backseat on 127.0.0.1:PORT at..."
        port = banner.split(" on 127.0.0.1:")[1].split()[0]
        log = tmp_path / "served.mcap"
        served = subprocess.run(
            _cptbt("serve", MSN007, "--link", f"backseat:udp:127.0.0.1:{port}",
                   "--clock-scale", "50", "--judge", "--log", str(log),
                   "--out", str(tmp_path / "run")),
            capture_output=True, text=True, timeout=120)
        vehicle.wait(timeout=30)
    finally:
        vehicle.kill()
    assert served.returncode == 0, served.stderr
    assert "declared (success); stopped: post_mission" in served.stdout
    summary = json.loads((tmp_path / "run" / "summary.json").read_text())
    assert summary["outcome"] == "declared" and summary["phases"]["end_phase"] == "post_mission"
    assert json.loads((tmp_path / "vehicle.json").read_text())["override_ended"] == ["released"]
    story = subprocess.run(_cptbt("log", "summary", str(log)), capture_output=True, text=True,
                           timeout=60)
    assert "declared_home" in story.stdout and "source declared" in story.stdout
    again = subprocess.run(_cptbt("replay", str(log)), capture_output=True, text=True,
                           timeout=60)
    assert again.returncode == 0 and "identical" in again.stdout


def test_a_bad_link_is_one_line_and_exit_2() -> None:
    r = subprocess.run(_cptbt("serve", MSN007, "--link", "serial:/dev/ttyUSB0"),
                       capture_output=True, text=True, timeout=60)
    assert r.returncode == 2 and r.stderr.startswith("cptbt: link") and "Traceback" not in r.stderr


def test_frontseat_errors_are_one_line_and_exit_2() -> None:
    # No mission_a section to fly; a host that cannot be resolved; a link URI without a transport.
    cases = [
        (str(MISSIONS / "ab2001_strategy3.yaml"), "--link", "backseat:udp:127.0.0.1:0"),
        (MSN007, "--link", "mavlink:udp:no-such-host.invalid:14550"),
        (MSN007, "--link", "backseat:14550"),
    ]
    for args in cases:
        r = subprocess.run(_cptbt("frontseat", *args), capture_output=True, text=True, timeout=60)
        lines = r.stderr.strip().splitlines()
        assert r.returncode == 2 and len(lines) == 1 and lines[0].startswith("cptbt: "), r.stderr
        assert "internal error" not in r.stderr


@pytest.mark.parametrize(("command", "args", "says"), [
    ("serve", ["--clock-scale", "1e-300"], "between 0.001 and 10000"),  # overflowed the clock
    ("serve", ["--connect-timeout", "nan"], "must be a finite number"),  # waited for ever
    ("serve", ["--connect-timeout", "-1"], "must be more than 0"),
    ("serve", ["--link-timeout", "0"], "must be more than 0"),
    ("frontseat", ["--drop", "1.5"], "between 0 and 1"),
])
def test_serve_and_frontseat_options_out_of_range_are_usage_errors(
    command: str, args: list[str], says: str
) -> None:
    r = subprocess.run(_cptbt(command, MSN007, "--link", "backseat:udp:127.0.0.1:9", *args),
                       capture_output=True, text=True, timeout=60)
    lines = r.stderr.strip().splitlines()
    assert r.returncode == 2 and len(lines) == 1 and says in lines[0], r.stderr
    assert lines[0].startswith(f"cptbt {command}: error: argument ")
