"""Information-seeking search: infotaxis and space-aware infotaxis on the source map.

Infotaxis (Vergassola, Villermaux & Shraiman, "'Infotaxis' as a strategy for searching without
gradients", Nature 445, 2007) keeps a Bayesian belief over where the source is and, every
decision, takes the move among a few candidates after which it expects the belief's entropy to
be lowest. Space-aware infotaxis (SAI; Loisy & Eloy, "Searching for a source without gradients:
how good is infotaxis and how to beat it", Proc. R. Soc. A 478, 2022) minimises instead the
expectation of ``J = log2(D + 2^(H-1) - 1/2)``, ``D`` the belief's mean distance to the vehicle
and ``H`` its entropy: near the source it values getting there over learning more.

The belief
----------
The belief is the likelihood map of :mod:`cptbt.behaviours.source_map` (its grid, its
tempering, and its back-trajectory kernel along the estimated flow,
:mod:`cptbt.behaviours.plume_likelihood`), with one change of reading — the detection model is
a Poisson one, as Vergassola's:

- hits arrive as a Poisson process whose rate follows the plume's *mean* concentration
  downstream of a source at ``s``: ``R(s; x) = R0 · exp(-a / L) · exp(-c² / (2 σ(a)²))``, the
  map's kernel shape (``a`` the range up-flow along the back-trajectory of the estimated flow,
  ``c`` the cross-flow offset from it, ``σ(a)² = σ0² + (a tan φ)²`` the meander's spread, ``L``
  ``detection_decay_m``, ``σ0`` ``near_spread_m``, ``φ`` ``spread_deg``);
- ``R0 = -ln(1 - detection_prob)``: ``detection_prob`` is read *per second* here (the chance of
  at least one hit in a second on the plume's axis next to the source), so the model does not
  depend on the planning rate; likewise ``false_alarm_prob`` per second;
- the perception condenses a cycle's samples into one detection flag (SPEC §2), so an
  observation is "at least one hit in the cycle": ``K(s; x) = 1 - exp(-R(s; x) Δt)`` with
  ``Δt`` the cycle's length; a detection multiplies cell ``s`` by
  ``(1 - (1 - ε)(1 - K))^w_d``, a non-detection by ``(1 - K)^w_nd``, as in the map;
- **(reading) evidence fades**: every cycle the log-belief is scaled by
  ``exp(-Δt / memory_s)`` before the new percept is folded in (``memory_s`` 60 s by default;
  None keeps the papers' belief, which never forgets). Vergassola's model is a stationary
  plume; a meandering one is not, and a minute of misses where the plume was not *then* rules
  the true source out for good: the belief then collapses onto the vehicle's latest hits and
  SAI circles there (seen on AB's grid; measured there on plume replicates 0–1, 200 paired
  runs each: 94.5% success without fading, 99.5% with ``memory_s: 60``, 96% with 180 — chosen
  on those plumes, so the study's 500 runs, 95.2%, are the figure to quote).

The defaults (the map's, with 4 m cells) serve both the TRO ocean at 1 Hz and AB's 1 m/s,
3 filaments/s plume at 10 Hz; the TRO mission lengthens the moves for the REMUS's turning
circle.

The decision
------------
Every ``replan_s`` the candidates are ``candidates`` points at ``step_m`` from the vehicle, at
equal angles; those outside the OpArea are dropped. For each candidate ``x'`` (all candidates
at once, as ``(candidates, cells)`` arrays):

- ``p_end`` = the belief within ``found_radius_m`` of ``x'`` (the chance of arriving at the
  source there); the rest, renormalised, is the belief if not;
- ``P_d`` = the predicted chance of a detection at ``x'``; ``b_d``, ``b_nd`` the beliefs after a
  detection and after none (tempered as the map tempers them);
- infotaxis scores ``(1 - p_end)(P_d H(b_d) + (1 - P_d) H(b_nd))``, SAI
  ``(1 - p_end)(P_d J(b_d) + (1 - P_d) J(b_nd))`` (``J`` of a found source is 0), and the
  vehicle heads for the candidate with the lowest score.

With no hits at all the best moves are those whose misses rule out the most: the searcher
goes to the down-flow end of the unexplored water and casts across the flow there (a miss
rules out every source up-flow of it), as Vergassola's searcher casts crosswind.

Readings chosen: one step of look-ahead, as both papers' heuristics; ``D`` is the Euclidean mean
distance in cells (Loisy & Eloy's grid agent moves along the axes and so uses Manhattan; a
vehicle moves in any direction); ``H`` in bits over the map's cells; ``p_end`` is what the
policy *expects*, not an observation: arrival is judged by the simulator (AB) or declaration by
``declare_source`` (TRO), never by this node, so the map is not told "not found here". That is
why ``found_radius_m`` is small (2 m, half a cell): a larger one keeps promising information the
map never receives, and the searcher returns to the same cells (measured on AB's grid, 200
paired runs each without fading: 2 m 94.5%, 4 m 71%, 8 m 85%, 0 m 85.5%).

In the priority tree
--------------------
Infotaxis needs no separate plume-following: a detection concentrates the belief up-flow and
the next move goes there. A mission that wants the literature's searcher lists no
``maintain_plume`` and no ``reacquire_plume`` and lets ``find_plume: {variant: infotaxis}``
drive whenever nothing above it has an output, i.e. from the end of move-to-field to the
declaration (safety still overrides at the OpArea boundary). With TRO's ``declaration``
criterion pair it with ``declare_source: {variant: likelihood_map}``, which declares from the
same kind of map once its posterior is concentrated (the ``upflow_cluster`` rule needs
lost-contact points that a searcher which never loses contact on purpose rarely makes).
Listed under a moth ``maintain_plume``, it becomes a find-plume only: the moth tracks while in
the plume and infotaxis searches whenever contact is lost for good. The ``reacquire_plume``
variants steer the same way from the loss of contact (a detection, none within λ) for
``give_up_s``, then yield to the mission's find-plume. Each node keeps its own map, folded in
every cycle (:meth:`watch`), so the belief also learns while other behaviours drive.
"""

