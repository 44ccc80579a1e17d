"""Monte Carlo studies: a mission plus a sweep, split into groups that share a plume.

A study is the product of *configurations* (sweep values), *replicates* (plume realisations) and
*starts*. A group is one configuration × one replicate: all its starts fly together in one
vectorised world, as AB's searchers shared one plume. Replicate ``r`` uses the same plume in every
configuration (common random numbers make variant comparisons paired), and every seed is spawned
from one root ``SeedSequence`` by position, so results do not depend on the number of workers or
the order in which groups finish.
"""

from __future__ import annotations

import copy
import dataclasses
import itertools
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any, cast

import numpy as np
import yaml
from pydantic import BaseModel

from cptbt import study_spec
from cptbt.batch.integrity import digest
from cptbt.loader import MissionError, dump_mission, located_errors, validate_data
from cptbt.mission import Loc, MissionBase, dotted, mission_model, mission_to_data
from cptbt.registry import RegistryError, default_registry
from cptbt.yaml_dialect import OldNumberError, load_scalar

MAX_STARTS = study_spec.MAX_STARTS
"""Most starts a study may have: a bound on typos such as ``--starts-x 0:100:0.0001``."""


@dataclass(frozen=True)
class Sweep:
    """One swept setting: mission paths (joined by '+' on the command line) and their values.

    A path is a top-level mission field (``speed_mps``), a field of a section
    (``perception.lambda_s``, ``environment.flow_speed_mps``, ``evaluation.success_radius_m``), or
    ``<family>.<param>`` of a behaviour. Setting ``<family>.variant`` to another variant replaces
    that behaviour's parameters with the new variant's defaults (``variant_sweep_notes`` says
    which of the mission's settings that drops); the mission's own variant keeps its settings.
    """

    paths: tuple[str, ...]
    values: tuple[Any, ...]

    @classmethod
    def parse(cls, text: str) -> Sweep:
        """From ``path[+path...]=v1,v2,...`` (values read as YAML scalars, as a mission file's
        are: ``1e-3`` is a number).

        Raises:
            ValueError: no ``=``, no values, or a value YAML cannot read.
        """
        if "=" not in text:
            raise ValueError(f"{text!r}: expected PATH=V1,V2,...")
        left, right = text.split("=", 1)
        try:
            values = tuple(load_scalar(v) for v in right.split(",") if v.strip())
        except OldNumberError as exc:
            raise ValueError(f"{text!r}: {exc}") from None
        except yaml.YAMLError as exc:
            raise ValueError(f"{text!r}: a value is not YAML: {' '.join(str(exc).split())}"
                             ) from None
        if not values:
            raise ValueError(f"{text!r}: no values")
        return cls(tuple(p.strip() for p in left.split("+")), values)

    @property
    def name(self) -> str:
        """Column name of this sweep in the results."""
        return "+".join(self.paths)


NOT_SWEPT = {
    "environment.seed": "a study draws replicate r's plume from its root seed (--seed) and r, "
                        "so every value would fly the same plumes (a review's two 'worlds' "
                        "came out identical, run for run); more plumes: --runs-per-start; "
                        "another set of them: --seed",
    "start": "every configuration flies the study's own starts (study.starts, --grid, "
             "--starts...; else the mission's start), so every value would fly the same runs; "
             "give the starts with --starts",
}
"""Mission keys a study sets itself: a sweep of one would change nothing, and is refused."""


def apply_setting(data: dict[str, Any], path: str, value: Any) -> None:
    """Set one path of mission data in place.

    Raises:
        ValueError: the path names nothing in the mission, or nothing a study flies.
    """
    if path in NOT_SWEPT:
        raise ValueError(f"sweep path {path!r}: {NOT_SWEPT[path]}")
    head, _, rest = path.partition(".")
    if not rest:
        if head not in data and head != "environment":
            raise ValueError(f"sweep path {path!r}: no such mission field")
        data[head] = value
        return
    if head in ("environment", "perception", "evaluation", "mission_a"):
        section = data.setdefault(head, {}) or {}
        data[head] = section
        node = section
        *parents, leaf = rest.split(".")
        for p in parents:
            node = node.setdefault(p, {})
        node[leaf] = value
        return
    for entry in data["behaviours"]:
        if head in entry:
            body = entry[head]
            if rest != "variant":
                entry[head] = {**body, rest: value}
            elif value != body.get("variant"):  # the mission's own variant keeps its settings
                entry[head] = {"variant": value}
            return
    raise ValueError(f"sweep path {path!r}: the mission has no {head!r} behaviour")


