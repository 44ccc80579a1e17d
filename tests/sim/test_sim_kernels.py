"""The optional numba kernels give the numpy code's numbers: bit for bit (exact tier) or to
rounding (fast tier)."""

from __future__ import annotations

import os
from collections.abc import Iterator

import numpy as np
import pytest

from cptbt.sim import EnvironmentParams, World, kernels

pytest.importorskip("numba")


@pytest.fixture(autouse=True)
def _restore_tier() -> Iterator[None]:
    before = kernels.tier()
    yield
    kernels.use(before)


def _fly(preset: str, tier: kernels.Tier, warm_s: float, seconds: float
         ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    kernels.use(tier)
    params = EnvironmentParams.preset(preset, seed=3)  # type: ignore[arg-type]
    xy = np.column_stack([np.linspace(-60.0, 90.0, 7), np.linspace(-40.0, 40.0, 7)])
    if preset != "tro_ocean":
        xy = np.column_stack([np.linspace(30.0, 95.0, 7), np.linspace(-40.0, 40.0, 7)])
    world = World(params, xy=xy, heading_deg=175.0)
    world.warm_up(warm_s)
    world.set_commands(np.linspace(150.0, 210.0, 7), np.full(7, 1.2))
    samples = []
    for _ in range(round(seconds / params.dt_s)):
        out = world.step()
        if out.fluorometer is not None:
            samples.append(out.fluorometer)
    probe = world.flow.velocity_at(world.plume.positions)
    return np.concatenate(samples), world.plume.positions.copy(), world.plume.radii_sq.copy(), probe


@pytest.mark.parametrize(("preset", "warm_s", "seconds"),
                         [("tro_ocean", 600.0, 60.0), ("ab_large_meander", 60.0, 10.0)])
def test_exact_kernels_match_numpy_bit_for_bit(preset: str, warm_s: float, seconds: float) -> None:
    ref = _fly(preset, "numpy", warm_s, seconds)
    fast = _fly(preset, "exact", warm_s, seconds)
    assert len(ref[1]) > 50  # puffs were there to move, drop and sample
    for a, b in zip(ref, fast, strict=True):
        assert a.shape == b.shape
        assert np.array_equal(a, b)


@pytest.fixture(autouse=True)
def _restore_tier():  # type: ignore[no-untyped-def]
    before = kernels.tier()
    yield
    kernels.use(before)  # the tier is process-wide: leave it as the next test expects


def test_fast_concentration_matches_numpy_to_rounding() -> None:
    kernels.use("exact")
    params = EnvironmentParams.preset("ab_large_meander", seed=5)
    world = World(params, xy=np.array([[50.0, 0.0]]))
    world.warm_up(60.0)
    rng = np.random.default_rng(1)
    # Points near puff centres, so the sums compared are sums of real, non-zero terms whatever
    # the plume realisation (a sparse filament plume leaves random points mostly at zero).
    centres = world.plume.positions[rng.choice(len(world.plume.positions), 12, replace=False)]
    pts = centres + rng.normal(0.0, 0.05, centres.shape)
    ref = np.array([world.concentration_at(p[None, :])[0] for p in pts])
    kernels.use("fast")
    got = np.array([world.concentration_at(p[None, :])[0] for p in pts])
    assert np.count_nonzero(ref > 0.01) >= 3
    np.testing.assert_allclose(got, ref, rtol=1e-12, atol=1e-300)


def test_unknown_tier_is_refused() -> None:
    with pytest.raises(ValueError, match="unknown kernel tier"):
        kernels.use("gpu")  # type: ignore[arg-type]


def test_an_unwritable_kernel_cache_compiles_afresh_with_a_warning() -> None:
    """A review: with numba installed and neither the package folder nor $HOME writable (a
    shared install, a service user, a vehicle's read-only root) every command stopped on
    "internal error: cannot cache function '_bilinear'"."""
    import subprocess
    import sys

    pytest.importorskip("numba")
    code = (
        "import numba\n"
        "njit = numba.njit\n"
        "def refusing(*a, cache=False, **k):\n"
        "    if cache:\n"
        "        raise RuntimeError(\"cannot cache function '_bilinear': no locator available\")\n"
        "    return njit(*a, cache=cache, **k)\n"
        "numba.njit = refusing\n"
        "import numpy as np\n"
        "from cptbt.sim import kernels\n"
        "kernels.use('exact')\n"
        "print(kernels.concentration_direct(np.zeros((1, 2)), np.zeros(1), np.zeros(1),\n"
        "      np.ones(1), 1.0, -50.0)[0] > 0)\n"
        "from cptbt.sim import EnvironmentParams, World\n"
        "World(EnvironmentParams.preset('tro_ocean', seed=1), np.zeros((1, 2)))\n"
        "World(EnvironmentParams.preset('tro_ocean', seed=1), np.zeros((1, 2)))\n")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=300, env={**os.environ, "CPTBT_KERNELS": "exact"})
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "True"
    # said once, when a world is made (a command's logging is set up by then)
    assert done.stderr.count("numba cannot write its kernel cache here") == 1, done.stderr
