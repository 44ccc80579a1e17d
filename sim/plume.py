"""Puff (filament) plume of Farrell et al. 2002, vectorised over puffs.

Puffs leave the source as a Poisson process. Each puff centre moves with the flow at the centre
plus a centre-relative random walk of diffusivity ``K_c`` (displacement std ``sqrt(2 K_c dt)``
per axis and step, so the spread does not depend on the step size). The squared radius grows
linearly with age: ``r² = r0² + s·age``. The concentration is the sum of 2-D Gaussian puffs of
fixed mass ``m`` each:

    C(x) = Σ_k m / (2π r_k²) · exp(-|x - x_k|² / (2 r_k²)),

so the integral of C over the plane is ``m`` per puff (concentration units × m²). The 2-D form is
used (not pompy's 3-D form) because the vehicle samples a horizontal layer and the flow is 2-D.

Calibration (concentration in units of the planner's threshold, TRO Table I: 0.20; fraction of
time above 0.2 at a fixed point on the mean axis, 3 seeds, after warm-up):

- ``"ab"`` (AB 2001 §2.2 and SPEC §10): 3 filaments/s (AB); Farrell et al. 2002's filament sizes:
  r0² = 0.001 m², r² growth s = 0.001 m²/s, relative dispersion K_c = 0.02 m²/s. The mass
  (the concentration scale; AB's units are the gypsy moth's threshold, which we cannot copy) is
  chosen as m = 4 so that a *single* filament stays detectable across the whole area: a lone
  filament 150 s old (beyond the area's far corner at 1 m/s) has r² = 0.151 m² and a peak of 4.2
  (21 × the threshold), above threshold within 0.96 m of its centre; 20 s old, within 0.46 m.
  A lower mass (m = 1, peak 5 × threshold at 150 s) gives the same plume geometry with a thinner
  detectable core. With ``ab_large_meander``: 24 % above threshold at 20 m downflow, 16 % at
  50 m, 16 % at 80 m; a crossflow line at 20/50/80 m meets an above-threshold filament 94/97/99 %
  of the time. Intermittent everywhere, and no fading with distance: AB's searchers start
  60–85 m downflow and detect routinely (SPEC §10).
- ``"ocean"`` (TRO, ~0.1 m/s): 0.5 puff/s, m = 0.8, r0 = 0.2 m, s = 0.0003 m²/s,
  K_c = 0.03 m²/s. A lone puff 100 m (1000 s) downflow has r² = 0.34 m² and a peak of 0.37;
  62–67 % at 5 m, 16–28 % at 100 m, 12–21 % at 150 m, 7–19 % at 190 m: detectable beyond 100 m.
tests/sim/test_sim_plume.py and tests/sim/test_sim_ab_plume.py check both.
"""

from __future__ import annotations

import math
from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray
from pydantic import BaseModel, ConfigDict, Field, model_validator

from . import kernels
from .flow import Domain, FlowField

PlumePreset = Literal["ab", "ocean"]

_HASH_MIN_POINTS = 16  # from this many query points on, bucket puffs into cells
_HASH_MAX_CELLS_PER_SIDE = 1024  # cells no smaller than this fraction of the domain's side
_NEIGHBOUR_DX = np.array([-1, 0, 1, -1, 0, 1, -1, 0, 1])
_NEIGHBOUR_DY = np.array([-1, -1, -1, 0, 0, 0, 1, 1, 1])

_PRESETS: dict[str, dict[str, Any]] = {
    "ab": dict(
        release_rate_hz=3.0,
        puff_mass=4.0,
        initial_radius_m=math.sqrt(0.001),
        spread_rate_m2ps=0.001,
        centre_rel_diffusivity_m2ps=0.02,
        max_puffs=2000,
    ),
    "ocean": dict(
        release_rate_hz=0.5,
        puff_mass=0.8,
        initial_radius_m=0.2,
        spread_rate_m2ps=0.0003,
        centre_rel_diffusivity_m2ps=0.03,
        max_puffs=8000,
    ),
}


