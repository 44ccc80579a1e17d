"""The plume's meander offset as a discrete Markov chain (the likelihood map's meander state).

:class:`MeanderChain` is the state ``z`` each cell of the source map carries with
``meander_memory_s`` (:mod:`cptbt.behaviours.source_map`, "Correlated meander"): the
normalised cross-flow offset of the plume's axis, stationary N(0, 1), an Ornstein–Uhlenbeck
process with correlation time ``tau_s``.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

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
