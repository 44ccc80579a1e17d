"""The ``environment:`` section of a mission file, and its conversion to simulator settings.

The section is written in the mission's own frame (N-E metres and compass degrees for ``frame:
ne``; planning metres and degrees for ``frame: planning``); the simulator works in the planning
frame. Any simulator setting can be overridden by name under ``flow``, ``plume``, ``vehicle``,
``fluorometer``, ``adcp`` and ``navigation``; unset ones come from the preset.
"""

from __future__ import annotations

import math
from typing import Annotated, Any

from pydantic import BaseModel, ConfigDict, Field, ValidationError, WithJsonSchema

from cptbt.batch.sensing_advice import (
    adcp_advice,
    dropout_advice,
    lambda_advice,
    noise_advice,
    sensor_rate_advice,
    threshold_advice,
)
from cptbt.batch.sim_advice import (
    flow_direction_advice,
    launch_turn_advice,
    leaf_advice,
    move_advice,
    pace_advice,
    plain,
    source_wall_advice,
    tour_flow_advice,
    turn_guard_advice,
)
from cptbt.coercions import coercions
from cptbt.mission import Coord, Loc, MissionBase, Problem, latlon_problem
from cptbt.policy import RELINQUISH_OUTSIDE_M, metres_text
from cptbt.schema import partial_schema
from cptbt.sim.flow import MAX_FLOW_SPEED_MPS, FlowParams
from cptbt.sim.plume import PlumeParams
from cptbt.sim.sensors import ADCPParams, FluorometerParams, NavigationParams
from cptbt.sim.vehicle import VehicleParams
from cptbt.sim.world import MAX_EXTRA_SOURCES, EnvironmentParams, EnvPreset
from cptbt.types import Point

Overrides = dict[str, Any]

# Partial overrides of the simulator's models, typed in the JSON Schema by those models (the
# merged result is validated by the models themselves, see to_sim_params).
FlowOverrides = Annotated[Overrides, WithJsonSchema(partial_schema(FlowParams))]
PlumeOverrides = Annotated[Overrides, WithJsonSchema(partial_schema(PlumeParams))]
VehicleOverrides = Annotated[Overrides, WithJsonSchema(partial_schema(VehicleParams))]
FluorometerOverrides = Annotated[Overrides, WithJsonSchema(partial_schema(FluorometerParams))]
ADCPOverrides = Annotated[Overrides, WithJsonSchema(partial_schema(ADCPParams))]
NavigationOverrides = Annotated[Overrides, WithJsonSchema(partial_schema(NavigationParams))]


class Environment(BaseModel):
    """A simulated environment for a mission."""

    model_config = ConfigDict(frozen=True, extra="forbid", allow_inf_nan=False)

    preset: EnvPreset = Field(
        default="tro_ocean",
        description="Base setup: 'tro_ocean' (REMUS scale, ~0.1 m/s) or AB's 'ab_small_meander' "
        "/ 'ab_large_meander' (1 m/s, 100 x 100 m)",
    )
    source: Coord | None = Field(
        default=None, description="True source position in the mission frame (required: the "
        "presets' own sources lie in their own areas, not in yours); inside the OpArea unless "
        "the mission lists 'source' in allow_outside"
    )
    extra_sources: list[Coord] = Field(
        default_factory=list, max_length=MAX_EXTRA_SOURCES,
        description=f"At most {MAX_EXTRA_SOURCES} more true sources, in the mission frame, "
        "each with a plume of its own in the same flow (multi-source missions); inside the "
        "OpArea unless the mission lists 'source' in allow_outside"
    )
    flow_toward_deg: float | None = Field(
        default=None, ge=-360.0, le=360.0,  # 1e300 degrees had been taken modulo 360
        description="Mean flow direction (toward), compass degrees for frames 'ne' and "
        "'geodetic', planning "
        "degrees for frame 'planning' (default: preset's)",
    )
    flow_speed_mps: float | None = Field(
        default=None, ge=0, le=MAX_FLOW_SPEED_MPS,
        description=f"Mean flow speed, m/s (at most {MAX_FLOW_SPEED_MPS:g}; the fastest tidal "
        "races run at about 5 m/s)",
    )
    launch: Coord | None = Field(
        default=None, description="Vehicle position at t = 0 (default: mission start, else home)"
    )
    launch_heading_deg: float = Field(
        default=0.0, ge=-360.0, le=360.0,
        description="Vehicle heading at t = 0 (mission-frame convention)"
    )
    seed: int = Field(default=0, ge=0, lt=2**63,
                      description="Seed of every random draw of a run (below 2**63: the "
                      "results table stores it as a 64-bit integer)")
    dt_s: float | None = Field(default=None, gt=0, description="Vehicle step, s")
    plume_dt_s: float | None = Field(default=None, gt=0, description="Flow and plume step, s")
    warm_up_s: float | None = Field(default=None, ge=0, description="Plume spin-up, s")
    warm_up_step_s: float | None = Field(
        default=None, gt=0, description="Flow and plume step of the spin-up, s (faster, same "
        "statistics, another realisation; default: the plume step)"
    )
    flow: FlowOverrides = Field(
        default_factory=dict, description="Flow model overrides"
    )
    plume: PlumeOverrides = Field(
        default_factory=dict, description="Plume model overrides"
    )
    vehicle: VehicleOverrides = Field(
        default_factory=dict, description="Vehicle model overrides"
    )
    fluorometer: FluorometerOverrides = Field(
        default_factory=dict, description="Fluorometer overrides"
    )
    adcp: ADCPOverrides = Field(
        default_factory=dict, description="ADCP overrides"
    )
    navigation: NavigationOverrides = Field(
        default_factory=dict, description="Navigation error overrides"
    )


