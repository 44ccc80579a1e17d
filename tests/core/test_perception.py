"""Perception of SPEC §2, cycle by cycle."""

import itertools
import math

import pytest

from cptbt.frames import OpArea
from cptbt.perception import Perception, PerceptionSettings
from cptbt.testing import square_area
from cptbt.types import Pose

AREA = OpArea(0, 100, -50, 50)


def make(lambda_s: float = 2.0) -> Perception:
    return Perception(AREA, PerceptionSettings(threshold=0.2, lambda_s=lambda_s, flow_window_s=100))


def test_cycle_takes_the_max_of_its_samples_and_thresholds() -> None:
    p = make()
    p.set_pose(Pose(50, 0))
    for c in (0.05, 0.3, 0.1):
        p.add_sample(0.0, c)
    per = p.cycle(1.0)
    assert per.concentration == 0.3 and per.detected
    per = p.cycle(2.0)  # no samples: NaN, not a detection
    assert math.isnan(per.concentration) and not per.detected


def test_faulty_samples_are_ignored() -> None:
    p = make()
    p.set_pose(Pose(50, 0))
    p.add_sample(0.0, math.nan)
    p.add_sample(0.0, math.inf)
    p.add_sample(0.0, 0.1)
    per = p.cycle(1.0)
    assert per.concentration == 0.1 and not per.detected


def test_detections_outside_the_oparea_are_ignored() -> None:
    p = make()
    p.set_pose(Pose(150, 0))
    p.add_sample(0.0, 5.0)
    per = p.cycle(1.0)
    assert not per.detected and per.last_detection is None and not per.in_op_area


def test_contacts_first_detection_and_lost_contacts() -> None:
    p = make(lambda_s=2.0)
    script = [  # (t, x, conc)
        (1, 10, 0.5),   # contact 1 starts: T_first = 1
        (2, 11, 0.0),
        (3, 12, 0.5),   # still contact 1 (within λ): last detection at x=12
        (4, 13, 0.0),
        (5, 14, 0.0),   # 5 - 3 = 2 <= λ: still in plume
        (6, 15, 0.0),   # 6 - 3 = 3 > λ: lost, (12, 0) appended
        (7, 16, 0.5),   # contact 2: T_first = 7
    ]
    out = []
    for t, x, c in script:
        p.set_pose(Pose(x, 0))
        p.add_sample(t, c)
        out.append(p.cycle(t))
    assert [q.in_plume for q in out] == [True, True, True, True, True, False, True]
    assert [q.contact_count for q in out] == [1, 1, 1, 1, 1, 1, 2]
    assert out[3].first_detection_t == 1 and out[6].first_detection_t == 7
    assert [(q.x, q.y) for q in out[4].lost_contacts] == []
    assert [(q.x, q.y) for q in out[5].lost_contacts] == [(12.0, 0.0)]
    assert out[6].last_detection is not None and out[6].last_detection.x == 16


def test_flow_is_a_vector_average_over_the_window() -> None:
    p = make()
    p.set_pose(Pose(50, 0))
    # Flow toward +179° and -179°: the angle average would say 0°, the vector average 180°.
    p.add_flow(0.0, math.cos(math.radians(179)), math.sin(math.radians(179)))
    p.add_flow(1.0, math.cos(math.radians(-179)), math.sin(math.radians(-179)))
    per = p.cycle(2.0)
    assert per.flow is not None and abs(per.flow.toward_deg) == pytest.approx(180)
    # After 100 s the old samples leave the window.
    p.add_flow(150.0, 0.0, 0.5)
    per = p.cycle(150.0)
    assert per.flow is not None and per.flow.toward_deg == pytest.approx(90)
    assert per.flow.speed_mps == pytest.approx(0.5)


def test_navigation_fault_keeps_last_good_pose() -> None:
    p = make()
    p.set_pose(Pose(10, 5, 30))
    p.set_pose(Pose(math.nan, 0, 0))
    per = p.cycle(1.0)
    assert (per.pose.x, per.pose.y, per.pose.heading_deg) == (10, 5, 30)


def test_lambda_holds_exactly_on_float_time_stamps() -> None:
    # At 10 Hz, 2.2 - 1.2 = 1.0000000000000002: still within lambda = 1 s.
    p = make(lambda_s=1.0)
    p.set_pose(Pose(50, 0))
    p.add_sample(1.2, 0.5)
    assert p.cycle(1.2).in_plume
    t = 1.2
    for _ in range(10):
        t += 0.1
        per = p.cycle(t)
    assert round(t, 9) == 2.2 and per.in_plume and not per.lost_contacts
    assert not p.cycle(t + 0.1).in_plume


