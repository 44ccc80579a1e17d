"""``tables.md``'s account of what each behaviour family drove, per configuration.

A sweep compares variants of a behaviour only as far as that behaviour drove: a review swept
``find_plume.variant=billiard,lawnmower`` on a study whose vehicle met the plume on its way to
the start, and the two rows came out identical to the decimal (find-plume drove in 1 run of
8); on MSN007 it drove 6-12 s in all, and a 54-s difference between the rows was the runs'
divergence, not the variants'. The results table had the times (``time_<family>_s``, NaN
where a family never drove); ``tables.md`` had nothing.
"""

from __future__ import annotations

import math
from typing import Any

from cptbt.registry import FAMILIES

Rows = list[dict[str, Any]]

SELDOM = 0.5
"""A swept family that drove in fewer than this share of a configuration's runs is noted ..."""

LITTLE = 0.01
"""... as is one that drove less than this share of its AMP time."""


ORDER = FAMILIES
"""The table's columns: TRO Fig. 2's priorities first (the registry's), then other families by
name (a review: in first-seen order two studies' tables could not be read side by side)."""

DECIDES = ("declare_source",)
"""Families whose rule is a decision as well as driving: a sweep of the rule itself (the family
whole or its variant) compares when and where it declares, whatever it drove (a review's
declaration sweep, 11 runs to 0 in McNemar's test, was noted as "drove little"); a sweep of
one of its settings (``declare_source.flyby``) is noted as any other."""


def _families(rows: Rows) -> list[str]:
    """The behaviour families with a time column (``time_<family>_s``), in :data:`ORDER`."""
    seen = {k[5:-2] for r in rows for k in r
            if k.startswith("time_") and k.endswith("_s") and "." not in k} - {"none"}
    return sorted(seen, key=lambda f: (ORDER.index(f) if f in ORDER else len(ORDER), f))


def _seconds(row: dict[str, Any], family: str) -> float:
    v = row.get(f"time_{family}_s")
    return float(v) if isinstance(v, int | float) and math.isfinite(v) else 0.0


def swept_paths(groups: dict[str, Rows], families: list[str]) -> list[str]:
    """The sweeps the configurations differ by: their rows' sweep columns (a sweep's path, the
    configuration's value; ``find_plume``, ``declare_source.flyby``,
    ``maintain_plume.variant+reacquire_plume.variant``) whose value differs between
    configurations. Read from the columns, not the labels: a label keeps a setting's last key
    alone (``flyby=False``), and a diff review found such a sweep never noted."""
    def behaviour_path(key: str) -> bool:
        return any(part.split(".")[0] in families for part in key.split("+"))

    keys = {k for rows in groups.values() for r in rows for k in r if behaviour_path(k)}
    return sorted(k for k in keys
                  if len({repr(rows[0].get(k)) for rows in groups.values() if rows}) > 1)


def rule_swept(paths: list[str], family: str) -> bool:
    """Whether the sweeps change ``family``'s rule: the family whole or its variant
    (``declare_source``, ``declare_source.variant``, or either in a joint sweep)."""
    return any(part in (family, f"{family}.variant") for path in paths for part in path.split("+"))


def swept_families(paths: list[str], families: list[str]) -> list[str]:
    """The families the sweeps set something of."""
    named = {part.split(".")[0] for path in paths for part in path.split("+")}
    return [f for f in families if f in named]


def behaviour_time_table(groups: dict[str, Rows]) -> list[str]:
    """Per configuration, each family's share of the AMP's time and the runs it drove in, and a
    note for a swept family that drove in few of a configuration's runs; none for one
    configuration or a table without behaviour times."""
    every = [r for rows in groups.values() for r in rows]
    families = _families(every)
    if len(groups) < 2 or not families:
        return []
    lines = ["", "## Time each behaviour drove", "",
             "Each family's share of the AMP's time over a configuration's runs, and in how "
             "many runs it drove at all: a configuration differs from another only where the "
             "behaviours that differ drove.", "",
             "| configuration | " + " | ".join(families) + " |",
             "|---|" + "---:|" * len(families)]
    little: dict[str, list[str]] = {}
    paths = swept_paths(groups, families)
    swept = swept_families(paths, families)
    for label, rows in groups.items():
        total = sum(_seconds(r, f) for r in rows for f in families) or math.nan
        cells = []
        for f in families:
            spent = sum(_seconds(r, f) for r in rows)
            drove = sum(_seconds(r, f) > 0.0 for r in rows)
            share = spent / total if math.isfinite(total) else math.nan
            cells.append(f"{'—' if math.isnan(share) else f'{share:.1%}'} ({drove}/{len(rows)})")
            seldom = drove < SELDOM * len(rows) or not share >= LITTLE
            if f in swept and seldom and not (f in DECIDES and rule_swept(paths, f)):
                little.setdefault(f, []).append(
                    f"{label}: {drove} of {len(rows)} runs, {spent:.0f} s in all")
        lines.append(f"| {label} | " + " | ".join(cells) + " |")
    if any(float(r.get("safety_entering_s") or 0.0) > 0.0 for r in every):
        lines += ["", "Safety's share here includes bringing the vehicle in from a launch or "
                  "start outside the OpArea, which \"Left the OpArea\" leaves out."]
    for f, where in little.items():
        lines += ["", f"**Note: {f}, swept here, drove little ({'; '.join(where)}): the "
                  f"rows compare little of {f}'s settings.**"]
    return lines
