"""Intervals over a study's runs count its plume realisations: the starts of a replicate share
one plume, and their runs are not independent (a paper reviewer's 3-plume AB study printed an
interval that excluded the project's own 10 000-run rate)."""

from __future__ import annotations

import math

import pytest

from cptbt.batch.intervals import (
    design_effect,
    mean_sem,
    plumes_note,
    rate_interval,
    t975,
    wilson,
)


def _grid(rates: list[int], starts: int = 100) -> tuple[list[dict[str, int]], list[bool]]:
    rows, hits = [], []
    for r, wins in enumerate(rates):
        for k in range(starts):
            rows.append({"replicate": r, "start": k})
            hits.append(k < wins)
    return rows, hits


def test_three_plumes_of_a_hundred_starts_give_an_interval_over_the_plumes() -> None:
    """The reviewer's study: 97, 98 and 94 of 100 on three plumes. Read as 300 independent
    runs, 93.6%-97.9%, excluding the 10 000-run 89.9%; over three plumes it does not."""
    rows, hits = _grid([97, 98, 94])
    assert wilson(289, 300) == pytest.approx((0.936, 0.979), abs=5e-4)
    lo, hi = rate_interval(rows, hits)
    assert lo < 0.899 < 0.963 < hi <= 1.0
    assert design_effect(rows, [float(h) for h in hits]) > 1.0


def test_plumes_that_differ_widen_the_interval_beyond_the_runs() -> None:
    alike, spread = _grid([90, 90, 90, 90, 90, 90]), _grid([60, 99, 80, 99, 95, 67])
    a_lo, a_hi = rate_interval(*alike)
    s_lo, s_hi = rate_interval(*spread)
    assert s_hi - s_lo > 3 * (a_hi - a_lo)
    # alike plumes: no design effect, only Student's t on 5 degrees of freedom
    assert design_effect(alike[0], [float(h) for h in alike[1]]) == 1.0
    assert (a_lo, a_hi) == pytest.approx(wilson(540, 600, t975(5)))


def test_one_run_a_plume_is_wilsons_interval_and_one_plume_is_said() -> None:
    rows = [{"replicate": r} for r in range(30)]
    hits = [r % 10 != 0 for r in range(30)]
    assert rate_interval(rows, hits) == pytest.approx(wilson(27, 30))
    assert plumes_note(rows) is None
    one = [{"replicate": 0, "start": k} for k in range(30)]
    assert rate_interval(one, hits) == pytest.approx(wilson(27, 30))
    note = plumes_note(one)
    assert note is not None and "one plume realisation" in note


def test_a_mean_times_error_counts_the_plumes_and_is_never_below_the_runs() -> None:
    rows = [{"replicate": r, "start": k} for r in range(4) for k in range(25)]
    alike = [100.0 + (k % 5) for r in range(4) for k in range(25)]
    apart = [100.0 + 20 * r + (k % 5) for r in range(4) for k in range(25)]
    iid = math.sqrt(sum((v - sum(apart) / 100) ** 2 for v in apart) / 99 / 100)
    assert mean_sem(rows, apart) > 2 * iid
    iid_alike = math.sqrt(sum((v - 102.0) ** 2 for v in alike) / 99 / 100)
    assert mean_sem(rows, alike) >= iid_alike
    assert math.isnan(mean_sem(rows[:1], alike[:1]))


def test_student_t_falls_to_the_normal_quantile() -> None:
    assert t975(1) == pytest.approx(12.706) and t975(30) == pytest.approx(2.042)
    assert 1.96 < t975(60) < 2.01 and 1.96 < t975(500) < 1.965 and math.isnan(t975(0))
    assert t975(120) > t975(121) > t975(122)  # no step (a diff review saw one at 121)


