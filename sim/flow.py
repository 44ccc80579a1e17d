"""Flow fields in the planning frame: a uniform flow and the meandering flow of Farrell et al. 2002.

The meandering flow follows the approach of Farrell, Murlis, Long, Li and Cardé (2002), cited by
AB §2.2: the velocity (u, v) lives on a coarse regular grid and obeys an advection–diffusion
(K-closure) equation,

    du/dt = -(u du/dx + v du/dy) + K (d2u/dx2 + d2u/dy2)     (and the same for v),

whose Dirichlet boundary values are the mean flow plus coloured noise, one process per grid corner
and component, interpolated linearly along the edges. The noise is either first order (a
Gauss–Markov / Ornstein–Uhlenbeck process with correlation time ``T``) or, as in Farrell et al.
2002, second order: white noise through ``x'' + 2ζω x' + ω² x = drive``, with bandwidth
``ω = 1/T`` and damping ``ζ`` (Farrell 2002 and pompy: ζ = 0.1, ω = 0.2 rad/s), whose spectrum
peaks near ``ω`` when lightly damped, so the flow swings back and forth with a period of about
``2πT`` instead of wandering; the drive is scaled so the stationary std is ``noise_std_mps``.
The AB meander presets use the second-order form. Optionally a spatially uniform coloured-noise
velocity is added everywhere (``common_noise_std_mps``): large-scale (e.g. tidal) changes that
reach the whole area at once, which the slow advective response of the grid cannot produce at
ocean speeds.

Advection uses first-order upwind differences so the explicit scheme is stable for any cell
Péclet number; the step is sub-divided to respect the CFL/diffusion limit.

Angles are in degrees from +x toward +y; ``toward`` is where the water goes.
"""

from __future__ import annotations

import math
from typing import Any, Literal, Protocol

import numpy as np
from numpy.typing import NDArray
from pydantic import BaseModel, ConfigDict, Field, model_validator

from . import kernels

Domain = tuple[float, float, float, float]
FlowPreset = Literal["uniform", "small_meander", "large_meander", "ocean"]

# Calibrated (tests/sim/test_sim_flow.py): with Farrell 2002's second-order boundary noise
# (ζ = 0.1) the 90th percentile of the plume centreline deviation 100 m downflow (tracer puffs,
# 12 seeds × 800 s) is ~7 m (small: period ~50 s) and ~21 m (large: period ~250 s) at 1 m/s,
# AB §2.3's "normally < 10 m" and "< 25 m"; the ocean preset's flow direction wanders by ~10–30°
# over ten minutes at 0.1 m/s (TRO Table II, MSN007r2: 124°–146°, 0.08–0.12 m/s).
_PRESETS: dict[str, dict[str, Any]] = {
    "uniform": dict(
        mean_speed_mps=1.0,
        mean_dir_deg=0.0,
        noise_std_mps=0.0,
        noise_corr_time_s=10.0,
        diffusivity_m2ps=1.0,
        grid_n=11,
        margin_m=20.0,
        common_noise_std_mps=0.0,
    ),
    "small_meander": dict(
        mean_speed_mps=1.0,
        mean_dir_deg=0.0,
        noise_std_mps=0.3,
        noise_corr_time_s=8.0,
        noise_order=2,
        noise_damping=0.1,
        diffusivity_m2ps=5.0,
        grid_n=21,
        margin_m=20.0,
        common_noise_std_mps=0.0,
    ),
    "large_meander": dict(
        mean_speed_mps=1.0,
        mean_dir_deg=0.0,
        noise_std_mps=0.25,
        noise_corr_time_s=40.0,
        noise_order=2,
        noise_damping=0.1,
        diffusivity_m2ps=5.0,
        grid_n=21,
        margin_m=20.0,
        common_noise_std_mps=0.0,
    ),
    "ocean": dict(
        mean_speed_mps=0.1,
        mean_dir_deg=2.0,
        noise_std_mps=0.03,
        noise_corr_time_s=300.0,
        diffusivity_m2ps=2.0,
        grid_n=15,
        margin_m=40.0,
        common_noise_std_mps=0.015,
        common_corr_time_s=300.0,
    ),
}


MAX_FLOW_SPEED_MPS = 10.0
"""Fastest mean flow (and noise std) a mission may set, m/s."""

