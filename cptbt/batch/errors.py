"""The one error a study reports to its user: a sentence that says what to do, no traceback."""

from __future__ import annotations


class BatchError(Exception):
    """A study cannot go on (an unusable results folder, an unreachable cluster, a worker
    running other code); the message is one line for the user."""


class CodeChanged(BatchError):
    """The results folder holds a study made with different code; ``--restart`` or a new
    ``--out`` is needed."""
