"""The ``cptbt`` command line: the application layer that composes the planner and simulator.

Every command has ``--help``. Errors in mission files print one ``FILE:LINE: path: message`` line
each and exit with status 2, never a traceback.
"""

from __future__ import annotations

import argparse
import os
import sys
from collections.abc import Sequence
from typing import Any

from cptbt.cli import inspect_cmds, phases_cmd
from cptbt.loader import MissionError
from cptbt.registry import RegistryError

EXIT_USAGE = 2


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of every sub-command."""
    parser = argparse.ArgumentParser(
        prog="cptbt",
        description="Plan, simulate and study chemical plume tracing missions for an AUV.",
    )
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    inspect_cmds.add_parsers(sub)
    phases_cmd.add_parsers(sub)
    for module in _optional_command_modules():
        module.add_parsers(sub)
    return parser


def _optional_command_modules() -> list[Any]:
    """Command groups that need the simulator (absent when it cannot be imported)."""
    try:
        from cptbt.cli import batch_cmd, run_cmd
    except ImportError:  # the planner alone: validate, tree, behaviours, schema still work
        return []
    return [run_cmd, batch_cmd]


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``cptbt`` script; returns the exit status."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except MissionError as exc:
        for line in exc.problems:
            print(line, file=sys.stderr)
        return EXIT_USAGE
    except RegistryError as exc:
        print(f"cptbt: {exc}", file=sys.stderr)
        return EXIT_USAGE
    except BrokenPipeError:  # e.g. `cptbt run ... | head`: the reader left, nothing to report
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        return 1
    except KeyboardInterrupt:
        print("cptbt: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
