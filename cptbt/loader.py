"""Reading and writing mission files: safe YAML in, one-line errors out.

Every problem is reported as ``FILE:LINE: path.to.field: message``. YAML is read with the safe
loader (no tags that construct objects) and duplicate keys are errors rather than silently
overwritten.
"""

from __future__ import annotations

import difflib
import re
from collections.abc import Sequence
from pathlib import Path
from types import UnionType
from typing import Annotated, Any, Union, get_args, get_origin

import yaml
from pydantic import BaseModel, ValidationError

from cptbt.coercions import coercions, data_path
from cptbt.mission import Loc, MissionBase, Problem, dotted, mission_model, mission_to_data
from cptbt.registry import Registry, default_registry
from cptbt.yaml_dialect import MAX_DEPTH, MAX_VALUES, MissionLoader, old_number

MAX_BYTES = 1_000_000
"""A mission file larger than this is refused (the shipped ones are a few kB)."""

MOVED_KEYS: dict[tuple[str, ...], str] = {
    ("threshold",): "perception.threshold",
    ("flow_window_s",): "perception.flow_window_s",
    ("maintain_plume", "lambda_s"): "perception.lambda_s",
}
"""Keys of earlier mission files that moved, by (parent, key): where they live now."""


class MissionError(Exception):
    """A mission file is malformed; ``problems`` holds one line per problem.

    ``located`` holds the same problems as (key path, message) when each is about a key of the
    validated data (validation errors, not YAML syntax), so a caller that built the data itself
    (a sweep) can say where they are in its own terms.
    """

    def __init__(self, problems: list[str], located: list[tuple[Loc, str]] | None = None
                 ) -> None:
        super().__init__("\n".join(problems))
        self.problems = problems
        self.located = located


_OTHER_TYPES = frozenset(f"tag:yaml.org,2002:{t}" for t in ("set", "binary", "omap", "pairs"))
"""YAML's types beyond a mission's: a set has no order (a point read from one could come out
either way round), and bytes, ordered maps and pairs are nothing a mission holds."""


class Lines(dict[Loc, int]):
    """Each key path's line in the file; ``cols`` holds its column, so that several problems
    on one line (a flow mapping: ``{radius_m: "10", confidence: "0.9"}``) are told left to right."""

    def __init__(self) -> None:
        super().__init__()
        self.cols: dict[Loc, int] = {}


