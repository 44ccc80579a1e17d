"""The source map's plume likelihood model: how likely an observation is, were the source at ``s``.

The source map (:mod:`cptbt.behaviours.source_map`) multiplies each cell by the likelihood of each
cycle's observation if the source were there; this module is that likelihood, apart from the
grid: the kernel ``K(s; x)`` along the water's back-trajectory, a detection's likelihood from it,
and how far the already declared sources' plumes explain a detection.
:class:`PlumeLikelihood` keeps what the model reads besides the observation: the planner's flow
estimate, recorded every cycle, and the declared sources.

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

Assumptions of the model, stated because it is only as good as they are (the map's own, on the
hypotheses, the independence of cycles and the prior, are in :mod:`cptbt.behaviours.source_map`):

- a declared source's plume is known exactly: it is this model's plume from the declared point;
- the flow is uniform in space over the plume (the vehicle's estimate stands for the water's
  motion along the whole back-trajectory) and its history is the planner's own estimate.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from cptbt.angles import unit
from cptbt.behaviours.map_model import MapModelParams
from cptbt.types import Percept, Point

Array = NDArray[np.float64]


class PlumeLikelihood:
    """The plume likelihood model and the history it reads: the flow estimate and the declared
    sources.

    :class:`~cptbt.behaviours.source_map.SourceMap` is one, evaluated over its grid; the methods
    here take the hypothesised sources as arrays, so they serve any set of points.

    Args:
        model: the likelihood model's parameters.
        strong_concentration: the concentration of a *strong* detection (the two-level model);
            None: one level.
    """

    def __init__(self, model: MapModelParams, strong_concentration: float | None = None) -> None:
        self.model = model
        self.strong_concentration = strong_concentration
        self._tan = math.tan(math.radians(model.spread_deg))
        self._t = np.empty(1024)
        self._cum = np.empty((1024, 2))  # cumulative flow displacement ∫U dt at each cycle
        self._n = 0
        self._flow = (0.0, 0.0)
        self.known: tuple[Point, ...] = ()

    # -- the flow history and an observation's level -------------------------------------
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

    def level(self, p: Percept) -> int:
        """The percept's observation level: 0 a miss, 1 a detection, 2 a *strong* one (with
        the two-level model)."""
        if not p.detected:
            return 0
        strong = self.strong_concentration
        return 2 if strong is not None and p.concentration >= strong else 1

    # -- the kernel ----------------------------------------------------------------------
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

    # -- a detection's likelihood and the declared sources -------------------------------
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
