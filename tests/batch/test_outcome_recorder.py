"""The run pipeline's parts alone: stop policy, outcomes, verdicts and the recorder."""

from __future__ import annotations

import numpy as np
import pytest

from cptbt.batch.outcome import Outcome, judge, outcome_of
from cptbt.batch.recorder import Recorder
from cptbt.evaluation import EvaluationSpec
from cptbt.policy import RELINQUISH_OUTSIDE_M, give_back_trigger
from cptbt.types import Point

SOURCE = Point(0.0, 0.0)


@pytest.mark.parametrize(
    ("done", "elapsed", "outside", "trigger"),
    [
        (True, 10.0, 50.0, "declared_home"),  # done wins over everything
        (False, 100.0, 50.0, "amp_time_limit"),  # then the time limit
        (False, 10.0, RELINQUISH_OUTSIDE_M + 0.1, "outside_op_area"),
        (False, 10.0, RELINQUISH_OUTSIDE_M, None),  # exactly 30 m outside: keeps control
        (False, 100.0 - 1e-12, 0.0, "amp_time_limit"),  # float slack on the limit
        (False, 99.0, 0.0, None),
    ],
)
def test_give_back_policy(done: bool, elapsed: float, outside: float, trigger: str | None) -> None:
    due = give_back_trigger(done, elapsed, 100.0, outside)
    assert (due[0] if due else None) == trigger


def test_outcomes_of_triggers() -> None:
    assert outcome_of("declared_home", True) is Outcome.DECLARED
    assert outcome_of("amp_time_limit", False) is Outcome.TIMEOUT
    assert outcome_of("amp_time_limit", True) is Outcome.DECLARED  # declared, on the way home
    assert outcome_of("outside_op_area", False) is Outcome.RELINQUISHED
    assert outcome_of("watchdog_timeout", False) is Outcome.WATCHDOG
    assert outcome_of("arrival", False) is Outcome.FOUND
    assert outcome_of("mission_a_complete", False) is Outcome.MISSION_ENDED


TRO = EvaluationSpec(criterion="declaration", success_radius_m=15.0)
AB = EvaluationSpec(criterion="arrival", success_radius_m=1.0)


@pytest.mark.parametrize(
    ("outcome", "declared", "evaluation", "success", "false", "error"),
    [
        (Outcome.DECLARED, Point(9.0, 12.0), TRO, True, False, 15.0),  # on the radius
        (Outcome.DECLARED, Point(9.0, 12.1), TRO, False, True, None),  # just beyond: false
        (Outcome.TIMEOUT, None, TRO, False, False, None),
        (Outcome.FOUND, None, AB, True, False, 0.7),  # error = distance when it stopped
        (Outcome.TIMEOUT, None, AB, False, False, 0.7),
        (Outcome.FOUND, Point(5.0, 0.0), AB, True, True, 5.0),  # a wild declaration is false
    ],
)
def test_verdicts(outcome, declared, evaluation, success, false, error) -> None:  # type: ignore[no-untyped-def]
    v = judge(outcome, declared, SOURCE, 0.7, evaluation)
    assert (v.success, v.false_declaration) == (success, false)
    if error is not None:
        assert v.error_m == pytest.approx(error)


def test_recorder_rows_per_vehicle_codes_and_growth() -> None:
    rec = Recorder(3, capacity=2, trace=False)
    a, b = rec.code("find_plume.billiard"), rec.code("maintain_plume.track_in")
    assert rec.code("find_plume.billiard") == a and rec.code(None) == 0
    for k in range(20):  # vehicle 2 stops after 5 rows; arrays grow past the capacity
        idx = np.array([0, 1, 2] if k < 5 else [0, 1])
        rec.add(idx, {"t": float(k), "x": idx * 10.0 + k, "y": 0.0, "x_est": 1.0, "y_est": 2.0},
                detected=idx == 1, active=np.where(idx == 1, b, a).astype(np.int16))
    assert list(rec.count) == [20, 20, 5] and rec.capacity >= 20
    assert rec.column("t", 2).tolist() == [0.0, 1.0, 2.0, 3.0, 4.0]
    assert rec.xy(1)[-1].tolist() == [29.0, 0.0]
    assert rec.xy(0, estimated=True)[0].tolist() == [1.0, 2.0]
    assert rec.column("detected", 1).all() and not rec.column("detected", 0).any()
    # each cycle holds until the next (t = 0..19 s: 19 s), whatever the nominal period
    assert rec.time_in(1) == {"maintain_plume.track_in": 19.0}
    assert rec.time_in(2) == {"find_plume.billiard": 4.0}
    assert rec.active_names(2) == ["find_plume.billiard"] * 5
    table = rec.table(0)
    assert set(table) == {"t", "x", "y", "x_est", "y_est", "detected", "active"}
    assert len(table["active"]) == 20


def test_recorder_columns_a_row_does_not_give_are_nan() -> None:
    rec = Recorder(2, capacity=2, trace=True)
    for k in range(5):  # past the capacity: the grown arrays keep the rule
        values = {"t": float(k), "x": 1.0, "y": 2.0, "x_est": 1.0, "y_est": 2.0}
        if k % 2:
            values["concentration"] = 0.5
        rec.add(np.array([0, 1]), values)
    assert np.isnan(rec.column("heading", 0)).all()
    conc = rec.column("concentration", 1)
    assert np.isnan(conc[::2]).all() and (conc[1::2] == 0.5).all()
