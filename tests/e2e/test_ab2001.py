"""The AB 2001 missions end to end: Strategy III finds the source (AB Figs. 10-11, SPEC §12).

The fast test flies ``missions/ab2001_strategy3.yaml`` from a start 10 m down-flow of the source,
where AB's three strategies are equally good (Fig. 10) and the searcher meets the plume at once.
The slow test runs a small version of the AB Fig. 11 study; the full reproduction, with the
paper's numbers beside ours, is ``benchmarks/ab2001_reproduction.py``.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from cptbt.batch.engine import simulate
from cptbt.batch.scenario import to_sim_params
from cptbt.batch.store import load_results
from cptbt.cli.inspect_cmds import load

ROOT = Path(__file__).resolve().parents[2]
MISSION = ROOT / "missions" / "ab2001_strategy3.yaml"
SCRIPT = Path(sys.executable).parent / "cptbt"

# Success rate floor of the slow study (10 x 10 grid, 3 plume realisations per start, seed 2001).
# Measured with the filament ab_large_meander preset, timer: last_detection and find-plume
# restart: largest_area: 96.3 % on exactly this study (replicates 0-2: 97, 98, 94 %). Over 20
# replicates the rate is 91 %, 71-99 % per replicate (benchmarks/results/ab2001/report.md):
# whole plume realisations are hard or easy. 85 % sits below this study's replicates yet far
# above the contact timer's ~46 % on them.
SUCCESS_FLOOR = 0.85


# Seeds whose plume passes the start at t = 0 (in others it has meandered aside and the billiard
# takes over, returning to the axis ~100 s later: the test is about tracking, not finding).
# (Re-chosen after the any-flow billiard merged. From y = 0 exactly, the start's cross-flow side
# is a tie broken by navigation noise: in seeds 3, 5, 7 and 8 the billiard now breaks it toward
# +y, where the plume is not at t = 0.)
@pytest.mark.parametrize("seed", [9, 11])
def test_strategy_3_finds_the_source_from_a_near_start(seed: int) -> None:
    mission = load(str(MISSION))
    params = to_sim_params(mission, seed)
    (run,), _, _ = simulate(mission, params, [(30.0, 0.0, 180.0)], time_limit_s=150.0)
    assert run.outcome == "found"
    assert run.distance_at_end_m <= 1.0
    assert run.t_end < 150.0
    # Found by tracking the plume, not by the billiard stumbling on the source (10 m up-flow in
    # about 15 s with timer: last_detection).
    assert run.time_in.get("maintain_plume.strategy_3", 0.0) > 5.0
    assert run.time_in.get("find_plume.billiard_ab", 0.0) < 5.0


@pytest.mark.slow
def test_strategy_3_grid_study_success_rate(tmp_path: Path) -> None:
    res = subprocess.run(
        [str(SCRIPT), "batch", str(MISSION), "--grid", "10x10", "--runs-per-start", "3",
         "--seed", "2001", "--out", str(tmp_path), "--no-plots", "--quiet"],
        capture_output=True, text=True, timeout=1800,
    )
    assert res.returncode == 0, res.stderr
    rows = load_results(tmp_path)
    assert len(rows) == 300
    rate = sum(bool(r["success"]) for r in rows) / len(rows)
    assert rate >= SUCCESS_FLOOR, f"Strategy III success {rate:.0%} < floor {SUCCESS_FLOOR:.0%}"
    near = [r for r in rows if 25.0 <= r["start_x"] <= 35.0]
    assert sum(bool(r["success"]) for r in near) / len(near) >= 0.7
