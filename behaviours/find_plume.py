"""Find-plume: billiard-ball search of the OpArea (SPEC §4; TRO IV-A, AB appendix, OMAE).

Both variants head at a fixed offset from a reference direction, ``theta = ref + s·offset``, and
reflect off the OpArea walls: leaving through a cross-flow side turns the cross-flow component
back inside (s flips); leaving through the up-flow or the down-flow end picks the offset that
turns the along-flow component back inside (the small, down-flow offset after the up-flow end;
the large, up-flow offset after the down-flow end). They differ in their offsets and in how they
start. The papers' reference is the flow direction, drawn along the OpArea's x axis.

**(clarified) Any OpArea, any flow.** The papers' geometry — flow along x, so that the y walls
are the cross-flow sides and the x walls the up-flow and down-flow ends — rarely holds: real
currents cross survey boxes at any angle and turn during a mission (TRO MSN009 → MSN010
reversed). Every term is therefore defined from the OpArea's projection on the reference
direction ``u`` and its normal ``n`` (``ref + 90°``), which holds for any angle:

- **Reference** (parameter ``reference``). ``oparea_axis`` (default): the OpArea axis the
  current flow projects on most — the outward normal of the wall that faces down-flow — kept
  until the flow is more than ``45° + axis_hysteresis_deg`` from it, so a flow estimate
  wandering about a diagonal does not swap the pattern back and forth. With the flow along ±x
  the reference *is* flow_dir and the pattern is the papers'; with the flow along ±y it is the
  papers' pattern turned 90°. ``flow``: the flow estimate itself (the letter of TRO IV-A).
  Why the default is not the letter: with the legs laid off an oblique flow, the two legs of a
  sweep are no longer mirror images across the walls they bounce between, and in a steady
  flow the billiard locks into a short periodic path (kinematic tests: at 60°, 120°, 135°,
  240° and 300° in TRO's OpArea a loop of four legs, 62–76% of it ever swept after 40
  bounces). Laid off an OpArea axis, each sweep is a mirror zigzag and the pattern is a
  rotation of the papers' one, which sweeps the whole OpArea whatever the flow. In the
  simulated ocean the wandering current breaks the loops up, but the oblique legs meet the
  walls at steeper angles: ``benchmarks/any_flow.py --reference flow`` measured up to 15 safety
  take-overs in a 30-minute search, 18.5 m outside and 2 searches of 60 without a declaration,
  against 2, 12.8 m and none for the default. The legs still cross the flow within 45° of the
  papers' angles, and track-in, track-out and the reacquire patterns use the true flow.
- **Walls.** Which wall was left, and the reflection that never backs out through it, are
  in :mod:`cptbt.behaviours.walls`.
"""

from __future__ import annotations

import math
from types import SimpleNamespace
from typing import ClassVar, Literal, cast

import numpy as np
from py_trees.common import Access
from pydantic import Field

from cptbt.angles import bearing_deg_array, wrap_deg, wrap_deg_array
from cptbt.behaviours.walls import eta_side, reflect
from cptbt.fleet import BoolArray, FleetPercept, FleetRule, FloatArray, Index
from cptbt.frames import Normal, OpArea, WallExit, normals_of_bits
from cptbt.node import BehaviourParams, PlanBehaviour
from cptbt.registry import BehaviourSpec
from cptbt.types import Command, Percept, Point

Reference = Literal["oparea_axis", "flow"]


class BilliardBaseParams(BehaviourParams):
    """What both billiards measure their offsets from (module docstring, "Reference")."""

    reference: Reference = Field(
        default="oparea_axis",
        description="Direction the offsets are measured from: 'oparea_axis' = the OpArea axis "
        "the flow projects on most (sweeps any OpArea in any flow); 'flow' = the flow estimate "
        "(TRO's letter; can lock into a short loop when the flow is oblique to the OpArea)",
    )
    axis_hysteresis_deg: float = Field(
        default=10.0,
        ge=0,
        lt=45,
        description="'oparea_axis' only: keep the axis until the flow is more than 45° plus "
        "this from it, deg",
    )
    wall_margin_m: float = Field(
        default=5.0,
        ge=0,
        description="Reflect once within this distance of a wall and heading out through it "
        "(0: only once beyond it, the papers' letter), m",
    )


