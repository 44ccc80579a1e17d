"""The AMP's end of the backseat protocol (:mod:`cptbt.bridge.backseat`) over UDP."""

from __future__ import annotations

import logging
import time

from cptbt.bridge.backseat import Decoder, Heartbeat, encode
from cptbt.bridge.base import LinkURI
from cptbt.bridge.udp import UdpEndpoint
from cptbt.link import (
    CommandRefused,
    ConcentrationSample,
    FlowSample,
    InMessage,
    OutMessage,
    OverrideEnded,
    VehicleState,
)

log = logging.getLogger(__name__)

_IN = (VehicleState, ConcentrationSample, FlowSample, CommandRefused, OverrideEnded)


class BackseatLink:
    """A :class:`cptbt.link.VehicleLink` speaking backseat JSON lines over UDP.

    With ``backseat:udp:HOST:PORT`` the AMP binds a free local port and sends to the vehicle at
    HOST:PORT (its first heartbeat tells the vehicle where to answer); with
    ``backseat:udpin:HOST:PORT`` it listens there and answers the latest sender.
    """

    def __init__(self, uri: LinkURI) -> None:
        self.uri = uri
        if uri.transport == "udp":
            self.udp = UdpEndpoint(("0.0.0.0" if uri.host not in ("127.0.0.1", "localhost")
                                    else "127.0.0.1", 0), (uri.host, uri.port))
        else:
            self.udp = UdpEndpoint((uri.host, uri.port))
        self.decoder = Decoder()
        self._seq = 0
        self._last_heard: float | None = None
        self.vehicle_heartbeats = 0
        self.wrong_direction = 0

    # -- VehicleLink ------------------------------------------------------------------------
    def receive(self) -> list[InMessage]:
        """Every valid vehicle message waiting now, oldest first."""
        out: list[InMessage] = []
        for datagram in self.udp.recv_all():
            msgs = self.decoder.feed(datagram)
            for m in msgs:
                if isinstance(m, _IN):
                    out.append(m)
                elif isinstance(m, Heartbeat):
                    self.vehicle_heartbeats += 1
                else:  # an AMP message echoed back at us: not the vehicle's to send
                    self.wrong_direction += 1
            if msgs:
                self._last_heard = time.monotonic()
        return out

    def send(self, message: OutMessage) -> None:
        """Send a command, take or give (one datagram)."""
        self._send(encode(message, self._next_seq()))

    # -- WireLink ---------------------------------------------------------------------------
    def heartbeat(self) -> None:
        """Send an AMP heartbeat."""
        self._send(encode(Heartbeat(), self._next_seq()))

    def wait(self, timeout_s: float) -> None:
        """Block until a datagram arrives or ``timeout_s`` passes."""
        self.udp.wait(timeout_s)

    @property
    def last_heard(self) -> float | None:
        """Monotonic time of the last valid message from the vehicle."""
        return self._last_heard

    def stats(self) -> dict[str, int]:
        """Datagrams sent and received, messages decoded, and every kind ignored."""
        out = dict(self.decoder.counts)
        out |= {"sent": self.udp.sent, "send_errors": self.udp.send_errors,
                "foreign": self.udp.foreign,
                "vehicle_heartbeats": self.vehicle_heartbeats, "ignored": self.decoder.ignored,
                "wrong_direction": self.wrong_direction}
        return out

    def close(self) -> None:
        """Close the socket."""
        self.udp.close()

    def _next_seq(self) -> int:
        self._seq += 1
        return self._seq

    def _send(self, data: bytes) -> None:
        if not self.udp.send(data):
            log.debug("backseat: could not send to %s", self.udp.peer)
