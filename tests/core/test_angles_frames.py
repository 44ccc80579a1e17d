"""Angle conventions and the N-E ↔ planning rotation (SPEC §1)."""

import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from cptbt.angles import bearing_deg, sign, upflow_deg, wrap_deg
from cptbt.frames import OpArea, PlanningFrame


@pytest.mark.parametrize(
    ("angle", "wrapped"),
    [(0, 0), (180, 180), (-180, 180), (190, -170), (-190, 170), (540, 180), (360, 0), (-90, -90)],
)
def test_wrap_to_half_open_interval(angle: float, wrapped: float) -> None:
    assert wrap_deg(angle) == pytest.approx(wrapped)


@given(st.floats(-1e4, 1e4))
def test_wrap_range_and_equivalence(a: float) -> None:
    w = wrap_deg(a)
    assert -180 < w <= 180
    assert math.isclose(math.cos(math.radians(w)), math.cos(math.radians(a)), abs_tol=1e-9)


def test_sign_of_zero_is_plus_one() -> None:
    assert sign(0.0) == 1 and sign(-0.0) == 1 and sign(-1e-9) == -1


def test_bearing_measured_from_x_toward_y() -> None:
    assert bearing_deg(1, 0) == 0
    assert bearing_deg(0, 1) == 90  # +y is 90° clockwise of +x when drawn with y down
    assert bearing_deg(-1, 0) == 180
    assert upflow_deg(0) == 180 and upflow_deg(170) == -10


def test_frame_rotation_maps_axes_and_headings() -> None:
    f = PlanningFrame(x_bearing_deg=90.0)  # +x points east, so +y points south
    p = f.ne_to_xy(0, 10)
    assert (p.x, p.y) == pytest.approx((10, 0))
    p = f.ne_to_xy(-10, 0)
    assert (p.x, p.y) == pytest.approx((0, 10))
    assert f.compass_deg(90) == pytest.approx(180)
    assert f.planning_deg(0) == pytest.approx(-90)


@given(st.floats(-180, 180), st.floats(-500, 500), st.floats(-500, 500))
def test_frame_round_trip(b: float, n: float, e: float) -> None:
    f = PlanningFrame(b, 3.0, -7.0)
    p = f.ne_to_xy(n, e)
    assert f.xy_to_ne(p.x, p.y) == pytest.approx((n, e), abs=1e-6)


def test_tro_msn007_oparea_is_254_by_112_along_bearing_133() -> None:
    # TRO Table II corners NW, SW, SE, NE; TRO V: "approximately 254×112 m ... 47° west of north".
    area = OpArea.from_ne_corners([(130, -46), (54, -129), (-130, 46), (-54, 129)])
    assert area.frame.x_bearing_deg == pytest.approx(133.0, abs=4.0)  # corners: 136.4°
    assert area.xmax - area.xmin == pytest.approx(254, abs=3)
    assert area.ymax - area.ymin == pytest.approx(112, abs=3)
    # The nominal source (N 43, E -55) lies in the north-west (upflow, -x) half.
    src = area.frame.ne_to_xy(43, -55)
    assert area.contains(src.x, src.y) and src.x < 0


def test_oparea_distance_outside() -> None:
    a = OpArea(0, 100, -50, 50)
    assert a.distance_outside(50, 0) == 0
    assert a.distance_outside(103, 54) == pytest.approx(5)
    with pytest.raises(ValueError):
        OpArea(0, 0, -1, 1)


def test_a_discs_share_of_the_op_area_counts_only_what_fits_inside() -> None:
    square, thin = OpArea(-15, 15, -15, 15), OpArea(-60, 60, -6, 6)
    assert square.disc_share(10.0) == pytest.approx(math.pi * 100 / 900, rel=1e-4)
    assert square.disc_share(30.0) == 1.0
    # 120 x 12 m: a 15 m disc overhangs both long sides; at most a 30 x 12 m strip fits
    assert 0.24 < thin.disc_share(15.0) < 30 * 12 / 1440
    for area in (square, thin):
        for share in (0.1, 1 / 3):
            assert area.disc_share(area.disc_radius(share)) == pytest.approx(share, rel=1e-4)
