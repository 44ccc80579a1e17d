"""Several sources in one world: one plume each, in the same flow; concentrations add."""

from __future__ import annotations

import numpy as np
import pytest

from cptbt.sim import EnvironmentParams, World


def test_a_second_source_has_a_plume_of_its_own_and_the_concentrations_add() -> None:
    params = EnvironmentParams(extra_sources_xy_m=((0.0, -30.0),), warm_up_s=300.0)
    world = World(params, xy=np.zeros((1, 2)))
    world.warm_up()
    assert world.sources_xy_m == [(-70.0, 6.0), (0.0, -30.0)]
    (second,) = world.extra_plumes
    assert second.n > 0
    # every puff of the second plume left its own source and went down-flow (+x) of it
    assert np.all(second.positions[:, 0] > -5.0)
    q = np.array([[-60.0, 6.0], [10.0, -30.0], [40.0, 40.0]])
    total = world.concentration_at(q)
    assert total == pytest.approx(world.plume.concentration(q) + second.concentration(q))
    samples = [world.step().fluorometer for _ in range(20)]
    assert any(s is not None for s in samples)


def test_single_source_worlds_do_not_change() -> None:
    one = World(EnvironmentParams(seed=3, warm_up_s=100.0), xy=np.zeros((1, 2)))
    same = World(EnvironmentParams(seed=3, warm_up_s=100.0, extra_sources_xy_m=()),
                 xy=np.zeros((1, 2)))
    one.warm_up()
    same.warm_up()
    assert one.extra_plumes == [] and np.array_equal(one.plume.positions, same.plume.positions)
    for _ in range(30):
        a, b = one.step(), same.step()
        assert (a.fluorometer is None) == (b.fluorometer is None)
        if a.fluorometer is not None:
            assert np.array_equal(a.fluorometer, b.fluorometer)
