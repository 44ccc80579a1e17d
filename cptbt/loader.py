"""Reading and writing mission files: safe YAML in, one-line errors out.

Every problem is reported as ``FILE:LINE: path.to.field: message``. YAML is read with the safe
loader (no tags that construct objects) and duplicate keys are errors rather than silently
overwritten.
"""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path
from typing import Any

import yaml
from pydantic import BaseModel, ValidationError

from cptbt.mission import MissionBase, mission_model, mission_to_data
from cptbt.registry import Registry, default_registry

Loc = tuple[str | int, ...]


class MissionError(Exception):
    """A mission file is malformed; ``problems`` holds one line per problem."""

    def __init__(self, problems: list[str]) -> None:
        super().__init__("\n".join(problems))
        self.problems = problems


def _walk(node: yaml.Node, path: Loc, lines: dict[Loc, int], source: str) -> None:
    lines[path] = node.start_mark.line + 1
    if isinstance(node, yaml.MappingNode):
        seen: dict[Any, int] = {}
        for key_node, value_node in node.value:
            key = key_node.value
            if key in seen:
                raise MissionError(
                    [
                        f"{source}:{key_node.start_mark.line + 1}: {_dotted((*path, key))}: "
                        f"duplicate key (first at line {seen[key]})"
                    ]
                )
            seen[key] = key_node.start_mark.line + 1
            _walk(value_node, (*path, key), lines, source)
            lines[(*path, key)] = key_node.start_mark.line + 1
    elif isinstance(node, yaml.SequenceNode):
        for i, item in enumerate(node.value):
            _walk(item, (*path, i), lines, source)


def _dotted(path: Iterable[str | int]) -> str:
    out = ""
    for part in path:
        out += f"[{part}]" if isinstance(part, int) else (f".{part}" if out else str(part))
    return out or "(top)"


def parse_yaml(text: str, source: str) -> tuple[Any, dict[Loc, int]]:
    """Safe-load one YAML document and map every key path to its line.

    Raises:
        MissionError: the text is not valid YAML, uses an unsafe tag, or repeats a key.
    """
    loader = yaml.SafeLoader(text)
    try:
        node = loader.get_single_node()
        if node is None:
            raise MissionError([f"{source}:1: (top): the file is empty"])
        lines: dict[Loc, int] = {}
        _walk(node, (), lines, source)
        data = loader.construct_document(node)
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        line = mark.line + 1 if mark else 1
        msg = " ".join(str(x) for x in (exc.context, exc.problem) if x)
        raise MissionError([f"{source}:{line}: (yaml): {msg}"]) from None
    except yaml.YAMLError as exc:
        raise MissionError([f"{source}:1: (yaml): {exc}"]) from None
    finally:
        loader.dispose()
    return data, lines


def _data_path(loc: Loc, data: Any) -> Loc:
    """The part of a pydantic error location that exists in the data (drops union tags)."""
    path: list[str | int] = []
    cur = data
    for part in loc:
        if (isinstance(cur, dict) and part in cur) or (
            isinstance(cur, list) and isinstance(part, int) and 0 <= part < len(cur)
        ):
            cur = cur[part]  # type: ignore[index]
        elif isinstance(cur, dict) and part == cur.get("variant"):
            continue  # the tag of a discriminated union, not a key of the file
        elif isinstance(cur, dict) and isinstance(part, str):
            path.append(part)  # a missing or unknown key: named, reported on its parent's line
            break
        else:
            break
        path.append(part)
    return tuple(path)


def format_errors(
    exc: ValidationError, data: Any, lines: dict[Loc, int], source: str, prefix: Loc = ()
) -> list[str]:
    """One ``FILE:LINE: path: message`` line per pydantic error."""
    out = []
    for err in exc.errors(include_url=False):
        path = _data_path(tuple(err["loc"]), data)
        full = (*prefix, *path)
        line = next((lines[full[:i]] for i in range(len(full), -1, -1) if full[:i] in lines), 1)
        msg = err["msg"].removeprefix("Value error, ")
        if err["type"] == "extra_forbidden":
            msg = "unknown key"
        out.append(f"{source}:{line}: {_dotted(full)}: {msg}")
    return out


def validate_data(
    data: Any, lines: dict[Loc, int], source: str, model: type[BaseModel]
) -> BaseModel:
    """Validate parsed YAML against a model, turning errors into a :class:`MissionError`."""
    try:
        return model.model_validate(data)
    except ValidationError as exc:
        raise MissionError(format_errors(exc, data, lines, source)) from None


def load_mission(
    path: str | Path, registry: Registry | None = None, environment: type[BaseModel] | None = None
) -> MissionBase:
    """Read, parse and validate a mission file.

    Args:
        path: the YAML file.
        registry: behaviours to validate against (default: the installed entry points).
        environment: the model of the ``environment`` section (the simulator's, in the
            application layer); without it the section is kept as plain data.

    Raises:
        MissionError: with one ``FILE:LINE: path: message`` line per problem.
    """
    source = str(path)
    try:
        text = Path(path).read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        reason = exc.strerror if isinstance(exc, OSError) else None
        raise MissionError([f"{source}:0: (file): {reason or exc}"]) from None
    return loads_mission(text, source, registry, environment)


def loads_mission(
    text: str,
    source: str = "<mission>",
    registry: Registry | None = None,
    environment: type[BaseModel] | None = None,
) -> MissionBase:
    """Like :func:`load_mission`, from text."""
    data, lines = parse_yaml(text, source)
    if not isinstance(data, dict):
        raise MissionError(
            [f"{source}:1: (top): a mission is a mapping of keys, not {type(data).__name__}"]
        )
    model = mission_model(registry or default_registry(), environment)
    return validate_data(data, lines, source, model)  # type: ignore[return-value]


def dump_mission(mission: MissionBase) -> str:
    """The mission as YAML that loads back to an equal mission."""
    return yaml.safe_dump(mission_to_data(mission), sort_keys=False, default_flow_style=None)
