"""Geodetic ↔ N-E ↔ planning frames (SPEC §1; TRO II, Table II), within the stated accuracy."""

from __future__ import annotations

import math

import pytest
from conftest import scripted_registry

from cptbt.frames import OpArea
from cptbt.geodesy import (
    ROUND_TRIP_TOL_DEG,
    GeoPoint,
    LocalFrame,
    degrees_minutes,
    geodesic_distance_m,
)
from cptbt.loader import loads_mission
from cptbt.types import Point

# TRO Table II, MSN010: the OpArea centre 32°58.853'N 118°32.223'W
CENTRE = GeoPoint(degrees_minutes(32, 58.853, "N"), degrees_minutes(118, 32.223, "W"))
FRAME = LocalFrame(CENTRE)
WGS84_A = 6378137.0
WGS84_E2 = 6.69437999014e-3


def test_degrees_minutes_signs_by_hemisphere() -> None:
    assert degrees_minutes(32, 30.0, "N") == pytest.approx(32.5)
    assert degrees_minutes(118, 30.0, "W") == pytest.approx(-118.5)
    with pytest.raises(ValueError):
        degrees_minutes(1, 60.0, "N")


@pytest.mark.parametrize("n, e", [(0, 0), (148, -63), (-148, 63), (-72, 146), (900, -1000)])
def test_round_trip_is_within_the_stated_accuracy(n: float, e: float) -> None:
    g = FRAME.to_geodetic(n, e)
    back = FRAME.to_geodetic(*FRAME.to_ne(g.lat_deg, g.lon_deg))
    assert abs(back.lat_deg - g.lat_deg) < ROUND_TRIP_TOL_DEG
    assert abs(back.lon_deg - g.lon_deg) < ROUND_TRIP_TOL_DEG
    assert FRAME.to_ne(g.lat_deg, g.lon_deg) == pytest.approx((n, e), abs=1e-4)


def test_north_is_the_meridian_arc_and_east_the_parallel() -> None:
    # Independent check with the WGS-84 radii of curvature at the centre (no pyproj):
    # M = a(1-e²)/(1-e² sin²φ)^1.5 north-south, N_r cos φ east-west, N_r = a/(1-e² sin²φ)^0.5.
    phi = math.radians(CENTRE.lat_deg)
    w = 1.0 - WGS84_E2 * math.sin(phi) ** 2
    m_per_rad = WGS84_A * (1 - WGS84_E2) / w**1.5
    n_per_rad = WGS84_A / math.sqrt(w) * math.cos(phi)
    dlat = 1e-3  # ~111 m: small enough that the curvature formulas hold to < 1 mm
    n, e = FRAME.to_ne(CENTRE.lat_deg + dlat, CENTRE.lon_deg)
    assert n == pytest.approx(math.radians(dlat) * m_per_rad, abs=2e-3)
    assert e == pytest.approx(0.0, abs=1e-6)
    n, e = FRAME.to_ne(CENTRE.lat_deg, CENTRE.lon_deg - dlat)  # west is negative east
    assert e == pytest.approx(-math.radians(dlat) * n_per_rad, abs=2e-3)
    assert abs(n) < 2e-3  # the parallel curves away from the tangent plane by ~e²/(2R) tan φ


def test_distance_from_the_centre_is_the_geodesic_distance() -> None:
    for n, e in [(148, -63), (-72, 146), (300, 400)]:
        g = FRAME.to_geodetic(n, e)
        assert geodesic_distance_m(CENTRE, g) == pytest.approx(math.hypot(n, e), abs=1e-3)