class _Walk:
    """Maps every key path to its line, refusing what could make the loader explode."""

    def __init__(self, source: str) -> None:
        self.source = source
        self.lines = Lines()
        self.values = 0
        self.seen: set[int] = set()
        self.on_path: set[int] = set()
        # problems that leave the document readable (an old YAML 1.1 number form, a duplicate
        # key: the later value is kept), told with the rest once it is validated
        self.soft: list[tuple[Loc, str]] = []

    def fail(self, line: int, path: Loc, msg: str) -> MissionError:
        return MissionError([f"{self.source}:{line}: {dotted(path)}: {msg}"])

    def walk(self, node: yaml.Node, path: Loc, alias_at: Loc | None = None) -> None:
        """Record lines under ``path``; ``alias_at`` is where an alias expansion began."""
        if id(node) in self.seen and alias_at is None:
            alias_at = path  # a value reached a second time: this key holds an alias
        self.seen.add(id(node))
        line = node.start_mark.line + 1
        self.lines.setdefault(path, line)
        self.lines.cols.setdefault(path, node.start_mark.column)
        self.values += 1
        if self.values > MAX_VALUES:
            at = alias_at if alias_at is not None else path
            raise self.fail(self.lines.get(at, line), at, f"more than {MAX_VALUES} values once "
                            "aliases are expanded: refused (no mission needs so many; an alias "
                            "bomb?)")
        if len(path) > MAX_DEPTH:
            raise self.fail(line, path, f"nested deeper than {MAX_DEPTH} levels")
        if node.tag in _OTHER_TYPES:  # !!set {100, 0} read as the point (0, 100)
            raise self.fail(line, path, f"!!{node.tag.rsplit(':', 1)[1]}: a mission value is "
                            "a number, text, true/false, a list or a mapping")
        why = old_number(node)
        if why:  # every one in the file is told at once (after the walk)
            self.soft.append((path, why))
        if not isinstance(node, yaml.MappingNode | yaml.SequenceNode):
            return
        if id(node) in self.on_path:
            raise self.fail(self.lines.get(path, line), path,
                            "an alias refers to a value that contains it")
        self.on_path.add(id(node))
        if isinstance(node, yaml.MappingNode):
            keys: dict[Any, int] = {}
            for key_node, value_node in node.value:
                key_line = key_node.start_mark.line + 1
                if not isinstance(key_node, yaml.ScalarNode):
                    kind = "list" if isinstance(key_node, yaml.SequenceNode) else "mapping"
                    raise self.fail(key_line, path, f"a key must be a plain word, not a {kind}")
                if key_node.tag in _WORDLESS_KEYS and not key_node.style:  # `~:`, `yes:`
                    kind = _WORDLESS_KEYS[key_node.tag]  # (a review's `~:` was told at line 1)
                    raise self.fail(key_line, (*path, key_node.value),
                                    f"a key must be a word, and this one reads as {kind}")
                key = key_node.value
                if key in keys:  # told with the rest (a review's file was told this alone),
                    if alias_at is None:  # once: not again where an alias repeats the mapping
                        self.soft.append(((*path, key),
                                          f"duplicate key (first at line {keys[key]})"))
                else:
                    keys[key] = key_line
                if alias_at is None:
                    self.lines[(*path, key)] = key_line
                    self.lines.cols[(*path, key)] = key_node.start_mark.column
                self.walk(value_node, (*path, key), alias_at)
        else:
            for i, item in enumerate(node.value):
                if alias_at is None:
                    # An alias's node carries the line of its anchor; use the list's own line.
                    aliased = id(item) in self.seen
                    line_i = self.lines[path] if aliased else item.start_mark.line + 1
                    self.lines.setdefault((*path, i), line_i)
                self.walk(item, (*path, i), alias_at)
        self.on_path.discard(id(node))


_WORDLESS_KEYS = {"tag:yaml.org,2002:null": "null", "tag:yaml.org,2002:bool": "true/false"}
"""Keys YAML reads as something other than a word (a number key is told by the schema)."""

_OPENERS = (yaml.BlockMappingStartToken, yaml.BlockSequenceStartToken,
            yaml.FlowMappingStartToken, yaml.FlowSequenceStartToken)
_CLOSERS = (yaml.BlockEndToken, yaml.FlowMappingEndToken, yaml.FlowSequenceEndToken)


def _check_depth(text: str, source: str) -> None:
    """Refuse deep nesting before the (recursive) composer sees it."""
    depth = 0
    for token in yaml.scan(text, Loader=MissionLoader):
        if isinstance(token, _OPENERS):
            depth += 1
            if depth > MAX_DEPTH:
                line = token.start_mark.line + 1
                raise MissionError([f"{source}:{line}: (yaml): nested deeper than {MAX_DEPTH} "
                                    "levels"])
        elif isinstance(token, _CLOSERS):
            depth -= 1


def parse_yaml(text: str, source: str) -> tuple[Any, dict[Loc, int]]:
    """:func:`read_yaml`, refusing a document with any problem (duplicate keys and old number
    forms too, which :func:`read_yaml` returns to be told with the validation's).

    Raises:
        MissionError: as :func:`read_yaml`, and for those problems.
    """
    data, lines, soft = read_yaml(text, source)
    _raise([], soft, lines, source)
    return data, lines