SAME_WORLD = ("environment.fluorometer.", "environment.adcp.", "environment.navigation.",
              "environment.vehicle.", "environment.launch")
"""Simulator settings of the vehicle and its sensors: the plume and flow are drawn alike
whatever they are (the vehicle's noise has its own stream)."""


def changes_world(path: str) -> bool:
    """Whether a swept setting changes the simulated world (the flow and plume replicate r
    flies): a simulator setting other than the vehicle's and its sensors', or the OpArea (the
    flow field is laid over it). A review found an OpArea sweep paired as the same plume and
    a sensor sweep refused as another world. A joint sweep's column (``a+b``) changes it if
    any of its paths does (a review's ``speed_mps+environment.flow_speed_mps`` was paired run
    by run "on the same plume", its paths tested as one name)."""
    if "+" in path:
        return any(changes_world(part) for part in path.split("+"))
    return (path.startswith("environment.") and not path.startswith(SAME_WORLD)) or \
        path.startswith("op_area.")


def study_notes(mission: MissionBase, sweeps: list[Sweep]) -> list[str]:
    """What a reader of the study must know of its sweeps: the settings a swept variant drops
    (:func:`variant_sweep_notes`), and that a setting of the simulated world changes it, so
    its values do not fly the same plumes (a review swept three, told nothing)."""
    notes = variant_sweep_notes(mission, sweeps)
    world = [p for s in sweeps for p in s.paths if changes_world(p)]
    if world:
        notes.append(f"{', '.join(world)} {'is' if len(world) == 1 else 'are'} swept: "
                     "a setting of the simulated world changes it, so replicate r is not "
                     "the same plume at each value: compare those values over replicates, "
                     "not pair by pair")
    return notes


def variant_sweep_notes(mission: MissionBase, sweeps: list[Sweep]) -> list[str]:
    """What a ``<family>.variant`` sweep drops: the behaviour's settings in the mission that a
    swept variant flies otherwise, one note per such variant.

    Each swept variant flies with its own defaults (its parameters need not be the mission's
    variant's), so the settings the mission gave that behaviour are not carried over: those the
    variant also has fly at its default, and those it has no parameter for (a likelihood map's
    ``max_sources`` swept against a one-source rule) do not apply at all. Said once per swept
    variant, so it is never silent. Parameters another sweep sets are kept (variants are
    applied first).
    """
    data = mission_to_data(mission)
    registry = default_registry()
    notes = []
    for sweep in sweeps:
        for path in sweep.paths:
            family, _, rest = path.partition(".")
            if rest != "variant":
                continue
            body = next((e[family] for e in data["behaviours"] if family in e), None) or {}
            entry = next((e for e in mission.entries() if e.family == family), None)
            also = {q.partition(".")[2] for other in sweeps for q in other.paths
                    if q.startswith(family + ".")}
            # the settings the mission made: its variant's own defaults are no choice of it
            made = entry.params.model_fields_set if entry is not None else set()
            given = {k: v for k, v in body.items()
                     if k != "variant" and k not in also and k in made}
            for value in dict.fromkeys(sweep.values):
                if value == body.get("variant"):
                    continue
                try:
                    defaults = registry.get(family, str(value)).params().model_dump(mode="json")
                except RegistryError:  # an unknown variant fails in configurations()
                    continue
                # the value flown first, the mission's beside it (a review read "it flies
                # step_m=8.0 (its default 10.0)": the mission's 8.0 as the one flown)
                other = [f"{k}={defaults[k]} (the mission's {v})" for k, v in given.items()
                         if k in defaults and defaults[k] != v]
                absent = [f"{k}={v}" for k, v in given.items() if k not in defaults]
                parts = ([f"flies {', '.join(other)}"] if other else []) + (
                    [f"has no parameter for {', '.join(absent)}"] if absent else [])
                hint = (f" (give a setting both have with another --sweep "
                        f"{family}.<param>=...)") if other else ""
                if parts:
                    notes.append(
                        f"sweep {path}: {value} flies with its own defaults, not the mission's "
                        f"{family} settings: it {'; it '.join(parts)}{hint}")
    return notes


