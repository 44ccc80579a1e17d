"""Sensors: filter, threshold, noise statistics, faults, ADCP, navigation drift and jumps."""

from __future__ import annotations

import math

import numpy as np
import pytest

from cptbt.sim import (
    ADCP,
    ADCPParams,
    Fluorometer,
    FluorometerParams,
    Navigation,
    NavigationParams,
    NoiseBank,
)


def _rngs(n: int, seed: int = 0) -> list[np.random.Generator]:
    return [np.random.default_rng(s) for s in np.random.SeedSequence(seed).spawn(n)]


def test_noise_bank_streams_do_not_depend_on_the_number_of_vehicles() -> None:
    one = NoiseBank(_rngs(1), 2, 1, block=7)
    five = NoiseBank(_rngs(5), 2, 1, block=7)
    for _ in range(20):  # crosses several refills
        n1, u1 = one.draw()
        n5, u5 = five.draw()
        assert np.array_equal(n1[0], n5[0]) and np.array_equal(u1[0], u5[0])
    assert not np.array_equal(n5[0], n5[1])


def test_raw_fluorometer_applies_the_threshold() -> None:
    sensor = Fluorometer(FluorometerParams(tau=0.1), _rngs(3))
    out = sensor.sample(np.array([0.05, 0.1, 0.7]))
    assert out.tolist() == [0.0, 0.0, 0.7]


def test_low_pass_filter_step_response() -> None:
    # AB eq. 1 with a held unit input: rho(t) = 1 - e^{-alpha t}; 9 samples = 1 s.
    sensor = Fluorometer(FluorometerParams(alpha_per_s=2.0), _rngs(1))
    for _ in range(9):
        out = sensor.sample(np.array([1.0]))
    assert out[0] == pytest.approx(1 - math.exp(-2.0))


def test_fluorometer_noise_statistics() -> None:
    sensor = Fluorometer(FluorometerParams(noise_std=0.1), _rngs(2))
    out = np.array([sensor.sample(np.array([5.0, 5.0])) for _ in range(20000)])
    assert out.mean() == pytest.approx(5.0, abs=0.005)
    assert out.std() == pytest.approx(0.1, rel=0.03)
    assert abs(np.corrcoef(out[:, 0], out[:, 1])[0, 1]) < 0.03  # vehicles independent


def test_dropouts_are_nan_at_the_given_rate() -> None:
    sensor = Fluorometer(FluorometerParams(dropout_prob=0.1), _rngs(1))
    out = np.array([sensor.sample(np.array([1.0]))[0] for _ in range(20000)])
    frac = np.isnan(out).mean()
    assert frac == pytest.approx(0.1, abs=5 * math.sqrt(0.09 / 20000))
    assert np.all(out[~np.isnan(out)] == 1.0)


def test_stuck_output_freezes_for_its_duration() -> None:
    params = FluorometerParams(rate_hz=10.0, stuck_prob=1.0, stuck_duration_s=0.5)
    sensor = Fluorometer(params, _rngs(1))
    out = [sensor.sample(np.array([float(k)]))[0] for k in range(12)]
    # Sample 0 is read, then 5 samples (0.5 s) repeat it, then a fresh read starts a new freeze.
    assert out == [0.0] * 6 + [6.0] * 6


def test_adcp_noise_statistics() -> None:
    adcp = ADCP(ADCPParams(noise_std_mps=0.03), _rngs(1))
    flow = np.array([[0.1, -0.05]])
    out = np.array([adcp.sample(flow)[0] for _ in range(20000)])
    assert out.mean(axis=0) == pytest.approx([0.1, -0.05], abs=0.002)
    assert out.std(axis=0) == pytest.approx([0.03, 0.03], rel=0.03)