def read_yaml(text: str, source: str) -> tuple[Any, Lines, list[tuple[Loc, str]]]:
    """Safe-load one YAML document and map every key path to its line.

    Refused, each with one ``FILE:LINE: path: message`` line: files over :data:`MAX_BYTES`,
    control characters (NUL...), nesting deeper than :data:`MAX_DEPTH`, aliases that contain
    themselves or expand past :data:`MAX_VALUES` values, keys that are not plain scalars,
    duplicate keys, unsafe tags and anything else the YAML parser rejects.

    Raises:
        MissionError: the text is not a mission-sized, plain YAML document.
    """
    size = len(text.encode("utf-8", "surrogatepass"))
    if size > MAX_BYTES:
        raise MissionError([f"{source}:1: (file): {size} bytes; a mission file may have at most "
                            f"{MAX_BYTES}"])
    loader: MissionLoader | None = None
    try:
        _check_depth(text, source)
        loader = MissionLoader(text)
        node = loader.get_single_node()
        if node is None:
            raise MissionError([f"{source}:1: (top): the file is empty"])
        walk = _Walk(source)
        walk.walk(node, ())
        try:
            data = loader.construct_document(node)
        except (ValueError, OverflowError):  # an old number form PyYAML cannot read (01800)
            _raise([], walk.soft, walk.lines, source)
            raise
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        line = mark.line + 1 if mark else 1
        msg = " ".join(str(x) for x in (exc.context, exc.problem) if x)
        if "'\\t'" in str(exc.problem):  # PyYAML's words for a tab read as a token's start
            msg = (f"a tab character at column {mark.column + 1 if mark else '?'}: YAML indents "
                   "and separates with spaces only; replace the tab with spaces")
        began = exc.context_mark
        if began is not None and mark is not None and began.line != mark.line:
            msg += f" (it began at line {began.line + 1})"
        raise MissionError([f"{source}:{line}: (yaml): {msg}"]) from None
    except yaml.reader.ReaderError as exc:
        line = text.count("\n", 0, max(exc.position, 0)) + 1
        what = "NUL byte" if exc.character in (0, "\0") else f"character {exc.character!r}"
        raise MissionError(
            [f"{source}:{line}: (yaml): {what} not allowed in a mission file"]
        ) from None
    except yaml.YAMLError as exc:
        raise MissionError([f"{source}:1: (yaml): {' '.join(str(exc).split())}"]) from None
    except (RecursionError, ValueError, OverflowError) as exc:  # e.g. a 5000-digit integer
        raise MissionError([f"{source}:1: (yaml): cannot read: {exc}"]) from None
    finally:
        if loader is not None:
            loader.dispose()
    return data, walk.lines, walk.soft


def _line(path: Loc, lines: dict[Loc, int]) -> int:
    """The line of ``path``'s deepest part the file has (a key YAML read as a number, such
    as ``1: foo``, is recorded as it was written)."""
    return _place(path, lines)[0]


def _place(path: Loc, lines: dict[Loc, int]) -> tuple[int, int]:
    """(line, column) of ``path``'s deepest part the file has (column 0 where the lines
    carry none): the order problems are told in."""
    cols = lines.cols if isinstance(lines, Lines) else {}
    for i in range(len(path), -1, -1):
        head = path[:i]
        for key in (head, (*head[:-1], str(head[-1])) if head else head):
            if key in lines:
                return lines[key], cols.get(key, 0)
    return 1, 0


def _at(data: Any, path: Loc) -> Any:
    for part in path:
        try:
            data = data[part]
        except (KeyError, IndexError, TypeError):
            return None
    return data


def _unknown_key(path: Loc, model: type[BaseModel] | None, data: Any) -> str:
    """The message for an unknown key: where it moved, or the close matches."""
    key = str(path[-1])
    moved = MOVED_KEYS.get(tuple(str(p) for p in path[-2:])) or MOVED_KEYS.get((key,))
    if moved and (len(path) == 1 or path[-2] == "maintain_plume"):
        return (f"unknown key: '{key}' moved to {moved} in cptbt 0.2; write it under "
                f"'{moved.split('.')[0]}:'")
    known = _fields_at(model, path[:-1], data) if model is not None else []
    owner = ""
    if len(path) == 4 and path[0] == "behaviours":  # a behaviour's parameter: whose keys
        entry = _at(data, path[:3])
        variant = entry.get("variant") if isinstance(entry, dict) else None
        owner = (f" of {path[2]} {variant}" if isinstance(variant, str)
                 else f" of {path[2]}'s default variant")
    return f"unknown key{owner}" + (close_matches(key, known) if known else "")


