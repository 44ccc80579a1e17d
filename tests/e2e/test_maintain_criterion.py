"""The ``maintain`` evaluation criterion: AB §4.3's maintain-time protocol (Fig. 9).

A run ends on the first cycle after the first detection on which find-plume drives again, and
``T_M`` is AB eq. 3's last-minus-first detection of each contact, summed over the run's
contacts (the time spent reacquiring between them is AB's ``T_R``, not ``T_M``).
"""

from __future__ import annotations

import itertools
from pathlib import Path

import numpy as np
import pytest

from cptbt.batch.engine import simulate
from cptbt.batch.outcome import Outcome, contact_ended, judge
from cptbt.batch.scenario import to_sim_params
from cptbt.batch.summary import summarise
from cptbt.cli.inspect_cmds import load
from cptbt.evaluation import EvaluationSpec
from cptbt.types import Point

ROOT = Path(__file__).resolve().parents[2]
FIG9 = ROOT / "missions" / "ab2001_fig9.yaml"


@pytest.mark.parametrize(
    ("t1", "active", "ended"),
    [
        (None, "find_plume.billiard_ab", False),  # no contact yet: searching is not losing
        (3.0, "maintain_plume.strategy_3", False),
        (3.0, "reacquire_plume.strategy_3", False),  # the cast may still recover contact
        (3.0, "safety.oparea", False),  # a wall turn does not end contact
        (3.0, "find_plume.billiard_ab", True),
        (3.0, None, True),  # nothing drives
    ],
)
def test_contact_ended(t1: float | None, active: str | None, ended: bool) -> None:
    assert contact_ended(t1, active) is ended


def test_maintain_verdict_is_the_closest_approach() -> None:
    spec = EvaluationSpec(criterion="maintain", success_radius_m=1.0)
    near = judge(Outcome.CONTACT_LOST, None, Point(20, 0), 30.0, spec, closest_m=0.5)
    far = judge(Outcome.CONTACT_LOST, None, Point(20, 0), 30.0, spec, closest_m=4.0)
    assert (near.success, near.error_m) == (True, 0.5)
    assert (far.success, far.error_m) == (False, 4.0)


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_fig9_run_ends_when_find_plume_takes_over(seed: int) -> None:
    mission = load(str(FIG9))
    (run,), _, _ = simulate(mission, to_sim_params(mission, seed), [(60.0, 5.0, 180.0)],
                            trace=True)
    assert run.outcome == Outcome.CONTACT_LOST
    trace = run.trace
    assert trace is not None
    t = np.asarray(trace["t"])
    active = [a.partition(".")[0] for a in trace["active"]]
    hits = t[np.asarray(trace["detected"], dtype=bool)]
    assert run.t1 == hits[0]
    after = [a for tk, a in zip(t, active, strict=True) if tk >= hits[0]]
    # The last cycle is the first one after the first detection that find-plume drives.
    assert after[-1] == "find_plume"
    assert "find_plume" not in after[:-1]
    # Contact is lost for good at T_Last + T_W (T_W = give_up_s = 2 s), give or take a cycle.
    assert run.t_end == pytest.approx(hits[-1] + 2.0, abs=0.11)
    summary = summarise(run, mission, Point(20, 0), seed, 0.0)
    # each contact's span, a contact ending when no detection follows within λ (a review: the
    # span over the whole run had counted the casts between contacts as time in the plume)
    # (the planner's contacts: one ends at a cycle more than λ after its last detection)
    lam, dt = mission.perception.lambda_s, 1.0 / mission.cycle_hz
    contacts, first = [], hits[0]
    for a, b in itertools.pairwise(hits):
        if b - a > lam + dt + 1e-9:
            contacts.append(a - first)
            first = b
    contacts.append(hits[-1] - first)
    assert summary.T_M is not None
    assert pytest.approx(sum(contacts), abs=1e-9) == summary.T_M
    assert hits[-1] - hits[0] + 1e-9 >= summary.T_M
    assert summary.outcome == "contact_lost"
    assert summary.closest_approach_m is not None and summary.closest_approach_m <= 60.0


def test_other_criteria_have_no_maintain_time() -> None:
    mission = load(str(ROOT / "missions" / "ab2001_strategy3.yaml"))
    (run,), _, _ = simulate(mission, to_sim_params(mission, 9), [(30.0, 0.0, 180.0)],
                            time_limit_s=20.0)
    summary = summarise(run, mission, Point(20, 0), 9, 0.0)
    assert summary.T_M is None
    assert summary.closest_approach_m is not None


def test_maintain_criterion_needs_a_maintain_behaviour(tmp_path: Path, capsys) -> None:  # type: ignore[no-untyped-def]
    from cptbt.cli import main

    text = FIG9.read_text(encoding="utf-8")
    text = text.replace("  - maintain_plume: {variant: strategy_3, timer: last_detection}\n", "")
    text = text.replace("  - reacquire_plume: {variant: strategy_3, give_up_s: 2}\n", "")
    bad = tmp_path / "no_maintain.yaml"
    bad.write_text(text, encoding="utf-8")
    assert main(["validate", str(bad)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1
    assert "evaluation.criterion" in err[0] and "there is none" in err[0]


@pytest.mark.parametrize(("hits", "t_m"), [
    ([2.0], 0.0),  # a single detection
    ([2.0, 3.0], 1.0),  # λ apart: one contact
    ([2.0, 3.1], 1.1),  # λ + a cycle: no cycle out of the plume between, one contact
    ([2.0, 3.2], 0.0),  # a cycle out of the plume between: two contacts of 0 s
    ([2.0, 2.5, 3.0, 4.2, 5.0], 1.0 + 0.8),  # two contacts; the 1.2-s gap is AB's T_R
])
def test_t_m_sums_the_planners_contacts(hits: list[float], t_m: float) -> None:
    """AB's T_M is the time in contact (a reviewer of the papers: the whole span had counted
    the casts between contacts); a contact ends where the planner's does, at a cycle more
    than λ after its last detection (a diff review: split at λ, a gap the planner never left
    the plume in was dropped). λ = 1 s at 10 Hz, as AB's Fig. 9 missions."""
    from types import SimpleNamespace

    from cptbt.batch.summary import _maintain_time

    t = np.round(np.arange(0.0, 6.0, 0.1), 9)
    detected = np.isin(t, np.round(hits, 9))
    run = SimpleNamespace(t1=hits[0], path_t=t, index=0,
                          recorder=SimpleNamespace(column=lambda name, i: detected))
    assert _maintain_time(run, 1.0, 0.1) == pytest.approx(t_m, abs=1e-9)  # type: ignore[arg-type]
