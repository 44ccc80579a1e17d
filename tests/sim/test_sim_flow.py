"""Flow physics: uniform flow, the meandering PDE flow, presets and their meander amplitude."""

from __future__ import annotations

import math

import numpy as np
import pytest
from pydantic import ValidationError

from cptbt.sim import FlowParams, MeanderingFlow, PlumeParams, PuffPlume, UniformFlow, make_flow

AREA = (-20.0, 120.0, -70.0, 70.0)


def test_uniform_flow_points_toward_its_direction() -> None:
    xy = np.zeros((3, 2))
    assert np.allclose(UniformFlow(2.0, 180.0).velocity_at(xy), [[-2.0, 0.0]] * 3)
    v = UniformFlow(1.0, 30.0).velocity_at(xy)[0]
    assert v == pytest.approx([math.sqrt(3) / 2, 0.5])


def test_presets_fill_unset_fields_and_overrides_win() -> None:
    large = FlowParams(preset="large_meander")
    assert large.mean_speed_mps == 1.0 and large.noise_std_mps > 0
    stronger = FlowParams(preset="large_meander", noise_std_mps=0.5)
    assert stronger.noise_std_mps == 0.5
    assert stronger.noise_corr_time_s == large.noise_corr_time_s
    assert FlowParams().preset == "ocean" and FlowParams().mean_speed_mps == pytest.approx(0.1)
    assert FlowParams.model_validate(large.model_dump()) == large
    # Field defaults (what the schema documents) are the default "ocean" preset.
    assert FlowParams.model_construct() == FlowParams(preset="ocean")
    with pytest.raises(ValidationError):
        FlowParams(preset="large_meander", typo_speed=1.0)  # type: ignore[call-arg]
    with pytest.raises(ValidationError):
        FlowParams(preset="hurricane")  # type: ignore[arg-type]
    with pytest.raises(ValidationError):
        large.noise_std_mps = 1.0  # type: ignore[misc]


def test_make_flow_uniform_preset_is_constant_and_domain_has_margin() -> None:
    flow = make_flow("uniform", (0.0, 100.0, -50.0, 50.0), np.random.default_rng(0), margin_m=10)
    assert isinstance(flow, UniformFlow)
    assert flow.domain == (-10.0, 110.0, -60.0, 60.0)


def test_noiseless_meandering_flow_stays_at_its_mean() -> None:
    # A uniform field with constant boundaries is a fixed point of the advection–diffusion PDE.
    params = FlowParams(preset="small_meander", noise_std_mps=0.0, mean_dir_deg=-120.0)
    flow = MeanderingFlow(params, AREA, np.random.default_rng(0))
    flow.step(100.0)
    expected = [math.cos(math.radians(-120)), math.sin(math.radians(-120))]
    pts = np.random.default_rng(1).uniform(-20, 120, (50, 2))
    assert np.allclose(flow.velocity_at(pts), expected, atol=1e-12)


def test_bilinear_interpolation_is_exact_for_linear_fields() -> None:
    flow = MeanderingFlow(FlowParams(preset="small_meander"), AREA, np.random.default_rng(0))
    gx, gy = np.meshgrid(flow.xs, flow.ys)
    flow._f[0] = 0.3 + 0.01 * gx - 0.02 * gy  # white-box: install a known field
    flow._f[1] = -0.1 + 0.005 * gy
    pts = np.random.default_rng(2).uniform([-20, -70], [120, 70], (200, 2))
    v = flow.velocity_at(pts)
    assert np.allclose(v[:, 0], 0.3 + 0.01 * pts[:, 0] - 0.02 * pts[:, 1])
    assert np.allclose(v[:, 1], -0.1 + 0.005 * pts[:, 1])
    # Outside the grid the nearest edge value is used.
    outside = flow.velocity_at(np.array([[-500.0, 500.0]]))[0]
    assert outside == pytest.approx([0.3 + 0.01 * -20 - 0.02 * 70, -0.1 + 0.005 * 70])


def test_result_does_not_depend_on_how_time_is_sliced() -> None:
    a = make_flow("large_meander", AREA, np.random.default_rng(5))
    b = make_flow("large_meander", AREA, np.random.default_rng(5))
    for _ in range(10):
        a.step(2.0)
    for _ in range(200):
        b.step(0.1)
    assert isinstance(a, MeanderingFlow) and isinstance(b, MeanderingFlow)
    assert np.allclose(a.grid_velocity, b.grid_velocity)