def sampled(p: Perception, values: list[float], t0: float = 0.0, rate_hz: float = 9.0
            ) -> list[float]:
    """Feed one value per second (sampled ``rate_hz`` times), a cycle at each second's end;
    the cycles' concentrations."""
    out = []
    for k, v in enumerate(values):
        for j in range(int(rate_hz)):
            p.add_sample(t0 + k + j / rate_hz, v)
        out.append(p.cycle(t0 + k + 1.0).concentration)
    return out


def test_a_reading_stuck_above_zero_is_dropped_until_it_changes() -> None:
    # the helper's stuck fluorometer: 0.358 to the last bit while the vehicle moved 100 m+
    p = make()
    p.set_pose(Pose(50, 0))
    got = sampled(p, [0.1, 0.358, 0.358, 0.358, 0.358, 0.358, 0.4])
    assert got[:4] == [0.1, 0.358, 0.358, 0.358]  # 3 s not yet reached within them
    assert math.isnan(got[4]) and math.isnan(got[5])  # stuck: no observation, no detection
    assert got[6] == 0.4  # it changed: read again
    assert p.stuck_samples == 18  # the samples of t = 4.0-5.9 s, 3 s after the first 0.358


def test_a_stuck_reading_below_the_threshold_is_no_clean_water_either() -> None:
    p = make()
    p.set_pose(Pose(50, 0))
    got = sampled(p, [0.162] * 6)
    assert all(math.isnan(c) for c in got[4:])  # neither plume nor a miss


def test_zeros_and_varying_readings_are_never_stuck() -> None:
    p = make()
    p.set_pose(Pose(50, 0))
    assert sampled(p, [0.0] * 10) == [0.0] * 10  # clean water reads 0: normal
    varying = [0.3 + 0.01 * k for k in range(10)]
    assert sampled(p, varying, t0=10.0) == varying
    assert p.stuck_samples == 0


def test_a_filter_decaying_to_the_smallest_float_is_not_stuck() -> None:
    # AB's low-pass filter in clean water ends at 5e-324 exactly and stays there
    p = make()
    p.set_pose(Pose(50, 0))
    assert sampled(p, [5e-324] * 6) == [5e-324] * 6 and p.stuck_samples == 0
    # a reading stuck below zero (a sensor's offset) is as stuck as one above
    assert all(math.isnan(c) for c in sampled(p, [-0.05] * 6, t0=6.0)[4:])


def test_the_stuck_timer_runs_on_the_planner_clock() -> None:
    # a NaN time stamp, or a clock stepped back, does not restart a stuck reading's timer
    p = make()
    p.set_pose(Pose(50, 0))
    p.add_sample(math.nan, 0.5)
    got = sampled(p, [0.5] * 6)
    assert all(math.isnan(c) for c in got[4:]), got


def test_dropouts_do_not_hide_a_frozen_sensor() -> None:
    # a review: a reading frozen at 0.5 with 10% of samples dropped (NaN) was dropped as stuck
    # for 54 of ~1080 samples (0 at 30%): each NaN had restarted the "same reading" timer
    p = make()
    p.set_pose(Pose(50, 0))
    got = []
    for k in range(8):
        for j in range(9):
            p.add_sample(k + j / 9.0, math.nan if j % 3 == 1 else 0.5)  # a third dropped
        got.append(p.cycle(k + 1.0).concentration)
    assert got[:3] == [0.5] * 3 and all(math.isnan(c) for c in got[4:]), got
    assert p.stuck_samples == 6 + 4 * 6  # from t = 3 s on, the non-NaN samples
    # the dropouts are told too (a review's dead sensor, dropout_prob 1, looked like clean water)
    assert p.missing_samples == 8 * 3 and p.faults()["missing_samples"] == 24


def test_stuck_detection_can_be_turned_off() -> None:
    p = Perception(AREA, PerceptionSettings(threshold=0.2, stuck_after_s=None))
    p.set_pose(Pose(50, 0))
    assert sampled(p, [0.5] * 8) == [0.5] * 8 and p.stuck_samples == 0


