"""Geodetic latitude/longitude ↔ North-East metres about the OpArea centre (SPEC §1; TRO II).

TRO defines the OpArea by the latitude and longitude of its corners and keeps a North-East frame
in metres with its origin at the OpArea centre. The map used here is PROJ's ellipsoidal azimuthal
equidistant projection on WGS-84 centred on that origin (through pyproj): N is the distance along
the local meridian direction, E along the local parallel direction, and the distance and bearing
of every point from the centre are the exact geodesic ones (PROJ solves the geodesic by Karney's
method).

Accuracy, stated once here:

* Round trip geodetic → N-E → geodetic: below 1e-9 degrees (≈ 0.1 mm), tested.
* Distance and bearing from the centre: exact to the geodesic solver's precision (nanometres).
* Against a local tangent plane (the plane of the N-E frame itself), the projection's scale
  error at range r is about r²/(6 R²): for the 300 m TRO OpAreas that is below 1e-9 m relative,
  i.e. far below a millimetre. Any chord between two points of a 1 km area is reproduced to
  better than 1 mm.

Those numbers are far below the metres of LBL navigation error TRO reports, so the frame adds
nothing measurable to a declaration error.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from functools import lru_cache
from typing import Any

ROUND_TRIP_TOL_DEG = 1e-9
"""Stated round-trip accuracy, degrees of latitude or longitude (≈ 0.1 mm)."""


@dataclass(frozen=True, slots=True)
class GeoPoint:
    """A geodetic position on WGS-84, decimal degrees (north and east positive)."""

    lat_deg: float
    lon_deg: float


def degrees_minutes(degrees: int, minutes: float, hemisphere: str) -> float:
    """Decimal degrees from degrees and decimal minutes, as the TRO tables write them.

    Args:
        degrees: whole degrees (non-negative).
        minutes: decimal minutes, 0 ≤ minutes < 60.
        hemisphere: one of ``N``, ``S``, ``E``, ``W``.

    Raises:
        ValueError: a bad hemisphere or minutes out of range.
    """
    if hemisphere.upper() not in {"N", "S", "E", "W"}:
        raise ValueError(f"hemisphere must be N, S, E or W, got {hemisphere!r}")
    if not 0.0 <= minutes < 60.0 or degrees < 0:
        raise ValueError("degrees must be >= 0 and minutes in [0, 60)")
    value = degrees + minutes / 60.0
    return -value if hemisphere.upper() in {"S", "W"} else value


@lru_cache(maxsize=64)
def _transformer(lat0_deg: float, lon0_deg: float) -> Any:
    from pyproj import CRS, Transformer

    local = CRS.from_proj4(
        f"+proj=aeqd +lat_0={lat0_deg!r} +lon_0={lon0_deg!r} +x_0=0 +y_0=0 +ellps=WGS84 +units=m"
    )
    return Transformer.from_crs(CRS.from_epsg(4326), local, always_xy=True)


class PoleError(ValueError):
    """A North-East frame asked for at a pole, where there is no north.

    Attributes:
        pole: "North" or "South".
    """

    def __init__(self, pole: str) -> None:
        super().__init__(f"the corners' centre is the {pole} Pole")
        self.pole = pole


@dataclass(frozen=True, slots=True)
class LocalFrame:
    """The N-E metre frame tangent to WGS-84 at ``origin`` (the OpArea centre).

    Attributes:
        origin: the geodetic position of N = 0, E = 0.
    """

    origin: GeoPoint

    def __post_init__(self) -> None:
        if not -90.0 < self.origin.lat_deg < 90.0:
            raise ValueError(f"origin latitude must be in (-90, 90), got {self.origin.lat_deg}")
        if not -180.0 <= self.origin.lon_deg <= 180.0:
            raise ValueError(f"origin longitude must be in [-180, 180], got {self.origin.lon_deg}")

    def to_ne(self, lat_deg: float, lon_deg: float) -> tuple[float, float]:
        """North and east metres of a geodetic position."""
        tr = _transformer(self.origin.lat_deg, self.origin.lon_deg)
        e, n = tr.transform(lon_deg, lat_deg)
        return float(n), float(e)

    def to_geodetic(self, n: float, e: float) -> GeoPoint:
        """The geodetic position of a North-East point (metres)."""
        tr = _transformer(self.origin.lat_deg, self.origin.lon_deg)
        lon, lat = tr.transform(e, n, direction="INVERSE")
        return GeoPoint(float(lat), float(lon))

    @classmethod
    def centred_on(cls, corners: Sequence[tuple[float, float]]) -> LocalFrame:
        """The frame whose origin is the centre of geodetic corners ``[(lat, lon), ...]``.

        The centre is the centroid of the corners in N-E metres (found by projecting about the
        mean latitude/longitude and moving the origin to the projected centroid), so the corners'
        N-E centroid is zero to well below a millimetre.
        """
        if not corners:
            raise ValueError("need at least one corner")
        lat = sum(c[0] for c in corners) / len(corners)
        # A circular mean, so corners either side of the antimeridian (179.9, -179.9) centre
        # near 180 rather than near 0.
        lon = math.degrees(
            math.atan2(
                sum(math.sin(math.radians(c[1])) for c in corners),
                sum(math.cos(math.radians(c[1])) for c in corners),
            )
        )
        if abs(lat) >= 90.0:
            raise PoleError(_pole(lat))
        first = cls(GeoPoint(lat, lon))
        ne = [first.to_ne(c[0], c[1]) for c in corners]
        cn = sum(p[0] for p in ne) / len(ne)
        ce = sum(p[1] for p in ne) / len(ne)
        centre = first.to_geodetic(cn, ce)
        if abs(centre.lat_deg) >= 90.0:  # corners about a pole
            raise PoleError(_pole(centre.lat_deg))
        return cls(centre)


def _pole(lat_deg: float) -> str:
    return "North" if lat_deg > 0 else "South"


def geodesic_distance_m(a: GeoPoint, b: GeoPoint) -> float:
    """WGS-84 geodesic distance between two positions, metres (for checks and reports)."""
    from pyproj import Geod

    _, _, dist = Geod(ellps="WGS84").inv(a.lon_deg, a.lat_deg, b.lon_deg, b.lat_deg)
    return math.fabs(float(dist))