MIN_SUBSTEP_S = 0.01
"""Shortest internal PDE step of a meandering flow, s: the step the grid's stability needs
shrinks with the flow's speed and diffusivity and with the grid spacing, and below this a run
would take hours (a 1e300 m/s current needed steps of 1e-300 s and hung)."""


class FlowParams(BaseModel):
    """Flow-model settings; unset fields take the values of ``preset`` (defaults: ``"ocean"``).

    ``FlowParams(preset="large_meander", noise_std_mps=0.4)`` is the large-meander preset with a
    stronger boundary noise.
    """

    model_config = ConfigDict(frozen=True, extra="forbid", allow_inf_nan=False)

    preset: FlowPreset = "ocean"
    mean_speed_mps: float = Field(
        default=0.1, ge=0.0, le=MAX_FLOW_SPEED_MPS,
        description=f"Mean flow speed, m/s; at most {MAX_FLOW_SPEED_MPS:g} (the fastest tidal "
        "races run at about 5 m/s; AB: 1 m/s): the flow grid's step shrinks as the speed grows.",
    )
    mean_dir_deg: float = Field(
        default=2.0, ge=-360.0, le=360.0,
        description="Mean direction the water moves toward, deg from +x."
    )
    noise_std_mps: float = Field(
        default=0.03,
        ge=0.0,
        le=MAX_FLOW_SPEED_MPS,
        description="Stationary std of each boundary-corner velocity component, m/s (at most "
        "the fastest mean flow).",
    )
    noise_corr_time_s: float = Field(
        default=300.0,
        gt=0.0,
        description="Correlation time T of that noise, s (order 2: 1/bandwidth, 1/ω).",
    )
    noise_order: Literal[1, 2] = Field(
        default=1,
        description="Boundary noise: 1 = first-order Gauss–Markov; 2 = second-order "
        "(Farrell 2002).",
    )
    noise_damping: float = Field(
        default=0.1, gt=0.0, description="Damping ratio ζ of the second-order noise."
    )
    diffusivity_m2ps: float = Field(
        default=2.0, gt=0.0, description="Eddy diffusivity K of the velocity, m²/s."
    )
    grid_n: int = Field(
        default=15, ge=3, le=101, description="Grid nodes along the domain's longer side."
    )
    margin_m: float = Field(
        default=40.0, ge=0.0, description="Grid extends this far beyond the area, m."
    )
    common_noise_std_mps: float = Field(
        default=0.015,
        ge=0.0,
        le=MAX_FLOW_SPEED_MPS,
        description="Std of a spatially uniform noise velocity per axis, m/s (at most the "
        "fastest mean flow).",
    )
    common_corr_time_s: float = Field(
        default=300.0, gt=0.0, description="Correlation time of the uniform noise velocity, s."
    )
    max_substep_s: float = Field(
        default=1.0, ge=MIN_SUBSTEP_S,
        description=f"Longest internal PDE step, s; at least {MIN_SUBSTEP_S:g} (a shorter step "
        "makes a run take hours).",
    )

    @model_validator(mode="before")
    @classmethod
    def _fill_from_preset(cls, data: Any) -> Any:
        if isinstance(data, dict):
            preset = data.get("preset", "ocean")
            if isinstance(preset, str) and preset in _PRESETS:
                return {**_PRESETS[preset], **data}
        return data


class FlowField(Protocol):
    """What the plume, the vehicles and the world need from a flow."""

    @property
    def domain(self) -> Domain: ...

    @property
    def mean_velocity(self) -> NDArray[np.float64]: ...

    def step(self, dt: float) -> None: ...

    def velocity_at(self, xy: NDArray[np.float64]) -> NDArray[np.float64]: ...


def unit(deg: float) -> NDArray[np.float64]:
    """Unit vector (cos θ, sin θ) of a planning-frame angle in degrees."""
    rad = math.radians(deg)
    return np.array([math.cos(rad), math.sin(rad)])


