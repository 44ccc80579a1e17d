"""Confidence intervals for a study's rates and mean times, counting plumes, not only runs.

Every start of a replicate flies one plume realisation (AB's searchers shared one plume), so
the runs of a replicate are not independent: a plume that is hard for one start is hard for its
neighbours. A rate's interval computed as if every run were independent is then too narrow. A
paper reviewer's AB Fig. 11 study of 300 runs (3 plumes of 100 starts) printed 96.3% (95% CI
93.6-97.9%), an interval that excluded the project's own 10 000-run figure, 89.9% +- 0.7 (whose
standard error, over its 100 plumes, is 2.3 times the independent-runs one).

The intervals here are cluster-robust, the replicate being the cluster. For a mean ``m`` of
values ``y`` over ``N`` runs in ``R`` replicates, the variance of ``m`` is estimated as
``R / (R - 1) * sum_r (sum_{i in r} (y_i - m))^2 / N^2`` (the sandwich estimator), and the
design effect is its ratio to the independent-runs variance, at least 1 (a few replicates can
make it fall below by chance; the interval is never narrower than the runs alone make it).

- A rate: Wilson's score interval at the effective number of runs ``N / design effect``, with
  Student's t on ``R - 1`` degrees of freedom for the normal quantile (few plumes, wide
  interval: the variance is estimated from the replicates; Korn & Graubard 1998's
  degrees-of-freedom adjustment). One replicate: the plumes' spread cannot be estimated, and
  the interval is the runs' alone, which :func:`plumes_note` says.
- A mean time: its standard error is the larger of the cluster-robust and the independent one.

Runs that fly one start per replicate (MSN007's studies) are clusters of one, independent: the
interval is Wilson's, whose binomial variance is known, not estimated.
"""

from __future__ import annotations

import math
from collections import defaultdict
from collections.abc import Sequence
from typing import Any

import numpy as np

Rows = Sequence[dict[str, Any]]

_T975 = (12.706, 4.303, 3.182, 2.776, 2.571, 2.447, 2.365, 2.306, 2.262, 2.228, 2.201, 2.179,
         2.160, 2.145, 2.131, 2.120, 2.110, 2.101, 2.093, 2.086, 2.080, 2.074, 2.069, 2.064,
         2.060, 2.056, 2.052, 2.048, 2.045, 2.042)
"""Student's t, two-sided 95%, for 1-30 degrees of freedom."""


def t975(df: int) -> float:
    """Student's t quantile for a two-sided 95% interval (beyond 30 degrees of freedom, a
    close approximation tending to 1.96)."""
    if df < 1:
        return math.nan
    if df <= len(_T975):
        return _T975[df - 1]
    return 1.96 + 2.4 / df  # within 0.003 of the quantile beyond 30, and no step


