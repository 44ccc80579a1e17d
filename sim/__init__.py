"""Lightweight plume-tracing simulator: flow, filament plume, vehicles, sensors and world.

Pure numpy; imports neither the planner core nor any behaviour. Planning frame: x, y in metres,
angles in degrees from +x toward +y, ``flow_dir`` = where the water goes.
"""

from .flow import FlowField, FlowParams, MeanderingFlow, UniformFlow, make_flow
from .plume import PlumeParams, PuffPlume
from .sensors import (
    ADCP,
    ADCPParams,
    Fluorometer,
    FluorometerParams,
    Navigation,
    NavigationParams,
    NoiseBank,
)
from .vehicle import VehicleParams, Vehicles, wrap_deg
from .world import EnvironmentParams, StepOutput, World, env_rng_from_seed, vehicle_rngs_from_seed

__all__ = [
    "ADCP",
    "ADCPParams",
    "EnvironmentParams",
    "FlowField",
    "FlowParams",
    "Fluorometer",
    "FluorometerParams",
    "MeanderingFlow",
    "Navigation",
    "NavigationParams",
    "NoiseBank",
    "PlumeParams",
    "PuffPlume",
    "StepOutput",
    "UniformFlow",
    "VehicleParams",
    "Vehicles",
    "World",
    "env_rng_from_seed",
    "make_flow",
    "vehicle_rngs_from_seed",
    "wrap_deg",
]
