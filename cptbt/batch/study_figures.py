"""The study report's figures: maps and lines of time to source over the starts, success rates,
error and T_D-share histograms (the tables and the protocol are :mod:`cptbt.batch.report`'s).

Only presentation: these change no row, so they are outside the code identity
(:data:`cptbt.batch.integrity.PRESENTATION`).
"""

from __future__ import annotations

import math
import textwrap
from collections import defaultdict
from pathlib import Path
from typing import Any

import numpy as np

from cptbt.batch.comparison import every_source_declared, search_time
from cptbt.batch.compass import _north_arrow, _north_points, north_corner
from cptbt.batch.figures import flow_arrow
from cptbt.batch.intervals import rate_interval, replicates
from cptbt.batch.report import (
    Rows,
    StudyGeometry,
    _criterion,
    _mean,
    _sem,
    _several_sources,
    success_label,
    td_share,
)
from cptbt.batch.sweeps import label_parts
from cptbt.frames import OpArea


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


def colour_top(groups: dict[str, Rows]) -> float:
    """The map's colour scale's top, one for every panel (a review saw 0-950 s beside 0-1200
    s): the largest cell drawn. A review's start of one failure in two (1495 s) had been drawn
    in the top colour of a bar ending at its configuration's mean, 1267 s; and the longest
    run's whole time, its drive home included, had left another's map less than half its
    colours (top 1360 s, no cell past 564 s)."""
    cells = [_mean([search_time(r) for r in runs]) for rows in groups.values()
             for runs in _per_start(rows).values()]
    return max([c for c in cells if math.isfinite(c)] + [1.0])


