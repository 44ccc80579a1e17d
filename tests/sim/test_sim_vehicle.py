"""Vehicle kinematics: heading laws, turning radius, speed limits, NaN commands, current."""

from __future__ import annotations

import math

import numpy as np
import pytest

from cptbt.sim import VehicleParams, Vehicles, wrap_deg

STILL = np.zeros((1, 2))


def test_wrap_deg_maps_to_half_open_interval() -> None:
    assert wrap_deg(np.array([180.0, -180.0, 190.0, 360.0, -190.0])).tolist() == [
        180.0, 180.0, -170.0, 0.0, 170.0,
    ]  # fmt: skip


def test_first_order_heading_matches_the_exponential() -> None:
    # AB footnote 3: psi(t) = psi_cmd + (psi0 - psi_cmd) e^{-a t}; a = 5, after 0.2 s: 1 - 1/e.
    veh = Vehicles(VehicleParams(heading_mode="first_order"), STILL, 0.0)
    for _ in range(20):
        veh.step(0.01, np.array([90.0]), np.array([1.0]), STILL)
    assert veh.heading_deg[0] == pytest.approx(90.0 * (1 - math.exp(-1.0)))
    for _ in range(180):  # 2 s in all: converged to within 90 e^{-10} ≈ 0.004°
        veh.step(0.01, np.array([90.0]), np.array([1.0]), STILL)
    assert veh.heading_deg[0] == pytest.approx(90.0 * (1 - math.exp(-10.0)))


def test_heading_turns_the_short_way_round() -> None:
    veh = Vehicles(VehicleParams(heading_mode="first_order"), STILL, 10.0)
    veh.step(0.01, np.array([350.0]), np.array([1.0]), STILL)
    assert veh.heading_deg[0] < 10.0


def test_turn_radius_mode_never_turns_tighter_than_the_radius() -> None:
    params = VehicleParams(heading_mode="turn_radius", turning_radius_m=8.0)
    veh = Vehicles(params, STILL, 0.0, speed_mps=np.array([2.0]))
    dt = 0.05
    xs, ys, headings = [], [], []
    for _ in range(int(2 * math.pi * 8.0 / 2.0 / dt)):  # one full circle at 2 m/s
        veh.step(dt, veh.heading_deg + 170.0, np.array([2.0]), STILL)
        xs.append(veh.xy[0, 0])
        ys.append(veh.xy[0, 1])
        headings.append(veh.heading_deg[0])
    turn = np.abs(wrap_deg(np.diff(headings)))
    assert turn.max() <= math.degrees(2.0 * dt / 8.0) + 1e-9
    # The path is a circle of diameter 2R = 16 m.
    assert np.ptp(xs) == pytest.approx(16.0, rel=0.02)
    assert np.ptp(ys) == pytest.approx(16.0, rel=0.02)


def test_speed_is_clipped_to_the_remus_range() -> None:
    veh = Vehicles(VehicleParams(), np.zeros((2, 2)), 0.0)
    veh.step(0.1, np.zeros(2), np.array([5.0, 0.01]), np.zeros((2, 2)))
    assert veh.speed_mps.tolist() == [2.8, 0.25]


def test_nan_commands_hold_heading_and_speed() -> None:
    veh = Vehicles(VehicleParams(), np.zeros((2, 2)), np.array([30.0, -45.0]), np.array([1.2, 2.0]))
    veh.step(0.5, np.array([np.nan, 0.0]), np.array([np.nan, np.nan]), np.zeros((2, 2)))
    assert veh.heading_deg[0] == 30.0
    assert veh.speed_mps.tolist() == [1.2, 2.0]
    assert np.all(np.isfinite(veh.xy))


def test_position_integrates_speed_along_heading_plus_current() -> None:
    params = VehicleParams(min_speed_mps=0.0, heading_mode="first_order")
    veh = Vehicles(params, np.array([[1.0, 2.0], [0.0, 0.0]]), np.array([90.0, 0.0]))
    current = np.array([[0.1, -0.2], [0.1, -0.2]])
    for _ in range(100):
        veh.step(0.1, np.array([90.0, 0.0]), np.array([0.0, 1.5]), current)
    assert veh.xy[0] == pytest.approx([1.0 + 1.0, 2.0 - 2.0])  # drifts with the current only
    assert veh.xy[1] == pytest.approx([15.0 + 1.0, -2.0])
