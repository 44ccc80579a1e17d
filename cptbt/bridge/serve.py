"""The real-time AMP: :class:`cptbt.session.AmpSession` on a wire link, paced by the wall clock.

Every wall-clock cycle (the mission's ``cycle_hz``, times ``clock_scale``) the runner sends a
heartbeat and checks that the vehicle is still heard; between cycles it sleeps on the socket and
updates the session whenever traffic arrives, so a command leaves as soon as the vehicle's clock
says a planning cycle is due (the session times its cycles by the vehicle's clock, as on the
REMUS; the wall clock never reaches the planner).

Hand-back (OMAE "AMP-REMUS protocols": the vehicle resumes its own mission when the AMP lets go):
whatever ends the loop while the AMP has the override — Ctrl-C (``KeyboardInterrupt``), the link
falling silent, an exception anywhere in the planner or the session — the runner sends the
release (:data:`RELEASE_REPEATS` times, as UDP may lose one) and records the trigger
``amp_abort``, so the vehicle is never left flying the AMP's last command. The vehicle's own
command watchdog remains the last line of defence if even the release is lost.
"""

from __future__ import annotations

import logging
import math
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Literal

from cptbt.bridge.base import WireLink
from cptbt.link import OverrideRelease
from cptbt.mission import MissionBase
from cptbt.planner import Planner
from cptbt.session import AmpSession

log = logging.getLogger(__name__)

RELEASE_REPEATS = 3
"""The release is sent this many times on an abnormal stop (UDP may drop one)."""

StopReason = Literal["post_mission", "given_back", "interrupted", "link_lost", "no_vehicle",
                     "error", "wall_limit", "stopped"]

Observer = Callable[[AmpSession], None]
"""Called after every session update (e.g. a cycle log, a summary recorder)."""


@dataclass(frozen=True, slots=True)
class ServeOptions:
    """How the real-time runner paces and when it stops.

    Attributes:
        clock_scale: wall-clock pacing divided by this (tests run a vehicle double faster than
            real time); the vehicle's clock must run at the same scale.
        link_timeout_s: the link is lost after this long without a valid message, in vehicle
            seconds (scaled to wall time); None: the mission's ``mission_a.watchdog_s``.
        connect_timeout_s: wall seconds to wait for the vehicle's first message.
        until: stop when this phase is reached: ``post_mission`` (the default, like
            ``cptbt run``) or ``return_to_break_off`` (the AMP's job is done).
        max_wall_s: stop after this many wall seconds (None: no limit).
    """

    clock_scale: float = 1.0
    link_timeout_s: float | None = None
    connect_timeout_s: float = 30.0
    until: Literal["post_mission", "return_to_break_off"] = "post_mission"
    max_wall_s: float | None = None

    def __post_init__(self) -> None:
        if not (math.isfinite(self.clock_scale) and self.clock_scale > 0):
            raise ValueError(f"clock_scale must be a positive number, not {self.clock_scale}")


@dataclass
class ServeResult:
    """How a served run ended.

    Attributes:
        session: the session (phases, timeline, refusals, last state).
        stop_reason: why the loop stopped.
        error: the exception text when ``stop_reason`` is ``error``.
        handed_back: the runner sent the release on stopping (it had the override).
        wall_s: wall time of the loop.
        heartbeats: heartbeats sent.
        link_stats: the link's counters at the end.
    """

    session: AmpSession
    stop_reason: StopReason
    error: str = ""
    handed_back: bool = False
    wall_s: float = 0.0
    heartbeats: int = 0
    link_stats: dict[str, int] = field(default_factory=dict)