def config_label(coords: dict[str, Any], mission: str) -> str:
    """The name of a configuration in tables and legends: its sweep values, else the mission.

    A row's ``configuration`` column, so it lives with the code whose source is the study's
    identity (:mod:`cptbt.batch.report`, presentation only, is not).

    Each swept setting is named by its last key (``speed_mps=1``), a variant by its family
    (``reacquire_plume=three_point``: "variant=three_point" left a reader to guess whose); where
    two sweeps share a name (``maintain_plume.speed_mps`` and ``find_plume.speed_mps``) both
    keep their full path, so no label can be read two ways. A simulator setting keeps its whole
    path (``environment.flow_speed_mps=0.2``: a review read ``flow_speed_mps`` beside the
    vehicle's speeds, and such a sweep changes the world, not the AMP).
    """
    if not coords:
        return mission
    short = {path: path if path.startswith("environment.") else _last_keys(path)
             for path in coords}
    clash = {name for name in short.values() if list(short.values()).count(name) > 1}
    return ", ".join(f"{path if short[path] in clash else short[path]}={value}"
                     for path, value in coords.items())


def _last_keys(path: str) -> str:
    """``a.b`` -> ``b``; a behaviour's variant ``a.variant`` -> ``a``; a joint sweep
    ``a.variant+b.variant`` -> ``a+b``."""
    def name(part: str) -> str:
        keys = part.split(".")
        return keys[-2] if keys[-1] == "variant" and len(keys) > 1 else keys[-1]

    return "+".join(dict.fromkeys(name(part) for part in path.split("+")))


@dataclass(frozen=True)
class Config:
    """One point of the sweep: its coordinates and the mission (as validated YAML text)."""

    index: int
    coords: dict[str, Any]
    mission_yaml: str
    mission: MissionBase = field(compare=False, repr=False)
    """The mission validated (what ``mission_yaml`` loads to): no need to parse it again."""


def configurations(mission: MissionBase, sweeps: list[Sweep], source: str,
                   lines: dict[Loc, int] | None = None) -> list[Config]:
    """Every sweep combination, validated now so a bad value fails before any run.

    A swept mission is the mission's data with the sweep's values set, so its problems have no
    line of their own: each is reported at its key's line in the mission file (``lines``, the
    file's key paths) with the sweep named, or, for a key the file does not have, as
    ``FILE [sweep ...]: path: message`` without a line.

    Raises:
        MissionError: a combination is not a valid mission.
        ValueError: a sweep path names nothing in the mission.
    """
    out: list[Config] = []
    bad: list[MissionError] = []  # the combinations that are no valid mission
    by_text: dict[str, Config] = {}  # a configuration by its mission text: twins are refused
    combos = itertools.product(*(s.values for s in sweeps)) if sweeps else [()]
    base = mission_to_data(mission)
    # A configuration is one point of the study, not the study: without the study section
    # (the plan, read from the mission itself), a 500-value sweep no longer writes, parses and
    # checks its 500 values 1 000 times over (46 s to validate, most of it YAML).
    base["study"] = None
    env: type[BaseModel] | None = (type(mission.environment) if mission.environment is not None
                                   else None)
    model = mission_model(default_registry(), env)
    for i, combo in enumerate(combos):
        data = copy.deepcopy(base)
        coords = {}
        settings = [(path, value) for sweep, value in zip(sweeps, combo, strict=True)
                    for path in sweep.paths]
        # Variants first: a variant starts its behaviour afresh, and must not drop a parameter
        # another sweep sets for it, whatever order the sweeps were given in.
        for path, value in sorted(settings, key=lambda pv: not pv[0].endswith(".variant")):
            apply_setting(data, path, value)
        for sweep, value in zip(sweeps, combo, strict=True):
            coords[sweep.name] = value
        swept = ", ".join(f"{k}={v}" for k, v in coords.items())
        try:  # the data as it is: what YAML text of it would parse back to
            validated = cast(MissionBase, validate_data(
                data, {}, f"{source} [sweep {swept}]" if swept else source, model))
        except MissionError as exc:
            if not swept or exc.located is None:
                raise
            # every bad combination told, not the first alone (a review fixed and validated
            # again once per bad value)
            bad.append(_swept_error(exc.located, source, lines, swept, sweeps))
            continue
        if swept and validated.environment is not None:
            # The simulator's own limits (environment.dt_s, flow overrides...), as `load` checks
            # them for the mission file: a swept value must not first fail in a worker. (Imported
            # here: studies are planned, and the CLI inspects missions, without the simulator.)
            from cptbt.batch.scenario import check, problems
            from cptbt.sim.world import EnvironmentParams

            found = problems(validated, simulate=False)
            if found:
                bad.append(_swept_error(found, source, lines, swept, sweeps))
                continue
            error = check(validated)
            if error is not None:
                located = located_errors(error, data.get("environment") or {}, ("environment",),
                                         EnvironmentParams)
                bad.append(_swept_error(located, source, lines, swept, sweeps))
                continue
        text = dump_mission(validated)
        twin = by_text.get(text)
        if twin is not None:  # 10 and 10.0, or a value twice: one configuration flown as two
            same = ", ".join(f"{k}={v}" for k, v in twin.coords.items())
            raise ValueError(f"sweep {swept} flies the same mission as {same}: give each "
                             "value once")
        by_text[text] = Config(i, coords, text, validated)
        out.append(by_text[text])
    if bad:
        raise MissionError(list(dict.fromkeys(line for e in bad for line in e.problems)))
    return out