def _fields_at(model: type[BaseModel], path: Loc, data: Any) -> list[str]:
    """Field names of the model that validates the mapping at ``path`` (for suggestions)."""
    kind: Any = model
    for i, part in enumerate(path):
        kind = _unwrap(kind, _at(data, path[:i]))
        if isinstance(kind, type) and issubclass(kind, BaseModel):
            field = kind.model_fields.get(str(part))
            if field is None:
                return []
            kind = field.annotation
        elif get_origin(kind) is list:
            kind = get_args(kind)[0]
        else:
            return []
    kind = _unwrap(kind, _at(data, path))
    if isinstance(kind, type) and issubclass(kind, BaseModel):
        return list(kind.model_fields)
    return []


def _unwrap(kind: Any, value: Any) -> Any:
    """Strip Optional/Annotated; pick a discriminated union's member by the data's ``variant``."""
    while True:
        if get_origin(kind) is Annotated:
            kind = get_args(kind)[0]
        elif get_origin(kind) in (Union, UnionType):
            members = [a for a in get_args(kind) if a is not type(None)]
            variant = value.get("variant") if isinstance(value, dict) else None
            pick = [m for m in members if isinstance(m, type) and issubclass(m, BaseModel)
                    and m.model_fields.get("variant") is not None
                    and m.model_fields["variant"].default == variant]
            kind = pick[0] if pick else members[0] if len(members) == 1 else None
        else:
            return kind


def close_matches(word: str, choices: list[str], known: bool = True) -> str:
    """``; did you mean 'x'?`` for the close matches of ``word``, or ``; known keys: ...``
    (nothing without ``known``)."""
    matches = difflib.get_close_matches(word, choices, n=3, cutoff=0.6)
    if matches:
        return "; did you mean " + " or ".join(repr(m) for m in matches) + "?"
    return "; known keys: " + ", ".join(choices) if known else ""


BOUND_ERRORS = frozenset({"greater_than", "greater_than_equal", "less_than",
                          "less_than_equal"})
"""pydantic's range errors: their message is told with the value given."""


def format_errors(
    exc: ValidationError,
    data: Any,
    lines: dict[Loc, int],
    source: str,
    prefix: Loc = (),
    model: type[BaseModel] | None = None,
) -> list[str]:
    """One ``FILE:LINE: path: message`` line per pydantic error."""
    return _render(located_errors(exc, data, prefix, model), lines, source)


def _render(located: list[tuple[Loc, str]], lines: dict[Loc, int], source: str) -> list[str]:
    return [f"{source}:{_line(loc, lines)}: {dotted(loc)}: {msg}" for loc, msg in located]


def located_errors(
    exc: ValidationError, data: Any, prefix: Loc = (), model: type[BaseModel] | None = None
) -> list[tuple[Loc, str]]:
    """(key path, message) per pydantic error."""
    out = []
    for err in exc.errors(include_url=False):
        path = data_path(tuple(err["loc"]), data)
        msg = err["msg"].removeprefix("Value error, ")
        loc = tuple(err["loc"])
        if err["type"] == "extra_forbidden":
            msg = _unknown_key(path, model, data)
        elif err["type"] == "literal_error" and isinstance(err.get("input"), str):
            # pydantic's "Input should be 'a', 'b' or 'c'", in our words, with a suggestion
            # (a review's preset: tro_ocaen was told the list, no did-you-mean)
            options = re.findall(r"'([^']*)'", msg)
            msg = (f"unknown value {err['input']!r}: one of "
                   + ", ".join(repr(o) for o in options)
                   + close_matches(err["input"], options, known=False))
        elif err["type"] in BOUND_ERRORS and isinstance(err.get("input"), (int, float)):
            msg = f"{msg}, got {err['input']!r}"  # a review: the bad value was not echoed
        elif err["type"] == "missing" and loc and isinstance(loc[-1], int):
            given = err.get("input")  # a short list (a point of one coordinate), not a key
            count = len(given) if isinstance(given, (list, tuple)) else "fewer"
            msg = f"too few values: {count} given, item {loc[-1] + 1} missing"
        elif msg.startswith("unknown variant") or msg.startswith("'oracle'"):
            item = _at(data, path)
            if isinstance(item, dict) and len(item) == 1:
                (family,) = item
                path = (*path, family, "variant") if isinstance(item[family], dict) else path
        out.append(((*prefix, *path), msg))
    return out


