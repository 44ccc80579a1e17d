"""Commands that inspect missions and behaviours: validate, tree, behaviours, schema."""

from __future__ import annotations

import argparse
import json
import math
import sys
import textwrap
from pathlib import Path
from typing import TYPE_CHECKING, Any

from pydantic import BaseModel

from cptbt.cli.argtypes import not_the_mission
from cptbt.loader import (
    MissionError,
    format_errors,
    format_problems,
    loads_mission,
    parse_yaml,
    read_mission_text,
)
from cptbt.mission import Loc, MissionBase, dotted, printable
from cptbt.planner import Planner
from cptbt.registry import default_registry, misspelt_slot, package_of
from cptbt.schema import mission_json_schema
from cptbt.tree import render_ascii, render_dot

if TYPE_CHECKING:
    from cptbt.batch.study import Config
    from cptbt.batch.sweeps import Sweep


def environment_model() -> type[BaseModel] | None:
    """The simulator's environment model, so mission files are checked in full."""
    try:
        from cptbt.batch.scenario import Environment
    except ImportError:  # the core alone is installed
        return None
    return Environment


_TEXTS: dict[str, str] = {}
"""The text of each mission file :func:`load` read, by path: a pipe (/dev/stdin) reads once."""


def mission_text(path: str) -> str:
    """The text :func:`load` read from ``path`` (read now if it did not)."""
    if path not in _TEXTS:
        _TEXTS[path] = read_mission_text(path)
    return _TEXTS[path]


def load(path: str, simulate: bool = False, warn: bool = True) -> MissionBase:
    """Load a mission with the installed behaviours and check its simulator settings too.

    Args:
        path: the mission file.
        simulate: the caller will simulate it, so it must have an ``environment:`` section.
        warn: print the mission's advisories (valid settings likely not meant, such as a
            success radius covering much of the OpArea) to stderr, one
            ``FILE:LINE: path: warning: message`` line each.

    Raises:
        MissionError: one ``FILE:LINE: path: message`` line per problem.
    """
    env = environment_model()
    text = _TEXTS[path] = read_mission_text(path)
    mission = loads_mission(text, path, default_registry(), env)
    if env is not None:
        from cptbt.batch.scenario import check, problems

        found = problems(mission, simulate)
        error = check(mission) if mission.environment is not None and not found else None
        if found or error is not None:
            data, lines = parse_yaml(text, path)
            if found:
                raise MissionError(format_problems(found, lines, path))
            assert error is not None
            section = data.get("environment") or {}
            from cptbt.sim.world import EnvironmentParams

            raise MissionError(format_errors(error, section, lines, path, ("environment",),
                                             model=EnvironmentParams))
    if warn:
        print_advisories(path, advisories_of(mission))
    return mission


def advisories_of(mission: MissionBase) -> list[tuple[Loc, str]]:
    """The mission's advisories, with its simulated world's when the simulator is installed."""
    if environment_model() is None:
        return mission.advisories()
    from cptbt.batch.scenario import advisories

    return advisories(mission)


def study_sweeps(mission: MissionBase) -> list[Sweep]:
    """The sweeps of the mission's own ``study:`` section."""
    from cptbt.batch.sweeps import Sweep

    spec = mission.study
    return [Sweep(tuple(p.strip() for p in path.split("+")), tuple(values))
            for path, values in (spec.sweeps.items() if spec is not None else [])]


def warn_swept(mission: MissionBase, configs: list[Config], source: str,
               own: bool = True, echo: bool = True) -> list[str]:
    """The advisories of the configurations a study flies: the mission file's own at their
    lines (``FILE:LINE: path: warning:``) if some configuration keeps them (not those every
    sweep overrides; ``own=False``: none, they were printed already), then each swept
    configuration's others, one ``FILE [sweep ...]: path: warning:`` line each. Printed to
    stderr (``echo``) and returned: a study's ``tables.md`` heads with them (a review met a
    warning about the comparison on the terminal only)."""
    from cptbt.advice import NO_START
    from cptbt.batch.sweeps import value_yaml

    def flown(advice: list[tuple[Loc, str]]) -> list[tuple[Loc, str]]:
        # every run of a study has a start of its own: no word of the mission's (a review)
        return [(loc, msg) for loc, msg in advice if not msg.startswith(NO_START)]

    shown = flown(advisories_of(mission))
    if not configs:
        return print_advisories(source, shown, echo) if own else []
    kept: set[tuple[Loc, str]] = set()
    extra: list[str] = []
    for c in configs:
        m = c.mission
        sweep = ", ".join(f"{k}={value_yaml(v)}" for k, v in c.coords.items())  # as typed
        for loc, msg in flown(advisories_of(m)):
            if (loc, msg) in shown:
                kept.add((loc, msg))
            else:
                extra.append(f"{source} [sweep {sweep}]: {dotted(loc)}: warning: {msg}")
    said = print_advisories(source, [a for a in shown if a in kept], echo) if own else []
    for line in dict.fromkeys(printable(x) for x in extra):
        if echo:
            print(line, file=sys.stderr)
        said.append(line)
    return said


