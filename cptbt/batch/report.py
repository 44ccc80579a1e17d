"""A study's figures (AB Figs. 6, 10, 11; success, error, T_D share) and Markdown tables (TRO
Tables III and IV), built from the results table alone so ``cptbt plot`` can rebuild them."""

from __future__ import annotations

import math
from collections import defaultdict
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from cptbt.batch.figures import pyplot
from cptbt.batch.maintain_report import is_maintain_study, maintain_figure, maintain_table

Rows = list[dict[str, Any]]


def config_label(coords: dict[str, Any], mission: str) -> str:
    """The name of a configuration in tables and legends: its sweep values, else the mission."""
    if not coords:
        return mission
    return ", ".join(f"{path.split('.')[-1]}={value}" for path, value in coords.items())


def _config_label(row: dict[str, Any]) -> str:
    """A row's configuration: its ``configuration`` column (written by every study)."""
    label = row.get("configuration")
    return str(label) if label else str(row.get("mission", "study"))


def _time_to_source(row: dict[str, Any]) -> float:
    """Time to success (declaration, or the oracle's arrival); NaN for failures."""
    if not row.get("success"):
        return math.nan
    t3 = row.get("t3")
    return float(t3) if t3 is not None else float(row.get("sim_time_s") or math.nan)


def _search_time(row: dict[str, Any]) -> float:
    """AB Fig. 6's measure: time to source, a failure counting as the time it ran (the limit)."""
    t = _time_to_source(row)
    return t if math.isfinite(t) else float(row.get("sim_time_s") or math.nan)


def _fmt(v: Any, digits: int = 1) -> str:
    if v is None or (isinstance(v, float) and math.isnan(v)):
        return "—"
    return f"{v:.{digits}f}" if isinstance(v, float) else str(v)


@dataclass(frozen=True)
class StudyGeometry:
    """What the maps draw besides the results: the OpArea, the source and the mean flow.

    Planning frame; ``flow_deg`` is the direction the flow moves toward. Saved in ``study.json``
    so ``cptbt plot`` can redraw the maps from the folder alone.
    """

    area: tuple[float, float, float, float]
    source: tuple[float, float]
    flow_deg: float | None = None

    def to_data(self) -> dict[str, Any]:
        """For ``study.json``."""
        return {"area": list(self.area), "source": list(self.source), "flow_deg": self.flow_deg}

    @classmethod
    def from_data(cls, data: dict[str, Any] | None) -> StudyGeometry | None:
        """From ``study.json`` (None if absent or malformed)."""
        try:
            assert data is not None
            return cls(tuple(data["area"]), tuple(data["source"]), data.get("flow_deg"))
        except (AssertionError, KeyError, TypeError, ValueError):
            return None


def wilson(successes: int, n: int, z: float = 1.96) -> tuple[float, float]:
    """Wilson score interval of a proportion (95% by default); (nan, nan) for n = 0."""
    if n == 0:
        return math.nan, math.nan
    p = successes / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    return max(0.0, centre - half), min(1.0, centre + half)


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


def protocol(rows: Rows) -> Protocol:
    """The evaluation protocol's numbers over ``rows`` (one configuration); NaN where empty."""
    n = len(rows)
    t = np.array([_time_to_source(r) for r in rows], dtype=float)
    ok = t[np.isfinite(t)]
    fails = n - int(np.count_nonzero([bool(r.get("success")) for r in rows]))
    lo, hi = wilson(fails, n)
    mean = float(ok.mean()) if ok.size else math.nan
    sem = float(ok.std(ddof=1) / math.sqrt(ok.size)) if ok.size > 1 else math.nan
    q = np.percentile(ok, [50, 90, 99]) if ok.size else np.full(3, math.nan)
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
            f"| {_fmt(pr.mean_s)} ± {_fmt(pr.sem_s)} | {_fmt(pr.rel_sem, 3)} "
            f"| {_fmt(pr.median_s)} | {_fmt(pr.p90_s)} | {_fmt(pr.p99_s)} "
            f"| {_fmt(pr.efficiency, 2)} / {_fmt(pr.efficiency_median, 2)} "
            f"| {_fmt(pr.d0_over_d3, 2)} |")
    return lines


