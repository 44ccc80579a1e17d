"""A study's report, built from the results table alone so ``cptbt plot`` can rebuild it: the
Markdown tables (per configuration, the evaluation protocol, TRO Tables III and IV) here, the
figures (AB Figs. 6, 10, 11; success, error, T_D share) in :mod:`cptbt.batch.study_figures`."""

from __future__ import annotations

import json
import math
from collections import defaultdict
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from cptbt.batch.behaviour_times import behaviour_time_table
from cptbt.batch.comparison import (
    at_first,
    command_fault_table,
    errors_note,
    every_source_declared,
    excursion_table,
    fmt,
    paired_table,
    search_time,
    study_header,
    study_json,
    td_share,
    time_to_source,
    zeros_note,
)
from cptbt.batch.figures import pyplot
from cptbt.batch.intervals import mean_sem, plumes_note, rate_interval
from cptbt.batch.maintain_report import (
    is_maintain_study,
    maintain_figure,
    maintain_paired_table,
    maintain_table,
)
from cptbt.frames import PlanningFrame
from cptbt.mission import MissionBase

Rows = list[dict[str, Any]]


def _config_label(row: dict[str, Any]) -> str:
    """A row's configuration: its ``configuration`` column (written by every study)."""
    label = row.get("configuration")
    return str(label) if label else str(row.get("mission", "study"))


@dataclass(frozen=True)
class StudyGeometry:
    """What the maps draw besides the results: the OpArea, the true sources and the mean flow.

    Planning frame; ``flow_deg`` is the direction the flow moves toward; ``extra_sources`` the
    world's other sources (a several-source study's map had drawn the mission's ``source``
    alone). Saved in ``study.json`` so ``cptbt plot`` can redraw the maps from the folder alone.
    """

    area: tuple[float, float, float, float]
    source: tuple[float, float]
    flow_deg: float | None = None
    extra_sources: tuple[tuple[float, float], ...] = ()
    ne_frame: PlanningFrame | None = None
    """How planning points turn into the mission's North-East metres (None: a planning-frame
    mission, which has no compass): the tables give places in the frame the mission is
    written in."""

    @classmethod
    def of(cls, mission: MissionBase) -> StudyGeometry:
        """A mission's: its OpArea, true sources and mean flow (planning frame)."""
        from cptbt.batch.scenario import to_sim_params

        area = mission.op_area_geometry()
        params = to_sim_params(mission)
        return cls((area.xmin, area.xmax, area.ymin, area.ymax), params.source_xy_m,
                   params.flow.mean_dir_deg, tuple(params.extra_sources_xy_m),
                   None if mission.frame == "planning" else area.frame)

    def to_data(self) -> dict[str, Any]:
        """For ``study.json``."""
        f = self.ne_frame
        return {"area": list(self.area), "source": list(self.source), "flow_deg": self.flow_deg,
                "extra_sources": [list(q) for q in self.extra_sources],
                "ne_frame": None if f is None else [f.x_bearing_deg, f.origin_n, f.origin_e]}

    @classmethod
    def from_data(cls, data: dict[str, Any] | None) -> StudyGeometry | None:
        """From ``study.json`` (None if absent or malformed)."""
        try:
            assert data is not None
            extra = tuple((float(q[0]), float(q[1])) for q in data.get("extra_sources") or ())
            f = data.get("ne_frame")  # absent from a study.json written before it
            frame = None if f is None else PlanningFrame(*(float(v) for v in f))
            return cls(tuple(data["area"]), tuple(data["source"]), data.get("flow_deg"), extra,
                       frame)
        except (AssertionError, KeyError, TypeError, ValueError):
            return None


def config_geometries(study: dict[str, Any]) -> dict[int, StudyGeometry]:
    """Each configuration's own map geometry (its flow and sources), by configuration index,
    from the study's record (empty for a record written before it was kept)."""
    data = study.get("config_geometry")
    if not isinstance(data, list):
        return {}
    out = {i: g for i, d in enumerate(data)
           if isinstance(d, dict) and (g := StudyGeometry.from_data(d)) is not None}
    return out if len(out) == len(data) else {}


@dataclass(frozen=True)
class Protocol:
    """The field's evaluation protocol for one configuration (OTTO; Loisy & Eloy 2022).

    Times are times to source of the successful runs (the renormalised distribution of arrival
    times: a failure enters ``p_fail``, not the times); ``rel_sem`` is the standard error of
    their mean over the mean; ``efficiency`` is the mean of the successful runs' shortest path /
    path flown (``path_efficiency``), ``d0_over_d3`` the mean of TRO's D0/D3 over declarations.
    """

    runs: int
    failures: int
    p_fail: float
    p_fail_ci: tuple[float, float]
    mean_s: float
    sem_s: float
    rel_sem: float
    median_s: float
    p90_s: float
    p99_s: float
    efficiency: float
    efficiency_median: float
    d0_over_d3: float


