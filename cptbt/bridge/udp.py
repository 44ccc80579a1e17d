"""A non-blocking UDP endpoint: either sends to a known peer, or listens and answers the latest
sender. Shared by the adapters and the front-seat doubles."""

from __future__ import annotations

import select
import socket

RECV_BYTES = 65535
"""Read whole datagrams (an oversized one is read and then ignored by the decoder)."""


class UdpEndpoint:
    """One UDP socket.

    With a fixed ``peer`` only that address is heard: a datagram from any other is dropped and
    counted in :attr:`foreign` (on a shared machine a stray sender — another vehicle double still
    answering an earlier run on a port the system has since given to this socket — must not be
    taken for the vehicle). A vehicle that answers from another port needs the listening
    transport (``udpin``), which hears and answers whoever speaks.

    Args:
        bind: local address to bind (``("127.0.0.1", 0)`` for any free port).
        peer: where to send; None to answer whoever sent the latest datagram.

    Raises:
        ValueError: the peer's host name cannot be resolved, or ``bind`` cannot be bound.
    """

    def __init__(self, bind: tuple[str, int], peer: tuple[str, int] | None = None) -> None:
        if peer is not None:
            try:
                peer = (socket.gethostbyname(peer[0]), peer[1])
            except OSError:
                raise ValueError(f"cannot resolve the host {peer[0]!r}") from None
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.setblocking(False)
        try:
            self.sock.bind(bind)
        except OSError as exc:  # an unresolvable or foreign host, a port in use or forbidden
            self.sock.close()
            raise ValueError(f"cannot listen on {bind[0]}:{bind[1]}: "
                             f"{exc.strerror or exc}") from None
        self.peer = peer
        self._fixed_peer = peer is not None
        self.sent = 0
        self.send_errors = 0
        self.foreign = 0

    @property
    def address(self) -> tuple[str, int]:
        """The bound local address."""
        host, port = self.sock.getsockname()[:2]
        return str(host), int(port)

    def recv_all(self) -> list[bytes]:
        """Every datagram waiting now (never blocks)."""
        out: list[bytes] = []
        while True:
            try:
                data, addr = self.sock.recvfrom(RECV_BYTES)
            except (BlockingIOError, InterruptedError):
                return out
            except OSError:  # e.g. ICMP port unreachable surfacing as ECONNREFUSED
                continue
            sender = (str(addr[0]), int(addr[1]))
            if not self._fixed_peer:
                self.peer = sender
            elif sender != self.peer:
                self.foreign += 1
                continue
            out.append(data)

    def send(self, data: bytes) -> bool:
        """Send one datagram to the peer; False if there is none yet or the send failed."""
        if self.peer is None:
            return False
        try:
            self.sock.sendto(data, self.peer)
        except OSError:
            self.send_errors += 1
            return False
        self.sent += 1
        return True

    def wait(self, timeout_s: float) -> bool:
        """Block until a datagram is waiting or ``timeout_s`` passes; whether one is waiting."""
        if timeout_s <= 0:
            return False
        r, _, _ = select.select([self.sock], [], [], timeout_s)
        return bool(r)

    def close(self) -> None:
        """Close the socket."""
        self.sock.close()
