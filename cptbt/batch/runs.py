"""What a flight records of each vehicle (:class:`VehicleRun`), the plume at a moment
(:class:`PlumeSnapshot`), the declarations a planner published, and the flight an error
stopped (:class:`Partial`): shared by :mod:`cptbt.batch.engine` and the runs it feeds."""

from __future__ import annotations

import contextlib
import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from cptbt.batch.outcome import Outcome
from cptbt.batch.recorder import PATH_COLUMNS, TRACE_COLUMNS, Recorder
from cptbt.planner import Planner
from cptbt.sim.world import World
from cptbt.types import Point

TRACE = ("t", "x", "y", "heading", "x_est", "y_est", "heading_est", "concentration", "detected",
         "flow_vx", "flow_vy", "active", "cmd_heading", "cmd_speed")
"""Columns of a run's trace, in order."""
assert set(TRACE) == {*PATH_COLUMNS, *TRACE_COLUMNS, "detected", "active"}


@dataclass(frozen=True)
class PlumeSnapshot:
    """The plume's concentration on a grid at one moment (for figures).

    Attributes:
        xs, ys: grid axes, planning frame, m.
        conc: concentration, (len(ys), len(xs)).
        t_s: mission time of the snapshot.
    """

    xs: NDArray[np.float64]
    ys: NDArray[np.float64]
    conc: NDArray[np.float64]
    t_s: float

    @classmethod
    def of(cls, world: World, grid: tuple[NDArray[np.float64], NDArray[np.float64]]
           ) -> PlumeSnapshot:
        """The world's plume now, on the grid ``(xs, ys)``."""
        xs, ys = grid
        gx, gy = np.meshgrid(xs, ys)
        conc = world.concentration_at(np.column_stack([gx.ravel(), gy.ravel()]))
        return cls(xs, ys, conc.reshape(gx.shape), world.t_s)


@dataclass
class VehicleRun:
    """What one vehicle did: its planner, events, and its rows in a :class:`Recorder`.

    Attributes:
        planner: the vehicle's planner (closed when the run ends); None when the group was flown
            by the fleet planner.
        start: where the recorded part of the run began (planning frame, true position).
        recorder: the rows the measures use (the AMP's cycles).
        index: this vehicle's row in ``recorder``.
        period_s: the planning cycle.
        trace_recorder: every row of a traced run (for phased runs, Mission A's too).
        outcome: how the AMP's part ended.
        t_end: when it ended (mission clock).
        t1: first detection; t3: declaration (the planner's ``declared_source`` first set:
            with several sources, when the last was declared or the search for more ended).
        declared_at: when each point of ``declared_sources`` was first published (see
            :meth:`note_declarations`).
        distance_at_end_m: the vehicle's true distance to the true source when it ended.
        closest_m: its closest true approach to the true source during the recorded part.
        declared: the declared source (planning frame).
        lost_contacts: the perception's lost-contact points at the end.
        sensor_faults: what the perception dropped or corrected (its ``faults()``) at the end.
        plume: the plume when the source was declared (or the run ended), if asked for.
    """

    planner: Planner | None
    start: tuple[float, float]
    recorder: Recorder
    index: int
    period_s: float
    trace_recorder: Recorder | None = None
    outcome: Outcome | None = None
    t_end: float = math.nan
    t1: float | None = None
    t3: float | None = None
    distance_at_end_m: float = math.nan
    closest_m: float = math.inf
    outside_m: float = 0.0
    """How far outside the OpArea the true track went at steps no row records (a phased run's
    give-back step: the AMP's last command took it there, but the planner did not tick)."""
    declared: Point | None = None
    declared_all: tuple[Point, ...] = ()
    declared_at: dict[Point, float] = field(default_factory=dict)
    source_map: Any = None
    declaration_report: dict[str, Any] | None = None
    lost_contacts: tuple[Point, ...] = ()
    sensor_faults: dict[str, int] = field(default_factory=dict)
    nonfinite_commands: dict[str, int] = field(default_factory=dict)
    """Each behaviour that asked ``command()`` for a non-finite heading or speed, how often
    (:meth:`~cptbt.planner.Planner.nonfinite_commands`)."""
    unflyable_speeds: dict[str, tuple[int, float, float]] = field(default_factory=dict)
    """Each behaviour whose command's speed the simulated vehicle cannot fly (outside its
    ``min_speed_mps``, ``max_speed_mps``; it flew the nearest): the cycles, the slowest and the
    fastest such speed commanded."""
    plume: PlumeSnapshot | None = None
    error: Exception | None = None
    """The error this run's planner raised, which ended it (:func:`simulate`'s ``isolate``)."""

    @property
    def path_t(self) -> NDArray[np.float64]:
        """Time of each recorded cycle."""
        return self.recorder.column("t", self.index)

    @property
    def path_true(self) -> NDArray[np.float64]:
        """True positions, (k, 2)."""
        return self.recorder.xy(self.index)

    @property
    def path_est(self) -> NDArray[np.float64]:
        """Navigation estimates, (k, 2)."""
        return self.recorder.xy(self.index, estimated=True)

    @property
    def detections(self) -> NDArray[np.float64]:
        """Estimated positions of the detecting cycles, (m, 2)."""
        return self.path_est[self.recorder.column("detected", self.index)]

    @property
    def time_in(self) -> dict[str, float]:
        """Seconds in each behaviour ('none': no output)."""
        return self.recorder.time_in(self.index)

    @property
    def trace(self) -> dict[str, Any] | None:
        """Every traced row as columns, or None when not traced."""
        rec = self.trace_recorder
        if rec is None:
            return None
        table = rec.table(self.index, extra=("phase",) if len(rec.phases) > 1 else ())
        return {c: table[c] for c in (*TRACE, *(["phase"] if "phase" in table else []))}


