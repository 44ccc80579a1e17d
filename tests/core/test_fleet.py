"""The fleet planner (cptbt.fleet): array forms proven equal to the py_trees leaves, tick by tick.

The differential checks of :mod:`cptbt.testing` drive each behaviour's leaf and its array form
(and whole missions: one Planner per vehicle against one FleetPlanner) through the same random
percept streams in closed loop, and require the same percept, active leaf and command bit for
bit. The engine tests fly real AB groups both ways.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from cptbt.batch.engine import simulate
from cptbt.batch.scenario import to_sim_params
from cptbt.behaviours.safety import OpAreaSafetyFleet
from cptbt.behaviours.strategies_fleet import CrosswindCastFleet, StrategyIIIMaintainFleet
from cptbt.cli.inspect_cmds import load
from cptbt.fleet import fleet_support, planner_choice
from cptbt.fleet_testing import check_fleet_mission, check_fleet_rule, fleet_capable_specs
from cptbt.registry import default_registry

ROOT = Path(__file__).resolve().parents[2]
AB = [ROOT / "missions" / f"ab2001_strategy{k}.yaml" for k in (1, 2, 3)]
SPECS = fleet_capable_specs()


def test_the_ab_behaviours_have_array_forms() -> None:
    keys = {s.key for s in SPECS}
    assert {"safety.oparea", "find_plume.billiard_ab", "find_plume.billiard",
            *(f"{f}.strategy_{k}" for f in ("maintain_plume", "reacquire_plume")
              for k in (1, 2, 3))} <= keys
    for path in AB:
        assert fleet_support(load(str(path))).ok


@pytest.mark.parametrize("spec", SPECS, ids=[s.key for s in SPECS])
def test_array_form_equals_the_leaf(spec) -> None:  # type: ignore[no-untyped-def]
    drove = check_fleet_rule(spec)
    assert drove.get(spec.key, 0) > 100  # the behaviour itself drove, and was pre-empted
    assert drove.get("test.preempt", 0) > 100


@pytest.mark.parametrize("params", [
    {"timer": "contact"}, {"timer": "last_detection", "early_until_s": 0.3, "mid_until_s": 0.3},
])
def test_strategy_3_timers(params: dict[str, object]) -> None:
    spec = default_registry().get("maintain_plume", "strategy_3")
    check_fleet_rule(spec, spec.params(**params), seed=3)


@pytest.mark.parametrize("key,params", [
    ("maintain_plume.strategy_1", {"cast_rule": "lagging_heading"}),
    ("find_plume.billiard_ab", {"reference": "flow", "wall_margin_m": 0.0}),
    ("find_plume.billiard", {"reference": "flow"}),
    ("find_plume.billiard_ab", {"restart": "largest_area"}),
    ("maintain_plume.strategy_3", {"beta1_deg": 20.0}),
    ("safety.oparea", {"trigger_m": 0.0, "release_m": 0.0, "inset_m": 30.0}),
])
def test_parameter_variants(key: str, params: dict[str, object]) -> None:
    spec = default_registry().get(*key.split("."))
    check_fleet_rule(spec, spec.params(**params), seed=5)


@pytest.mark.parametrize("path", [*AB, ROOT / "missions" / "ab2001_fig9_constant.yaml"],
                         ids=lambda p: p.stem)
def test_whole_missions_tick_by_tick(path: Path) -> None:
    drove = check_fleet_mission(load(str(path)), seed=1)
    assert all(drove.get(name, 0) > 50 for name in drove if name)  # every leaf drove
    assert len([name for name in drove if name]) == 4


def test_the_check_catches_a_wrong_array_form(monkeypatch: pytest.MonkeyPatch) -> None:
    # The cast ignores the maintain half's cast sign: only the whole mission shows it.
    def always_plus(self, p, running):  # type: ignore[no-untyped-def]
        self.cast_sign[:] = 0
        self.beta_sign[:] = 0
        return original(self, p, running)

    original = CrosswindCastFleet.decide
    monkeypatch.setattr(CrosswindCastFleet, "decide", always_plus)
    with pytest.raises(AssertionError, match=r"reacquire|!="):
        check_fleet_mission(load(str(AB[2])), seed=1)


def test_the_check_catches_an_off_by_one_threshold(monkeypatch: pytest.MonkeyPatch) -> None:
    def late(self, p):  # type: ignore[no-untyped-def]
        return np.where(p.t - p.last_t <= 0.2, 10.0, 65.0)  # 0.2 s included; 85° never

    monkeypatch.setattr(StrategyIIIMaintainFleet, "beta_magnitude", late)
    with pytest.raises(AssertionError):
        check_fleet_rule(default_registry().get("maintain_plume", "strategy_3"))
    monkeypatch.undo()
    forgetful = OpAreaSafetyFleet.decide
    monkeypatch.setattr(OpAreaSafetyFleet, "decide",  # no hysteresis: safety forgets it drove
                        lambda self, p, running: forgetful(self, p, running & False))
    with pytest.raises(AssertionError):
        check_fleet_mission(load(str(AB[0])), seed=1)


def test_other_trees_keep_the_per_vehicle_planner() -> None:
    tro = load(str(ROOT / "missions" / "tro2006_msn007.yaml"))
    support = fleet_support(tro)
    assert not support.ok and support.reason
    (run,), _, _ = simulate(tro, to_sim_params(tro, 1), [(0.0, 0.0, 0.0)], time_limit_s=5.0)
    assert run.planner is not None  # flown by py_trees
    with pytest.raises(ValueError, match="cannot run"):
        simulate(tro, to_sim_params(tro, 1), [(0.0, 0.0, 0.0)], time_limit_s=5.0,
                 planner="fleet")


def test_auto_flies_a_lone_vehicle_with_py_trees(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("CPTBT_PLANNER", raising=False)
    ab = load(str(AB[2]))
    (run,), _, _ = simulate(ab, to_sim_params(ab, 1), [(50.0, 0.0, 0.0)], time_limit_s=2.0)
    assert run.planner is not None
    runs, _, _ = simulate(ab, to_sim_params(ab, 1), [(50.0, 0.0, 0.0)] * 8, time_limit_s=2.0)
    assert all(r.planner is None for r in runs)


def test_planner_choice(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("CPTBT_PLANNER", "tree")
    assert planner_choice() == "tree"
    assert planner_choice("fleet") == "fleet"
    monkeypatch.setenv("CPTBT_PLANNER", "both")
    with pytest.raises(ValueError, match="auto, fleet or tree"):
        planner_choice()


@pytest.mark.parametrize("path,seed", [(AB[2], 2001), (AB[0], 7),
                                       (ROOT / "missions" / "ab2001_fig9.yaml", 3)],
                         ids=["s3", "s1", "fig9-maintain-criterion"])
def test_ab_groups_fly_identically(path: Path, seed: int) -> None:
    """A few dozen AB missions: same outcome, end time, end distance and path, bit for bit."""
    mission = load(str(path))
    params = to_sim_params(mission, seed)
    rng = np.random.default_rng(seed)
    starts = [(float(x), float(y), 180.0) for x, y in
              zip(rng.uniform(30, 95, 16), rng.uniform(-45, 45, 16), strict=True)]
    flown = {}
    for planner in ("tree", "fleet"):
        runs, _, _ = simulate(mission, params, starts, env_rng=np.random.default_rng(seed),
                              vehicle_rngs=[np.random.default_rng([seed, i]) for i in range(16)],
                              planner=planner, trace=True, time_limit_s=200.0)
        flown[planner] = runs
    for a, b in zip(flown["tree"], flown["fleet"], strict=True):
        assert (a.outcome, a.t_end, a.distance_at_end_m, a.t1, a.lost_contacts) == (
            b.outcome, b.t_end, b.distance_at_end_m, b.t1, b.lost_contacts)
        assert a.time_in == b.time_in
        ta, tb = a.trace, b.trace
        assert ta is not None and tb is not None
        for column in ta:
            ca, cb = np.asarray(ta[column]), np.asarray(tb[column])
            assert np.array_equal(ca, cb, equal_nan=ca.dtype.kind == "f"), column
        assert a.closest_m == b.closest_m
    outcomes = {str(r.outcome) for r in flown["fleet"]}
    assert outcomes & {"found", "contact_lost"}


def test_safety_array_form_stands_aside_homeward_like_the_leaf() -> None:
    """A home outside the OpArea and ``homeward`` flipping at random: the array form of safety
    stands aside for the homeward leg exactly when the py_trees leaf does."""
    spec = default_registry().get("safety", "oparea")
    drove = check_fleet_rule(spec, home=(50.0, -70.0), homeward_rate=0.02, ticks=600)
    assert drove.get(spec.key, 0) > 100


@pytest.mark.parametrize("path", [AB[2], ROOT / "missions/tro2006_msn007.yaml"],
                         ids=["ab", "tro"])
def test_a_navigation_jump_across_the_oparea_during_safety_is_survived_alike(
    path: Path
) -> None:
    """The estimate goes beyond one wall (safety takes over), then beyond the opposite one in
    the same excursion, then back inside: safety reported both walls, whose mean normal is zero,
    and find-plume's reflection divided by it (a whole batch died). Now the walls start anew at
    such a jump; the py_trees planner and the fleet planner command the same, and both turn
    back in from the wall the vehicle is beyond."""
    from cptbt.fleet import FleetPlanner
    from cptbt.planner import Planner

    mission = load(str(path))
    mission = mission.model_copy(update={"mission_a": None})
    area = mission.op_area_geometry()
    cx = area.centre.x
    tree, ids = Planner(mission), np.arange(1)
    fleet = FleetPlanner.for_mission(mission, 1) if fleet_support(mission).ok else None
    out = []
    t = 0.0
    for y, n in ((area.centre.y, 10), (area.ymin - 30, 5), (area.ymax + 30, 5),
                 (area.centre.y, 5)):
        for _ in range(n):
            t += 1.0
            tree.add_flow(t, 0.1, 0.0), tree.add_sample(t, 0.0), tree.set_pose(cx, y, 0.0)
            cmd = tree.tick(t)
            assert cmd is not None
            if fleet is not None:  # the AB mission: its array forms too
                fleet.add_flows(t, ids, np.array([0.1]), np.array([0.0]))
                fleet.add_samples(ids, np.array([0.0]))
                fleet.set_poses(ids, np.array([cx]), np.array([y]), np.array([0.0]))
                tick = fleet.tick(t, ids)
                assert bool(tick.has_command[0]) and (
                    float(tick.heading[0]), float(tick.speed[0])) == (cmd.heading_deg,
                                                                      cmd.speed_mps)
            out.append((y, tree.active, cmd.heading_deg))
    y, active, heading = out[-1]  # back inside, find-plume: heading away from the north wall
    if any(e.family == "move_to_field" for e in mission.entries()):  # TRO's: bringing the
        # vehicle in does not end move-to-field (session 27), which drives on to the start
        assert active == "move_to_field.go_to", out[-6:]
    else:
        assert active is not None and active.startswith("find_plume")
        assert math.sin(math.radians(heading)) <= 0.0, out[-6:]
    tree.close()


def test_both_planners_count_the_same_sensor_faults() -> None:
    """A stuck fluorometer's dropped samples reach each run's summary, equal whichever planner
    flew the group."""
    from cptbt.batch.summary import summarise
    from cptbt.types import Point

    ab = load(str(AB[2]))
    params = to_sim_params(ab, 4)
    params = params.model_copy(update={"fluorometer": params.fluorometer.model_copy(
        update={"stuck_prob": 0.01, "stuck_duration_s": 6.0})})
    starts = [(60.0, y, 180.0) for y in (-20.0, -10.0, 0.0, 10.0, 20.0, 5.0, -5.0, 15.0)]
    counts = []
    for planner in ("fleet", "tree"):
        runs, _, _ = simulate(ab, params, starts, time_limit_s=60.0, planner=planner,
                              env_rng=np.random.default_rng(3),
                              vehicle_rngs=[np.random.default_rng(10 + i) for i in range(8)])
        counts.append([r.sensor_faults for r in runs])
        s = summarise(runs[0], ab, Point(*params.source_xy_m), 4, 0.0).to_dict()
        assert s["stuck_samples"] == runs[0].sensor_faults["stuck_samples"]
        assert s["rejected_flow_samples"] == s["clock_corrections"] == 0
    assert counts[0] == counts[1]
    assert sum(c["stuck_samples"] for c in counts[0]) > 0