class BilliardParams(BilliardBaseParams):
    """Parameters of the TRO billiard find-plume (TRO Table I)."""

    dtheta_up_deg: float = Field(
        default=125.0,
        gt=90,
        lt=180,
        description="Offset from the reference after leaving the down-flow end (heads up-flow), "
        "deg",
    )
    dtheta_down_deg: float = Field(
        default=60.0,
        gt=0,
        lt=90,
        description="Offset from the reference after leaving the up-flow end (heads down-flow), "
        "deg",
    )


class AppendixBilliardParams(BilliardBaseParams):
    """Parameters of the AB-appendix billiard find-plume."""

    initial_offset_deg: float = Field(
        default=70.0, gt=0, lt=180, description="|theta_0|: offset from the reference at start, deg"
    )
    offset_after_upflow_deg: float = Field(
        default=70.0,
        gt=0,
        lt=90,
        description="|theta| after leaving through the up-flow end (heads down-flow), deg",
    )
    offset_after_downflow_deg: float = Field(
        default=110.0,
        gt=90,
        lt=180,
        description="|theta| after leaving through the down-flow end (heads up-flow), deg",
    )
    restart: Literal["initial", "largest_area"] = Field(
        default="initial",
        description="How find-plume restarts after a plume contact: 'initial' = theta_0 again "
        "(the appendix's start, slightly down-flow); 'largest_area' = toward the larger "
        "cross-flow side and the larger along-flow part (up-flow with 110°, down-flow with 70°), "
        "as SPEC §4a restarts the TRO billiard",
    )


class _Billiard(PlanBehaviour):
    """Shared bounce mechanics; subclasses give the offsets and the start.

    State (kept across pre-emption on purpose, see ``persistent_state``): the cross-flow side s
    to head for (``+1`` toward ``ref + 90°``), the offset magnitude, the contact count at the
    last (re)start, the last safety report seen and the OpArea axis in use. A reflection sets
    the state from where the vehicle is beyond the walls, not by toggling it, and is skipped
    while the heading already points back in, so ticks spent beyond a wall repeat the same
    reflection: one excursion can never flip the heading back and forth.
    """

    persistent_state: ClassVar[tuple[str, ...]] = (
        "side",
        "offset_deg",
        "started_at_contact",
        "exit_seen_t",
        "axis_deg",
    )
    params: BilliardBaseParams

    def __init__(self, params: BehaviourParams | None = None, **kwargs: str) -> None:
        super().__init__(params, **kwargs)
        self.bb.register_key("oparea_exit", access=Access.READ)
        self.side = 1
        self.offset_deg = math.nan
        self.started_at_contact: int | None = None
        self.exit_seen_t: float | None = None
        self.axis_deg: float | None = None

    def start_state(self, here: Point, area: OpArea, ref_deg: float) -> tuple[int, float]:
        """The side s and the offset magnitude on (re)start."""
        raise NotImplementedError

    def offset_after_end_deg(self, upflow_end: bool) -> float:
        """The offset magnitude after leaving through the up-flow or the down-flow end."""
        raise NotImplementedError

    def reference_deg(self, flow_dir: float) -> float:
        """The direction the offsets are measured from, for the current flow estimate."""
        if self.params.reference == "flow":
            return flow_dir
        limit = 45.0 + self.params.axis_hysteresis_deg
        if self.axis_deg is None or abs(wrap_deg(flow_dir - self.axis_deg)) > limit:
            # The nearest axis; an exact diagonal goes to the x axis (listed first).
            axes = (0.0, 180.0, 90.0, -90.0)
            self.axis_deg = min(axes, key=lambda a: abs(wrap_deg(flow_dir - a)))
        return self.axis_deg

    def decide(self, p: Percept) -> Command | None:
        """Reflect off the walls; head ``ref + s*offset``."""
        assert self.context is not None
        if not self.bb.field_reached or p.flow is None:
            return None
        area = self.context.op_area
        ref = self.reference_deg(p.flow.toward_deg)
        here = p.pose.point
        if self.started_at_contact != p.contact_count:
            # (Re)start: first activation, or find-plume again after a plume contact.
            self.started_at_contact = p.contact_count
            self.side, self.offset_deg = self.start_state(here, area, ref)
        walls = area.walls_beyond(here.x, here.y, self.params.wall_margin_m)
        if walls:
            self.leave(here, walls, area, ref)
        report = self.bb.get("oparea_exit") if self.bb.exists("oparea_exit") else None
        if isinstance(report, WallExit) and report.t != self.exit_seen_t:
            self.exit_seen_t = report.t
            if report.normals:
                self.leave(report.point, report.normals, area, ref)
        return self.command(ref + self.side * self.offset_deg)

    def leave(self, point: Point, walls: tuple[Normal, ...], area: OpArea, ref: float) -> None:
        """Reflect for an exit at ``point`` through ``walls`` (module docstring)."""
        self.side, self.offset_deg = reflect(self.side, self.offset_deg, point, walls, area, ref,
                                             self.offset_after_end_deg)