@pytest.mark.parametrize(
    "centre, north, east",
    [
        ((58.853, 32.223), 26, -38),  # MSN010 (Table II: N = 26 m, E = -38 m)
        ((58.8435, 32.2125), 43, -55),  # MSN007r2 (N = 43 m, E = -55 m)
    ],
)
def test_tro_table_ii_source_matches_its_n_e(
    centre: tuple[float, float], north: float, east: float
) -> None:
    frame = LocalFrame(
        GeoPoint(degrees_minutes(32, centre[0], "N"), degrees_minutes(118, centre[1], "W"))
    )
    n, e = frame.to_ne(degrees_minutes(32, 58.867, "N"), degrees_minutes(118, 32.248, "W"))
    # the table rounds positions to 0.001' (1.85 m of latitude, 1.55 m of longitude) and metres
    assert n == pytest.approx(north, abs=2.0)
    assert e == pytest.approx(east, abs=2.0)


def test_centred_on_puts_the_corner_centroid_at_zero() -> None:
    corners = [FRAME.to_geodetic(n, e) for n, e in [(148, -63), (72, -146), (-148, 63), (-72, 146)]]
    frame = LocalFrame.centred_on([(c.lat_deg, c.lon_deg) for c in corners])
    ne = [frame.to_ne(c.lat_deg, c.lon_deg) for c in corners]
    assert sum(p[0] for p in ne) == pytest.approx(0.0, abs=1e-3)
    assert sum(p[1] for p in ne) == pytest.approx(0.0, abs=1e-3)
    assert geodesic_distance_m(frame.origin, CENTRE) < 1e-3


REG = scripted_registry("safety")
CORNERS_NE = [(148, -63), (72, -146), (-148, 63), (-72, 146)]


def _geodetic_mission(extra: str = "") -> str:
    corners = "\n".join(
        f"    - [{g.lat_deg:.10f}, {g.lon_deg:.10f}]"
        for g in (FRAME.to_geodetic(n, e) for n, e in CORNERS_NE)
    )
    home = FRAME.to_geodetic(-100, 60)
    return (
        "name: geo\nframe: geodetic\nop_area:\n  corners:\n" + corners + "\n"
        "  x_axis_bearing_deg: 136.5\n"
        f"home: [{home.lat_deg:.10f}, {home.lon_deg:.10f}]\n"
        "behaviours:\n  - safety: {}\n" + extra
    )


def test_geodetic_mission_gives_the_same_oparea_as_its_n_e_corners() -> None:
    m = loads_mission(_geodetic_mission(), "geo.yaml", REG)
    area = m.op_area_geometry()
    ref = OpArea.from_ne_corners(CORNERS_NE, 136.5)
    for a, b in [(area.xmin, ref.xmin), (area.xmax, ref.xmax), (area.ymin, ref.ymin),
                 (area.ymax, ref.ymax)]:
        assert a == pytest.approx(b, abs=1e-3)
    assert area.frame.x_bearing_deg == 136.5
    home = m.to_xy(m.home)
    expected = ref.frame.ne_to_xy(-100, 60)
    assert (home.x, home.y) == pytest.approx((expected.x, expected.y), abs=1e-3)
    geo = m.to_geodetic(home)
    assert geo is not None
    assert geodesic_distance_m(geo, GeoPoint(*m.home)) < 1e-3
    assert m.to_ne(home) == pytest.approx((-100, 60), abs=1e-3)


def test_n_e_mission_reports_geodetic_only_with_a_centre() -> None:
    text = (
        "name: ne\nframe: ne\nop_area:\n  corners: [[148, -63], [72, -146], [-148, 63], "
        "[-72, 146]]\nhome: [0, 0]\nbehaviours:\n  - safety: {}\n"
    )
    m = loads_mission(text, "ne.yaml", REG)
    assert m.to_geodetic(Point(0, 0)) is None
    centre = f"  geodetic_centre_deg: [{CENTRE.lat_deg}, {CENTRE.lon_deg}]\nhome:"
    m2 = loads_mission(text.replace("home:", centre), "ne.yaml", REG)
    p = m2.to_xy((26, -38))
    g = m2.to_geodetic(p)
    assert g is not None
    assert FRAME.to_ne(g.lat_deg, g.lon_deg) == pytest.approx((26, -38), abs=1e-4)
