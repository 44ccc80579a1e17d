"""The simulated world: flow, plume, vehicles and sensors stepped together.

The world knows nothing of the planner. An application layer loops::

    out = world.step()            # sensor samples due this step
    ...feed the planner...
    world.set_commands(heading_deg, speed_mps)

Random streams: the environment (flow + plume) draws from one generator; each vehicle's sensors
draw from that vehicle's own generator (split into fluorometer / ADCP / navigation children), so
vehicle i's noise is the same whether it is alone or one of a hundred. The plume is sampled at the
true positions; the planner sees the navigation estimate.

The flow and plume are stepped every ``plume_dt_s`` (rounded to a whole number of vehicle steps):
puffs move ``U·plume_dt`` per plume step, small against the puff spacing and radius for the
presets (ocean: 0.1 m per 1 s step; AB: 0.05 m per 0.05 s step), and the vehicle steps and
sensor samples happen at ``dt_s`` in between.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray
from pydantic import BaseModel, ConfigDict, Field, model_validator

from . import kernels
from .flow import MIN_SUBSTEP_S, Domain, FlowParams, flow_substep_s, make_flow
from .plume import PlumeParams, PuffPlume
from .sensors import (
    ADCP,
    ADCPParams,
    Fluorometer,
    FluorometerParams,
    Navigation,
    NavigationParams,
)
from .vehicle import VehicleParams, Vehicles

EnvPreset = Literal["tro_ocean", "ab_small_meander", "ab_large_meander"]

log = logging.getLogger(__name__)

MIN_DT_S = 0.005
"""Shortest vehicle step, s (see ``EnvironmentParams.dt_s``)."""

MAX_WARM_UP_S = 86_400.0
"""Longest spin-up a mission may ask for, s (see ``EnvironmentParams.warm_up_s``)."""

MAX_EXTRA_SOURCES = 20
"""Most extra sources a world may have (see ``EnvironmentParams.extra_sources_xy_m``)."""

MAX_PLUME_DT_S = 60.0
"""Longest flow and plume step, s (the presets: 1 s and 0.05 s)."""

MAX_WARM_UP_STEP_S = 600.0
"""Longest spin-up step, s (the warm-up tests use 10 s and 0.5 s)."""

DEFAULT_WARM_UP_CAP_S = 7_200.0
"""Longest *default* spin-up, s: the domain crossing time grows without bound as the mean flow
slows (a still sea: 10^6 s at the 1 mm/s floor); two hours is past every shipped mission's
crossing time (the longest, MSN010's, 5,386 s) and spins a slow plume up as far as the time a
mission flies in it."""


class EnvironmentParams(BaseModel):
    """Everything the simulator needs: the ``environment:`` section of a mission file.

    Defaults are the TRO ocean setup (MSN007r2): a 254 × 112 m OpArea with x along its long axis
    (compass 133°), the source at N 43 m, E -55 m → (-70, 6) in the planning frame, and a
    ~0.1 m/s flow toward compass ~135° → +2° in the planning frame.
    """

    model_config = ConfigDict(frozen=True, extra="forbid", allow_inf_nan=False)

    area_m: tuple[float, float, float, float] = Field(
        default=(-127.0, 127.0, -56.0, 56.0),
        description="Area of interest (xmin, xmax, ymin, ymax), m.",
    )
    source_xy_m: tuple[float, float] = (-70.0, 6.0)
    extra_sources_xy_m: tuple[tuple[float, float], ...] = Field(
        default=(),
        max_length=MAX_EXTRA_SOURCES,
        description="More sources (x, y), m, each with a plume of its own in the same flow; "
        f"the concentration is the sum of the plumes. At most {MAX_EXTRA_SOURCES}: each plume "
        "allocates its puffs and is stepped and summed on every sample.",
    )
    flow: FlowParams = FlowParams(preset="ocean")
    plume: PlumeParams = PlumeParams(preset="ocean")
    vehicle: VehicleParams = VehicleParams()
    fluorometer: FluorometerParams = FluorometerParams()
    adcp: ADCPParams = ADCPParams()
    navigation: NavigationParams = NavigationParams()
    dt_s: float = Field(
        default=1.0 / 9.0, ge=MIN_DT_S,
        description=f"Vehicle step, s; at least {MIN_DT_S} s (200 Hz, ten times AB's 20 Hz "
        "sampling): every step moves every vehicle and samples its sensors, so a 1800 s run of "
        "1e-6 s steps would be 1.8e9 steps (days of computing).",
    )
    plume_dt_s: float = Field(
        default=1.0, gt=0.0, le=MAX_PLUME_DT_S,
        description=f"Flow and plume step, s (≥ dt_s); at most {MAX_PLUME_DT_S:g} s: a step's "
        "puff releases are drawn at once, and puffs move U·plume_dt_s per step.",
    )
    warm_up_s: float | None = Field(
        default=None,
        ge=0.0,
        le=MAX_WARM_UP_S,
        description=f"Plume spin-up before t = 0, s; None = time for the mean flow to cross the "
        f"domain, at most {DEFAULT_WARM_UP_CAP_S:g} s. At most {MAX_WARM_UP_S:g} s (a day): a "
        "puff released earlier has long left any domain, and a spin-up of 1e8 s would run for "
        "hours before the mission starts.",
    )
    warm_up_step_s: float | None = Field(
        default=None,
        gt=0.0,
        le=MAX_WARM_UP_STEP_S,
        description=(
            "Flow and plume step during the spin-up, s; None = the plume step. A longer step "
            "spins the plume up in fewer steps with the same statistics (another realisation). "
            f"At most {MAX_WARM_UP_STEP_S:g} s: a step's puff releases are drawn at once."
        ),
    )
    seed: int | None = Field(
        default=0, ge=0, description="Seed for all streams when none are passed in."
    )

    @model_validator(mode="after")
    def _check(self) -> EnvironmentParams:
        xmin, xmax, ymin, ymax = self.area_m
        if not (xmin < xmax and ymin < ymax):
            raise ValueError(f"area_m must be (xmin, xmax, ymin, ymax), got {self.area_m}")
        if self.plume_dt_s < self.dt_s:
            raise ValueError("plume_dt_s must be at least dt_s")
        if self.dt_s > 1.0 / self.fluorometer.rate_hz + 1e-12:
            raise ValueError(
                f"the simulator's step dt_s ({self.dt_s:g} s) must not exceed the fluorometer's "
                f"sample period 1/rate_hz ({1.0 / self.fluorometer.rate_hz:g} s): set dt_s to "
                "at most that, or lower fluorometer.rate_hz")
        substep = flow_substep_s(self.flow, self.area_m)
        if substep is not None and substep < MIN_SUBSTEP_S:
            raise ValueError(
                f"the flow model would step every {substep:.3g} s (at least {MIN_SUBSTEP_S:g} s "
                "is needed to finish in reasonable time): its grid is too fine for its speed, "
                "noise and diffusivity; lower flow.diffusivity_m2ps or the flow speeds, or "
                "coarsen the grid (flow.grid_n)")
        return self

    @classmethod
    def preset(cls, name: EnvPreset, **overrides: Any) -> EnvironmentParams:
        """Named setups: ``"tro_ocean"`` (the defaults) or AB's 100 × 100 m meander setups.

        AB: area x 0–100, y -50–50 m, source (20, 0), flow 1 m/s toward +x, first-order heading
        with a = 5, 20 Hz sampling; the speed is set by the planner's command. The plume is the
        filament preset ``"ab"`` (3 filaments/s, Farrell 2002 sizes; see ``sim.plume``); the
        flow has Farrell 2002's second-order boundary noise. The flow sensor reads the
        *instantaneous local* flow with a direction error phi redrawn at 1 Hz (AB §5); AB gives
        no size for phi: 10° is chosen, the spread AB's §4.2 study uses (uniform in ±10°).
        The AB sensor filter (eqs. 1–2) is off (``fluorometer.alpha_per_s``: AB gives no
        alpha).
        """
        if name == "tro_ocean":
            base: dict[str, Any] = {}
        else:
            base = dict(
                area_m=(0.0, 100.0, -50.0, 50.0),
                source_xy_m=(20.0, 0.0),
                flow=FlowParams(preset=name.removeprefix("ab_")),  # type: ignore[arg-type]
                plume=PlumeParams(preset="ab"),
                vehicle=VehicleParams(
                    heading_mode="first_order",
                    initial_speed_mps=1.0,
                    min_speed_mps=0.0,
                    max_speed_mps=5.0,
                    advected=False,
                ),
                fluorometer=FluorometerParams(rate_hz=20.0),
                adcp=ADCPParams(rate_hz=20.0, noise_std_mps=0.0, direction_error_std_deg=10.0),
                navigation=NavigationParams(drift_std_m=0.0, fix_rate_per_s=0.0, fix_std_m=0.0),
                dt_s=0.05,
                plume_dt_s=0.05,
            )
        return cls.model_validate({**base, **overrides})


@dataclass(frozen=True)
class StepOutput:
    """What the vehicles' sensors report at the end of one step.

    Attributes:
        t_s: Mission time at the end of the step, s.
        fluorometer: Concentration samples (N,) if a sample was due, else None.
        adcp_flow: Earth-relative flow (N, 2) if a sample was due, else None.
        nav_xy: Estimated positions (N, 2) (what the planner sees).
        nav_heading_deg: Estimated headings (N,).
        true_xy: True positions (N, 2) (for metrics, not for the planner).
        true_heading_deg: True headings (N,).
    """

    t_s: float
    fluorometer: NDArray[np.float64] | None
    adcp_flow: NDArray[np.float64] | None
    nav_xy: NDArray[np.float64]
    nav_heading_deg: NDArray[np.float64]
    true_xy: NDArray[np.float64]
    true_heading_deg: NDArray[np.float64]


class _Schedule:
    """Sample instants k·period on the step grid: due when the step's end passes one."""

    def __init__(self, period_s: float) -> None:
        self.period_s = period_s
        self.next_k = 1

    def due(self, t_s: float) -> bool:
        if t_s + 1e-9 >= self.next_k * self.period_s:
            self.next_k = math.floor((t_s + 1e-9) / self.period_s) + 1
            return True
        return False


def vehicle_rngs_from_seed(seed: int | None, n: int) -> list[np.random.Generator]:
    """Per-vehicle generators; vehicle i's is the same for any ``n``."""
    root = np.random.SeedSequence(seed).spawn(2)[1]
    return [np.random.default_rng(s) for s in root.spawn(n)]


def env_rng_from_seed(seed: int | None) -> np.random.Generator:
    """The environment generator derived from ``seed``."""
    return np.random.default_rng(np.random.SeedSequence(seed).spawn(2)[0])


_CAP_WARNED: set[tuple[float, float]] = set()
"""(mean flow, domain diagonal) pairs whose capped spin-up this process has warned about."""


class World:
    """Flow, plume, N vehicles and their sensors.

    Args:
        params: Environment settings.
        xy: Initial true vehicle positions (N, 2), m.
        heading_deg: Initial headings (N,) or a scalar, degrees.
        env_rng: Generator for flow and plume; from ``params.seed`` if None.
        vehicle_rngs: One generator per vehicle; from ``params.seed`` if None.
    """

    def __init__(
        self,
        params: EnvironmentParams,
        xy: NDArray[np.float64],
        heading_deg: NDArray[np.float64] | float = 0.0,
        env_rng: np.random.Generator | None = None,
        vehicle_rngs: Sequence[np.random.Generator] | None = None,
    ) -> None:
        kernels.say_cache_note()  # here, where a command's logging is set up
        self.params = params
        xy = np.asarray(xy, dtype=float).reshape(-1, 2)
        n = len(xy)
        env_rng = env_rng if env_rng is not None else env_rng_from_seed(params.seed)
        if vehicle_rngs is None:
            vehicle_rngs = vehicle_rngs_from_seed(params.seed, n)
        if len(vehicle_rngs) != n:
            raise ValueError(f"{len(vehicle_rngs)} vehicle generators for {n} vehicles")
        per_sensor = [g.spawn(3) for g in vehicle_rngs]  # loop at construction only
        self.flow = make_flow(params.flow, params.area_m, env_rng)
        self.plume = PuffPlume(params.plume, params.source_xy_m, self.flow, env_rng)
        # More sources draw from the same environment stream after the first plume, so a
        # single-source world is unchanged by their existence in the model.
        self.extra_plumes = [
            PuffPlume(params.plume, xy, self.flow, env_rng) for xy in params.extra_sources_xy_m
        ]
        heading = np.broadcast_to(np.asarray(heading_deg, dtype=float), (n,))
        self.vehicles = Vehicles(params.vehicle, xy, heading)
        self.fluorometer = Fluorometer(params.fluorometer, [s[0] for s in per_sensor])
        self.adcp = ADCP(params.adcp, [s[1] for s in per_sensor])
        self.navigation = Navigation(params.navigation, [s[2] for s in per_sensor])
        self._cmd_heading = self.vehicles.heading_deg.copy()
        self._cmd_speed = self.vehicles.speed_mps.copy()
        self._plume_stride = max(1, round(params.plume_dt_s / params.dt_s))
        self._current = self.flow.velocity_at(self.vehicles.xy)
        self._fluor_sched = _Schedule(self.fluorometer.period_s)
        self._adcp_sched = _Schedule(self.adcp.period_s)
        self.steps = 0

    @property
    def n(self) -> int:
        """Number of vehicles."""
        return self.vehicles.n

    @property
    def t_s(self) -> float:
        """Mission time, s (0 after warm-up)."""
        return self.steps * self.params.dt_s

    @property
    def domain(self) -> Domain:
        """Region simulated by the flow and plume (the area plus the flow margin)."""
        return self.flow.domain

    def default_warm_up_s(self) -> float:
        """Time for the mean flow to carry a puff across the simulated domain, at most
        :data:`DEFAULT_WARM_UP_CAP_S` (a slow or still mean flow is logged when capped)."""
        xmin, xmax, ymin, ymax = self.domain
        mean = float(np.hypot(*self.flow.mean_velocity))
        diagonal = math.hypot(xmax - xmin, ymax - ymin)
        crossing = diagonal / max(mean, 1e-3)
        if crossing <= DEFAULT_WARM_UP_CAP_S:
            return crossing
        if (mean, diagonal) not in _CAP_WARNED:  # once per setting and process, not per group
            _CAP_WARNED.add((mean, diagonal))
            took = f"would take {crossing:,.0f} s to cross" if mean >= 1e-3 else "never crosses"
            log.warning("plume spin-up capped at %g s: a mean flow of %.3g m/s %s the "
                        "%.0f m domain (set environment.warm_up_s to choose)",
                        DEFAULT_WARM_UP_CAP_S, mean, took, diagonal)
        return DEFAULT_WARM_UP_CAP_S

    def warm_up(self, seconds: float | None = None) -> None:
        """Spin the flow and plume up (vehicles and sensors frozen, mission time unchanged).

        The spin-up steps by ``params.warm_up_step_s`` if set (the puffs' Euler step and the
        release are step-size independent in distribution; ``tests/sim/test_sim_warm_up.py``
        compares such a plume with a long fine-stepped spin-up), else by the plume step.

        Args:
            seconds: Spin-up time; ``params.warm_up_s`` or ``default_warm_up_s()`` if None.
        """
        if seconds is None:
            seconds = self.params.warm_up_s
        if seconds is None:
            seconds = self.default_warm_up_s()
        h = self._plume_stride * self.params.dt_s
        if self.params.warm_up_step_s is not None:
            h = max(h, self.params.warm_up_step_s)
        for _ in range(math.ceil(seconds / h)):
            self.flow.step(h)
            self.plume.step(h)
            for plume in self.extra_plumes:
                plume.step(h)

    def set_commands(
        self, heading_deg: NDArray[np.float64], speed_mps: NDArray[np.float64]
    ) -> None:
        """Commanded heading (N,) and speed (N,), held until changed; NaN = hold present value."""
        # Assignment into fresh arrays broadcasts (and refuses a wrong length) like
        # np.broadcast_to(...).copy(), at a fifth of its cost: this runs every step.
        self._cmd_heading = np.empty(self.n)
        self._cmd_heading[:] = heading_deg
        self._cmd_speed = np.empty(self.n)
        self._cmd_speed[:] = speed_mps

    def concentration_at(self, xy: NDArray[np.float64]) -> NDArray[np.float64]:
        """True instantaneous concentration at points (M, 2) (for plots and metrics)."""
        return self._concentration(xy)

    def _concentration(self, xy: NDArray[np.float64]) -> NDArray[np.float64]:
        """The sum of every source's plume at points (M, 2)."""
        out = self.plume.concentration(xy)
        for plume in self.extra_plumes:
            out = out + plume.concentration(xy)
        return out

    @property
    def sources_xy_m(self) -> list[tuple[float, float]]:
        """Every true source (x, y), the first one first."""
        return [self.params.source_xy_m, *self.params.extra_sources_xy_m]

    def step(self) -> StepOutput:
        """Advance everything by ``dt_s`` and return the samples due at the end of the step."""
        dt = self.params.dt_s
        veh = self.vehicles
        if self.steps % self._plume_stride == 0:
            h = self._plume_stride * dt
            self.flow.step(h)
            self.plume.step(h)
            for plume in self.extra_plumes:
                plume.step(h)
            # The current is looked up once per plume step: the flow changes no faster, and the
            # vehicle moves ≤ 2.8 m per 1 s step against a flow grid of ~20 m.
            self._current = self.flow.velocity_at(veh.xy)
            if not self.params.vehicle.advected:
                self._current = np.zeros_like(self._current)
        veh.step(dt, self._cmd_heading, self._cmd_speed, self._current)
        self.steps += 1
        t = self.t_s
        fluor = None
        if self._fluor_sched.due(t):
            fluor = self.fluorometer.sample(self._concentration(veh.xy))
        adcp = None
        if self._adcp_sched.due(t):
            adcp = self.adcp.sample(self.flow.velocity_at(veh.xy))
        nav_xy, nav_heading = self.navigation.step(dt, veh.xy, veh.heading_deg)
        return StepOutput(
            t_s=t,
            fluorometer=fluor,
            adcp_flow=adcp,
            nav_xy=nav_xy,
            nav_heading_deg=nav_heading,
            true_xy=veh.xy.copy(),
            true_heading_deg=veh.heading_deg.copy(),
        )
