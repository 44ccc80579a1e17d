"""Argument types of the command line: each checks one value at the door, so a bad number is a
usage error (one line, exit 2) rather than a crash or a silent nonsense study later.

Every function takes the argument's text and returns the parsed value or raises
``argparse.ArgumentTypeError`` with a message that says what was expected.
"""

from __future__ import annotations

import argparse
import math
import signal
import threading
from pathlib import Path
from types import FrameType

from cptbt.batch.starts import MAX_STARTS, line_xs

Start = tuple[float, float]


def _number(text: str, kind: type[int] | type[float]) -> float:
    try:
        if "_" in text:  # Python reads 1_0 as 10; a mission refuses it (yaml_dialect.old_number)
            raise ValueError(text)
        return kind(text.strip())
    except ValueError:
        name = "an integer" if kind is int else "a number"
        raise argparse.ArgumentTypeError(f"{text!r} is not {name}") from None


def positive_int(text: str) -> int:
    """An integer ≥ 1 (counts: runs per start, workers)."""
    value = int(_number(text, int))
    if value < 1:
        raise argparse.ArgumentTypeError(f"{value} must be at least 1")
    return value


def non_negative_int(text: str) -> int:
    """An integer ≥ 0 (seeds: ``numpy.random.SeedSequence`` takes no negative entropy)."""
    value = int(_number(text, int))
    if value < 0:
        raise argparse.ArgumentTypeError(f"{value} must be 0 or more")
    return value


def seed(text: str) -> int:
    """A seed: an integer from 0 to 2**63 - 1 (the results table stores it as a 64-bit
    integer: a review's 2**63 flew a group, then failed writing it, on every resume)."""
    value = non_negative_int(text)
    if value >= 2**63:
        raise argparse.ArgumentTypeError(f"{value} must be below 2**63")
    return value


def out_dir(text: str) -> str:
    """A folder to write to, not empty (an unset shell variable, ``--out "$OUT"``, had written
    a study into the current folder: a review)."""
    if not text.strip():
        raise argparse.ArgumentTypeError("an empty folder name: give a folder")
    return text


def finite_float(text: str) -> float:
    """A finite number (coordinates, m)."""
    value = float(_number(text, float))
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"{text!r} must be a finite number")
    return value


def positive_float(text: str) -> float:
    """A finite number > 0 (durations, s)."""
    value = finite_float(text)
    if value <= 0:
        raise argparse.ArgumentTypeError(f"{text!r} must be more than 0")
    return value


def clock_scale(text: str) -> float:
    """A pace relative to real time, 0.001 to 10 000 (1e-300 overflowed the clock)."""
    value = positive_float(text)
    if not 1e-3 <= value <= 1e4:
        raise argparse.ArgumentTypeError(f"{text!r} must be between 0.001 and 10000")
    return value


def probability(text: str) -> float:
    """A probability, 0 to 1."""
    value = finite_float(text)
    if not 0.0 <= value <= 1.0:
        raise argparse.ArgumentTypeError(f"{text!r} must be between 0 and 1")
    return value


def grid(text: str) -> tuple[int, int]:
    """``NXxNY`` (or ``N`` for ``NxN``), both at least 1, at most ``MAX_STARTS`` cells."""
    nx_text, sep, ny_text = text.strip().lower().partition("x")
    try:
        nx = int(nx_text)
        ny = int(ny_text) if sep else nx
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"{text!r} is not a grid: expected NXxNY, e.g. 10x10") from None
    if nx < 1 or ny < 1:
        raise argparse.ArgumentTypeError(f"{text!r}: both sides of the grid must be at least 1")
    if nx * ny > MAX_STARTS:
        raise argparse.ArgumentTypeError(f"{text!r}: more than {MAX_STARTS} starts")
    return nx, ny


def start_range(text: str) -> list[float]:
    """``X0:X1:STEP`` with STEP > 0, X0 ≤ X1, all finite: the x of each start, X1 included."""
    try:
        return line_xs(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def starts(text: str) -> list[Start]:
    """``X,Y;X,Y;...``: explicit starts in the planning frame, every coordinate finite."""
    out: list[Start] = []
    for item in text.split(";"):
        if not item.strip():
            continue
        parts = item.split(",")
        if len(parts) != 2:
            raise argparse.ArgumentTypeError(
                f"{item.strip()!r} is not a start: expected X,Y (starts are separated by ';')")
        try:
            x, y = (finite_float(p) for p in parts)
        except argparse.ArgumentTypeError as exc:
            raise argparse.ArgumentTypeError(f"start {item.strip()!r}: {exc}") from None
        out.append((x, y))
    if not out:
        raise argparse.ArgumentTypeError("no starts given: expected X,Y;X,Y")
    if len(out) > MAX_STARTS:
        raise argparse.ArgumentTypeError(f"more than {MAX_STARTS} starts")
    return out


class UsageError(Exception):
    """A command line that parsed but makes no sense (found after parsing); exit status 2."""


def not_the_mission(option: str, path: str | None, mission: str | None) -> None:
    """Refuse an output path that is the mission file the command reads (a review: ``cptbt tree
    m.yaml --dot m.yaml`` and ``cptbt run m.yaml --log m.yaml`` replaced the mission, exit 0).

    Raises:
        UsageError: naming the option.
    """
    if not path or not mission:
        return
    out, src = Path(path), Path(mission)
    same = out.resolve() == src.resolve()
    if not same and out.exists() and src.exists():
        same = out.samefile(src)  # a hard link, or another path to it
    if same:
        raise UsageError(f"{option} {path} is the mission file this command reads: writing it "
                         "would replace the mission; give another file")


def sigterm_as_interrupt() -> None:
    """Make SIGTERM (``kill``, a scheduler's stop) end the command as Ctrl-C does: it says
    what it kept and exits 130, rather than dying silently."""
    def raise_interrupt(signum: int, frame: FrameType | None) -> None:
        raise KeyboardInterrupt

    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGTERM, raise_interrupt)