def write_report(rows: Rows, out: Path, geometry: StudyGeometry | None = None) -> list[Path]:
    """Write every figure and table that means something for the study; the paths written.

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
    groups: dict[str, Rows] = defaultdict(list)
    for r in rows:
        groups[_config_label(r)].append(r)
    written: list[Path | None] = [_tables(groups, out / "tables.md")]
    plt = pyplot()
    written.append(_map(groups, out / "time_to_source_map.png", plt, geometry))
    written.append(_line(groups, out / "time_vs_start.png", plt))
    if is_maintain_study(rows):
        written.append(maintain_figure(groups, out / "maintain_time.png", plt))
    else:
        written.append(_rates(groups, out / "success_and_false_declarations.png", plt))
    written.append(_distributions(groups, out / "error_and_td_share.png", plt))
    return [p for p in written if p is not None]


def _starts(rows: Rows) -> tuple[np.ndarray, np.ndarray]:
    xs = np.array([r["start_x"] for r in rows], dtype=float)
    ys = np.array([r["start_y"] for r in rows], dtype=float)
    return xs, ys


def _per_start(rows: Rows) -> dict[tuple[float, float], Rows]:
    by: dict[tuple[float, float], Rows] = defaultdict(list)
    for r in rows:
        by[(float(r["start_x"]), float(r["start_y"]))].append(r)
    return by


def _edges(centres: list[float]) -> np.ndarray:
    """Cell edges around sorted cell centres."""
    c = np.asarray(centres, dtype=float)
    mid = (c[1:] + c[:-1]) / 2
    return np.concatenate([[c[0] - (mid[0] - c[0])], mid, [c[-1] + (c[-1] - mid[-1])]])


def _map(groups: dict[str, Rows], path: Path, plt: Any,
         geometry: StudyGeometry | None) -> Path | None:
    """Mean time to source over start positions (AB Figs. 6 and 11), one panel per config.

    A heat map on the real aspect ratio, planning frame with y drawn down (as TRO and AB draw
    it), with the OpArea, the true source and the mean flow; contours are added on grids of at
    least 10 × 10 starts. As in AB, a search that fails counts with the time it ran.
    """
    first = next(iter(groups.values()))
    xs_all = sorted({float(r["start_x"]) for r in first})
    ys_all = sorted({float(r["start_y"]) for r in first})
    if len(xs_all) < 2 or len(ys_all) < 2:
        return None  # one start, or starts along a line: the line plot says it
    n = len(groups)
    # The figure takes the map's shape, so the colour bar beside it is as tall as the map.
    if geometry is not None:
        x0, x1, y0, y1 = geometry.area
        aspect = (y1 - y0) / max(x1 - x0, 1e-9)
    else:
        aspect = (ys_all[-1] - ys_all[0]) / max(xs_all[-1] - xs_all[0], 1e-9)
    height = min(max(4.6 * aspect + (1.4 if aspect >= 0.75 else 2.0), 3.2), 7.0)
    fig, axes = plt.subplots(1, n, figsize=(6.0 * n, height), squeeze=False,
                             layout="constrained")
    vmax = max(_mean([_search_time(r) for r in rows]) for rows in groups.values())
    for ax, (label, rows) in zip(axes[0], groups.items(), strict=True):
        by = _per_start(rows)
        xs = sorted({k[0] for k in by})
        ys = sorted({k[1] for k in by})
        grid = np.full((len(ys), len(xs)), np.nan)
        counts = np.zeros(grid.shape, dtype=int)
        for (x, y), runs in by.items():
            grid[ys.index(y), xs.index(x)] = _mean([_search_time(r) for r in runs])
            counts[ys.index(y), xs.index(x)] = len(runs)
        limit = max(float(r.get("sim_time_s") or 0) for r in rows)
        top = max(vmax, limit, 1.0)
        if np.isnan(grid).any():  # scattered starts (--starts), not a grid: points, not cells
            pts = list(by)
            im = ax.scatter([x for x, _ in pts], [y for _, y in pts],
                            c=[grid[ys.index(y), xs.index(x)] for x, y in pts], cmap="viridis",
                            vmin=0, vmax=top, s=90, edgecolors="black", zorder=3)
        else:
            im = ax.pcolormesh(_edges(xs), _edges(ys), grid, cmap="viridis", vmin=0, vmax=top,
                               shading="flat")
        if len(xs) >= 10 and len(ys) >= 10 and not np.isnan(grid).any():
            ax.contour(xs, ys, grid, levels=6, colors="white", linewidths=0.6, alpha=0.7)
        scattered = bool(np.isnan(grid).any())
        if grid.size <= 64 or scattered:
            for (x, y), runs in by.items():
                if scattered:  # beside the point, not on it
                    ax.annotate(f"n={len(runs)}", (x, y), xytext=(0, 9),
                                textcoords="offset points", ha="center", fontsize=7)
                else:
                    ax.text(x, y, f"n={len(runs)}", ha="center", va="center", fontsize=6,
                            color="white")
        # Beside a tall map, under a wide one: the bar is never taller than the map, and its
        # label never longer than the bar.
        fig.colorbar(im, ax=ax, shrink=0.8, location="right" if aspect >= 0.75 else "bottom",
                     label="mean time to source (s); a failure counts as the time it ran")
        if geometry is not None:
            x0, x1, y0, y1 = geometry.area
            ax.add_patch(plt.Rectangle((x0, y0), x1 - x0, y1 - y0, fill=False, ec="black",
                                       lw=1.2))
            ax.plot(*geometry.source, "*", color="gold", mec="black", ms=15, label="source")
            if geometry.flow_deg is not None:
                size = 0.12 * min(x1 - x0, y1 - y0)
                th = math.radians(geometry.flow_deg)
                cx, cy = x0 + 1.5 * size, y0 + 1.2 * size
                # White with a dark outline: readable on every colour of the map.
                from matplotlib import patheffects

                halo = [patheffects.withStroke(linewidth=2.0, foreground="black")]
                arrow = ax.annotate("", xy=(cx + size * math.cos(th), cy + size * math.sin(th)),
                                    xytext=(cx, cy),
                                    arrowprops={"arrowstyle": "-|>", "color": "white", "lw": 2})
                arrow.arrow_patch.set_path_effects(halo)
                ax.text(cx, cy - 0.3 * size, "mean flow", color="white", fontsize=8,
                        ha="center", path_effects=halo)
        runs_n = sorted(set(counts[counts > 0].ravel().tolist()))
        per_cell = f"n = {runs_n[0]}" if len(runs_n) == 1 else f"n = {runs_n[0]}–{runs_n[-1]}"
        ok = sum(bool(r["success"]) for r in rows)
        lo, hi = wilson(ok, len(rows))
        ax.set_title(f"{label}\nsuccess {ok / len(rows):.1%} (95% CI {lo:.1%}–{hi:.1%}) of "
                     f"{len(rows)} runs; {per_cell} per start", fontsize=9)
        ax.set_aspect("equal")
        ax.invert_yaxis()
        ax.set_xlabel("start x (m)")
        ax.set_ylabel("start y (m), drawn down")
    fig.savefig(path, dpi=130)
    plt.close(fig)
    return path


def _line(groups: dict[str, Rows], path: Path, plt: Any) -> Path | None:
    """Mean time to source against the start's x (AB Fig. 10), ± one standard error."""
    first = next(iter(groups.values()))
    xs_all = {float(r["start_x"]) for r in first}
    ys_all = {float(r["start_y"]) for r in first}
    if len(ys_all) == 1 and len(xs_all) > 1:
        axis, fixed = "x", f"y = {next(iter(ys_all)):g} m"
    elif len(xs_all) == 1 and len(ys_all) > 1:
        axis, fixed = "y", f"x = {next(iter(xs_all)):g} m"
    else:
        return None
    fig, ax = plt.subplots(figsize=(7.5, 4.4), layout="constrained")
    for label, rows in groups.items():
        by: dict[float, list[float]] = defaultdict(list)
        for r in rows:
            by[float(r[f"start_{axis}"])].append(_search_time(r))
        pos = sorted(by)
        mean = np.array([_mean(by[p]) for p in pos])
        se = np.array([_sem(by[p]) for p in pos])
        ns = sorted({len(by[p]) for p in pos})
        per = f"{ns[0]}" if len(ns) == 1 else f"{ns[0]}–{ns[-1]}"
        line = ax.plot(pos, mean, "o-", ms=3, label=f"{label} (n = {per} per start)")
        ax.fill_between(pos, mean - se, mean + se, color=line[0].get_color(), alpha=0.25, lw=0)
    ax.set_xlabel(f"start {axis} (m), {fixed}")
    ax.set_ylabel("mean time to source (s) ± 1 SE;\na failure counts as the time it ran")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    fig.savefig(path, dpi=130)
    plt.close(fig)
    return path