class PlumeParams(BaseModel):
    """Puff-plume settings; unset fields take the values of ``preset`` (defaults: ``"ocean"``).

    The source position is given separately.
    """

    model_config = ConfigDict(frozen=True, extra="forbid", allow_inf_nan=False)

    preset: PlumePreset = "ocean"
    release_rate_hz: float = Field(
        default=0.5, gt=0.0, le=1000.0,
        description="Mean puff release rate (Poisson), 1/s; at most 1000 (AB's filaments: 3/s): "
        "each plume step draws its releases at once."
    )
    puff_mass: float = Field(
        default=0.8, gt=0.0, description="Mass per puff, concentration units × m²."
    )
    initial_radius_m: float = Field(
        default=0.2, ge=0.001,
        description="Puff radius r0 at release, m; at least 1 mm (a puff's peak, mass / 2πr², "
        "overflows as r0 goes to 0).",
    )
    spread_rate_m2ps: float = Field(default=0.0003, ge=0.0, description="Growth rate of r², m²/s.")
    centre_rel_diffusivity_m2ps: float = Field(
        default=0.03, ge=0.0, description="Centre-relative random-walk diffusivity K_c, m²/s."
    )
    max_puffs: int = Field(
        default=8000, gt=0, le=200_000,
        description="Capacity; releases are skipped when full. At most 200,000 (the presets: "
        "2,000 and 8,000): the puffs' arrays are allocated at this size, per source."
    )
    cutoff_sigmas: float = Field(
        default=4.0, gt=0.0, description="Puffs beyond this many r are ignored."
    )

    @model_validator(mode="before")
    @classmethod
    def _fill_from_preset(cls, data: Any) -> Any:
        if isinstance(data, dict):
            preset = data.get("preset", "ocean")
            if isinstance(preset, str) and preset in _PRESETS:
                return {**_PRESETS[preset], **data}
        return data


