"""Optional numba kernels for the simulator's hot loops (``pip install ".[fast]"``).

The flow and the plume keep their numpy code as the reference; when numba is importable they
hand the same work to a compiled loop here. Two tiers:

- ``exact`` (the default with numba): the bilinear flow lookup, the puff advance, the drop of
  puffs outside the domain and the flow PDE sub-step. These are element-wise IEEE operations in
  the numpy code's order (numba does not contract ``a*b + c`` into a fused multiply-add unless
  ``fastmath`` is set), so they give the same numbers bit for bit; the random draws stay in numpy.
  ``tests/sim/test_sim_kernels.py`` checks the equality.
- ``fast`` (opt-in): also the concentration at few points as a plain double loop. Its sum order
  and ``exp`` differ from numpy's matrix product in the last bits (relative 1e-15), so a run may
  differ in a rare threshold crossing; it is never switched on silently.

The tier is read from the environment variable ``CPTBT_KERNELS`` (``numpy``, ``exact`` or
``fast``; default ``exact`` when numba is installed, else ``numpy``) and can be changed at run
time with :func:`use`.
"""

from __future__ import annotations

import importlib.util
import logging
import math
import os
from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray

Tier = Literal["numpy", "exact", "fast"]

HAVE_NUMBA = importlib.util.find_spec("numba") is not None
"""numba is installed (it is imported, and the kernels compiled or loaded from their on-disk
cache, only when a kernel tier is selected: ``import numba`` alone costs ~0.3 s)."""
_COMPILED = False

EXACT = False
"""Use the bit-for-bit kernels (flow lookup, puff advance, drop, flow sub-step)."""
FAST = False
"""Also use the kernels that differ from numpy in the last bits (concentration)."""


def use(tier: Tier) -> None:
    """Select the kernel tier for this process.

    Args:
        tier: ``"numpy"`` (no kernels), ``"exact"`` or ``"fast"``.

    Raises:
        ValueError: an unknown tier, or a kernel tier without numba installed.
    """
    global EXACT, FAST
    if tier not in ("numpy", "exact", "fast"):
        raise ValueError(f"unknown kernel tier {tier!r}; expected numpy, exact or fast")
    if tier != "numpy" and not HAVE_NUMBA:
        raise ValueError(f"kernel tier {tier!r} needs numba: pip install 'cptbt[fast]'")
    if tier != "numpy":
        _compile()
    EXACT = tier != "numpy"
    FAST = tier == "fast"


def tier() -> Tier:
    """The kernel tier in force."""
    return "fast" if FAST else "exact" if EXACT else "numpy"


_CACHE_NOTE: str | None = None
"""Said once, by :func:`say_cache_note`, when a world is made: the kernels are compiled at
import, before a command has set its logging up (a diff review saw the note bare, and under
``--quiet``)."""


def say_cache_note() -> None:
    """Log that the kernels have no on-disk cache here, once per process (if so)."""
    global _CACHE_NOTE
    if _CACHE_NOTE is not None:
        logging.getLogger(__name__).warning("%s", _CACHE_NOTE)
        _CACHE_NOTE = None


def _compile() -> None:
    """Replace the plain-Python loops below by their numba-compiled versions (once)."""
    global _COMPILED
    if _COMPILED:
        return
    import numba

    cache = True
    for name in ("_bilinear", "_advance", "_compact", "_substep", "_concentration_direct"):
        try:
            globals()[name] = numba.njit(cache=cache, nogil=True)(globals()[name])
        except RuntimeError as exc:  # no writable cache: the package folder and $HOME are
            # read-only (a shared install, a service user, a vehicle's read-only root): every
            # command had stopped on "internal error: cannot cache function" (a review)
            if not cache or "cannot cache" not in str(exc):
                raise
            cache = False
            global _CACHE_NOTE
            _CACHE_NOTE = (f"numba cannot write its kernel cache here ({' '.join(str(exc).split())}"
                           "): the kernels are compiled afresh in each process (set "
                           "NUMBA_CACHE_DIR to a writable folder to keep them)")
            globals()[name] = numba.njit(cache=False, nogil=True)(globals()[name])
    _COMPILED = True