def note_declarations(run: VehicleRun, planner: Planner, t: float) -> None:
    """A cycle's declarations: t3 when ``declared_source`` is first set, and the time each
    declared point first appears among ``declared_sources`` (a several-source run's measures
    end at the declaration that completed its set, not when its search ended)."""
    if run.t3 is None and planner.declared_source is not None:
        run.t3 = t
    for q in planner.declared_sources:
        run.declared_at.setdefault(q, t)


def note_unflyable(run: VehicleRun, active: str | None, speed: float) -> None:
    """A cycle whose command's speed the simulated vehicle cannot fly, counted against the
    behaviour that drove (a review's plug-in commanded 0.1 m/s: the vehicle flew 0.25 and a
    study credited the variant with it, saying nothing)."""
    name = active or "no behaviour"
    n, lo, hi = run.unflyable_speeds.get(name, (0, math.inf, -math.inf))
    run.unflyable_speeds[name] = (n + 1, min(lo, speed), max(hi, speed))


def collect_declarations(run: VehicleRun, planner: Planner) -> None:
    """Copy what map-keeping declarations publish into the run (absent for the others).

    Every source declared, the belief at the final declaration (or when the search gave up),
    else the latest one (a run that ended searching: the map it ended on, ``map_at`` "end" in
    the report), and the fly-by report.
    """
    run.declared_all = planner.declared_sources
    final = planner.declared_source is not None
    run.source_map = ((planner.read("source_map_at_declaration") if final else None)
                      or planner.read("source_map"))
    report = planner.read("declaration_report")
    run.declaration_report = dict(report) if isinstance(report, dict) else None
    if run.declaration_report is not None and not final:
        run.declaration_report["map_at"] = "end"


_PARTIAL = "cptbt_partial_runs"


@dataclass(frozen=True)
class Partial:
    """A flight stopped by an error: its runs (their rows up to the last whole cycle), its
    world, and Mission A's waypoints (a phased run's; None otherwise)."""

    runs: list[VehicleRun]
    world: World
    waypoints: list[Point] | None = None


def keep_partial(exc: BaseException, runs: list[VehicleRun], world: World,
                 waypoints: list[Point] | None = None) -> None:
    """Attach the flight ``exc`` stopped to it, for :func:`partial_runs`."""
    if getattr(exc, _PARTIAL, None) is None:
        with contextlib.suppress(AttributeError, TypeError):
            setattr(exc, _PARTIAL, Partial(runs, world, waypoints))


def partial_runs(exc: BaseException) -> Partial | None:
    """The flight that stopped on ``exc`` (:func:`simulate`,
    :func:`~cptbt.batch.phased.simulate_phased`): ``cptbt run`` writes its trace and figure (a
    review's plug-in raised at t = 319 s and the run wrote nothing to look at). None: not a
    flight's error."""
    got = getattr(exc, _PARTIAL, None)
    return got if isinstance(got, Partial) else None
