"""AB 2001 Strategies I–III (SPEC §5c, §6c), tick by tick at 10 Hz.

Times are on the grid t = k/10 (k an int). Flow toward +x, so psi_u = 180°. λ = 1 s and T_W = 4 s
(AB Table 3). The last detection of each contact is at an exactly representable time (1.5 s or
3.0 s), so "in the plume" ends exactly at t_last + 1.0 and the cast exactly at t_last + 4.0.
"""

from __future__ import annotations

from collections.abc import Iterable

import py_trees
import pytest
from py_trees.common import Access
from pydantic import ValidationError

from cptbt.behaviours.strategies import (
    BEHAVIOURS,
    ConstantBetaCast,
    ConstantBetaMaintain,
    ConstantBetaParams,
    StrategyICast,
    StrategyIICast,
    StrategyIIICast,
    StrategyIIIMaintain,
    StrategyIIIParams,
    StrategyIIMaintain,
    StrategyIMaintain,
    StrategyIParams,
)
from cptbt.mission import BehaviourEntry
from cptbt.node import PlanBehaviour
from cptbt.registry import BehaviourSpec, Registry
from cptbt.testing import ScriptedPerception, TreeHarness, check_behaviour, fresh_namespace
from cptbt.tree import build_tree
from cptbt.types import Percept

Expected = list[tuple[int, float | None]]


def span(k0: int, k1: int, heading: float | None) -> Expected:
    """Ticks k0..k1 inclusive, all expecting ``heading`` (None = no output)."""
    return [(k, heading) for k in range(k0, k1 + 1)]


def script(
    ks: Iterable[int], detect: set[int], heading: dict[int, float], default_heading: float = 90.0
) -> list[Percept]:
    """One percept per k at t = k/10, vehicle at (50, 0), detecting on ``detect``."""
    sp = ScriptedPerception(flow=(1.0, 0.0), lambda_s=1.0)
    return [
        sp.step(k / 10, 50.0, 0.0, heading.get(k, default_heading), 1.0 if k in detect else 0.0)
        for k in ks
    ]


def pair(maintain: PlanBehaviour, cast: PlanBehaviour) -> py_trees.composites.Selector:
    return py_trees.composites.Selector("pair", memory=False, children=[maintain, cast])


def check(h: TreeHarness, percepts: list[Percept], expected: Expected) -> None:
    """Tick and compare each tick's heading (None for FAILURE) with the hand-derived one."""
    assert [round(p.t * 10) for p in percepts] == [k for k, _ in expected]
    got = []
    for p in percepts:
        tk = h.tick(p)
        got.append(None if tk.command is None else round(tk.command.heading_deg, 9))
        assert (tk.status == py_trees.common.Status.RUNNING) == (tk.command is not None)
    assert list(zip((k for k, _ in expected), got, strict=True)) == expected


def write_key(namespace: str, key: str, value: object) -> None:
    client = py_trees.blackboard.Client(name="test-writer")
    client.register_key(f"{namespace}/{key}", access=Access.WRITE)
    client.set(f"{namespace}/{key}", value)