from __future__ import annotations

import math
from typing import Any, ClassVar

import numpy as np
from numpy.typing import NDArray
from pydantic import Field

from cptbt.behaviours.map_model import MapModelParams
from cptbt.behaviours.source_map import SourceMap, grid_advice
from cptbt.frames import OpArea
from cptbt.node import BehaviourParams, Contract, PlanBehaviour
from cptbt.registry import BehaviourSpec
from cptbt.types import Command, Percept

Array = NDArray[np.float64]

TABLE_STEP_M = 0.5
"""Resolution of the back-trajectory table the Poisson map reads its kernel from, m."""

SHAPE_FLOOR_LOG = -60.0
"""The kernel shape is floored at ``exp(-60)`` ≈ 1e-26 (nothing a belief can tell apart from 0)."""

NOMINAL_CYCLE_S = 1.0
"""Cycle length assumed before two cycles have been seen (TRO's 1 Hz), s."""


def _advise(params: BehaviourParams, area: OpArea) -> list[tuple[str, str]]:
    """The belief grid's warning (:func:`~cptbt.behaviours.source_map.grid_advice`)."""
    assert isinstance(params, MapModelParams)
    return grid_advice(params, area)


class InfotaxisParams(MapModelParams):
    """The belief's model (the map's, read per second: module docstring) and the decision."""

    cell_m: float = Field(default=4.0, gt=0.1, le=100, description="Belief grid resolution, m")
    candidates: int = Field(
        default=8, ge=3, le=64, description="Candidate moves per decision, at equal angles"
    )
    step_m: float = Field(default=6.0, gt=0, description="Distance of the candidate points, m")
    replan_s: float = Field(
        default=2.0, gt=0, description="A new move is chosen this often (not at every "
        "detection: at 10 Hz a burst of filaments would re-plan every cycle), s"
    )
    found_radius_m: float = Field(
        default=2.0, ge=0, description="The policy expects to find the source when it comes "
        "this close to it (0: it never expects to), m"
    )
    memory_s: float | None = Field(
        default=60.0, gt=0, description="Evidence older than this fades: every cycle of Δt the "
        "log-belief is scaled by exp(-Δt / memory_s) (None: the belief never forgets), s"
    )


