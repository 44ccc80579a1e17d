"""Safety: keep the vehicle in the OpArea (TRO V; SPEC §3, §8)."""

from __future__ import annotations

from typing import ClassVar

import numpy as np
from py_trees.common import Access, Status
from pydantic import Field

from cptbt.angles import bearing_deg_array
from cptbt.fleet import BoolArray, FleetPercept, FleetRule, FloatArray, Index
from cptbt.frames import Normal, WallExit
from cptbt.node import BehaviourParams, Contract, PlanBehaviour
from cptbt.registry import BehaviourSpec
from cptbt.types import Command, Percept, Point


class OpAreaSafetyParams(BehaviourParams):
    """Parameters of the OpArea safety behaviour."""

    trigger_m: float = Field(
        default=5.0,
        ge=0,
        description="Take over once the vehicle is this far outside the OpArea, m",
    )
    inset_m: float = Field(
        default=10.0,
        ge=0,
        description="Steer for the point this far inside the boundary nearest the vehicle, m",
    )
    release_m: float = Field(
        default=5.0,
        ge=0,
        description="Hand back once the vehicle is this far inside the OpArea, m (at most "
        "inset_m and a quarter of the OpArea's smaller side)",
    )


class OpAreaSafety(PlanBehaviour):
    """Return the vehicle into the OpArea when a behaviour drives it out (TRO V).

    Reading chosen: the plume behaviours handle the boundary themselves (find-plume reflects off
    it, the maintain and reacquire patterns are kept inside), so safety only takes over once
    the vehicle is ``trigger_m`` outside. It then steers for the nearest point ``inset_m``
    inside the boundary — along the wall's inward normal, or toward the interior diagonally at
    a corner — and keeps its output until the vehicle is ``release_m`` *inside* the OpArea.
    The gap between taking over outside and handing back inside is the hysteresis that stops
    safety and the behaviour below from trading control at the wall every cycle; handing back
    with room to turn means a behaviour that still heads for the wall is reflected by its own
    rule (or by the plume behaviours' wall margins) before it reaches the trigger again. Both
    insets are clipped to what a small OpArea allows (``inset_m`` to half its width on each
    axis, ``release_m`` to ``inset_m`` and to a quarter of the smaller side).

    On handing back it writes a :class:`~cptbt.frames.WallExit` to the blackboard key
    ``oparea_exit`` (where it took over and the walls the vehicle was beyond during the
    excursion), so that find-plume's next leg leaves that wall instead of driving out again.

    **(clarified) A home outside the OpArea.** A mission may place home outside
    (``allow_outside: [home]``); the homeward leg must then leave the box, and safety pulling
    the vehicle back at every ``trigger_m`` locked the two in a loop at the wall until the time
    limit. Once the AMP is on its way home (blackboard ``homeward``: the declaration is done
    with the source, or home was asked for) and home lies outside, safety stands aside; the
    AMP's give-back rule (:data:`cptbt.policy.RELINQUISH_OUTSIDE_M`) still bounds the excursion.
    """

    family: ClassVar[str] = "safety"
    variant: ClassVar[str] = "oparea"
    contract: ClassVar[Contract] = Contract(needs_flow=False)
    ends_move_to_field: ClassVar[bool] = False
    """Reading chosen: bringing the vehicle in does not end move-to-field. TRO III blocks
    move-to-field "once the vehicle activates any other behaviors", meaning the search's; a
    study's vehicles launched from a dock outside the OpArea were brought in by safety and
    never went to their starts (a review: 0 cycles of move-to-field in every run, each filed
    under a start it never flew from)."""
    Params: ClassVar[type[BehaviourParams]] = OpAreaSafetyParams
    params: OpAreaSafetyParams

    def __init__(self, params: BehaviourParams | None = None, **kwargs: str) -> None:
        super().__init__(params, **kwargs)
        self.bb.register_key("oparea_exit", access=Access.WRITE)
        self.bb.register_key("homeward", access=Access.READ)
        self.taken_over_at: Point | None = None
        self.walls: tuple[Normal, ...] = ()

    def initialise(self) -> None:
        """A new take-over: forget the previous excursion."""
        self.taken_over_at = None
        self.walls = ()

    def decide(self, p: Percept) -> Command | None:
        """Head back in from beyond the trigger distance until ``release_m`` inside."""
        assert self.context is not None
        a = self.context.op_area
        x, y = p.pose.x, p.pose.y
        if not p.pose.located:  # before the first navigation fix: nowhere to turn back from
            return None
        active = self.status == Status.RUNNING
        if self.bb.homeward and a.distance_outside(self.context.home.x, self.context.home.y) > 0:
            if active:
                self._report(p.t)
            return None  # the homeward leg leaves the box on purpose
        if not active:
            if a.distance_outside(x, y) <= self.params.trigger_m:
                return None
            self.taken_over_at = p.pose.point
            self.walls = ()
        release = min(self.params.release_m, self.params.inset_m,
                      0.25 * min(a.xmax - a.xmin, a.ymax - a.ymin))
        if a.depth_inside(x, y) >= release:
            self._report(p.t)
            return None
        now = a.walls_beyond(x, y)
        if any(w[0] + v[0] == 0.0 and w[1] + v[1] == 0.0 for w in now for v in self.walls):
            self.walls = now  # beyond the opposite wall: a navigation jump, the walls start anew
        else:
            self.walls = (*self.walls, *(w for w in now if w not in self.walls))
        goal = a.clamp(x, y, self.params.inset_m)
        return self.command(p.pose.point.bearing_to(goal))

    def _report(self, t: float) -> None:
        if self.taken_over_at is not None and self.walls:
            self.bb.oparea_exit = WallExit(t, self.taken_over_at, self.walls)
        self.taken_over_at = None


