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


def test_the_map_panel_marks_every_kind_of_point_the_report_names() -> None:
    """A review saw a held candidate (on the true third source) left off the figure."""
    import numpy as np

    from cptbt.batch.figures import pyplot
    from cptbt.batch.map_figure import map_panel
    from cptbt.frames import OpArea
    from cptbt.types import Point, SourceBelief

    plt = pyplot()
    xs, ys = np.linspace(-45, 45, 10), np.linspace(-45, 45, 10)
    post = np.full((10, 10), 0.01)
    belief = SourceBelief(100.0, xs, ys, post, (Point(10, 0),))
    fig, ax = plt.subplots()
    report = {"withdrawn_at": [(1.0, 2.0)], "superseded_at": [(5.0, 0.0)],
              "held_at": (-20.5, -34.7), "verifying_at": (30.0, 12.0)}
    map_panel(ax, belief, OpArea(-50, 50, -50, 50), [Point(10, 0), Point(-20, -35)],
              [Point(10, 0)], report, plt)
    marks = {line.get_label(): (list(line.get_xdata()), list(line.get_ydata()))
             for line in ax.lines}
    assert marks["withdrawn after fly-by"] == ([1.0], [2.0])
    assert marks["replaced declaration (taken for the same source)"] == ([5.0], [0.0])
    assert marks["held candidate (unconfirmed: in a declared source's plume)"] == (
        [-20.5], [-34.7])
    # a run out of time mid-fly-by (a review: where it was verifying was drawn nowhere)
    assert marks["candidate a fly-by was verifying"] == ([30.0], [12.0])
    plt.close(fig)


def test_the_current_arrows_label_keeps_off_its_head() -> None:
    """A review: the label below the tail covered the head of a current with a downward part
    (y is drawn down); it goes on the side of the tail the head does not reach."""
    from cptbt.batch.figures import flow_arrow, pyplot
    from cptbt.frames import OpArea

    plt = pyplot()
    for flow_deg, label_above in ((90.0, True), (135.0, True), (270.0, False), (0.0, False)):
        fig, ax = plt.subplots()
        flow_arrow(ax, OpArea(-50, 50, -50, 50), flow_deg)
        arrow = next(t for t in ax.texts if t.get_text() == "")
        label = next(t for t in ax.texts if t.get_text() == "mean current")
        tail_y, head_y = arrow.xyann[1], arrow.xy[1]
        assert (label.get_position()[1] < tail_y) == label_above, flow_deg
        if abs(head_y - tail_y) > 1e-9:  # the label lies away from the head
            assert (label.get_position()[1] - tail_y) * (head_y - tail_y) < 0, flow_deg
        plt.close(fig)


def test_the_current_arrow_keeps_off_the_markers_before_the_track() -> None:
    """A review's north-up figure had the "mean current" label on the start markers: their
    corner had the fewest track points. A corner clear of markers wins over fewer track
    points, and a marker just beside the arrow's box counts (the label reaches past it)."""
    import numpy as np

    from cptbt.batch.figures import flow_arrow, pyplot
    from cptbt.frames import OpArea

    plt = pyplot()
    area = OpArea(-100, 100, -50, 50)  # size 12 m; corners inset 16.8 m
    track = np.array([[83.2, 33.2], [-83.2, -33.2], [83.2, -33.2]])  # one in three corners
    start = np.array([[-80.0, 20.0]])  # 1.2 m beyond the fourth corner's box

    def tail(**marks: object) -> tuple[float, float]:
        fig, ax = plt.subplots()
        flow_arrow(ax, area, 0.0, np.vstack([track, start]), **marks)  # type: ignore[arg-type]
        at = next(t for t in ax.texts if t.get_text() == "").xyann
        plt.close(fig)
        return (round(at[0], 6), round(at[1], 6))

    assert tail() == (-83.2, 33.2)  # markers only as points of the track: on the start
    assert tail(marks=start) != (-83.2, 33.2)  # told as markers: kept clear of them