def _bilinear(
    flat: NDArray[np.float64],
    nx: int,
    ny: int,
    x0: float,
    y0: float,
    dx: float,
    dy: float,
    cu: float,
    cv: float,
    xy: NDArray[np.float64],
    out: NDArray[np.float64],
) -> None:
    xhi = nx - 1.000001
    yhi = ny - 1.000001
    for k in range(xy.shape[0]):
        fx = min(max((xy[k, 0] - x0) / dx, 0.0), xhi)
        fy = min(max((xy[k, 1] - y0) / dy, 0.0), yhi)
        ix = int(fx)
        iy = int(fy)
        wx = fx - ix
        wy = fy - iy
        i00 = iy * nx + ix
        for c in range(2):
            a = flat[c, i00]
            b = flat[c, i00 + 1]
            cc = flat[c, i00 + nx]
            d = flat[c, i00 + nx + 1]
            val = (a * (1 - wx) + b * wx) * (1 - wy) + (cc * (1 - wx) + d * wx) * wy
            out[k, c] = val + (cu if c == 0 else cv)


def bilinear(flow: Any, xy: NDArray[np.float64]) -> NDArray[np.float64]:
    """``MeanderingFlow.velocity_at`` as a kernel: the flow at points ``xy`` (N, 2) → (N, 2)."""
    pts = np.ascontiguousarray(xy, dtype=float).reshape(-1, 2)
    out = np.empty_like(pts)
    _bilinear(flow._flat, flow.nx, flow.ny, float(flow.xs[0]), float(flow.ys[0]), flow.dx,
              flow.dy, float(flow._common[0]), float(flow._common[1]), pts, out)
    return out


def _advance(
    xy: NDArray[np.float64],
    vel: NDArray[np.float64],
    noise: NDArray[np.float64],
    r2: NDArray[np.float64],
    dt: float,
    walk: float,
    dr2: float,
) -> None:
    for k in range(xy.shape[0]):
        xy[k, 0] = xy[k, 0] + (vel[k, 0] * dt + walk * noise[k, 0])
        xy[k, 1] = xy[k, 1] + (vel[k, 1] * dt + walk * noise[k, 1])
        r2[k] = r2[k] + dr2


def advance_puffs(
    xy: NDArray[np.float64],
    r2: NDArray[np.float64],
    vel: NDArray[np.float64],
    noise: NDArray[np.float64],
    dt: float,
    walk: float,
    dr2: float,
) -> None:
    """In place: ``xy += vel·dt + walk·noise`` and ``r2 += dr2`` (the puff step's Euler move)."""
    _advance(xy, vel, noise, r2, dt, walk, dr2)


def _compact(
    xy: NDArray[np.float64],
    r2: NDArray[np.float64],
    n: int,
    xmin: float,
    xmax: float,
    ymin: float,
    ymax: float,
) -> int:
    kept = 0
    for k in range(n):
        x = xy[k, 0]
        y = xy[k, 1]
        if x >= xmin and x <= xmax and y >= ymin and y <= ymax:
            if kept != k:
                xy[kept, 0] = x
                xy[kept, 1] = y
                r2[kept] = r2[k]
            kept += 1
    return kept


def compact_inside(
    xy: NDArray[np.float64], r2: NDArray[np.float64], n: int, domain: tuple[float, ...]
) -> int:
    """Move the first ``n`` puffs inside ``domain`` to the front, in order; return their count."""
    xmin, xmax, ymin, ymax = domain
    return int(_compact(xy, r2, n, xmin, xmax, ymin, ymax))


