"""A study's figures (AB Figs. 6, 10, 11; success, error, T_D share) and Markdown tables (TRO
Tables III and IV), built from the results table alone so ``cptbt plot`` can rebuild them."""

from __future__ import annotations

import math
from collections import defaultdict
from pathlib import Path
from typing import Any

import numpy as np

from cptbt.batch.figures import pyplot

Rows = list[dict[str, Any]]
META = {"config", "replicate", "start"}


def _config_label(row: dict[str, Any], sweep_cols: list[str]) -> str:
    if not sweep_cols:
        return str(row.get("mission", "study"))
    return ", ".join(f"{c.split('.')[-1]}={row.get(c)}" for c in sweep_cols)


def _sweep_columns(rows: Rows) -> list[str]:
    first = rows[0]
    cols = list(first)
    end = cols.index("replicate") if "replicate" in cols else 0
    return [c for c in cols[:end] if c not in META]


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


def write_report(rows: Rows, out: Path) -> list[Path]:
    """Write every figure and table that fits the study; returns the paths written."""
    if not rows:
        return []
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    sweep_cols = _sweep_columns(rows)
    groups: dict[str, Rows] = defaultdict(list)
    for r in rows:
        groups[_config_label(r, sweep_cols)].append(r)
    written: list[Path | None] = [_tables(groups, out / "tables.md")]
    plt = pyplot()
    written.append(_map(groups, out / "time_to_source_map.png", plt))
    line = _line(groups, out / "time_vs_start_x.png", plt)
    if line:
        written.append(line)
    written.append(_outcomes(groups, out / "success_and_error.png", plt))
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


def _map(groups: dict[str, Rows], path: Path, plt: Any) -> Path | None:
    """Mean time to source over start positions (AB Figs. 6 and 11), one panel per config.

    As in AB, a search that fails counts with the time it ran (the 300 s limit in AB).
    """
    n = len(groups)
    fig, axes = plt.subplots(1, n, figsize=(5.2 * n, 4.6), squeeze=False, constrained_layout=True)
    for ax, (label, rows) in zip(axes[0], groups.items(), strict=True):
        by = _per_start(rows)
        xs = sorted({k[0] for k in by})
        ys = sorted({k[1] for k in by})
        grid = np.full((len(ys), len(xs)), np.nan)
        succ = np.full_like(grid, np.nan)
        for (x, y), runs in by.items():
            grid[ys.index(y), xs.index(x)] = _mean([_search_time(r) for r in runs])
            succ[ys.index(y), xs.index(x)] = np.mean([bool(r["success"]) for r in runs])
        if len(xs) > 1 and len(ys) > 1:
            im = ax.contourf(xs, ys, grid, levels=12, cmap="viridis")
            fig.colorbar(im, ax=ax, label="mean time to source (s), failures at the limit")
            ax.invert_yaxis()
        else:
            ax.plot(xs if len(xs) > 1 else ys, grid.ravel(), "o-")
            ax.set_ylabel("mean time to source (s)")
        rate = np.nanmean(succ)
        ax.set_title(f"{label}\nsuccess {rate:.1%} over {len(rows)} runs", fontsize=9)
        ax.set_xlabel("start x (m)")
        if len(ys) > 1:
            ax.set_ylabel("start y (m)")
    fig.savefig(path, dpi=130)
    plt.close(fig)
    return path


def _line(groups: dict[str, Rows], path: Path, plt: Any) -> Path | None:
    """Mean time to source against start x, one curve per config (AB Fig. 10)."""
    ys = {float(r["start_y"]) for rows in groups.values() for r in rows}
    if len(ys) != 1:
        return None
    fig, ax = plt.subplots(figsize=(7, 4.2), constrained_layout=True)
    y = next(iter(ys))
    for label, rows in groups.items():
        by = _per_start(rows)
        xs = sorted({k[0] for k in by})
        mean = [_mean([_search_time(r) for r in by[(x, y)]]) for x in xs]
        ax.plot(xs, mean, "o-", ms=3, label=label)
    ax.set_xlabel("start x (m)")
    ax.set_ylabel("mean time to source (s), failures at the limit")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    fig.savefig(path, dpi=130)
    plt.close(fig)
    return path


def _outcomes(groups: dict[str, Rows], path: Path, plt: Any) -> Path:
    """Success rate, declaration error and T_D share per config."""
    fig, (a1, a2, a3) = plt.subplots(1, 3, figsize=(14, 4), constrained_layout=True)
    labels = list(groups)
    rates = [np.mean([bool(r["success"]) for r in groups[k]]) for k in labels]
    a1.bar(range(len(labels)), rates, color="#2ca02c")
    a1.set_xticks(range(len(labels)), labels, rotation=20, ha="right", fontsize=8)
    a1.set_ylim(0, 1)
    a1.set_ylabel("success rate")
    for k in labels:
        err = [r["error_m"] for r in groups[k] if r.get("error_m") is not None]
        if err:
            a2.hist(err, bins=30, alpha=0.6, label=k)
        share = [v for v in map(_td_share, groups[k]) if v is not None]
        if share:
            a3.hist(share, bins=20, range=(0, 1), alpha=0.6, label=k)
    a2.set_xlabel("declaration error (m)")
    a2.set_ylabel("runs")
    a3.set_xlabel("T_D / mission time (TRO Table III)")
    for ax in (a2, a3):
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


def _mean(values: list[Any]) -> float:
    v = [float(x) for x in values if x is not None and not (isinstance(x, float) and math.isnan(x))]
    return float(np.mean(v)) if v else math.nan


def _tables(groups: dict[str, Rows], path: Path) -> Path:
    lines = ["# Study results", "", "## Per configuration", "",
             "| configuration | runs | success | mean time to source (s) | sd (s) "
             "| mean search time, failures at the limit (s) | mean error (m) | max error (m) |",
             "|---|---:|---:|---:|---:|---:|---:|---:|"]
    for label, rows in groups.items():
        t = np.array([_time_to_source(r) for r in rows])
        ok = t[np.isfinite(t)]
        err = [r["error_m"] for r in rows if r.get("error_m") is not None]
        lines.append(
            f"| {label} | {len(rows)} | {np.mean([bool(r['success']) for r in rows]):.1%} "
            f"| {_fmt(float(ok.mean()) if ok.size else None)} "
            f"| {_fmt(float(ok.std()) if ok.size > 1 else None)} "
            f"| {_fmt(_mean([_search_time(r) for r in rows]))} "
            f"| {_fmt(_mean(err))} | {_fmt(max(err) if err else None)} |")
    for label, rows in groups.items():
        declared = [r for r in rows if r.get("t3") is not None]
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