class PuffPlume:
    """A plume of Gaussian puffs released at a point source and advected by a flow.

    The plume does not step the flow: the owner (the ``World``) steps the flow, then the plume.

    Args:
        params: Plume settings.
        source_xy: Source position (x, y), m.
        flow: Flow advecting the puffs.
        rng: Environment generator (release times and random walk).
        domain: Region (xmin, xmax, ymin, ymax) puffs are dropped outside of; the flow's
            domain if None.
    """

    def __init__(
        self,
        params: PlumeParams,
        source_xy: tuple[float, float],
        flow: FlowField,
        rng: np.random.Generator,
        domain: Domain | None = None,
    ) -> None:
        self.params = params
        self.source = np.asarray(source_xy, dtype=float)
        self.flow = flow
        self._rng = rng
        self.domain: Domain = flow.domain if domain is None else domain
        cap = params.max_puffs
        self._xy = np.empty((cap, 2))
        self._r2 = np.empty(cap)
        self.n = 0
        self.released = 0
        self.dropped = 0
        self.skipped = 0
        self.time_s = 0.0
        self._r2_max = params.initial_radius_m**2

    @property
    def positions(self) -> NDArray[np.float64]:
        """Puff centres (n, 2), a read-only view."""
        view = self._xy[: self.n]
        view.flags.writeable = False
        return view

    @property
    def radii_sq(self) -> NDArray[np.float64]:
        """Squared puff radii (n,), a read-only view."""
        view = self._r2[: self.n]
        view.flags.writeable = False
        return view

    def total_mass(self) -> float:
        """Mass of all puffs in the domain (= live puffs × puff mass)."""
        return self.n * self.params.puff_mass

    def step(self, dt: float) -> None:
        """Advance puffs by ``dt`` (Euler), release new ones, drop those outside the domain."""
        p = self.params
        rng = self._rng
        n = self.n
        xy = self._xy[:n]
        if n:
            vel = self.flow.velocity_at(xy)
            walk = math.sqrt(2.0 * p.centre_rel_diffusivity_m2ps * dt)
            if kernels.EXACT:
                noise = rng.standard_normal((n, 2))
                kernels.advance_puffs(xy, self._r2[:n], vel, noise, dt, walk,
                                      p.spread_rate_m2ps * dt)
            else:
                xy += vel * dt + walk * rng.standard_normal((n, 2))
                self._r2[:n] += p.spread_rate_m2ps * dt
        self._release(dt)
        self._drop_outside()
        self.time_s += dt
        self._r2_max = float(self._r2[: self.n].max()) if self.n else p.initial_radius_m**2

    def _release(self, dt: float) -> None:
        p = self.params
        k = int(self._rng.poisson(p.release_rate_hz * dt))
        # Random release instants within the step so a coarse dt does not bunch puffs.
        frac = self._rng.random(k)
        room = p.max_puffs - self.n
        if k > room:
            self.skipped += k - room
            k = room
            frac = frac[:k]
        if k == 0:
            return
        age = frac * dt
        v_src = self.flow.velocity_at(self.source[None, :])[0]
        sl = slice(self.n, self.n + k)
        self._xy[sl] = self.source + age[:, None] * v_src
        self._r2[sl] = p.initial_radius_m**2 + p.spread_rate_m2ps * age
        self.n += k
        self.released += k

    def _drop_outside(self) -> None:
        n = self.n
        if not n:
            return
        if kernels.EXACT:
            kept = kernels.compact_inside(self._xy, self._r2, n, self.domain)
            self.dropped += n - kept
            self.n = kept
            return
        xmin, xmax, ymin, ymax = self.domain
        x = self._xy[:n, 0]
        y = self._xy[:n, 1]
        keep = (x >= xmin) & (x <= xmax) & (y >= ymin) & (y <= ymax)
        kept = int(np.count_nonzero(keep))
        if kept == n:
            return
        self._xy[:kept] = self._xy[:n][keep]
        self._r2[:kept] = self._r2[:n][keep]
        self.dropped += n - kept
        self.n = kept

    def concentration(self, xy: NDArray[np.float64]) -> NDArray[np.float64]:
        """Concentration at points ``xy`` (M, 2) → (M,).

        A puff contributes only within ``cutoff_sigmas`` × its radius (at most e^{-8} of its peak
        is lost for the default 4). Puffs outside the query points' bounding box grown by that
        reach for the largest puff are culled first; the rest are summed over all points at once
        (in chunks of points, to bound memory).
        """
        q = np.asarray(xy, dtype=float).reshape(-1, 2)
        out = np.zeros(len(q))
        n = self.n
        if n == 0 or len(q) == 0:
            return out
        reach = self.params.cutoff_sigmas * math.sqrt(self._r2_max)
        if len(q) >= _HASH_MIN_POINTS:
            return self._concentration_hashed(q, reach)
        pxy = self._xy[:n]
        px = pxy[:, 0]
        py = pxy[:, 1]
        lo = q.min(axis=0) - reach
        hi = q.max(axis=0) + reach
        sel = (px >= lo[0]) & (px <= hi[0]) & (py >= lo[1]) & (py <= hi[1])
        idx = np.flatnonzero(sel)
        if idx.size == 0:
            return out
        px = px[idx]
        py = py[idx]
        r2 = self._r2[idx]
        # Per-puff cut-off too, so a point's value does not depend on the other query points.
        floor = -0.5 * self.params.cutoff_sigmas**2
        if kernels.FAST:
            return kernels.concentration_direct(q, px, py, r2, self.params.puff_mass, floor)
        weight = self.params.puff_mass / (2.0 * math.pi * r2)
        inv = -0.5 / r2
        chunk = max(1, 2_000_000 // idx.size)
        for start in range(0, len(q), chunk):
            qs = q[start : start + chunk]
            expo = ((qs[:, 0:1] - px) ** 2 + (qs[:, 1:2] - py) ** 2) * inv
            out[start : start + chunk] = np.where(expo > floor, np.exp(expo), 0.0) @ weight
        return out

    def _concentration_hashed(self, q: NDArray[np.float64], reach: float) -> NDArray[np.float64]:
        """Concentration at many scattered points via a uniform grid of cells of side ``reach``.

        Puffs are bucketed by cell (a sort); each point gathers the puffs of its 3 × 3
        neighbourhood as a flat list of (point, puff) pairs built with ``np.repeat``, so the work
        grows with the pairs actually near a point, not with points × puffs.
        """
        n = self.n
        xmin, xmax, ymin, ymax = self.domain
        # A cell at least ``reach`` wide keeps every puff within reach of a point in its 3 × 3
        # neighbourhood; a wider one only gathers more pairs. Tiny puffs (a small r0 or
        # cutoff) would otherwise ask for billions of cells.
        reach = max(reach, max(xmax - xmin, ymax - ymin) / _HASH_MAX_CELLS_PER_SIDE)
        ncx = int((xmax - xmin) / reach) + 1
        ncy = int((ymax - ymin) / reach) + 1
        pxy = self._xy[:n]
        pcx = np.minimum(((pxy[:, 0] - xmin) / reach).astype(np.intp), ncx - 1)
        pcy = np.minimum(((pxy[:, 1] - ymin) / reach).astype(np.intp), ncy - 1)
        order = np.argsort(pcy * ncx + pcx, kind="stable")
        counts = np.bincount(pcy * ncx + pcx, minlength=ncx * ncy)
        starts = np.concatenate(([0], np.cumsum(counts)[:-1]))
        qcx = np.floor((q[:, 0] - xmin) / reach).astype(np.intp)
        qcy = np.floor((q[:, 1] - ymin) / reach).astype(np.intp)
        nx_ = (qcx[:, None] + _NEIGHBOUR_DX).ravel()
        ny_ = (qcy[:, None] + _NEIGHBOUR_DY).ravel()
        valid = (nx_ >= 0) & (nx_ < ncx) & (ny_ >= 0) & (ny_ < ncy)
        cell = np.where(valid, ny_ * ncx + nx_, 0)
        cnt = np.where(valid, counts[cell], 0)
        total = int(cnt.sum())
        out = np.zeros(len(q))
        if total == 0:
            return out
        first = np.repeat(starts[cell] - (np.cumsum(cnt) - cnt), cnt)
        puff = order[first + np.arange(total)]
        point = np.repeat(np.arange(len(q) * 9) // 9, cnt)
        r2 = self._r2[puff]
        expo = ((q[point, 0] - pxy[puff, 0]) ** 2 + (q[point, 1] - pxy[puff, 1]) ** 2) * (-0.5 / r2)
        floor = -0.5 * self.params.cutoff_sigmas**2
        contrib = np.where(expo > floor, np.exp(expo), 0.0) * (
            self.params.puff_mass / (2.0 * math.pi) / r2
        )
        return np.bincount(point, weights=contrib, minlength=len(q)).astype(float)

    def snapshot_grid(
        self, xs: NDArray[np.float64], ys: NDArray[np.float64]
    ) -> NDArray[np.float64]:
        """Concentration on the grid ``xs`` × ``ys`` → array (len(ys), len(xs)) for images.

        Each Gaussian puff is separable, so the grid is ``Gy · diag(w) · Gxᵀ`` (a matrix product,
        no loop over puffs).
        """
        xs = np.asarray(xs, dtype=float)
        ys = np.asarray(ys, dtype=float)
        n = self.n
        if n == 0:
            return np.zeros((len(ys), len(xs)))
        px = self._xy[:n, 0]
        py = self._xy[:n, 1]
        r2 = self._r2[:n]
        weight = self.params.puff_mass / (2.0 * math.pi * r2)
        gx = np.exp(-((xs[:, None] - px) ** 2) / (2.0 * r2))  # (nx, n)
        gy = np.exp(-((ys[:, None] - py) ** 2) / (2.0 * r2))  # (ny, n)
        return (gy * weight) @ gx.T