def test_the_fleet_drops_stuck_readings_as_the_scalar_perception_does() -> None:
    import numpy as np

    from cptbt.fleet import FleetPerception

    rows = [  # per vehicle, a value per second
        [0.358] * 8,                      # stuck above the threshold
        [0.162] * 8,                      # stuck below it
        [0.0] * 8,                        # clean water
        [0.3, 0.31, 0.3, 0.31, 0.3, 0.31, 0.3, 0.31],  # varying
        [0.5, 0.5, math.nan, 0.5, 0.5, 0.5, 0.5, 0.5],  # a dropout does not break the run
        [math.inf] * 4 + [0.5] * 4,       # inf: a fault of its own, never a stuck reading
        [5e-324] * 8,                     # a filter's decay in clean water: not stuck
    ]
    scalars = [make() for _ in rows]
    fleet = FleetPerception(len(rows), AREA, scalars[0].settings)
    ids = np.arange(len(rows))
    fleet.set_poses(ids, np.full(len(rows), 50.0), np.zeros(len(rows)), np.zeros(len(rows)))
    for p in scalars:
        p.set_pose(Pose(50, 0))
    for k in range(8):
        for j in range(9):
            t = k + j / 9.0
            values = np.array([r[k] for r in rows])
            for p, v in zip(scalars, values, strict=True):
                p.add_sample(t, float(v))
            fleet.add_samples(ids, values, t)
        out = fleet.cycle(k + 1.0, ids)
        want = [p.cycle(k + 1.0) for p in scalars]
        np.testing.assert_array_equal(out.concentration, [w.concentration for w in want])
        np.testing.assert_array_equal(out.detected, [w.detected for w in want])
    assert fleet.stuck_samples.tolist() == [p.stuck_samples for p in scalars]
    assert fleet.stuck_samples[0] > 0 and fleet.stuck_samples[2] == 0
    assert [fleet.faults(i) for i in ids] == [p.faults() | {"clock_corrections": 0}
                                              for p in scalars]
    assert fleet.missing_samples.tolist() == [0, 0, 0, 0, 9, 36, 0]


def test_the_scripted_perception_reads_a_script_as_written_unless_asked() -> None:
    # a test scripting plume for a while must not see it vanish as a frozen sensor
    from cptbt.testing import ScriptedPerception

    script = ScriptedPerception(AREA)
    assert all(script.step(t, 50.0, 0.0, conc=1.0).detected for t in range(10))
    faulty = ScriptedPerception(AREA, stuck_after_s=3.0)
    got = [faulty.step(t, 50.0, 0.0, conc=1.0).detected for t in range(10)]
    assert got[:3] == [True] * 3 and not any(got[4:])


def test_a_flow_sample_stamped_far_ahead_does_not_hold_the_window_open() -> None:
    # A review: one ADCP sample stamped 4e9 s sat at the window's front for good, so the
    # 100-s mean became an all-time mean (2 991 samples) and read -63.6 deg after a turn to -90.
    p = Perception(square_area(100), PerceptionSettings(flow_window_s=100))
    p.set_pose(Pose(50, 0, 0))
    for k in range(1500):
        if k == 10:
            p.add_flow(4e9, 0.1, 0.0)
        p.add_flow(float(k), 0.1, 0.0) if k < 1000 else p.add_flow(float(k), 0.0, -0.1)
        pc = p.cycle(float(k))
    assert pc.flow is not None and pc.flow.toward_deg == pytest.approx(-90.0)
    assert len(p._flows) <= 101 and p.faults()["rejected_flow_samples"] == 1


@pytest.mark.parametrize("stamp", [1e300, 1e17, 5e4])
def test_one_absurd_time_stamp_neither_freezes_nor_leaps_the_clock(stamp: float) -> None:
    # A review: after a stamp of 1e300 the planner clock stood still (1e300 + 1 == 1e300) and
    # one detection held in_plume for good; 1e17 made every cycle 16 s long.
    p = Perception(square_area(100), PerceptionSettings(lambda_s=8.5))
    p.set_pose(Pose(50, 0, 0))
    times = []
    for k in range(100):
        t = stamp if k == 50 else float(k)
        if k == 60:
            p.add_sample(t, 1.0)  # one detection
        times.append(p.cycle(t).t)
    steps = [b - a for a, b in itertools.pairwise(times)]
    assert all(0.5 <= d <= 1.5 for d in steps), steps  # one nominal period each, no leap
    assert not p.latest.in_plume  # 39 s after the detection: contact lost after lambda_s
    assert p.clock_corrections >= 1


