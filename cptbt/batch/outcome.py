"""How a run ends and how it is judged: one outcome enum and one verdict for every runner.

The run ends on a give-back trigger (:func:`cptbt.policy.give_back_trigger`), on the vehicle's
watchdog, or — for ``evaluation.criterion: arrival`` — when the vehicle reaches the true source,
or — for ``maintain`` — when contact, once made, is lost for good (:func:`contact_ended`).
The *verdict* then compares what the planner did with the simulator's truth (SPEC §11): a
declaration within ``evaluation.success_radius_m`` of the true source is a success, one beyond it
a *false declaration*; under ``arrival`` only reaching the source counts.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import StrEnum

from cptbt.evaluation import EvaluationSpec
from cptbt.policy import RELINQUISH_OUTSIDE_M
from cptbt.types import Point

ERROR_OUTCOME = "error"
"""A results row's outcome when its group stopped on an error (a bug), not an ending of the run
(:func:`cptbt.batch.worker.failed_rows`)."""


class Outcome(StrEnum):
    """How a run (the AMP's part of it) ended."""

    FOUND = "found"
    """Arrival criterion: the vehicle came within the success radius of the true source."""
    DECLARED = "declared"
    """The planner declared a source (and reached home, or the time ran out after declaring)."""
    TIMEOUT = "timeout"
    """The AMP time limit, no declaration."""
    RELINQUISHED = "relinquished"
    """More than 30 m outside the OpArea (TRO II)."""
    WATCHDOG = "watchdog"
    """The vehicle heard no accepted command for its watchdog time and took control back."""
    MISSION_ENDED = "mission_ended"
    """The vehicle's own mission ended during the override."""
    ABORTED = "aborted"
    """The AMP computer stopped driving and gave back (operator stop, link lost, error)."""
    CONTACT_LOST = "contact_lost"
    """Maintain criterion: contact, once made, was lost for good (AB Fig. 9's end of T_M)."""
    AMP_NOT_ENABLED = "amp_not_enabled"
    """The run stopped before the AMP took over."""
    AMP_RUNNING = "amp_running"
    """The run stopped (simulation cap) with the AMP still in control."""


WHY_ENDED = {
    Outcome.RELINQUISHED: f"the vehicle's estimated position was more than "
                          f"{RELINQUISH_OUTSIDE_M:g} m outside the OpArea, where the AMP gives "
                          "control back (TRO II; a navigation error counts as much as a real "
                          "excursion)",
    Outcome.WATCHDOG: "the AMP had no control for the watchdog time (the vehicle heard no "
                      "accepted command, or was not in override)",
    Outcome.MISSION_ENDED: "the vehicle's own mission ended during the override",
    Outcome.ABORTED: "the AMP stopped driving and gave control back",
    Outcome.CONTACT_LOST: "contact, once made, was lost for good",
}
"""Why a run ended, for the outcomes that are not a declaration, an arrival or a time-out
(what a time-out came before depends on the run: ``cptbt run`` words it)."""


_BY_TRIGGER = {
    "declared_home": Outcome.DECLARED,
    "arrival": Outcome.FOUND,
    "amp_time_limit": Outcome.TIMEOUT,
    "outside_op_area": Outcome.RELINQUISHED,
    "watchdog_timeout": Outcome.WATCHDOG,
    "amp_abort": Outcome.ABORTED,
}


CONTACT_FAMILIES = frozenset({"maintain_plume", "reacquire_plume", "safety", "declare_source"})
"""Behaviour families that may drive without ending a contact (criterion ``maintain``)."""


def contact_ended(first_detection_t: float | None, active: str | None) -> bool:
    """Criterion ``maintain``: has contact, once made, been lost for good this cycle?

    True on a cycle after the first detection on which the active behaviour (``family.variant``)
    is not one of :data:`CONTACT_FAMILIES` — find-plume or anything below it drives, or nothing
    does: the maintain and reacquire halves have both let go.
    """
    if first_detection_t is None:
        return False
    return active is None or active.partition(".")[0] not in CONTACT_FAMILIES


def outcome_of(trigger: str, declared: bool) -> Outcome:
    """The outcome of the trigger that ended the AMP's control.

    A time-out after a declaration (on the way home) counts as declared.
    """
    outcome = _BY_TRIGGER.get(trigger, Outcome.MISSION_ENDED)
    if outcome is Outcome.TIMEOUT and declared:
        return Outcome.DECLARED
    return outcome


@dataclass(frozen=True, slots=True)
class Verdict:
    """A run judged against the true source.

    Attributes:
        success: the evaluation's criterion was met.
        false_declaration: a declaration farther than the success radius from the true source.
        error_m: the declared source's distance to the true one; under ``arrival``, the
            vehicle's distance when it stopped if it declared nothing. None if neither applies.
    """

    success: bool
    false_declaration: bool
    error_m: float | None


def judge(
    outcome: Outcome,
    declared: Point | None,
    source: Point,
    distance_at_end_m: float,
    evaluation: EvaluationSpec,
    closest_m: float = math.inf,
) -> Verdict:
    """Judge one run by the mission's ``evaluation`` section.

    ``closest_m`` is the vehicle's closest true approach to the source over the run (the
    ``maintain`` criterion's success: within the radius at some point).
    """
    radius = evaluation.success_radius_m
    error = None if declared is None else math.hypot(declared.x - source.x,
                                                     declared.y - source.y)
    false = error is not None and error > radius
    if evaluation.criterion == "arrival":
        success = outcome is Outcome.FOUND
        return Verdict(success, false, error if error is not None else distance_at_end_m)
    if evaluation.criterion == "maintain":
        return Verdict(closest_m <= radius, false, error if error is not None else closest_m)
    return Verdict(error is not None and not false, false, error)
