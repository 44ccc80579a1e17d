"""The evaluation protocol (issue 14): P(fail) with its interval, time quantiles, path efficiency,
and ``--until-sem``, which adds realisations until the mean time is known well enough."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from cptbt.batch.intervals import wilson
from cptbt.batch.report import protocol, write_report
from cptbt.batch.store import load_results
from cptbt.cli import main
from cptbt.cli.batch_rounds import next_replicates

ROOT = Path(__file__).resolve().parents[2]
AB3 = str(ROOT / "missions/ab2001_strategy3.yaml")


def rows(times: list[float | None], **extra: Any) -> list[dict[str, Any]]:
    """Arrival-criterion rows: a time is a success at that time, None a failure at 300 s."""
    out = []
    for i, t in enumerate(times):
        ok = t is not None
        out.append({"configuration": "c", "success": ok, "criterion": "arrival", "t3": None,
                    "sim_time_s": t if ok else 300.0, "start": i, "replicate": 0,
                    "start_x": 0.0, "start_y": 0.0, "path_efficiency": 0.5 if ok else None,
                    **extra})
    return out


def test_protocol_counts_failures_apart_from_the_times() -> None:
    times: list[float | None] = [float(t) for t in range(1, 101)] + [None] * 10
    pr = protocol(rows(times))
    assert pr.runs == 110 and pr.failures == 10
    assert pr.p_fail == pytest.approx(10 / 110)
    assert pr.p_fail_ci == wilson(10, 110)
    assert pr.mean_s == pytest.approx(50.5)  # over the 100 successes only
    assert pr.median_s == pytest.approx(50.5)
    assert pr.p90_s == pytest.approx(np.percentile(np.arange(1, 101), 90))
    assert pr.p99_s == pytest.approx(np.percentile(np.arange(1, 101), 99))
    sem = np.std(np.arange(1, 101), ddof=1) / 10
    assert pr.sem_s == pytest.approx(sem)
    assert pr.rel_sem == pytest.approx(sem / 50.5)
    assert pr.efficiency == pytest.approx(0.5)
    assert math.isnan(pr.d0_over_d3)


def test_protocol_of_no_success_is_all_failure_and_no_times() -> None:
    pr = protocol(rows([None, None]))
    assert pr.p_fail == 1.0 and math.isnan(pr.mean_s) and math.isnan(pr.rel_sem)


def test_tables_carry_the_protocol(tmp_path: Path) -> None:
    write_report(rows([10.0, 20.0, None]), tmp_path)
    text = (tmp_path / "tables.md").read_text(encoding="utf-8")
    assert "## Evaluation protocol" in text
    assert "| c | 3 | 33.3% (" in text


@pytest.mark.parametrize(("n", "rel", "want"), [
    (10, 0.01, None),          # met
    (10, 0.04, 40),            # 10 (0.04/0.02)² = 40
    (10, 0.021, 20),           # at least one more round
    (10, math.inf, 20),        # fewer than two successes: double
    (10, 0.2, 100),            # capped
    (100, 0.2, None),          # at the cap
])
def test_next_replicates(n: int, rel: float, want: int | None) -> None:
    assert next_replicates(n, rel, 0.02, 10, 100) == want


def test_until_sem_adds_realisations_and_resumes(tmp_path: Path,
                                                 capsys: pytest.CaptureFixture[str]) -> None:
    args = ["batch", AB3, "--starts", "60,10", "--runs-per-start", "2", "--until-sem", "0.001",
            "--max-runs-per-start", "6", "--time-limit", "120", "--workers", "1", "--no-plots",
            "--out", str(tmp_path)]
    assert main(args) == 0
    first = load_results(tmp_path)
    assert len(first) == 6  # 2, then more up to the cap: the target is out of reach
    out = capsys.readouterr().out
    assert "realisations per start" in out
    # Its own earlier rounds are not "resumed from disk": nothing was there before it began.
    assert "6 missions (0 groups resumed from disk)" in out
    parts = sorted(p.name for p in (tmp_path / "parts").glob("*.parquet"))
    (tmp_path / "parts" / parts[-1]).unlink()  # as if interrupted in the last round
    assert main(args) == 0
    n = len(parts) - 1
    assert f"({n} group{'s' * (n != 1)} resumed from disk)" in capsys.readouterr().out
    again = load_results(tmp_path)
    key = lambda r: (r["replicate"], r["start"])  # noqa: E731
    strip = [{k: v for k, v in r.items() if k != "wall_time_s"} for r in sorted(first, key=key)]
    assert strip == [{k: v for k, v in r.items() if k != "wall_time_s"}
                     for r in sorted(again, key=key)]


@pytest.mark.parametrize(("extra", "fragment"), [
    (["--max-runs-per-start", "3"], "without --until-sem"),  # would be ignored silently
    (["--runs-per-start", "5", "--until-sem", "0.1", "--max-runs-per-start", "2"],
     "below the first round"),  # would run past the stated maximum
])
def test_a_cap_that_cannot_hold_is_a_usage_error(tmp_path: Path, extra: list[str],
                                                 fragment: str,
                                                 capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "o"
    assert main(["batch", AB3, "--starts", "60,10", *extra, "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and fragment in err[0]
    assert not out.exists()


def test_a_tail_percentile_needs_the_runs_to_have_one() -> None:
    """A review read a "99th percentile" of 4 runs (the largest of them): the 90th is given
    from 10 successes, the 99th from 100."""
    few = protocol(rows([float(t) for t in range(1, 10)]))  # 9 successes
    assert math.isnan(few.p90_s) and math.isnan(few.p99_s) and few.median_s == 5.0
    ten = protocol(rows([float(t) for t in range(1, 11)]))
    assert ten.p90_s == pytest.approx(np.percentile(np.arange(1, 11), 90))
    assert math.isnan(ten.p99_s)
