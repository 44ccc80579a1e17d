"""A study's sweeps: the settings it compares, how each is set in a mission, and what a reader
must know of them (the settings a swept variant drops, a swept world that is not paired).

A path is a mission field, a field of a section, a behaviour's parameter or variant, or a
behaviour whole (:func:`apply_behaviour`); :func:`cptbt.batch.study.configurations` makes the
product of the sweeps' values into validated missions.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import yaml

from cptbt.mission import MissionBase, mission_to_data
from cptbt.registry import RegistryError, default_registry
from cptbt.yaml_dialect import RefusedValueError, load_scalar


@dataclass(frozen=True)
class Sweep:
    """One swept setting: mission paths (joined by '+' on the command line) and their values.

    A path is a top-level mission field (``speed_mps``), a field of a section
    (``perception.lambda_s``, ``environment.flow_speed_mps``, ``evaluation.success_radius_m``),
    ``<family>.<param>`` of a behaviour, or a behaviour's ``<family>`` whole. Setting
    ``<family>.variant`` to another variant replaces that behaviour's parameters with the new
    variant's defaults (``variant_sweep_notes`` says which of the mission's settings that
    drops); the mission's own variant keeps its settings. A value of a whole ``<family>`` is a
    variant's name (as ``<family>.variant``) or a mapping ``{variant: NAME, PARAM: VALUE...}``
    (the variant set first, then each parameter; no ``variant``: the mission's): one study can
    so compare a shipped variant with several settings of another (:func:`apply_behaviour`).
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
        shown = text if len(text) <= 120 else text[:117] + "..."  # not 5 000 digits again
        try:
            values = tuple(load_scalar(v) for v in split_values(right) if v.strip())
        except RefusedValueError as exc:  # an old number form, an alias bomb or loop
            raise ValueError(f"{shown!r}: {exc}") from None
        except yaml.YAMLError as exc:
            raise ValueError(f"{shown!r}: a value is not YAML: {' '.join(str(exc).split())}"
                             ) from None
        if not values:
            raise ValueError(f"{text!r}: no values")
        return cls(tuple(p.strip() for p in left.split("+")), values)

    @property
    def name(self) -> str:
        """Column name of this sweep in the results."""
        return "+".join(self.paths)

    @property
    def text(self) -> str:
        """The sweep as ``--sweep`` spells it: ``PATH=V1,V2`` (a mapping in YAML's flow form)."""
        return f"{self.name}={','.join(value_yaml(v) for v in self.values)}"


def split_values(text: str) -> list[str]:
    """``a,{variant: b, k: 1},[1, 2]`` -> its three values: commas inside brackets, braces or
    quotes belong to a value (a whole behaviour's mapping has them)."""
    out, depth, quote, start = [], 0, "", 0
    for i, ch in enumerate(text):
        if quote:
            quote = "" if ch == quote else quote
        elif ch in "'\"" and text[:i].rstrip()[-1:] in ("", ",", "[", "{", ":"):
            quote = ch  # a quoted scalar's opening, not an apostrophe in a word (o'clock)
        elif ch in "[{":
            depth += 1
        elif ch in "]}":
            depth -= 1
        elif ch == "," and depth == 0:
            out.append(text[start:i])
            start = i + 1
    return [*out, text[start:]]


def label_parts(label: str) -> list[str]:
    """A configuration label's settings, ``a=1, b=x(k=1, m=2)`` -> ``a=1``, ``b=x(k=1, m=2)``:
    the ``, `` inside a whole behaviour's parentheses (:func:`value_label`) belongs to it."""
    out, depth, start = [], 0, 0
    for i, ch in enumerate(label):
        depth += (ch in "([{") - (ch in ")]}")
        if depth == 0 and label.startswith(", ", i):
            out.append(label[start:i])
            start = i + 2
    return [*out, label[start:]]


def value_yaml(value: Any) -> str:
    """A swept value as one would type it: ``8``, ``upflow_cluster``,
    ``{variant: likelihood_map, radius_m: 8}``."""
    if isinstance(value, (dict, list)) or value is None or isinstance(value, bool):
        text = yaml.safe_dump(value, default_flow_style=True, sort_keys=False, width=10**6)
        return text.strip().removesuffix("...").strip()  # a bare scalar's document end
    return str(value)


def value_label(value: Any, variant: str | None = None) -> str | Any:
    """A swept value as a results table holds it: a whole behaviour's mapping as
    ``likelihood_map(radius_m=8, flyby=true)`` (without a variant, the mission's: ``variant``;
    a review's ``{half_width_m: 20}`` had read ``(half_width_m=20)``, no variant named), any
    other value as it is."""
    if not isinstance(value, dict):
        return value
    name = str(value.get("variant", variant or ""))
    rest = ", ".join(f"{k}={value_yaml(v)}" for k, v in value.items() if k != "variant")
    return f"{name}({rest})" if rest else (name or "()")


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
        entry = next((e for e in data.get("behaviours") or [] if head in e), None)
        if entry is not None:
            apply_behaviour(entry, head, value)
            return
        if head not in data and head != "environment":
            raise ValueError(f"sweep path {path!r}: no such mission field")
        data[head] = value
        return
    if head in ("environment", "perception", "evaluation", "mission_a", "op_area"):
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


def apply_behaviour(entry: dict[str, Any], family: str, value: Any) -> None:
    """Set a behaviour whole (a sweep of ``<family>``): a variant's name, as a sweep of
    ``<family>.variant`` sets it (the mission's own variant keeps its settings, another starts
    from its defaults), or a mapping: its ``variant`` (else the mission's) so, then each of its
    other keys.

    Raises:
        ValueError: the value is neither a name nor a mapping with names as keys.
    """
    if isinstance(value, str):
        settings: dict[str, Any] = {"variant": value}
    elif isinstance(value, dict) and value and all(isinstance(k, str) for k in value):
        settings = dict(value)
    else:
        raise ValueError(f"sweep path {family!r}: {value_yaml(value)} is neither a variant's "
                         f"name nor a mapping of its settings ({{variant: NAME, PARAM: VALUE}})")
    body = entry[family] or {}
    variant = settings.pop("variant", body.get("variant"))
    if variant != body.get("variant"):  # the mission's own variant keeps its settings
        body = {"variant": variant}
    entry[family] = {**body, **settings}


def setting_order(path: str) -> int:
    """The order swept settings are applied in: a behaviour whole first, then a variant, then
    parameters (a variant starts its behaviour afresh, and must not drop a parameter another
    sweep sets for it, whatever order the sweeps were given in)."""
    return 0 if "." not in path else 1 if path.endswith(".variant") else 2


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
            body = next((e[family] for e in data["behaviours"] if family in e), None)
            if rest != "variant" and (rest or body is None):
                continue
            body = body or {}
            entry = next((e for e in mission.entries() if e.family == family), None)
            also = {q.partition(".")[2] for other in sweeps for q in other.paths
                    if q.startswith(family + ".")}
            # the settings the mission made: its variant's own defaults are no choice of it
            made = entry.params.model_fields_set if entry is not None else set()
            flown: dict[str, set[str]] = {}  # each variant swept in, and the settings given it
            for value in sweep.values:
                if isinstance(value, dict):  # a whole behaviour: its variant, its settings
                    flown.setdefault(str(value.get("variant", body.get("variant"))),
                                     set()).update(k for k in value if k != "variant")
                else:
                    flown.setdefault(str(value), set())
            for value, keys in flown.items():
                if value == body.get("variant"):  # the mission's own: its settings, said
                    # (a review: a bare name flew the mission's 12 m, another study's its 10)
                    # ... less those every value naming it sets (an attacker's note listed
                    # radius_m beside two values that each set it)
                    mine = [v if isinstance(v, dict) else {} for v in sweep.values
                            if (v.get("variant", body.get("variant")) if isinstance(v, dict)
                                else v) == value]
                    each = set.intersection(*(set(v) for v in mine)) if mine else set()
                    kept = [f"{k}={value_yaml(v)}" for k, v in body.items()
                            if k != "variant" and k not in also | each and k in made]
                    if kept and not rest:  # a whole-behaviour sweep, beside mappings
                        notes.append(f"sweep {path}: {value} is the mission's own variant: "
                                     f"where a value does not set them, it flies the mission's "
                                     f"{family} settings ({', '.join(kept)}), not its defaults")
                    continue
                try:
                    defaults = registry.get(family, value).params().model_dump(mode="json")
                except RegistryError:  # an unknown variant fails in configurations()
                    continue
                given = {k: v for k, v in body.items()
                         if k != "variant" and k not in also | keys and k in made}
                # the value flown first, the mission's beside it (a review read "it flies
                # step_m=8.0 (its default 10.0)": the mission's 8.0 as the one flown)
                other = [f"{k}={defaults[k]} (the mission's {v})" for k, v in given.items()
                         if k in defaults and defaults[k] != v]
                absent = [f"{k}={v}" for k, v in given.items() if k not in defaults]
                parts = ([f"flies {', '.join(other)}"] if other else []) + (
                    [f"has no parameter for {', '.join(absent)}"] if absent else [])
                hint = ((f" (give a setting both have with another --sweep "
                         f"{family}.<param>=...)") if rest else
                        f" (give a setting in its mapping: {{variant: {value}, PARAM: VALUE}})"
                        ) if other else ""
                if parts:
                    notes.append(
                        f"sweep {path}: {value} flies with its own defaults, not the mission's "
                        f"{family} settings: it {'; it '.join(parts)}{hint}")
    return notes
