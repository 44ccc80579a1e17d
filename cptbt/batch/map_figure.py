"""The source-likelihood map's panel of ``trajectory.png`` and the source markers it shares
with the track's panel (matplotlib, imported lazily by the caller: the ``plot`` extra)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from cptbt.frames import OpArea
from cptbt.types import Point, SourceBelief

VERIFYING_COLOUR = "#ff00ff"
VERIFYING_LABEL = "candidate a fly-by was verifying"
"""The marker of the candidate a fly-by cut short was verifying, on both panels."""


def source_markers(ax: Any, truth: Sequence[Point], declared: Sequence[Point],
                   label: bool = True) -> None:
    """True sources (stars) and declared sources (circles) on one panel."""
    ax.plot([q.x for q in truth], [q.y for q in truth], "*", color="gold", mec="black", ms=16,
            ls="none", label=(("true source" if len(truth) == 1 else "true sources")
                              if label else None))
    if declared:
        ax.plot([q.x for q in declared], [q.y for q in declared], "o", color="#9467bd",
                mec="black", ms=9, ls="none",
                label=(("declared source" if len(declared) == 1
                        else "declared sources, numbered in order") if label else None))
    if len(declared) > 1:  # which came first (a review could not tell)
        for i, q in enumerate(declared, start=1):
            ax.annotate(str(i), (q.x, q.y), xytext=(7, 7), textcoords="offset points",
                        fontsize=11, fontweight="bold", color="#4b2a7a",
                        bbox={"boxstyle": "round,pad=0.15", "fc": "white", "ec": "#4b2a7a",
                              "lw": 0.8, "alpha": 0.85})


def map_panel(ax: Any, belief: SourceBelief, area: OpArea, truth: Sequence[Point],
              declared: Sequence[Point], report: dict[str, Any], plt: Any) -> None:
    """The source-likelihood posterior (log scale, four decades) with the declarations."""
    from matplotlib.colors import LogNorm

    post = np.asarray(belief.posterior, dtype=float)
    top = float(post.max()) if post.size else 0.0
    if top > 0:
        shown = np.where(post >= top * 1e-4, post, np.nan)
        mesh = ax.pcolormesh(belief.xs, belief.ys, shown, cmap="viridis", shading="auto",
                             norm=LogNorm(vmin=top * 1e-4, vmax=top), rasterized=True)
        bar = plt.colorbar(mesh, ax=ax, location="bottom", shrink=0.5, aspect=40, pad=0.02)
        when = ("the search gave up" if report.get("search_given_up") else
                "the end of the run, verifying a candidate" if report.get("verifying_at") else
                "the end of the run, still searching" if report.get("map_at") == "end"
                else "last declaration" if len(declared) > 1 else "declaration")
        bar.set_label(f"source-likelihood posterior per cell at t = {belief.t:.0f} s ({when}), "
                      "log scale;\nwhite inside the OpArea: below 1e-4 of the peak (ruled out)",
                      fontsize=8)
    else:  # every cell masked by a declared source: a blank panel said nothing
        ax.text(0.5 * (area.xmin + area.xmax), 0.5 * (area.ymin + area.ymax),
                f"t = {belief.t:.0f} s: every cell ruled out\n(within mask_radius_m of a "
                "declared source)", ha="center", va="center", fontsize=9, color="#444444")
    ax.add_patch(plt.Rectangle((area.xmin, area.ymin), area.xmax - area.xmin,
                               area.ymax - area.ymin, fill=False, lw=1.5, ec="black"))
    withdrawn = report.get("withdrawn_at") or []
    if withdrawn:
        w = np.asarray(withdrawn, dtype=float)
        ax.plot(w[:, 0], w[:, 1], "X", color="#d62728", mec="black", ms=9, ls="none",
                label="withdrawn after fly-by")
    source_markers(ax, truth, declared, label=False)
    replaced = report.get("superseded_at") or []
    if replaced:  # a ring, drawn last: it may sit on a true source's star
        r = np.asarray(replaced, dtype=float)
        ax.plot(r[:, 0], r[:, 1], "o", mfc="none", mec="#9467bd", mew=2.0, ms=15, ls="none",
                zorder=10, label="replaced declaration (taken for the same source)")
    for key, colour, what in (("held_at", "#ff7f0e", "held candidate (unconfirmed: in a "
                               "declared source's plume)"),  # summary: held_candidate
                              ("verifying_at", VERIFYING_COLOUR, VERIFYING_LABEL)):
        if report.get(key):  # a probable source the rule had not confirmed
            ax.plot(*report[key], "D", mfc="none", mec=colour, mew=2.0, ms=12, ls="none",
                    zorder=10, label=what)
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m), 90° clockwise from x")
    # when the map was drawn, as its colour bar says (a review read "at the declaration")
    moment = ("when the search gave up" if report.get("search_given_up") else
              "at the end of the run" if report.get("map_at") == "end" else
              "at the last declaration" if len(declared) > 1 else "at the declaration")
    ax.set_title(f"Where the source is likely: the source-likelihood map {moment}",
                 fontsize=10)
