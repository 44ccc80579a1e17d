"""The noise bank's buffer size and error-free navigation change memory, never a number.

A :class:`~cptbt.sim.NoiseBank` of one kind (normals only or uniforms only) holds fewer draws
than its stream's block, and error-free navigation draws nothing (issue 15's memory target).
Both are checked against the bank as it was — every vehicle's block of 512 draws held at once —
draw for draw, bit for bit.
"""

from __future__ import annotations

import numpy as np
import pytest

from cptbt.sim import Navigation, NavigationParams, NoiseBank
from cptbt.sim.vehicle import wrap_deg


class BlockBank:
    """The reference: a whole block of every vehicle's draws generated and held at once."""

    def __init__(self, rngs: list[np.random.Generator], n_normal: int, n_uniform: int,
                 block: int = 512) -> None:
        self.rngs, self.shape, self.block, self.i = rngs, (n_normal, n_uniform), block, block
        self.normal = np.empty((block, len(rngs), n_normal))
        self.uniform = np.empty((block, len(rngs), n_uniform))

    def draw(self) -> tuple[np.ndarray, np.ndarray]:
        if self.i == self.block:
            for j, rng in enumerate(self.rngs):
                self.normal[:, j] = rng.standard_normal((self.block, self.shape[0]))
                self.uniform[:, j] = rng.random((self.block, self.shape[1]))
            self.i = 0
        self.i += 1
        return self.normal[self.i - 1], self.uniform[self.i - 1]


def _rngs(n: int, seed: int) -> list[np.random.Generator]:
    return [np.random.default_rng(s) for s in np.random.SeedSequence(seed).spawn(n)]


@pytest.mark.parametrize("kind", [(2, 0), (1, 0), (0, 3), (1, 2), (5, 1)])
@pytest.mark.parametrize("buffered", [1, 7, 128, 512, 700])
def test_every_buffer_size_draws_the_stream_of_whole_blocks(
    kind: tuple[int, int], buffered: int
) -> None:
    n = 3
    bank = NoiseBank(_rngs(n, 7), *kind, block=64, buffered=buffered)
    ref = BlockBank(_rngs(n, 7), *kind, block=64)
    for _ in range(200):  # several blocks and several buffers
        (a, b), (c, d) = bank.draw(), ref.draw()
        assert a.tobytes() == c.tobytes() and b.tobytes() == d.tobytes()


def test_a_bank_of_one_kind_holds_its_buffer_not_the_block() -> None:
    normals = NoiseBank(_rngs(4, 0), 2, 0, block=512, buffered=16)
    both = NoiseBank(_rngs(4, 0), 2, 1, block=512, buffered=16)
    assert normals._normal.shape == (16, 4, 2)
    assert both._normal.shape == (512, 4, 2)  # a block's normals come before its uniforms


def test_error_free_navigation_is_the_truth_as_the_drawing_one_computed_it() -> None:
    """The same estimates bit for bit as the general path with zero noise and a drawing bank."""
    params = NavigationParams(drift_std_m=0.0, fix_rate_per_s=0.0, fix_std_m=0.5,
                              heading_noise_std_deg=0.0)
    n = 6
    lazy = Navigation(params, _rngs(n, 3))
    drawing = Navigation(params, _rngs(n, 3))
    drawing._bank = NoiseBank(_rngs(n, 3), n_normal=5, n_uniform=1)  # the path as it was
    rng = np.random.default_rng(1)
    for k in range(1100):  # past two blocks
        xy = rng.normal(scale=50.0, size=(n, 2))
        xy[k % n] = -0.0 if k % 3 else 0.0
        heading = wrap_deg(rng.choice([0.0, 180.0, -180.0, 360.0, 1e-300, -1e-300], n)
                           + rng.normal(scale=200.0, size=n) * (rng.random(n) < 0.5))
        a, b = lazy.step(0.05, xy, heading), drawing.step(0.05, xy, heading)
        assert a[0].tobytes() == b[0].tobytes() and a[1].tobytes() == b[1].tobytes()
    assert lazy.fixes == drawing.fixes == 0
    assert lazy._bank is None


def test_navigation_with_any_error_still_draws() -> None:
    for change in ({"drift_std_m": 1.0}, {"fix_rate_per_s": 0.1}, {"heading_noise_std_deg": 1.0}):
        params = NavigationParams(drift_std_m=0.0, fix_rate_per_s=0.0, heading_noise_std_deg=0.0)
        assert Navigation(params.model_copy(update=change), _rngs(2, 0))._bank is not None