def _swept_error(located: list[tuple[Loc, str]], source: str, lines: dict[Loc, int] | None,
                 swept: str, sweeps: Sequence[Sweep] = ()) -> MissionError:
    """A swept mission's problems, the sweep named: at the line of the file's own
    ``study.sweeps`` entry that set the value, else at the key's line in the file, or without a
    line (a key the file lacks, swept from the command line)."""
    out = []
    for loc, msg in located:
        where = None
        if lines is not None:  # the study entry that set the value, else the key's own line
            path = dotted(loc)
            where = next((lines[("study", "sweeps", s.name)] for s in sweeps
                          if ("study", "sweeps", s.name) in lines
                          and any(path == p or path.endswith("." + p) for p in s.paths)),
                         lines.get(loc))
        out.append(f"{source}:{where}: {dotted(loc)}: {msg} (with sweep {swept})"
                   if where is not None else f"{source} [sweep {swept}]: {dotted(loc)}: {msg}")
    return MissionError(out)


@dataclass(frozen=True)
class GroupTask:
    """Everything a worker needs to fly one group; picklable, self-contained."""

    config: int
    replicate: int
    mission_yaml: str
    starts: tuple[tuple[float, float], ...]
    root_seed: int
    heading_deg: float
    time_limit_s: float | None = None
    coords: dict[str, Any] = field(default_factory=dict)
    code: str = ""
    """The code identity (``integrity.code_identity``) the worker must run; empty: unchecked."""
    start_mode: str = "place"
    """'place': vehicles start at their start points; 'launch': at the mission's launch point,
    with their start points as move-to-field goals."""
    start_ids: tuple[int, ...] | None = None
    """Each start's index in the study (seeds its vehicle); default 0, 1, 2, ..."""
    log_ids: tuple[int, ...] = ()
    """Study indices of the starts whose runs write a cycle log (see :func:`log_sample`)."""
    log_dir: str = ""
    """Where those logs go: ``<log_dir>/<group key>-s<start>.mcap``."""
    flies: tuple[tuple[str, str], ...] = ()
    """The (family, variant) pairs the whole study flies (:meth:`Study.flies`): ``code`` is
    the code identity over them; empty: over every installed plug-in."""
    journal: str = ""
    """A file the worker appends each run's row to as soon as that run ends (a line of JSON,
    ``ResultStore.journal_line``), so that an interrupted group keeps the runs it finished;
    empty: none (a Dask worker, whose files are not the study's)."""
    journal_tag: str = ""
    """The study's fingerprint, written on every journal line (a resume trusts no other's)."""

    @property
    def ids(self) -> tuple[int, ...]:
        """The study index of each start of this group."""
        return self.start_ids if self.start_ids is not None else tuple(range(len(self.starts)))

    @property
    def key(self) -> str:
        """File-name-safe identity of the group."""
        return f"c{self.config:03d}-r{self.replicate:05d}"


