"""The ``cptbt`` command line: the application layer that composes the planner and simulator.

Every command has ``--help``. No input shows a traceback: a bad argument or mission file prints
one line per problem and exits with status 2 (mission problems as ``FILE:LINE: path: message``);
a failure while running (an unwritable output, an unreadable results table, an unreachable
cluster) prints one ``cptbt: ...`` line and exits with status 1. ``CPTBT_DEBUG=1`` shows the
traceback of unexpected errors.
"""

from __future__ import annotations

import argparse
import importlib.metadata
import logging
import os
import re
import sys
from collections.abc import Sequence
from typing import Any, NoReturn, cast

from cptbt.batch.errors import BatchError
from cptbt.cli import inspect_cmds, log_cmds, phases_cmd
from cptbt.cli.argtypes import UsageError
from cptbt.loader import MissionError
from cptbt.mission import printable
from cptbt.node import blame
from cptbt.registry import RegistryError

EXIT_RUNTIME = 1
EXIT_USAGE = 2
DEBUG_ENV = "CPTBT_DEBUG"


class _Parser(argparse.ArgumentParser):
    """An argument parser whose usage errors are one line (argparse prints the usage first)."""

    def error(self, message: str) -> NoReturn:
        """Print ``PROG: error: MESSAGE`` and exit with status 2."""
        self.exit(EXIT_USAGE, f"{self.prog}: error: {_one_line(message)} "
                              f"(see {self.prog} --help)\n")


def version() -> str:
    """The installed distribution's version (the package's own when run from a source tree)."""
    try:
        return importlib.metadata.version("cptbt")
    except importlib.metadata.PackageNotFoundError:
        from cptbt import __version__

        return __version__


def build_parser(command: str | None = None) -> argparse.ArgumentParser:
    """The argument parser of every sub-command.

    With ``command`` (the sub-command about to run) only the simulator-side module that defines
    it is imported: ``cptbt run`` need not import the batch, plotting and serving stacks
    (issue 15: a single run at 1000× real time counts the interpreter's imports too).
    """
    parser = _Parser(
        prog="cptbt",
        description="Plan, simulate and study chemical plume tracing missions for an AUV.",
    )
    parser.add_argument("--version", action="version", version=f"cptbt {version()}")
    parser.add_argument("-v", "--verbose", action="count", default=0,
                        help="log more: -v what the planner corrected (clock steps, rejected "
                        "samples), -vv everything")
    parser.add_argument("-q", "--quiet-log", dest="quiet_log", action="store_true",
                        help="log errors only (validation warnings and summaries still "
                        "print: for no output at all, run --quiet or batch --quiet)")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    inspect_cmds.add_parsers(sub)
    phases_cmd.add_parsers(sub)
    log_cmds.add_parsers(sub)
    for module in _optional_command_modules(command):
        module.add_parsers(sub)
    _plain_descriptions(parser)
    return parser


def _plain_descriptions(parser: argparse.ArgumentParser) -> None:
    """Sub-command descriptions are their functions' docstrings: ``--help`` shows them without
    the reStructuredText literal marks (double backquotes)."""
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for sub in action.choices.values():
                if sub.description:
                    sub.description = re.sub(r"``(.+?)``", r"\1", sub.description, flags=re.S)
                _plain_descriptions(sub)


def configure_logging(verbose: int, quiet: bool) -> None:
    """Log records of cptbt's per-module loggers to stderr, one line each.

    Default: warnings; ``-v``: info; ``-vv``: debug; ``-q``: errors only.
    """
    level = logging.ERROR if quiet else (
        logging.WARNING, logging.INFO, logging.DEBUG)[min(verbose, 2)]
    logger = logging.getLogger("cptbt")
    logger.setLevel(level)
    if not any(getattr(h, "_cptbt", False) for h in logger.handlers):
        handler = logging.StreamHandler(sys.stderr)
        handler.setFormatter(logging.Formatter("cptbt: %(levelname)s: %(name)s: %(message)s"))
        handler._cptbt = True  # type: ignore[attr-defined]
        logger.addHandler(handler)


MAX_PROBLEMS_TOLD = 50
"""A malformed mission is told this many problems at most, then how many more there are."""

MAX_PROBLEM_CHARS = 2000
"""A problem longer than this is cut, and its length said (it echoes what the file gave)."""

_COMMAND_MODULES = {"run": "run_cmd", "batch": "batch_cmd", "plot": "batch_cmd",
                    "serve": "serve_cmd", "frontseat": "serve_cmd"}
"""The simulator-side sub-commands and the module that defines each."""


def _optional_command_modules(command: str | None = None) -> list[Any]:
    """Command groups that need the simulator (absent when it cannot be imported).

    All of them, or only the one that defines ``command`` when it is one of theirs.
    """
    import importlib

    names = ([_COMMAND_MODULES[command]] if command in _COMMAND_MODULES
             else ["run_cmd", "batch_cmd", "serve_cmd"])
    try:
        return [importlib.import_module(f"cptbt.cli.{name}") for name in names]
    except ImportError as exc:  # the planner alone: validate, tree, behaviours, schema work
        if command in _COMMAND_MODULES:  # asked for by name: say why it is missing (it had
            # read "invalid choice: 'batch'", hiding a broken install: a review)
            raise UsageError(
                f"{command}: needs the simulator, which did not import ({type(exc).__name__}: "
                f"{_one_line(str(exc))}): is another copy of cptbt, or what an uninstall left "
                "of one, on the path? python -c 'import cptbt; print(cptbt.__path__)' shows "
                "which is used") from None
        return []