@pytest.mark.parametrize("first", [1e300, 1e20, 1e17, 1e16])
def test_an_absurd_first_time_stamp_neither_freezes_nor_races_the_clock(first: float) -> None:
    # A review: the leap check needs an earlier cycle, so a *first* stamp of 1e20 or 1e300 froze
    # the clock (t0 + k == t0): the flow window stayed empty, the planner silent for 600 cycles,
    # and one detection in_plume for good; 1e17 ran it 16 times fast (one float step a cycle).
    p = Perception(square_area(100), PerceptionSettings(lambda_s=8.5, flow_window_s=100))
    p.set_pose(Pose(50, 0, 0))
    times = []
    for k in range(60):
        t = first + k
        p.add_flow(t, 0.1, 0.0)
        if k == 5:
            p.add_sample(t, 1.0)
        times.append(p.cycle(t).t)
    steps = [b - a for a, b in itertools.pairwise(times)]
    assert all(d == pytest.approx(1.0) for d in steps), steps
    assert p.latest is not None and not p.latest.in_plume  # lost 8.5 s after the detection
    assert p.latest.flow is not None and p.latest.flow.toward_deg == pytest.approx(0.0)


def test_unusable_stamps_count_the_planning_period() -> None:
    # A review of the change: with every stamp beyond MAX_STAMP_S (epoch milliseconds sent as
    # seconds) 10-Hz cycles counted 1 s each, ten times fast.
    p = Perception(square_area(100), nominal_period_s=0.1)
    p.set_pose(Pose(50, 0, 0))
    times = [p.cycle(1.7e12 + 100 * k).t for k in range(5)]
    assert times == pytest.approx([0.0, 0.1, 0.2, 0.3, 0.4])


def test_epoch_seconds_are_elapsed_time() -> None:
    p = Perception(square_area(100))
    p.set_pose(Pose(50, 0, 0))
    assert [p.cycle(1.7e9 + k).t for k in range(3)] == [1.7e9, 1.7e9 + 1, 1.7e9 + 2]
    assert p.clock_corrections == 0


def test_a_forward_jump_within_an_hour_is_elapsed_time() -> None:
    p = Perception(square_area(100))
    p.set_pose(Pose(50, 0, 0))
    p.cycle(0.0)
    p.cycle(1.0)
    assert p.cycle(601.0).t == 601.0 and p.clock_corrections == 0  # a 10-min link outage


def test_a_sample_delivered_after_its_cycle_is_dropped_and_counted() -> None:
    """A review's samples, delivered 20 s late with their true stamps, were each placed where
    the vehicle was on arrival (a false declaration 15.7 m off): one taken before the previous
    cycle's period is dropped; one up to a period late still counts."""
    p = make()
    p.set_pose(Pose(50, 0))
    p.cycle(10.0)
    p.add_sample(9.5, 0.3)  # within the period before the previous cycle: transport jitter
    assert p.cycle(11.0).concentration == 0.3
    p.add_sample(2.0, 5.0)  # taken 9 s before the previous cycle
    per = p.cycle(12.0)
    assert math.isnan(per.concentration) and not per.detected
    assert p.faults()["late_samples"] == 1


def test_a_clock_step_back_is_no_late_delivery() -> None:
    """A diff review: after the clock stepped back 60 s, the next cycle's in-plume samples were
    dropped as late; held until the cycle, they count once it finds the step."""
    p = make()
    p.set_pose(Pose(50, 0))
    for t in range(100, 111):
        p.cycle(float(t))
    for k in range(1, 10):
        p.add_sample(50.0 + k / 10, 0.9)
    per = p.cycle(51.0)
    assert per.concentration == 0.9 and per.detected
    assert p.faults()["late_samples"] == 0 and p.faults()["clock_corrections"] == 1


def test_a_stuck_reading_across_a_clock_step_back_stays_dropped() -> None:
    """Samples held aside as possibly late skipped the stuck check: a sensor frozen at 0.9
    gave a detection at the cycle that found the clock stepped back."""
    p = make()
    p.set_pose(Pose(50, 0))
    assert all(math.isnan(c) for c in sampled(p, [0.9] * 10, t0=100.0)[4:])
    for k in range(1, 10):
        p.add_sample(50.0 + k / 10, 0.9)  # stamped after a step back of the clock
    per = p.cycle(51.0)
    assert math.isnan(per.concentration) and not per.detected
    assert p.faults()["clock_corrections"] == 1 and p.faults()["late_samples"] == 0
    stuck = p.stuck_samples
    for k in range(1, 10):  # the reading changes: read again
        p.add_sample(51.0 + k / 10, 0.3)
    assert p.cycle(52.0).concentration == 0.3 and p.stuck_samples == stuck