def wilson(successes: float, n: float, z: float = 1.96) -> tuple[float, float]:
    """Wilson score interval of a proportion (95% by default); (nan, nan) for n = 0. ``n`` may
    be an effective (fractional) number of runs, ``successes`` then scaled alike."""
    if n <= 0:
        return math.nan, math.nan
    p = successes / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z * math.sqrt(max(p * (1 - p), 0.0) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    return max(0.0, centre - half), min(1.0, centre + half)


def _clusters(rows: Rows, values: Sequence[float]) -> list[list[float]]:
    by: dict[Any, list[float]] = defaultdict(list)
    for r, v in zip(rows, values, strict=True):
        by[r.get("replicate", id(r))].append(v)
    return list(by.values())


def replicates(rows: Rows) -> int:
    """How many plume realisations (replicates) the rows fly."""
    return len({r.get("replicate", id(r)) for r in rows})


def design_effect(rows: Rows, values: Sequence[float]) -> float:
    """The cluster-robust variance of the values' mean over the independent-runs one, at least
    1 (NaN with fewer than two replicates, or no spread to compare with)."""
    groups = _clusters(rows, values)
    n, k = len(values), len(groups)
    if k < 2 or n < 2:
        return math.nan
    mean = sum(values) / n
    iid = sum((v - mean) ** 2 for v in values) / (n - 1) / n
    robust = k / (k - 1) * sum(sum(v - mean for v in g) ** 2 for g in groups) / (n * n)
    if iid <= 0.0:
        return 1.0 if robust <= 0.0 else math.inf
    return max(1.0, robust / iid)


def rate_interval(rows: Rows, hits: Sequence[bool]) -> tuple[float, float]:
    """95% interval of a rate over the rows (see the module's docstring)."""
    n = len(rows)
    if n == 0:
        return math.nan, math.nan
    k = replicates(rows)
    wins = float(sum(bool(h) for h in hits))
    deff = design_effect(rows, [float(bool(h)) for h in hits])
    if k < 2 or k == n or not math.isfinite(deff):  # one plume (or none to compare): the
        # runs alone; one run a plume: independent runs, whose binomial variance is known
        return wilson(wins, n)
    if deff == math.inf:
        return 0.0, 1.0
    eff = n / deff
    return wilson(wins * eff / n, eff, t975(k - 1))


def mean_sem(rows: Rows, values: Sequence[float]) -> float:
    """Standard error of the values' mean: the larger of the cluster-robust and the
    independent-runs one (NaN for fewer than two values)."""
    n = len(values)
    if n < 2:
        return math.nan
    mean = sum(values) / n
    iid = math.sqrt(sum((v - mean) ** 2 for v in values) / (n - 1) / n)
    deff = design_effect(rows, values)
    return iid * math.sqrt(deff) if math.isfinite(deff) else iid


def mean_df(rows: Rows) -> int:
    """Degrees of freedom of :func:`mean_sem`: plumes less one where a plume holds several of
    the values (Korn & Graubard, as :func:`rate_interval`), else the values less one."""
    n, k = len(rows), replicates(rows)
    return k - 1 if 2 <= k < n else n - 1


def mean_interval(rows: Rows, values: Sequence[float]) -> tuple[float, float]:
    """95% interval of the values' mean: ± :func:`mean_sem` times Student's t on
    :func:`mean_df` degrees of freedom (NaN for fewer than two values)."""
    half = mean_sem(rows, values) * t975(mean_df(rows))
    mean = sum(values) / len(values) if values else math.nan
    return mean - half, mean + half


FEW_PLUMES = 10
"""Fewer plume realisations than this, of several starts each, are said to widen an interval
(Student's t on 1 degree of freedom is 12.7: two plumes' interval reads near 0-100%, which a
diff review read as a bug)."""


def plumes_note(rows: Rows) -> str | None:
    """What a reader of an interval over these rows must know: one plume realisation only, or
    few of several starts each (the interval is then wide, and why)."""
    k = replicates(rows)
    if k < 2 and len(rows) > 1:
        return ("one plume realisation: its interval covers the starts' spread only, not the "
                "plumes' (fly more replicates: --runs-per-start)")
    if 2 <= k < FEW_PLUMES and len(rows) > k:
        return (f"{k} plume realisations: how much plumes differ is estimated from {k} "
                f"(Student's t on {k - 1} degree{'s' * (k > 2)} of freedom, "
                f"{t975(k - 1):.3g} for 1.96), so the interval is wide; more replicates "
                "(--runs-per-start) narrow it")
    return None


def sign_flip_floor(pairs: Sequence[tuple[dict[str, Any], dict[str, Any]]]) -> float | None:
    """The smallest p :func:`clustered_mcnemar` can give these pairs, ``2 / 2^m`` for the ``m``
    plumes whose difference is not 0; None where it does not apply (every replicate one pair,
    or no plume differs). A review read 12 to 0 over 3 plumes, p 0.25, as "not significant":
    0.25 is the least any test over 3 plumes can say."""
    by = _plume_differences(pairs)
    m = sum(v != 0 for v in by.values()) if by is not None else 0
    return 2.0 / 2**m if m else None


def _plume_differences(pairs: Sequence[tuple[dict[str, Any], dict[str, Any]]]
                       ) -> dict[Any, int] | None:
    """Each plume's ``b_k - c_k`` (the starts only the first succeeded in, less those only the
    second did), by replicate; None when every replicate holds one pair."""
    if len({a.get("replicate", id(a)) for a, _ in pairs}) == len(pairs):
        return None
    by: dict[Any, int] = defaultdict(int)
    for a, b in pairs:
        by[a.get("replicate", id(a))] += int(bool(a.get("success"))) - int(bool(b.get("success")))
    return by


def clustered_mcnemar(pairs: Sequence[tuple[dict[str, Any], dict[str, Any]]]) -> float | None:
    """Two-sided p of the paired success difference with the pairs clustered by replicate, or
    None when every replicate holds one pair (the exact McNemar then applies: the pairs are
    independent). The pairs of a replicate share one plume: a plume that one configuration
    fails and the other does not is one piece of evidence, not one per start.

    The test is McNemar's over plumes (the clustered McNemar's question, Durkalski et al. 2003)
    made exact by randomisation: each plume's difference ``d_k = b_k - c_k`` (the starts only
    the first configuration succeeded in, less those only the second did) is as likely to have
    had the other sign under the null, and p is the share of the ``2^K`` sign flips whose
    ``|sum d_k|`` is at least the one seen, computed exactly by convolution. Durkalski's
    chi-square was asymptotic, and with few plumes too small (a review: p = 0.029 from 5
    plumes, where no test over 5 plumes goes below 2/32 = 0.0625)."""
    by = _plume_differences(pairs)
    if by is None:
        return None
    d = [abs(v) for v in by.values() if v != 0]
    if not d:
        return 1.0
    total = sum(d)
    dist = np.zeros(2 * total + 1)
    dist[total] = 1.0  # the distribution of the signed sum, offset by total
    for step in d:
        flipped = np.zeros_like(dist)
        flipped[step:] += 0.5 * dist[:-step]
        flipped[:-step] += 0.5 * dist[step:]
        dist = flipped
    seen = abs(sum(by.values()))
    sums = np.abs(np.arange(-total, total + 1))
    return float(min(1.0, dist[sums >= seen].sum()))