class PoissonSourceMap(SourceMap):
    """The source map with Poisson hits: ``K = 1 - exp(-R0 · shape · Δt)`` (module docstring)."""

    def __init__(self, area: OpArea, model: MapModelParams,
                 memory_s: float | None = None) -> None:
        super().__init__(area, model)
        self._rate = -math.log1p(-model.detection_prob)
        self._fa_rate = -math.log1p(-model.false_alarm_prob)
        self.memory_s = memory_s

    def observe(self, p: Percept) -> bool:
        """Fade the old evidence (with ``memory_s``), then fold the percept in."""
        dt = p.t - self.t
        if self.memory_s is not None and math.isfinite(dt) and dt > 0:
            self._log *= math.exp(-dt / self.memory_s)
        return super().observe(p)

    def cycle_s(self, k: int) -> float:
        """The length of cycle ``k`` (the time since the previous one), s."""
        if k <= 0:
            return NOMINAL_CYCLE_S
        dt = float(self._t[k] - self._t[k - 1])
        return min(max(dt, 1e-3), 10.0) if math.isfinite(dt) else NOMINAL_CYCLE_S

    def kernel(self, k: int, x: float | Array, y: float | Array, sx: Array, sy: Array) -> Array:
        """Chance of at least one hit in cycle ``k`` at ``(x, y)`` from sources ``s``."""
        return -np.expm1(-self._rate * self.cycle_s(k) * self.kernel_shape(k, x, y, sx, sy))

    def kernel_shape(self, k: int, x: float | Array, y: float | Array, sx: Array,
                     sy: Array) -> Array:
        """The map's kernel shape, read from a table of the back-trajectory's sideways drift.

        The same function as
        :meth:`~cptbt.behaviours.plume_likelihood.PlumeLikelihood.kernel_shape` to within the
        table's resolution (``TABLE_STEP_M``; see :meth:`shape_at`).
        """
        traj = self.back_trajectory(k)
        ux, uy = traj[0], traj[1]
        a = (x - sx) * ux + (y - sy) * uy
        c0 = (sx - x) * -uy + (sy - y) * ux
        return self.shape_at(a, c0, traj)

    def shape_at(self, a: Array, c0: Array, traj: tuple[float, float, Array, Array]) -> Array:
        """The kernel shape from the source's range ``a`` up-flow of the observer and its
        offset ``c0`` across the flow (both along the back-trajectory's mean direction).

        The cross-flow offset from the back-trajectory is ``c0`` plus the trajectory's sideways
        drift at range ``a``, looked up by index in a table at ``TABLE_STEP_M`` steps rather
        than by :func:`numpy.interp`'s binary search per cell, which dominated the cost of
        scoring several moves over every cell. The log of the shape is floored at
        ``SHAPE_FLOOR_LOG``: subnormal numbers downstream are slow.
        """
        m = self.model
        ux, uy, along, disp = traj
        n = math.ceil(float(along[-1]) / TABLE_STEP_M) + 2
        grid = np.arange(n) * TABLE_STEP_M
        drift = np.interp(grid, along, disp[:, 0]) * -uy + np.interp(grid, along, disp[:, 1]) * ux
        slope = np.append(np.diff(drift), 0.0)
        u = np.clip(a * (1.0 / TABLE_STEP_M), 0.0, n - 1.0)
        i = u.astype(np.intp)
        c = c0 + drift.take(i) + (u - i) * slope.take(i)
        ap = np.maximum(a, 0.0)
        an = np.minimum(a, 0.0)
        var2 = 2.0 * m.near_spread_m**2 + (2.0 * self._tan**2) * (ap * ap)
        expo = c * c / var2 + ap * (1.0 / m.detection_decay_m) + an * an * (
            0.5 / m.near_spread_m**2)
        np.minimum(expo, -SHAPE_FLOOR_LOG, out=expo)
        return np.exp(-expo) * (a <= m.max_range_m)

    def exposure(self, k: int) -> float:
        """``R0 Δt``: the mean number of hits in cycle ``k`` on the axis next to the source."""
        return self._rate * self.cycle_s(k)

    @property
    def cell_area_m2(self) -> float:
        """The area of one cell, m²."""
        dx = float(self.xs[1] - self.xs[0]) if len(self.xs) > 1 else self.model.cell_m
        dy = float(self.ys[1] - self.ys[0]) if len(self.ys) > 1 else self.model.cell_m
        return dx * dy

    def false_alarm(self, k: int) -> float:
        """Chance of a false hit in cycle ``k``."""
        return -math.expm1(-self._fa_rate * self.cycle_s(k))

    @property
    def cycles(self) -> int:
        """Cycles recorded so far."""
        return self._n


SUPPORT = 1e-12
"""Cells with less than this times the largest posterior are left out of the move scores (their
share of the entropy and of the mean distance is below rounding)."""