@pytest.mark.parametrize("toward", [0.0, 180.0, 30.0])
def test_time_averaged_flow_follows_the_mean(toward: float) -> None:
    flow = make_flow("small_meander", AREA, np.random.default_rng(3), mean_dir_deg=toward)
    pts = np.array([[0.0, 0.0], [50.0, 20.0], [100.0, -40.0]])
    acc = np.zeros((3, 2))
    steps = 3000
    for _ in range(steps):
        flow.step(1.0)
        acc += flow.velocity_at(pts)
    mean = acc / steps
    expected = np.array([math.cos(math.radians(toward)), math.sin(math.radians(toward))])
    assert np.allclose(mean, expected, atol=0.06)
    assert np.all(np.abs(flow.velocity_at(pts)) < 3.0)  # explicit scheme stayed stable


def _centreline_deviation(preset: str, seed: int) -> np.ndarray:
    """|Lateral offset| of the tracer centreline 100 m downflow of a source at the origin."""
    rng = np.random.default_rng(seed)
    flow = make_flow(preset, AREA, rng)
    tracer = PlumeParams(preset="ab", release_rate_hz=2.0, centre_rel_diffusivity_m2ps=0.0)
    plume = PuffPlume(tracer, (0.0, 0.0), flow, rng)
    devs = []
    for k in range(2000):  # 1000 s at 0.5 s; the first 200 s spin the plume up
        flow.step(0.5)
        plume.step(0.5)
        if k >= 400 and k % 4 == 0:
            p = plume.positions
            sel = np.abs(p[:, 0] - 100.0) < 2.0
            if sel.any():
                devs.append(p[sel, 1].mean())
    return np.abs(np.array(devs))


def test_meander_presets_match_ab_centreline_deviation() -> None:
    """AB §2.3: deviation at 100 m downflow normally < 10 m (small) and < 25 m (large)."""
    small = np.concatenate([_centreline_deviation("small_meander", s) for s in range(4)])
    large = np.concatenate([_centreline_deviation("large_meander", s) for s in range(4)])
    p90_small = np.percentile(small, 90)
    p90_large = np.percentile(large, 90)
    assert 3.0 < p90_small < 10.0
    assert 12.0 < p90_large < 25.0
    assert np.median(large) > 1.5 * np.median(small)


def test_ocean_flow_direction_drifts_tens_of_degrees_over_minutes() -> None:
    """TRO Table II (MSN007r2): 0.08–0.12 m/s, direction within a ~22° band over ~12 min."""
    ranges = []
    for seed in range(4):
        flow = make_flow("ocean", (-127.0, 127.0, -56.0, 56.0), np.random.default_rng(seed))
        flow.step(2000.0)
        v = []
        for _ in range(140):
            flow.step(5.0)
            v.append(flow.velocity_at(np.zeros((1, 2)))[0])
        v = np.array(v)
        speed = np.hypot(v[:, 0], v[:, 1])
        assert np.all((speed > 0.03) & (speed < 0.2))
        ranges.append(np.ptp(np.degrees(np.arctan2(v[:, 1], v[:, 0]))))
    assert 8.0 < np.mean(ranges) < 60.0


def test_second_order_boundary_noise_is_stationary_and_swings_back() -> None:
    """Farrell 2002's second-order noise: std kept, anticorrelated half a period later."""
    sigma, period_s = 0.3, 2 * math.pi * 10.0
    params = FlowParams(
        preset="uniform", noise_std_mps=sigma, noise_corr_time_s=10.0, noise_order=2
    )
    flow = MeanderingFlow(params, (0.0, 100.0, -50.0, 50.0), np.random.default_rng(5))
    h = flow.substep_s
    lag = round(period_s / 2 / h)
    xs = []
    for _ in range(40000):
        flow._substep(h)
        xs.append(flow._noise.copy())
    x = np.array(xs).reshape(len(xs), -1)  # (steps, 8 corner components)
    assert x.std() == pytest.approx(sigma, rel=0.12)
    corr = np.mean([np.corrcoef(x[:-lag, j], x[lag:, j])[0, 1] for j in range(8)])
    assert corr < -0.3  # a first-order process is positively correlated at every lag
