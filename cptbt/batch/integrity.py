"""What makes study results trustworthy on disk: the code's identity and content digests.

A study's *fingerprint* hashes what its results depend on: the normalised mission of every
configuration, the study's options (starts, replicates, seed, time limit) and the code that flies
it: cptbt's source, the source of any plug-in behaviours, and the versions of the libraries that
can change a row (numpy's random streams, py_trees). Every part file carries the fingerprint and
a checksum of its rows, so a resumed study can tell its own finished groups from damaged,
foreign or stale ones.
"""

from __future__ import annotations

import functools
import hashlib
import importlib.util
import json
from collections.abc import Iterable
from pathlib import Path
from typing import Any

# The packages whose source shapes a run's rows, and the modules among them that only present
# the results (changing a figure's label must not force a study to start over).
CODE_PACKAGES = ("cptbt", "cptbt.batch", "cptbt.behaviours", "cptbt.sim")
PRESENTATION = frozenset({"cptbt.batch/report.py", "cptbt.batch/figures.py",
                          "cptbt.batch/study_figures.py"})


def digest(value: Any) -> str:
    """SHA-256 (hex) of a JSON-able value in canonical form (sorted keys, exact floats)."""
    text = json.dumps(value, sort_keys=True, separators=(",", ":"), default=repr)
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


def rows_checksum(rows: list[dict[str, Any]]) -> str:
    """Checksum of a table's rows as a reader sees them (column order ignored)."""
    return digest(rows)


def _package_dir(name: str) -> Path | None:
    try:
        spec = importlib.util.find_spec(name)
    except (ImportError, ValueError):  # blocked or broken: not part of this install's code
        return None
    locations = spec.submodule_search_locations if spec is not None else None
    return Path(next(iter(locations))) if locations else None


@functools.cache
def source_hash() -> str:
    """SHA-256 of the installed source of the code that produces results.

    Files are named by package and file name, so an editable and a regular install of the same
    source agree. The command line and the figures are left out: they do not change a row.
    """
    h = hashlib.sha256()
    for package in CODE_PACKAGES:
        folder = _package_dir(package)
        if folder is None:
            continue
        for path in sorted(folder.glob("*.py")):
            name = f"{package}/{path.name}"
            if name in PRESENTATION:
                continue
            h.update(name.encode("utf-8") + b"\0" + path.read_bytes() + b"\0")
    return h.hexdigest()


RESULT_DEPENDENCIES = ("numpy", "py_trees")
"""Libraries whose version can change a row: numpy's ``Generator`` streams are not promised
stable across its releases (NEP 19), and py_trees ticks every behaviour."""


def plugin_packages(used: Iterable[tuple[str, str]] | None = None) -> frozenset[str]:
    """The top-level packages of the behaviours registered from outside cptbt (plug-ins):
    those of the (family, variant) pairs ``used``, or of every one registered."""
    from cptbt.registry import default_registry, package_of

    wanted = None if used is None else set(used)
    return frozenset(package_of(spec) for spec in default_registry().specs()
                     if wanted is None or (spec.family, spec.variant) in wanted) - {"cptbt"}


def plugin_sources(tops: frozenset[str] | None = None) -> list[Path]:
    """The source files of the plug-in packages ``tops`` (default: every plug-in's).

    A plug-in's whole top-level package is taken (its behaviours may use its other modules).
    """
    import inspect
    import sys

    files: list[Path] = []
    tops = plugin_packages() if tops is None else tops
    for top in sorted(tops):
        module = sys.modules.get(top)
        try:
            origin = inspect.getsourcefile(module) if module is not None else None
        except TypeError:  # a built-in module
            origin = None
        if origin is None:
            continue
        path = Path(origin)
        files += sorted(path.parent.rglob("*.py")) if path.name == "__init__.py" else [path]
    return files


@functools.cache
def environment_hash(tops: frozenset[str] | None = None) -> str:
    """SHA-256 of what besides cptbt's source shapes a row: the sources of the plug-in
    packages ``tops`` (default: every installed one), library versions."""
    from importlib.metadata import PackageNotFoundError, version

    h = hashlib.sha256()
    for name in RESULT_DEPENDENCIES:
        try:
            h.update(f"{name}=={version(name.replace('_', '-'))}\0".encode())
        except PackageNotFoundError:
            h.update(f"{name}==?\0".encode())
    for path in plugin_sources(tops):
        h.update(path.name.encode("utf-8") + b"\0" + path.read_bytes() + b"\0")
    return h.hexdigest()


def code_identity(used: Iterable[tuple[str, str]] | None = None) -> str:
    """``<version>+src.<hash>``: the package version and a hash of its source (see above),
    of the plug-ins' sources and of the versions of :data:`RESULT_DEPENDENCIES`. With
    ``used`` (the (family, variant) pairs a study flies: ``Study.flies``), only the
    plug-ins among them count: a review's unrelated plug-in, edited, had stopped every study
    from resuming (and one without plug-ins gets the identity it always had).

    Under the ``fast`` simulator-kernel tier (``CPTBT_KERNELS=fast``), whose concentrations
    differ from numpy's in the last bits, ``+kernels.fast`` is appended: its rows are another
    code's rows. The ``exact`` tier gives numpy's numbers and so the same identity.
    """
    from cptbt import __version__
    from cptbt.sim import kernels

    tier = "+kernels.fast" if kernels.tier() == "fast" else ""
    tops = None if used is None else plugin_packages(used)
    return f"{__version__}+src.{_source_hash_cached(tops)[:16]}{tier}"


@functools.cache
def _source_hash_cached(tops: frozenset[str] | None = None) -> str:
    return hashlib.sha256(f"{source_hash()}+{environment_hash(tops)}".encode()).hexdigest()


def fingerprint(study_identity: str, code: str) -> str:
    """The fingerprint of a study (its identity, see ``Study.identity``) flown by ``code``."""
    return digest({"study": study_identity, "code": code})
