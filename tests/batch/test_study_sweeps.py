"""Study sweeps: every kind of mission path is set where the mission keeps it."""

from __future__ import annotations

import pytest

from cptbt.batch.study import Sweep, apply_setting


def data() -> dict:  # type: ignore[type-arg]
    return {
        "speed_mps": 1.5,
        "perception": {"threshold": 0.2},
        "behaviours": [{"maintain_plume": {"variant": "track_in_out", "beta_deg": 10}}],
    }


@pytest.mark.parametrize(
    ("path", "value", "where"),
    [
        ("speed_mps", 2.0, ("speed_mps",)),
        ("perception.lambda_s", 4.0, ("perception", "lambda_s")),
        ("perception.threshold", 0.5, ("perception", "threshold")),
        ("evaluation.success_radius_m", 5.0, ("evaluation", "success_radius_m")),
        ("environment.flow.mean_speed_mps", 0.3, ("environment", "flow", "mean_speed_mps")),
        ("maintain_plume.beta_deg", 20, ("behaviours", 0, "maintain_plume", "beta_deg")),
    ],
)
def test_a_sweep_sets_its_path(path: str, value: object, where: tuple) -> None:  # type: ignore[type-arg]
    d = data()
    apply_setting(d, path, value)
    node = d
    for key in where:
        node = node[key]
    assert node == value


def test_a_variant_sweep_drops_the_old_variants_params() -> None:
    d = data()
    apply_setting(d, "maintain_plume.variant", "counter_turn")
    assert d["behaviours"][0] == {"maintain_plume": {"variant": "counter_turn"}}


@pytest.mark.parametrize("path", ["nonsense", "find_plume.dtheta_up_deg"])
def test_a_sweep_of_nothing_is_an_error(path: str) -> None:
    with pytest.raises(ValueError, match="sweep path"):
        apply_setting(data(), path, 1)


def test_sweep_parses_joined_paths_and_yaml_values() -> None:
    s = Sweep.parse("maintain_plume.variant+reacquire_plume.variant=strategy_1,strategy_2")
    assert s.paths == ("maintain_plume.variant", "reacquire_plume.variant")
    assert s.values == ("strategy_1", "strategy_2") and s.name.count("+") == 1
    assert Sweep.parse("perception.lambda_s=1,2.5").values == (1, 2.5)
