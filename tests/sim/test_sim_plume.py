"""Puff plume: mass accounting, normalisation, growth, axis and intermittent detection."""

from __future__ import annotations

import math

import numpy as np
import pytest

from cptbt.sim import EnvironmentParams, PlumeParams, PuffPlume, UniformFlow, World, make_flow

THRESHOLD = 0.20  # TRO Table I


# Numerics tests use puffs the 0.05 m test grids resolve, with peaks of order one (the "ab"
# preset's young filaments are 3 cm wide and peak in the hundreds).
RESOLVED = dict(puff_mass=0.15, initial_radius_m=0.1, spread_rate_m2ps=0.004, release_rate_hz=10.0)


def _uniform_plume(
    toward: float = 0.0,
    domain: tuple[float, float, float, float] = (-200.0, 200.0, -200.0, 200.0),
    seed: int = 0,
    **plume: float,
) -> PuffPlume:
    params = PlumeParams(preset="ab", **plume)  # type: ignore[arg-type]
    flow = UniformFlow(1.0, toward, domain)
    return PuffPlume(params, (0.0, 0.0), flow, np.random.default_rng(seed))


def test_mass_is_conserved_until_puffs_leave() -> None:
    plume = _uniform_plume(release_rate_hz=10.0)
    for _ in range(1000):  # 100 s: puffs reach x ≈ 100 m, inside the 200 m domain
        plume.step(0.1)
    assert plume.dropped == 0
    assert plume.n == plume.released
    assert plume.total_mass() == pytest.approx(plume.released * plume.params.puff_mass)
    # Poisson release: mean rate·T = 1000, std ≈ 32
    assert abs(plume.released - 1000) < 5 * math.sqrt(1000)


def test_puffs_leaving_the_domain_are_dropped_and_counted() -> None:
    plume = _uniform_plume(
        domain=(-10.0, 30.0, -20.0, 20.0), centre_rel_diffusivity_m2ps=0.0, release_rate_hz=10.0
    )
    for _ in range(600):
        plume.step(0.1)
    assert plume.dropped > 0
    assert plume.n == plume.released - plume.dropped
    # At 1 m/s a puff lives 30 s in the domain: about 10 puffs/s × 30 s alive.
    assert abs(plume.n - 300) < 5 * math.sqrt(300)
    assert np.all(plume.positions[:, 0] <= 30.0)


def test_capacity_caps_the_puff_count() -> None:
    plume = _uniform_plume(max_puffs=50, release_rate_hz=10.0)
    for _ in range(200):
        plume.step(0.1)
    assert plume.n == 50
    assert plume.skipped > 0
    assert plume.released == 50


def test_concentration_integrates_to_the_total_mass() -> None:
    plume = _uniform_plume(toward=30.0, **RESOLVED)
    for _ in range(300):
        plume.step(0.1)
    xs = np.arange(-5.0, 40.0, 0.05)
    ys = np.arange(-15.0, 30.0, 0.05)
    grid = plume.snapshot_grid(xs, ys)
    assert grid.sum() * 0.05**2 == pytest.approx(plume.total_mass(), rel=1e-3)


def test_culled_concentration_matches_the_brute_force_sum() -> None:
    plume = _uniform_plume(toward=-60.0, **RESOLVED)
    for _ in range(400):
        plume.step(0.1)
    q = np.random.default_rng(9).uniform(-5, 25, (300, 2)) * [1, -1]
    p, r2 = plume.positions, plume.radii_sq
    d2 = ((q[:, None, :] - p[None, :, :]) ** 2).sum(-1)
    brute = (plume.params.puff_mass / (2 * np.pi * r2) * np.exp(-d2 / (2 * r2))).sum(1)
    # Culling beyond 4 r drops at most e^{-8} ≈ 3.4e-4 of a puff's peak (≤ 2.4 here), and only a
    # few puffs sit just outside a point's reach: well under 1 % of the 0.2 threshold.
    assert np.allclose(plume.concentration(q), brute, rtol=0.0, atol=2e-3)
    assert not np.allclose(plume.concentration(q), 0.5 * brute, rtol=0.0, atol=2e-3)
    assert brute.max() > THRESHOLD  # the comparison covered plume, not empty water
    # Few points take the bounding-box path, many the cell-bucket path: same values.
    assert np.allclose(plume.concentration(q[:3]), plume.concentration(q)[:3], rtol=1e-12)
    xs, ys = np.linspace(0, 20, 7), np.linspace(-20, 0, 5)
    gx, gy = np.meshgrid(xs, ys)
    pts = np.column_stack([gx.ravel(), gy.ravel()])
    assert np.allclose(plume.snapshot_grid(xs, ys).ravel(), plume.concentration(pts), atol=2e-3)


