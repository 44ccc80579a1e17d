"""Where a study's vehicles start: a grid over the OpArea, or a line of x values (AB Fig. 10)."""

from __future__ import annotations

import math

import numpy as np

from cptbt import study_spec
from cptbt.mission import MissionBase

MAX_STARTS = study_spec.MAX_STARTS


def grid_starts(mission: MissionBase, nx: int, ny: int) -> list[tuple[float, float]]:
    """Cell centres of an ``nx × ny`` grid over the OpArea (planning frame), row by row."""
    a = mission.op_area_geometry()
    xs = a.xmin + (np.arange(nx) + 0.5) * (a.xmax - a.xmin) / nx
    ys = a.ymin + (np.arange(ny) + 0.5) * (a.ymax - a.ymin) / ny
    return [(float(x), float(y)) for y in ys for x in xs]


def line_xs(spec: str) -> list[float]:
    """The x of each start from ``X0:X1:STEP`` inclusive (AB Fig. 10: 0:100:1).

    Raises:
        ValueError: not three finite numbers, STEP not positive, X1 before X0, or more than
            ``MAX_STARTS`` points.
    """
    try:
        x0, x1, step = (float(v) for v in spec.split(":"))
    except ValueError:
        raise ValueError(f"{spec!r} is not a range: expected X0:X1:STEP, e.g. 0:100:5") from None
    if not all(math.isfinite(v) for v in (x0, x1, step)):
        raise ValueError(f"{spec!r}: X0, X1 and STEP must be finite numbers")
    if step <= 0:
        raise ValueError(f"{spec!r}: STEP must be more than 0")
    if x1 < x0:
        raise ValueError(f"{spec!r}: X1 must not be less than X0")
    steps = (x1 - x0) / step + 1e-9  # may be inf for a tiny step: compare before floor()
    if steps >= MAX_STARTS:
        raise ValueError(f"{spec!r}: more than {MAX_STARTS} starts")
    n = math.floor(steps) + 1
    return [x0 + i * step for i in range(n)]


def line_starts(spec: str, y: float = 0.0) -> list[tuple[float, float]]:
    """Starts ``(x, y)`` for x from ``X0:X1:STEP`` inclusive (see :func:`line_xs`)."""
    return [(x, y) for x in line_xs(spec)]