@pytest.mark.parametrize(
    ("rule", "heading", "cast", "cast_sign"),
    [
        # opposite_wind_change (AB §4.1): heading 170 trails an upflow that has turned + (from
        # ~170 to 180), i.e. the wind turned +: cast the other way, toward the older wind's
        # plume: sign(wrap(180 - 170)) = +1 → psi_u - 90 = 90, the side the heading points to.
        ("opposite_wind_change", 170.0, 90.0, 1),
        # heading 190: the upflow turned - → sign(wrap(180 - 190)) = -1 → 180 + 90 = 270 ≡ -90.
        ("opposite_wind_change", 190.0, -90.0, -1),
        # lagging_heading (the former reading of eqs. 7–8): wrap(170 - 180) = -10 → gamma = -90
        # → psi_u - gamma = 180 + 90 = 270 ≡ -90, casting with the wind's change.
        ("lagging_heading", 170.0, -90.0, -1),
        # heading 190: wrap(190 - 180) = +10 → gamma = +90 → 180 - 90 = 90.
        ("lagging_heading", 190.0, 90.0, 1),
    ],
)
def test_strategy_1_pair_surges_upflow_then_casts_by_its_rule(
    rule: str, heading: float, cast: float, cast_sign: int
) -> None:
    # k 10-12 never detected: no output. Detections at 1.3, 1.4, 1.5: in the plume until
    # 1.5 + λ = 2.5 → psi_u = 180. From 2.6 to 1.5 + T_W = 5.5: cast. From 5.6: give up.
    ns = fresh_namespace()
    params = StrategyIParams(cast_rule=rule)  # type: ignore[arg-type]
    h = TreeHarness(pair(StrategyIMaintain(params, namespace=ns), StrategyICast(namespace=ns)))
    expected = span(10, 12, None) + span(13, 25, 180.0) + span(26, 55, cast) + span(56, 57, None)
    check(h, script(range(10, 58), {13, 14, 15}, {}, heading), expected)
    assert h.get("cast_sign") == cast_sign
    assert h.get("casting") is False


def test_strategy_1_cast_sign_is_taken_on_the_last_in_plume_tick() -> None:
    # The heading swings from 170 (k ≤ 20) to 185 (k ≥ 21) while still in the plume (to 2.5):
    # the cast follows the sign at T_Lost = 2.5: sign(wrap(180 - 185)) = -1 → 270 ≡ -90.
    ns = fresh_namespace()
    h = TreeHarness(pair(StrategyIMaintain(namespace=ns), StrategyICast(namespace=ns)))
    headings = {k: 185.0 for k in range(21, 30)}
    expected = span(13, 25, 180.0) + span(26, 29, -90.0)
    check(h, script(range(13, 30), {13, 14, 15}, headings, 170.0), expected)
    assert h.get("cast_sign") == -1


def test_strategy_1_maintain_alone_has_output_only_in_the_plume() -> None:
    ns = fresh_namespace()
    h = TreeHarness(StrategyIMaintain(namespace=ns))
    expected = span(10, 12, None) + span(13, 25, 180.0) + span(26, 30, None)
    check(h, script(range(10, 31), {13, 14, 15}, {}, 170.0), expected)
    assert h.get("cast_sign") == 1  # opposite_wind_change: sign(wrap(180 - 170))


def test_strategy_1_default_rule_is_the_paper_s() -> None:
    assert StrategyIParams().cast_rule == "opposite_wind_change"
    with pytest.raises(ValidationError):
        StrategyIParams(cast_rule="with_wind_change")  # type: ignore[arg-type]


def test_cast_alone_sign_sources_and_give_up() -> None:
    # One detection at 1.5: in plume to 2.5, cast 2.6..5.5, none from 5.6.
    # No cast_sign / beta_sign on the blackboard → +1 → 180 - 90 = 90.
    h = TreeHarness(StrategyICast(namespace=fresh_namespace()))
    expected = span(15, 25, None) + span(26, 55, 90.0) + span(56, 57, None)
    check(h, script(range(15, 58), {15}, {}), expected)
    # cast_sign = -1 → 180 + 90 = 270 ≡ -90.
    ns = fresh_namespace()
    write_key(ns, "cast_sign", -1)
    h = TreeHarness(StrategyICast(namespace=ns))
    check(h, script(range(15, 28), {15}, {}), span(15, 25, None) + span(26, 27, -90.0))
    # only beta_sign = -1 (e.g. TRO track-out) → the same counterturn, -90.
    ns = fresh_namespace()
    write_key(ns, "beta_sign", -1)
    h = TreeHarness(StrategyICast(namespace=ns))
    check(h, script(range(15, 27), {15}, {}), [*span(15, 25, None), (26, -90.0)])


