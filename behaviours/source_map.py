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
  ``1 - (1 - ε3)(1 - K3)(1 - q)``, a weak one by ``1 - (1 - ε)(1 - (K - K3))(1 - q)``. A strong
  detection thus says "the source is close up-flow"; a weak one leans to sources farther off.
  Without it the along-flow position comes only from misses up-flow of the source, since a
  detection says "up-flow of here" but hardly how far.

Correlated meander (optional: a map made with ``meander_memory_s``)
-------------------------------------------------------------------
The plume's axis does not follow the back-trajectory of the planner's ~100-s flow estimate: it
meanders about it, slowly, and near the source the filament is much narrower than the spread of
the hits over time. The cycles are therefore not independent given the source: after the plume
swings away the vehicle collects a *run* of misses, each of which the independent-cycle model
counts against the true source up-flow. With ``meander_memory_s`` (τ) each cell hypothesis
carries a persistent meander state, the normalised cross-flow offset ``z`` of the plume's axis
(``z ~ N(0, 1)`` stationary, an Ornstein–Uhlenbeck process with correlation time τ, discretised
as a :class:`MeanderChain` of ``meander_bins`` states). The axis at range ``a`` up-flow lies
``z · σm(a)`` across the flow from the back-trajectory, and the plume about it is ``σi(a)``
wide, ``σi(a)² = σi(0)² + w · a`` (``instant_near_spread_m``, ``instant_spread_m``: relative
dispersion widens it), with the rest of the kernel's spread the meander's:
``σm(a)² = σ(a)² - σi(a)²``, ``σ(a)² = σ0² + min(a tan φ, σmax)²``. The chance of a detection
given the state is

    K(s; x | z) = p_in(a) · exp(-(c - z σm(a))² / (2 σi(a)²)),
    p_in(a) = min(p0 · exp(-a / L) · σ(a) / σi(a), IN_PLUME_MAX),

