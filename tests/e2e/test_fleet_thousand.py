"""The fleet planner flies 1,000 AB Fig. 11 missions exactly as the per-vehicle planner does.

Ten plume realisations of the Strategy III study (10 x 10 starts each, the seeds ``cptbt batch``
uses): outcome, end time, end distance, declared point, first detection, lost contacts and the
whole true path must be identical. ``benchmarks/fleet_equivalence.py`` runs the same comparison
(also over Strategies I and II) and reports the CPU time of both planners.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

from cptbt.batch.starts import grid_starts
from cptbt.batch.study import Study, configurations
from cptbt.batch.worker import fly_group
from cptbt.cli.inspect_cmds import load

MISSION = Path(__file__).resolve().parents[2] / "missions" / "ab2001_strategy3.yaml"


@pytest.mark.slow
def test_a_thousand_ab_missions_fly_identically(monkeypatch: pytest.MonkeyPatch) -> None:
    m = load(str(MISSION))
    tasks = Study(configurations(m, [], str(MISSION)), grid_starts(m, 10, 10), 10, 2001, 0.0,
                  None).tasks()
    missions = found = 0
    for task in tasks:
        flown = {}
        for planner in ("tree", "fleet"):
            monkeypatch.setitem(os.environ, "CPTBT_PLANNER", planner)
            _, runs, _, _ = fly_group(task)
            flown[planner] = runs
        for a, b in zip(flown["tree"], flown["fleet"], strict=True):
            assert a.planner is not None and b.planner is None  # really both paths
            key = f"replicate {task.replicate} start {a.index}"
            assert (a.outcome, a.t_end, a.distance_at_end_m, a.declared, a.t1,
                    a.lost_contacts) == (b.outcome, b.t_end, b.distance_at_end_m, b.declared,
                                         b.t1, b.lost_contacts), key
            assert np.array_equal(a.path_true, b.path_true), key
            missions += 1
            found += a.outcome == "found"
    assert missions == 1000
    assert 0 < found < 1000