def _merge(base: dict[str, Any], over: dict[str, Any]) -> dict[str, Any]:
    out = dict(base)
    for k, v in over.items():
        out[k] = _merge(out[k], v) if isinstance(v, dict) and isinstance(out.get(k), dict) else v
    return out


def environment_of(mission: MissionBase) -> Environment:
    """The mission's environment section.

    Raises:
        ValueError: the mission has none (check :func:`problems` first for a located message).
    """
    env = mission.environment
    if env is None:
        raise ValueError(f"mission {mission.name} has no environment section to simulate")
    return env if isinstance(env, Environment) else Environment.model_validate(env)


def problems(mission: MissionBase, simulate: bool) -> list[Problem]:
    """What stops the mission's environment from being simulated, as (key path, message).

    Args:
        mission: a validated mission.
        simulate: a run is asked for, so the section must exist.
    """
    env = mission.environment
    if env is None:
        if not simulate:
            return []
        return [(("environment",), "a simulated run needs an 'environment:' section giving the "
                                   "true 'source:' (see missions/tro2006_msn007.yaml)")]
    env = environment_of(mission)
    if env.source is None:
        return [(("environment", "source"), "required: the true source in the mission frame "
                                            "(cptbt does not guess one for your OpArea)")]
    if mission.frame == "geodetic" and (why := latlon_problem(env.source)):
        return [(("environment", "source"), why)]
    area = mission.op_area_geometry()
    out: list[Problem] = []
    for key, inner in (("flow_speed_mps", "mean_speed_mps"), ("flow_toward_deg", "mean_dir_deg")):
        # the short key overrides the flow section's: its value (even NaN) would go unread,
        # and a sweep of it would fly the same flow in every configuration
        if getattr(env, key) is not None and inner in env.flow:
            out.append((("environment", "flow", inner), f"given with environment.{key}, which "
                        "sets it: give one of them"))
    if env.launch is not None and mission.mission_a is None:
        if mission.frame == "geodetic" and (why := latlon_problem(env.launch)):
            out.append((("environment", "launch"), why))
        else:
            at = mission.to_xy(env.launch)
            outside = area.distance_outside(at.x, at.y)
            if outside > RELINQUISH_OUTSIDE_M:
                out.append((("environment", "launch"),
                            f"{metres_text(outside)} m outside the OpArea: without a mission_a "
                            f"the AMP drives from the launch, and it gives control back "
                            f"{RELINQUISH_OUTSIDE_M:g} m outside the OpArea (TRO II); launch "
                            "within that distance, or add a mission_a that brings the vehicle in"))
    places: list[tuple[Loc, Coord]] = [(("environment", "source"), env.source)]
    places += [(("environment", "extra_sources", i), c) for i, c in enumerate(env.extra_sources)]
    for loc, coord in places:
        if mission.frame == "geodetic" and (why := latlon_problem(coord)):
            out.append((loc, why))
            continue
        src = mission.to_xy(coord)
        if "source" not in mission.allow_outside and not area.contains(src.x, src.y):
            out.append((loc, f"{metres_text(area.distance_outside(src.x, src.y))} m outside the "
                             "OpArea (list 'source' in allow_outside if that is intended)"))
    return out + _speed_problems(mission) + override_coercions(env)