class UniformFlow:
    """Constant, spatially uniform flow (for tests and calm-water setups).

    Args:
        speed_mps: Flow speed, m/s.
        toward_deg: Direction the water moves toward, degrees from +x toward +y.
        domain: Region (xmin, xmax, ymin, ymax) the flow is defined on; unbounded if None.
    """

    def __init__(self, speed_mps: float, toward_deg: float, domain: Domain | None = None) -> None:
        self._vel = speed_mps * unit(toward_deg)
        inf = math.inf
        self._domain: Domain = domain if domain is not None else (-inf, inf, -inf, inf)
        self.time_s = 0.0

    @property
    def domain(self) -> Domain:
        """The region (xmin, xmax, ymin, ymax) covered."""
        return self._domain

    @property
    def mean_velocity(self) -> NDArray[np.float64]:
        """Mean (u, v) in m/s."""
        return self._vel.copy()

    def step(self, dt: float) -> None:
        """Advance time; the field does not change."""
        self.time_s += dt

    def velocity_at(self, xy: NDArray[np.float64]) -> NDArray[np.float64]:
        """Velocity at points ``xy`` (N, 2) → (N, 2)."""
        return np.broadcast_to(self._vel, np.shape(xy)).copy()


class MeanderingFlow:
    """Spatially and temporally varying flow driven by coloured boundary noise (Farrell 2002).

    Args:
        params: Flow settings.
        domain: Grid region (xmin, xmax, ymin, ymax), already including any margin.
        rng: Generator for the boundary noise (the environment stream).
    """

    def __init__(self, params: FlowParams, domain: Domain, rng: np.random.Generator) -> None:
        self.params = params
        self._domain = domain
        self._rng = rng
        xmin, xmax, ymin, ymax = domain
        if xmax - xmin <= 0 or ymax - ymin <= 0:
            raise ValueError(f"empty flow domain {domain}")
        self.nx, self.ny, self.dx, self.dy = _grid(params, domain)
        self.xs = np.linspace(xmin, xmax, self.nx)
        self.ys = np.linspace(ymin, ymax, self.ny)
        self._mean = params.mean_speed_mps * unit(params.mean_dir_deg)
        # Fields indexed [iy, ix]; both components stacked: shape (2, ny, nx).
        self._f = np.empty((2, self.ny, self.nx))
        self._f[0] = self._mean[0]
        self._f[1] = self._mean[1]
        # Corner noise state (2 components × 4 corners: (x0,y0), (x1,y0), (x0,y1), (x1,y1)),
        # started in its stationary distribution so no spin-up of the noise itself is needed.
        sigma = params.noise_std_mps
        self._noise = sigma * rng.standard_normal((2, 4))
        self.substep_s = _substep_s(params, self.dx, self.dy)
        h = self.substep_s
        self._order2: _SecondOrderNoise | None = None
        if params.noise_order == 2:
            self._order2 = _SecondOrderNoise(
                sigma, 1.0 / params.noise_corr_time_s, params.noise_damping, h, self._noise, rng
            )
        self._phi = math.exp(-h / params.noise_corr_time_s)
        self._kick = sigma * math.sqrt(1.0 - self._phi**2)
        sig_c = params.common_noise_std_mps
        self._common = sig_c * rng.standard_normal(2)
        self._phi_c = math.exp(-self.substep_s / params.common_corr_time_s)
        self._kick_c = sig_c * math.sqrt(1.0 - self._phi_c**2)
        self._rx = np.linspace(0.0, 1.0, self.nx)
        self._ry = np.linspace(0.0, 1.0, self.ny)
        self._pending_s = 0.0
        self.time_s = 0.0
        self._apply_boundary()
        self._flat = self._f.reshape(2, -1)

    @property
    def domain(self) -> Domain:
        """The grid region (xmin, xmax, ymin, ymax)."""
        return self._domain

    @property
    def mean_velocity(self) -> NDArray[np.float64]:
        """Long-run mean (u, v) in m/s (the noise has zero mean)."""
        return self._mean.copy()

    @property
    def grid_velocity(self) -> NDArray[np.float64]:
        """Current grid velocities, shape (2, ny, nx), indexed [component, iy, ix] (a copy)."""
        return self._f + self._common[:, None, None]

    def step(self, dt: float) -> None:
        """Advance the field by ``dt`` seconds in fixed internal sub-steps.

        Time not yet covered by a whole sub-step is carried over to the next call, so the
        result depends only on the total elapsed time, not on how it was sliced.
        """
        self.time_s += dt
        self._pending_s += dt
        h = self.substep_s
        while self._pending_s >= h - 1e-12:
            self._substep(h)
            self._pending_s -= h

    def _apply_boundary(self) -> None:
        c = self._mean[:, None] + self._noise  # (2, 4)
        rx, ry = self._rx, self._ry
        f = self._f
        for comp in range(2):
            c00, c10, c01, c11 = c[comp]
            f[comp, 0, :] = c00 + rx * (c10 - c00)
            f[comp, -1, :] = c01 + rx * (c11 - c01)
            f[comp, :, 0] = c00 + ry * (c01 - c00)
            f[comp, :, -1] = c10 + ry * (c11 - c10)

    def _substep(self, h: float) -> None:
        noise = self._rng.standard_normal(10)
        if self._order2 is not None:
            # The rate's own noise comes after the first-order draws, so order 1 streams are
            # unchanged by this option.
            extra = self._rng.standard_normal(8).reshape(2, 4)
            self._order2.step(self._noise, noise[:8].reshape(2, 4), extra)
        else:
            self._noise *= self._phi
            self._noise += self._kick * noise[:8].reshape(2, 4)
        self._common *= self._phi_c
        self._common += self._kick_c * noise[8:]
        if kernels.EXACT:
            kernels.flow_substep(self, h)
            return
        self._apply_boundary()
        f = self._f
        c = f[:, 1:-1, 1:-1]
        west, east = f[:, 1:-1, :-2], f[:, 1:-1, 2:]
        south, north = f[:, :-2, 1:-1], f[:, 2:, 1:-1]
        u = c[0]
        v = c[1]
        ddx = np.where(u > 0, c - west, east - c) / self.dx
        ddy = np.where(v > 0, c - south, north - c) / self.dy
        lap = (west - 2 * c + east) / self.dx**2 + (south - 2 * c + north) / self.dy**2
        rhs = -u * ddx - v * ddy + self.params.diffusivity_m2ps * lap
        c += h * rhs

    def velocity_at(self, xy: NDArray[np.float64]) -> NDArray[np.float64]:
        """Bilinear interpolation of the grid velocity at points ``xy`` (N, 2) → (N, 2).

        Points outside the grid take the value at the nearest edge.
        """
        if kernels.EXACT:
            return kernels.bilinear(self, xy)
        xy = np.asarray(xy, dtype=float)
        # np.minimum/np.maximum: np.clip's wrapper costs more than the work for a few points.
        fx = np.minimum(np.maximum((xy[:, 0] - self.xs[0]) / self.dx, 0.0), self.nx - 1.000001)
        fy = np.minimum(np.maximum((xy[:, 1] - self.ys[0]) / self.dy, 0.0), self.ny - 1.000001)
        ix = fx.astype(np.intp)
        iy = fy.astype(np.intp)
        wx = fx - ix
        wy = fy - iy
        i00 = iy * self.nx + ix
        flat = self._flat
        a = flat[:, i00]
        b = flat[:, i00 + 1]
        cc = flat[:, i00 + self.nx]
        d = flat[:, i00 + self.nx + 1]
        out = (a * (1 - wx) + b * wx) * (1 - wy) + (cc * (1 - wx) + d * wx) * wy
        return out.T + self._common


