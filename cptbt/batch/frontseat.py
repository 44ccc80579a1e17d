"""Front-seat doubles: the simulated vehicle behind a real wire protocol, for tests and try-outs.

A double listens on a loopback UDP port, flies :mod:`cptbt.sim`'s vehicle and plume through the
emulated REMUS executive of :class:`cptbt.batch.sim_link.SimVehicleLink` (the same Mission A,
override, refusals, watchdog and return to the break-off point as ``cptbt run``), paced by the
wall clock at ``clock_scale`` times real time, and speaks a protocol through a :class:`Codec`:
the backseat JSON lines (:class:`BackseatCodec`) or MAVLink (:mod:`cptbt.batch.frontseat_mavlink`).
It answers whoever spoke to it last, and waits at the dock (``pre_launch``) until the AMP first
speaks. :class:`WireFaults` injects what a real link does: lost, late and junk datagrams, and
silence.
"""

from __future__ import annotations

import math
import random
import threading
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np

from cptbt.batch.phased import launch_pose_phased
from cptbt.batch.scenario import to_sim_params
from cptbt.batch.sim_link import SimVehicleLink
from cptbt.bridge import backseat
from cptbt.bridge.udp import UdpEndpoint
from cptbt.link import (
    CommandRefused,
    HeadingSpeedCommand,
    InMessage,
    OutMessage,
    OverrideEnded,
    OverrideRelease,
    OverrideRequest,
)
from cptbt.mission import MissionBase
from cptbt.mission_a import VehicleLimits
from cptbt.sim.world import EnvironmentParams, World

_OUT = (HeadingSpeedCommand, OverrideRequest, OverrideRelease)


class Codec(Protocol):
    """A protocol as the vehicle's side speaks it.

    Attributes:
        junk: malformed datagrams in this protocol, for :attr:`WireFaults.junk_every`.
    """

    junk: Sequence[bytes]

    def decode(self, datagram: bytes) -> list[OutMessage]:
        """The AMP's messages in one datagram (invalid content ignored and counted)."""
        ...

    def encode(self, messages: Sequence[InMessage]) -> list[bytes]:
        """Datagrams carrying the vehicle's messages of one step."""
        ...

    def heartbeat(self, t_s: float, mode: str) -> bytes:
        """A vehicle heartbeat datagram."""
        ...

    def counts(self) -> dict[str, int]:
        """What the decoder counted (received, messages, every kind ignored)."""
        ...


JUNK = (b"{not json\n", b'{"v":1,"seq":1,"type":"nav","t_s":"soon"}\n',
        b'{"v":99,"seq":1,"type":"nav"}\n', b'{"v":1,"seq":1,"type":"teleport"}\n',
        b"\xff\xfe\x00garbage\n", b'[1,2,3]\n')
"""Malformed backseat datagrams the double sprinkles in (``junk_every``)."""


class BackseatCodec:
    """The vehicle's side of :mod:`cptbt.bridge.backseat`."""

    junk: Sequence[bytes] = JUNK

    def __init__(self) -> None:
        self.decoder = backseat.Decoder()
        self._seq = 0

    def decode(self, datagram: bytes) -> list[OutMessage]:
        """The AMP's messages; heartbeats only show the AMP is alive."""
        return [m for m in self.decoder.feed(datagram) if isinstance(m, _OUT)]

    def encode(self, messages: Sequence[InMessage]) -> list[bytes]:
        """One datagram per step (more if it would exceed the size limit)."""
        lines = []
        for m in messages:
            self._seq += 1
            lines.append(backseat.encode(m, self._seq))
        return backseat.pack(lines)

    def heartbeat(self, t_s: float, mode: str) -> bytes:
        """A vehicle heartbeat with its clock and mode."""
        self._seq += 1
        return backseat.encode(backseat.Heartbeat(t_s, mode), self._seq)

    def counts(self) -> dict[str, int]:
        """The decoder's counters."""
        return dict(self.decoder.counts)