def test_held_samples_are_judged_stuck_one_by_one() -> None:
    """A diff review: held samples were dropped as stuck only when every one read the frozen
    value, so a sensor frozen at 0.9 that recovered to 0.0 within the held cycle gave a
    detection of 0.9."""
    p = make()
    p.set_pose(Pose(50, 0))
    sampled(p, [0.9] * 10, t0=100.0)
    for k in range(1, 9):
        p.add_sample(50.0 + k / 10, 0.9)  # after a step back of the clock, still frozen ...
    p.add_sample(50.95, 0.0)  # ... then clean water
    per = p.cycle(51.0)
    assert per.concentration == 0.0 and not per.detected


def test_lateness_is_judged_against_a_second_not_a_10_hz_period() -> None:
    """A diff review: at 10 Hz, the measured period (0.1 s) dropped every sample of a steady
    0.25-s latency; the measured period after a gap (up to 60 s) kept a minute-old one."""
    p = Perception(AREA, PerceptionSettings(threshold=0.2, lambda_s=2.0), nominal_period_s=0.1)
    p.set_pose(Pose(50, 0))
    p.cycle(10.0)
    p.add_sample(9.75, 0.5)  # 0.25 s of latency
    assert p.cycle(10.1).concentration == 0.5
    p.cycle(70.0)  # a 60-s gap
    p.add_sample(15.0, 5.0)
    assert math.isnan(p.cycle(70.1).concentration) and p.faults()["late_samples"] == 1


def test_a_current_sensor_gone_silent_is_said_once(caplog: pytest.LogCaptureFixture) -> None:
    """A field re-test: a current sensor dead after the take-over went unnoticed while the AMP
    planned 920 s on the held flow average. The estimate is still held (the planner goes on),
    and the outage is said once."""
    p = make()
    p.set_pose(Pose(50, 0))
    for k in range(10):
        p.add_flow(float(k), 0.1, 0.0)
        p.cycle(float(k) + 0.5)
    with caplog.at_level("WARNING", logger="cptbt.perception"):
        for k in range(10, 300):
            per = p.cycle(float(k))
        assert per.flow is not None and per.flow.vx == pytest.approx(0.1)
        said = [r for r in caplog.records if "no flow sample for" in r.getMessage()]
        assert len(said) == 1
        p.add_flow(300.0, 0.1, 0.0)  # back ...
        p.cycle(300.5)
        for k in range(301, 500):  # ... and gone again: said again
            p.cycle(float(k))
        assert len([r for r in caplog.records if "no flow sample for" in r.getMessage()]) == 2
    # ... and counted for the run's summary: the cycles planned on the held estimate (the
    # sample of t = 9 leaves the 100-s window at t = 109, that of t = 300 at t = 400)
    assert p.settings.flow_window_s == 100.0
    assert p.faults()["flow_held_cycles"] == (300 - 109) + (500 - 400)


def _four_at_rest():  # type: ignore[no-untyped-def]
    """Four scalar perceptions and a fleet one of four vehicles, all at (50, 0)."""
    import numpy as np

    from cptbt.fleet import FleetPerception

    scalars = [make() for _ in range(4)]
    fleet = FleetPerception(4, AREA, scalars[0].settings)
    ids = np.arange(4)
    fleet.set_poses(ids, np.full(4, 50.0), np.zeros(4), np.zeros(4))
    for p in scalars:
        p.set_pose(Pose(50, 0))
    return scalars, fleet, ids


def test_the_fleet_counts_held_flow_cycles_as_the_scalar_perception_does() -> None:
    """The held-flow count (the summary's ``flow_held_cycles``) of the fleet's perception is
    the scalar one's: a sensor that goes silent, one whose samples are all rejected (too fast),
    one that never had an estimate (nothing held), one that keeps reporting."""
    import numpy as np


    scalars, fleet, ids = _four_at_rest()
    for k in range(400):
        t = float(k)
        vx = np.array([0.1 if k < 20 else math.nan, 0.1 if k < 30 else 9.0,
                       math.nan, 0.2])
        for p, v in zip(scalars, vx, strict=True):
            p.add_flow(t, float(v), 0.0)
        fleet.add_flows(t, ids, vx, np.zeros(4))
        fleet.cycle(t + 0.5, ids)
        for p in scalars:
            p.cycle(t + 0.5)
    held = [p.faults()["flow_held_cycles"] for p in scalars]
    assert held == [400 - 119, 400 - 129, 0, 0]
    assert [fleet.faults(i)["flow_held_cycles"] for i in ids] == held