class _SecondOrderNoise:
    """Second-order coloured noise ``x'' + 2ζω x' + ω² x = q^½ w`` (Farrell 2002), exact steps.

    The state (x, x') is advanced over a step ``h`` by its exact discrete-time transition
    ``F = exp(A h)`` and a Cholesky factor of the exact step covariance (Van Loan), so the
    process keeps its stationary std ``sigma`` for any step size. ``q = 4 ζ ω³ σ²`` gives
    ``Var(x) = σ²`` (and ``Var(x') = ω² σ²``).

    Args:
        sigma: Stationary std of x.
        omega: Bandwidth ω, rad/s.
        zeta: Damping ratio ζ.
        h: Step, s.
        x: The initial x values (any shape), started from the stationary law; kept in place.
        rng: Generator for the initial x' draw.
    """

    def __init__(
        self,
        sigma: float,
        omega: float,
        zeta: float,
        h: float,
        x: NDArray[np.float64],
        rng: np.random.Generator,
    ) -> None:
        a = np.array([[0.0, 1.0], [-(omega**2), -2.0 * zeta * omega]])
        q = 4.0 * zeta * omega**3 * sigma**2
        self._f = _expm(a * h)
        # Van Loan: the step covariance Q_d = ∫ e^{As} B q Bᵀ e^{Aᵀs} ds over [0, h].
        m = np.zeros((4, 4))
        m[:2, :2] = -a * h
        m[:2, 2:] = np.array([[0.0, 0.0], [0.0, q]]) * h
        m[2:, 2:] = a.T * h
        e = _expm(m)
        qd = e[2:, 2:].T @ e[:2, 2:]
        qd = 0.5 * (qd + qd.T)
        self._chol = np.linalg.cholesky(qd + 1e-18 * np.eye(2))
        self._v = omega * sigma * rng.standard_normal(x.shape)

    def step(
        self, x: NDArray[np.float64], white: NDArray[np.float64], white2: NDArray[np.float64]
    ) -> None:
        """Advance x (in place) and its rate by one step; two standard normals per element."""
        f, c = self._f, self._chol
        x_new = f[0, 0] * x + f[0, 1] * self._v + c[0, 0] * white
        self._v = f[1, 0] * x + f[1, 1] * self._v + c[1, 0] * white + c[1, 1] * white2
        x[...] = x_new


