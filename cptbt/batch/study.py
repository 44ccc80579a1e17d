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
import re
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from typing import Any, cast

import numpy as np
from pydantic import BaseModel

from cptbt import study_spec
from cptbt.batch.integrity import digest
from cptbt.batch.sweeps import Sweep, apply_setting, setting_order, value_label, value_yaml
from cptbt.loader import MissionError, dump_mission, located_errors, validate_data
from cptbt.mission import Loc, MissionBase, dotted, mission_model, mission_to_data
from cptbt.registry import default_registry

MAX_STARTS = study_spec.MAX_STARTS
"""Most starts a study may have: a bound on typos such as ``--starts-x 0:100:0.0001``."""


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
    paths = [p for s in sweeps for p in s.paths]
    for path in paths:
        if f"{path}.variant" in paths:
            raise ValueError(f"sweeps of {path} and {path}.variant both set its variant: give "
                             f"the variants in the sweep of {path}")
        given = {k for s in sweeps if path in s.paths for v in s.values
                 if isinstance(v, dict) for k in v}
        both = sorted(k for k in given if f"{path}.{k}" in paths)
        if both:  # the parameter's sweep, applied after, had silently replaced the mapping's
            # value under a label that still showed it (a diff review)
            raise ValueError(f"sweeps of {path} and {path}.{both[0]} both set {both[0]}: give "
                             f"it in one of them")
    combos = itertools.product(*(s.values for s in sweeps)) if sweeps else [()]
    base = mission_to_data(mission)
    # A configuration is one point of the study, not the study: without the study section
    # (the plan, read from the mission itself), a 500-value sweep no longer writes, parses and
    # checks its 500 values 1 000 times over (46 s to validate, most of it YAML).
    base["study"] = None
    env: type[BaseModel] | None = (type(mission.environment) if mission.environment is not None
                                   else None)
    model = mission_model(default_registry(), env)
    variants = {e.family: e.variant for e in mission.entries()}  # a mapping's, when it names none
    for i, combo in enumerate(combos):
        data = copy.deepcopy(base)
        coords = {}
        settings = [(path, value) for sweep, value in zip(sweeps, combo, strict=True)
                    for path in sweep.paths]
        for path, value in sorted(settings, key=lambda pv: setting_order(pv[0])):
            apply_setting(data, path, value)
        for sweep, value in zip(sweeps, combo, strict=True):
            coords[sweep.name] = value_label(value, variants.get(sweep.name))
        # as typed in YAML: null, true (a review read Python's None)
        swept = ", ".join(f"{k}={value_yaml(v)}" for k, v in coords.items())
        try:  # the data as it is: what YAML text of it would parse back to
            validated = cast(MissionBase, validate_data(
                data, {}, f"{source} [sweep {swept}]" if swept else source, model))
        except MissionError as exc:
            if not swept or exc.located is None:
                raise
            # every bad combination told, not the first alone (a review fixed and validated
            # again once per bad value)
            bad.append(_swept_error(exc.located, source, lines, swept, sweeps, coords))
            continue
        # a sweep that takes the environment away (an attacker's ``environment: [null]``) is
        # the missing section's error, at its line, not an internal error when flown
        if swept and (validated.environment is not None or mission.environment is not None):
            # The simulator's own limits (environment.dt_s, flow overrides...), as `load` checks
            # them for the mission file: a swept value must not first fail in a worker. (Imported
            # here: studies are planned, and the CLI inspects missions, without the simulator.)
            from cptbt.batch.scenario import check, problems
            from cptbt.sim.world import EnvironmentParams

            found = problems(validated, simulate=mission.environment is not None)
            if found:
                bad.append(_swept_error(found, source, lines, swept, sweeps, coords))
                continue
            error = check(validated)
            if error is not None:
                located = located_errors(error, data.get("environment") or {}, ("environment",),
                                         EnvironmentParams)
                bad.append(_swept_error(located, source, lines, swept, sweeps, coords))
                continue
        text = dump_mission(validated)
        twin = by_text.get(text)
        if twin is not None:  # 10 and 10.0, or a value twice: one configuration flown as two
            same = ", ".join(f"{k}={value_yaml(v)}" for k, v in twin.coords.items())
            raise ValueError(f"sweep {swept} flies the same mission as {same}: give each "
                             "value once")
        by_text[text] = Config(i, coords, text, validated)
        out.append(by_text[text])
    if bad:
        raise MissionError(_merged(line for e in bad for line in e.problems))
    return out


