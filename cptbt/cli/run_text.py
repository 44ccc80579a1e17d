"""How a run's summary reads on the console (``cptbt run``, ``cptbt run --from``): its verdict,
its declarations, the up-flow check's work and why it ended, from ``summary.json``'s data."""

from __future__ import annotations

from typing import Any

from cptbt.batch.outcome import WHY_ENDED
from cptbt.cli.output import fmt, place


def verdict_text(s: dict[str, Any]) -> str:
    """The run's verdict as ``cptbt run`` words it: what a success needs, and how a failure
    missed it (a false declaration's error beside the radius it is beyond)."""
    radius = f"{s['success_radius_m']:g} m"
    if s["criterion"] == "maintain":
        return ("success: came" if s["success"] else "no success: never came") + \
            f" within {radius} of the source"
    every = " of every source" if s.get("sources_true", 1) > 1 else ""
    if s["success"]:
        return f"success: {s['criterion']} within {radius}{every}"
    if s["false_declaration"]:
        if s.get("sources_true", 1) > 1 or s.get("sources_declared", 1) > 1:
            # a point is false when no true source is left for it, at whatever distance
            n = s.get("false_declarations") or 0
            return (f"FALSE DECLARATION: {n} of {s.get('sources_declared')} declared points "
                    f"matched to no source within {radius}")
        return (f"FALSE DECLARATION: {fmt(s['error_m'], ' m')} off, beyond the {radius} a "
                "success needs")
    article = "an" if s["criterion"][:1] in "aeiou" else "a"
    return f"no success: needs {article} {s['criterion']} within {radius}{every}"


def short_verdict(s: dict[str, Any]) -> str:
    """The verdict in a few words, for the figure's title: a run's outcome alone ("declared")
    does not say whether the declaration was right, or how many sources it found."""
    if s["criterion"] != "maintain" and s.get("sources_true", 1) > 1:
        false = s.get("false_declarations") or 0
        return (f"{s['sources_found']} of {s['sources_true']} sources found"
                + (f", {false} false" if false else ""))
    if s["success"]:
        return "success" + (f", error {fmt(s['error_m'], ' m')}"
                            if s["criterion"] == "declaration" else "")
    if s["false_declaration"]:
        return (f"false declaration, {fmt(s['error_m'], ' m')} off (success within "
                f"{s['success_radius_m']:g} m)")
    return "no success"


def upflow_check_line(s: dict[str, Any]) -> str | None:
    """The run summary's up-flow check counts as one line (None: the check did nothing)."""
    if not (s["upflow_checks"] or s["upflow_vetoes"] or s["unchecked"] or s.get("visits")):
        return None
    legs, vetoes = s["upflow_checks"] or 0, s["upflow_vetoes"] or 0
    return (f"  up-flow check: {legs} check leg{'s' * (legs != 1)} flown, {vetoes} "
            f"candidate{'s' * (vetoes != 1)} vetoed by plume seen up-flow of them"
            + (f" ({s['trace_vetoes']} by a sub-threshold trace alone)"
               if s.get("trace_vetoes") else "")
            + (f", {s['visits']} candidate{'s' * (s['visits'] != 1)} visited for want "
               "of plume seen near"
               + (f" ({s['visits_ended']} held back, the visit timed out)"
                  if s.get("visits_ended") else "")
               if s.get("visits") else "")
            + (f", {s['unchecked']} declared unchecked (a check leg timed out, or no "
               "flow direction)"
               if s["unchecked"] else ""))


