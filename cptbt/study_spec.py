"""The ``study:`` section of a mission: a Monte Carlo study as a file, not a command line.

It says where the searches start (a grid over the OpArea, a line of starts along x, or a list of
points in the mission's own frame), how many plume realisations each start gets, what is swept,
the time limit, and how a run begins (``start_mode``). ``cptbt batch MISSION`` reads it; every
command-line flag overrides the matching key.
"""

from __future__ import annotations

from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field, model_validator

Coord = tuple[float, float]

MAX_STARTS = 100_000
"""Most starts a study may have (``cptbt.batch.study.MAX_STARTS``, the command line's bound)."""

MAX_RUNS = 10_000_000
"""Most runs a study may have, starts × replicates × configurations (a review's study within
every other bound, 10^5 starts × 10^6 replicates, took 24 GB before flying a run; 10^7 runs is
some 60 CPU-hours at the fleet planner's pace)."""

MAX_GROUPS = 1_000_000
"""Most groups (configurations × replicates) a study may have: each is a task held in memory
before the study flies (about 0.5 GB at this bound)."""


MAX_CONFIGS = 10_000
"""Most configurations (the product of the sweeps' values) a study may have: each is a mission
made and validated before any run (about 5 ms and 0.2 MB each; an attacker's 90 000 kept
``validate`` busy past two minutes at 800 MB, growing, silent)."""


def configs_note(configs: int) -> str | None:
    """What a reader waiting for many configurations to be checked is told (None: few)."""
    if configs < 1_000:
        return None
    return f"checking {configs:,} configurations (about {configs * 5e-3:.0f} s)"


def configs_problem(configs: int) -> str | None:
    """Why a study with this many configurations is refused (None: it is not)."""
    if configs > MAX_CONFIGS:
        return (f"the sweeps make {configs:,} configurations (the product of their values), "
                f"more than {MAX_CONFIGS:,}: split the study")
    return None


def study_size_problem(starts: int, runs_per_start: int, configs: int) -> str | None:
    """Why a study of this size is refused (None: it is not)."""
    if configs_problem(configs):
        return configs_problem(configs)
    runs, groups = starts * runs_per_start * configs, runs_per_start * configs
    if runs > MAX_RUNS:
        return (f"{starts} starts × {runs_per_start} replicates × {configs} configurations is "
                f"{runs:,} runs, more than {MAX_RUNS:,}: split the study")
    if groups > MAX_GROUPS:
        return (f"{runs_per_start} replicates × {configs} configurations is {groups:,} groups, "
                f"more than {MAX_GROUPS:,}: split the study")
    return None


class LineSpec(BaseModel):
    """Starts along the planning x axis at one y (AB Fig. 10: x from 0 to 100 m, y = 0)."""

    model_config = ConfigDict(frozen=True, extra="forbid", allow_inf_nan=False)

    x_from_m: float = Field(description="First start's x, planning frame, m")
    x_to_m: float = Field(description="Last start's x (inclusive), m")
    step_m: float = Field(gt=0, description="Spacing, m")
    y_m: float = Field(default=0.0, description="The line's y, planning frame, m")

    @model_validator(mode="after")
    def _ordered(self) -> LineSpec:
        if self.x_to_m < self.x_from_m:
            raise ValueError("x_to_m must not be less than x_from_m")
        if (self.x_to_m - self.x_from_m) / self.step_m >= MAX_STARTS:
            raise ValueError(f"more than {MAX_STARTS} starts")
        return self


class StudySpec(BaseModel):
    """A Monte Carlo study of the mission (``cptbt batch``); give one of grid, line or starts."""

    model_config = ConfigDict(frozen=True, extra="forbid", allow_inf_nan=False)

    grid: tuple[int, int] | None = Field(
        default=None, description="[nx, ny]: starts at the centres of an nx × ny grid over the "
        "OpArea (AB Fig. 11: [10, 10])"
    )
    line: LineSpec | None = Field(default=None, description="Starts along x at one y")
    starts: list[Coord] | None = Field(
        default=None, min_length=1, max_length=MAX_STARTS,
        description="Start points in the mission's frame (N-E, lat/lon or planning)"
    )
    runs_per_start: int = Field(
        default=1, ge=1, le=1_000_000, description="Plume realisations (replicates) per start"
    )
    sweeps: dict[str, list[Any]] = Field(
        default_factory=dict,
        description="Mission path (joined by '+' to sweep several together) → values, e.g. "
        "'maintain_plume.variant+reacquire_plume.variant': [strategy_1, strategy_3]",
    )
    time_limit_s: float | None = Field(
        default=None, gt=0, le=7 * 86400, description="Per-run limit (default: the mission's)"
    )
    start_mode: Literal["place", "launch"] = Field(
        default="place",
        description="'place': each vehicle starts at its start point (AB's searchers); "
        "'launch': it is launched where the mission launches (environment.launch, else home) and "
        "move-to-field drives it to its start point",
    )

    @model_validator(mode="after")
    def _one_layout(self) -> StudySpec:
        given = [k for k in ("grid", "line", "starts") if getattr(self, k) is not None]
        if len(given) > 1:
            raise ValueError(f"give one of grid, line and starts, not {' and '.join(given)}")
        if self.grid is not None and not (self.grid[0] >= 1 and self.grid[1] >= 1):
            # as --grid (a review: 1001 x 1 passed there and not here)
            raise ValueError("grid: each of nx, ny must be at least 1")
        if self.grid is not None and self.grid[0] * self.grid[1] > MAX_STARTS:
            # as --grid: every start of a group flies in one world, with its own sensors' noise
            raise ValueError(f"grid: {self.grid[0]} x {self.grid[1]} is more than {MAX_STARTS} "
                             "starts")
        for path, values in self.sweeps.items():
            if not values:
                raise ValueError(f"sweeps.{path}: no values")
        configs = 1
        for values in self.sweeps.values():
            configs *= len(values)
        starts = (self.grid[0] * self.grid[1] if self.grid is not None else
                  len(self.starts) if self.starts is not None else
                  int((self.line.x_to_m - self.line.x_from_m) / self.line.step_m) + 1
                  if self.line is not None else 1)
        too_big = study_size_problem(starts, self.runs_per_start, configs)
        if too_big:
            raise ValueError(too_big)
        return self