class BilliardFindPlume(_Billiard):
    """Billiard-ball find-plume of TRO IV-A: ``theta = ref + s*dtheta`` (SPEC §4a).

    ``ref`` is the ``reference``: the OpArea's axis by default (its direction nearer the flow),
    or the flow itself (``reference: flow``, the letter of TRO IV-A's ``flow_dir``); the module
    docstring says why and what each gives.

    s makes the cross-flow motion take the sign of ``eta`` (sign(0) = +1), eta being recomputed
    only when the vehicle leaves through a cross-flow side; ``dtheta`` becomes ``dtheta_down``
    after leaving through the up-flow end and ``dtheta_up`` after the down-flow end. flow_dir,
    sides and ends are read as the module docstring says: with the flow along ±x (TRO's
    drawing) they are flow_dir, TRO's y walls and its x walls, the up-flow x wall being the one
    the flow comes from; for any other flow, the reference direction and the walls it faces.

    Reading chosen: "(re)start" is the first tick with an output, and the first one after a
    plume contact was made (``contact_count`` changed); pre-emption by safety alone keeps the
    bounce state. On (re)start the lines through the vehicle along and across the reference
    split the OpArea in four; s and ``dtheta`` head into the part with the largest area (OMAE:
    toward the farthest corner), ties going to ``s = sign(eta)`` and then to ``dtheta_up``; with
    the reference along x that part is the larger y side times the larger x side, as TRO draws
    it. "Leaving through a wall" is the estimated position being within ``wall_margin_m`` of it,
    or beyond it, while heading out through it (module docstring). s and ``dtheta``
    are kept relative to the reference, so the heading turns with it (a reversed flow reverses
    the sweep too, and the next wall exit sets it again).
    """

    family: ClassVar[str] = "find_plume"
    variant: ClassVar[str] = "billiard"
    Params: ClassVar[type[BehaviourParams]] = BilliardParams
    params: BilliardParams

    def start_state(self, here: Point, area: OpArea, ref_deg: float) -> tuple[int, float]:
        """s and ``dtheta`` that head into the largest of the four parts about ``here``."""
        own_side = eta_side(here, area, ref_deg)
        total = (area.xmax - area.xmin) * (area.ymax - area.ymin)
        best: tuple[float, int, float] | None = None
        up, down = self.params.dtheta_up_deg, self.params.dtheta_down_deg
        for side in (own_side, -own_side):
            for along, offset in ((-1, up), (1, down)):
                a = area.sector_area(here, ref_deg, along, side)
                if best is None or a > best[0] + 1e-9 * total:
                    best = (a, side, offset)
        assert best is not None
        return best[1], best[2]

    def offset_after_end_deg(self, upflow_end: bool) -> float:
        """``dtheta_down`` after the up-flow end, ``dtheta_up`` after the down-flow end."""
        return self.params.dtheta_down_deg if upflow_end else self.params.dtheta_up_deg


