"""Infotaxis and space-aware infotaxis, tick by tick with scripted perception (issue 14).

The Poisson map's update is checked against the planning rate; the decision on scripted hits (a
detection turns the searcher up-flow and concentrates the belief), on no hits at all (it
explores), and on a belief concentrated by hand (SAI heads for it); the reacquire variant's
activation window; the registry's conformance check on all four variants.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from cptbt.angles import wrap_deg
from cptbt.behaviours.infotaxis import (
    InfotaxisFindPlume,
    InfotaxisParams,
    InfotaxisReacquire,
    InfotaxisReacquireParams,
    PoissonSourceMap,
    SpaceAwareInfotaxisFindPlume,
    score_moves,
)
from cptbt.registry import default_registry
from cptbt.testing import (
    FakeVehicle,
    ScriptedPerception,
    TreeHarness,
    check_behaviour,
    fresh_namespace,
    make_context,
    run_script,
    square_area,
)

AREA = square_area(100.0)  # x 0..100, y -50..50
FLOW = (1.0, 0.0)  # toward +x: up-flow is -x, heading 180


def entropy_bits(p: np.ndarray) -> float:
    q = p[p > 0]
    return float(-(q * np.log2(q)).sum())


@pytest.mark.parametrize("variant", ["infotaxis", "space_aware_infotaxis"])
@pytest.mark.parametrize("family", ["find_plume", "reacquire_plume"])
def test_conformance(family: str, variant: str) -> None:
    check_behaviour(default_registry().get(family, variant))


def test_non_detections_do_not_depend_on_the_planning_rate() -> None:
    """Poisson hits: ten 0.1 s cycles without a hit say what one 1 s cycle says."""
    slow = PoissonSourceMap(AREA, InfotaxisParams())
    fast = PoissonSourceMap(AREA, InfotaxisParams())
    s1, s2 = ScriptedPerception(AREA, flow=FLOW), ScriptedPerception(AREA, flow=FLOW)
    for t in range(20):  # the same flow history, then the vehicle sits at (60, 0) for 3 s
        slow.observe(s1.step(t, 99.0, 49.0))
        fast.observe(s2.step(t, 99.0, 49.0))
    for t in range(1, 4):
        slow.observe(s1.step(19 + t, 60.0, 0.0))
    for k in range(1, 31):
        fast.observe(s2.step(19 + 0.1 * k, 60.0, 0.0))
    a, b = slow.posterior(), fast.posterior()
    assert entropy_bits(a) < math.log2(a.size) - 0.05  # the misses did say something
    np.testing.assert_allclose(a, b, rtol=0.02, atol=1e-12)


def test_a_detection_turns_it_up_flow_and_concentrates_the_belief() -> None:
    node = InfotaxisFindPlume(namespace=fresh_namespace())
    script = ScriptedPerception(AREA, flow=FLOW, lambda_s=1.0)
    percepts = [script.step(t, 70.0, 30.0 + t) for t in range(5)]  # crossing, no hits
    percepts += [script.step(5, 70.0, 0.0, conc=1.0), script.step(6, 70.0, 0.5, conc=1.0)]
    harness = TreeHarness(node, make_context(AREA))
    ticks = harness.run(percepts)
    assert node.map is not None
    post = node.map.posterior()
    cx, _ = node.map.cells()
    assert post[cx < 70].sum() > 0.9  # the source is up-flow of the hits
    assert entropy_bits(post) < math.log2(post.size) - 1.0
    heading = ticks[-1].command.heading_deg  # type: ignore[union-attr]
    assert abs(wrap_deg(heading - 180.0)) <= 45.0, heading


def test_with_no_hits_it_explores() -> None:
    """Closed loop, never a hit: it casts across the flow down-flow of the unexplored water (a
    miss there rules out every source up-flow of it), back and forth over the whole width, and
    the belief learns from the misses."""
    node = SpaceAwareInfotaxisFindPlume(namespace=fresh_namespace())
    harness = TreeHarness(node, make_context(AREA))
    script = ScriptedPerception(AREA, flow=FLOW)
    vehicle = FakeVehicle(80.0, 0.0, 180.0)
    track = []
    for i in range(300):
        t = i * 1.0
        tk = harness.tick(script.step(t, vehicle.x, vehicle.y, vehicle.heading_deg))
        assert tk.command is not None
        vehicle.apply(tk.command, 1.0)
        track.append((vehicle.x, vehicle.y))
    xy = np.array(track)
    assert np.ptp(xy[:, 1]) > 80  # the whole width of the OpArea
    legs = np.sign(np.diff(xy[::10, 1]))
    assert np.count_nonzero(np.diff(legs[legs != 0])) >= 2  # back and forth
    assert node.map is not None
    post = node.map.posterior()
    assert entropy_bits(post) < math.log2(post.size) - 0.5


def test_space_aware_heads_for_a_concentrated_belief() -> None:
    """With the belief all within a few metres of a point 30 m off, SAI's best move is toward it,
    where plain infotaxis weighs only what it would learn."""
    m = PoissonSourceMap(AREA, InfotaxisParams())
    script = ScriptedPerception(AREA, flow=FLOW)
    for t in range(5):
        m.observe(script.step(t, 99.0, 49.0))
    cx, cy = m.cells()
    post = np.exp(-((cx - 30.0) ** 2 + (cy - 20.0) ** 2) / (2 * 3.0**2))
    post /= post.sum()
    angles = np.radians(np.arange(8) * 45.0)
    here = (60.0, 20.0)
    targets = np.column_stack([here[0] + 6 * np.cos(angles), here[1] + 6 * np.sin(angles)])
    sai = score_moves(m, post, targets, InfotaxisParams(), space_aware=True)
    assert int(np.argmin(sai)) == 4  # heading 180: straight at the belief


def test_find_plume_waits_for_the_field_and_a_flow() -> None:
    node = InfotaxisFindPlume(namespace=fresh_namespace())
    script = ScriptedPerception(AREA, flow=FLOW)
    ticks = run_script(node, [script.step(0, 50, 0)], make_context(AREA), field_reached=False)
    assert ticks[0].command is None


def test_reacquire_is_active_from_the_loss_of_contact_until_it_gives_up() -> None:
    node = InfotaxisReacquire(InfotaxisReacquireParams(give_up_s=10),
                              namespace=fresh_namespace())
    script = ScriptedPerception(AREA, flow=FLOW, lambda_s=2.0)
    percepts = [script.step(0, 60, 0)]  # no contact yet
    percepts += [script.step(1, 60, 0, conc=1.0)]  # in the plume
    percepts += [script.step(t, 60, 0) for t in (2, 4, 8, 12)]  # lost at 4 s; gives up after 11
    ticks = run_script(node, percepts, make_context(AREA))
    active = [tk.command is not None for tk in ticks]
    assert active == [False, False, False, True, True, False]
