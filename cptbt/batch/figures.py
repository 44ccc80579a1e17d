"""Figures of runs and studies (matplotlib, imported lazily: it is the ``plot`` extra)."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from cptbt.batch.engine import VehicleRun
from cptbt.frames import OpArea
from cptbt.types import Point

BEHAVIOUR_COLOURS = {
    "safety": "#d62728",
    "declare_source": "#9467bd",
    "maintain_plume": "#2ca02c",
    "track_in": "#2ca02c",
    "track_out": "#98df8a",
    "reacquire_plume": "#ff7f0e",
    "find_plume": "#1f77b4",
    "move_to_field": "#7f7f7f",
    "return_home": "#8c564b",
    "none": "#bbbbbb",
}


PHASE_STYLES = {
    "mission_a": ("#555555", "--", "Mission A (vehicle)"),
    "return_to_break_off": ("#8c564b", ":", "return to break-off"),
    "amp.give_back": ("#8c564b", ":", "return to break-off"),
    "pre_launch": ("#555555", "--", "Mission A (vehicle)"),
    "post_mission": ("#555555", "--", "Mission A (vehicle)"),
}
"""How the phases outside the AMP override are drawn (trace column ``phase``)."""


def _phase_style(phase: str) -> tuple[str, str, str] | None:
    return PHASE_STYLES.get(phase) or PHASE_STYLES.get(phase.split(".")[0])


def _colour(active: str) -> str:
    for key in (active, active.split(".")[-1], active.split(".")[0]):
        if key in BEHAVIOUR_COLOURS:
            return BEHAVIOUR_COLOURS[key]
    return "#17becf"


def pyplot() -> Any:
    """matplotlib.pyplot on a non-interactive backend, or a clear error without the extra."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError as exc:  # pragma: no cover - depends on the install
        raise RuntimeError("figures need matplotlib: pip install 'cptbt[plot]'") from exc
    return plt


def trajectory_figure(
    path: Path,
    run: VehicleRun,
    area: OpArea,
    source: Point,
    plume: tuple[np.ndarray, np.ndarray, np.ndarray] | None,
    title: str,
    *,
    waypoints: Sequence[Point] | None = None,
) -> None:
    """The run in the planning frame, drawn as TRO Figs. 10–12 (y positive down).

    With a ``phase`` column in the trace (a phased run), the parts of the track outside the AMP
    override are drawn dashed (Mission A) or dotted (return to the break-off point), and the
    planned Mission A ``waypoints`` as a light dashed line (TRO Fig. 1).
    """
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(10, 5.2), constrained_layout=True)
    if plume is not None:
        xs, ys, conc = plume
        ax.pcolormesh(xs, ys, conc, cmap="Greys", shading="auto",
                      vmin=0, vmax=max(float(np.percentile(conc, 99.5)), 1e-9), alpha=0.6)
    ax.add_patch(plt.Rectangle((area.xmin, area.ymin), area.xmax - area.xmin,
                               area.ymax - area.ymin, fill=False, lw=1.5, ec="black"))
    trace = run.trace or {}
    xs_true = np.asarray(trace.get("x", run.path_true[:, 0]))
    ys_true = np.asarray(trace.get("y", run.path_true[:, 1]))
    actives = list(trace.get("active", ["none"] * len(xs_true)))
    phases = trace.get("phase")
    if phases is not None:
        actives = [f"phase:{ph}" if _phase_style(ph) else a for a, ph in zip(actives, phases,
                                                                            strict=True)]
    if waypoints:
        ax.plot([w.x for w in waypoints], [w.y for w in waypoints], "--", color="#aaaaaa", lw=0.8,
                marker=".", label="Mission A plan")
    seen: set[str] = set()
    start = 0
    for i in range(1, len(xs_true) + 1):
        if i == len(xs_true) or actives[i] != actives[start]:
            name = actives[start] or "none"
            style = _phase_style(name.removeprefix("phase:")) if name.startswith("phase:") else None
            colour, ls, shown = style if style else (_colour(name), "-", name)
            label = None if shown in seen else shown
            seen.add(shown)
            seg = slice(start, min(i + 1, len(xs_true)))
            ax.plot(xs_true[seg], ys_true[seg], color=colour, ls=ls, lw=1.6, label=label)
            start = i
    if len(run.detections):
        d = run.detections
        ax.plot(d[:, 0], d[:, 1], "x", color="black", ms=4, mew=1, label="detection (est.)")
    if run.lost_contacts:
        lc = np.asarray([(p.x, p.y) for p in run.lost_contacts])
        ax.plot(lc[:, 0], lc[:, 1], "s", mfc="none", mec="#ff7f0e", ms=6, label="lost contact")
    ax.plot(*run.start, "o", mfc="white", mec="black", ms=8, label="start")
    ax.plot(source.x, source.y, "*", color="gold", mec="black", ms=16, label="true source")
    if run.declared is not None:
        ax.plot(run.declared.x, run.declared.y, "o", color="#9467bd", mec="black", ms=9,
                label="declared source")
    ax.set_aspect("equal")
    ax.invert_yaxis()  # TRO draws the planning y axis positive downward
    ax.set_xlabel("x (m), along the OpArea's long axis")
    ax.set_ylabel("y (m)")
    ax.set_title(title)
    ax.legend(loc="center left", bbox_to_anchor=(1.01, 0.5), fontsize=8, frameon=False)
    fig.savefig(path, dpi=150)
    plt.close(fig)
