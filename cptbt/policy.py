"""When the AMP gives control back: the one stop policy of every runner (SPEC §3, §9; TRO II).

The AMP relinquishes control when it has declared and reached home, when its time limit is up,
or when the vehicle is more than :data:`RELINQUISH_OUTSIDE_M` outside the OpArea. The AMP
session on a vehicle, the simulated batch engine and the phased simulation all ask
:func:`give_back_trigger`, so the rule is written once.
"""

from __future__ import annotations

RELINQUISH_OUTSIDE_M = 30.0
"""TRO II: the AMP gives control back when the vehicle is this far outside the OpArea, m."""

TIME_EPS_S = 1e-9
"""Slack on time comparisons (float cycle times)."""


def metres_text(v: float) -> str:
    """A distance for a message: 0.1 m, or three digits past a million (not 309 of them)."""
    return f"{v:.1f}" if v < 1e6 else f"{v:.3g}"


def share_text(v: float) -> str:
    """A share for a message: 12%, "<1%" for one that would round to 0% (a review saw a
    behaviour that drove read as 0%; 0.005 rounds to even, 0%), and ">99%" for one short of
    the whole that would round to 100%."""
    text = f"{v:.0%}"
    if text == "0%" and v > 0:
        return "<1%"
    return ">99%" if text == "100%" and v < 1 else text


def give_back_trigger(
    done: bool, elapsed_s: float, time_limit_s: float, outside_m: float
) -> tuple[str, str] | None:
    """The give-back trigger due now and a note, or None while the AMP keeps control.

    Args:
        done: the planner declared and reached home.
        elapsed_s: time since the AMP took control.
        time_limit_s: the mission's AMP time limit.
        outside_m: the vehicle's (estimated) distance outside the OpArea; 0 inside.
    """
    if done:
        return "declared_home", ""
    if elapsed_s + TIME_EPS_S >= time_limit_s:
        return "amp_time_limit", f"{time_limit_s:g} s"
    if outside_m > RELINQUISH_OUTSIDE_M:
        return "outside_op_area", f"{metres_text(outside_m)} m outside"
    return None
