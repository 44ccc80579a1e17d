"""Sensing settings the simulated world makes hopeless are warned of: a threshold the plume
never reaches (or only next to its source), a λ no shorter than the time limit (such settings
flew silent 0 % studies)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from cptbt.batch.scenario import Environment, advisories, to_sim_params
from cptbt.batch.sensing_advice import MARGIN, plume_peaks
from cptbt.loader import loads_mission
from cptbt.registry import default_registry
from cptbt.sim.world import World

ROOT = Path(__file__).resolve().parents[2]


def _mission(name: str, old: str = "", new: str = ""):  # type: ignore[no-untyped-def]
    text = (ROOT / "missions" / name).read_text(encoding="utf-8")
    assert old in text
    return loads_mission(text.replace(old, new, 1), "m.yaml", default_registry(), Environment)


@pytest.mark.parametrize("name", ["tro2006_msn007.yaml", "ab2001_strategy1.yaml"])
def test_the_peak_is_the_plumes_within_the_margin(name: str) -> None:
    """The world's concentration on a 2-cm grid around the source over the same minutes
    never exceeds the advisory's peak times its margin, and comes near the peak."""
    params = to_sim_params(_mission(name))
    peak, far = plume_peaks(params)
    assert 0 < far < peak
    world = World(params, np.zeros((0, 2)))
    sx, sy = params.source_xy_m
    xs, ys = np.meshgrid(np.arange(sx - 1, sx + 3, 0.02), np.arange(sy - 2, sy + 2, 0.02))
    grid = np.column_stack([xs.ravel(), ys.ravel()])
    best = 0.0
    for _ in range(12):
        world.warm_up(10.0)
        best = max(best, float(world.concentration_at(grid).max()))
    assert 0.9 * peak <= best <= MARGIN * peak


def test_a_threshold_the_plume_never_reaches_is_warned_of() -> None:
    said = {loc: msg for loc, msg in advisories(_mission("tro2006_msn007.yaml"))}
    assert ("perception", "threshold") not in said  # the shipped 0.2
    said = {loc: msg for loc, msg in advisories(
        _mission("tro2006_msn007.yaml", "threshold: 0.20", "threshold: 20"))}
    assert "above the simulated plume's highest concentration" in said[("perception",
                                                                         "threshold")]
    for high in (5, 7):  # 5: a review's, 1.3 times the peak beyond 10 m, saw nothing
        said = {loc: msg for loc, msg in advisories(
            _mission("tro2006_msn007.yaml", "threshold: 0.20", f"threshold: {high}"))}
        assert "only within 10 m of its source" in said[("perception", "threshold")]


def test_a_lambda_as_long_as_the_time_limit_is_warned_of() -> None:
    said = {loc: msg for loc, msg in advisories(
        _mission("tro2006_msn007.yaml", "lambda_s: 8.5", "lambda_s: 3600"))}
    assert "never lost before the run ends" in said[("perception", "lambda_s")]
    said = {loc: msg for loc, msg in advisories(_mission("tro2006_msn007.yaml"))}
    assert ("perception", "lambda_s") not in said


def test_a_slow_quiet_current_is_not_taken_for_a_plume_found_only_near_its_source() -> None:
    """A review: in a current under ~0.017 m/s without noise no puff got 10 m from the source
    in the minutes looked at, and TRO's own 0.2 was warned of as reached only near it; every
    run of such a mission declared, most first detecting 24-90 m out. Nothing seen that far,
    nothing said."""
    quiet = ("flow_speed_mps: 0.01\n  flow: {noise_std_mps: 0.0, common_noise_std_mps: 0.0}")
    mission = _mission("tro2006_msn007.yaml", "flow_speed_mps: 0.1", quiet)
    assert to_sim_params(mission).flow.noise_std_mps == 0.0
    said = {loc: msg for loc, msg in advisories(mission)}
    assert ("perception", "threshold") not in said


def test_a_source_beyond_the_simulated_water_is_said_to_release_nothing() -> None:
    """An attacker's source 400 m outside (allowed) read "above the simulated plume's highest
    concentration (about 0, at its source)": at its source the plume reads about 10."""
    text = (ROOT / "missions" / "tro2006_msn007.yaml").read_text(encoding="utf-8")
    text = text.replace("source: [43, -55]", "source: [400, -400]").replace(
        "\nbehaviours:", "\nallow_outside: [source]\nbehaviours:")
    mission = loads_mission(text, "m.yaml", default_registry(), Environment)
    said = {loc: msg for loc, msg in advisories(mission)}
    assert "holds no puff in its first minutes" in said[("perception", "threshold")]