def test_tiny_puffs_bucket_into_a_bounded_number_of_cells() -> None:
    # Cells of the puffs' reach (4 r of 1 mm puffs over a 400 m domain) were 1e11 cells: a
    # MemoryError. Cells are at least 1/1024 of the domain's side, with the same values.
    plume = _uniform_plume(initial_radius_m=0.001, spread_rate_m2ps=0.0, cutoff_sigmas=4.0,
                           centre_rel_diffusivity_m2ps=0.0, release_rate_hz=10.0)
    for _ in range(100):
        plume.step(0.1)
    p = plume.positions
    q = np.vstack([p[:20], p[:20] + 0.002])  # on puffs and 2 r beside them: 40 points, hashed
    alone = np.concatenate([plume.concentration(q[i : i + 1]) for i in range(len(q))])
    assert np.allclose(plume.concentration(q), alone, rtol=1e-12, atol=0.0)
    assert alone.min() > 0.0


def test_radius_squared_grows_linearly_with_age() -> None:
    # Without diffusion a puff at distance d from the source in a 1 m/s flow is d s old.
    plume = _uniform_plume(centre_rel_diffusivity_m2ps=0.0)
    for _ in range(500):
        plume.step(0.1)
    age = plume.positions[:, 0]
    p = plume.params
    assert np.allclose(plume.radii_sq, p.initial_radius_m**2 + p.spread_rate_m2ps * age)
    assert np.allclose(plume.positions[:, 1], 0.0)


@pytest.mark.parametrize("toward", [0.0, 180.0, 35.0])
def test_uniform_plume_axis_follows_the_flow(toward: float) -> None:
    plume = _uniform_plume(toward=toward)
    for _ in range(600):
        plume.step(0.1)
    mean = plume.positions.mean(axis=0)
    angle = math.degrees(math.atan2(mean[1], mean[0]))
    assert (angle - toward + 180) % 360 - 180 == pytest.approx(0.0, abs=1.5)


@pytest.mark.parametrize("toward", [180.0, 35.0])
def test_meandering_plume_axis_follows_the_mean_flow(toward: float) -> None:
    rng = np.random.default_rng(4)
    area = (-110.0, 110.0, -110.0, 110.0)
    flow = make_flow("large_meander", area, rng, mean_dir_deg=toward)
    params = PlumeParams(preset="ab", release_rate_hz=2.0)
    plume = PuffPlume(params, (0.0, 0.0), flow, rng)
    acc = np.zeros(2)
    for k in range(3000):
        flow.step(0.5)
        plume.step(0.5)
        if k >= 300:
            acc += plume.positions.mean(axis=0)
    angle = math.degrees(math.atan2(acc[1], acc[0]))
    assert (angle - toward + 180) % 360 - 180 == pytest.approx(0.0, abs=8.0)


def _detection_fraction(name: str, dists: list[float], seconds: float, seed: int) -> np.ndarray:
    params = EnvironmentParams.preset(name, seed=seed)  # type: ignore[arg-type]
    src = np.array(params.source_xy_m)
    d = math.radians(params.flow.mean_dir_deg)
    pts = src + np.outer(dists, [math.cos(d), math.sin(d)])
    world = World(params, xy=pts)
    world.warm_up()
    hits = np.zeros(len(dists))
    h = params.plume_dt_s * 2
    steps = int(seconds / h)
    for _ in range(steps):
        world.flow.step(h)
        world.plume.step(h)
        hits += world.plume.concentration(pts) > THRESHOLD
    return hits / steps


def test_ocean_plume_is_intermittently_detectable_beyond_100_m() -> None:
    frac = _detection_fraction("tro_ocean", [10.0, 100.0, 150.0], 1200.0, 0)
    assert np.all((frac > 0.02) & (frac < 0.9))