def _rates(groups: dict[str, Rows], path: Path, plt: Any) -> Path | None:
    """Success and false-declaration rates per configuration, with 95% Wilson intervals."""
    if len(groups) < 2:
        return None  # one bar says nothing the table does not
    labels = list(groups)
    every = [r for rows in groups.values() for r in rows]
    bars = [("success", "success", "#2ca02c")]
    if _criterion(every) == "declaration" or any(r.get("t3") is not None for r in every):
        bars.append(("false_declaration", "false declaration", "#d62728"))
    width = 0.76 / len(bars)
    fig, ax = plt.subplots(figsize=(max(6.0, 1.4 * len(labels) + 2), 4.2), layout="constrained")
    pos = np.arange(len(labels))
    for k, (key, name, colour) in enumerate(bars):
        rate, lo, hi = [], [], []
        for lab in labels:
            rows = groups[lab]
            hits = sum(bool(r.get(key)) for r in rows)
            a, b = wilson(hits, len(rows))
            rate.append(hits / len(rows))
            # Wilson's bounds can land a rounding error past the rate (0 of n, n of n).
            lo.append(max(0.0, hits / len(rows) - a))
            hi.append(max(0.0, b - hits / len(rows)))
        ax.bar(pos + (k - (len(bars) - 1) / 2) * width, rate, width, yerr=[lo, hi], capsize=3,
               color=colour, label=f"{name} (95% Wilson CI)")
    ax.set_xticks(pos, [f"{lab}\nn = {len(groups[lab])}" for lab in labels], fontsize=8)
    ax.set_ylim(0, 1.05)
    ax.set_ylabel("rate")
    judged = _SUCCESS.get(_criterion(every), "success").removesuffix(" (95% CI)")
    ax.set_title(f"{judged}, per configuration", fontsize=10)
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0))  # off the bars
    ax.grid(axis="y", alpha=0.3)
    fig.savefig(path, dpi=130)
    plt.close(fig)
    return path


