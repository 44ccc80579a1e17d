"""The YAML dialect of mission files: PyYAML's safe loader, with YAML 1.2's numbers where 1.1
reads text (``1e-3``, ``-.5``), and YAML 1.1's other number forms (``017``, ``0x10``, ``1_5``,
``1:30``, ``09``) found so that the loader can refuse them (:func:`old_number`).
"""

from __future__ import annotations

import re
from typing import Any

import yaml


class MissionLoader(yaml.SafeLoader):
    """The safe YAML loader of every mission, study and sweep value cptbt reads.

    PyYAML follows YAML 1.1, where a float needs a dot: ``1e-3`` and ``1E9`` are strings there,
    and a mission would refuse them as quoted strings. YAML 1.2 reads them as numbers, and
    users write small probabilities so; this loader adds YAML 1.2's exponent floats, and its
    signed ``-.5`` and ``+.5``. A quoted ``'1e-3'`` stays a string (implicit resolution applies
    to plain scalars only). YAML 1.1's other number forms are refused (:func:`old_number`).
    """


MissionLoader.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(r"^[-+]?(?:\.[0-9]+|[0-9]+(?:\.[0-9]*)?)[eE][-+]?[0-9]+$"),
    list("-+0123456789."),
)
MissionLoader.add_implicit_resolver(  # -.5 and +.5, which YAML 1.1 reads as text (.5 it reads)
    "tag:yaml.org,2002:float", re.compile(r"^[-+]\.[0-9]+$"), list("-+"))
MissionLoader.add_implicit_resolver(  # 09, 0900: text in YAML 1.1, refused as such by name
    "tag:yaml.org,2002:int", re.compile(r"^[-+]?0[0-9_]*[89][0-9_]*$"), list("-+0"))


_INT, _FLOAT = "tag:yaml.org,2002:int", "tag:yaml.org,2002:float"
_OLD_NUMBERS = (
    (re.compile(r"^[-+]?0[0-9_]*[89][0-9_]*$"), "leading zero"),
    (re.compile(r"^[-+]?0[0-7_]+$"), "octal"),
    (re.compile(r"^[-+]?0x[0-9a-fA-F_]+$"), "hexadecimal"),
    (re.compile(r"^[-+]?0b[01_]+$"), "binary"),
    (re.compile(r"^[-+]?[0-9][0-9_]*(?::[0-5]?[0-9])+(?:\.[0-9_]*)?$"), "base 60"),
    (re.compile(r"_"), "digits grouped with _"),
)
"""YAML 1.1's number forms besides plain decimal, which PyYAML reads (``seed: 017`` as 15,
``speed_mps: 1_5`` as 15, ``beta_deg: 1:30`` as 90) and YAML 1.2 reads otherwise or not at
all: a mission refuses them rather than fly a number its author did not write."""


class RefusedValueError(yaml.YAMLError):
    """A value the mission dialect refuses (the message says why)."""


class OldNumberError(RefusedValueError):
    """A plain scalar in one of :data:`_OLD_NUMBERS`' forms."""


MAX_VALUES = 50_000
"""Most values a mission, or one ``--sweep`` value, may hold once its aliases are expanded (a
guard against alias bombs)."""

MAX_DEPTH = 40
"""Deepest nesting of mappings and sequences a mission, or one ``--sweep`` value, may have (the
shipped missions: 5)."""


MAX_NUMBER_CHARS = 100
"""A plain number longer than this is refused at its key (Python reads at most 4 300 digits of
an integer, and says so in its own words)."""


def old_number(node: yaml.Node) -> str | None:
    """Why a plain scalar that YAML 1.1 reads as a number is refused (None: it is not)."""
    if not isinstance(node, yaml.ScalarNode) or node.style or node.tag not in (_INT, _FLOAT):
        return None
    text = node.value
    if len(text) > MAX_NUMBER_CHARS:  # an attacker's 5001 digits read "(yaml): ... use
        # sys.set_int_max_str_digits()" at line 1, its key unnamed
        return (f"a number {len(text)} characters long: no mission value needs more than "
                f"{MAX_NUMBER_CHARS}")
    for pattern, kind in _OLD_NUMBERS:
        if pattern.search(text):
            fix = "write the number in plain decimal (or quote it, if it is text)"
            if kind == "leading zero":
                return (f"{text!r} has a leading zero, which YAML 1.1 reads as text (and 017 "
                        f"as octal 15): {fix}")
            return f"{text!r} is read by YAML 1.1 as {yaml.safe_load(text)!r} ({kind}): {fix}"
    return None


def load_scalar(text: str) -> Any:
    """One YAML value read as a mission would read it (e.g. a ``--sweep`` value).

    Raises:
        OldNumberError: a number in an old YAML 1.1 form (:func:`old_number`).
        RefusedValueError: an alias that contains itself, more than :data:`MAX_VALUES` values
            once aliases are expanded, or nesting deeper than :data:`MAX_DEPTH` (the mission
            loader's guards: an attacker's ``--sweep`` value had recursed without end, and an
            alias bomb had taken 0.9 GB).
    """
    loader = MissionLoader(text)
    try:
        node = loader.get_single_node()
        for scalar in _scalars(node):  # inside a mapping or a list too (a whole behaviour's
            # radius_m: 010 flew 8, a point's [043, -55] the source 8 m off: a diff review)
            why = old_number(scalar)
            if why:
                raise OldNumberError(why)
        return loader.construct_document(node) if node is not None else None
    finally:
        loader.dispose()


def _scalars(node: yaml.Node | None) -> list[yaml.Node]:
    """Every scalar node of a value, depth-first, within the loader's guards (see
    :func:`load_scalar`)."""
    out: list[yaml.Node] = []
    on_path: set[int] = set()
    seen = 0

    def visit(n: yaml.Node, depth: int) -> None:
        nonlocal seen
        seen += 1
        if seen > MAX_VALUES:
            raise RefusedValueError(f"more than {MAX_VALUES} values once aliases are "
                                    "expanded: refused (no mission needs so many; an alias bomb?)")
        if depth > MAX_DEPTH:
            raise RefusedValueError(f"nested deeper than {MAX_DEPTH} levels")
        if not isinstance(n, yaml.MappingNode | yaml.SequenceNode):
            out.append(n)
            return
        if id(n) in on_path:
            raise RefusedValueError("an alias refers to a value that contains it")
        on_path.add(id(n))
        items = ([x for pair in n.value for x in pair] if isinstance(n, yaml.MappingNode)
                 else n.value)
        for item in items:
            visit(item, depth + 1)
        on_path.discard(id(n))

    if node is not None:
        visit(node, 0)
    return out
