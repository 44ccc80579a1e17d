"""A simulated fluorometer noisy enough to cross the threshold in clean water is warned of."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from cptbt.batch.scenario import (
    NOISE_ALARM_PER_CYCLE,
    Environment,
    advisories,
    clean_water_alarm,
)
from cptbt.loader import loads_mission
from cptbt.perception import Perception, PerceptionSettings
from cptbt.registry import default_registry
from cptbt.sim.sensors import Fluorometer, FluorometerParams
from cptbt.types import Pose

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.parametrize(("noise", "threshold"), [(0.1, 0.2), (0.08, 0.2), (0.05, 0.1)])
def test_the_warned_chance_is_what_the_simulated_sensor_gives(noise: float,
                                                              threshold: float) -> None:
    """The perception's cycles over clean water, 9 samples of the simulated sensor each, read
    above the threshold as often as the advisory says."""
    cycles, samples = 4000, 9
    sensor = Fluorometer(FluorometerParams(noise_std=noise, rate_hz=9.0),
                         [np.random.default_rng(5)])
    area = loads_mission((ROOT / "missions/tro2006_msn007.yaml").read_text(), "m.yaml",
                         default_registry(), Environment).op_area_geometry()
    perception = Perception(area, PerceptionSettings(threshold=threshold, stuck_after_s=None))
    perception.set_pose(Pose(0.0, 0.0, 0.0))
    hits = 0
    for k in range(cycles):
        for j in range(samples):
            perception.add_sample(k + j / samples, float(sensor.sample(np.zeros(1))[0]))
        hits += perception.cycle(k + 1.0).detected
    expected = clean_water_alarm(noise, threshold, samples)
    se = np.sqrt(expected * (1 - expected) / cycles)
    assert abs(hits / cycles - expected) < 4 * se + 1e-3, (hits / cycles, expected)


def _mission(noise: float | None, threshold: float = 0.2) -> str:
    text = (ROOT / "missions/two_sources.yaml").read_text()
    text = text.replace("threshold: 0.20", f"threshold: {threshold}")
    if noise is not None:
        text = text.replace("  seed: 11", f"  seed: 11\n  fluorometer: {{noise_std: {noise}}}")
    return text


def test_a_noisy_sensor_is_warned_of_at_its_key() -> None:
    mission = loads_mission(_mission(0.1), "noisy.yaml", default_registry(), Environment)
    (warned,) = [(loc, msg) for loc, msg in advisories(mission) if "noise_std" in loc]
    assert warned[0] == ("environment", "fluorometer", "noise_std")
    assert warned[1].startswith("0.1 against perception.threshold 0.2: in clean water 19% of "
                                "planning cycles (the largest of 9 samples each)"), warned[1]
    assert "set the threshold at 4 σ or more, 0.4" in warned[1]


@pytest.mark.parametrize(("noise", "threshold"), [(None, 0.2), (0.0, 0.2), (0.04, 0.2),
                                                  (0.1, 0.45)])
def test_a_quiet_sensor_or_a_high_threshold_is_not(noise: float | None,
                                                   threshold: float) -> None:
    mission = loads_mission(_mission(noise, threshold), "quiet.yaml", default_registry(),
                            Environment)
    assert not [loc for loc, _ in advisories(mission) if "fluorometer" in loc]
    if noise:
        assert clean_water_alarm(noise, threshold, 9) <= NOISE_ALARM_PER_CYCLE