def print_advisories(path: str, advice: list[tuple[Loc, str]], echo: bool = True) -> list[str]:
    """Print a mission file's advisories to stderr (``echo``), one ``FILE:LINE: path: warning:
    message`` line each, in the file's line order; the lines."""
    if not advice:
        return []
    _, lines = parse_yaml(mission_text(path), path)
    said = [printable(line) for line in format_problems(
        [(loc, f"warning: {msg}") for loc, msg in advice], lines, path, by_line=True)]
    for line in said if echo else ():
        print(line, file=sys.stderr)
    return said


def add_parsers(sub: Any) -> None:
    """Register the inspection commands."""
    p = sub.add_parser("validate", help="check mission files", description=cmd_validate.__doc__)
    p.add_argument("missions", nargs="+", metavar="MISSION", help="mission YAML files")
    p.add_argument("--dump", action="store_true", help="print each mission as normalised YAML")
    p.set_defaults(func=cmd_validate)

    p = sub.add_parser("tree", help="show a mission's behaviour tree", description=cmd_tree.__doc__)
    p.add_argument("mission", metavar="MISSION", help="mission YAML file")
    p.add_argument("--dot", metavar="FILE", help="also write the tree as Graphviz dot")
    p.set_defaults(func=cmd_tree)

    p = sub.add_parser(
        "behaviours", help="list behaviours, variants and parameters",
        description=cmd_behaviours.__doc__,
    )
    p.add_argument("--json", action="store_true", help="machine-readable output")
    p.set_defaults(func=cmd_behaviours)

    p = sub.add_parser(
        "schema", help="print the mission JSON Schema", description=cmd_schema.__doc__
    )
    p.set_defaults(func=cmd_schema)


def cmd_validate(args: argparse.Namespace) -> int:
    """Validate mission files: every problem as FILE:LINE: path: message; exit 2 if any."""
    from cptbt.loader import dump_mission
    from cptbt.mission_checks import corner_fit_note

    problems: list[str] = []
    for path in args.missions:
        try:
            mission = load(path)
            _check_study_sweeps(mission, path)
        except MissionError as exc:
            problems.extend(exc.problems)
            continue
        if args.dump:
            print(dump_mission(mission), end="")
        else:
            names = ", ".join(f"{e.family}.{e.variant}" for e in mission.entries())
            print(printable(f"{path}: ok ({mission.name}: {names})"))
        note = corner_fit_note(mission)
        if note is not None:
            line = parse_yaml(mission_text(path), path)[1].get(("op_area", "corners"), 1)
            print(printable(f"{path}:{line}: op_area.corners: note: {note}"), file=sys.stderr)
    if problems:
        raise MissionError(problems)
    return 0


def _check_study_sweeps(mission: MissionBase, path: str) -> None:
    """Fly nothing, but make every configuration of the mission's own ``study:`` sweeps, as
    ``cptbt batch`` would: a swept value that is no valid mission is a problem at its line;
    a swept value likely not meant, a warning naming its sweep.

    Raises:
        MissionError: a configuration is no valid mission, or a sweep path names nothing.
    """
    if mission.study is not None and mission.mission_a is not None and \
            environment_model() is not None:
        _check_amp_alone(mission, path)
    sweeps = study_sweeps(mission)
    if not sweeps or environment_model() is None:  # the core alone: no study is flown here
        return
    from cptbt.batch.study import configurations
    from cptbt.batch.sweeps import study_notes
    from cptbt.study_spec import configs_note

    lines = parse_yaml(mission_text(path), path)[1]
    note = configs_note(math.prod(len(s.values) for s in sweeps))
    if note:
        print(printable(f"{path}: note: {note}"), file=sys.stderr)
    try:
        configs = configurations(mission, sweeps, path, lines)
    except ValueError as exc:
        where = lines.get(("study", "sweeps"), lines.get(("study",), 1))
        raise MissionError([f"{path}:{where}: study.sweeps: {exc}"]) from None
    for note in study_notes(mission, sweeps):
        print(printable(f"{path}: note: {note}"), file=sys.stderr)
    warn_swept(mission, configs, path, own=False)


