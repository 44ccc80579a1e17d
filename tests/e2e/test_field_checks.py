"""What a field engineer's slips and a front seat's integrator need (a review of a deployment
in latitude and longitude): a far waypoint and a far geodetic centre are warned of, and the
planning frame the backseat link speaks in is printed."""

from __future__ import annotations

from pathlib import Path

import pytest

from cptbt import cli

ROOT = Path(__file__).resolve().parents[2]
MSN010 = (ROOT / "missions" / "tro2006_msn010.yaml").read_text(encoding="utf-8")


def write(tmp_path: Path, text: str) -> str:
    path = tmp_path / "m.yaml"
    path.write_text(text, encoding="utf-8")
    return str(path)


def test_a_waypoint_thousands_of_km_away_is_warned_of(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """A lost minus sign put a waypoint 9 500 km off: it validated, and the run never reached
    the take-over."""
    text = MSN010.replace("- [32.98025216, -118.53686813]  # 2",
                          "- [32.98025216, 118.53686813]  # 2")
    assert text != MSN010
    assert cli.main(["validate", write(tmp_path, text)]) == 0
    err = capsys.readouterr().err
    assert "mission_a.waypoints[2]: warning: " in err and "km outside the OpArea: a slip" in err
    assert cli.main(["validate", write(tmp_path, MSN010)]) == 0
    assert "warning" not in capsys.readouterr().err


def test_a_geodetic_centre_far_from_the_corners_is_warned_of(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    text = MSN010.replace("geodetic_centre_deg: [32.98088333,",
                          "geodetic_centre_deg: [32.99088333,")
    assert text != MSN010
    assert cli.main(["validate", write(tmp_path, text)]) == 0
    err = capsys.readouterr().err
    assert "op_area.geodetic_centre_deg: warning: 1" in err and "a typo?" in err


def test_phases_prints_the_planning_frame_and_the_waypoint_count_from_zero(
        capsys: pytest.CaptureFixture[str]) -> None:
    assert cli.main(["phases", str(ROOT / "missions" / "tro2006_msn010.yaml")]) == 0
    out = capsys.readouterr().out
    assert "amp_enable: on reaching waypoint 1 (0-based: the 2nd of the list)" in out
    assert ("planning frame: origin at 32.980883, -118.537050; +x toward compass bearing "
            "136.") in out
    assert "the backseat link's positions, flows and headings are in it" in out


def test_the_planning_frame_line_of_a_mavlink_serve_says_the_amp_converts() -> None:
    """A review: a MAVLink serve's frame line had said the backseat link speaks in the planning
    frame; MAVLink speaks latitude/longitude, which the AMP converts."""
    from cptbt.cli.output import frame_line
    from cptbt.loader import load_mission

    m = load_mission(ROOT / "missions" / "tro2006_msn010.yaml")
    line = frame_line(m, mavlink=True)
    assert "backseat" not in line and "the AMP turns MAVLink's latitude/longitude" in line