def test_a_fluorometer_gone_silent_is_said_and_counted(caplog: pytest.LogCaptureFixture) -> None:
    """A field review: the fluorometer's samples cut at t = 200 s, the planner blind for 780
    cycles, and the run timed out with nothing said and every fault count at 0. The cycles with
    no reading are counted (``blind_cycles``), the outage said once when it reaches
    SILENT_SENSOR_S, and the readings coming back said too."""
    from cptbt.perception import SILENT_SENSOR_S

    p = make()
    p.set_pose(Pose(50, 0))
    assert math.isnan(p.cycle(0.0).concentration)  # a first cycle before the first sample
    with caplog.at_level("WARNING", logger="cptbt.perception"):
        for k in range(1, 200):
            p.add_sample(k - 0.5, 0.0)
            p.cycle(float(k))
        assert p.faults()["blind_cycles"] == 0  # not a fault: the sensor had not started
        for k in range(200, 230):  # silent from t = 200
            p.cycle(float(k))
        said = [r.getMessage() for r in caplog.records]
        assert len(said) == 1 and said[0].startswith(
            f"no fluorometer reading kept for {SILENT_SENSOR_S:.1f} s (t = 209.0 s"), said
        p.add_sample(229.5, 0.0)
        p.cycle(230.0)
        assert caplog.records[-1].getMessage().startswith(
            "fluorometer readings back at t = 230.0 s, after 31.0 s")
        # an attacker's sensor off 11 s, on 11 s: outages 1, 10 and 100 said, not each one
        k = 231
        for _ in range(120):
            for _ in range(11):
                p.cycle(float(k))
                k += 1
            p.add_sample(k - 0.5, 0.0)
            p.cycle(float(k))
            k += 1
        assert len(caplog.records) == 2 + 2 * 2  # outages 10 and 100, each with its end
    assert p.faults()["blind_cycles"] == 30 + 120 * 11


def test_a_fluorometer_that_never_starts_counts_once_it_is_late() -> None:
    """No reading at all: the cycles count once the sensor is SILENT_SENSOR_S late, from the
    first; the fleet's perception counts as the scalar one does (a sensor that stops, one
    that never starts, one late by less, one that keeps reporting)."""
    import numpy as np


    scalars, fleet, ids = _four_at_rest()
    for k in range(60):
        t = float(k)
        c = np.array([0.0 if k < 20 else math.nan, math.nan, 0.0 if k >= 5 else math.nan,
                      0.1 + 1e-3 * k])  # the last changing: not a stuck reading
        for p, v in zip(scalars, c, strict=True):
            p.add_sample(t, float(v))
        fleet.add_samples(ids, c, t)
        fleet.cycle(t + 0.5, ids)
        for p in scalars:
            p.cycle(t + 0.5)
    blind = [p.faults()["blind_cycles"] for p in scalars]
    assert blind == [40, 60, 0, 0]
    assert [fleet.faults(i)["blind_cycles"] for i in ids] == blind


def test_a_non_finite_heading_keeps_the_previous_one() -> None:
    """An attacker's heading noise of 1.7e308 gave NaN headings, read as 0 (north)."""
    import numpy as np

    from cptbt.fleet_perception import FleetPerception
    from cptbt.frames import OpArea
    from cptbt.perception import Perception
    from cptbt.types import Pose

    p = Perception(OpArea(0, 100, -50, 50))
    p.set_pose(Pose(10.0, 0.0, 135.0))
    p.set_pose(Pose(11.0, 0.0, float("nan")))
    assert (p.pose.x, p.pose.heading_deg) == (11.0, 135.0)
    fleet, ids = FleetPerception(1, OpArea(0, 100, -50, 50)), np.array([0])  # the same rule
    fleet.set_poses(ids, np.array([10.0]), np.array([0.0]), np.array([135.0]))
    fleet.set_poses(ids, np.array([11.0]), np.array([0.0]), np.array([np.nan]))
    assert fleet.poses(ids)[0][0] == 11.0 and fleet._heading[0] == 135.0