def _command_of(argv: Sequence[str] | None) -> str | None:
    """The sub-command named on the command line (the first argument not an option)."""
    words = sys.argv[1:] if argv is None else argv
    return next((w for w in words if not w.startswith("-")), None)


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``cptbt`` script; returns the exit status."""
    try:
        parser = build_parser(_command_of(argv))
        args, extra = parser.parse_known_args(argv)  # usage errors exit here, with status 2
        if extra:  # told by the sub-command's parser: its --help, not cptbt's (a review)
            _unrecognized(parser, list(sys.argv[1:] if argv is None else argv), extra)
        configure_logging(args.verbose, args.quiet_log)
        return int(args.func(args) or 0)
    except MissionError as exc:
        for line in exc.problems[:MAX_PROBLEMS_TOLD]:
            line = printable(line)
            if len(line) > MAX_PROBLEM_CHARS:  # an attacker's 300 000-character variant name
                line = f"{line[:MAX_PROBLEM_CHARS]}... ({len(line)} characters in all)"
            print(line, file=sys.stderr)
        if len(exc.problems) > MAX_PROBLEMS_TOLD:  # a file of 2 000 stray keys: not 2 000 lines
            print(f"cptbt: ... and {len(exc.problems) - MAX_PROBLEMS_TOLD} more problems "
                  "(mend these and validate again)", file=sys.stderr)
        return EXIT_USAGE
    except UsageError as exc:  # worded as argparse's own: PROG: error: MESSAGE
        command, text = _command_of(argv), _one_line(str(exc))
        if command and text.startswith(f"{command}: "):
            text = text[len(command) + 2:]
        print(f"cptbt{f' {command}' if command else ''}: error: {text}", file=sys.stderr)
        return EXIT_USAGE
    except RegistryError as exc:
        print(f"cptbt: {_one_line(str(exc))}", file=sys.stderr)
        return EXIT_USAGE
    except BatchError as exc:
        print(f"cptbt: {_one_line(str(exc))}", file=sys.stderr)
        return EXIT_RUNTIME
    except BrokenPipeError:  # e.g. `cptbt run ... | head`: the reader left, nothing to report
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        return EXIT_RUNTIME
    except KeyboardInterrupt as exc:  # a command may say what it kept
        print(f"cptbt: interrupted{f': {exc}' if str(exc) else ''}", file=sys.stderr)
        return 130
    except Exception as exc:  # a bug: one line, and the way to see more
        if os.environ.get(DEBUG_ENV):
            raise
        fault = blame(exc)  # a behaviour's (a plug-in's): named, not called cptbt's own
        if fault is not None:
            print(f"cptbt: {fault} (run with {DEBUG_ENV}=1 for the traceback)",
                  file=sys.stderr)
        elif isinstance(exc, OSError):  # an unwritable output or unreadable input
            print(f"cptbt: {_os_error(exc)}", file=sys.stderr)
        else:
            print(f"cptbt: internal error: {type(exc).__name__}: {_one_line(str(exc))} "
                  f"(run with {DEBUG_ENV}=1 for the traceback)", file=sys.stderr)
        return EXIT_RUNTIME


def _unrecognized(parser: argparse.ArgumentParser, words: list[str], extra: list[str]) -> NoReturn:
    """Refuse the arguments no parser took, told by the (sub-)command they were given to: one
    given only before the command is cptbt's, one after it the deepest sub-command's (``cptbt
    log summary``); cptbt's own ``-q``/``-v`` given after the command say where they go."""
    owner, path = parser, []
    for word in words:  # down the sub-commands the words name, in order
        subs = [a for a in owner._actions if isinstance(a, argparse._SubParsersAction)]
        if not word.startswith("-") and subs and word in subs[0].choices:
            owner = cast(argparse.ArgumentParser, subs[0].choices[word])
            path.append(words.index(word))
    # a stray word before the command and nowhere after it is cptbt's (--bogus validate)
    after = path and any(w == extra[0] for w in words[path[0] + 1:])
    if not after:
        owner = parser
    own = [a for a in extra if re.fullmatch(r"-[vq]+|--(verbose|quiet-log)", a)]
    hint = (f": {own[0]} is cptbt's own option, given before the command (cptbt {own[0]} "
            f"{owner.prog.removeprefix('cptbt ')} ...)" if own and owner is not parser else "")
    owner.error(f"unrecognized arguments: {' '.join(extra)}{hint}")


def _one_line(text: str) -> str:
    return printable(" ".join(text.split()))




def _os_error(exc: OSError) -> str:
    """``FILE: reason`` (``FILE -> FILE2: reason`` for a rename) from an OSError."""
    reason = exc.strerror or _one_line(str(exc)) or type(exc).__name__
    if exc.filename is None:
        return reason
    where = str(exc.filename)
    if exc.filename2 is not None:
        where += f" -> {exc.filename2}"
    return f"{where}: {reason}"


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