def _substep(
    f: NDArray[np.float64],
    noise: NDArray[np.float64],
    mean: NDArray[np.float64],
    rx: NDArray[np.float64],
    ry: NDArray[np.float64],
    rhs: NDArray[np.float64],
    h: float,
    dx: float,
    dy: float,
    k_diff: float,
) -> None:
    ny = f.shape[1]
    nx = f.shape[2]
    for comp in range(2):
        c00 = mean[comp] + noise[comp, 0]
        c10 = mean[comp] + noise[comp, 1]
        c01 = mean[comp] + noise[comp, 2]
        c11 = mean[comp] + noise[comp, 3]
        for i in range(nx):
            f[comp, 0, i] = c00 + rx[i] * (c10 - c00)
            f[comp, ny - 1, i] = c01 + rx[i] * (c11 - c01)
        for j in range(ny):
            f[comp, j, 0] = c00 + ry[j] * (c01 - c00)
            f[comp, j, nx - 1] = c10 + ry[j] * (c11 - c10)
    dx2 = dx**2
    dy2 = dy**2
    for comp in range(2):
        for j in range(1, ny - 1):
            for i in range(1, nx - 1):
                c = f[comp, j, i]
                west = f[comp, j, i - 1]
                east = f[comp, j, i + 1]
                south = f[comp, j - 1, i]
                north = f[comp, j + 1, i]
                u = f[0, j, i]
                v = f[1, j, i]
                ddx = (c - west if u > 0 else east - c) / dx
                ddy = (c - south if v > 0 else north - c) / dy
                lap = (west - 2 * c + east) / dx2 + (south - 2 * c + north) / dy2
                rhs[comp, j, i] = -u * ddx - v * ddy + k_diff * lap
    for comp in range(2):
        for j in range(1, ny - 1):
            for i in range(1, nx - 1):
                f[comp, j, i] = f[comp, j, i] + h * rhs[comp, j, i]


def flow_substep(flow: Any, h: float) -> None:
    """``MeanderingFlow._apply_boundary`` + the interior update of ``_substep`` as a kernel.

    The caller has already advanced the corner and common noise (numpy draws, unchanged).
    """
    rhs = flow.__dict__.get("_kernel_rhs")
    if rhs is None:
        rhs = np.empty_like(flow._f)
        flow._kernel_rhs = rhs
    _substep(flow._f, flow._noise, flow._mean, flow._rx, flow._ry, rhs, h, flow.dx, flow.dy,
             flow.params.diffusivity_m2ps)


def _concentration_direct(
    q: NDArray[np.float64],
    px: NDArray[np.float64],
    py: NDArray[np.float64],
    r2: NDArray[np.float64],
    mass: float,
    floor: float,
    out: NDArray[np.float64],
) -> None:
    two_pi = 2.0 * math.pi
    for m in range(q.shape[0]):
        qx = q[m, 0]
        qy = q[m, 1]
        acc = 0.0
        for k in range(px.shape[0]):
            expo = ((qx - px[k]) ** 2 + (qy - py[k]) ** 2) * (-0.5 / r2[k])
            if expo > floor:
                acc += math.exp(expo) * (mass / (two_pi * r2[k]))
        out[m] = acc


def concentration_direct(
    q: NDArray[np.float64],
    px: NDArray[np.float64],
    py: NDArray[np.float64],
    r2: NDArray[np.float64],
    mass: float,
    floor: float,
) -> NDArray[np.float64]:
    """Sum of Gaussian puffs at few points ``q`` (M, 2) over the given puffs (``fast`` tier)."""
    out = np.zeros(len(q))
    _concentration_direct(np.ascontiguousarray(q), np.ascontiguousarray(px),
                          np.ascontiguousarray(py), np.ascontiguousarray(r2), mass, floor, out)
    return out


_env = os.environ.get("CPTBT_KERNELS", "exact" if HAVE_NUMBA else "numpy")
use(_env if _env in ("numpy", "exact", "fast") and HAVE_NUMBA else "numpy")  # type: ignore[arg-type]