def _speed_problems(mission: MissionBase) -> list[Problem]:
    """A commanded speed the simulated vehicle cannot fly: it would clip it to its speeds
    (a review's ``speed_mps: 16`` flew at 2.8 m/s through the water, and validated)."""
    try:
        vehicle = to_sim_params(mission).vehicle
    except (ValueError, TypeError):  # an unusable setting is a problem, reported as one
        return []
    lo, hi = vehicle.min_speed_mps, vehicle.max_speed_mps
    speeds = mission.commanded_speeds()
    env = mission.environment
    given = getattr(env, "vehicle", None) or {}
    if "initial_speed_mps" in given:  # the preset's own is clipped quietly under a slower max
        speeds.append((("environment", "vehicle", "initial_speed_mps"),
                       vehicle.initial_speed_mps))
    return [(loc, f"{plain(v)} m/s is outside the simulated vehicle's speeds [{plain(lo)}, "
                  f"{plain(hi)}] m/s (environment.vehicle min_speed_mps, max_speed_mps): it "
                  f"would fly at {plain(min(max(v, lo), hi))} m/s; command a speed it can fly, "
                  "or set the vehicle's")
            for loc, v in speeds if not lo <= v <= hi]


SECTIONS: dict[str, type[BaseModel]] = {
    "flow": FlowParams, "plume": PlumeParams, "vehicle": VehicleParams,
    "fluorometer": FluorometerParams, "adcp": ADCPParams, "navigation": NavigationParams}
"""The simulator's models of the environment's override sections."""


def override_coercions(env: Environment) -> list[Problem]:
    """Values in the override sections (``fluorometer: {noise_std: true}``) that the simulator's
    models would take only by converting them from another YAML type, as the mission's own
    keys are refused (:func:`cptbt.coercions.coercions`): a YAML boolean or a quoted string where
    a number is meant."""
    out: list[Problem] = []
    for name, model in SECTIONS.items():
        given = getattr(env, name)
        if given:
            out += [(("environment", name, *path), why) for path, why in coercions(given, model)]
    return out


def advisories(mission: MissionBase) -> list[Problem]:
    """The mission's advisories (:meth:`~cptbt.mission.MissionBase.advisories`) and those only
    its simulated world shows, as (key path, message): a run is judged a success only when
    every true source has a declared point within the success radius, so a declaration that
    can declare fewer points than the world has sources, or two sources within that radius of
    each other (one point matches one source), makes success impossible."""
    out = list(mission.advisories())
    if mission.environment is None:
        return out
    try:
        params = to_sim_params(mission)
    except (ValueError, TypeError):  # an unusable setting is a problem, reported as one
        params = None
    if params is not None:
        out += [a for advice in (noise_advice, dropout_advice, adcp_advice, leaf_advice,
                                 tour_flow_advice,
                                 move_advice, pace_advice, turn_guard_advice,
                                 flow_direction_advice, sensor_rate_advice,
                                 threshold_advice, lambda_advice)
                for a in advice(mission, params)]
        out += launch_turn_advice(mission, params, launch_pose(mission))
    try:
        truth = true_sources(mission)
    except (ValueError, TypeError):  # an unusable place is a problem, reported as one
        return out
    if params is not None:
        out += source_wall_advice(mission, params, truth)
    if mission.evaluation.criterion != "declaration":
        return out
    area, r = mission.op_area_geometry(), mission.evaluation.success_radius_m
    for j, s in enumerate(truth):
        d = area.distance_outside(s.x, s.y)
        if d > r:  # a review's source 20 m beyond the up-flow wall: declared at the wall, failed
            out.append((("environment", "source") if j == 0 else
                        ("environment", "extra_sources", j - 1),
                        f"{metres_text(d)} m outside the OpArea, farther than the success radius "
                        f"({r:g} m): detections outside it are ignored (TRO V), so a declaration "
                        "is made inside and no run can succeed"))
    if len(truth) < 2:
        return out
    r = mission.evaluation.success_radius_m
    for i, e in enumerate(mission.entries()):
        if e.family != "declare_source":
            continue
        several = hasattr(e.params, "max_sources")  # a variant that can declare more
        most = int(e.params.max_sources) if several else 1  # type: ignore[attr-defined]
        if most < len(truth):
            key = ("behaviours", i, e.family) + (("max_sources",) if several else ())
            can = (f"max_sources {most}" if several
                   else f"the {e.variant} rule declares one source")
            out.append((key, f"{can}, but the world has {len(truth)} sources and a run "
                        "succeeds only when every one is found: no run can succeed"
                        + ("" if several else " (the likelihood_map variant takes "
                           "max_sources)")))
    for j in range(1, len(truth)):
        near = min(range(j), key=lambda k: truth[k].distance_to(truth[j]))
        d = truth[near].distance_to(truth[j])
        if d <= r:
            out.append((("environment", "extra_sources", j - 1),
                        f"{d:.1f} m from {'source' if near == 0 else f'extra_sources[{near - 1}]'}"
                        f", within the success radius ({r:g} m): a declared point counts for one "
                        "source only, so both must be declared apart"))
    return out