@dataclass(frozen=True)
class Study:
    """The whole plan of a study."""

    configs: list[Config]
    starts: list[tuple[float, float]]
    runs_per_start: int
    root_seed: int
    heading_deg: float
    time_limit_s: float | None
    start_mode: str = "place"

    def tasks(self, code: str = "") -> list[GroupTask]:
        """One task per configuration × replicate; ``code``: the code identity workers need."""
        flies = self.flies()
        starts = tuple(self.starts)  # one tuple for every task: a copy each had cost gigabytes
        return [
            GroupTask(c.index, r, c.mission_yaml, starts, self.root_seed,
                      self.heading_deg, self.time_limit_s, c.coords, code, self.start_mode,
                      flies=flies)
            for c in self.configs for r in range(self.runs_per_start)
        ]

    def flies(self) -> tuple[tuple[str, str], ...]:
        """The (family, variant) pairs any configuration flies: the code identity counts the
        plug-ins among them, for the whole study (a worker flying one configuration checks the
        same set, or a sweep between a plug-in and a built-in refuses every group)."""
        return tuple(sorted({(e.family, e.variant) for c in self.configs
                             for e in c.mission.entries()}))

    def identity(self) -> str:
        """SHA-256 of everything the rows depend on but the code: each configuration's
        normalised mission and sweep coordinates, the starts, replicates, seed, heading and
        time limit."""
        return digest({
            "configs": [{"index": c.index, "coords": c.coords, "mission": c.mission_yaml}
                        for c in self.configs],
            "starts": [list(s) for s in self.starts],
            "runs_per_start": self.runs_per_start,
            "root_seed": self.root_seed,
            "heading_deg": self.heading_deg,
            "time_limit_s": self.time_limit_s,
            "start_mode": self.start_mode,
        })

    @property
    def total_runs(self) -> int:
        """Number of missions in the study."""
        return len(self.configs) * self.runs_per_start * len(self.starts)


def group_seeds(root_seed: int, replicate: int, ids: int | Sequence[int]
                ) -> tuple[np.random.Generator, list[np.random.Generator]]:
    """The environment generator of a replicate and one generator per start, by its index.

    ``ids`` are the starts' indices in the study (or their count, for 0..n-1): a vehicle's
    stream depends on its own index only, so one row can be flown again alone.
    """
    env = np.random.default_rng(np.random.SeedSequence(root_seed, spawn_key=(replicate, 0)))
    index = range(ids) if isinstance(ids, int) else ids
    vehicles = [
        np.random.default_rng(np.random.SeedSequence(root_seed, spawn_key=(replicate, 1, i)))
        for i in index
    ]
    return env, vehicles


LOG_SAMPLE_KEY = 2**31 - 1
"""``SeedSequence(root_seed, spawn_key=(LOG_SAMPLE_KEY,))`` draws the logged runs; the plume and
vehicle streams use two- and three-element keys, so the draw cannot disturb them."""


def log_sample(tasks: Sequence[GroupTask], k: int, root_seed: int,
               log_dir: str) -> list[GroupTask]:
    """The tasks, with ``k`` of their runs (drawn uniformly without replacement) marked to log.

    The draw is seeded by the study's root seed, so the same study logs the same runs whatever
    the workers or the order the groups finish in.
    """
    runs = [(j, i) for j, task in enumerate(tasks) for i in task.ids]
    rng = np.random.default_rng(np.random.SeedSequence(root_seed, spawn_key=(LOG_SAMPLE_KEY,)))
    chosen = {runs[n] for n in rng.choice(len(runs), size=min(k, len(runs)), replace=False)}
    return [dataclasses.replace(task, log_ids=tuple(i for i in task.ids if (j, i) in chosen),
                                log_dir=log_dir)
            for j, task in enumerate(tasks)]