@dataclass(frozen=True, slots=True)
class WireFaults:
    """What the double does to the wire.

    Attributes:
        drop_to_amp: probability that a datagram to the AMP is lost.
        drop_from_amp: probability that a datagram from the AMP is lost.
        delay_p: probability that a datagram to the AMP is held back ...
        delay_s: ... by this many vehicle seconds (so it arrives late and out of order).
        junk_every: every this many datagrams to the AMP, also send a malformed one and an
            oversized one (0: never).
        silent_from_s: from this vehicle time the AMP's datagrams are no longer heard ...
        silent_both: ... and, if set, the vehicle stops sending too (the link is cut).
        refuse_speed_above_mps: the vehicle refuses commands faster than this.
        seed: the fault generator's seed.
    """

    drop_to_amp: float = 0.0
    drop_from_amp: float = 0.0
    delay_p: float = 0.0
    delay_s: float = 0.0
    junk_every: int = 0
    silent_from_s: float | None = None
    silent_both: bool = False
    refuse_speed_above_mps: float | None = None
    seed: int = 0




@dataclass
class FrontSeatReport:
    """What the double saw, for tests.

    Attributes:
        t_end: vehicle clock at the end.
        mode: the vehicle's mode at the end.
        override_ended: reasons the vehicle left the override, in order.
        break_off: where the (first) override began, planning frame.
        commands_heard: AMP commands that reached the executive.
        refusals: commands the executive refused.
        sent: datagrams sent; dropped/delayed/junk: faults injected.
        decoder: the codec's counters of what came from the AMP.
        true_xy: the vehicle's true position at the end.
    """

    t_end: float = 0.0
    mode: str = "pre_launch"
    override_ended: list[str] = field(default_factory=list)
    break_off: tuple[float, float] | None = None
    commands_heard: int = 0
    refusals: int = 0
    sent: int = 0
    dropped: int = 0
    delayed: int = 0
    junk: int = 0
    decoder: dict[str, int] = field(default_factory=dict)
    true_xy: tuple[float, float] = (math.nan, math.nan)

    def to_dict(self) -> dict[str, Any]:
        """Plain data."""
        return {k: getattr(self, k) for k in self.__dataclass_fields__}