def serve(
    mission: MissionBase,
    link: WireLink,
    *,
    planner: Planner | None = None,
    options: ServeOptions | None = None,
    observers: Sequence[Observer] = (),
    stop: threading.Event | None = None,
) -> ServeResult:
    """Run the AMP against a vehicle in real time until the mission ends or something stops it.

    Args:
        mission: a validated mission with a ``mission_a`` section.
        link: an open wire link (the caller closes it).
        planner: the planner to run (default: a new one for ``mission``).
        options: pacing and stop conditions.
        observers: called after every session update.
        stop: set it (from another thread) to stop the loop cleanly.

    Returns:
        The result; the loop never raises for a link or planner fault (``KeyboardInterrupt``
        included), it hands back and reports it.
    """
    opts = options or ServeOptions()
    assert mission.mission_a is not None, "serve needs a mission with a mission_a section"
    session = AmpSession(mission, planner or Planner(mission), link)
    period = 1.0 / (mission.cycle_hz * opts.clock_scale)
    loss_s = (opts.link_timeout_s if opts.link_timeout_s is not None
              else mission.mission_a.watchdog_s) / opts.clock_scale
    result = ServeResult(session, "stopped")
    wall0 = time.monotonic()
    next_cycle = wall0
    try:
        while True:
            now = time.monotonic()
            if now >= next_cycle:
                link.heartbeat()
                result.heartbeats += 1
                next_cycle = max(next_cycle + period, now)
                reason = _lost(link.last_heard, now, wall0, loss_s, opts)
                if reason is not None:
                    result.stop_reason = reason
                    break
            session.update()
            for observe in observers:
                observe(session)
            if session.phases.is_in(opts.until) or session.phases.state == "post_mission":
                result.stop_reason = ("post_mission" if session.phases.state == "post_mission"
                                      else "given_back")
                break
            if stop is not None and stop.is_set():
                result.stop_reason = "stopped"
                break
            link.wait(max(0.0, next_cycle - time.monotonic()))
    except KeyboardInterrupt:
        result.stop_reason = "interrupted"
    except Exception as exc:  # any fault of the planner, the session or the link
        log.exception("AMP internal error: handing control back")
        result.stop_reason = "error"
        result.error = f"{type(exc).__name__}: {exc}"
    finally:
        result.handed_back = _hand_back(session, link, result)
        if result.handed_back:  # the observers hear of it (a log had ended in the override)
            session.ticked = False  # no new cycle: the last was heard already
            for observe in observers:
                try:
                    observe(session)
                except Exception:  # pragma: no cover - the release has gone already
                    log.exception("could not report the hand-back to an observer")
        result.wall_s = time.monotonic() - wall0
        try:
            result.link_stats = dict(link.stats())
        except Exception:  # pragma: no cover - a broken link cannot spoil the report
            result.link_stats = {}
    return result


def _lost(last_heard: float | None, now: float, wall0: float, loss_s: float,
          opts: ServeOptions) -> StopReason | None:
    if opts.max_wall_s is not None and now - wall0 >= opts.max_wall_s:
        return "wall_limit"
    if last_heard is None:
        return "no_vehicle" if now - wall0 > opts.connect_timeout_s else None
    return "link_lost" if now - last_heard > loss_s else None


_DETAIL = {"interrupted": "operator stop (Ctrl-C or SIGTERM)", "link_lost": "vehicle link lost",
           "error": "AMP internal error", "wall_limit": "wall-clock limit",
           "stopped": "stopped by the caller", "no_vehicle": "no vehicle heard"}


def _hand_back(session: AmpSession, link: WireLink, result: ServeResult) -> bool:
    """Release the override if the AMP still holds it; whether a release was sent."""
    if not session.in_override:
        return False
    for _ in range(RELEASE_REPEATS):
        try:
            link.send(OverrideRelease())
        except Exception:  # keep trying: this is the one message that must get out
            log.exception("could not send the release")
    detail = _DETAIL.get(result.stop_reason, result.stop_reason)
    if result.error:
        detail += f": {result.error}"
    try:
        session.fire_phase("amp_abort", session.t, detail)
    except Exception:  # pragma: no cover - the release has gone; the timeline is secondary
        log.exception("could not record the hand-back")
    log.warning("AMP handed control back: %s", detail)
    return True
