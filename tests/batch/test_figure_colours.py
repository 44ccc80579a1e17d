"""Track colours of trajectory.png: by behaviour family, and apart for what a behaviour with
several jobs is doing (the active name's "(...)" part)."""

from __future__ import annotations

from cptbt.batch.figures import ACTIVITY_COLOURS, BEHAVIOUR_COLOURS, _colour, _line_style


def test_a_behaviours_jobs_are_coloured_apart_and_unknown_ones_by_family() -> None:
    base = "declare_source.likelihood_map"
    assert _colour(base) == BEHAVIOUR_COLOURS["declare_source"]
    jobs = {_colour(f"{base} ({job})") for job in ("check leg", "visit", "search on", "fly-by")}
    assert len(jobs) == 4 and BEHAVIOUR_COLOURS["declare_source"] not in jobs
    assert _colour(f"{base} (home)") == BEHAVIOUR_COLOURS["return_home"]
    assert _colour(f"{base} (something new)") == BEHAVIOUR_COLOURS["declare_source"]
    assert _colour("maintain_plume.track_in") == BEHAVIOUR_COLOURS["track_in"]
    assert _colour("my_family.my_variant") not in {*BEHAVIOUR_COLOURS.values(),
                                                   *ACTIVITY_COLOURS.values()}


def test_the_trip_home_and_a_visit_are_dashed_the_rest_solid() -> None:
    base = "declare_source.likelihood_map"
    assert _line_style(f"{base} (home)") == _line_style(f"{base} (visit)") == "--"
    assert _line_style(f"{base} (check leg)") == _line_style(base) == "-"
