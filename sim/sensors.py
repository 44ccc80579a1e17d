"""Vehicle sensors, vectorised over vehicles: fluorometer, ADCP and navigation.

Every vehicle has its own random stream (a ``numpy.random.Generator`` per vehicle, spawned by the
caller), so vehicle i's noise does not depend on how many vehicles share the world. To keep the
hot path free of a Python loop over vehicles, each stream is drawn ahead in blocks
(``NoiseBank``): one loop over vehicles per block of samples, then array slices per sample. Each
sample always consumes the same numbers whatever features are enabled, so switching on, say,
dropouts does not change the noise (error-free navigation, all of whose noise would be
multiplied by zero, draws none: see :class:`Navigation`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray
from pydantic import BaseModel, ConfigDict, Field

from .vehicle import wrap_deg


class NoiseBank:
    """Per-vehicle random streams served as (N, k) arrays per draw.

    Each vehicle's generator is read in blocks of ``block`` draws: the block's normals, then
    its uniforms. That order fixes the stream, so ``block`` is part of the noise model (512
    throughout). How many draws are held in memory at once is not, where it can be changed
    without changing a number: a bank of normals only (or uniforms only) reads its stream in
    order whatever the chunk (numpy's generators keep no draw cached between calls), so it
    holds ``buffered`` draws; a bank of both must draw a whole
    block's normals before the block's first uniform, so it holds the block. The memory is
    ``N × draws held × (n_normal + n_uniform) × 8`` bytes (issue 15: a 512-draw navigation bank
    was 24 MB at 1,000 vehicles). ``tests/sim/test_sim_noise_bank.py`` checks that every
    buffer size draws the same numbers.

    Args:
        rngs: One generator per vehicle.
        n_normal: Standard normals per vehicle and draw.
        n_uniform: Uniforms on [0, 1) per vehicle and draw.
        block: Draws per block of the stream.
        buffered: Draws held at once by a bank of one kind (its stream has no blocks).
    """

    def __init__(
        self,
        rngs: Sequence[np.random.Generator],
        n_normal: int,
        n_uniform: int,
        block: int = 512,
        buffered: int = 128,
    ) -> None:
        self._rngs = list(rngs)
        self._shape = (n_normal, n_uniform)
        self._block = block if n_normal and n_uniform else buffered
        self._i = self._block
        self._normal = np.empty((self._block, len(self._rngs), n_normal))
        self._uniform = np.empty((self._block, len(self._rngs), n_uniform))

    def draw(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Next (normals (N, n_normal), uniforms (N, n_uniform))."""
        if self._i == self._block:
            n_normal, n_uniform = self._shape
            for j, rng in enumerate(self._rngs):  # once per block, not per sample
                self._normal[:, j] = rng.standard_normal((self._block, n_normal))
                self._uniform[:, j] = rng.random((self._block, n_uniform))
            self._i = 0
        i = self._i
        self._i += 1
        return self._normal[i], self._uniform[i]


class FluorometerParams(BaseModel):
    """Concentration sensor settings (TRO: 9 Hz; AB eqs. 1–2 filter and threshold)."""

    model_config = ConfigDict(frozen=True, extra="forbid", allow_inf_nan=False)

    rate_hz: float = Field(default=9.0, gt=0.0, description="Sample rate, Hz.")
    alpha_per_s: float | None = Field(
        default=None,
        gt=0.0,
        description="AB low-pass bandwidth alpha, 1/s; None = raw concentration.",
    )
    tau: float = Field(
        default=0.0, ge=0.0, description="Output threshold: c = rho if rho > tau else 0."
    )
    noise_std: float = Field(default=0.0, ge=0.0, description="Additive Gaussian noise std.")
    dropout_prob: float = Field(default=0.0, ge=0.0, le=1.0, description="Chance a sample is NaN.")
    stuck_prob: float = Field(
        default=0.0, ge=0.0, le=1.0, description="Chance per sample that the output freezes."
    )
    stuck_duration_s: float = Field(
        default=5.0, ge=0.0, le=86_400.0,
        description="How long a frozen output lasts, s; at most a day (counted in samples, an "
        "integer that must fit 64 bits)."
    )


class Fluorometer:
    """Filtered, thresholded, noisy concentration samples with optional faults.

    Args:
        params: Sensor settings.
        rngs: One generator per vehicle.
    """

    def __init__(self, params: FluorometerParams, rngs: Sequence[np.random.Generator]) -> None:
        self.params = params
        n = len(rngs)
        self.period_s = 1.0 / params.rate_hz
        self._bank = NoiseBank(rngs, n_normal=1, n_uniform=2)
        self._rho = np.zeros(n)
        self._last = np.zeros(n)
        self._stuck_left = np.zeros(n, dtype=np.int64)
        self._stuck_samples = round(params.stuck_duration_s * params.rate_hz)
        a = params.alpha_per_s
        self._gain = 1.0 if a is None else 1.0 - math.exp(-a * self.period_s)

    def sample(self, true_conc: NDArray[np.float64]) -> NDArray[np.float64]:
        """One sample per vehicle from the true concentration at the sensors (N,) → (N,).

        The filter is advanced by one sample period with the input held (exact for a
        piecewise-constant input).
        """
        p = self.params
        normal, uniform = self._bank.draw()
        self._rho += self._gain * (true_conc - self._rho)
        meas = self._rho + p.noise_std * normal[:, 0] if p.noise_std else self._rho.copy()
        out = np.where(meas > p.tau, meas, 0.0)
        if p.stuck_prob > 0.0:
            stuck = self._stuck_left > 0
            out = np.where(stuck, self._last, out)
            self._stuck_left = np.where(stuck, self._stuck_left - 1, self._stuck_left)
            start = ~stuck & (uniform[:, 1] < p.stuck_prob)
            self._stuck_left = np.where(start, self._stuck_samples, self._stuck_left)
            self._last = out
        if p.dropout_prob > 0.0:
            out = np.where(uniform[:, 0] < p.dropout_prob, np.nan, out)
        return out


class ADCPParams(BaseModel):
    """Flow sensor settings (TRO: 0.5 Hz, flow relative to earth; AB §5: direction error φ)."""

    model_config = ConfigDict(frozen=True, extra="forbid", allow_inf_nan=False)

    rate_hz: float = Field(default=0.5, gt=0.0, description="Sample rate, Hz.")
    noise_std_mps: float = Field(
        default=0.02, ge=0.0, description="Gaussian noise std per axis, m/s."
    )
    direction_error_std_deg: float = Field(
        default=0.0,
        ge=0.0,
        description="Std of the direction error phi (white normal, held between redraws), deg "
        "(AB §5; AB gives no size); 0 = off.",
    )
    direction_error_period_s: float = Field(
        default=1.0, gt=0.0, le=86_400.0,
        description="phi is redrawn this often, s (AB §5: at 1 Hz); at most a day (counted in "
        "samples)."
    )


class ADCP:
    """Earth-relative flow at each vehicle plus Gaussian noise and a held direction error.

    The direction error (AB §5: "additive noise phi that is a white normal random process that
    changes value at a 1.0 Hz rate") rotates the measured flow vector by ``phi``; ``phi`` is drawn
    from ``N(0, direction_error_std_deg²)`` on the first sample and every
    ``round(direction_error_period_s * rate_hz)`` samples after. Reading chosen: AB adds phi to
    the measured wind *direction*, so the speed is kept. Its draws come from a child of each
    vehicle's generator, so switching it on does not change the other noise.

    Args:
        params: Sensor settings.
        rngs: One generator per vehicle.
    """

    def __init__(self, params: ADCPParams, rngs: Sequence[np.random.Generator]) -> None:
        self.params = params
        self.period_s = 1.0 / params.rate_hz
        self._bank = NoiseBank(rngs, n_normal=2, n_uniform=0)
        self._phi_bank: NoiseBank | None = None
        if params.direction_error_std_deg > 0.0:
            # Generator.spawn leaves the parent's state alone: the stream above is unchanged.
            self._phi_bank = NoiseBank([g.spawn(1)[0] for g in rngs], n_normal=1, n_uniform=0)
        self._hold = max(1, round(params.direction_error_period_s * params.rate_hz))
        self._count = 0
        self.phi_deg = np.zeros(len(rngs))

    def sample(self, true_flow: NDArray[np.float64]) -> NDArray[np.float64]:
        """Noisy flow (N, 2) from the true flow at the vehicles (N, 2)."""
        normal, _ = self._bank.draw()
        out = true_flow + self.params.noise_std_mps * normal
        if self._phi_bank is not None:
            if self._count % self._hold == 0:
                self.phi_deg = self.params.direction_error_std_deg * self._phi_bank.draw()[0][:, 0]
            self._count += 1
            c = np.cos(np.radians(self.phi_deg))
            s = np.sin(np.radians(self.phi_deg))
            out = np.column_stack(
                [c * out[:, 0] - s * out[:, 1], s * out[:, 0] + c * out[:, 1]]
            )
        return out


class NavigationParams(BaseModel):
    """Position estimate settings: slow dead-reckoning drift reset by LBL fixes (TRO V)."""

    model_config = ConfigDict(frozen=True, extra="forbid", allow_inf_nan=False)

    drift_std_m: float = Field(
        default=3.0, ge=0.0, description="Stationary std of the drift, per axis, m."
    )
    drift_tau_s: float = Field(
        default=300.0, gt=0.0, description="Correlation time of the drift, s."
    )
    fix_rate_per_s: float = Field(
        default=1.0 / 120.0, ge=0.0, description="Mean rate of LBL fixes (Poisson), 1/s."
    )
    fix_std_m: float = Field(
        default=0.5, ge=0.0, description="Error just after a fix, per axis, m."
    )
    heading_noise_std_deg: float = Field(
        default=0.0, ge=0.0, le=360.0, description="Noise of the heading the planner is told, "
        "deg (at most 360: a wider spread is no less uniform, and 1.7e308 overflowed to a NaN "
        "heading, an attacker's). The "
        "vehicle steers to a commanded heading by its true heading (its autopilot's compass is "
        "not modelled), so behaviours that command absolute headings, as the papers' do, fly "
        "the same; only what reads the pose's heading sees it."
    )


class Navigation:
    """Estimated position = true position + error; the error drifts and jumps at LBL fixes.

    The error is a first-order Gauss–Markov process (std ``drift_std_m``, time constant
    ``drift_tau_s``). At Poisson fix times it is reset to ``N(0, fix_std_m²)``, so the estimate
    jumps by about the accumulated drift — the discontinuities TRO Figs. 11–12 show.

    Error-free navigation (no drift, no fixes, no heading noise: AB's setup) draws nothing: its
    noise would be multiplied by zero, and its stream (this sensor's own generator) feeds
    nothing else, so the estimate is the truth plus an error that stays exactly 0.0 as before,
    without the 24 MB bank (1,000 vehicles) and its draws (issue 15). The numbers are the same
    bit for bit; the one value it could change is the sign of an estimated heading of -0.0
    (which took the sign of the unused draw), and the vehicle model never outputs -0.0
    (``wrap_deg`` returns ``180 - m``).

    Args:
        params: Navigation settings.
        rngs: One generator per vehicle.
    """

    def __init__(self, params: NavigationParams, rngs: Sequence[np.random.Generator]) -> None:
        self.params = params
        n = len(rngs)
        exact = (params.drift_std_m == 0.0 and params.fix_rate_per_s == 0.0
                 and params.heading_noise_std_deg == 0.0)
        self._bank = None if exact else NoiseBank(rngs, n_normal=5, n_uniform=1)
        self.error = np.zeros((n, 2))
        self.fixes = 0

    def step(
        self, dt: float, true_xy: NDArray[np.float64], true_heading_deg: NDArray[np.float64]
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Advance the error by ``dt``; return (estimated xy (N, 2), estimated heading (N,))."""
        if self._bank is None:
            return true_xy + self.error, true_heading_deg.copy()
        p = self.params
        normal, uniform = self._bank.draw()
        phi = math.exp(-dt / p.drift_tau_s)
        self.error = phi * self.error + p.drift_std_m * math.sqrt(1 - phi**2) * normal[:, 0:2]
        fix = uniform[:, 0] < 1.0 - math.exp(-p.fix_rate_per_s * dt)
        if fix.any():
            self.error = np.where(fix[:, None], p.fix_std_m * normal[:, 2:4], self.error)
            self.fixes += int(np.count_nonzero(fix))
        # in (-180, 180] as the vehicle's own: 179.9 plus noise had read 180.3
        heading = wrap_deg(true_heading_deg + p.heading_noise_std_deg * normal[:, 4])
        return true_xy + self.error, heading