PERCENTILE_RUNS = {90: 10, 99: 100}
"""The successful runs a tail percentile needs before the tables give it."""


def protocol(rows: Rows) -> Protocol:
    """The evaluation protocol's numbers over ``rows`` (one configuration); NaN where empty."""
    n = len(rows)
    t = np.array([time_to_source(r) for r in rows], dtype=float)
    ok = t[np.isfinite(t)]
    fails = n - int(np.count_nonzero([bool(r.get("success")) for r in rows]))
    lo, hi = rate_interval(rows, [not r.get("success") for r in rows])
    mean = float(ok.mean()) if ok.size else math.nan
    timed = [r for r, v in zip(rows, t, strict=True) if math.isfinite(v)]
    sem = mean_sem(timed, ok.tolist())  # over plumes: the runs of a replicate share one
    q = np.percentile(ok, [50, 90, 99]) if ok.size else np.full(3, math.nan)
    # a percentile from fewer runs than it needs is the largest run (a review read a "99th
    # percentile" of 4 runs): given from 10 successes (90th) and 100 (99th)
    q[1] = q[1] if ok.size >= PERCENTILE_RUNS[90] else math.nan
    q[2] = q[2] if ok.size >= PERCENTILE_RUNS[99] else math.nan
    eff = [float(r["path_efficiency"]) for r in rows if r.get("success")
           and r.get("path_efficiency") is not None and math.isfinite(r["path_efficiency"])]
    d03 = [float(r["D0"]) / float(r["D3"]) for r in rows
           if r.get("D0") is not None and r.get("D3")]
    return Protocol(
        runs=n, failures=fails, p_fail=fails / n if n else math.nan, p_fail_ci=(lo, hi),
        mean_s=mean, sem_s=sem, rel_sem=sem / mean if mean > 0 else math.nan,
        median_s=float(q[0]), p90_s=float(q[1]), p99_s=float(q[2]),
        efficiency=float(np.mean(eff)) if eff else math.nan,
        efficiency_median=float(np.median(eff)) if eff else math.nan,
        d0_over_d3=float(np.mean(d03)) if d03 else math.nan,
    )


def by_configuration(rows: Rows) -> dict[str, Rows]:
    """Rows grouped by configuration label, in the order they first appear."""
    groups: dict[str, Rows] = defaultdict(list)
    for r in rows:
        groups[_config_label(r)].append(r)
    return dict(groups)