def test_strategy_2_pair_counterturns_and_flips_beta_on_reacquisition() -> None:
    # Contact 1 entered at 1.3 heading 90 (+y): wrap(90 - 180) = -90 → beta sign -1.
    #   1.3-1.5 detecting: psi_u = 180; 1.6-2.5 within λ: 180 - 35 = 145 (still moving +y).
    #   2.6-2.9 cast: 180 - 90*(-1) = 270 ≡ -90 (counterturn toward -y).
    # Contact 2 at 3.0 while casting: a reacquisition → sign flips to +1 (the heading, 90, would
    #   have said -1). 3.0 detecting: 180; 3.1-4.0: 180 + 35 = 215 ≡ -145; 4.1-7.0 cast:
    #   180 - 90 = 90; 7.1: 4.1 s after the last detection > T_W → give up.
    # Contact 3 at 7.2 found after giving up: sign from the entry heading -90:
    #   wrap(-90 - 180) = 90 → +1 (a flip would have given -1). 7.2: 180; 7.3: -145.
    ns = fresh_namespace()
    h = TreeHarness(pair(StrategyIIMaintain(namespace=ns), StrategyIICast(namespace=ns)))
    expected = span(10, 12, None) + span(13, 15, 180.0) + span(16, 25, 145.0)
    expected += [*span(26, 29, -90.0), (30, 180.0), *span(31, 40, -145.0), *span(41, 70, 90.0)]
    expected += [(71, None), (72, 180.0), (73, -145.0)]
    percepts = script(range(10, 74), {13, 14, 15, 30, 72}, {72: -90.0, 73: -90.0})
    check(h, percepts, expected)
    assert h.get("beta_sign") == 1


def test_strategy_2_maintain_alone_flips_only_when_the_cast_was_running() -> None:
    # Contact 1 at 1.3, heading 90 → -1: 145 within λ. The test plays the cast's part by
    # writing casting = True; contact 2 at 3.0 (heading 90 again) then flips to +1: -145.
    ns = fresh_namespace()
    h = TreeHarness(StrategyIIMaintain(namespace=ns))
    percepts = script(range(13, 32), {13, 30}, {})
    check(h, percepts[:4], [(13, 180.0), (14, 145.0), (15, 145.0), (16, 145.0)])
    write_key(ns, "casting", True)
    check(h, percepts[17:], [(30, 180.0), (31, -145.0)])


def test_constant_beta_pair_holds_beta_through_detections_and_flips_on_reacquisition() -> None:
    # AB eq. 4 / Fig. 3: beta is held on detecting cycles too (Strategy II's test above goes
    # straight upflow, 180, on 1.3-1.5 and 3.0). Contact 1 entered at 1.3 heading 90 → sign -1:
    #   1.3-2.5 (detections at 1.3-1.5, then within λ): 180 - 35 = 145; 2.6-2.9 cast (eq. 5):
    #   180 + 90 = 270 ≡ -90. Contact 2 at 3.0 while casting: the sign flips to +1:
    #   3.0-4.0: 215 ≡ -145; 4.1-7.0 cast: 90; 7.1 give up. Contact 3 at 7.2 after giving up:
    #   sign from the entry heading -90 → +1: -145.
    ns = fresh_namespace()
    h = TreeHarness(pair(ConstantBetaMaintain(namespace=ns), ConstantBetaCast(namespace=ns)))
    expected = span(10, 12, None) + span(13, 25, 145.0)
    expected += [*span(26, 29, -90.0), *span(30, 40, -145.0), *span(41, 70, 90.0)]
    expected += [(71, None), (72, -145.0), (73, -145.0)]
    percepts = script(range(10, 74), {13, 14, 15, 30, 72}, {72: -90.0, 73: -90.0})
    check(h, percepts, expected)
    assert h.get("beta_sign") == 1 and h.get("cast_sign") == 1


def test_constant_beta_zero_is_straight_upflow_and_beta_is_bounded() -> None:
    ns = fresh_namespace()
    h = TreeHarness(ConstantBetaMaintain(ConstantBetaParams(beta_deg=0.0), namespace=ns))
    check(h, script(range(13, 17), {13}, {}), span(13, 16, 180.0))
    with pytest.raises(ValidationError):
        ConstantBetaParams(beta_deg=95.0)