class OpAreaSafetyFleet(FleetRule):
    """:class:`OpAreaSafety` for N vehicles (:mod:`cptbt.fleet`).

    Blackboard ``oparea_exit`` as arrays: ``oparea_exit_t`` (NaN: none yet), ``oparea_exit_x``,
    ``oparea_exit_y`` (where safety took over) and ``oparea_exit_walls`` (a wall mask,
    :meth:`~cptbt.frames.OpArea.walls_beyond_bits`).
    """

    covers = (OpAreaSafety,)
    params: OpAreaSafetyParams

    def prepare(self) -> None:
        """The excursion state per vehicle and the blackboard's ``oparea_exit`` arrays."""
        n, a = self.n, self.context.op_area
        self.has_taken = np.zeros(n, dtype=bool)
        self.taken_x = np.full(n, np.nan)
        self.taken_y = np.full(n, np.nan)
        self.walls = np.zeros(n, dtype=np.int64)
        self.release = min(self.params.release_m, self.params.inset_m,
                           0.25 * min(a.xmax - a.xmin, a.ymax - a.ymin))
        b = self.board
        self.exit_t = b.array("oparea_exit_t")
        self.exit_x = b.array("oparea_exit_x")
        self.exit_y = b.array("oparea_exit_y")
        self.exit_walls = b.array("oparea_exit_walls", np.int64, 0)
        self.homeward = b.array("homeward", bool, False)
        self.home_outside = a.distance_outside(self.context.home.x, self.context.home.y) > 0

    def initialise(self, ids: Index) -> None:
        """A new take-over: forget the previous excursion."""
        self.has_taken[ids] = False
        self.walls[ids] = 0

    def decide(self, p: FleetPercept, running: BoolArray) -> FloatArray:
        """:meth:`OpAreaSafety.decide`, element by element."""
        a = self.context.op_area
        out = np.full(len(p), np.nan)
        take = ~running
        if self.home_outside:  # the homeward leg leaves the OpArea on purpose: stand aside
            aside = self.homeward[p.ids]
            self._hand_back(p.ids[aside & running], p.t)
            running = running & ~aside
            take &= ~aside
        take[take] = a.distance_outside_array(p.x[take], p.y[take]) > self.params.trigger_m
        work = running | take
        if not np.count_nonzero(work):
            return out
        pos = np.flatnonzero(work)
        ids, x, y = p.ids[pos], p.x[pos], p.y[pos]
        new = take[pos]
        if np.count_nonzero(new):
            k = ids[new]
            self.has_taken[k], self.taken_x[k], self.taken_y[k] = True, x[new], y[new]
            self.walls[k] = 0
        release = a.depth_inside_array(x, y) >= self.release
        if np.count_nonzero(release):
            self._hand_back(ids[release], p.t)
        drive = ~release
        if np.count_nonzero(drive):
            k, xd, yd = ids[drive], x[drive], y[drive]
            now = a.walls_beyond_bits(xd, yd)
            # beyond the wall opposite one already crossed (bits 1|2, 4|8): a navigation jump,
            # and the walls start anew, as in the per-vehicle form
            swapped = ((now & 1) << 1 | (now & 2) >> 1 | (now & 4) << 1 | (now & 8) >> 1)
            jumped = (swapped & self.walls[k]) != 0
            self.walls[k] = np.where(jumped, now, self.walls[k] | now)
            gx, gy = a.clamp_array(xd, yd, self.params.inset_m)
            out[pos[drive]] = bearing_deg_array(gx - xd, gy - yd)
        return out

    def _hand_back(self, k: Index, t: float) -> None:
        """Vehicles ``k`` end their excursion: its walls reported (``oparea_exit``), as
        :meth:`OpAreaSafety._report`."""
        report = k[self.has_taken[k] & (self.walls[k] != 0)]
        self.exit_t[report] = t
        self.exit_x[report], self.exit_y[report] = self.taken_x[report], self.taken_y[report]
        self.exit_walls[report] = self.walls[report]
        self.has_taken[k] = False


OpAreaSafety.fleet_rule = OpAreaSafetyFleet

BEHAVIOURS = [BehaviourSpec.of(OpAreaSafety, default=True)]