class FrontSeatDouble:
    """The simulated vehicle behind a wire protocol.

    Args:
        mission: a mission with ``mission_a`` and ``environment`` sections.
        codec: the protocol's vehicle side.
        bind: the UDP address to listen on (port 0: any free port; see :attr:`address`).
        clock_scale: vehicle seconds per wall second.
        faults: faults to inject on the wire.
        params: the simulated environment (default: the mission's).
        wait_for_amp: stay at the dock until the AMP first speaks.
    """

    def __init__(
        self,
        mission: MissionBase,
        codec: Codec,
        *,
        bind: tuple[str, int] = ("127.0.0.1", 0),
        clock_scale: float = 1.0,
        faults: WireFaults | None = None,
        params: EnvironmentParams | None = None,
        wait_for_amp: bool = True,
    ) -> None:
        spec = mission.mission_a
        if spec is None:
            raise ValueError(f"mission {mission.name!r} has no mission_a section")
        self.faults = faults or WireFaults()
        if self.faults.refuse_speed_above_mps is not None:
            limits = VehicleLimits(min_speed_mps=min(spec.limits.min_speed_mps,
                                                     self.faults.refuse_speed_above_mps),
                                   max_speed_mps=self.faults.refuse_speed_above_mps,
                                   max_depth_m=spec.limits.max_depth_m)
            spec = spec.model_copy(update={"limits": limits})
        self.params = params or to_sim_params(mission)
        x0, y0, h0 = launch_pose_phased(mission)
        self.world = World(self.params, np.array([[x0, y0]]), h0)
        self.world.warm_up()
        waypoints = [mission.to_xy(w) for w in spec.waypoints]
        self.vehicle = SimVehicleLink(self.world, spec, waypoints)
        self.codec = codec
        self.udp = UdpEndpoint(bind)
        self.clock_scale = clock_scale
        self.wait_for_amp = wait_for_amp
        self.report = FrontSeatReport()
        self._rng = random.Random(self.faults.seed)
        self._held: list[tuple[float, bytes]] = []
        self._to_amp = 0

    @property
    def address(self) -> tuple[str, int]:
        """Where the double listens."""
        return self.udp.address

    def run(self, max_time_s: float | None = None, stop: threading.Event | None = None,
            connect_timeout_s: float = 30.0) -> FrontSeatReport:
        """Fly until the vehicle's mission ends, ``max_time_s`` (vehicle) or ``stop`` is set."""
        try:
            if self.wait_for_amp and not self._await_amp(connect_timeout_s, stop):
                return self.report  # finished below
            wall0 = time.monotonic()
            t0 = self.world.t_s
            next_beat = t0
            while True:
                self._hear()
                out = self.vehicle.step()
                t = out.t_s
                self.report.true_xy = (float(out.true_xy[0, 0]), float(out.true_xy[0, 1]))
                msgs = self.vehicle.receive()
                self._note(msgs)
                if not self._silent_out(t):
                    for d in self.codec.encode(msgs):
                        self._send(d, t)
                    if t >= next_beat:
                        self._send(self.codec.heartbeat(t, self.vehicle.mode), t)
                        next_beat = t + 1.0
                self._release_held(t)
                if self.vehicle.mode == "post_mission":
                    break
                if (max_time_s is not None and t >= max_time_s) or (
                        stop is not None and stop.is_set()):
                    break
                due = wall0 + (t - t0) / self.clock_scale
                while (left := due - time.monotonic()) > 0:  # hear the AMP while waiting
                    if self.udp.wait(left):
                        self._hear()
        finally:  # an interrupted flight's report too (a review's ended "at t 0.0 s")
            self.udp.close()
            self._finish()
        return self.report

    # -- internals --------------------------------------------------------------------------
    def _await_amp(self, timeout_s: float, stop: threading.Event | None) -> bool:
        end = time.monotonic() + timeout_s
        while time.monotonic() < end and not (stop is not None and stop.is_set()):
            if self.udp.wait(0.05):
                self._hear()  # take any first message (a heartbeat) and learn the AMP's address
                if self.udp.peer is not None:
                    return True
        return False

    def _hear(self) -> None:
        t = self.world.t_s
        f = self.faults
        for d in self.udp.recv_all():
            if f.silent_from_s is not None and t >= f.silent_from_s:
                continue
            if f.drop_from_amp and self._rng.random() < f.drop_from_amp:
                continue
            for m in self.codec.decode(d):
                if isinstance(m, HeadingSpeedCommand):
                    self.report.commands_heard += 1
                self.vehicle.send(m)

    def _silent_out(self, t: float) -> bool:
        f = self.faults
        return f.silent_both and f.silent_from_s is not None and t >= f.silent_from_s

    def _send(self, data: bytes, t: float) -> None:
        f = self.faults
        self._to_amp += 1
        if f.junk_every and self._to_amp % f.junk_every == 0:
            junk = self.codec.junk[(self._to_amp // f.junk_every) % len(self.codec.junk)]
            self.udp.send(junk)
            self.udp.send(b"x" * (backseat.MAX_DATAGRAM + 100))
            self.report.junk += 2
        if f.drop_to_amp and self._rng.random() < f.drop_to_amp:
            self.report.dropped += 1
            return
        if f.delay_p and self._rng.random() < f.delay_p:
            self._held.append((t + f.delay_s, data))
            self.report.delayed += 1
            return
        if self.udp.send(data):
            self.report.sent += 1

    def _release_held(self, t: float) -> None:
        if not self._held:
            return
        due = [d for d in self._held if d[0] <= t]
        self._held = [d for d in self._held if d[0] > t]
        for _, data in due:
            self.udp.send(data)

    def _note(self, msgs: Sequence[InMessage]) -> None:
        for m in msgs:
            if isinstance(m, OverrideEnded):
                self.report.override_ended.append(m.reason)
                if self.report.break_off is None:
                    self.report.break_off = m.break_off
            elif isinstance(m, CommandRefused):
                self.report.refusals += 1

    def _finish(self) -> FrontSeatReport:
        r = self.report
        r.t_end = self.world.t_s
        r.mode = self.vehicle.mode
        r.decoder = dict(self.codec.counts())
        return r