def protocol_table(groups: dict[str, Rows]) -> list[str]:
    """The evaluation protocol as Markdown table lines, one row per configuration."""
    lines = ["| configuration | runs | P(fail) (95% CI) | mean time (s) ± SEM | rel. SEM "
             "| median (s) | 90th pct (s) | 99th pct (s) | path efficiency mean / median "
             "| D0/D3 |",
             "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for label, rows in groups.items():
        pr = protocol(rows)
        lo, hi = pr.p_fail_ci
        lines.append(
            f"| {label} | {pr.runs} | {pr.p_fail:.1%} ({lo:.1%}–{hi:.1%}) "
            f"| {fmt(pr.mean_s)} ± {fmt(pr.sem_s)} | {fmt(pr.rel_sem, 3)} "
            f"| {fmt(pr.median_s)} | {fmt(pr.p90_s)} | {fmt(pr.p99_s)} "
            f"| {fmt(pr.efficiency, 2)} / {fmt(pr.efficiency_median, 2)} "
            f"| {fmt(pr.d0_over_d3, 2)} |")
    return lines


def paired(groups: dict[str, Rows]) -> tuple[dict[str, Rows], str | None]:
    """The configurations cut to the runs (replicate and start: the same plume and start) that
    every one of them has, and a note saying so; unchanged, with no note, when they all flew
    the same runs (a finished study always has). An interrupted or running study's folder had
    been plotted as 144 runs of one variant against 36 of another, not the same plumes."""
    keys = {label: {(r.get("replicate"), r.get("start")) for r in rows}
            for label, rows in groups.items()}
    common = set.intersection(*keys.values()) if keys else set()
    if len(groups) < 2 or all(k == common for k in keys.values()):
        return groups, None
    flown = ", ".join(f"{label} {len(k)}" for label, k in keys.items())
    if not common:
        return groups, (f"The configurations flew different runs ({flown}) and share none: "
                        "they are not compared on the same plumes.")
    cut = {label: [r for r in rows if (r.get("replicate"), r.get("start")) in common]
           for label, rows in groups.items()}
    return cut, (f"The configurations flew different runs ({flown}): every table and figure "
                 f"compares the {len(common)} runs each of them has (the same plumes and "
                 "starts); the rest are left out.")


def compared(rows: Rows, planned_runs: int | None = None) -> tuple[dict[str, Rows], list[str]]:
    """The rows by configuration, cut to the runs all of them share (:func:`paired`), and what
    the tables must say first: fewer rows than ``planned_runs``, runs left out."""
    groups: dict[str, Rows] = defaultdict(list)
    for r in rows:
        groups[_config_label(r)].append(r)
    cut, note = paired(dict(groups))
    notes = [note] if note else []
    if planned_runs is not None and len(rows) < planned_runs:
        notes.insert(0, f"Incomplete study: {len(rows)} of {planned_runs} planned runs (an "
                     "interrupted or running batch; `cptbt batch` with the same arguments "
                     "resumes it).")
    return cut, notes


def write_report(rows: Rows, out: Path, geometry: StudyGeometry | None = None,
                 figures: bool = True, planned_runs: int | None = None,
                 study: dict[str, Any] | None = None) -> list[Path]:
    """Write every figure and table that means something for the study; the paths written
    (without ``figures``, the tables alone: matplotlib is not needed).

    ``study`` is the study's record (``study.json``; default: the one in ``out``), which
    heads ``tables.md`` with what was flown.

    Configurations that flew different runs (an interrupted study) are compared on the runs
    they share (:func:`paired`); with ``planned_runs`` (the study's plan), fewer rows than
    that are said at the top of ``tables.md``.

    Skipped where they would mislead: maps need starts spread in x and y, the start-x line
    needs starts along one line, the rate chart needs two configurations or more, and the
    error histogram needs declarations judged by distance (not AB's arrival criterion); a
    maintain-time study (AB Fig. 9) gets T_M tables and T_M against its swept setting instead of
    TRO's declaration tables and the success chart.
    """
    if not rows:
        return []
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    from cptbt.batch.study_figures import _distributions, _line, _map, _rates, drop_stale

    frame = geometry.ne_frame if geometry is not None else None
    grouped, notes = compared(rows, planned_runs)
    groups: dict[str, Rows] = defaultdict(list, grouped)
    written: list[Path | None] = [_tables(groups, out / "tables.md", frame, notes,
                                          study_header(study if study is not None
                                                       else study_json(out), len(groups)))]
    if not figures:
        return drop_stale(out, [p for p in written if p is not None])
    plt = pyplot()
    per_config = config_geometries(study if study is not None else study_json(out))
    written.append(_map(groups, out / "time_to_source_map.png", plt, geometry, per_config))
    written.append(_line(groups, out / "time_vs_start.png", plt))
    if is_maintain_study(rows):
        written.append(maintain_figure(groups, out / "maintain_time.png", plt))
    else:
        written.append(_rates(groups, out / "success_and_false_declarations.png", plt))
    written.append(_distributions(groups, out / "error_and_td_share.png", plt))
    return drop_stale(out, [p for p in written if p is not None])



def _sem(values: list[Any]) -> float:
    v = [float(x) for x in values if x is not None and not (isinstance(x, float) and math.isnan(x))]
    return float(np.std(v, ddof=1) / math.sqrt(len(v))) if len(v) > 1 else math.nan


def _mean(values: list[Any]) -> float:
    v = [float(x) for x in values if x is not None and not (isinstance(x, float) and math.isnan(x))]
    return float(np.mean(v)) if v else math.nan


_DISTANCE_COLUMNS = {  # what a row's error_m is, by evaluation criterion (outcome.judge)
    "declaration": ("mean error (m)", "max error (m)"),
    "arrival": ("mean distance at the end (m)", "max distance at the end (m)"),
    "maintain": ("mean closest approach (m)", "max closest approach (m)"),
}
_SUCCESS = {"declaration": "success: declared within the radius (95% CI)",
            "arrival": "success: reached the source (95% CI)",
            "maintain": "came within the radius (95% CI)"}


def _several_sources(rows: Rows) -> bool:
    """Whether some run's world has more than one true source."""
    return any((r.get("sources_true") or 1) > 1 for r in rows)


def success_label(rows: Rows) -> str:
    """What a success is in these runs, as the tables and the rate chart head it (several true
    sources: every one declared)."""
    criterion = _criterion(rows)
    if criterion == "declaration" and _several_sources(rows):
        return "success: every source declared within the radius (95% CI)"
    return _SUCCESS.get(criterion, "success (95% CI)")


def _criterion(rows: Rows) -> str:
    """The study's evaluation criterion (its rows share one)."""
    found = {r.get("criterion") or "declaration" for r in rows}
    return found.pop() if len(found) == 1 else "declaration"


def _place(x: Any, y: Any, frame: PlanningFrame | None) -> str:
    """A planning point as the tables give it: ``(x, y)``, or ``(N, E)`` in ``frame``."""
    if frame is not None and x is not None and y is not None:
        x, y = frame.xy_to_ne(float(x), float(y))
    return f"({fmt(x)}, {fmt(y)})"


def _declared_cell(row: dict[str, Any], frame: PlanningFrame | None = None) -> str:
    """The declared point of a run, or every one with its own error when it declared several
    (``declared_source_*`` is the last one alone, and the row's error is the worst one's)."""
    text = row.get("declared_points")
    points = json.loads(text) if isinstance(text, str) and text else []
    if len(points) > 1:
        return "; ".join(f"{_place(x, y, frame)} {fmt(e)} m" for x, y, e in points)
    if points:  # also a run that ended still searching for more (no declared_source)
        return _place(points[0][0], points[0][1], frame)
    return _place(row.get("declared_source_x"), row.get("declared_source_y"), frame)


def _tables(groups: dict[str, Rows], path: Path, frame: PlanningFrame | None = None,
            notes: Sequence[str] = (), header: Sequence[str] = ()) -> Path:
    every = [r for rows in groups.values() for r in rows]
    criterion = _criterion(every)
    mean_col, max_col = _DISTANCE_COLUMNS.get(criterion, _DISTANCE_COLUMNS["declaration"])
    # A study whose runs cannot declare has no false declarations to count: "—", not 0.
    declares = criterion == "declaration" or any(r.get("t3") is not None for r in every)
    lines = ["# Study results", "", *header]
    lines += [line for note in notes for line in (f"**{note}**", "")]
    failed = errors_note(every)
    if failed:
        lines += [f"**{failed}**", ""]
    if is_maintain_study(every):  # what such a study measures comes first
        lines += [*maintain_table(groups), "", *maintain_paired_table(groups)]
    # Several true sources: a run succeeds only when it finds every one, and a rule that can
    # declare one source alone fails every run with no false declaration and a small error;
    # how many sources were found says what the success rate does not.
    multi = _several_sources(every)
    lines += ["## Per configuration", "",
              f"| configuration | runs | {success_label(every)} "
              + ("| sources found / true | " if multi else "| ")
              + "false declarations (runs) | mean time to source, successes (s) | sd (s) "
              f"| mean search time, a failure at the time limit (s) | {mean_col} | {max_col} |",
              "|---|---:|---:|---:|---:|---:|---:|---:|---:|" + ("---:|" if multi else "")]
    if multi:
        lines[-2:-2] = ["With several true sources a run succeeds when every source has a "
                        "declared point within the radius and none is false; the error is the "
                        "worst declared point's, to its nearest true source, over the runs that "
                        "declared as many points as there are sources (a review read a rule "
                        "that declares one source alone as 4.8 m off).", ""]
    for label, rows in groups.items():
        t = np.array([time_to_source(r) for r in rows])
        ok = t[np.isfinite(t)]
        err = [r["error_m"] for r in rows if r.get("error_m") is not None and (
            not multi or every_source_declared(r))]
        wins = sum(bool(r["success"]) for r in rows)
        lo, hi = rate_interval(rows, [bool(r["success"]) for r in rows])
        false = sum(bool(r.get("false_declaration")) for r in rows)
        found = (f"| {sum(int(r.get('sources_found') or 0) for r in rows)} / "
                 f"{sum(int(r.get('sources_true') or 1) for r in rows)} ") if multi else ""
        lines.append(
            f"| {label} | {len(rows)} | {wins / len(rows):.1%} ({lo:.1%}–{hi:.1%}) {found}"
            f"| {false if declares else '—'} "
            f"| {fmt(float(ok.mean()) if ok.size else None)} "
            f"| {fmt(float(ok.std(ddof=1)) if ok.size > 1 else None)} "
            f"| {fmt(_mean([search_time(r) for r in rows]))} "
            f"| {fmt(_mean(err))} | {fmt(max(err) if err else None)} |")
    single = next(filter(None, map(plumes_note, groups.values())), None)
    lines += ["", "The intervals count plume realisations, not only runs: every start of a "
              "replicate flies one plume, so its runs are not independent (Wilson's interval "
              "at the runs over the design effect the replicates' spread gives, with Student's "
              "t on replicates − 1 degrees of freedom; the SEMs likewise)."
              + (f" Note: {single}." if single else "")]
    lines += excursion_table(groups) + command_fault_table(groups)
    lines += behaviour_time_table(groups)
    if is_maintain_study(every):  # nothing declared: TRO's tables say nothing
        path.write_text("\n".join(lines) + "\n", encoding="utf-8")
        return path
    lines += paired_table(groups)
    lines += ["", "## Evaluation protocol", "",
              "Times to source over the successful runs (a failure counts in P(fail) only; "
              f"the 90th and 99th percentiles once there are {PERCENTILE_RUNS[90]} and "
              f"{PERCENTILE_RUNS[99]} of them, — with fewer); "
              "path efficiency = straight line from the start to the true source / true path "
              "flown to success; D0/D3 the mean of each declaration's ratio of TRO's D0 and D3 "
              "(SPEC §11; not the ratio of the means, and not a column of TRO Table IV, which "
              "gives D1/D0 and D1/D3).", "",
              *protocol_table(groups)]
    for label, rows in groups.items():
        declared = [r for r in rows if r.get("t3") is not None]
        if not declared:
            continue  # TRO's tables are about declarations (AB's arrival runs declare nothing)
        lines += ["", f"## {label}: times and paths (TRO Tables III and IV form)", "",
                  "Errors are to the simulator's true source. TRO Table III's 15–50 m are not "
                  "comparable: they are offsets in the vehicle's navigation frame from a "
                  "nominal source position (TRO V).", ""]
        if multi:
            lines += ["Each declared point is listed with its own error (to its nearest true "
                      "source); the error column is the worst of them. The times and paths are "
                      "the last declaration's (the one that completed the set): t2 is the first "
                      "pass within 13 m of the last declared point, and D0 runs from the first "
                      "detection to it, so D1/D0 can be far from 1; the path efficiency's "
                      "straight line runs to the mission's `source`.", ""]
        lines += [("Places in North-East metres from the OpArea's centre (the mission's "
                   "compass)." if frame is not None else
                   "Places in the planning frame (x along the OpArea's long axis).")
                  + " D1 ends at t2, the first pass within 13 m of the declared point (SPEC "
                  "§11), so D1/D0 can be below 1, and is 0 where the first detection was "
                  "already that close (t2 = t1: marked; TRO Table IV's mean counts such runs, "
                  "and the mean row gives it with and without them). The mean row's D1/D0 and "
                  "T_D share are the means of each run's ratio, not the ratios of the means "
                  "beside them.", ""]
        axes = "(N, E)" if frame is not None else "(x, y)"
        lines += [f"| run | start {axes} | declared {axes} | error (m) | T_F (s) | T_T (s) "
                  "| T_D (s) | T_D share | D0 (m) | D1 (m) | D2 (m) | D3 (m) | D1/D0 |",
                  "|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
        shown = declared if len(declared) <= 20 else []
        for r in shown:
            share = td_share(r)
            lines.append(
                f"| r{r['replicate']}s{r['start']} | {_place(r['start_x'], r['start_y'], frame)} "
                f"| {_declared_cell(r, frame)} | {fmt(r.get('error_m'))}"
                f"{' (false)' if r.get('false_declaration') else ''} "
                f"| {fmt(r.get('T_F'))} | {fmt(r.get('T_T'))} "
                f"| {fmt(r.get('T_D'))} | {fmt(share * 100 if share is not None else None)}% "
                f"| {fmt(r.get('D0'))} | {fmt(r.get('D1'))} | {fmt(r.get('D2'))} "
                f"| {fmt(r.get('D3'))} | {fmt(r.get('D1_over_D0'), 2)}"
                f"{' (t2 = t1)' if at_first(r) else ''} |")
        keys = ("error_m", "T_F", "T_T", "T_D", "D0", "D1", "D2", "D3", "D1_over_D0")
        means = {k: _mean([r.get(k) for r in declared]) for k in keys}
        # several sources: the runs that declared one a source (a diff review: 4.8 m here too)
        means["error_m"] = _mean([r.get("error_m") for r in declared if every_source_declared(r)])
        share = _mean([td_share(r) for r in declared])
        lines.append(
            f"| mean of {len(declared)} declared | | | {fmt(means['error_m'])} "
            f"| {fmt(means['T_F'])} | {fmt(means['T_T'])} | {fmt(means['T_D'])} "
            f"| {fmt(share * 100)}% | {fmt(means['D0'])} | {fmt(means['D1'])} "
            f"| {fmt(means['D2'])} | {fmt(means['D3'])} | {fmt(means['D1_over_D0'], 2)}"
            f"{zeros_note(declared)} |")
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path
