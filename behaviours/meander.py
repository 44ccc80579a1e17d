"""The plume's meander offset as a discrete Markov chain (the likelihood map's meander state).

:class:`MeanderChain` is the state ``z`` each cell of the source map carries with
``meander_memory_s`` (:mod:`cptbt.behaviours.source_map`, "Correlated meander"): the
normalised cross-flow offset of the plume's axis, stationary N(0, 1), an Ornstein–Uhlenbeck
process with correlation time ``tau_s``.

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
detection and non-detection likelihoods as the independent-cycle model's in
:mod:`cptbt.behaviours.plume_likelihood`, ``K(s; x | z)`` for ``K(s; x)``, each raised to
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
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from cptbt.behaviours.map_model import MapModelParams

Array = NDArray[np.float64]


class MeanderChain:
    """The meander state ``z`` as a discrete Markov chain: an Ornstein–Uhlenbeck process.

    ``bins`` equally spaced states with weights ∝ the standard normal density, the nodes scaled
    so that the weighted variance is exactly 1; a birth–death chain between neighbouring states
    whose rates satisfy detailed balance with those weights (so they are its stationary
    distribution) and are scaled so that the autocorrelation of ``z`` falls to 1/e after
    ``tau_s``. The transition matrix over ``dt`` is ``expm(Q dt)``, from the eigenvectors of the
    chain's symmetrised generator; matrices are cached by ``dt`` (to the millisecond).
    """

    def __init__(self, bins: int, tau_s: float) -> None:
        z = np.linspace(-2.4, 2.4, bins)
        w = np.exp(-0.5 * z * z)
        w /= w.sum()
        z = z / math.sqrt(float(w @ (z * z)))
        self.z: Array = z
        self.weights: Array = w
        root = np.sqrt(w)
        sym = np.zeros((bins, bins))  # S = D^½ Q D^-½ with unit rate scale
        for i in range(bins - 1):
            sym[i, i + 1] = sym[i + 1, i] = 1.0
            sym[i, i] -= math.sqrt(w[i + 1] / w[i])
            sym[i + 1, i + 1] -= math.sqrt(w[i] / w[i + 1])
        lam, vec = np.linalg.eigh(sym)
        self._lam, self._vec, self._root = lam, vec, root
        # the autocorrelation after u units of the unit-rate chain; find u where it is 1/e
        lo, hi = 1e-6, 1e3
        for _ in range(80):
            mid = math.sqrt(lo * hi)
            if self._corr(mid) > math.exp(-1.0):
                lo = mid
            else:
                hi = mid
        self._rate = math.sqrt(lo * hi) / tau_s
        self._cache: dict[int, Array] = {}

    def _unit(self, u: float) -> Array:
        t = (self._vec * np.exp(self._lam * u)) @ self._vec.T
        out = np.asarray(t / self._root[:, None] * self._root[None, :], dtype=float)
        out = np.maximum(out, 0.0)
        return np.asarray(out / out.sum(axis=1, keepdims=True), dtype=float)

    def _corr(self, u: float) -> float:
        return float(self.weights * self.z @ self._unit(u) @ self.z)

    def transition(self, dt: float) -> Array:
        """``P(z' | z)`` after ``dt`` seconds, rows ``z`` and columns ``z'``."""
        key = round(max(dt, 0.0) * 1000)
        got = self._cache.get(key)
        if got is None:
            if len(self._cache) > 256:
                self._cache.clear()
            got = self._cache[key] = self._unit(self._rate * key / 1000.0)
        return got


IN_PLUME_MAX = 0.95
"""With a meander state, the chance of a detection on the plume's instantaneous axis is capped
at this (a miss there is never certain proof: see :meth:`SourceMap._kernel_given_meander`)."""


def meander_kernel(m: MapModelParams, z: Array, a: Array, c: Array, meander: Array,
                   strong: bool) -> tuple[NDArray[np.intp], Array, Array | None]:
    """``K(s; x | z)`` for every meander state ``z`` and the cells it can reach: ``(idx, K)``,
    ``K`` of shape ``(len(z), len(idx))``; with ``strong`` also the strong level's
    ``K3(s; x | z)``. ``a``, ``c``: each cell's range up-flow of the observer and cross-flow
    offset from the back-trajectory; ``meander``: the meander part of the independent-cycle
    spread at ``max(a, 0)``. Cells not in ``idx`` have ``K`` below ``exp(-18)`` in every state.

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
    ap = np.maximum(a, 0.0)
    behind = m.behind_spread_m if m.behind_spread_m is not None else m.near_spread_m
    gate = np.where(a <= m.max_range_m, np.exp(-np.minimum(a, 0.0) ** 2 / (2.0 * behind**2)),
                    0.0)
    var_total = m.near_spread_m**2 + meander**2
    near_i = m.instant_near_spread_m if m.instant_near_spread_m is not None \
        else m.near_spread_m
    var_i = np.minimum(near_i**2 + m.instant_spread_m * ap, var_total)
    sig_m = np.sqrt(var_total - var_i)
    reach = np.maximum(np.abs(c) - float(z[-1]) * sig_m, 0.0)
    idx = np.flatnonzero((gate > 1e-8) & (reach * reach < 36.0 * var_i))
    ap, c, var_i, var_total, sig_m, gate = (
        v[idx] for v in (ap, c, var_i, var_total, sig_m, gate))
    ratio = np.sqrt(var_total / var_i)
    p_in = np.minimum(m.detection_prob * np.exp(-ap / m.detection_decay_m) * ratio,
                      IN_PLUME_MAX) * gate
    d = c - z[:, None] * sig_m
    shape = np.exp(np.maximum(d * d * (-0.5 / var_i), -60.0))  # no subnormals: they are slow
    k_cells = p_in * shape
    if not strong:
        return idx, k_cells, None
    p3 = np.minimum(m.strong_prob * np.exp(-ap / m.strong_decay_m) * ratio,
                    IN_PLUME_MAX) * gate
    return idx, k_cells, np.minimum(p3 * shape, k_cells)