def declaration_lines(s: dict[str, Any]) -> list[str]:
    """What was declared, when and how far off: a one-point run's point and error; with several
    points (or a search for more that gave up, or ran to the end) the worst error and every
    point (the error is the worst point's: summary.py)."""
    points = [q for q in s["declared_sources"] if q]
    n = f"{len(points)} point{'s' * (len(points) != 1)}"
    worst = (f"worst error {fmt(s['error_m'], ' m')} (each declared point against its nearest "
             "true source)")
    lines = []
    if s["declared_source"] and s.get("search_given_up"):
        end = f"  the search for more sources gave up at {fmt(s.get('search_end_t'), ' s')}"
        lines.append(f"{end} with {n}, the last declared at t3 = {fmt(s['t3'], ' s')}; {worst}"
                     if len(points) > 1 else
                     f"{end} with 1 point, declared at t3 = {fmt(s['t3'], ' s')}: source "
                     f"{place(s['declared_source'])}; error {fmt(s['error_m'], ' m')}")
    elif s["declared_source"] and len(points) > 1:
        lines.append(f"  declared at t3 = {fmt(s['t3'], ' s')}: the last of {n} "
                     f"{place(s['declared_source'])}; {worst}")
    elif s["declared_source"]:
        lines.append(f"  declared at t3 = {fmt(s['t3'], ' s')}: source "
                     f"{place(s['declared_source'])}; error {fmt(s['error_m'], ' m')}")
    elif points:  # the run ended still searching for more
        lines.append(
            f"  declared at t3 = {fmt(s['t3'], ' s')}, still searching for more at the end: "
            + (f"error {fmt(s['error_m'], ' m')}" if len(points) == 1
               else f"the last of {n}; {worst}"))
    if len(points) > 1 or (points and not s["declared_source"]):
        lines.append("  declared points, numbered as in trajectory.png: " + "; ".join(
            f"{i}: {_point_and_error(q, s)}" for i, q in enumerate(points, 1)))
    return lines


def _point_and_error(q: dict[str, Any], s: dict[str, Any]) -> str:
    """A declared point with its error and, among several true sources, which one it is
    judged against, by its key in the mission (``source``, ``extra_sources[0]``, ...: a
    review read "source 2" against the figure's declaration numbers)."""
    if q.get("error_m") is None:
        return place(q)
    k = q.get("nearest_source")
    key = "source" if k == 0 else f"extra_sources[{k - 1}]" if k is not None else ""
    against = f" from {key}" if s["sources_true"] > 1 and key else ""
    return f"{place(q)} ({fmt(q['error_m'], ' m')}{against})"


def sources_line(s: dict[str, Any]) -> str | None:
    """Sources found and false, and how the search for more ended (None: one source, one
    point, no fly-by)."""
    if not (s["sources_true"] > 1 or s["sources_declared"] > 1 or s["withdrawn"]
            or s["flybys"]):
        return None
    return (f"  sources: {s['sources_found']} of {s['sources_true']} found, "
            f"{s['false_declarations']} false"
            + (f"; the search for more ended at {fmt(s.get('search_end_t'), ' s')}: "
               f"{s.get('search_end')}"
               + (f", the latest held candidate (unconfirmed) at {place(s['held_candidate'])}"
                  if s.get("held_candidate") else "")
               if s.get("search_given_up") else "")
            + (f"; fly-bys {s['flybys']}, withdrawn {s['withdrawn']}"
               if s["flybys"] is not None else "")
            + (f"; {s['superseded']} declaration{'s' * (s['superseded'] != 1)} replaced "
               "an earlier one taken for the same source (at "
               + ", ".join(place(q) for q in s["superseded_points"] if q) + ")"
               if s.get("superseded") else ""))


def why_ended(s: dict[str, Any]) -> str | None:
    """Why a run ended without a declaration or an arrival (None when it did not)."""
    if s["outcome"] == "timeout":  # what the limit came before
        held = s.get("held_in_known_plume")
        # with one source declared or none (a diff review: the second's was not said)
        verifying = (f" (a fly-by was verifying a candidate at "
                     f"{place(s['verifying_candidate'])})" if s.get("verifying_candidate")
                     else "")
        return "the AMP's time limit came " + (
            "before the vehicle reached the source" if s["criterion"] == "arrival" else
            "while it searched for more sources" + (
                f" (a candidate held for {held} cycle{'s' * (held != 1)} in a declared "
                "source's plume, where "
                "the up-flow check cannot tell the two: known_plume_max_prob"
                + (f"; the latest, unconfirmed, at {place(s['held_candidate'])}"
                   if s.get("held_candidate") else "") + ")" if held else "") + verifying
            if any(s["declared_sources"]) else "with no declaration" + verifying)
    return WHY_ENDED.get(s["outcome"])  # a StrEnum: its members are their strings
