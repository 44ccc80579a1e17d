"""The TRO tree of real behaviours, scenario by scenario: who drives, and pre-emption (SPEC §3).

Flow toward +x at 0.1 m/s, so upflow = 180°. OpArea x ∈ [0, 200], y ∈ [-50, 50].
"""

from __future__ import annotations

from cptbt.loader import loads_mission
from cptbt.planner import Planner
from cptbt.registry import default_registry

MISSION = """
name: scenario
frame: planning
op_area: {corners: [[0, -50], [200, -50], [200, 50], [0, 50]]}
home: [190, 0]
start: [150, 20]
speed_mps: 1.5
perception: {stuck_after_s: null}  # scripted readings repeat exactly; a real sensor's do not
behaviours:
  - safety: {variant: oparea}
  - declare_source: {variant: upflow_cluster}
  - maintain_plume: {variant: track_in_out, beta_deg: 10}
  - reacquire_plume: {variant: cloverleaf, d_leaf_m: 15, repeats: 3}
  - find_plume: {variant: billiard}
  - move_to_field: {variant: go_to}
"""


class Scenario:
    """Drive a planner cycle by cycle with scripted pose and concentration."""

    def __init__(self) -> None:
        self.planner = Planner(loads_mission(MISSION, "scenario.yaml", default_registry()))
        self.t = 0.0

    def cycle(self, x: float, y: float, conc: float = 0.0) -> str | None:
        self.t += 1.0
        self.planner.add_flow(self.t, 0.1, 0.0)
        self.planner.add_sample(self.t, conc)
        self.planner.set_pose(x, y, 0.0)
        self.planner.tick(self.t)
        return self.planner.active


def cloverleaf(s: Scenario):  # type: ignore[no-untyped-def]
    return next(n for n in s.planner.leaves if n.family == "reacquire_plume")


def test_mission_start_moves_to_field_then_finds_then_tracks() -> None:
    s = Scenario()
    assert s.cycle(190, 0) == "move_to_field.go_to"          # far from the start point
    # Arrived: move-to-field sets field_reached and has no output; find-plume, ticked before
    # it in priority order, sees the flag from the next cycle (the planner holds its command).
    assert s.cycle(151, 19) is None
    assert s.cycle(151, 19) == "find_plume.billiard"
    assert s.cycle(140, 10, conc=0.5) == "maintain_plume.track_in"
    assert s.planner.command is not None and s.planner.command.heading_deg == 180
    assert s.cycle(139, 12) == "maintain_plume.track_out"     # detected within lambda


def test_move_to_field_is_blocked_for_good_once_another_behaviour_ran() -> None:
    s = Scenario()
    assert s.cycle(190, 0) == "move_to_field.go_to"
    assert s.cycle(185, 0, conc=0.5) == "maintain_plume.track_in"  # a hit on the way
    for _ in range(10):                       # contact lost: reacquire, never move-to-field
        assert s.cycle(180, 0) != "move_to_field.go_to"


def test_safety_preempts_tracking_outside_the_oparea() -> None:
    s = Scenario()
    s.cycle(151, 19)
    s.cycle(151, 19)
    assert s.cycle(100, 0, conc=0.5) == "maintain_plume.track_in"
    assert s.cycle(100, -60, conc=0.5) == "safety.oparea"     # 10 m outside: safety first
    assert s.planner.command is not None and s.planner.command.heading_deg == 90  # back in (+y)
    # Back inside but within release_m = 5 m of the wall: safety keeps driving (no chatter).
    assert s.cycle(100, -49, conc=0.5) == "safety.oparea"
    assert s.cycle(100, -44, conc=0.5) == "maintain_plume.track_in"


def test_lost_contact_goes_to_cloverleaf_and_a_hit_preempts_it() -> None:
    s = Scenario()
    s.cycle(151, 19)
    s.cycle(151, 19)
    s.cycle(100, 0, conc=0.5)                 # last detection at (100, 0), t = 3
    for k in range(8):                        # t = 4 .. 11: within lambda = 8.5 s
        assert s.cycle(99 - k, 2) == "maintain_plume.track_out"
    assert s.cycle(90, 3) == "reacquire_plume.cloverleaf"     # t = 12: 9 s > lambda, contact lost
    leaf = cloverleaf(s)
    assert leaf.status.name == "RUNNING"
    first_tour = leaf.waypoints
    assert (first_tour[0].x, first_tour[0].y) == (100, 0)  # C → tip → C, centred on (100, 0)
    assert s.cycle(92, 4, conc=0.5) == "maintain_plume.track_in"  # hit: maintain pre-empts
    assert leaf.status.name == "INVALID"                       # terminated by py_trees
    for k in range(9):
        s.cycle(80 - k, 0)
    assert s.cycle(70, 0) == "reacquire_plume.cloverleaf"     # a fresh cloverleaf
    # The new leaf pattern is centred on the new last detection (92, 4).
    assert s.planner.percept is not None and s.planner.percept.last_detection is not None
    last = s.planner.percept.last_detection
    assert (last.x, last.y) == (92, 4)
    assert len(s.planner.percept.lost_contacts) == 2
    tour = leaf.waypoints
    assert (tour[0].x, tour[0].y) == (92, 4) and tour != first_tour


def test_no_flow_estimate_means_no_flow_relative_output() -> None:
    s = Scenario()
    s.planner.add_sample(1.0, 0.0)
    s.planner.set_pose(151, 19, 0)
    s.planner.tick(1.0)                       # at the start point, but no ADCP sample yet
    assert s.planner.active is None and s.planner.command is None