(the strong level likewise, with ``p3 · exp(-a / L3)``), so that averaged over ``z`` it is the
independent-cycle ``K(s; x)`` wherever ``p_in`` is not capped. Each cell is then an HMM filtered
forward: every observation propagates the cell's ``P(z)`` with the chain's transition over the
time since the last one, multiplies it by the observation's likelihood in each state (the same
detection and non-detection likelihoods as above, ``K(s; x | z)`` for ``K(s; x)``, each raised to
its tempering exponent) and renormalises; the cell's log-posterior gains the log of the
normaliser (the predictive probability of the observation). A run of misses is then explained by
one offset of the plume (its evidence is capped at about "the plume was elsewhere for a while",
the weight of the states far to the side), and a run of detections concentrates ``z`` instead of
only multiplying location evidence. Readings chosen: one ``z`` per cell for all ranges (the
meander swings the whole plume; a bend within it is not modelled); the part of ``σ0`` that is not
``σi(0)`` persists as well (near the source the hits' spread over time comes from the axis's
slow wander and the vehicle's navigation drift, not from a wide filament); ``p_in`` is capped, so
within ~10 m of the source (and where the measured chance over ``σ(a)/σi(a)`` exceeds the cap)
the ``z``-average is *below* the measured independent-cycle chance (0.32 against 0.72 at the
source with the TRO settings): a pass beside a thin filament says little. A version that widened
``σi`` instead, to keep the average exact, declared farther from the source on tuning runs
(:class:`~cptbt.behaviours.likelihood.LikelihoodMapParams`). Cells the plume cannot reach in any
state (``K < exp(-18)``) skip the per-state arithmetic: a non-detection leaves them as they are
and a detection multiplies them by the false-alarm term. The transition matrices are products
with ``numpy.einsum``: a ``(bins, cells)`` product through BLAS was 7 times slower with
threads on a busy two-core host.

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
from pydantic import Field

from cptbt.angles import unit
from cptbt.behaviours.meander import MeanderChain
from cptbt.frames import OpArea
from cptbt.node import BehaviourParams
from cptbt.types import Percept, Point, SourceBelief

Array = NDArray[np.float64]

MAX_CELLS = 250_000
"""A finer grid is coarsened to this many cells (per-cycle cost grows with the cell count)."""

SOURCE_MAP_KEY = "source_map"
"""Blackboard key of the published :class:`~cptbt.types.SourceBelief`."""


class MapModelParams(BehaviourParams):
    """The grid and the likelihood model of the source map (see the module docstring)."""

    cell_m: float = Field(default=2.0, gt=0.1, le=100, description="Grid resolution, m")
    detection_prob: float = Field(
        default=0.6, gt=0, lt=1, description="p0: chance of a detection per cycle on the plume's "
        "mean axis next to the source"
    )
    detection_decay_m: float = Field(
        default=1000.0, gt=0, description="L: range over which that chance falls by a factor e, m "
        "(long by default: see the module docstring)"
    )
    false_alarm_prob: float = Field(
        default=0.02, gt=0, lt=1, description="ε: chance of a detection with no plume, per cycle"
    )
    near_spread_m: float = Field(
        default=3.0, gt=0, description="σ0: cross-flow spread at the source (navigation error, "
        "puff size), m"
    )
    behind_spread_m: float | None = Field(
        default=None, gt=0, description="How fast K falls off for sources down-flow of the "
        "observer (None: near_spread_m), m"
    )
    spread_deg: float = Field(
        default=12.0, ge=0, lt=80, description="φ: half-angle of the meander; the cross-flow "
        "spread grows by tan φ per metre of range, deg"
    )
    max_range_m: float = Field(
        default=250.0, gt=0, description="Detections are not traced back farther than this, m"
    )
    max_spread_m: float | None = Field(
        default=None, gt=0, description="σmax: the meander's cross-flow spread stops growing "
        "at this (None: it grows with range without bound), m"
    )
    detection_weight: float = Field(
        default=0.5, gt=0, le=1, description="Tempering exponent of a detection's likelihood"
    )
    nondetection_weight: float = Field(
        default=0.3, gt=0, le=1, description="Tempering exponent of a non-detection's likelihood"
    )
    explored_radius_m: float = Field(
        default=6.0, gt=0, description="Cells within this of the vehicle's track count as "
        "explored (for map-guided reacquire), m"
    )
    mask_radius_m: float = Field(
        default=6.0, gt=0, description="Cells within this of a declared source are ruled out "
        "as another source, m"
    )
    explained_prob: float = Field(
        default=0.05, gt=0, lt=1, description="A detection a declared source's plume would "
        "cause with at least this chance is explained by it and says nothing about other sources"
    )
    strong_prob: float = Field(
        default=0.68, gt=0, lt=1, description="p3: chance per cycle of a *strong* detection "
        "(see the module docstring) on the plume's axis next to the source"
    )
    strong_decay_m: float = Field(
        default=40.0, gt=0, description="L3: range over which the chance of a strong detection "
        "falls by a factor e, m"
    )
    strong_false_alarm_prob: float = Field(
        default=0.002, gt=0, lt=1, description="ε3: chance of a strong detection with no plume, "
        "per cycle"
    )
    trajectory_points: int = Field(
        default=200, ge=2, le=10_000, description="Back-trajectory samples per observation"
    )
    meander_memory_s: float | None = Field(
        default=None, gt=0, description="τ: correlation time of the plume's meander; with it "
        "each cell carries a meander state and cycles are correlated through it (module "
        "docstring, 'Correlated meander'); None: cycles are independent given the source, s"
    )
    instant_spread_m: float = Field(
        default=0.55, ge=0, description="With meander_memory_s: the plume's width about its "
        "instantaneous axis grows as σi(a)² = σ0² + this · a (relative dispersion, 2 K_c / U), m"
    )
    instant_near_spread_m: float | None = Field(
        default=None, gt=0, description="With meander_memory_s: σi(0), the plume's width about "
        "its instantaneous axis at the source; the rest of σ0 persists like the meander (None: "
        "σ0, all of it instantaneous), m"
    )
    meander_bins: int = Field(
        default=9, ge=3, le=41, description="With meander_memory_s: discrete meander states "
        "per cell"
    )


IN_PLUME_MAX = 0.95
"""With a meander state, the chance of a detection on the plume's instantaneous axis is capped
at this (a miss there is never certain proof: see :meth:`SourceMap._kernel_given_meander`)."""


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
        cell = max(model.cell_m, math.sqrt(w * h / MAX_CELLS))
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
        level = int(p.detected)
        if p.detected and self.strong_concentration is not None \
                and p.concentration >= self.strong_concentration:
            level = 2
        obs = (self._n - 1, x, y, level)
        self._obs.append(obs)
        self.detections += int(p.detected)
        if p.detected and not self.explained_by_known(self._n - 1, x, y):
            self.unexplained += 1
        self._fold(obs)
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
        self._log = np.zeros(self._cx.size)
        self._reset_meander()
        for obs in self._obs:
            self._fold(obs)
        self._log[self._excluded] = -np.inf
        if (~self._excluded).any():
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
                         sy: Array) -> tuple[Array, Array]:
        """The kernel's shape without the decay with range, and the range ``max(a, 0)``."""
        m = self.model
        a, c = self._geometry(k, x, y, sx, sy)
        ap = np.maximum(a, 0.0)
        meander = self._meander(ap)
        var = m.near_spread_m**2 + meander**2
        expo = -c * c / (2.0 * var)
        behind = m.behind_spread_m if m.behind_spread_m is not None else m.near_spread_m
        expo -= np.where(a < 0, a * a / (2.0 * behind**2), 0.0)
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
            miss_known = 1.0
            if self.known:
                kx = np.array([s.x for s in self.known])
                ky = np.array([s.y for s in self.known])
                miss_known = float(np.prod(1.0 - self.kernel(k, x, y, kx, ky)))
                if miss_known <= 1.0 - m.explained_prob:
                    return np.where(self._excluded, -np.inf, 0.0)
            if strong_cells is None:
                like = 1.0 - (1.0 - self.false_alarm(k)) * (1.0 - k_cells) * miss_known
            elif level >= 2:
                like = 1.0 - (1.0 - m.strong_false_alarm_prob) * (1.0 - strong_cells) * miss_known
            else:
                like = 1.0 - (1.0 - self.false_alarm(k)) * (1.0 - (k_cells - strong_cells)) \
                    * miss_known
            out = m.detection_weight * np.log(like)
        return np.where(self._excluded, -np.inf, out)

    def _kernel_given_meander(self, k: int, x: float, y: float,
                              strong: bool) -> tuple[NDArray[np.intp], Array, Array | None]:
        """``K(s; x | z)`` for every meander state and the cells it can reach: ``(idx, K)``,
        ``K`` of shape ``(bins, len(idx))``; with ``strong`` also the strong level's
        ``K3(s; x | z)``. Cells not in ``idx`` have ``K`` below ``exp(-18)`` in every state.

        The plume's axis at range ``a`` up-flow lies ``z · σm(a)`` across the flow from the
        back-trajectory, and the plume about that axis is ``σi(a)`` wide:

            K(s; x | z) = p_in(a) · exp(-(c - z σm(a))² / (2 σi(a)²)),
            σi(a)² = σ0² + w · a,   σm(a)² = max(σ(a)² - σi(a)², 0),
            p_in(a) = min(p0 exp(-a / L) · σ(a) / σi(a), IN_PLUME_MAX),

        with ``σ(a)² = σ0² + min(a tan φ, σmax)²`` the independent-cycle kernel's spread and
        ``w`` ``instant_spread_m``: over ``z ~ N(0, 1)`` the kernel averages to the
        independent-cycle one (up to the cap on ``p_in`` and the quadrature), so the model keeps
        the measured detection chances and widths and adds only their persistence.
        """
        m = self.model
        assert self.chain is not None
        a, c = self._geometry(k, x, y, self._cx, self._cy)
        ap = np.maximum(a, 0.0)
        behind = m.behind_spread_m if m.behind_spread_m is not None else m.near_spread_m
        gate = np.where(a <= m.max_range_m, np.exp(-np.minimum(a, 0.0) ** 2 / (2.0 * behind**2)),
                        0.0)
        meander = self._meander(ap)
        var_total = m.near_spread_m**2 + meander**2
        near_i = m.instant_near_spread_m if m.instant_near_spread_m is not None \
            else m.near_spread_m
        var_i = np.minimum(near_i**2 + m.instant_spread_m * ap, var_total)
        sig_m = np.sqrt(var_total - var_i)
        reach = np.maximum(np.abs(c) - float(self.chain.z[-1]) * sig_m, 0.0)
        idx = np.flatnonzero((gate > 1e-8) & (reach * reach < 36.0 * var_i))
        ap, c, var_i, var_total, sig_m, gate = (
            v[idx] for v in (ap, c, var_i, var_total, sig_m, gate))
        ratio = np.sqrt(var_total / var_i)
        p_in = np.minimum(m.detection_prob * np.exp(-ap / m.detection_decay_m) * ratio,
                          IN_PLUME_MAX) * gate
        d = c - self.chain.z[:, None] * sig_m
        shape = np.exp(np.maximum(d * d * (-0.5 / var_i), -60.0))  # no subnormals: they are slow
        k_cells = p_in * shape
        if not strong:
            return idx, k_cells, None
        p3 = np.minimum(m.strong_prob * np.exp(-ap / m.strong_decay_m) * ratio,
                        IN_PLUME_MAX) * gate
        return idx, k_cells, np.minimum(p3 * shape, k_cells)

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
        miss_known = 1.0
        if self.known:
            kx = np.array([s.x for s in self.known])
            ky = np.array([s.y for s in self.known])
            miss_known = float(np.prod(1.0 - self.kernel(k, x, y, kx, ky)))
            if miss_known <= 1.0 - m.explained_prob:
                return None
        idx, k_cells, strong_cells = self._kernel_given_meander(
            k, x, y, self.strong_concentration is not None)
        if strong_cells is None:
            eps = self.false_alarm(k)
            like = 1.0 - (1.0 - eps) * (1.0 - k_cells) * miss_known
        elif level >= 2:
            eps = m.strong_false_alarm_prob
            like = 1.0 - (1.0 - eps) * (1.0 - strong_cells) * miss_known
        else:
            eps = self.false_alarm(k)
            like = 1.0 - (1.0 - eps) * (1.0 - (k_cells - strong_cells)) * miss_known
        rest = m.detection_weight * math.log(1.0 - (1.0 - eps) * miss_known)
        return idx, np.exp(m.detection_weight * np.log(like)), rest

    def explained_by_known(self, k: int, x: float, y: float) -> bool:
        """Whether the declared sources' plumes would cause a detection at ``(x, y)`` on cycle
        ``k`` with at least ``explained_prob``."""
        if not self.known:
            return False
        kx = np.array([s.x for s in self.known])
        ky = np.array([s.y for s in self.known])
        miss_known = float(np.prod(1.0 - self.kernel(k, x, y, kx, ky)))
        return miss_known <= 1.0 - self.model.explained_prob

    def expected_detection(self, source: Point, x: float, y: float) -> float:
        """``K(source; (x, y))`` on the latest cycle: how likely a detection there is now."""
        if self._n == 0:
            return 0.0
        return float(self.kernel(self._n - 1, x, y, np.array([source.x]), np.array([source.y]))[0])

    # -- reading -------------------------------------------------------------------------
    def posterior(self) -> Array:
        """Cell probabilities (flat), summing to 1 over the cells not ruled out."""
        post = np.exp(self._log - self._log[~self._excluded].max()) if (~self._excluded).any() \
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
