"""``cptbt batch --until-sem``'s rounds: how precise the study is, and how many realisations
per start to go on to."""

from __future__ import annotations

import math
from typing import Any


def worst_rel_sem(rows: list[dict[str, Any]]) -> float:
    """The largest relative SEM of the mean time to source over the configurations (inf where a
    configuration has fewer than two successes)."""
    from cptbt.batch.report import by_configuration, protocol

    worst = 0.0
    for group in by_configuration(rows).values():
        rel = protocol(group).rel_sem
        worst = max(worst, rel if math.isfinite(rel) else math.inf)
    return worst


def next_replicates(n: int, rel_sem: float, target: float, step: int,
                    max_n: int) -> int | None:
    """How many realisations per start to go on to, or None to stop.

    The SEM falls as 1/sqrt(n), so ``n (rel_sem / target)²`` is the estimate, rounded up to a
    whole number of rounds of ``step`` and at least one more round. The choice depends only on
    the rows of the first ``n`` realisations, which do not depend on how the study was
    interrupted, so a resumed study takes the same steps.
    """
    if rel_sem <= target or n >= max_n:
        return None
    want = n * (rel_sem / target) ** 2 if math.isfinite(rel_sem) else 2 * n
    rounds = max(1, math.ceil((min(want, max_n) - n) / step))
    return min(max_n, n + rounds * step)