def test_a_paired_difference_from_one_plume_is_one_piece_of_evidence() -> None:
    """Ten starts of one plume that one configuration wins and the other loses: read as ten
    independent pairs, the exact McNemar p is 0.002; over the plumes it is what one plume can
    say, 1. Five plumes all one way: 2/32, the least a test over 5 plumes can give (a review
    saw Durkalski's asymptotic chi-square give 0.029). One pair a plume: the exact test."""
    from cptbt.batch.comparison import mcnemar
    from cptbt.batch.intervals import clustered_mcnemar

    def plumes(wins: list[int], starts: int = 10) -> list[tuple[dict, dict]]:  # type: ignore[type-arg]
        return [({"replicate": r, "start": k, "success": True},
                 {"replicate": r, "start": k, "success": k >= w})
                for r, w in enumerate(wins) for k in range(starts)]

    assert mcnemar(10, 0) == pytest.approx(0.00195, abs=1e-5)
    assert clustered_mcnemar(plumes([10, 0, 0])) == pytest.approx(1.0)
    assert clustered_mcnemar(plumes([4, 5, 6, 6, 8])) == pytest.approx(2 / 32)
    # 12 plumes all one way: 2/4096; and one plume against, by one start, of 8
    assert clustered_mcnemar(plumes([2] * 12)) == pytest.approx(2 / 4096)
    mixed = plumes([3, 3, 3, 3, 3, 3, 3]) + [({"replicate": 9, "start": k, "success": k != 0},
                                            {"replicate": 9, "start": k, "success": True})
                                           for k in range(10)]
    p = clustered_mcnemar(mixed)
    assert p is not None and 2 / 256 < p < 0.05
    single = [({"replicate": r, "success": True}, {"replicate": r, "success": r % 2 == 0})
              for r in range(8)]
    assert clustered_mcnemar(single) is None


def test_few_plumes_of_several_starts_say_why_their_interval_is_wide() -> None:
    """A diff review read two plumes' 5.7%-100% as a bug: the table now says why."""
    rows, hits = _grid([23, 23], starts=25)
    lo, hi = rate_interval(rows, hits)
    assert hi - lo > 0.5
    note = plumes_note(rows)
    assert note is not None and note.startswith("2 plume realisations") and "12.7" in note
    assert plumes_note(_grid([9] * 12, starts=10)[0]) is None
    assert plumes_note([{"replicate": r} for r in range(3)]) is None  # one run a plume


def test_a_mean_difference_over_few_plumes_has_students_t_on_the_plumes_less_one() -> None:
    """A review: a paired time difference over 4 plumes printed ± SE alone, which a reader
    doubles; with 4 plumes the 95% half-width is 3.18 SE (3 degrees of freedom)."""
    from cptbt.batch.intervals import mean_df, mean_interval, mean_sem

    rows = [{"replicate": r} for r in range(4) for _ in range(2)]
    values = [-300.0, -290.0, -250.0, -260.0, -310.0, -300.0, -240.0, -250.0]
    assert mean_df(rows) == 3
    lo, hi = mean_interval(rows, values)
    half = 3.182 * mean_sem(rows, values)
    mean = sum(values) / len(values)
    assert (lo, hi) == pytest.approx((mean - half, mean + half))
    one_each = [{"replicate": r} for r in range(8)]
    assert mean_df(one_each) == 7  # independent runs: the runs less one
    assert mean_df([{"replicate": 0}] * 8) == 7  # one plume: the runs (and a note says so)


def test_a_p_at_the_floor_of_few_plumes_is_said() -> None:
    """A review read 12 to 0 over 3 plumes, p 0.25, as "not significant": 0.25 is the least a
    test over 3 plumes can give, and the paired table says so."""
    from cptbt.batch.comparison import paired_table

    base = {"criterion": "declaration", "t3": 50.0, "start_x": 0.0, "start_y": 0.0}
    groups = {c: [{**base, "configuration": c, "replicate": r, "start": i,
                   "success": c == "b"} for r in range(3) for i in range(4)] for c in "ab"}
    (row,) = [line for line in paired_table(groups) if line.startswith("| b ")]
    assert "| 12 / 0 | 0.25 (the least a test over the 3 plumes that differ can give) |" in row, row
