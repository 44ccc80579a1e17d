"""Comparing a study's configurations: what was flown, and each against the first, run by run.

The paired comparisons (:func:`paired_table`) and the header saying what a study flew
(:func:`study_header`, from its ``study.json``) of ``tables.md``; :func:`mcnemar` for the
discordant runs; and the two measures every table shares, :func:`time_to_source` and the cell
format :func:`fmt`.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from cptbt.batch.intervals import (
    clustered_mcnemar,
    mean_df,
    mean_interval,
    mean_sem,
    sign_flip_floor,
)
from cptbt.batch.outcome import ERROR_OUTCOME
from cptbt.batch.sweeps import changes_world, value_yaml
from cptbt.policy import RELINQUISH_OUTSIDE_M

Rows = list[dict[str, Any]]


def fmt(v: Any, digits: int = 1) -> str:
    """A table cell: a number to ``digits`` places, "—" for none (None or NaN)."""
    if v is None or (isinstance(v, float) and math.isnan(v)):
        return "—"
    if not isinstance(v, float):
        return str(v)
    text = f"{v:.{digits}f}"
    # a start on an axis, turned into the planning frame, is -0.0 or -1e-15: 0.0, not -0.0
    return text[1:] if text.startswith("-") and not text.strip("-0.") else text


def time_to_source(row: dict[str, Any]) -> float:
    """Time to success (declaration, or the oracle's arrival); NaN for failures."""
    if not row.get("success"):
        return math.nan
    t3 = row.get("t3")
    return float(t3) if t3 is not None else float(row.get("sim_time_s") or math.nan)



def search_time(row: dict[str, Any]) -> float:
    """AB Fig. 6's measure: time to source, a failure counting as the run's time limit (a
    review: a false declaration had counted at its run's end, after the trip home, so a setting
    that never succeeded looked only a little slow on the map). Rows from before the limit was
    recorded count a failure at its end."""
    t = time_to_source(row)
    if math.isfinite(t):
        return t
    limit = row.get("run_time_limit_s")
    if limit is not None and math.isfinite(float(limit)):
        return float(limit)
    return float(row.get("sim_time_s") or math.nan)


def mcnemar(b: int, c: int) -> float:
    """Two-sided exact McNemar p-value: the discordant pairs against a fair coin (summed in
    floats from logarithms: exact integers took seconds for thousands of runs, a review)."""
    n, k = b + c, min(b, c)
    if n == 0:
        return 1.0
    log_half = n * math.log(0.5)
    tail = sum(math.exp(math.lgamma(n + 1) - math.lgamma(i + 1) - math.lgamma(n - i + 1)
                        + log_half) for i in range(k + 1))
    return min(1.0, 2 * tail)


def pairings(groups: dict[str, Rows]) -> tuple[bool, list[tuple[str, str, list[tuple[Any, Any]]]]]:
    """Each configuration with the first of its world and their runs paired by (replicate,
    start): whether a swept setting changes the world (configurations are then set against
    the first of their own world only), and (label, base, pairs) for every configuration that
    has a base other than itself. Configurations that differ in a swept setting of the
    simulated world (``changes_world``: the flow, the plume, the OpArea; not the vehicle or its
    sensors) fly other worlds and are not paired."""
    world_keys = sorted({k for rows in groups.values() for r in rows[:1] for k in r
                         if changes_world(k)})

    def world(rows: Rows) -> tuple[Any, ...]:
        # repr: a swept value may be a list (environment.source: a review's crash, unhashable)
        return tuple(repr(rows[0].get(k)) for k in world_keys) if rows else ()

    first: dict[tuple[Any, ...], str] = {}
    for label, rows in groups.items():
        first.setdefault(world(rows), label)
    out = []
    for label, rows in groups.items():
        base = first[world(rows)]
        if base == label:
            continue
        there = {(r.get("replicate"), r.get("start")): r for r in groups[base]}
        out.append((label, base, [(r, there[k]) for r in rows
                                  if (k := (r.get("replicate"), r.get("start"))) in there]))
    return bool(world_keys), out


def paired_table(groups: dict[str, Rows]) -> list[str]:
    """Each configuration against the first of its world, run by run (a review: the runs are
    paired, the tables compared only each configuration's own intervals).

    Runs pair by (replicate, start): the same plume, start and vehicle noise (:func:`pairings`).
    Success: the runs only one of the two succeeded in, with the exact McNemar p on them; time:
    the mean paired difference over the runs both succeeded in, with its standard error and
    95% interval (Student's t on :func:`~cptbt.batch.intervals.mean_df` degrees of freedom);
    search time (:func:`search_time`, a failure at its time limit): the same over every pair
    (a review: the difference over the runs both succeeded in leaves out a configuration's
    failures, so it alone can favour the one that fails more).
    """
    if len(groups) < 2:
        return []
    worlds, paired = pairings(groups)
    if not paired:  # every configuration a world of its own: none pairs
        return []
    lines = ["", "## Paired comparisons", "",
             "Each configuration against the first"
             + (" of its world (the same swept settings of the simulated world)"
                if worlds else "")
             + ", run by run on the same plume, start and vehicle noise: the runs only one "
             "of the two succeeded in (exact McNemar p on those; where a plume holds several "
             "starts, an exact sign-flip test over the plumes' differences, as McNemar's "
             "clustered by plume), and the mean "
             "time difference over the runs both succeeded in (this minus the first, ± its SE: "
             "over plumes, or over runs where that is larger; then its 95% interval, Student's "
             "t on the plumes less one, or the runs less one where each plume holds one). A "
             "difference over the runs both succeeded in leaves out the runs only one did: read "
             "it with the counts beside it. The search-time difference is over every pair, a "
             "failure counting as its time limit (AB Fig. 6's measure, the table's search time; "
             "its end, for rows from before the limit was recorded), with its SE and interval "
             "alike; where the sweep changes the time limit, two failures differ by the limits.",
             "",
             "| configuration | against | pairs | succeeded only here / only there | McNemar p "
             "| both succeeded | time difference over them (s) | search-time difference over "
             "every pair (s) |",
             "|---|---|---:|---:|---:|---:|---:|---:|"]
    for label, base, pairs in paired:
        here_only = sum(bool(a.get("success")) and not b.get("success") for a, b in pairs)
        there_only = sum(bool(b.get("success")) and not a.get("success") for a, b in pairs)
        both = [(a, time_to_source(a) - time_to_source(b)) for a, b in pairs
                if a.get("success") and b.get("success")]
        size, diff = _mean_difference(both)
        counted, searched = _mean_difference([(a, search_time(a) - search_time(b))
                                              for a, b in pairs])
        if counted < len(pairs):  # a run with no time at all: said, not hidden (a diff review)
            searched += f" over {counted} pairs"
        p = clustered_mcnemar(pairs)
        floor = sign_flip_floor(pairs) if p is not None else None
        p = mcnemar(here_only, there_only) if p is None else p
        least = (f" (the least a test over the {round(math.log2(2 / floor))} plumes that "
                 "differ can give)" if floor is not None and floor < 1.0
                 and p <= floor * (1 + 1e-9) else "")
        lines.append(f"| {label} | {base} | {len(pairs)} | {here_only} / {there_only} "
                     f"| {p:.2g}{least} | {size} | {diff} | {searched} |")
    return lines


def _mean_difference(pairs: list[tuple[dict[str, Any], float]]) -> tuple[int, str]:
    """(how many, "mean ± SE (95% interval, df)") of paired differences, each with its row
    (the row names its plume): the SE over plumes, as the intervals'."""
    kept = [(a, v) for a, v in pairs if math.isfinite(v)]
    d = np.array([v for _, v in kept], dtype=float)
    runs = [a for a, _ in kept]
    se = mean_sem(runs, d.tolist())
    text = f"{fmt(float(d.mean()) if d.size else None)} ± {fmt(se)}"
    if d.size >= 2 and math.isfinite(se):  # a review: ± SE over 4 plumes read as ± 2 SE
        lo, hi = mean_interval(runs, d.tolist())
        text += f" ({fmt(lo)} to {fmt(hi)}, {mean_df(runs)} df)"
    return d.size, text


def code_change(meta: dict[str, Any], where: str) -> tuple[str, str] | None:
    """(the code identity a study's record ``meta`` was flown by, this code's) when they
    differ (its source, a plug-in's or a result dependency changed since); None when they are
    the same or the record does not say (``where`` names the record in a mission error)."""
    from cptbt.batch.integrity import code_identity
    from cptbt.batch.scenario import Environment
    from cptbt.loader import MissionError, loads_mission
    from cptbt.registry import default_registry

    try:
        flies = sorted({(e.family, e.variant) for text in meta["config_missions"]
                        for e in loads_mission(text, where, default_registry(),
                                               Environment).entries()})
    except (MissionError, KeyError, TypeError):
        return None
    here, there = code_identity(flies), meta.get("code")
    return (there, here) if isinstance(there, str) and there != here else None


def study_json(folder: Path) -> dict[str, Any]:
    """The study's ``study.json`` in ``folder`` (empty when there is none, or it is unreadable:
    tables written elsewhere, by ``cptbt plot --out``, say)."""
    try:
        data = json.loads((folder / "study.json").read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return {}
    return data if isinstance(data, dict) else {}


def study_header(meta: dict[str, Any], configurations: int) -> list[str]:
    """What was flown, from the study's record: the mission, seed, starts and replicates, the
    sweeps, whether the runs are paired, and the sweeps' notes (a review found tables.md
    silent on all of it; the notes went to the terminal only). Empty without a record."""
    if not meta.get("mission"):
        return []
    starts, reps = len(meta.get("starts") or []), meta.get("runs_per_start")
    limit = meta.get("time_limit_s")
    flown = (f"{starts} start{'s' * (starts != 1)} × {reps} replicate{'s' * (reps != 1)} per "
             "configuration, " if starts and isinstance(reps, int) else "")
    planned = meta.get("configs")
    planned = len(planned) if isinstance(planned, list) and planned else configurations
    count = f"{planned} configuration{'s' * (planned != 1)}" + (
        "" if planned == configurations else f" ({configurations} with runs so far)")
    lines = ["## What was flown", "",
             f"- Mission `{meta['mission']}` ({meta.get('mission_name', '')}), root seed "
             f"{meta.get('root_seed')}; {flown}{count}; time limit "
             + (f"{limit:g} s." if isinstance(limit, (int, float)) else "the mission's.")]
    sweeps = meta.get("sweeps") or {}
    lines.append("- Swept: " + "; ".join(f"`{k}` = {', '.join(map(value_yaml, v))}"
                                         for k, v in sweeps.items()) + "."
                 if sweeps else "- One configuration: the mission as written.")
    world = [k for k in sweeps if any(changes_world(p) for p in k.split("+"))]
    if configurations > 1:
        lines.append("- Paired: replicate r flies the same plume in every configuration and "
                     "start i the same vehicle noise, so configurations are compared run by run"
                     + (" (but not across the values of a setting of the simulated world: note "
                        "below)." if world else "."))
    if meta.get("until_sem") is not None:
        lines.append(f"- Adaptive: replicates added {meta.get('runs_per_round')} at a time until "
                     "the largest relative SEM of a mean time to source was at most "
                     f"{meta['until_sem']:g} (or {meta.get('max_runs_per_start')} per start).")
    lines += [f"- Note: {note}" for note in meta.get("notes") or []]
    lines += [f"- Warning (as `cptbt validate` gives it): {w}" for w in meta.get("warnings") or []]
    return [*lines, ""]


def td_share(row: dict[str, Any]) -> float | None:
    """T_D as a share of the mission time to declaration, ``T_total = t3 - t0`` (TRO Table
    III), when both exist. Not ``T_D / t3``: a run with the vehicle's own mission first starts
    its measures at t0 > 0 (a review: 29% by t3 where TRO's share is 43.5%)."""
    if row.get("T_D") is None:
        return None
    total = row.get("T_total")
    if total is None and row.get("t3") is not None:  # a table without T_total
        total = float(row["t3"]) - float(row.get("t0") or 0.0)
    if not total:
        return None
    return float(row["T_D"]) / float(total)


def errors_note(rows: Rows) -> str | None:
    """What the study's runs that stopped on an error (a bug; outcome ``error``, see
    :func:`cptbt.batch.worker.failed_rows`) were, in one sentence; None when there are none."""
    bad = [r for r in rows if r.get("outcome") == ERROR_OUTCOME]
    if not bad:
        return None
    first = bad[0]
    return (f"{len(bad)} of {len(rows)} runs stopped on an error (outcome 'error', counted as "
            f"failures; they are not flown again on resume): the first, "
            f"{first.get('configuration') or first.get('config')} replicate "
            f"{first.get('replicate')} start {first.get('start')}: {first.get('error')}")


def every_source_declared(row: dict[str, Any]) -> bool:
    """Whether a run declared as many points as it had true sources (a row from before the
    count was kept: yes): a several-source run's ``error_m`` is its worst declared point's, and
    a rule that declares one source alone had read as 4.8 m off (a review)."""
    n = row.get("sources_declared")
    return n is None or int(n) >= int(row.get("sources_true") or 1)


OUTSIDE_NOTED_M = 0.05
"""A run is said to have left the OpArea when its true track went this far outside or farther
(``cptbt run``'s summary line and ``tables.md`` alike)."""


def left_oparea(farthest_outside_m: float) -> bool:
    """Whether a run that went this far outside the OpArea is said to have left it."""
    return farthest_outside_m >= OUTSIDE_NOTED_M


def excursions(rows: Rows) -> tuple[int, int, float, float]:
    """Runs that left the OpArea, the runs flown (error rows flew nothing to judge), the
    farthest any went (m), and the share of the AMP's time safety drove over all runs (the
    family time columns: the share of what the tree did)."""
    rows = [r for r in rows if r.get("outcome") != ERROR_OUTCOME]
    far = [float(r.get("farthest_outside_m") or 0.0) for r in rows]
    out = sum(left_oparea(f) for f in far)
    amp = sum(float(v or 0.0) for r in rows for k, v in r.items()
              if k.startswith("time_") and k.endswith("_s") and "." not in k)
    # safety bringing the vehicle in from a launch or start outside is the mission's way in
    safety = sum(float(r.get("time_safety_s") or 0.0) - float(r.get("safety_entering_s") or 0.0)
                 for r in rows)
    return out, len(rows), max(far, default=0.0), safety / amp if amp > 0 else math.nan


def excursion_table(groups: dict[str, Rows]) -> list[str]:
    """``tables.md``'s account of the runs that left the OpArea (a review: a study whose every
    run went 5-14 m outside said nothing of it outside ``results.parquet``); none when no run
    left it."""
    counts = {label: excursions(rows) for label, rows in groups.items()}
    if not any(n for n, _, _, _ in counts.values()):
        return []
    lines = ["", "## Left the OpArea", "",
             "Runs whose true track went outside the OpArea while the AMP drove "
             f"(`farthest_outside_m`; the AMP gives control back "
             f"{RELINQUISH_OUTSIDE_M:g} m out, TRO II), the "
             "farthest, and the share of the AMP's time the safety behaviour drove (it acts "
             "on the navigation estimate, by default once that is 5 m out: a true track a few "
             "metres out need not wake it, and a navigation error can wake it with the true "
             "track inside). The way in "
             "from a launch or start outside the OpArea and the way to a home the mission puts "
             "outside (`allow_outside`) are left out of both.", "",
             "| configuration | runs outside | farthest outside (m) | safety drove |",
             "|---|---:|---:|---:|"]
    for label, (n, flown, far, share) in counts.items():
        lines.append(f"| {label} | {n} of {flown} | {fmt(far)} "
                     f"| {'—' if math.isnan(share) else f'{100 * share:.1f}%'} |")
    return lines


def command_faults(rows: Rows) -> tuple[int, int, int, int]:
    """Runs with a behaviour fault (a command not flown as asked: ``nonfinite_commands``,
    ``unflyable_commands``), the runs flown, and the cycles of each kind over all runs."""
    rows = [r for r in rows if r.get("outcome") != ERROR_OUTCOME]
    nonfinite = [int(r.get("nonfinite_commands") or 0) for r in rows]
    unflyable = [int(r.get("unflyable_commands") or 0) for r in rows]
    hit = sum(1 for a, b in zip(nonfinite, unflyable, strict=True) if a or b)
    return hit, len(rows), sum(nonfinite), sum(unflyable)


def command_fault_table(groups: dict[str, Rows]) -> list[str]:
    """``tables.md``'s account of behaviours whose commands were not flown as asked (a
    review's plug-in sent none in 457 cycles, or 0.1 m/s the vehicle flew at 0.25, and the
    study credited it with what covered for it); none when no run had one."""
    counts = {label: command_faults(rows) for label, rows in groups.items()}
    if not any(n for n, _, _, _ in counts.values()):
        return []
    lines = ["", "## Behaviour faults", "",
             "Runs in which a behaviour asked `command()` for a non-finite heading or speed (no "
             "command was sent: the behaviour below it drove), or commanded a speed the "
             "simulated vehicle cannot fly (it flew the nearest it can). The results are not "
             "the behaviour's as written; `command_faults` in `results.parquet` names it.", "",
             "| configuration | runs | non-finite (cycles) | speed not flyable (cycles) |",
             "|---|---:|---:|---:|"]
    for label, (n, flown, nonfinite, unflyable) in counts.items():
        lines.append(f"| {label} | {n} of {flown} | {nonfinite} | {unflyable} |")
    return lines


def at_first(row: dict[str, Any]) -> bool:
    """The run's first detection was within 13 m of its declared point (t2 = t1): T_T, D1 and
    D1/D0 are 0 by SPEC §11's definition, not by an ideal path (a review)."""
    return row.get("T_T") == 0 and row.get("D1_over_D0") is not None


def zeros_note(declared: Rows) -> str:
    """How many of the declared runs' D1/D0 are 0 because t2 = t1, and their mean without
    them (``tables.md``'s TRO-form mean row)."""
    zeros = sum(at_first(r) for r in declared)
    if not zeros:
        return ""
    rest = [float(r["D1_over_D0"]) for r in declared if not at_first(r)
            and r.get("D1_over_D0") is not None and math.isfinite(float(r["D1_over_D0"]))]
    return f" ({zeros} at 0, t2 = t1; {fmt(sum(rest) / len(rest) if rest else None, 2)} without)"