def _map(groups: dict[str, Rows], path: Path, plt: Any, geometry: StudyGeometry | None,
         per_config: dict[int, StudyGeometry] | None = None) -> Path | None:
    """Mean time to source over start positions (AB Figs. 6 and 11), one panel per config.

    A heat map on the real aspect ratio, planning frame with y drawn down (as TRO and AB draw
    it), with the OpArea, the true source and the mean flow, each panel its configuration's
    own (``per_config``, by configuration index; else ``geometry`` for all); contours are
    added on grids of at least 10 × 10 starts. As in AB, a search that fails counts with the
    time limit; the colour scale reaches the largest mean drawn.
    """
    if not _any_time(groups):
        return None
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
    # At most three panels a row (four: two by two): six configurations in one row had made
    # a figure 36 in wide, each map a sliver when opened.
    cols = 2 if n == 4 else min(n, 3)
    nrows = -(-n // cols)
    fig, grid_axes = plt.subplots(nrows, cols, figsize=(6.0 * cols, height * nrows),
                                  squeeze=False, layout="constrained")
    axes = grid_axes.ravel()[:n]
    for spare in grid_axes.ravel()[n:]:
        spare.remove()
    top = colour_top(groups)
    for ax, (label, rows) in zip(axes, groups.items(), strict=True):
        by = _per_start(rows)
        key = rows[0].get("config") if rows else None
        here = (per_config or {}).get(int(key), geometry) if key is not None else geometry
        xs = sorted({k[0] for k in by})
        ys = sorted({k[1] for k in by})
        grid = np.full((len(ys), len(xs)), np.nan)
        counts = np.zeros(grid.shape, dtype=int)
        for (x, y), runs in by.items():
            grid[ys.index(y), xs.index(x)] = _mean([search_time(r) for r in runs])
            counts[ys.index(y), xs.index(x)] = len(runs)
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
        labels = []  # where the "n=" labels are: the arrow keeps off them
        # Per start only when the counts differ (--until-sem): the title gives a single count,
        # and 64 cells of "n=1" left the current's arrow no free corner.
        varied = len(set(counts[counts > 0].ravel().tolist())) > 1
        if varied and (grid.size <= 64 or scattered):
            y_edges = _edges(ys)
            for (x, y), runs in by.items():
                if scattered:  # beside the point, not on it
                    ax.annotate(f"n={len(runs)}", (x, y), xytext=(0, 9),
                                textcoords="offset points", ha="center", fontsize=7)
                    labels.append((x, y))
                else:
                    # viridis is light at its top: dark text there (white was unreadable).
                    # At the cell's top edge (y drawn down), not its centre: a source there,
                    # or the current's arrow in a corner cell, had covered it.
                    j = ys.index(y)
                    at = y_edges[j] + 0.06 * (y_edges[j + 1] - y_edges[j])
                    light = grid[j, xs.index(x)] > 0.7 * top
                    ax.text(x, at, f"n={len(runs)}", ha="center", va="top", fontsize=6,
                            color="black" if light else "white")
                    labels.append((x, at))
        if here is not None:
            x0, x1, y0, y1 = here.area
            ax.add_patch(plt.Rectangle((x0, y0), x1 - x0, y1 - y0, fill=False, ec="black",
                                       lw=1.2))
            stars = np.asarray([here.source, *here.extra_sources], dtype=float)
            ax.plot(stars[:, 0], stars[:, 1], "*", color="gold", mec="black", ms=15, ls="none",
                    label="source" if len(stars) == 1 else "sources")
            marks = np.asarray([*by, *labels, *stars.tolist()], dtype=float)
            if here.ne_frame is not None:  # a compass: the north arrow, as run figures have
                area = OpArea(x0, x1, y0, y1, here.ne_frame)
                corner = north_corner(area, marks, np.empty((0, 2)))
                _north_arrow(ax, area, corner)
                marks = np.concatenate([marks, _north_points(area, corner)])
            if here.flow_deg is not None:  # off the starts, sources and north where it can be
                flow_arrow(ax, OpArea(x0, x1, y0, y1), here.flow_deg, marks)
        runs_n = sorted(set(counts[counts > 0].ravel().tolist()))
        per_cell = f"n = {runs_n[0]}" if len(runs_n) == 1 else f"n = {runs_n[0]}–{runs_n[-1]}"
        ok = sum(bool(r["success"]) for r in rows)
        lo, hi = rate_interval(rows, [bool(r["success"]) for r in rows])
        # wrapped to the panel (~12 characters an inch at 9 pt): two sweeps' label ran into the
        # next panel's, mangling the value that told them apart (a review)
        ax.set_title(f"{textwrap.fill(label, 70, break_on_hyphens=False)}\nsuccess "
                     f"{ok / len(rows):.1%} (95% CI {lo:.1%}–{hi:.1%}) of "
                     f"{len(rows)} runs; {per_cell} per start", fontsize=9)
        # a wide map shrinks its box under constrained layout and lost its title off the top
        # of the figure (a review): it widens its limits instead
        ax.set_aspect("equal", adjustable="box" if aspect >= 0.75 else "datalim")
        ax.invert_yaxis()
        # the planning frame (x along the OpArea's long axis), whatever frame --starts took
        frame = here.ne_frame if here is not None else None  # the panel's own
        # with a compass, its bearing (a review's rotated box had none to read)
        ax.set_xlabel("start x (m), planning frame" + (
            f", compass bearing {frame.x_bearing_deg % 360:.1f}°" if frame is not None else ""))
        # a wide map's panel is short: its whole label had run off the figure's top (a review)
        ax.set_ylabel("start y (m), planning frame, drawn down" if aspect >= 0.75
                      else "start y (m),\ndrawn down")
    # One bar for the panels' one scale: beside tall maps, under wide ones (never taller than
    # the map, its label never longer than the bar).
    beside = aspect >= 0.75
    fig.colorbar(im, ax=axes.tolist(), shrink=0.8 if n == 1 or beside else 0.5,
                 location="right" if beside else "bottom",
                 label="mean search time (s);" + ("\n" if beside else " ")
                 + "a failure counts as the time limit")
    fig.savefig(path, dpi=130)
    plt.close(fig)
    return path


def _any_time(groups: dict[str, Rows]) -> bool:
    """Whether any run has a search time to draw (a run stopped on an error has none)."""
    return any(math.isfinite(search_time(r)) for rows in groups.values() for r in rows)


def _line(groups: dict[str, Rows], path: Path, plt: Any) -> Path | None:
    """Mean time to source against the start's x (AB Fig. 10), ± one standard error."""
    if not _any_time(groups):
        return None  # every run stopped on an error: empty axes said nothing (a review)
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
            by[float(r[f"start_{axis}"])].append(search_time(r))
        pos = sorted(by)
        mean = np.array([_mean(by[p]) for p in pos])
        se = np.array([_sem(by[p]) for p in pos])
        ns = sorted({len(by[p]) for p in pos})
        per = f"{ns[0]}" if len(ns) == 1 else f"{ns[0]}–{ns[-1]}"
        line = ax.plot(pos, mean, "o-", ms=3, label=f"{label} (n = {per} per start)")
        ax.fill_between(pos, mean - se, mean + se, color=line[0].get_color(), alpha=0.25, lw=0)
    ax.set_xlabel(f"start {axis} (m, planning frame), {fixed}")  # as the map says (a review)
    ax.set_ylabel("mean search time (s) ± 1 SE;\na failure counts as the time limit")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    fig.savefig(path, dpi=130)
    plt.close(fig)
    return path


def _rates(groups: dict[str, Rows], path: Path, plt: Any) -> Path | None:
    """Success and false-declaration rates per configuration, with 95% intervals over the
    plumes (:mod:`cptbt.batch.intervals`)."""
    if len(groups) < 2:
        return None  # one bar says nothing the table does not
    labels = list(groups)
    every = [r for rows in groups.values() for r in rows]
    bars = [("success", "success", "#2ca02c")]
    if _criterion(every) == "declaration" or any(r.get("t3") is not None for r in every):
        bars.append(("false_declaration", "false declaration", "#d62728"))
    width = 0.76 / len(bars)
    # One swept setting per line under each bar, and each bar as wide as its longest line
    # (two sweeps' "a=1, b=2" labels ran into each other); past 20 in the labels slant instead.
    ticks = ["\n".join(label_parts(lab)) + f"\nn = {len(groups[lab])}" for lab in labels]
    longest = max(len(line) for t in ticks for line in t.splitlines())
    per_bar = max(1.4, 0.075 * longest)
    slant = per_bar * len(labels) + 2.5 > 20.0
    fig_w = min(20.0, max(6.0, (1.4 if slant else per_bar) * len(labels) + 2.5))
    fig, ax = plt.subplots(figsize=(fig_w, 4.2 + (0.14 * longest if slant else 0.0)),
                           layout="constrained")
    pos = np.arange(len(labels))
    # over the plumes where there are several; one plume's covers its starts only (a review)
    over = (" over plumes" if all(replicates(groups[lab]) > 1 for lab in labels)
            else ", one plume: its starts only")
    for k, (key, name, colour) in enumerate(bars):
        rate, lo, hi, counts = [], [], [], []
        for lab in labels:
            rows = groups[lab]
            hits = sum(bool(r.get(key)) for r in rows)
            counts.append(f"{hits}/{len(rows)}")
            a, b = rate_interval(rows, [bool(r.get(key)) for r in rows])
            rate.append(hits / len(rows))
            # Wilson's bounds can land a rounding error past the rate (0 of n, n of n).
            lo.append(max(0.0, hits / len(rows) - a))
            hi.append(max(0.0, b - hits / len(rows)))
        drawn = ax.bar(pos + (k - (len(bars) - 1) / 2) * width, rate, width, yerr=[lo, hi],
                       capsize=3, color=colour, label=f"{name} (95% CI{over})")
        # the count on each bar: a rate of 0 is no bar, only its interval (a review read it as
        # a floating error bar)
        ax.bar_label(drawn, counts, padding=2, fontsize=7, label_type="edge")
    ax.set_xticks(pos, ticks, fontsize=8)
    if slant:
        ax.tick_params(axis="x", labelrotation=30)
        for tick in ax.get_xticklabels():
            tick.set_horizontalalignment("right")
    ax.set_ylim(0, 1.05)
    ax.set_ylabel("rate")
    judged = success_label(every).removesuffix(" (95% CI)")
    title = f"{judged}, per configuration" + (" (and false declarations)"
                                               if len(bars) > 1 else "")
    # wrapped to the plot's width (a two-source title lost its start at the page's edge)
    ax.set_title(textwrap.fill(title, max(30, int(11 * (fig_w - 2.5)))), fontsize=10)
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0))  # off the bars
    ax.grid(axis="y", alpha=0.3)
    fig.savefig(path, dpi=130)
    plt.close(fig)
    return path


