"""``cptbt batch``'s sweeps: the configurations a study flies, from the mission's ``study:``
section or the command line's ``--sweep`` (which replaces the section's, said when it does)."""

from __future__ import annotations

import argparse
import math
import re
import sys
from collections.abc import Callable
from typing import Any

from pydantic import BaseModel

from cptbt.batch.study import Config, configurations
from cptbt.batch.sweeps import Sweep, study_notes
from cptbt.cli.argtypes import UsageError
from cptbt.cli.inspect_cmds import mission_text, study_sweeps, warn_swept
from cptbt.loader import parse_yaml
from cptbt.mission import MissionBase, printable
from cptbt.study_spec import configs_note, configs_problem


def study_configs(args: argparse.Namespace,
                  mission: MissionBase) -> tuple[list[Sweep], list[Config], list[str]]:
    """The study's sweeps and configurations, with the notes they call for, and the warnings
    (printed unless ``--quiet``, and returned for ``study.json``)."""
    own = study_sweeps(mission)
    seen: dict[str, Sweep] = {}
    for s in args.sweep:  # a path twice: the second had silently replaced the first (a review)
        for path in s.paths:
            if path in seen:
                raise UsageError(f"batch: --sweep {path} is given twice ({seen[path].text}"
                                 f" and {s.text}): give its values in one --sweep")
            seen[path] = s
    sweeps: list[Sweep] = args.sweep or own
    dropped = _not_flown(own, args.sweep, lambda p: _fallback_value(mission, p)[0]) \
        if args.sweep else []
    if dropped:  # --sweep replaces the study section's sweeps, all of them: never silently
        # Per value: a --sweep that flies some of a study sweep's values leaves only the rest
        # unflown; a path no --sweep sets is flown at one value, which is said.
        unset = [p for s in dropped for p in s.paths
                 if not any(p in g.paths for g in args.sweep)]
        falls = "".join(f"; {_fallback(mission, p)}" for p in dict.fromkeys(unset))
        print(printable(f"cptbt: note: --sweep replaces the sweeps of {args.mission}'s study "
                        f"section; not flown: {'; '.join(s.text for s in dropped)} (give them "
                        f"as --sweep too to keep them){falls}"), file=sys.stderr)
    count = math.prod(len(s.values) for s in sweeps)
    too_many = configs_problem(count)
    if too_many:
        raise UsageError(f"batch: {too_many}")
    note = configs_note(count)
    if note and not args.quiet:
        print(f"cptbt: note: {note}", file=sys.stderr)
    try:
        lines = parse_yaml(mission_text(args.mission), args.mission)[1] \
            if sweeps else None
        configs = configurations(mission, sweeps, args.mission, lines)
    except ValueError as exc:
        raise UsageError(f"batch: {exc}") from None
    for note in study_notes(mission, sweeps):
        print(f"cptbt: note: {note}", file=sys.stderr)
    warnings = warn_swept(mission, configs if sweeps else [], args.mission,
                          echo=not args.quiet)
    return sweeps, configs, warnings


_UNKNOWN = object()  # a path whose fallback value is not known: no study value is taken for it


def _not_flown(own: list[Sweep], given: list[Sweep],
               fallback: Callable[[str], Any] = lambda path: _UNKNOWN) -> list[Sweep]:
    """The study section's sweeps cut to the values the command line's sweeps do not fly.

    A value is flown when each of its paths takes it in some given sweep (the configurations
    are their product) or, for a path no given sweep sets, is the value it falls back to
    (``fallback(path)``); a study sweep with every value flown is left out.
    """
    def flies(path: str, value: Any) -> bool:
        setting = [g for g in given if path in g.paths]
        if setting:
            return any(value in g.values for g in setting)
        return bool(fallback(path) == value)

    out = []
    for s in own:
        left = tuple(v for v in s.values if not all(flies(p, v) for p in s.paths))
        if left:
            out.append(Sweep(s.paths, left))
    return out


def _fallback_value(mission: MissionBase, path: str) -> tuple[Any, str, Any]:
    """What a path no sweep sets is flown at: (value, whose: "the mission's value" or "the
    default", its field or None), the value :data:`_UNKNOWN` where it is not a field of a
    loaded model."""
    head, _, rest = path.partition(".")
    entry = next((e for e in mission.entries() if e.family == head), None) \
        if rest and head not in type(mission).model_fields else None
    node: Any = entry.params if entry is not None else mission
    *parents, leaf = (rest if entry is not None else path).split(".")
    for key in parents:
        node = node.get(key) if isinstance(node, dict) else getattr(node, key, None)
    if isinstance(node, dict) and leaf in node:
        return node[leaf], "the mission's value", None
    field = type(node).model_fields.get(leaf) if isinstance(node, BaseModel) else None
    if field is None:
        return _UNKNOWN, "", None
    whose = "the mission's value" if leaf in node.model_fields_set else "the default"
    return getattr(node, leaf), whose, field


def _fallback(mission: MissionBase, path: str) -> str:
    """What a path no sweep sets is flown at: ``PATH falls back to the mission's value, V`` (or
    ``the default, V`` where the mission file leaves it out); a None says what None means, from
    the field's description."""
    value, whose, field = _fallback_value(mission, path)
    if value is _UNKNOWN:  # not a field of a loaded model: say no more than is known
        return f"{path} falls back to the mission's own setting"
    if value is None and field is not None:
        meaning = re.search(r"\b(?:None|default): ([^)]*)", field.description or "")
        shown = f"none ({meaning.group(1).strip()})" if meaning else "none"
    else:
        shown = str(value)
    return f"{path} falls back to {whose}, {shown}"