def _expm(m: NDArray[np.float64]) -> NDArray[np.float64]:
    """Matrix exponential by scaling and squaring with a Taylor series (small matrices)."""
    norm = float(np.abs(m).sum(axis=1).max())
    k = max(0, math.ceil(math.log2(norm)) + 1) if norm > 0 else 0
    a = m / 2.0**k
    out = np.eye(len(m))
    term = np.eye(len(m))
    for i in range(1, 20):
        term = term @ a / i
        out = out + term
    for _ in range(k):
        out = out @ out
    return out


def _grid(params: FlowParams, domain: Domain) -> tuple[int, int, float, float]:
    """Nodes (nx, ny) and spacing (dx, dy) of a meandering flow's grid over ``domain``."""
    xmin, xmax, ymin, ymax = domain
    lx, ly = xmax - xmin, ymax - ymin
    step = max(lx, ly) / (params.grid_n - 1)
    nx = max(3, round(lx / step) + 1)
    ny = max(3, round(ly / step) + 1)
    return nx, ny, lx / (nx - 1), ly / (ny - 1)


def _substep_s(params: FlowParams, dx: float, dy: float) -> float:
    """The internal PDE step: ``max_substep_s``, or shorter as the explicit scheme's stability
    (advection at the fastest likely speed, diffusion) needs on a grid of spacing dx, dy."""
    sigma = params.noise_std_mps
    k = params.diffusivity_m2ps
    vmax = params.mean_speed_mps + 4.0 * sigma
    rate = vmax / dx + vmax / dy + 2 * k / dx**2 + 2 * k / dy**2
    return min(params.max_substep_s, 0.8 / rate)


def flow_substep_s(params: FlowParams, area: Domain) -> float | None:
    """The internal step the flow over ``area`` (grown by ``margin_m``) will take, s; None for a
    uniform flow (no noise: no grid, no steps)."""
    if params.noise_std_mps == 0.0 and params.common_noise_std_mps == 0.0:
        return None
    _, _, dx, dy = _grid(params, expand(area, params.margin_m))
    return _substep_s(params, dx, dy)


def expand(area: Domain, margin_m: float) -> Domain:
    """The area (xmin, xmax, ymin, ymax) grown by ``margin_m`` on every side."""
    xmin, xmax, ymin, ymax = area
    return (xmin - margin_m, xmax + margin_m, ymin - margin_m, ymax + margin_m)


def make_flow(
    preset: str | FlowParams,
    domain: Domain,
    rng: np.random.Generator,
    **overrides: Any,
) -> UniformFlow | MeanderingFlow:
    """Build a flow for an area of interest from a preset name or a ``FlowParams``.

    Args:
        preset: ``"uniform"``, ``"small_meander"``, ``"large_meander"``, ``"ocean"`` or params.
        domain: Area of interest (xmin, xmax, ymin, ymax); the flow grid adds ``margin_m``.
        rng: Environment generator driving the boundary noise.
        **overrides: Field values replacing those of the preset.

    Returns:
        A ``UniformFlow`` when both noises are zero, otherwise a ``MeanderingFlow``.
    """
    if isinstance(preset, FlowParams):
        params = preset.model_copy(update=overrides) if overrides else preset
        params = FlowParams.model_validate(params.model_dump())
    else:
        params = FlowParams(preset=preset, **overrides)  # type: ignore[arg-type]
    grid = expand(domain, params.margin_m)
    if params.noise_std_mps == 0.0 and params.common_noise_std_mps == 0.0:
        return UniformFlow(params.mean_speed_mps, params.mean_dir_deg, grid)
    return MeanderingFlow(params, grid, rng)