def test_strategy_3_pair_beta_schedule_and_flip() -> None:
    # Contact 1: T_first = 1.3, entry heading 90 → sign -1; psi_v = 180 - |beta(t - T_first)|:
    #   dt 0.0, 0.1 → 10° → 170; dt 0.2 ... 0.5 → 65° → 115; dt 0.6 ... 1.2 → 85° → 95.
    #   Last detection 1.5 → cast 2.6-2.9: 180 + 90 = 270 ≡ -90.
    # Contact 2 at 3.0 while casting → sign +1, T_first = 3.0: psi_v = 180 + |beta|:
    #   dt 0.0, 0.1 → 190 ≡ -170; 0.2-0.5 → 245 ≡ -115; 0.6-1.0 → 265 ≡ -95.
    #   Last detection 3.0 → in plume to 4.0; 4.1: cast 180 - 90 = 90.
    registry = Registry()
    registry.register_all(
        [BehaviourSpec.of(StrategyIIIMaintain), BehaviourSpec.of(StrategyIIICast)]
    )
    entries = [
        BehaviourEntry(family="maintain_plume", variant="strategy_3",
                       params=StrategyIIIParams(timer="contact")),
        BehaviourEntry(
            family="reacquire_plume", variant="strategy_3", params=StrategyIIICast.Params()
        ),
    ]
    h = TreeHarness(build_tree(entries, registry, fresh_namespace()))
    expected = span(10, 12, None) + span(13, 14, 170.0) + span(15, 18, 115.0)
    expected += span(19, 25, 95.0) + span(26, 29, -90.0) + span(30, 31, -170.0)
    expected += span(32, 35, -115.0) + span(36, 40, -95.0) + [(41, 90.0)]
    check(h, script(range(10, 42), {13, 14, 15, 30}, {}), expected)


def test_strategy_3_maintain_alone_schedule_at_0_1_0_3_0_6() -> None:
    # Entry heading -90: wrap(-90 - 180) = 90 → sign +1. T_first = 1.0 (one detection).
    # dt 0.1 → 180 + 10 = 190 ≡ -170; dt 0.3 → 180 + 65 = 245 ≡ -115; dt 0.6 → 265 ≡ -95.
    h = TreeHarness(StrategyIIIMaintain(StrategyIIIParams(timer="contact"),
                                        namespace=fresh_namespace()))
    percepts = script(range(10, 17), {10}, {}, default_heading=-90.0)
    ticks = h.run(percepts)
    headings = {round(tk.t * 10): tk.command.heading_deg for tk in ticks if tk.command}
    assert (headings[11], headings[13], headings[16]) == (-170.0, -115.0, -95.0)


def test_strategy_3_contact_timer_runs_from_the_first_detection() -> None:
    # Detections every 0.1 s from 1.3 to 1.9 (a dense run of filaments), heading 90 → sign -1.
    # contact: dt from T_first = 1.3: 1.3-1.4 → 170; 1.5-1.8 → 115; 1.9 on → 95 although the
    # searcher is still detecting; in the plume to 2.9.
    ns = fresh_namespace()
    contact = StrategyIIIParams(timer="contact")
    h = TreeHarness(pair(StrategyIIIMaintain(contact, namespace=ns), StrategyIIICast(namespace=ns)))
    expected = span(13, 14, 170.0) + span(15, 18, 115.0) + span(19, 29, 95.0) + [(30, -90.0)]
    check(h, script(range(13, 31), set(range(13, 20)), {}), expected)


def test_strategy_3_last_detection_timer_is_the_default() -> None:
    # The reading that reproduces AB's ranking, so that a variant sweep reaching strategy_3
    # (which resets its parameters) does not silently fly the slow letter of eq. 11.
    assert StrategyIIIParams().timer == "last_detection"


