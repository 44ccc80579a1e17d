"""The output helpers cptbt run and cptbt serve share."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from cptbt.batch.scenario import Environment
from cptbt.batch.summary import where
from cptbt.cli.output import fmt, fresh_folder, place, sensor_faults_line, time_share
from cptbt.cli.run_text import upflow_check_line
from cptbt.loader import load_mission
from cptbt.registry import default_registry
from cptbt.types import Point


def test_fresh_folder_never_reuses_one(tmp_path: Path) -> None:
    base = tmp_path / "m-served"
    assert fresh_folder(base) == base
    base.mkdir()
    assert fresh_folder(base) == tmp_path / "m-served-2"
    (tmp_path / "m-served-2").mkdir()
    assert fresh_folder(base) == tmp_path / "m-served-3"


def test_time_share_leaves_out_only_an_empty_none() -> None:
    assert time_share({"a.b": 0.5, "none": 0.0}) == "a.b 50%"
    assert time_share({"a.b": 0.5, "none": 0.001, "c.d": 0.004}) == \
        "a.b 50%, no output <1%, c.d <1%"
    assert time_share({"a.b": 0.9, "none": 0.1}) == "a.b 90%, no output 10%"
    assert fmt(None) == fmt(math.nan) == "—" and fmt(3.14159, " m") == "3.1 m"


def test_a_point_is_told_in_the_frame_the_mission_has() -> None:
    assert place({"x": 1.0, "y": -2.0, "north": 3.0, "east": 4.0}) == "N 3.0 m, E 4.0 m"
    assert place({"x": 1.0, "y": -2.0}) == "x 1.0 m, y -2.0 m"  # planning frame: no compass
    geo = {"x": 0.0, "y": 0.0, "north": 1.0, "east": 2.0, "lat": 32.5, "lon": -118.25}
    assert place(geo) == "N 1.0 m, E 2.0 m (32.500000, -118.250000)"


def test_a_planning_frame_summary_point_has_no_north() -> None:
    root = Path(__file__).resolve().parents[2]
    ab = load_mission(root / "missions/ab2001_strategy3.yaml", default_registry(), Environment)
    assert where(ab, Point(20, 5)) == {"x": 20, "y": 5}
    tro = load_mission(root / "missions/oblique_flow.yaml", default_registry(), Environment)
    assert {"x", "y", "north", "east"} == set(where(tro, Point(20, 5)) or {})


def test_the_up_flow_check_line_names_each_count_it_has() -> None:
    none = {"upflow_checks": 0, "upflow_vetoes": 0, "unchecked": 0, "visits": 0}
    assert upflow_check_line(none) is None
    line = upflow_check_line({**none, "upflow_checks": 1, "upflow_vetoes": 2, "trace_vetoes": 1,
                              "visits": 2, "visits_ended": 1, "unchecked": 1})
    assert line == ("  up-flow check: 1 check leg flown, 2 candidates vetoed by plume seen "
                    "up-flow of them (1 by a sub-threshold trace alone), 2 candidates visited "
                    "for want of plume seen near (1 held back, the visit timed out), 1 declared "
                    "unchecked (a check leg timed out, or no flow direction)")
    assert "held back" not in str(upflow_check_line({**none, "visits": 1, "visits_ended": 0}))


def test_the_verdict_says_what_a_success_needs_and_how_a_failure_missed_it() -> None:
    from cptbt.cli.run_text import verdict_text

    one = {"criterion": "declaration", "success_radius_m": 15.0, "sources_true": 1,
           "sources_declared": 1, "success": False, "false_declaration": True, "error_m": 16.4}
    # not "FALSE DECLARATION: declaration within 15 m", which read as the opposite
    assert verdict_text(one) == "FALSE DECLARATION: 16.4 m off, beyond the 15 m a success needs"
    assert verdict_text({**one, "success": True, "false_declaration": False, "error_m": 3.0}) \
        == "success: declaration within 15 m"
    assert verdict_text({**one, "false_declaration": False, "error_m": None}) \
        == "no success: needs a declaration within 15 m"
    # with several points a point is false when matching leaves it no source, whatever its
    # distance to the nearest (two points 10 m either side of one source: one is false)
    two = {**one, "sources_true": 2, "sources_declared": 2, "false_declarations": 1,
           "error_m": 10.0}
    assert verdict_text(two) == ("FALSE DECLARATION: 1 of 2 declared points matched to no "
                                 "source within 15 m")
    assert verdict_text({**two, "false_declaration": False, "sources_declared": 1}) \
        == "no success: needs a declaration within 15 m of every source"
    arrival = {**one, "criterion": "arrival", "success_radius_m": 1.0, "false_declaration": False}
    assert verdict_text(arrival) == "no success: needs an arrival within 1 m"
    maintain = {**arrival, "criterion": "maintain", "success": True}
    assert verdict_text(maintain) == "success: came within 1 m of the source"


def test_the_figure_title_says_whether_the_declaration_was_right() -> None:
    from cptbt.cli.run_text import short_verdict

    one = {"criterion": "declaration", "success_radius_m": 15.0, "sources_true": 1,
           "success": True, "false_declaration": False, "error_m": 3.04}
    assert short_verdict(one) == "success, error 3.0 m"
    assert short_verdict({**one, "success": False, "false_declaration": True,
                          "error_m": 16.4}) == "false declaration, 16.4 m off (success within 15 m)"
    three = {**one, "success": False, "sources_true": 3, "sources_found": 2,
             "false_declarations": 0}
    assert short_verdict(three) == "2 of 3 sources found"
    assert short_verdict({**three, "false_declarations": 1}) == "2 of 3 sources found, 1 false"


def test_sensor_faults_are_told_only_when_there_were_some() -> None:
    assert sensor_faults_line({"stuck_samples": 0, "rejected_flow_samples": 0,
                               "clock_corrections": 0}) is None
    assert sensor_faults_line({}) is None  # a summary from before the counts
    line = sensor_faults_line({"missing_samples": 1, "stuck_samples": 976,
                               "rejected_flow_samples": 1, "clock_corrections": 2})
    assert line == ("  sensor faults: 1 fluorometer sample missing (not a finite number: a "
                    "dropout); 976 fluorometer samples dropped as stuck (the same reading "
                    "for perception.stuck_after_s); 1 flow sample rejected (not finite, or "
                    "faster than perception.max_flow_speed_mps); 2 cycle times not after the "
                    "previous one, or leaping more than an hour past it, taken as one period "
                    "later")


def test_the_sources_line_says_how_the_search_for_more_ended() -> None:
    from cptbt.cli.run_text import sources_line

    one = {"sources_true": 1, "sources_declared": 1, "withdrawn": None, "flybys": None}
    assert sources_line(one) is None  # one source, one point: the verdict says it all
    held = {**one, "sources_true": 2, "sources_found": 1, "false_declarations": 0,
            "search_given_up": True, "search_end_t": 1234.0, "flybys": 0, "withdrawn": 0,
            "search_end": "candidates held or vetoed 600 s in all, none confirmed (...)",
            "held_candidate": {"x": 42.7, "y": 3.5}}
    assert sources_line(held) == (
        "  sources: 1 of 2 found, 0 false; the search for more ended at 1234.0 s: candidates "
        "held or vetoed 600 s in all, none confirmed (...), the latest held candidate "
        "(unconfirmed) at x 42.7 m, y 3.5 m; fly-bys 0, withdrawn 0")


def test_a_run_out_of_time_mid_fly_by_says_where_it_was_verifying() -> None:
    """A review: a fly-by cut short by the time limit drew and reported no candidate."""
    from cptbt.cli.run_text import why_ended

    s = {"outcome": "timeout", "criterion": "declaration", "declared_sources": [],
         "verifying_candidate": {"x": -70.2, "y": 11.6}}
    assert why_ended(s) == ("the AMP's time limit came with no declaration (a fly-by was "
                            "verifying a candidate at x -70.2 m, y 11.6 m)")
    assert why_ended({**s, "verifying_candidate": None}) == (
        "the AMP's time limit came with no declaration")
    # one of two sources declared, the second's fly-by cut short
    one = {**s, "declared_sources": [{"x": 3.0, "y": 4.0}], "held_in_known_plume": 0}
    assert why_ended(one) == ("the AMP's time limit came while it searched for more sources "
                              "(a fly-by was verifying a candidate at x -70.2 m, y 11.6 m)")


def test_a_d1_over_d0_below_one_is_explained() -> None:
    """A review read D1/D0 0.4 as an impossible tracking efficiency: D1 ends at t2, within
    13 m of the declared point (SPEC §11), so it can be shorter than D0."""
    from cptbt.cli.output import times_line

    base = {"T_F": 1.0, "T_T": 20.0, "T_D": 5.0}
    assert times_line({**base, "D1_over_D0": 0.4}).endswith(
        "D1/D0 0.4  (D1 ends within 13 m of the declared point: SPEC §11)")
    assert times_line({**base, "D1_over_D0": 1.8}).endswith("D1/D0 1.8")
    assert times_line({**base, "D1_over_D0": None}).endswith("D1/D0 —")
    # t2 = t1: 0 by the definition, said so (a review read T_T 0.0 as a measured time)
    assert times_line({**base, "T_T": 0.0, "D1_over_D0": 0.0}).endswith(
        "D1/D0 0.0  (t2 = t1: the first detection was already within 13 m of the declared "
        "point, SPEC §11)")


def test_several_declared_points_are_printed_with_their_own_error_and_source() -> None:
    from cptbt.cli.run_text import declaration_lines

    # the worst point is not the last: the error printed beside each point is its own
    s = {"declared_source": {"x": -68.5, "y": 23.8}, "search_given_up": None, "t3": 300.0,
         "error_m": 2.6, "sources_true": 2,
         "declared_sources": [{"x": -7.4, "y": -24.7, "error_m": 2.6, "nearest_source": 1},
                              {"x": -68.5, "y": 23.8, "error_m": 1.9, "nearest_source": 0}]}
    lines = declaration_lines(s)
    assert lines[-1] == ("  declared points, numbered as in trajectory.png: 1: x -7.4 m, "
                         "y -24.7 m (2.6 m from extra_sources[0]); 2: x -68.5 m, y 23.8 m "
                         "(1.9 m from source)")
    # one true source: no source to name
    one = {**s, "sources_true": 1}
    assert "from source" not in declaration_lines(one)[-1]


def test_a_served_run_says_it_left_the_oparea_on_its_navigation_track(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """A field review: ``cptbt serve`` had a farthest_outside_m of 20.6 m (a bad fix) in its
    summary and said nothing, where ``cptbt run`` prints the line; a served run knows only the
    navigation track, and says so."""
    import json
    import types

    from cptbt import cli
    from cptbt.cli.serve_cmd import print_summary

    mission = Path(__file__).resolve().parents[2] / "missions/small_oparea.yaml"
    assert cli.main(["run", str(mission), "--out", str(tmp_path / "r"),
                     "--no-figure"]) == 0
    s = json.loads((tmp_path / "r/summary.json").read_text())
    s |= {"farthest_outside_m": 20.6, "phases": {"timeline": []},
          "link": {"stop_reason": "vehicle_done", "error": None, "handed_back": False,
                   "heartbeats": 3}}
    capsys.readouterr()  # the run's own lines
    print_summary(s, types.SimpleNamespace(refusals=0))  # type: ignore[arg-type]
    out = capsys.readouterr().out
    assert "  left the OpArea: at most 20.6 m outside it (navigation track)" in out


def test_a_link_lost_after_the_give_back_ends_serve_well() -> None:
    """A field review: over MAVLink at 20% loss a mission declared, gave back, and ``serve``
    exited 1 ("link_lost") when the vehicle's last report was lost. A link lost after the AMP
    gave back is no failure of the AMP; one lost while it held control still is."""
    import types

    from cptbt.cli.serve_cmd import _done_before
    from cptbt.phases import PhaseChange

    def result(handed_back: bool, *dest: str) -> object:
        timeline = [PhaseChange(float(i), "x", d, "t") for i, d in enumerate(dest)]
        return types.SimpleNamespace(stop_reason="link_lost", handed_back=handed_back,
                                     session=types.SimpleNamespace(
                                         phases=types.SimpleNamespace(timeline=timeline)))

    assert _done_before(result(False, "amp.override", "amp.give_back", "return_to_break_off"))
    assert not _done_before(result(True, "amp.override", "amp.give_back"))  # lost holding it
    assert not _done_before(result(False, "mission_a.waypoints"))  # never took over
