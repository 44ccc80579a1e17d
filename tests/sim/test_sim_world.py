"""World: sample schedules, determinism, per-vehicle streams, truth sampling, params, layering."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from pydantic import ValidationError

import cptbt.sim
from cptbt.sim import EnvironmentParams, FluorometerParams, NavigationParams, World
from cptbt.sim.world import DEFAULT_WARM_UP_CAP_S


def _run(world: World, seconds: float) -> list:
    out = []
    while world.t_s < seconds - 1e-9:
        out.append(world.step())
    return out


@pytest.mark.parametrize(
    ("name", "fluor", "adcp"), [("tro_ocean", 90, 5), ("ab_large_meander", 200, 200)]
)
def test_sensor_sample_counts_follow_their_rates(name: str, fluor: int, adcp: int) -> None:
    world = World(EnvironmentParams.preset(name), xy=np.zeros((2, 2)))  # type: ignore[arg-type]
    outs = _run(world, 10.0)
    assert sum(o.fluorometer is not None for o in outs) == fluor
    assert sum(o.adcp_flow is not None for o in outs) == adcp
    assert outs[-1].t_s == pytest.approx(10.0)


def test_nine_hertz_samples_on_a_fine_step() -> None:
    world = World(EnvironmentParams(dt_s=0.01, plume_dt_s=0.5), xy=np.zeros((1, 2)))
    times = [o.t_s for o in _run(world, 2.0) if o.fluorometer is not None]
    assert len(times) == 18
    assert np.diff(times) == pytest.approx(np.full(17, 1 / 9), abs=0.011)


def test_same_seed_is_bit_identical_and_another_seed_differs() -> None:
    def trace(seed: int) -> np.ndarray:
        params = EnvironmentParams.preset("ab_large_meander", seed=seed)
        world = World(params, xy=[[40.0, 0.0], [60.0, 5.0]], heading_deg=180.0)
        world.warm_up(60.0)
        rows = []
        for k, out in enumerate(_run(world, 20.0)):
            world.set_commands(np.array([180.0 + k % 40, 170.0]), np.array([1.0, 1.5]))
            rows.append(
                np.concatenate([out.nav_xy.ravel(), out.fluorometer, out.adcp_flow.ravel()])
            )
        return np.array(rows)

    assert np.array_equal(trace(7), trace(7))
    assert not np.array_equal(trace(7), trace(8))


def test_vehicle_noise_does_not_depend_on_how_many_vehicles() -> None:
    params = EnvironmentParams(
        fluorometer=FluorometerParams(noise_std=0.05), navigation=NavigationParams(drift_std_m=4.0)
    )
    alone = World(params, xy=[[-50.0, 6.0]])
    crowd = World(params, xy=[[-50.0, 6.0], [0.0, 0.0], [30.0, -20.0]])
    for world in (alone, crowd):
        world.warm_up(300.0)
    a, c = _run(alone, 30.0), _run(crowd, 30.0)
    for oa, oc in zip(a, c, strict=True):
        assert np.array_equal(oa.nav_xy[0], oc.nav_xy[0])
        if oa.fluorometer is not None:
            # Equal up to float summation order over a different set of culled puffs; the
            # noise itself (std 0.05) is the same draw.
            assert oa.fluorometer[0] == pytest.approx(oc.fluorometer[0], rel=1e-9, abs=1e-12)
        if oa.adcp_flow is not None:
            assert np.array_equal(oa.adcp_flow[0], oc.adcp_flow[0])


def test_the_plume_is_sampled_at_the_true_position() -> None:
    nav = NavigationParams(drift_std_m=20.0, drift_tau_s=60.0, fix_rate_per_s=0.0)
    world = World(EnvironmentParams(navigation=nav), xy=[[-60.0, 6.0]], heading_deg=0.0)
    world.warm_up()
    world.set_commands(np.array([0.0]), np.array([0.5]))
    hits = 0
    for _ in range(540):
        out = world.step()
        if out.fluorometer is not None:
            truth = world.plume.concentration(out.true_xy)
            assert out.fluorometer[0] == pytest.approx(truth[0])
            hits += truth[0] > 0.2
    assert hits > 0  # the vehicle was in the plume, so the check had teeth
    assert np.hypot(*(out.nav_xy - out.true_xy)[0]) > 1.0


def test_warm_up_fills_the_domain_without_advancing_mission_time() -> None:
    world = World(EnvironmentParams(), xy=np.zeros((1, 2)))
    world.warm_up()
    assert world.t_s == 0.0
    reach = world.plume.positions[:, 0].max() - world.params.source_xy_m[0]
    assert reach > 0.9 * (world.domain[1] - world.params.source_xy_m[0])
    assert world.plume.skipped == 0


def test_the_default_spin_up_of_a_still_sea_is_capped_and_logged(
    caplog: pytest.LogCaptureFixture, monkeypatch: pytest.MonkeyPatch,
) -> None:
    # No mean current: the crossing time at the 1 mm/s floor was ~4e5 s of spin-up (75 s wall
    # for a 200 x 120 m box). It is capped, and the cap is logged once per process (a batch
    # said it again for every group).
    monkeypatch.setattr("cptbt.sim.world._CAP_WARNED", set())
    still = EnvironmentParams.model_validate({"flow": {"preset": "ocean", "mean_speed_mps": 0.0}})
    world = World(still, xy=np.zeros((1, 2)))
    with caplog.at_level("WARNING", logger="cptbt.sim.world"):
        assert world.default_warm_up_s() == DEFAULT_WARM_UP_CAP_S
    assert sum("spin-up capped" in r.getMessage() for r in caplog.records) == 1, caplog.records
    caplog.clear()
    with caplog.at_level("WARNING", logger="cptbt.sim.world"):
        assert World(still, xy=np.zeros((1, 2))).default_warm_up_s() == DEFAULT_WARM_UP_CAP_S
    assert not caplog.records  # said already
    ocean = World(EnvironmentParams(), xy=np.zeros((1, 2)))  # 0.1 m/s: the crossing time
    with caplog.at_level("WARNING", logger="cptbt.sim.world"):
        assert 1000.0 < ocean.default_warm_up_s() < DEFAULT_WARM_UP_CAP_S
    assert not caplog.records


def test_step_and_spin_up_are_bounded() -> None:
    with pytest.raises(ValidationError, match=r"greater than or equal to 0\.005"):
        EnvironmentParams(dt_s=1e-6)
    with pytest.raises(ValidationError, match="less than or equal to 86400"):
        EnvironmentParams(warm_up_s=1e8)


def test_nan_commands_are_held_by_the_world() -> None:
    world = World(EnvironmentParams(), xy=np.zeros((1, 2)), heading_deg=45.0)
    world.set_commands(np.array([np.nan]), np.array([np.nan]))
    out = world.step()
    assert out.true_heading_deg[0] == 45.0
    assert np.all(np.isfinite(out.true_xy))


def test_environment_params_validate_and_round_trip() -> None:
    default = EnvironmentParams()
    assert default.flow.preset == "ocean" and default.fluorometer.rate_hz == 9.0
    ab = EnvironmentParams.preset("ab_small_meander")
    assert ab.flow.preset == "small_meander" and ab.source_xy_m == (20.0, 0.0)
    assert EnvironmentParams.model_validate(ab.model_dump()) == ab
    assert EnvironmentParams.model_validate({"flow": {"preset": "large_meander"}}).flow.grid_n == 21
    with pytest.raises(ValidationError):
        EnvironmentParams.model_validate({"flow": {"preset": "ocean", "speed": 1.0}})
    with pytest.raises(ValidationError):
        EnvironmentParams(dt_s=0.5)  # slower than the 9 Hz fluorometer
    with pytest.raises(ValidationError):
        EnvironmentParams(area_m=(10.0, 0.0, -5.0, 5.0))


def test_sim_imports_neither_behaviours_nor_the_core() -> None:
    sim_dir = Path(cptbt.sim.__file__).parent
    for path in sim_dir.glob("*.py"):
        text = path.read_text(encoding="utf-8")
        assert "cptbt.behaviours" not in text and "from cptbt" not in text, path.name
    code = "import sys, cptbt.sim; assert 'cptbt.behaviours' not in sys.modules"
    # Run away from the source folder, whose cptbt/ (without the package-dir mapping) would
    # otherwise shadow the installed package when the install is not editable.
    away = Path(cptbt.sim.__file__).parents[2]
    subprocess.run([sys.executable, "-c", code], check=True, cwd=away)
