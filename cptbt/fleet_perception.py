"""Perception for the fleet planner (:mod:`cptbt.fleet`): N vehicles' samples condensed into one
:class:`FleetPercept` of arrays per cycle, by the rules of :class:`~cptbt.perception.Perception`
and with the same numbers (bit for bit: ``math.fsum`` for flow windows of more than two samples).
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from cptbt.perception import (
    MAX_FIX_OUTSIDE_M,
    SILENT_SENSOR_S,
    STUCK_FLOOR,
    TIME_EPS_S,
    PerceptionSettings,
)
from cptbt.types import Point

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]
IntArray = NDArray[np.int64]
Index = NDArray[np.intp]


@dataclass(frozen=True, slots=True)
class FleetPercept:
    """One cycle's percepts for a set of vehicles, field by field as arrays (see ``Percept``).

    Absent values are NaN (``vx``/``vy`` without a flow, ``last_*`` without a detection,
    ``first_t`` without a contact) with the ``has_*`` masks saying which.

    Attributes:
        t: planner time (the same for every vehicle).
        ids: the vehicles, as indices into the fleet.
    """

    t: float
    ids: Index
    x: FloatArray
    y: FloatArray
    heading: FloatArray
    concentration: FloatArray
    detected: BoolArray
    in_area: BoolArray
    has_flow: BoolArray
    vx: FloatArray
    vy: FloatArray
    has_last: BoolArray
    last_t: FloatArray
    last_x: FloatArray
    last_y: FloatArray
    has_first: BoolArray
    first_t: FloatArray
    in_plume: BoolArray
    contact_count: IntArray

    def take(self, pos: Index | BoolArray) -> FleetPercept:
        """The percepts of a subset (positions or a mask over this percept's vehicles)."""
        return FleetPercept(
            self.t, self.ids[pos], self.x[pos], self.y[pos], self.heading[pos],
            self.concentration[pos], self.detected[pos], self.in_area[pos], self.has_flow[pos],
            self.vx[pos], self.vy[pos], self.has_last[pos], self.last_t[pos], self.last_x[pos],
            self.last_y[pos], self.has_first[pos], self.first_t[pos], self.in_plume[pos],
            self.contact_count[pos])

    def __len__(self) -> int:
        return len(self.ids)


class FleetPerception:
    """:class:`~cptbt.perception.Perception` for N vehicles at once, with the same numbers.

    Samples arrive for all vehicles at the same instants (one simulated world); each call takes
    the vehicles it is for as an index array. Lost-contact points are kept per vehicle in
    Python lists (a handful per run).
    """

    def __init__(self, n: int, op_area: Any, settings: PerceptionSettings | None = None) -> None:
        self.n = n
        self.op_area = op_area
        self.settings = settings or PerceptionSettings()
        self._box = (op_area.xmin, op_area.xmax, op_area.ymin, op_area.ymax)
        self._cycle_max = np.full(n, -np.inf)
        self._x = np.full(n, np.nan)
        self._y = np.full(n, np.nan)
        self._heading = np.zeros(n)
        self._flows: deque[tuple[float, FloatArray, FloatArray, BoolArray]] = deque()
        self._flow_vx = np.full(n, np.nan)
        self._flow_vy = np.full(n, np.nan)
        self._has_flow = np.zeros(n, dtype=bool)
        self._has_last = np.zeros(n, dtype=bool)
        self._last_t = np.full(n, np.nan)
        self._last_x = np.full(n, np.nan)
        self._last_y = np.full(n, np.nan)
        self._first_t = np.full(n, np.nan)
        self._was_in_plume = np.zeros(n, dtype=bool)
        self._contacts = np.zeros(n, dtype=np.int64)
        self._lost: list[list[Point]] = [[] for _ in range(n)]
        self._t_prev = -math.inf
        self.rejected_flow_samples = np.zeros(n, dtype=np.int64)
        self.flow_held_cycles = np.zeros(n, dtype=np.int64)  # planned on a held estimate
        self.stuck_samples = np.zeros(n, dtype=np.int64)
        self.missing_samples = np.zeros(n, dtype=np.int64)
        self.blind_cycles = np.zeros(n, dtype=np.int64)  # cycles with no reading (Perception's)
        self.rejected_fixes = np.zeros(n, dtype=np.int64)  # as Perception's
        self._read = np.zeros(n, dtype=bool)  # has had a reading
        self._start_t = np.full(n, np.nan)  # first cycle without one, before any reading
        self._early = np.zeros(n, dtype=np.int64)  # such cycles not yet counted
        self._run_value = np.full(n, np.nan)  # each vehicle's latest sample, since when
        self._run_t = np.full(n, np.nan)

    def add_samples(self, ids: Index, concentration: FloatArray, t: float = math.nan) -> None:
        """One fluorometer sample per vehicle of ``ids`` at time ``t``; non-finite values and a
        reading stuck away from zero (``stuck_after_s``, as :class:`~cptbt.perception.Perception`)
        are ignored."""
        c = concentration
        self.missing_samples[ids] += ~np.isfinite(c)
        limit = self.settings.stuck_after_s
        if limit is not None:
            # NaN and inf are faults of their own (dropped below), never a stuck reading
            run_value, run_t = self._run_value[ids], self._run_t[ids]
            same = (c == run_value) & (np.abs(c) > STUCK_FLOOR) & np.isfinite(c)
            keep = same | ~np.isfinite(c)  # a dropout does not unfreeze a frozen sensor
            run_t = np.where(keep, run_t, t)
            self._run_t[ids] = run_t
            self._run_value[ids] = np.where(keep, run_value, c)
            if same.any():
                stuck = same & (t - run_t >= limit - TIME_EPS_S)
                self.stuck_samples[ids] += stuck
                c = np.where(stuck, np.nan, c)
        cm = self._cycle_max[ids]
        self._cycle_max[ids] = np.where(np.isfinite(c) & (c > cm), c, cm)

    def add_flows(self, t: float, ids: Index, vx: FloatArray, vy: FloatArray) -> None:
        """One flow-over-ground sample per vehicle of ``ids`` (planning frame, m/s)."""
        if self.settings.flow_source == "none":
            return
        limit = self.settings.max_flow_speed_mps
        speed = np.hypot(vx, vy)
        valid = np.isfinite(vx) & np.isfinite(vy) & (speed <= limit)
        near = np.abs(speed - limit) <= 1e-9 * limit  # numpy's hypot may differ by an ulp
        if np.count_nonzero(near):
            for j in np.flatnonzero(near):
                valid[j] = math.hypot(float(vx[j]), float(vy[j])) <= limit
        full_vx, full_vy = np.zeros(self.n), np.zeros(self.n)
        full_ok = np.zeros(self.n, dtype=bool)
        full_vx[ids], full_vy[ids], full_ok[ids] = vx, vy, valid
        self.rejected_flow_samples[ids] += ~valid
        self._flows.append((t, full_vx, full_vy, full_ok))

    def set_poses(self, ids: Index, x: FloatArray, y: FloatArray, heading: FloatArray) -> None:
        """The latest navigation estimates; a non-finite fix, or one more than
        :data:`~cptbt.perception.MAX_FIX_OUTSIDE_M` outside the OpArea, keeps the previous
        estimate (as :meth:`Perception.set_pose <cptbt.perception.Perception.set_pose>`; an
        attacker's navigation drift of 1e300 m had been taken as a position)."""
        ok = np.isfinite(x) & np.isfinite(y)
        far = ok & (self.op_area.distance_outside_array(np.where(ok, x, 0.0),
                                                        np.where(ok, y, 0.0)) > MAX_FIX_OUTSIDE_M)
        self.rejected_fixes[ids] += far
        ok &= ~far
        self._x[ids] = np.where(ok, x, self._x[ids])
        self._y[ids] = np.where(ok, y, self._y[ids])
        # a non-finite heading keeps the previous one, as Perception.set_pose (0 at the start)
        h = np.where(np.isfinite(heading), heading, self._heading[ids])
        self._heading[ids] = np.where(ok, h, self._heading[ids])

    def _flow(self, t: float, ids: Index) -> None:
        flows = self._flows
        while flows and flows[0][0] <= t - self.settings.flow_window_s:
            flows.popleft()
        if not flows:
            self.flow_held_cycles[ids] += self._has_flow[ids]
            return  # keep the last estimates
        ok = np.stack([f[3][ids] for f in flows])
        count = ok.sum(axis=0)
        some = count > 0
        self.flow_held_cycles[ids] += ~some & self._has_flow[ids]  # kept: held
        if len(flows) == 1:
            sx, sy = flows[0][1][ids], flows[0][2][ids]
        elif len(flows) == 2 and ok.all():
            # Two values: a + b is correctly rounded, as fsum is.
            sx = flows[0][1][ids] + flows[1][1][ids]
            sy = flows[0][2][ids] + flows[1][2][ids]
        else:
            vx = np.stack([f[1][ids] for f in flows])
            vy = np.stack([f[2][ids] for f in flows])
            sx, sy = np.zeros(len(ids)), np.zeros(len(ids))
            for j in np.flatnonzero(some):
                col = ok[:, j]
                sx[j] = math.fsum(vx[col, j].tolist())
                sy[j] = math.fsum(vy[col, j].tolist())
        k = ids[some]
        n = count[some]
        self._flow_vx[k] = sx[some] / n
        self._flow_vy[k] = sy[some] / n
        self._has_flow[k] = True

    def _note_readings(self, t: float, ids: Index, reading: BoolArray) -> None:
        """:meth:`Perception._note_reading`'s count for the vehicles ``ids`` (the fleet's runs
        are simulated, and say nothing in the log)."""
        read = self._read[ids]
        self.blind_cycles[ids] += ~reading & read
        k = ids[~reading & ~read]  # none yet: counted once the sensor is late
        if k.size:
            self._start_t[k] = np.where(np.isnan(self._start_t[k]), t, self._start_t[k])
            self._early[k] += 1
            late = k[t - self._start_t[k] >= SILENT_SENSOR_S]
            self.blind_cycles[late] += self._early[late]
            self._early[late] = 0
        self._read[ids] = read | reading

    def cycle(self, t: float, ids: Index) -> FleetPercept:
        """Close the current cycle at time ``t`` for the vehicles ``ids``; their percepts.

        Raises:
            ValueError: ``t`` is not finite or not after the previous cycle.
        """
        if not (math.isfinite(t) and t > self._t_prev):
            raise ValueError(f"fleet perception: cycle time {t!r} is not after {self._t_prev!r}")
        self._t_prev = t
        x, y = self._x[ids], self._y[ids]
        cm = self._cycle_max[ids]
        conc = np.where(cm > -np.inf, cm, np.nan)
        self._cycle_max[ids] = -np.inf
        self._note_readings(t, ids, cm > -np.inf)
        xmin, xmax, ymin, ymax = self._box
        in_area = (xmin <= x) & (x <= xmax) & (ymin <= y) & (y <= ymax)  # NaN: False
        detected = in_area & (conc > self.settings.threshold)
        was = self._was_in_plume[ids]
        new_contact = detected & ~was
        if np.count_nonzero(new_contact):
            k = ids[new_contact]
            self._contacts[k] += 1
            self._first_t[k] = t
        if np.count_nonzero(detected):
            k = ids[detected]
            self._has_last[k] = True
            self._last_t[k] = t
            self._last_x[k] = x[detected]
            self._last_y[k] = y[detected]
        has_last = self._has_last[ids]
        last_t = self._last_t[ids]
        in_plume = has_last & (t - last_t <= self.settings.lambda_s + TIME_EPS_S)
        lost = was & ~in_plume & has_last
        if np.count_nonzero(lost):
            for i in ids[lost]:
                self._lost[i].append(Point(float(self._last_x[i]), float(self._last_y[i])))
        self._was_in_plume[ids] = in_plume
        self._flow(t, ids)
        first_t = self._first_t[ids]
        return FleetPercept(
            t=t, ids=ids, x=x, y=y, heading=self._heading[ids], concentration=conc,
            detected=detected, in_area=in_area, has_flow=self._has_flow[ids],
            vx=self._flow_vx[ids], vy=self._flow_vy[ids], has_last=has_last, last_t=last_t,
            last_x=self._last_x[ids], last_y=self._last_y[ids], has_first=~np.isnan(first_t),
            first_t=first_t, in_plume=in_plume, contact_count=self._contacts[ids],
        )

    def poses(self, ids: Index) -> tuple[FloatArray, FloatArray]:
        """The navigation estimates the planner uses (x, y; NaN before a usable fix)."""
        return self._x[ids], self._y[ids]

    def faults(self, i: int) -> dict[str, int]:
        """Vehicle ``i``'s :meth:`~cptbt.perception.Perception.faults` (the fleet's cycles come
        from the simulator's clock, never corrected)."""
        return {"missing_samples": int(self.missing_samples[i]),
                "stuck_samples": int(self.stuck_samples[i]), "late_samples": 0,
                "rejected_fixes": int(self.rejected_fixes[i]),
                "rejected_flow_samples": int(self.rejected_flow_samples[i]),
                "clock_corrections": 0, "flow_held_cycles": int(self.flow_held_cycles[i]),
                "blind_cycles": int(self.blind_cycles[i])}

    def lost_contacts(self, i: int) -> tuple[Point, ...]:
        """Vehicle ``i``'s lost-contact points, oldest first."""
        return tuple(self._lost[i])