def _sets(sweep_path: str, path: str) -> bool:
    """Whether a sweep of ``sweep_path`` sets the mission key ``path`` (a problem's dotted
    location: ``behaviours[1].declare_source.radius_m`` is set by ``declare_source.radius_m``
    and by ``declare_source`` whole)."""
    return (path == sweep_path or path.endswith("." + sweep_path)
            or ("." not in sweep_path and sweep_path in path.split(".")))


def _merged(lines: Iterable[str]) -> list[str]:
    """The problems of the bad configurations, one line per problem: the same problem at the
    same place under several sweep values names them together (an attacker's misspelt sweep
    path was told once per value, 30 values 30 lines), the first three and how many more."""
    said: dict[tuple[str, str], list[str]] = {}  # (before, after) the sweep -> its values
    for line in lines:
        head, sep, tail = line.rpartition(" (with sweep ")
        if sep and tail.endswith(")"):  # FILE:LINE: path: message (with sweep X)
            said.setdefault((head + " (with sweep ", ")"), []).append(tail[:-1])
            continue
        found = re.match(r"(.*? \[sweep )(.*?)(\]: .*)$", line)
        if found:  # FILE [sweep X]: path: message (a key the file lacks)
            said.setdefault((found[1], found[3]), []).append(found[2])
        else:
            said.setdefault((line, ""), [])
    out = []
    for (before, after), sweeps in said.items():
        sweeps = list(dict.fromkeys(sweeps))  # one value under many other sweeps' values
        more = f" and {len(sweeps) - 3} more" if len(sweeps) > 3 else ""
        out.append(f"{before}{'; '.join(sweeps[:3])}{more}{after}" if sweeps else before)
    return out


def _swept_error(located: list[tuple[Loc, str]], source: str, lines: dict[Loc, int] | None,
                 swept: str, sweeps: Sequence[Sweep] = (),
                 coords: dict[str, Any] | None = None) -> MissionError:
    """A swept mission's problems, the sweep named: at the line of the file's own
    ``study.sweeps`` entry that set the value, else at the key's line in the file, or without a
    line (a key the file lacks, swept from the command line). A problem at a swept path names
    that sweep's value alone (``coords``, the configuration's values; a diff review read a
    lambda_s problem under every other sweep's values too)."""
    out = []
    for loc, msg in located:
        path = dotted(loc)
        mine = [s for s in sweeps if any(_sets(p, path) for p in s.paths)]
        named = (", ".join(f"{s.name}={value_yaml(coords[s.name])}" for s in mine)
                 if mine and coords is not None and all(s.name in coords for s in mine)
                 else swept)
        if len(named) > 200:  # an attacker's 20 000-value list: one 129 kB line before
            named = named[:197] + "..."
        where = None
        if lines is not None:  # the study entry that set the value, else the key's own line
            where = next((lines[("study", "sweeps", s.name)] for s in mine
                          if ("study", "sweeps", s.name) in lines), lines.get(loc))
        out.append(f"{source}:{where}: {path}: {msg} (with sweep {named})"
                   if where is not None else f"{source} [sweep {named}]: {path}: {msg}")
        out[-1] += _whole_sweep_hint(loc, msg, sweeps)
    return MissionError(list(dict.fromkeys(out)))  # one line per problem, not per value


def _whole_sweep_hint(loc: Loc, msg: str, sweeps: Sequence[Sweep]) -> str:
    """For a setting swept across variants that one of them lacks, how to give it to the others
    alone (a plug-in author's review crossed a variant sweep with such a setting's)."""
    if len(loc) < 4 or loc[0] != "behaviours" or not msg.startswith("unknown key of "):
        return ""
    family, key = str(loc[2]), str(loc[3])
    swept = [str(v) for s in sweeps if f"{family}.variant" in s.paths for v in s.values]
    lacking = msg.removeprefix(f"unknown key of {family} ").partition(";")[0]
    others = [v for v in swept if v != lacking]
    if lacking not in swept or not others:
        return ""
    values = [value_yaml(v) for s in sweeps if f"{family}.{key}" in s.paths for v in s.values]
    given = ",".join(f"{{variant: {o}, {key}: {v}}}" for o in others for v in values or ["VALUE"])
    return (f"; a setting only some variants have goes in a whole-behaviour sweep, with them: "
            f"--sweep '{family}={lacking},{given}'")


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
