"""Tables and a figure for maintain-time studies (``evaluation: {criterion: maintain}``, AB Fig. 9).

A maintain study measures how long a strategy keeps the plume (``T_M``, AB eq. 3) rather than
whether it finds the source, so its report is T_M per configuration — and, when a numeric
setting is swept, T_M against that setting with one curve per value of the others.
"""

from __future__ import annotations

import math
import statistics
from collections import defaultdict
from pathlib import Path
from typing import Any

from cptbt.batch.intervals import mean_sem
from cptbt.batch.sweeps import label_parts

Rows = list[dict[str, Any]]


def is_maintain_study(rows: Rows) -> bool:
    """Whether the rows come from a maintain-criterion study."""
    return any(r.get("criterion") == "maintain" for r in rows)


def _has_t_m(row: dict[str, Any]) -> bool:
    v = row.get("T_M")
    return v is not None and not (isinstance(v, float) and math.isnan(v))


def _t_m(rows: Rows) -> list[float]:
    return [float(r["T_M"]) for r in rows if _has_t_m(r)]


def _t_m_mean_se(rows: Rows) -> tuple[float, float]:
    """Mean T_M and its SE over the runs with a contact."""
    kept = [r for r in rows if _has_t_m(r)]
    return _mean_se(kept, _t_m(kept))


def _mean_se(rows: Rows, values: list[float]) -> tuple[float, float]:
    """The mean and its SE over plumes (:func:`~cptbt.batch.intervals.mean_sem`: the starts of
    a replicate fly one plume; the SE had treated them as independent)."""
    if not values:
        return math.nan, math.nan
    return statistics.fmean(values), mean_sem(rows, values)


def _se_text(se: float) -> str:
    """A standard error as the tables give it: "—" where there is none (one run's, whose
    standard deviation is NaN: the table had read "± nan")."""
    return "—" if math.isnan(se) else f"{se:.1f}"


def maintain_table(groups: dict[str, Rows]) -> list[str]:
    """Markdown lines: T_M per configuration (runs without a contact are counted, not averaged)."""
    lines = ["## Maintain time (AB eq. 3: T_M = T_Last − T_First of each contact, summed until "
             "contact is lost for good)",
             "", "| configuration | runs | with a contact | mean T_M ± SE over plumes (s) "
             "| median T_M (s) | came within the success radius |",
             "|---|---:|---:|---:|---:|---:|"]
    for label, rows in groups.items():
        t_m = _t_m(rows)
        m, se = _t_m_mean_se(rows)
        med = statistics.median(t_m) if t_m else math.nan
        reached = sum(bool(r.get("success")) for r in rows)
        lines.append(f"| {label} | {len(rows)} | {len(t_m)} | "
                     + ("—" if not t_m else f"{m:.1f} ± {_se_text(se)}") + " | "
                     + ("—" if not t_m else f"{med:.1f}") + f" | {reached} |")
    return [*lines, ""]


def _coords(label: str) -> dict[str, str]:
    """``k=v, k=v`` (the configuration label of :func:`cptbt.batch.study.config_label`)."""
    out = {}
    for part in label_parts(label):
        key, sep, value = part.partition("=")
        if not sep:
            return {}
        out[key] = value
    return out


def _number(text: str) -> float | None:
    try:
        value = float(text)
    except ValueError:
        return None
    return value if math.isfinite(value) else None


def maintain_figure(groups: dict[str, Rows], path: Path, plt: Any) -> Path | None:
    """Mean T_M ± SE against the first numeric swept setting; None if nothing numeric is swept."""
    coords = {label: _coords(label) for label in groups}
    keys = [k for k in next(iter(coords.values()), {})
            if all(k in c and _number(c[k]) is not None for c in coords.values())]
    if not keys or len({coords[label][keys[0]] for label in groups}) < 2:
        return None
    x_key = keys[0]
    series: dict[str, dict[float, tuple[float, float]]] = defaultdict(dict)
    for label, rows in groups.items():
        c = coords[label]
        name = ", ".join(f"{k}={v}" for k, v in c.items() if k != x_key) or "T_M"
        x = _number(c[x_key])
        assert x is not None
        series[name][x] = _t_m_mean_se(rows)
    fig, ax = plt.subplots(figsize=(7.5, 4.5), layout="constrained")
    for name, points in sorted(series.items()):
        xs = sorted(points)
        ax.errorbar(xs, [points[x][0] for x in xs], yerr=[points[x][1] for x in xs],
                    marker="o", ms=3, capsize=2, label=name)
    # the setting's full path (a label names it by its last key): which behaviour it belongs to
    row = next((r for rows in groups.values() for r in rows), {})
    full = [k for k in row if "." in k and k.rsplit(".", 1)[1] == x_key]
    ax.set_xlabel(full[0] if len(full) == 1 else x_key)
    ax.set_ylabel("mean maintain time T_M, s (± 1 SE)")
    ax.set_title("Maintain time against the swept setting (AB Fig. 9 form)", fontsize=10)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def maintain_paired_table(groups: dict[str, Rows]) -> list[str]:
    """T_M of each configuration against the first of its world, run by run over the runs
    that made a contact in both (a review recomputed Fig. 9's β differences with paired SEs,
    smaller than the unpaired ones the figure shows)."""
    from cptbt.batch.comparison import pairings

    worlds, paired = pairings(groups) if len(groups) > 1 else (False, [])
    if not paired:
        return []
    lines = ["## Paired maintain times", "",
             "Each configuration against the first" + (" of its world" if worlds else "")
             + ", run by run on the same plume and start: the mean difference in T_M (this "
             "minus the first) over the runs with a contact in both, ± its paired SE over "
             "plumes.", "",
             "| configuration | against | pairs with a contact in both | T_M difference (s) |",
             "|---|---|---:|---:|"]
    for label, base, pairs in paired:
        both = [(a, float(a["T_M"]) - float(b["T_M"])) for a, b in pairs
                if _has_t_m(a) and _has_t_m(b)]
        d = [v for _, v in both]
        m, se = _mean_se([a for a, _ in both], d)
        lines.append(f"| {label} | {base} | {len(d)} | "
                     + ("—" if not d else f"{m:.1f} ± {_se_text(se)}") + " |")
    return [*lines, ""]