def _check_amp_alone(mission: MissionBase, path: str) -> None:
    """The problems of a mission's ``study:`` section flown as ``cptbt batch`` flies it, the
    AMP alone (``--amp-only``): a launch that the mission's Mission A brings in may be too far
    out without it (a review: validate said ok, batch refused).

    Raises:
        MissionError: the mission without its Mission A has a problem.
    """
    from cptbt.batch.scenario import problems

    found = problems(mission.model_copy(update={"mission_a": None}), simulate=False)
    if found:
        lines = parse_yaml(mission_text(path), path)[1]
        raise MissionError([f"{line} (the study: section flies the AMP alone, as cptbt batch "
                            "--amp-only)" for line in format_problems(found, lines, path)])


TREE_KEY = (
    "key (py_trees): [-] sequence: its children tick in turn, every cycle; [o] selector: the\n"
    "first child with a command drives, the rest are not ticked (highest priority first: the\n"
    "subsumption of TRO Fig. 2); --> a behaviour; watch:NAME runs NAME's perception every\n"
    "cycle, whether or not it drives")
"""The legend printed under ``cptbt tree`` (a review read its symbols without one)."""


def cmd_tree(args: argparse.Namespace) -> int:
    """Print the arbitration tree a mission builds (highest priority first)."""
    not_the_mission("--dot", args.dot, args.mission)
    mission = load(args.mission)
    planner = Planner(mission)
    try:
        print(render_ascii(planner.root), end="")
        print(TREE_KEY)
        if args.dot:
            Path(args.dot).write_text(render_dot(planner.root), encoding="utf-8")
            print(f"wrote {args.dot}")
    finally:
        planner.close()
    return 0


def _param_rows(model: type[BaseModel]) -> list[dict[str, Any]]:
    rows = []
    for name, field in model.model_fields.items():
        row: dict[str, Any] = {"name": name, "description": field.description or ""}
        if field.is_required():  # no default: "PydanticUndefined" had been printed (a review)
            row["required"] = True
        else:
            row["default"] = field.get_default(call_default_factory=True)
        rows.append(row)
    return rows


def cmd_behaviours(args: argparse.Namespace) -> int:
    """List every behaviour family, its variants (default first) and their parameters."""
    registry = default_registry()
    if args.json:
        out = [
            {"family": s.family, "variant": s.variant, "default": s.default,
             "summary": s.summary, "params": _param_rows(s.params),
             "pairs_with": [list(p) for p in s.contract.pairs_with],
             "package": package_of(s)}
            for s in registry.specs()
        ]
        print(json.dumps(out, indent=2, default=str))
        return 0
    def plain(text: str) -> str:  # docstring markup (``psi_u``) read as clutter (a review)
        return text.replace("``", "")

    for family in registry.families():
        slot = misspelt_slot(family)  # a review's plug-in family "find_plum" was listed silently
        print(f"{family}" + (f"  (not a TRO slot: one slip from {slot}; misspelt?)"
                             if slot else ""))
        for spec in registry.variants(family):
            mark = " (default)" if spec.default else ""
            print(textwrap.fill(f"{spec.variant}{mark}: {plain(spec.summary)}", 100,
                                initial_indent="  ", subsequent_indent="      "))
            # what validate would refuse, and whose it is (a review learnt both late)
            notes = [f"with {f} {v} only" for f, v in spec.contract.pairs_with]
            package = package_of(spec)
            if package != "cptbt":
                notes.append(f"from the plug-in package {package}")
            if notes:
                print(f"      ({'; '.join(notes)})")
            for row in _param_rows(spec.params):
                given = "(required)" if row.get("required") else f"= {row['default']!r}"
                print(textwrap.fill(f"{row['name']} {given}  "
                                    f"{plain(row['description'])}", 100,
                                    initial_indent="      ", subsequent_indent="          "))
    return 0


def cmd_schema(args: argparse.Namespace) -> int:
    """Print the JSON Schema of mission files (for editor completion and validation)."""
    schema = mission_json_schema(default_registry(), environment_model())
    json.dump(schema, sys.stdout, indent=2)
    print()
    return 0