def _distributions(groups: dict[str, Rows], path: Path, plt: Any) -> Path | None:
    """Declaration error and T_D share (TRO Table III) histograms, where they exist."""
    judged = {k: rows for k, rows in groups.items()
              if any(r.get("criterion", "declaration") == "declaration" for r in rows)}
    err = {k: [float(r["error_m"]) for r in rows if r.get("error_m") is not None
               and r.get("t3") is not None] for k, rows in judged.items()}
    share = {k: [v for v in map(_td_share, rows) if v is not None] for k, rows in judged.items()}
    if not any(err.values()) and not any(share.values()):
        return None
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(11, 4), layout="constrained")
    radius = next((float(r["success_radius_m"]) for rows in judged.values() for r in rows
                   if r.get("success_radius_m") is not None), None)
    top = max([v for vals in err.values() for v in vals] + [radius or 0.0, 1.0])
    edges = np.linspace(0.0, top * 1.02, 31)  # one set of bins for every configuration
    for k in judged:
        if err[k]:
            a1.hist(err[k], bins=edges, alpha=0.6, label=f"{k} (n = {len(err[k])})")
        if share[k]:
            a2.hist(share[k], bins=20, range=(0, 1), alpha=0.6, label=f"{k} (n = {len(share[k])})")
    if radius is not None:
        a1.axvline(radius, color="#d62728", ls="--", lw=1, label=f"success radius {radius:g} m")
    a1.set_xlabel("declaration error (m)")
    a2.set_xlabel("T_D / mission time to declaration (TRO Table III)")
    for ax in (a1, a2):
        ax.set_ylabel("runs")
        ax.yaxis.get_major_locator().set_params(integer=True)  # counts: no 0.25-run ticks
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize=7)
    fig.savefig(path, dpi=130)
    plt.close(fig)
    return path


def _td_share(row: dict[str, Any]) -> float | None:
    """T_D as a share of the mission time to declaration (TRO Table III), when both exist."""
    if row.get("T_D") is None or not row.get("t3"):
        return None
    return float(row["T_D"]) / float(row["t3"])


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


def _criterion(rows: Rows) -> str:
    """The study's evaluation criterion (its rows share one)."""
    found = {r.get("criterion") or "declaration" for r in rows}
    return found.pop() if len(found) == 1 else "declaration"