def test_navigation_drift_has_the_stationary_std_without_fixes() -> None:
    params = NavigationParams(drift_std_m=2.0, drift_tau_s=10.0, fix_rate_per_s=0.0)
    nav = Navigation(params, _rngs(1))
    err = []
    truth = np.zeros((1, 2))
    for k in range(40000):
        est, _ = nav.step(1.0, truth, np.zeros(1))
        if k > 100:
            err.append(est[0])
    assert np.std(err) == pytest.approx(2.0, rel=0.08)
    assert nav.fixes == 0


def test_navigation_jumps_at_lbl_fixes() -> None:
    params = NavigationParams(drift_std_m=5.0, drift_tau_s=600.0, fix_rate_per_s=1 / 60.0)
    nav = Navigation(params, _rngs(1, seed=3))
    truth = np.zeros((1, 2))
    est = np.array([nav.step(1.0, truth, np.zeros(1))[0][0] for _ in range(7200)])
    jumps = np.hypot(*np.diff(est, axis=0).T)
    # Between fixes the OU step is ~5·sqrt(2/600) ≈ 0.29 m; a fix jumps by the accumulated drift.
    assert (jumps > 2.0).sum() > 30
    assert nav.fixes == pytest.approx(120, abs=5 * math.sqrt(120))


def test_adcp_direction_error_is_held_for_its_period_and_keeps_the_speed() -> None:
    # AB §5: phi white normal, redrawn at 1 Hz; at 20 Hz it is held for 20 samples.
    params = ADCPParams(
        rate_hz=20.0, noise_std_mps=0.0, direction_error_std_deg=10.0, direction_error_period_s=1.0
    )
    adcp = ADCP(params, _rngs(3))
    flow = np.array([[1.0, 0.0], [0.0, 2.0], [-0.5, 0.5]])
    angles = []
    for _ in range(20 * 400):
        out = adcp.sample(flow)
        assert np.allclose(np.hypot(out[:, 0], out[:, 1]), np.hypot(flow[:, 0], flow[:, 1]))
        turn = np.arctan2(out[:, 1], out[:, 0]) - np.arctan2(flow[:, 1], flow[:, 0])
        angles.append(np.degrees(turn))
    phi = (np.array(angles) + 180.0) % 360.0 - 180.0  # (samples, vehicles)
    blocks = phi.reshape(400, 20, 3)
    assert np.allclose(blocks, blocks[:, :1, :])  # constant within each second
    assert not np.allclose(blocks[1:, 0], blocks[:-1, 0])  # redrawn every second
    assert blocks[:, 0].std() == pytest.approx(10.0, rel=0.1)
    assert abs(blocks[:, 0].mean()) < 1.5
    assert not np.allclose(blocks[:, 0, 0], blocks[:, 0, 1])  # each vehicle its own phi


def test_adcp_direction_error_leaves_the_other_noise_unchanged() -> None:
    flow = np.array([[0.3, 0.1]])
    plain = ADCP(ADCPParams(noise_std_mps=0.05), _rngs(1, seed=4))
    rotated = ADCP(ADCPParams(noise_std_mps=0.05, direction_error_std_deg=20.0), _rngs(1, seed=4))
    for _ in range(30):
        a = plain.sample(flow)[0]
        b = rotated.sample(flow)[0]
        phi = math.radians(float(rotated.phi_deg[0]))
        c, s = math.cos(-phi), math.sin(-phi)
        back = [c * b[0] - s * b[1], s * b[0] + c * b[1]]
        assert back == pytest.approx(list(a), abs=1e-12)
    assert rotated.phi_deg[0] != 0.0


def test_navigation_heading_is_wrapped_like_the_vehicles() -> None:
    # the vehicle's heading is in (-180, 180]; noise on 179.9 had been told as 180.3
    params = NavigationParams(heading_noise_std_deg=3.0)
    nav = Navigation(params, _rngs(2))
    told = np.concatenate([nav.step(1.0, np.zeros((2, 2)), np.array([179.9, -179.9]))[1]
                           for _ in range(200)])
    assert told.min() > -180.0 and told.max() <= 180.0
    assert told.min() < -170.0 and told.max() > 170.0  # both sides of the seam were drawn