def _distributions(groups: dict[str, Rows], path: Path, plt: Any) -> Path | None:
    """Declaration error and T_D share (TRO Table III) histograms, where they exist."""
    judged = {k: rows for k, rows in groups.items()
              if any(r.get("criterion", "declaration") == "declaration" for r in rows)}
    # several sources: the runs that declared one point a source (a rule declaring one alone
    # had drawn inside the success line; a review)
    err = {k: [float(r["error_m"]) for r in rows if r.get("error_m") is not None
               and r.get("t3") is not None and every_source_declared(r)]
           for k, rows in judged.items()}
    share = {k: [v for v in map(td_share, rows) if v is not None] for k, rows in judged.items()}
    if not any(err.values()) and not any(share.values()):
        return None
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(11, 4), layout="constrained")
    radius = next((float(r["success_radius_m"]) for rows in judged.values() for r in rows
                   if r.get("success_radius_m") is not None), None)
    top = max([v for vals in err.values() for v in vals] + [radius or 0.0, 1.0])
    # Fewer, wider bins as configurations share them: four side by side in 30 bins were a
    # pixel wide each, under their white edges (a review saw an empty error panel)
    many = max(1, sum(1 for k in judged if err[k] or share[k]))
    edges = np.linspace(0.0, top * 1.02, max(8, 30 // many) + 1)  # one set for every config
    # Several configurations: their bars side by side in each bin (filled bars at alpha 0.6
    # blended into colours no configuration has, and outlines of equal height hid each other:
    # two reviews); the colours follow the configurations whether or not a panel has them all.
    colours = {k: f"C{i}" for i, k in enumerate(judged)}
    for ax, values, bins in ((a1, err, edges),
                             # tenths (twentieths for one): edges on the axis's ticks (a
                             # review had to infer which 1/8-wide bin a bar stood for)
                             (a2, share, np.linspace(0.0, 1.0, (20 if many == 1 else 10) + 1))):
        have = [k for k in judged if values[k]]
        if have:
            # edged: runs in adjacent bins had drawn as one wide block (a review read 3 as 1)
            ax.hist([values[k] for k in have], bins=bins, color=[colours[k] for k in have],
                    label=list(have), edgecolor="white",
                    linewidth=0.8 if many <= 2 else 0.4)
    if radius is not None:
        a1.axvline(radius, color="#d62728", ls="--", lw=1, label=f"success radius {radius:g} m")
    # Several true sources: a run's error_m is its worst declared source's, and T_D and t3
    # end at the declaration that completed the set (a review read them as the first's).
    several = any(_several_sources(rows) for rows in judged.values())
    a1.set_xlabel("worst declared source's error, runs declaring every source (m)" if several
                  else "declaration error (m)")
    a2.set_xlabel("T_D of the last declaration / mission time to it (TRO Table III)" if several
                  else "T_D / mission time to declaration (TRO Table III)")
    a1.set_title("How far off the declared sources were" if several
                 else "How far off the declared source was", fontsize=10)
    a2.set_title("Share of the mission spent declaring (T_D)", fontsize=10)  # fits the panel
    entries: dict[str, Any] = {}  # one legend for both panels: each configuration once
    for ax in (a1, a2):
        ax.set_ylabel("runs")
        ax.yaxis.get_major_locator().set_params(integer=True)  # counts: no 0.25-run ticks
        for handle, text in zip(*ax.get_legend_handles_labels(), strict=True):
            if text in judged:  # a configuration: with its counts in each panel
                n_err, n_share = len(err[text]), len(share[text])
                runs = len(judged[text])  # the runs that declared nothing are said (a review
                # read "n = 28" of a study of 30)
                of = f" of {runs} runs" if max(n_err, n_share) < runs else ""
                count = (f" (n = {n_err}{of})" if n_err == n_share or not n_share
                         else f" (n = {n_share}{of})" if not n_err
                         else f" (n = {n_err} errors, {n_share} T_D shares{of})")
                # unbreakable spaces: wrapped whole, not mid-phrase (a review's "16 / runs)")
                text += " " + count[1:].replace(" ", "\u00a0")
            entries.setdefault(text, handle)
    if entries:  # under the panels, long labels wrapped (two sweeps' labels had run off the
        # page and over each other, a legend per panel: a review)
        width = max(len(t) for t in entries)
        ncol = 1 if width > 70 else 2
        fig.legend(list(entries.values()),
                   [textwrap.fill(t, 100 if ncol == 1 else 60) for t in entries],
                   loc="outside lower center", ncol=ncol, fontsize=7, frameon=False)
    fig.savefig(path, dpi=130)
    plt.close(fig)
    return path


STUDY_FIGURES = ("time_to_source_map.png", "time_vs_start.png", "maintain_time.png",
                 "success_and_false_declarations.png", "error_and_td_share.png")
"""The figures :func:`cptbt.batch.report.write_report` may draw."""


def drop_stale(out: Path, written: list[Path]) -> list[Path]:
    """Remove the study figures in ``out`` that this report did not draw: an earlier report's,
    now stale (a review extended a study with ``--no-plots``: its old figures of 34 of 40 runs
    stood beside tables of 48)."""
    for name in STUDY_FIGURES:
        if out / name not in written:
            (out / name).unlink(missing_ok=True)
    return written