def format_problems(problems: list[Problem], lines: dict[Loc, int], source: str,
                    by_line: bool = False) -> list[str]:
    """One ``FILE:LINE: path: message`` line per cross-field problem of a mission (with
    ``by_line``, in the file's line order)."""
    ordered = sorted(problems, key=lambda p: _place(p[0], lines)) if by_line else list(problems)
    return _render(ordered, lines, source)


def validate_data(
    data: Any, lines: dict[Loc, int], source: str, model: type[BaseModel],
    soft: Sequence[tuple[Loc, str]] = (),
) -> BaseModel:
    """Validate parsed YAML against a model, turning errors into a :class:`MissionError`.

    Cross-field problems (:meth:`~cptbt.mission.MissionBase.problems`) are reported at the line
    of the key each is about; ``soft`` are the reading's own (:func:`read_yaml`), told with the
    rest (a key they are about is not told again).
    """
    problems: list[Problem] = []
    try:
        result = model.model_validate(data, context={"problems": problems})
    except ValidationError as exc:
        located = located_errors(exc, data, model=model)
        # the converted values too, in the same pass (a review's file with five mistakes was
        # told four, and the fifth only once they were mended), and all in the file's order
        seen = {loc for loc, _ in located}
        located += [(loc, msg) for loc, msg in coercions(data, model) if loc not in seen]
        _raise(located, soft, lines, source)
    _raise(coercions(data, model) or list(problems), soft, lines, source)
    return result


def _raise(located: list[tuple[Loc, str]], soft: Sequence[tuple[Loc, str]],
           lines: dict[Loc, int], source: str) -> None:
    """Raise :class:`MissionError` with every problem in the file's order, if there is one."""
    told = {loc for loc, _ in soft}
    every = [*soft, *((loc, msg) for loc, msg in located if loc not in told)]
    if every:
        every.sort(key=lambda e: _place(e[0], lines))
        raise MissionError(_render(every, lines, source), every) from None


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
    return loads_mission(read_mission_text(path), source, registry, environment)


def read_mission_text(path: str | Path) -> str:
    """A mission file's text, read once and no further than a mission's size (/dev/zero is
    endless; a pipe cannot be read twice).

    Raises:
        MissionError: the file cannot be read, is too large or is not UTF-8.
    """
    source = str(path)
    try:
        with Path(path).open("rb") as f:
            raw = f.read(MAX_BYTES + 1)
    except OSError as exc:
        raise MissionError([f"{source}: (file): cannot be read: {exc.strerror or exc}"]) from None
    if len(raw) > MAX_BYTES:
        raise MissionError([f"{source}:1: (file): more than {MAX_BYTES} bytes; a mission file "
                            f"may have at most {MAX_BYTES}"])
    return decode(raw, source)


def decode(raw: bytes, source: str) -> str:
    """A mission file's bytes as UTF-8 text.

    Raises:
        MissionError: a byte sequence is not UTF-8, reported at its line and column (1-based;
            the column counts bytes).
    """
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = raw.count(b"\n", 0, exc.start) + 1
        column = exc.start - (raw.rfind(b"\n", 0, exc.start) + 1) + 1
        raise MissionError([f"{source}:{line}: (file): byte 0x{raw[exc.start]:02x} at column "
                            f"{column} is not UTF-8 ({exc.reason}); save the file as UTF-8"]
                           ) from None


def loads_mission(
    text: str,
    source: str = "<mission>",
    registry: Registry | None = None,
    environment: type[BaseModel] | None = None,
) -> MissionBase:
    """Like :func:`load_mission`, from text."""
    data, lines, soft = read_yaml(text, source)
    if not isinstance(data, dict):
        what = ("an empty document (only '---' or comments)" if data is None
                else type(data).__name__)
        raise MissionError([f"{source}:1: (top): a mission is a mapping of keys, not {what}"])
    model = mission_model(registry or default_registry(), environment)
    return validate_data(data, lines, source, model, soft)  # type: ignore[return-value]


def dump_mission(mission: MissionBase) -> str:
    """The mission as YAML that loads back to an equal mission."""
    return yaml.safe_dump(mission_to_data(mission), sort_keys=False, default_flow_style=None)
