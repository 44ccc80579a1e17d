"""A link that sends to its vehicle hears only that vehicle: on a shared machine a stray sender
(another double still answering an earlier run on a port since given to this link) is dropped
and counted, never taken for the vehicle."""

from __future__ import annotations

import socket

import pytest
from wire_doubles import MISSIONS

from cptbt.batch.frontseat import BackseatCodec
from cptbt.batch.frontseat_mavlink import MavlinkCodec
from cptbt.bridge import open_link
from cptbt.link import VehicleState
from cptbt.loader import load_mission

MSN007 = load_mission(MISSIONS / "tro2006_msn007.yaml")


@pytest.mark.parametrize("protocol", ["backseat", "mavlink"])
def test_only_the_vehicle_is_heard(protocol: str) -> None:
    codec = BackseatCodec() if protocol == "backseat" else MavlinkCodec(MSN007)
    vehicle, stranger = (socket.socket(socket.AF_INET, socket.SOCK_DGRAM) for _ in range(2))
    for s in (vehicle, stranger):
        s.bind(("127.0.0.1", 0))
    link = open_link(f"{protocol}:udp:localhost:{vehicle.getsockname()[1]}", MSN007)
    try:
        link.heartbeat()  # tells the vehicle where the AMP is
        amp = vehicle.recvfrom(65535)[1]
        stray = codec.encode([VehicleState(999.0, 0.0, 0.0, 0.0, 1.5, 3.0, "post_mission", 9)])
        mine = codec.encode([VehicleState(10.0, 1.0, 2.0, 0.0, 1.5, 3.0, "mission", 0)])
        for d in stray:
            stranger.sendto(d, amp)
        for d in mine:
            vehicle.sendto(d, amp)
        heard = []
        for _ in range(50):
            link.wait(0.1)
            heard += [m for m in link.receive() if isinstance(m, VehicleState)]
            if heard:
                break
        assert [(m.t_s, m.mode) for m in heard] == [(10.0, "mission")]
        assert link.stats()["foreign"] == len(stray)
    finally:
        link.close()
        vehicle.close()
        stranger.close()
