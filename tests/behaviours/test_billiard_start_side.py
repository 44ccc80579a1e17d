"""The billiards' starting side comes from the OpArea, not from the noisy instantaneous flow.

With ``reference: flow`` (AB's searcher steers off the instantaneous wind), a few degrees of flow
direction times the along-flow distance to the centre must not outweigh the cross-flow offset:
AB's ``theta_0 = 70°·sign((ymin+ymax)/2 - y0)`` heads toward the centre line whatever the wind's
last swing (before the fix, 6 of 64 paired AB searchers went the wrong way).
"""

from __future__ import annotations

import pytest

from cptbt.behaviours.walls import eta_side as _eta_side
from cptbt.frames import OpArea
from cptbt.types import Point

AB_AREA = OpArea(0.0, 100.0, -50.0, 50.0)


@pytest.mark.parametrize("flow_deg", [-15.0, -5.0, 0.0, 5.0, 15.0])
@pytest.mark.parametrize(("y0", "side"), [(-0.5, 1), (0.5, -1), (-20.0, 1), (20.0, -1)])
def test_side_heads_for_the_centre_line_whatever_the_wind_swing(flow_deg: float, y0: float,
                                                                 side: int) -> None:
    # 20 m up-flow of the centre: 20 m × sin(15°) = 5 m would outweigh a 0.5 m offset.
    assert _eta_side(Point(30.0, y0), AB_AREA, flow_deg) == side


@pytest.mark.parametrize(("flow_deg", "side"), [(180.0, -1), (175.0, -1), (-170.0, -1)])
def test_a_reversed_flow_keeps_the_side_relative_to_the_reference(flow_deg: float, side: int
                                                                  ) -> None:
    # Flow toward -x: the reference's left-hand normal is -y, so the centre (y = 0) seen from
    # y0 = -20 lies on the side s = -1 (heading ref - offset turns toward +y).
    assert _eta_side(Point(30.0, -20.0), AB_AREA, flow_deg) == side