def score_moves(
    belief: PoissonSourceMap,
    post: Array,
    targets: Array,
    params: InfotaxisParams,
    *,
    space_aware: bool,
) -> Array:
    """The expected cost of moving to each of ``targets`` (``(m, 2)``): lower is better.

    Infotaxis: the expected entropy after the move; SAI: the expected ``J`` (module docstring).
    ``post`` is the belief's flat posterior. One pass over ``(m, cells)`` arrays: the
    likelihoods are written as exponentials of the kernel's shape, so the entropies come from
    ``log post`` (taken once) plus the log-likelihood, with no logarithm of a posterior array.
    """
    cx, cy = belief.cells()
    keep = post > SUPPORT * float(post.max())
    if not keep.all():
        cx, cy, post = cx[keep], cy[keep], post[keep]
    log_post = np.log(post)
    px, py = targets[:, :1], targets[:, 1:2]
    k = belief.cycles - 1
    traj = belief.back_trajectory(k)
    ux, uy = traj[0], traj[1]
    a = (px * ux + py * uy) - (cx * ux + cy * uy)  # (m, n): range of s up-flow of x'
    c0 = (cy * ux - cx * uy) - (py * ux - px * uy)  # and its offset across the flow
    dist = np.sqrt(a * a + c0 * c0)
    found = dist <= params.found_radius_m
    rest = np.where(found, 0.0, post)
    p_end = post.sum() - rest.sum(axis=1)
    exposure = belief.exposure(k) * belief.shape_at(a, c0, traj)  # R(s; x') Δt
    miss = (1.0 - belief.false_alarm(k)) * np.exp(-exposure)  # P(no hit | s)
    z_rest = rest.sum(axis=1)
    p_det = 1.0 - (rest * miss).sum(axis=1) / np.where(z_rest > 0, z_rest, 1.0)
    log_det = params.detection_weight * np.log1p(-miss)  # tempered log-likelihoods
    log_none = -params.nondetection_weight * exposure  # (the constant (1 - ε)^w cancels)
    w_det = rest * np.exp(log_det)
    w_none = rest * np.exp(log_none)
    h_det, z_det = _entropy(w_det, log_post + log_det)
    h_none, z_none = _entropy(w_none, log_post + log_none)
    if space_aware:
        cell = math.sqrt(belief.cell_area_m2)
        d_det = (w_det * dist).sum(axis=1) / (z_det * cell)
        d_none = (w_none * dist).sum(axis=1) / (z_none * cell)
        h_det = _space_aware_cost(d_det, h_det)
        h_none = _space_aware_cost(d_none, h_none)
    return np.asarray((1.0 - p_end) * (p_det * h_det + (1.0 - p_det) * h_none))


def _entropy(w: Array, log_w: Array) -> tuple[Array, Array]:
    """Entropy (bits) of each row of ``w / Z`` given ``log w``, and ``Z`` (1 where 0)."""
    z = w.sum(axis=1)
    z = np.where(z > 0, z, 1.0)
    return (np.log(z) - (w * log_w).sum(axis=1) / z) / math.log(2.0), z


def _space_aware_cost(d: Array, h: Array) -> Array:
    """Loisy & Eloy's ``J = log2(D + 2^(H-1) - 1/2)`` (its argument when that is not > 0)."""
    v = d + np.exp2(h - 1.0) - 0.5
    return np.where(v > 0, np.log2(np.where(v > 0, v, 1.0)), v)


