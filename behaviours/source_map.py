"""The source map: a grid of hypotheses of where the source is, and the posterior over them.

After Pang & Farrell, "Chemical plume source localization", IEEE Trans. SMC-B 36(5), 2006: the
OpArea is a grid of cells, each a hypothesis "the source is here"; every planning cycle the
percept (a detection or a non-detection at the vehicle's estimated position) multiplies each
cell's probability by the likelihood of that observation if the source were there, and the map
is renormalised. That likelihood (the kernel along the back-trajectory of the flow, the two
levels of detection, a declared source's plume explained away) is the model of
:mod:`cptbt.behaviours.plume_likelihood`, which :class:`SourceMap` extends with the grid: the
log-posterior over the cells, the observation history the map is rebuilt from when sources are
declared (:meth:`SourceMap.explain`, which also rules out their neighbourhood), the meander
states, and the readings the behaviours take (posterior, peak, the mass near a point, the
belief published on the blackboard).

Correlated meander (optional: a map made with ``meander_memory_s``)
-------------------------------------------------------------------
Each cell may carry a persistent meander state, the plume axis's cross-flow offset, and be
filtered as a small hidden Markov model, so that a run of misses after the plume swings away
counts as one meander, not many independent cycles: the model, its readings and its cost are in
:mod:`cptbt.behaviours.meander`.

Assumptions, stated because the map is only as good as they are (the plume model's own, on the
flow and on the declared sources' plumes, are in :mod:`cptbt.behaviours.plume_likelihood`):

- one source per hypothesis; a declared source's plume is explained away (by the plume model)
  rather than the sources estimated jointly;
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

from cptbt.behaviours.map_model import MapModelParams
from cptbt.behaviours.meander import MeanderChain, meander_kernel
from cptbt.behaviours.plume_likelihood import PlumeLikelihood
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


class SourceMap(PlumeLikelihood):
    """The grid, the log-posterior over it, and the history it was built from.

    The likelihood it folds in every cycle is its base's,
    :class:`~cptbt.behaviours.plume_likelihood.PlumeLikelihood`, evaluated over the cells.

    Args:
        area: the OpArea; the grid covers it with cells of ``model.cell_m`` (coarsened to at most
            :data:`MAX_CELLS` cells).
        model: the likelihood model's parameters.
        strong_concentration: the concentration of a *strong* detection (the two-level model);
            None: one level.
    """

    def __init__(self, area: OpArea, model: MapModelParams,
                 strong_concentration: float | None = None) -> None:
        super().__init__(model, strong_concentration)
        w, h = area.xmax - area.xmin, area.ymax - area.ymin
        cell = grid_cell_m(model.cell_m, area)
        nx, ny = max(1, math.ceil(w / cell)), max(1, math.ceil(h / cell))
        self.xs: Array = np.asarray(area.xmin + (np.arange(nx) + 0.5) * (w / nx), dtype=float)
        self.ys: Array = np.asarray(area.ymin + (np.arange(ny) + 0.5) * (h / ny), dtype=float)
        gx, gy = np.meshgrid(self.xs, self.ys)
        self._cx: Array = gx.ravel()
        self._cy: Array = gy.ravel()
        self.shape = (ny, nx)
        self._obs: list[tuple[int, float, float, int]] = []
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

    # -- the likelihood over the grid ----------------------------------------------------
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