def test_strategy_3_last_detection_timer_restarts_at_every_detection() -> None:
    # The same script with timer = last_detection: while detections keep coming every 0.1 s,
    # dt ≤ 0.1 → 10°: 170 from 1.3 to 2.0 (dt 0.1 after 1.9). Then from the last hit (1.9):
    # dt 0.2-0.5 (2.1-2.4) → 115; dt 0.6-1.0 (2.5-2.9) → 95; 3.0 cast: 180 + 90 = 270 ≡ -90.
    ns = fresh_namespace()
    params = StrategyIIIParams(timer="last_detection")
    h = TreeHarness(pair(StrategyIIIMaintain(params, namespace=ns), StrategyIIICast(namespace=ns)))
    expected = span(13, 20, 170.0) + span(21, 24, 115.0) + span(25, 29, 95.0) + [(30, -90.0)]
    check(h, script(range(13, 31), set(range(13, 20)), {}), expected)


def test_strategy_3_last_detection_timer_with_a_gap_inside_the_contact() -> None:
    # Detections at 1.0 and 1.6 (one contact: the gap 0.6 s < λ), entry heading -90 → sign +1.
    # 1.0-1.1 → 190 ≡ -170; 1.2-1.5 → 245 ≡ -115; 1.6 (new hit, dt 0) → -170 again, 1.7 → -170,
    # 1.8 → -115. The contact timer would have given 1.6 → -95 (dt 0.6 from T_first = 1.0).
    ns = fresh_namespace()
    percepts = script(range(10, 19), {10, 16}, {}, default_heading=-90.0)
    params = StrategyIIIParams(timer="last_detection")
    h = TreeHarness(StrategyIIIMaintain(params, namespace=ns))
    expected = span(10, 11, -170.0) + span(12, 15, -115.0) + span(16, 17, -170.0) + [(18, -115.0)]
    check(h, percepts, expected)
    h = TreeHarness(StrategyIIIMaintain(StrategyIIIParams(timer="contact"),
                                        namespace=fresh_namespace()))
    check(h, percepts, span(10, 11, -170.0) + span(12, 15, -115.0) + span(16, 18, -95.0))


def test_strategy_3_beta1_gives_eq_11_s_schedule() -> None:
    # AB eq. 11 with beta_1 = 20: |beta| = 20, 40, 60 at dt 0.1, 0.3, 0.6 from T_first = 1.0;
    # entry heading -90 → sign +1: 180 + 20 = 200 ≡ -160, 220 ≡ -140, 240 ≡ -120. The three
    # beta_*_deg are ignored while beta1_deg is set.
    params = StrategyIIIParams(beta1_deg=20.0, beta_early_deg=1.0, beta_late_deg=2.0)
    h = TreeHarness(StrategyIIIMaintain(params, namespace=fresh_namespace()))
    percepts = script(range(10, 17), {10}, {}, default_heading=-90.0)
    check(h, percepts, span(10, 11, -160.0) + span(12, 15, -140.0) + [(16, -120.0)])
    with pytest.raises(ValidationError):
        StrategyIIIParams(beta1_deg=31.0)  # 3 beta_1 must stay within 90°


def test_strategy_3_timer_is_validated() -> None:
    with pytest.raises(ValidationError):
        StrategyIIIParams(timer="first")  # type: ignore[arg-type]


@pytest.mark.parametrize("spec", BEHAVIOURS, ids=lambda s: s.key)
def test_each_half_declares_its_partner(spec: BehaviourSpec) -> None:
    # The pairing is data that `cptbt validate` checks (tests/core/test_bad_missions.py).
    partner = "reacquire_plume" if spec.family == "maintain_plume" else "maintain_plume"
    assert spec.contract.pairs_with == ((partner, spec.variant),)


def test_schedule_must_be_ordered() -> None:
    with pytest.raises(ValidationError):
        StrategyIIIParams(early_until_s=0.6, mid_until_s=0.5)


@pytest.mark.parametrize("spec", BEHAVIOURS, ids=lambda s: s.key)
def test_conformance(spec: BehaviourSpec) -> None:
    check_behaviour(spec)
