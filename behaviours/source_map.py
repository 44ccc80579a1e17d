"""A recursive Bayesian map of where the source is, from detections and non-detections.

After Pang & Farrell, "Chemical plume source localization", IEEE Trans. SMC-B 36(5), 2006: the
OpArea is a grid of cells, each a hypothesis "the source is here"; every planning cycle the
percept (a detection or a non-detection at the vehicle's estimated position) multiplies each
cell's probability by the likelihood of that observation if the source were there, and the map
is renormalised.

The likelihood model
--------------------
A filament detected at ``x`` at time ``t`` left the source some time ``τ`` earlier and has since
been carried by the flow, so the source lies up-flow of ``x`` along the *back-trajectory* of the
water: ``B(τ) = x - ∫_{t-τ}^{t} U(t') dt'``, where ``U`` is the planner's own flow estimate
(the vector mean of SPEC §2) recorded every cycle. Turbulent dispersion and meander spread the
possible origins sideways. For a cell ``s`` whose along-flow distance up-flow of ``x`` is ``a``
(measured along the mean direction of the recent back-trajectory) and whose cross-flow distance
from the back-trajectory at that range is ``c``, the probability of a detection at ``x`` in one
cycle, if the source were at ``s``, is

    K(s; x) = p0 · exp(-a / L) · exp(-c² / (2 σ(a)²)),   σ(a)² = σ0² + min(a · tan φ, σmax)²,

for ``0 <= a <= max_range_m``; down-flow of ``x`` (``a < 0``) it falls off as
``exp(-a² / (2 σb²))`` (σb ``behind_spread_m``, by default σ0: the vehicle's navigation error
and the puff size blur "up-flow"), and
beyond ``max_range_m`` it is 0. ``p0`` is the chance of a detection on the plume's mean axis near
the source, ``L`` how fast that chance decays with range (filaments thin out and meander), ``σ0``
the spread at the source (navigation error, puff size), ``φ`` the half-angle of the meander and
``σmax`` (optional) the width at which the meander stops widening the plume: the back-trajectory
follows the flow estimate's slow turns, so far down-flow the hits stay within a band of roughly
constant width around it rather than a cone.

- A **detection** multiplies cell ``s`` by ``1 - (1 - ε)(1 - K(s; x))(1 - q)``: a false alarm
  (``ε``), the hypothesised source, or one of the already *declared* sources (``q``, the chance
  that a declared source's plume explains a detection at ``x``) could have caused it. A detection
  straight down-flow of a cell raises it. A detection with ``q >= explained_prob`` is taken as
  the declared source's and is no observation at all: a partial explanation, repeated over the
  hundreds of correlated detections a known plume gives, would otherwise still pile up.
- A **non-detection** multiplies cell ``s`` by ``1 - K(s; x)``: it lowers the cells whose plume
  would probably have been seen at ``x`` (those up-flow of ``x`` along the back-trajectory), and
  leaves the cells it says nothing about (down-flow or far to the side) alone.
- **Two levels of detection** (optional: a map made with ``strong_concentration``). Filaments
  dilute as they travel, so how *strong* a detection is says how far it came: a *strong*
  detection (concentration at least ``strong_concentration``) has its own kernel
  ``K3(s; x) = p3 · exp(-a / L3) · (the same cross-flow shape)``, with ``L3`` much shorter than
  ``L``, and a weak one (above the threshold, below the strong level) the rest,
  ``K(s; x) - K3(s; x)``. A strong detection multiplies cell ``s`` by
  ``1 - (1 - ε3)(1 - K3)(1 - q3)`` (``q3``: a declared source's chance of a strong detection
  there, so a strong detection far down a known plume, where strong ones are rare, is not
  explained by it), a weak one by ``1 - (1 - ε)(1 - (K - K3))(1 - q)``. A strong
  detection thus says "the source is close up-flow"; a weak one leans to sources farther off.
  Without it the along-flow position comes only from misses up-flow of the source, since a
  detection says "up-flow of here" but hardly how far.

Correlated meander (optional: a map made with ``meander_memory_s``)
-------------------------------------------------------------------
Each cell may carry a persistent meander state, the plume axis's cross-flow offset, and be
filtered as a small hidden Markov model, so that a run of misses after the plume swings away
counts as one meander, not many independent cycles: the model, its readings and its cost are in
:mod:`cptbt.behaviours.meander`.

Assumptions, stated because the model is only as good as they are:

- one source per hypothesis; a declared source's plume is known exactly (multi-source search
  explains it away rather than estimating the sources jointly);
- the flow is uniform in space over the plume (the vehicle's estimate stands for the water's
  motion along the whole back-trajectory) and its history is the planner's own estimate;
- without a meander state, cycles are conditionally independent given the source. They are
  not (a plume contact gives a run of correlated detections, intermittency a run of misses), so
  each log-likelihood is tempered by ``detection_weight`` / ``nondetection_weight`` (< 1 keeps
  the map from growing over-confident on correlated evidence). With one, cycles are
  independent given the source *and* the meander state; what the state does not carry (a
  patch of filaments gives several strong detections in a row whatever the meander) is still
  tempered;
- the source lies inside the OpArea (the prior is uniform over it); cycles without a valid
  sample (NaN), without a flow estimate or outside the OpArea are not observations.

No simulator truth enters: the inputs are the percept's estimated position, detection flag and
flow estimate.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from cptbt.angles import unit
from cptbt.behaviours.map_model import MapModelParams
from cptbt.behaviours.meander import MeanderChain, meander_kernel
from cptbt.frames import OpArea
from cptbt.types import Percept, Point, SourceBelief

Array = NDArray[np.float64]

MAX_CELLS = 250_000
"""A finer grid is coarsened to this many cells (per-cycle cost grows with the cell count)."""


def grid_cell_m(cell_m: float, area: OpArea) -> float:
    """The cell size a map over ``area`` uses: ``cell_m``, coarsened to at most about
    :data:`MAX_CELLS` cells."""
    return max(cell_m, math.sqrt((area.xmax - area.xmin) * (area.ymax - area.ymin) / MAX_CELLS))


def grid_advice(params: MapModelParams, area: OpArea) -> list[tuple[str, str]]:
    """A warning, ``(parameter, why)``, when ``cell_m`` would give more than :data:`MAX_CELLS`
    cells over the OpArea, so the grid is coarsened (:class:`SourceMap` does it unsaid)."""
    cell = grid_cell_m(params.cell_m, area)
    if cell <= params.cell_m:
        return []
    w, h = area.xmax - area.xmin, area.ymax - area.ymin
    cells = math.ceil(w / params.cell_m) * math.ceil(h / params.cell_m)
    return [("cell_m", f"{params.cell_m:g} m: {cells} cells over the OpArea; the map is "
             f"coarsened to {cell:.3g} m cells (about {MAX_CELLS})")]


SOURCE_MAP_KEY = "source_map"
"""Blackboard key of the published :class:`~cptbt.types.SourceBelief`."""


class SourceMap:
    """The grid, the log-posterior over it, and the history it was built from.

    Args:
        area: the OpArea; the grid covers it with cells of ``model.cell_m`` (coarsened to at most
            :data:`MAX_CELLS` cells).
        model: the likelihood model's parameters.
    """

    def __init__(self, area: OpArea, model: MapModelParams,
                 strong_concentration: float | None = None) -> None:
        self.model = model
        self.strong_concentration = strong_concentration
        w, h = area.xmax - area.xmin, area.ymax - area.ymin
        cell = grid_cell_m(model.cell_m, area)
        nx, ny = max(1, math.ceil(w / cell)), max(1, math.ceil(h / cell))
        self.xs: Array = np.asarray(area.xmin + (np.arange(nx) + 0.5) * (w / nx), dtype=float)
        self.ys: Array = np.asarray(area.ymin + (np.arange(ny) + 0.5) * (h / ny), dtype=float)
        gx, gy = np.meshgrid(self.xs, self.ys)
        self._cx: Array = gx.ravel()
        self._cy: Array = gy.ravel()
        self.shape = (ny, nx)
        self._tan = math.tan(math.radians(model.spread_deg))
        self._t = np.empty(1024)
        self._cum = np.empty((1024, 2))  # cumulative flow displacement ∫U dt at each cycle
        self._n = 0
        self._flow = (0.0, 0.0)
        self._obs: list[tuple[int, float, float, int]] = []
        self.known: tuple[Point, ...] = ()
        self.t = math.nan
        self.detections = 0
        self.unexplained = 0  # detections no declared source explains (at the time)
        self.explored = np.zeros(self._cx.size, dtype=bool)
        self._log = np.zeros(self._cx.size)
        self._excluded = np.zeros(self._cx.size, dtype=bool)
        # every cell within mask_radius_m of a declared source: nowhere is left where another
        # source could be (set where the mask changes, in explain(), not on every cycle)
        self.exhausted = False
        self.chain = (MeanderChain(model.meander_bins, model.meander_memory_s)
                      if model.meander_memory_s is not None else None)
        self._alpha: Array | None = None  # P(z | history, cell), (bins, cells), columns sum to 1
        self._last_k = -1  # cycle of the last observation folded in
        self._reset_meander()

    # -- updating ------------------------------------------------------------------------
    def observe(self, p: Percept) -> bool:
        """Fold one cycle's percept into the map; True when it was an observation."""
        self._record_flow(p)
        self.t = p.t
        x, y = p.pose.x, p.pose.y
        if not (math.isfinite(x) and math.isfinite(y)):
            return False
        r = self.model.explored_radius_m
        self.explored |= (self._cx - x) ** 2 + (self._cy - y) ** 2 <= r * r
        if p.flow is None or not p.in_op_area or not math.isfinite(p.concentration):
            return False
        level = self.level(p)
        obs = (self._n - 1, x, y, level)
        self._obs.append(obs)
        self.detections += int(p.detected)
        if p.detected and not self.explained_by_known(x, y, level=level):
            self.unexplained += 1
        self._fold(obs)
        if not self.exhausted:  # every cell masked: nothing to normalise (nor to search)
            self._log -= self._log[~self._excluded].max()
        return True

    def level(self, p: Percept) -> int:
        """The percept's observation level: 0 a miss, 1 a detection, 2 a *strong* one (with
        the two-level model)."""
        if not p.detected:
            return 0
        strong = self.strong_concentration
        return 2 if strong is not None and p.concentration >= strong else 1

    def _reset_meander(self) -> None:
        self._last_k = -1
        if self.chain is not None:
            self._alpha = np.repeat(self.chain.weights[:, None], self._cx.size, axis=1)

    def _fold(self, obs: tuple[int, float, float, int]) -> None:
        """Multiply the map by one observation's likelihood (through the meander states when
        the map has them)."""
        if self.chain is None or self._alpha is None:
            self._log += self._log_likelihood(*obs)
            return
        k = obs[0]
        dt = float(self._t[k] - self._t[self._last_k]) if self._last_k >= 0 else 0.0
        self._last_k = k
        if dt > 0:  # einsum, not BLAS: a (9, n) product is slow with threads on a busy host
            self._alpha = np.einsum("ij,in->jn", self.chain.transition(dt), self._alpha)
        got = self._likelihood_given_meander(*obs)
        if got is None:
            return
        idx, like, rest = got
        if rest != 0.0:
            self._log += rest
        if idx.size:
            alpha = self._alpha[:, idx] * like
            total = alpha.sum(axis=0)
            self._alpha[:, idx] = alpha / total
            self._log[idx] += np.log(total) - rest
        self._log[self._excluded] = -np.inf

    def _record_flow(self, p: Percept) -> None:
        if self._n == len(self._t):  # grow the history (amortised doubling)
            self._t = np.concatenate([self._t, np.empty_like(self._t)])
            self._cum = np.concatenate([self._cum, np.empty_like(self._cum)])
        if self._n == 0:
            cum = (0.0, 0.0)
        else:
            dt = max(p.t - self._t[self._n - 1], 0.0)
            prev = self._cum[self._n - 1]
            cum = (prev[0] + self._flow[0] * dt, prev[1] + self._flow[1] * dt)
        if p.flow is not None:
            self._flow = (p.flow.vx, p.flow.vy)
        self._t[self._n] = p.t
        self._cum[self._n] = cum
        self._n += 1

    def explain(self, sources: tuple[Point, ...]) -> None:
        """Declare sources known: rule out their neighbourhood and explain away their plumes.

        The map is rebuilt from the whole observation history under the new model (a detection
        a declared source explains no longer raises the cells up-flow of it).
        """
        self.known = tuple(sources)
        self._excluded[:] = False
        r2 = self.model.mask_radius_m**2
        for s in self.known:
            self._excluded |= (self._cx - s.x) ** 2 + (self._cy - s.y) ** 2 <= r2
        self.exhausted = not bool((~self._excluded).any())
        self._log = np.zeros(self._cx.size)
        self._reset_meander()
        for obs in self._obs:
            self._fold(obs)
        self._log[self._excluded] = -np.inf
        if not self.exhausted:
            self._log -= self._log[~self._excluded].max()

    # -- the model -----------------------------------------------------------------------
    def kernel(self, k: int, x: float | Array, y: float | Array, sx: Array, sy: Array) -> Array:
        """``K(s; x)``: the chance of a detection at ``(x, y)`` on cycle ``k`` from sources ``s``.

        ``p0`` times :meth:`kernel_shape`; ``x``, ``y`` may be arrays broadcasting against ``sx``,
        ``sy`` (e.g. ``(m, 1)`` candidate positions against ``(n,)`` cells give ``(m, n)``).
        """
        return self.model.detection_prob * self.kernel_shape(k, x, y, sx, sy)

    def false_alarm(self, k: int) -> float:
        """``ε``: the chance of a detection with no plume on cycle ``k``."""
        return self.model.false_alarm_prob

    def kernel_shape(self, k: int, x: float | Array, y: float | Array, sx: Array,
                     sy: Array) -> Array:
        """The kernel's spatial shape (1 on the plume's axis at the source, 0 beyond range)."""
        shape, ap = self._shape_and_range(k, x, y, sx, sy)
        return shape * np.exp(-ap / self.model.detection_decay_m)

    def _shape_and_range(self, k: int, x: float | Array, y: float | Array, sx: Array,
                         sy: Array, bounded: bool = True) -> tuple[Array, Array]:
        """The kernel's shape without the decay with range, and the range ``max(a, 0)``;
        ``bounded`` False: not cut off at ``max_range_m`` (the back-trajectory goes on straight
        beyond it)."""
        m = self.model
        a, c = self._geometry(k, x, y, sx, sy)
        ap = np.maximum(a, 0.0)
        meander = self._meander(ap)
        var = m.near_spread_m**2 + meander**2
        expo = -c * c / (2.0 * var)
        behind = m.behind_spread_m if m.behind_spread_m is not None else m.near_spread_m
        expo -= np.where(a < 0, a * a / (2.0 * behind**2), 0.0)
        if not bounded:
            return np.exp(expo), ap
        return np.where(a <= m.max_range_m, np.exp(expo), 0.0), ap

    def _geometry(self, k: int, x: float | Array, y: float | Array, sx: Array,
                  sy: Array) -> tuple[Array, Array]:
        """``(a, c)``: each source's range up-flow of ``(x, y)`` along the back-trajectory of
        cycle ``k`` and its cross-flow offset from the back-trajectory at that range."""
        ux, uy, along, disp = self.back_trajectory(k)
        a = (x - sx) * ux + (y - sy) * uy  # how far up-flow of the detection each source is
        dx = np.interp(a, along, disp[:, 0])
        dy = np.interp(a, along, disp[:, 1])
        c = (sx - (x - dx)) * -uy + (sy - (y - dy)) * ux  # cross-flow offset from B(τ)
        return np.asarray(a, dtype=float), np.asarray(c, dtype=float)

    def _meander(self, ap: Array) -> Array:
        """The meander part of the kernel's spread, ``min(a tan φ, σmax)``, at range ``ap``."""
        meander = self._tan * ap
        if self.model.max_spread_m is not None:
            meander = np.minimum(meander, self.model.max_spread_m)
        return meander

    def back_trajectory(self, k: int) -> tuple[float, float, Array, Array]:
        """The water's back-trajectory from cycle ``k``: ``(ux, uy, along, disp)``.

        The flow history up to cycle ``k``, traced back until it has covered ``max_range_m``
        (or the history runs out, when it is extended straight along its mean direction):
        ``disp`` the displacements (newest first, ``(len, 2)``), ``(ux, uy)`` the unit vector of
        the last, and ``along`` (non-decreasing) how far up-flow along it each one lies.
        """
        m = self.model
        cum = self._cum[: k + 1]
        disp = cum[k] - cum[::-1]  # displacement of the water over the last τ, newest first
        along_total = np.hypot(disp[:, 0], disp[:, 1])
        stop = int(np.searchsorted(np.maximum.accumulate(along_total), m.max_range_m)) + 1
        disp = disp[: min(stop, len(disp))]
        if len(disp) > m.trajectory_points:
            disp = disp[np.linspace(0, len(disp) - 1, m.trajectory_points).astype(np.intp)]
        end = disp[-1]
        norm = math.hypot(end[0], end[1])
        if norm > 1e-6:
            ux, uy = end[0] / norm, end[1] / norm
        else:
            fx, fy = self._flow
            ux, uy = unit(math.degrees(math.atan2(fy, fx))) if (fx or fy) else (1.0, 0.0)
        along = np.maximum.accumulate(disp[:, 0] * ux + disp[:, 1] * uy)
        return float(ux), float(uy), along, disp

    def _log_likelihood(self, k: int, x: float, y: float, level: int) -> Array:
        m = self.model
        if not level:
            k_cells = self.kernel(k, x, y, self._cx, self._cy)
            out = m.nondetection_weight * np.log1p(-k_cells)
        else:
            strong_cells: Array | None = None
            if self.strong_concentration is not None:  # the two-level model
                shape, ap = self._shape_and_range(k, x, y, self._cx, self._cy)
                k_cells = m.detection_prob * shape * np.exp(-ap / m.detection_decay_m)
                strong_cells = np.minimum(
                    m.strong_prob * shape * np.exp(-ap / m.strong_decay_m), k_cells)
            else:
                k_cells = self.kernel(k, x, y, self._cx, self._cy)
            miss_known = self._miss_known(k, x, y, level)
            if miss_known <= 1.0 - m.explained_prob:
                return np.where(self._excluded, -np.inf, 0.0)
            like, _ = self._detection_like(k, level, k_cells, strong_cells, miss_known)
            out = m.detection_weight * np.log(like)
        return np.where(self._excluded, -np.inf, out)

    def _kernel_given_meander(self, k: int, x: float, y: float,
                              strong: bool) -> tuple[NDArray[np.intp], Array, Array | None]:
        """``K(s; x | z)`` per meander state for the cells the plume can reach from ``(x, y)``
        on cycle ``k`` (:func:`~cptbt.behaviours.meander.meander_kernel`)."""
        assert self.chain is not None
        a, c = self._geometry(k, x, y, self._cx, self._cy)
        return meander_kernel(self.model, self.chain.z, a, c, self._meander(np.maximum(a, 0.0)),
                              strong)

    def _likelihood_given_meander(self, k: int, x: float, y: float, level: int
                                  ) -> tuple[NDArray[np.intp], Array, float] | None:
        """The tempered likelihood of one observation: ``(idx, like, rest)``, ``like`` per
        meander state for the cells ``idx`` the plume can reach from ``(x, y)``, ``rest`` the
        log-likelihood of every other cell (the same in each state); None when a declared
        source explains it (no observation)."""
        m = self.model
        if not level:
            idx, k_cells, _ = self._kernel_given_meander(k, x, y, False)
            return idx, np.exp(m.nondetection_weight * np.log1p(-k_cells)), 0.0
        miss_known = self._miss_known(k, x, y, level)
        if miss_known <= 1.0 - m.explained_prob:
            return None
        idx, k_cells, strong_cells = self._kernel_given_meander(
            k, x, y, self.strong_concentration is not None)
        like, eps = self._detection_like(k, level, k_cells, strong_cells, miss_known)
        rest = m.detection_weight * math.log(1.0 - (1.0 - eps) * miss_known)
        return idx, np.exp(m.detection_weight * np.log(like)), rest

    def _miss_known(self, k: int, x: float, y: float, level: int = 1) -> float:
        """``1 - q``: the chance that no declared source's plume causes a detection at
        ``(x, y)`` on cycle ``k`` (1 with none declared); of a *strong* one (``level`` 2, the
        two-level model) with ``q`` the strong kernel's (``p3``, ``L3``).

        A strong detection is explained only as far as a known plume gives strong ones: they are
        rare far down a plume (4% of on-axis cycles at 80-120 m, 1-2% beyond: the class
        docstring of the declaration's parameters), so a strong detection there says another
        source is close, while the total chance ``q`` reaches the whole meander cone (about
        +/-40 m at 100 m) and explained away every detection of a second source lying in it
        (a review's sources 98 m apart, 40 m across the flow: the second was never found).
        A weak detection is explained by the total chance, as before: next to a known source a
        weak one is rarer than a strong one, and its weak chance alone would leave the known
        source's own weak detections unexplained.

        A declared source's plume is not cut off at ``max_range_m``: that bound limits how far
        back a detection is traced to *hypothesise* a source, but a known source farther
        up-flow along the back-trajectory still explains it, and beyond that range with the
        chance it has at the range (the decay with range goes no further: with the declaration's
        defaults the chance fell below ``explained_prob`` ~400 m down-flow even on the plume's
        axis). Cut off, the known plume's far detections (in an OpArea longer than the range)
        were unexplained and piled the map's mass at the far end of their range, beside the
        known plume, where the search went on looking and handing back to plume tracking for the
        rest of the mission."""
        if not self.known:
            return 1.0
        kx = np.array([s.x for s in self.known])
        ky = np.array([s.y for s in self.known])
        m = self.model
        shape, ap = self._shape_and_range(k, x, y, kx, ky, bounded=False)
        ap = np.minimum(ap, m.max_range_m)
        if level >= 2 and self.strong_concentration is not None and m.strong_own_reach:
            q = m.strong_prob * shape * np.exp(-ap / m.strong_decay_m)
        else:
            q = m.detection_prob * shape * np.exp(-ap / m.detection_decay_m)
        return float(np.prod(1.0 - q))

    def _detection_like(self, k: int, level: int, k_cells: Array, strong_cells: Array | None,
                        miss_known: float) -> tuple[Array, float]:
        """A detection's likelihood per cell (or per state and cell) and its false-alarm
        chance: one level, or a strong (``level`` 2) or weak one of the two-level model."""
        if strong_cells is None:
            eps = self.false_alarm(k)
            return 1.0 - (1.0 - eps) * (1.0 - k_cells) * miss_known, eps
        if level >= 2:
            eps = self.model.strong_false_alarm_prob
            return 1.0 - (1.0 - eps) * (1.0 - strong_cells) * miss_known, eps
        eps = self.false_alarm(k)
        return 1.0 - (1.0 - eps) * (1.0 - (k_cells - strong_cells)) * miss_known, eps

    def explained_by_known(self, x: float, y: float, k: int | None = None,
                           level: int = 1) -> bool:
        """Whether the declared sources' plumes would cause a detection (``level`` 2: a strong
        one) at ``(x, y)`` on cycle ``k`` (None: the latest) with at least ``explained_prob``."""
        if not self.known or self._n == 0:
            return False
        k = self._n - 1 if k is None else k
        return self._miss_known(k, x, y, level) <= 1.0 - self.model.explained_prob

    def known_chance(self, at: Point) -> float:
        """``q``: the chance that a declared source's plume causes a detection at ``at`` on the
        latest cycle (0 with none declared)."""
        if not self.known or self._n == 0:
            return 0.0
        return 1.0 - self._miss_known(self._n - 1, at.x, at.y)

    def expected_detection(self, source: Point, x: float, y: float) -> float:
        """``K(source; (x, y))`` on the latest cycle: how likely a detection there is now."""
        if self._n == 0:
            return 0.0
        return float(self.kernel(self._n - 1, x, y, np.array([source.x]), np.array([source.y]))[0])

    # -- reading -------------------------------------------------------------------------
    def posterior(self) -> Array:
        """Cell probabilities (flat), summing to 1 over the cells not ruled out."""
        post = np.exp(self._log - self._log[~self._excluded].max()) if not self.exhausted \
            else np.zeros_like(self._log)
        post[self._excluded] = 0.0
        total = post.sum()
        return post / total if total > 0 else post

    def peak(self, post: Array | None = None) -> Point:
        """Centre of the most probable cell."""
        post = self.posterior() if post is None else post
        i = int(np.argmax(post))
        return Point(float(self._cx[i]), float(self._cy[i]))

    def within(self, centre: Point, radius_m: float) -> NDArray[np.bool_]:
        """Which cells lie within ``radius_m`` of ``centre``."""
        return (self._cx - centre.x) ** 2 + (self._cy - centre.y) ** 2 <= radius_m**2

    def mass_and_mean(self, centre: Point, radius_m: float,
                      post: Array | None = None) -> tuple[float, Point]:
        """Posterior mass within ``radius_m`` of ``centre`` and its weighted mean position."""
        post = self.posterior() if post is None else post
        sel = self.within(centre, radius_m)
        w = post[sel]
        mass = float(w.sum())
        if mass <= 0:
            return 0.0, centre
        return mass, Point(float(w @ self._cx[sel] / mass), float(w @ self._cy[sel] / mass))

    def cells(self) -> tuple[Array, Array]:
        """Flat cell-centre coordinates ``(x, y)``."""
        return self._cx, self._cy

    def belief(self, post: Array | None = None) -> SourceBelief:
        """A read-only snapshot for the blackboard."""
        post = (self.posterior() if post is None else post).reshape(self.shape).copy()
        post.flags.writeable = False
        explored = self.explored.reshape(self.shape).copy()
        explored.flags.writeable = False
        return SourceBelief(self.t, self.xs, self.ys, post, self.known, explored)
