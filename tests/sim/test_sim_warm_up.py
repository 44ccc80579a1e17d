"""A spin-up with a long step gives the plume statistics of a long fine-stepped spin-up."""

from __future__ import annotations

import numpy as np
import pytest

from cptbt.sim import EnvironmentParams, World

SEEDS = range(8)


def _warmed(preset: str, step_s: float | None, multiple: float, seed: int
            ) -> tuple[np.ndarray, np.ndarray]:
    params = EnvironmentParams.preset(preset, seed=seed, warm_up_step_s=step_s)  # type: ignore[arg-type]
    world = World(params, xy=np.array([[0.0, 0.0]]))
    world.warm_up(multiple * world.default_warm_up_s())
    return world.plume.positions.copy(), world.plume.radii_sq.copy()


def _ks(a: np.ndarray, b: np.ndarray) -> float:
    """Two-sample Kolmogorov–Smirnov distance."""
    grid = np.sort(np.concatenate([a, b]))
    fa = np.searchsorted(np.sort(a), grid, side="right") / len(a)
    fb = np.searchsorted(np.sort(b), grid, side="right") / len(b)
    return float(np.abs(fa - fb).max())


@pytest.mark.slow
@pytest.mark.parametrize(("preset", "step_s"), [("tro_ocean", 10.0), ("ab_large_meander", 0.5)])
def test_coarse_spin_up_matches_a_long_fine_one(preset: str, step_s: float) -> None:
    long = [_warmed(preset, None, 2.0, s) for s in SEEDS]
    quick = [_warmed(preset, step_s, 1.0, 100 + s) for s in SEEDS]
    n_long = np.array([len(r2) for _, r2 in long])
    n_quick = np.array([len(r2) for _, r2 in quick])
    se = np.sqrt(n_long.var(ddof=1) / len(SEEDS) + n_quick.var(ddof=1) / len(SEEDS))
    assert abs(n_long.mean() - n_quick.mean()) < 3.0 * se
    assert abs(n_long.mean() - n_quick.mean()) < 0.15 * n_long.mean()
    xy_long = np.concatenate([xy for xy, _ in long])
    xy_quick = np.concatenate([xy for xy, _ in quick])
    r2_long = np.concatenate([r2 for _, r2 in long])
    r2_quick = np.concatenate([r2 for _, r2 in quick])
    # Age (r² grows linearly with it) and the along-flow spread of the puffs.
    assert _ks(r2_long, r2_quick) < 0.1
    assert _ks(xy_long[:, 0], xy_quick[:, 0]) < 0.1
    # The cross-flow spread is set by the meander realisations: the same within sampling noise.
    assert 0.6 < xy_quick[:, 1].std() / xy_long[:, 1].std() < 1.6


def test_warm_up_step_sets_the_spin_up_step() -> None:
    params = EnvironmentParams.preset("tro_ocean", seed=1, warm_up_step_s=10.0)
    world = World(params, xy=np.array([[0.0, 0.0]]))
    world.warm_up(100.0)
    assert world.plume.time_s == pytest.approx(100.0)
    assert world.flow.time_s == pytest.approx(100.0)  # type: ignore[attr-defined]
    assert world.t_s == 0.0