class _InfotaxisBase(PlanBehaviour):
    """Keeps the Poisson source map every cycle and steers by the move score."""

    Params: ClassVar[type[BehaviourParams]] = InfotaxisParams
    contract: ClassVar[Contract] = Contract(advise=_advise)
    params: InfotaxisParams
    space_aware: ClassVar[bool] = False
    persistent_state: ClassVar[tuple[str, ...]] = ("map",)

    def __init__(self, params: BehaviourParams | None = None, **kwargs: Any) -> None:
        super().__init__(params, **kwargs)
        self.map: PoissonSourceMap | None = None
        self.heading: float | None = None
        self.planned_t = -math.inf

    def setup(self, **kwargs: Any) -> None:
        """Bind the context and lay the belief grid over its OpArea (uniform prior)."""
        super().setup(**kwargs)
        assert self.context is not None
        self.map = PoissonSourceMap(self.context.op_area, self.params, self.params.memory_s)

    def initialise(self) -> None:
        """A new activation chooses a new move at once (the belief is kept)."""
        self.heading = None
        self.planned_t = -math.inf

    def watch(self, p: Percept) -> None:
        """Fold this cycle's percept into the belief, whoever drives."""
        assert self.map is not None, "call setup()"
        self.map.observe(p)

    def steer(self, p: Percept) -> Command | None:
        """The infotactic command: re-plan when due or after a detection, else hold."""
        assert self.map is not None and self.context is not None
        here = p.pose.point
        if not (math.isfinite(here.x) and math.isfinite(here.y)) or self.map.cycles == 0:
            return None
        if self.heading is None or p.t - self.planned_t >= self.params.replan_s:
            self.heading = self.choose(here.x, here.y)
            self.planned_t = p.t
        return None if self.heading is None else self.command(self.heading)

    def choose(self, x: float, y: float) -> float | None:
        """The heading of the best candidate move from ``(x, y)``; None when none is inside."""
        assert self.map is not None and self.context is not None
        m = self.params.candidates
        angles = np.arange(m) * (2.0 * math.pi / m)
        targets = np.column_stack([x + self.params.step_m * np.cos(angles),
                                   y + self.params.step_m * np.sin(angles)])
        area = self.context.op_area
        inside = ((targets[:, 0] >= area.xmin) & (targets[:, 0] <= area.xmax)
                  & (targets[:, 1] >= area.ymin) & (targets[:, 1] <= area.ymax))
        if not inside.any():
            return None  # outside the OpArea: safety brings the vehicle back
        post = self.map.posterior()
        score = np.full(m, np.inf)
        score[inside] = score_moves(self.map, post, targets[inside], self.params,
                                    space_aware=self.space_aware)
        best = int(np.argmin(np.where(np.isfinite(score), score, np.inf)))
        if not inside[best]:
            return None
        return math.degrees(float(angles[best]))


class InfotaxisFindPlume(_InfotaxisBase):
    """Find-plume by infotaxis (Vergassola et al. 2007): see the module docstring.

    Has an output whenever the field is reached and a flow estimate exists; with no
    ``maintain_plume`` in the mission it is the whole search (module docstring, "In the priority
    tree").
    """

    family: ClassVar[str] = "find_plume"
    variant: ClassVar[str] = "infotaxis"

    def decide(self, p: Percept) -> Command | None:
        """Steer infotactically once the field is reached."""
        if not self.bb.field_reached or p.flow is None:
            return None
        return self.steer(p)


class SpaceAwareInfotaxisFindPlume(InfotaxisFindPlume):
    """Find-plume by space-aware infotaxis (Loisy & Eloy 2022): see the module docstring."""

    variant: ClassVar[str] = "space_aware_infotaxis"
    space_aware: ClassVar[bool] = True


class InfotaxisReacquireParams(InfotaxisParams):
    """The infotaxis parameters and how long reacquiring lasts."""

    give_up_s: float = Field(
        default=180.0, gt=0, description="Find-plume takes over after this long without a "
        "detection (the cloverleaf's 3 repeats take about as long), s"
    )


class InfotaxisReacquire(_InfotaxisBase):
    """Reacquire by infotaxis: from a loss of contact for ``give_up_s``, then find-plume.

    Active while contact is lost (a detection was made, none within λ) and the last detection is
    less than ``give_up_s`` old; the belief it steers by has folded in every cycle of the mission.
    """

    family: ClassVar[str] = "reacquire_plume"
    variant: ClassVar[str] = "infotaxis"
    Params: ClassVar[type[BehaviourParams]] = InfotaxisReacquireParams
    params: InfotaxisReacquireParams

    def decide(self, p: Percept) -> Command | None:
        """Steer infotactically while contact is lost and the give-up time has not passed."""
        if p.in_plume or p.last_detection is None or p.flow is None:
            return None
        if p.since_detection() > self.params.give_up_s:
            return None
        return self.steer(p)


class SpaceAwareInfotaxisReacquire(InfotaxisReacquire):
    """Reacquire by space-aware infotaxis (Loisy & Eloy 2022)."""

    variant: ClassVar[str] = "space_aware_infotaxis"
    space_aware: ClassVar[bool] = True


BEHAVIOURS = [
    BehaviourSpec.of(InfotaxisFindPlume),
    BehaviourSpec.of(SpaceAwareInfotaxisFindPlume),
    BehaviourSpec.of(InfotaxisReacquire),
    BehaviourSpec.of(SpaceAwareInfotaxisReacquire),
]
