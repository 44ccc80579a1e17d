"""YAML values pydantic would convert silently, found so that the gate can refuse them.

YAML has its own numbers and booleans: a quoted number or ``yes`` where a number is meant is a
slip, not a way of writing one; :func:`coercions` finds every such value in a mission's data.
"""

from __future__ import annotations

import json
import logging
import re
from typing import Any, Literal, get_args, get_origin

from pydantic import BaseModel, ValidationError

from cptbt.mission import Loc


def data_path(loc: Loc, data: Any) -> Loc:
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



_COERCIONS = {"float_type": "a number", "int_type": "a whole number", "bool_type": "true or false"}
"""Strict-mode error types that mean pydantic's lax mode converted a YAML value of another
type: ``cycle_hz: yes`` (a YAML boolean) read as 1, ``speed_mps: "1.5"`` (a string) as 1.5."""


def coercions(data: Any, model: type[BaseModel]) -> list[tuple[Loc, str]]:
    """Values that validated only by being converted from another YAML type, (path, message)
    each.

    YAML has its own numbers and booleans, so a boolean or a quoted string where a number is
    meant is a slip (``yes`` for 1, ``"1.0"``), not a way of writing one. The mission is
    validated again in strict JSON mode (JSON arrays still fill tuples, integers floats), and
    only these type errors are kept: strict mode's other opinions are not the mission's. Strict
    mode still takes ``true`` for ``Literal[1, 2]`` (True is 1 in Python): a boolean for a
    top-level field that does not take one is refused too (``flow: {noise_order: true}``).
    """
    try:
        text = json.dumps(data, allow_nan=False)
    except (TypeError, ValueError):  # values JSON cannot carry: the lax pass judged them
        return []
    out = _literal_booleans(data, model)
    said = logging.getLogger("cptbt.mission")  # its notes were said by the first pass (a
    was, said.disabled = said.disabled, True  # review's -v printed each twice)
    try:
        model.model_validate_json(text, strict=True, context={"problems": []})
    except ValidationError as exc:
        seen = {path for path, _ in out}
        for err in exc.errors(include_url=False):
            want = _COERCIONS.get(err["type"])
            value = err.get("input")
            if want is None or isinstance(value, (dict, list)):
                continue
            if isinstance(value, float) and value.is_integer() and err["type"] == "int_type":
                continue  # 100.0 for a count: the value is whole, only its spelling is not
            path = data_path(tuple(err["loc"]), data)
            if path in seen:
                continue
            out.append((path, f"expected {want}, got {_given(value)}"))
    finally:
        said.disabled = was
    return out


def _given(value: Any) -> str:
    """A converted value as the file spelled it, as near as YAML lets us tell: ``cycle_hz:
    yes`` had read "got True", a word the file does not have."""
    if isinstance(value, bool):
        return ("a YAML boolean (yes, on and true all read as true)" if value
                else "a YAML boolean (no, off and false all read as false)")
    if isinstance(value, str):
        return f"{value!r} ({'a quoted string' if _numeric(value) else 'text'})"
    return f"{value!r} ({type(value).__name__})"


_DECIMAL = re.compile(r"^[-+]?(?:\.[0-9]+|[0-9]+(?:\.[0-9]*)?)(?:[eE][-+]?[0-9]+)?$")


def _numeric(text: str) -> bool:
    """Whether text is a decimal number (so in a YAML file it was quoted: every plain number
    form is a number, or refused, at the door; Python's ``float`` also takes ``nan``, which a
    plain YAML ``nan`` is text for)."""
    return bool(_DECIMAL.match(text))


def _literal_booleans(data: Any, model: type[BaseModel]) -> list[tuple[Loc, str]]:
    """Top-level booleans given for a ``Literal`` of other values, (path, message) each."""
    if not isinstance(data, dict):
        return []
    out: list[tuple[Loc, str]] = []
    for key, value in data.items():
        field = model.model_fields.get(key)
        if (isinstance(value, bool) and field is not None
                and get_origin(field.annotation) is Literal
                and not any(isinstance(o, bool) for o in get_args(field.annotation))):
            options = ", ".join(repr(o) for o in get_args(field.annotation))
            out.append(((key,), f"expected one of {options}, got {_given(value)}"))
    return out