def _tables(groups: dict[str, Rows], path: Path) -> Path:
    every = [r for rows in groups.values() for r in rows]
    criterion = _criterion(every)
    mean_col, max_col = _DISTANCE_COLUMNS.get(criterion, _DISTANCE_COLUMNS["declaration"])
    # A study whose runs cannot declare has no false declarations to count: "—", not 0.
    declares = criterion == "declaration" or any(r.get("t3") is not None for r in every)
    lines = ["# Study results", ""]
    if is_maintain_study(every):  # what such a study measures comes first
        lines += [*maintain_table(groups), ""]
    lines += ["## Per configuration", "",
              f"| configuration | runs | {_SUCCESS.get(criterion, 'success (95% CI)')} "
              "| false declarations | mean time to source (s) | sd (s) "
              f"| mean search time, failures at the limit (s) | {mean_col} | {max_col} |",
              "|---|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for label, rows in groups.items():
        t = np.array([_time_to_source(r) for r in rows])
        ok = t[np.isfinite(t)]
        err = [r["error_m"] for r in rows if r.get("error_m") is not None]
        wins = sum(bool(r["success"]) for r in rows)
        lo, hi = wilson(wins, len(rows))
        false = sum(bool(r.get("false_declaration")) for r in rows)
        lines.append(
            f"| {label} | {len(rows)} | {wins / len(rows):.1%} ({lo:.1%}–{hi:.1%}) "
            f"| {false if declares else '—'} "
            f"| {_fmt(float(ok.mean()) if ok.size else None)} "
            f"| {_fmt(float(ok.std(ddof=1)) if ok.size > 1 else None)} "
            f"| {_fmt(_mean([_search_time(r) for r in rows]))} "
            f"| {_fmt(_mean(err))} | {_fmt(max(err) if err else None)} |")
    if is_maintain_study(every):  # nothing declared: TRO's tables say nothing
        path.write_text("\n".join(lines) + "\n", encoding="utf-8")
        return path
    lines += ["", "## Evaluation protocol", "",
              "Times to source over the successful runs (a failure counts in P(fail) only); "
              "path efficiency = straight line from the start to the true source / true path "
              "flown to success; D0/D3 (TRO) over declarations.", "",
              *protocol_table(groups)]
    for label, rows in groups.items():
        declared = [r for r in rows if r.get("t3") is not None]
        if not declared:
            continue  # TRO's tables are about declarations (AB's arrival runs declare nothing)
        lines += ["", f"## {label}: times and paths (TRO Tables III and IV form)", "",
                  "| run | start (x, y) | declared (N, E) | error (m) | T_F (s) | T_T (s) "
                  "| T_D (s) | T_D share | D0 (m) | D1 (m) | D2 (m) | D3 (m) | D1/D0 |",
                  "|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
        shown = declared if len(declared) <= 20 else []
        for r in shown:
            share = _td_share(r)
            lines.append(
                f"| r{r['replicate']}s{r['start']} | ({_fmt(r['start_x'])}, {_fmt(r['start_y'])}) "
                f"| ({_fmt(r.get('declared_source_north'))}, "
                f"{_fmt(r.get('declared_source_east'))}) "
                f"| {_fmt(r.get('error_m'))} | {_fmt(r.get('T_F'))} | {_fmt(r.get('T_T'))} "
                f"| {_fmt(r.get('T_D'))} | {_fmt(share * 100 if share is not None else None)}% "
                f"| {_fmt(r.get('D0'))} | {_fmt(r.get('D1'))} | {_fmt(r.get('D2'))} "
                f"| {_fmt(r.get('D3'))} | {_fmt(r.get('D1_over_D0'), 2)} |")
        keys = ("error_m", "T_F", "T_T", "T_D", "D0", "D1", "D2", "D3", "D1_over_D0")
        means = {k: _mean([r.get(k) for r in declared]) for k in keys}
        share = _mean([_td_share(r) for r in declared])
        lines.append(
            f"| mean of {len(declared)} declared | | | {_fmt(means['error_m'])} "
            f"| {_fmt(means['T_F'])} | {_fmt(means['T_T'])} | {_fmt(means['T_D'])} "
            f"| {_fmt(share * 100)}% | {_fmt(means['D0'])} | {_fmt(means['D1'])} "
            f"| {_fmt(means['D2'])} | {_fmt(means['D3'])} | {_fmt(means['D1_over_D0'], 2)} |")
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path
