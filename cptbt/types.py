"""Value objects shared by the planner, the behaviours and the simulator adapters.

All positions are planning-frame metres and all angles planning-frame degrees (SPEC §1).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from cptbt.angles import bearing_deg, wrap_deg


@dataclass(frozen=True, slots=True)
class Point:
    """A position in the planning frame, metres."""

    x: float
    y: float

    def distance_to(self, other: Point) -> float:
        """Euclidean distance in metres."""
        return math.hypot(other.x - self.x, other.y - self.y)

    def bearing_to(self, other: Point) -> float:
        """Planning angle from this point toward ``other``."""
        return bearing_deg(other.x - self.x, other.y - self.y)


@dataclass(frozen=True, slots=True)
class Pose:
    """Estimated vehicle pose: position and heading (planning frame)."""

    x: float
    y: float
    heading_deg: float = 0.0

    @property
    def point(self) -> Point:
        """The position alone."""
        return Point(self.x, self.y)

    @property
    def located(self) -> bool:
        """Whether there is a position (none before the first navigation fix)."""
        return math.isfinite(self.x) and math.isfinite(self.y)


@dataclass(frozen=True, slots=True)
class Command:
    """A guidance command: heading (planning degrees, wrapped) and through-water speed."""

    heading_deg: float
    speed_mps: float

    def __post_init__(self) -> None:
        if not (math.isfinite(self.heading_deg) and math.isfinite(self.speed_mps)):
            raise ValueError(f"non-finite command {self.heading_deg!r}, {self.speed_mps!r}")
        object.__setattr__(self, "heading_deg", wrap_deg(self.heading_deg))


@dataclass(frozen=True, slots=True)
class FlowEstimate:
    """Averaged flow relative to earth: the direction it moves toward, and its speed."""

    vx: float
    vy: float

    @property
    def toward_deg(self) -> float:
        """``flow_dir`` of SPEC §1: where the water goes."""
        return bearing_deg(self.vx, self.vy)

    @property
    def upflow_deg(self) -> float:
        """Direction the water comes from (``flow_dir + 180``)."""
        return wrap_deg(self.toward_deg + 180.0)

    @property
    def speed_mps(self) -> float:
        """Magnitude of the averaged flow vector."""
        return math.hypot(self.vx, self.vy)


@dataclass(frozen=True, slots=True)
class Detection:
    """A detection: when and where (estimated position) the concentration crossed threshold."""

    t: float
    x: float
    y: float

    @property
    def point(self) -> Point:
        """The position alone."""
        return Point(self.x, self.y)


@dataclass(frozen=True, slots=True)
class Percept:
    """What every behaviour sees on one planning cycle (SPEC §2).

    Attributes:
        t: planner time, seconds.
        pose: estimated pose.
        concentration: max of the valid samples since the previous cycle; NaN when none arrived.
        detected: concentration above threshold, inside the OpArea, this cycle.
        flow: 100-s vector average of the flow; None until a flow sample has arrived.
        last_detection: most recent detection (any cycle), or None.
        first_detection_t: time of the first detection of the current plume contact, or None.
        in_plume: a detection within the last ``lambda_s`` seconds.
        contact_count: number of plume contacts so far (a contact starts at a detection made
            while not in the plume); behaviours use it to notice a reacquisition.
        lost_contacts: ``(x_last, y_last)`` appended each time contact was lost, oldest first.
        in_op_area: the estimated position lies inside the OpArea.
    """

    t: float
    pose: Pose
    concentration: float
    detected: bool
    flow: FlowEstimate | None
    last_detection: Detection | None
    first_detection_t: float | None
    in_plume: bool
    contact_count: int
    lost_contacts: tuple[Point, ...]
    in_op_area: bool

    def since_detection(self) -> float:
        """Seconds since the last detection (infinite when there has been none)."""
        if self.last_detection is None:
            return math.inf
        return self.t - self.last_detection.t


@dataclass(frozen=True, slots=True, eq=False)
class SourceBelief:
    """A gridded belief over where the source is, published by map-keeping behaviours.

    Attributes:
        t: planner time of the belief, seconds.
        xs: cell-centre x coordinates (nx,), planning metres.
        ys: cell-centre y coordinates (ny,), planning metres.
        posterior: probability of each cell (ny, nx), summing to 1 (read-only array).
        declared: points whose plumes are explained away in the belief: the sources declared
            so far and the earlier declarations each replaced for lying near it.
        explored: cells the vehicle has passed near (ny, nx), or None.
    """

    t: float
    xs: NDArray[np.float64]
    ys: NDArray[np.float64]
    posterior: NDArray[np.float64]
    declared: tuple[Point, ...] = ()
    explored: NDArray[np.bool_] | None = None