class AppendixBilliardFindPlume(_Billiard):
    """Billiard find-plume of the AB appendix: ``psi_v = psi_w + theta_i`` (SPEC §4b).

    ``theta_0 = 70°·sign((ymin+ymax)/2 - y0)``; leaving through a y wall, ``theta = -theta``;
    leaving through an x wall, ``|theta|`` becomes 70° at the up-flow wall and 110° at the
    down-flow wall, its sign kept.

    Reading chosen: AB assumes the flow runs toward +x, where the sign of theta is the sign of
    the cross-flow (y) motion. So that the pattern survives any flow direction, the sign is kept
    as the cross-flow side to head for and ``psi_w``, the y walls and the x walls are read as
    the module docstring says (reference direction, sides, ends), as in
    :class:`BilliardFindPlume`: the start heads for the larger cross-flow side (``sign(eta)``),
    and a side exit turns back inside — which is ``theta = -theta`` whenever the vehicle left
    heading outward. (Re)start and wall exits are read as in the TRO variant.

    ``restart``: AB's searchers "revert to the plume-finding behavior" after losing the plume
    (AB §3), and the appendix only says how it starts ("Initially ... theta_0 = 70°"). Two
    readings, named: ``initial`` (the default) restarts at theta_0 every time — slightly
    down-flow, so a searcher that lost the plume far down-flow first drives to the down-flow
    wall; ``largest_area`` restarts as SPEC §4a restarts the TRO billiard, into the larger
    along-flow part (110° up-flow, 70° down-flow) on the larger cross-flow side. Measured on
    AB's Fig. 11 grid (Strategy III, R = 10 plumes, paired): 80.9 % success with ``initial``,
    90.7 % with ``largest_area`` (70 % if the interrupted bounce simply resumes), so the AB
    missions use ``largest_area`` (benchmarks/results/ab2001).
    """

    family: ClassVar[str] = "find_plume"
    variant: ClassVar[str] = "billiard_ab"
    Params: ClassVar[type[BehaviourParams]] = AppendixBilliardParams
    params: AppendixBilliardParams

    def start_state(self, here: Point, area: OpArea, ref_deg: float) -> tuple[int, float]:
        """``sign(eta)`` and ``|theta_0|``; on a restart under ``largest_area``, the offset that
        heads into the larger along-flow part."""
        side = eta_side(here, area, ref_deg)
        if self.params.restart == "initial" or math.isnan(self.offset_deg):
            return side, self.params.initial_offset_deg
        upflow = area.sector_area(here, ref_deg, -1, side)
        downflow = area.sector_area(here, ref_deg, 1, side)
        return side, (self.params.offset_after_downflow_deg if upflow >= downflow
                      else self.params.offset_after_upflow_deg)

    def offset_after_end_deg(self, upflow_end: bool) -> float:
        """70° after the up-flow end, 110° after the down-flow end (defaults)."""
        if upflow_end:
            return self.params.offset_after_upflow_deg
        return self.params.offset_after_downflow_deg