def to_sim_params(mission: MissionBase, seed: int | None = None) -> EnvironmentParams:
    """Simulator settings for a mission, in the planning frame.

    Raises:
        pydantic.ValidationError: an override does not fit the simulator's models (locations are
            relative to the ``environment`` section).
    """
    env = environment_of(mission)
    area = mission.op_area_geometry()
    base = EnvironmentParams.preset(env.preset).model_dump()
    over: dict[str, Any] = {
        "area_m": (area.xmin, area.xmax, area.ymin, area.ymax),
        "seed": env.seed if seed is None else seed,
    }
    if env.source is not None:
        src = mission.to_xy(env.source)
        over["source_xy_m"] = (src.x, src.y)
    if env.extra_sources:
        extra = [mission.to_xy(c) for c in env.extra_sources]
        over["extra_sources_xy_m"] = [(q.x, q.y) for q in extra]
    flow: dict[str, Any] = dict(env.flow)
    if env.flow_toward_deg is not None:
        flow["mean_dir_deg"] = planning_angle(mission, env.flow_toward_deg)
    if env.flow_speed_mps is not None:
        flow["mean_speed_mps"] = env.flow_speed_mps
    for key in ("dt_s", "plume_dt_s", "warm_up_s", "warm_up_step_s"):
        if getattr(env, key) is not None:
            over[key] = getattr(env, key)
    for key in ("plume", "vehicle", "fluorometer", "adcp", "navigation"):
        over[key] = getattr(env, key)
    over["flow"] = flow
    return EnvironmentParams.model_validate(_merge(base, over))


def mean_flow(mission: MissionBase) -> dict[str, Any]:
    """The simulated current's mean, for ``summary.json``: toward which compass bearing (a
    planning-frame mission: which planning angle) and how fast (a review could tell the
    direction a mission without ``flow_toward_deg`` flew only from its figure)."""
    flow = to_sim_params(mission).flow
    if mission.frame == "planning":
        return {"toward_planning_deg": flow.mean_dir_deg, "speed_mps": flow.mean_speed_mps}
    bearing = mission.op_area_geometry().frame.x_bearing_deg + flow.mean_dir_deg
    return {"toward_deg": round(bearing % 360, 6), "speed_mps": flow.mean_speed_mps}


def true_sources(mission: MissionBase) -> list[Point]:
    """Every true source of a mission's environment (planning frame), ``source`` first."""
    env = environment_of(mission)
    coords = ([env.source] if env.source is not None else []) + list(env.extra_sources)
    return [mission.to_xy(c) for c in coords]


def planning_angle(mission: MissionBase, angle_deg: float) -> float:
    """A mission-frame angle (compass for 'ne' and 'geodetic') as a planning angle."""
    if mission.frame != "planning":
        return mission.op_area_geometry().frame.planning_deg(angle_deg)
    return angle_deg


def launch_pose(mission: MissionBase) -> tuple[float, float, float]:
    """True planning-frame (x, y, heading) of the vehicle at t = 0."""
    env = environment_of(mission)
    where = env.launch or mission.start or mission.home
    p = mission.to_xy(where)
    return p.x, p.y, planning_angle(mission, env.launch_heading_deg)


def check(mission: MissionBase) -> ValidationError | None:
    """Validate the simulator settings a mission implies; the error, or None."""
    try:
        to_sim_params(mission)
    except ValidationError as exc:
        return exc
    return None


def starts_at_a_source(mission: MissionBase, starts: list[tuple[float, float]]) -> str | None:
    """Under the arrival criterion, the starts already within the success radius of a true
    source, in one sentence (None: none): their runs succeed at once and pull a study's mean
    time down (a review: AB Fig. 10's start at the source made 20 successes of 0.05 s, the
    mean 126 s against 154 s without it, and no table said so)."""
    if mission.evaluation.criterion != "arrival" or mission.environment is None:
        return None
    try:
        params = to_sim_params(mission)
    except (ValueError, TypeError):  # an unusable setting is reported as a problem elsewhere
        return None
    sources = [params.source_xy_m, *params.extra_sources_xy_m]
    radius = mission.evaluation.success_radius_m
    near = [(x, y) for x, y in starts
            if any(math.hypot(x - sx, y - sy) <= radius for sx, sy in sources)]
    if not near:
        return None
    shown = ", ".join(f"({x:g}, {y:g})" for x, y in near[:3]) + (", ..." if len(near) > 3 else "")
    return (f"{len(near)} start{'s' * (len(near) != 1)} within the success radius "
            f"({radius:g} m) of a source: {shown} (planning frame); their runs succeed at once "
            "and count in the success rate and the mean time")
