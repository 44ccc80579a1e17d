"""What the real-time runner needs of a link beyond :class:`cptbt.link.VehicleLink`, and the URIs.

A *wire link* is a :class:`~cptbt.link.VehicleLink` over a network: it can wait for traffic,
send a heartbeat, say when it last heard the vehicle and count what it ignored. Adapters are
chosen by URI (:func:`parse_uri`): ``backseat:udp:HOST:PORT`` (:mod:`cptbt.bridge.backseat_link`)
and ``mavlink:udp:HOST:PORT`` (:mod:`cptbt.bridge.mavlink_link`, needs ``pymavlink``).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Protocol, runtime_checkable

from cptbt.link import InMessage, OutMessage
from cptbt.mission import MissionBase

PROTOCOLS = ("backseat", "mavlink")
TRANSPORTS = ("udp", "udpin")


class LinkURIError(ValueError):
    """A link URI that cannot be used."""


@dataclass(frozen=True, slots=True)
class LinkURI:
    """A parsed ``PROTOCOL:TRANSPORT:HOST:PORT``.

    ``udp`` sends to the vehicle at HOST:PORT (it answers the address the AMP sends from);
    ``udpin`` listens on HOST:PORT and answers whoever speaks to it.
    """

    protocol: str
    transport: str
    host: str
    port: int

    def __str__(self) -> str:
        return f"{self.protocol}:{self.transport}:{self.host}:{self.port}"


def parse_uri(uri: str, listen: bool = False) -> LinkURI:
    """Parse a link URI such as ``backseat:udp:127.0.0.1:14600``.

    Args:
        uri: the URI.
        listen: the URI names where to listen (a front-seat double): port 0, any free port,
            is allowed.

    Raises:
        LinkURIError: with a one-line reason.
    """
    parts = uri.split(":")
    if len(parts) != 4:
        raise LinkURIError(f"link {uri!r}: expected PROTOCOL:TRANSPORT:HOST:PORT (transport udp "
                           "or udpin), e.g. backseat:udp:127.0.0.1:14600")
    proto, transport, host, port = parts
    if proto not in PROTOCOLS:
        raise LinkURIError(f"link {uri!r}: protocol {proto!r} is not one of {list(PROTOCOLS)}")
    if transport not in TRANSPORTS:
        raise LinkURIError(f"link {uri!r}: transport {transport!r} is not one of "
                           f"{list(TRANSPORTS)}")
    if not host:
        raise LinkURIError(f"link {uri!r}: no host")
    try:
        n = int(port)
    except ValueError:
        raise LinkURIError(f"link {uri!r}: port {port!r} is not a number") from None
    if not (0 if listen else 1) <= n < 65536:
        raise LinkURIError(f"link {uri!r}: port {n} out of range")
    return LinkURI(proto, transport, host, n)


@runtime_checkable
class WireLink(Protocol):
    """A vehicle link over a network, as the real-time runner uses it."""

    def receive(self) -> Sequence[InMessage]:
        """Messages from the vehicle since the last call (never blocks)."""
        ...

    def send(self, message: OutMessage) -> None:
        """Send a command or an override request/release."""
        ...

    def wait(self, timeout_s: float) -> None:
        """Block until traffic arrives or ``timeout_s`` passes."""
        ...

    def heartbeat(self) -> None:
        """Tell the vehicle the AMP is alive."""
        ...

    @property
    def last_heard(self) -> float | None:
        """``time.monotonic()`` of the last valid message from the vehicle (None: never)."""
        ...

    def stats(self) -> dict[str, int]:
        """Counters: datagrams and messages in and out, and every kind ignored."""
        ...

    def close(self) -> None:
        """Release the socket."""
        ...


def open_link(uri: str, mission: MissionBase | None = None) -> WireLink:
    """The adapter a URI names, connected.

    Args:
        uri: the link URI.
        mission: the mission flown; the MAVLink adapter needs its frames (geodetic positions
            on the wire), the backseat protocol already speaks the planning frame.

    Raises:
        LinkURIError: a bad URI, the adapter's optional dependency is missing, or a MAVLink
            link without a mission.
    """
    u = parse_uri(uri)
    if u.protocol == "backseat":
        from cptbt.bridge.backseat_link import BackseatLink

        return BackseatLink(u)
    try:
        from cptbt.bridge.mavlink_link import MavlinkLink
    except ImportError as exc:
        raise LinkURIError(f"link {uri!r} needs pymavlink: pip install 'cptbt[mavlink]' "
                           f"({exc})") from None
    if mission is None:
        raise LinkURIError(f"link {uri!r}: a MAVLink link needs the mission (its frames)")
    return MavlinkLink(u, mission)