class _BilliardFleet(FleetRule):
    """:class:`_Billiard` for N vehicles (:mod:`cptbt.fleet`).

    The common tick (reference, heading) is array code; a (re)start, a wall exit and a safety
    report are rare and call the leaf's own rules per vehicle (``start_state``,
    ``offset_after_end_deg`` and :func:`reflect`), so those are written once.
    """

    behaviour: ClassVar[type[_Billiard]]
    params: BilliardBaseParams

    def prepare(self) -> None:
        """The bounce state per vehicle (kept across pre-emption, as the leaf's)."""
        n = self.n
        self.side = np.ones(n, dtype=np.int64)
        self.offset = np.full(n, np.nan)
        self.started = np.zeros(n, dtype=np.int64)
        self.has_started = np.zeros(n, dtype=bool)
        self.exit_seen = np.full(n, np.nan)
        self.axis = np.full(n, np.nan)
        self.field_reached = self.board.array("field_reached", bool, True)
        self.exit_t = self.board.array("oparea_exit_t")
        self.exit_x = self.board.array("oparea_exit_x")
        self.exit_y = self.board.array("oparea_exit_y")
        self.exit_walls = self.board.array("oparea_exit_walls", np.int64, 0)
        # The leaf's rules that read only its parameters (and, for a restart, its current
        # offset), called on a stand-in for the leaf.
        self._leaf = cast(_Billiard, SimpleNamespace(params=self.params))

    def _after_end(self, upflow_end: bool) -> float:
        return self.behaviour.offset_after_end_deg(self._leaf, upflow_end)

    def reference(self, ids: Index, flow_dir: FloatArray) -> FloatArray:
        """:meth:`_Billiard.reference_deg` per vehicle."""
        if self.params.reference == "flow":
            return flow_dir
        limit = 45.0 + self.params.axis_hysteresis_deg
        axis = self.axis[ids]
        swap = np.isnan(axis)
        swap[~swap] = np.abs(wrap_deg_array(flow_dir[~swap] - axis[~swap])) > limit
        if np.count_nonzero(swap):
            axes = np.array([0.0, 180.0, 90.0, -90.0])
            dist = np.abs(wrap_deg_array(flow_dir[swap][:, None] - axes[None, :]))
            axis[swap] = axes[np.argmin(dist, axis=1)]  # the first of equals, as min() picks
            self.axis[ids] = axis
        return axis

    def decide(self, p: FleetPercept, running: BoolArray) -> FloatArray:
        """Reflect off the walls; head ``ref + s*offset``."""
        out = np.full(len(p), np.nan)
        ok = self.field_reached[p.ids] & p.has_flow
        if not np.count_nonzero(ok):
            return out
        q = p.take(ok)
        ids = q.ids
        area = self.context.op_area
        ref = self.reference(ids, bearing_deg_array(q.vx, q.vy))
        restart = ~self.has_started[ids] | (self.started[ids] != q.contact_count)
        for j in np.flatnonzero(restart):
            i = ids[j]
            self.started[i], self.has_started[i] = q.contact_count[j], True
            here = Point(float(q.x[j]), float(q.y[j]))
            self._leaf.offset_deg = float(self.offset[i])  # NaN before the first start
            self.side[i], self.offset[i] = self.behaviour.start_state(
                self._leaf, here, area, float(ref[j]))
        bits = area.walls_beyond_bits(q.x, q.y, self.params.wall_margin_m)
        for j in np.flatnonzero(bits):
            self._leave(int(ids[j]), Point(float(q.x[j]), float(q.y[j])), int(bits[j]),
                        float(ref[j]))
        report_t = self.exit_t[ids]
        fresh = ~np.isnan(report_t) & (report_t != self.exit_seen[ids])
        for j in np.flatnonzero(fresh):
            i = int(ids[j])
            self.exit_seen[i] = report_t[j]
            if self.exit_walls[i]:
                self._leave(i, Point(float(self.exit_x[i]), float(self.exit_y[i])),
                            int(self.exit_walls[i]), float(ref[j]))
        out[ok] = ref + self.side[ids] * self.offset[ids]
        return out

    def _leave(self, i: int, point: Point, bits: int, ref: float) -> None:
        self.side[i], self.offset[i] = reflect(
            int(self.side[i]), float(self.offset[i]), point, normals_of_bits(bits),
            self.context.op_area, ref, self._after_end)


class BilliardFleet(_BilliardFleet):
    """:class:`BilliardFindPlume` for N vehicles."""

    covers = (BilliardFindPlume,)
    behaviour = BilliardFindPlume


class AppendixBilliardFleet(_BilliardFleet):
    """:class:`AppendixBilliardFindPlume` for N vehicles."""

    covers = (AppendixBilliardFindPlume,)
    behaviour = AppendixBilliardFindPlume


BilliardFindPlume.fleet_rule = BilliardFleet
AppendixBilliardFindPlume.fleet_rule = AppendixBilliardFleet

BEHAVIOURS = [
    BehaviourSpec.of(BilliardFindPlume, default=True),
    BehaviourSpec.of(AppendixBilliardFindPlume),
]
