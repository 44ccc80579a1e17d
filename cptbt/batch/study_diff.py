"""What tells the study in a results folder from the one about to be flown there, in a few
words, for the refusal to mix them (:class:`cptbt.batch.store.StudyMismatch`)."""

from __future__ import annotations

import json
from typing import Any

import yaml

from cptbt.batch.sweeps import value_yaml
from cptbt.mission import Loc, dotted

# the mission's path is not compared: the same mission from another path is the same study;
# nor the runs per start: more of them extend a study (cptbt batch's identity leaves them out)
_COMPARED = (("root_seed", "root seed"), ("time_limit_s", "time limit (s)"),
             ("start_mode", "start mode"), ("starts", "starts"), ("heading_deg", "heading (deg)"),
             ("sweeps", "sweeps"), ("config_missions", "the missions' settings"))


def differences(old: dict[str, Any], new: dict[str, Any]) -> str:
    """What tells the study in a folder (``old``, its ``study.json``) from this one (``new``,
    the metadata about to be written), in a few words: the first three differences named."""
    said = []
    for key, name in _COMPARED:
        if key not in old or key not in new:
            continue
        a, b = old[key], json.loads(json.dumps(new[key], default=str))
        if a == b:
            continue
        if key == "config_missions":
            same = (isinstance(a, list) and isinstance(b, list)
                    and sorted(map(str, a)) == sorted(map(str, b)))
            said.extend(["the same configurations in another order (the order of the sweep "
                         "values numbers them)"] if same else _mission_differences(a, b))
        elif key == "sweeps" and isinstance(a, dict) and isinstance(b, dict):
            # each swept path that differs, with its values (a review: the two JSON texts cut
            # at 40 characters hid exactly the value that differed)
            said.extend(_sweep_difference(k, a.get(k), b.get(k))
                        for k in sorted(set(a) | set(b)) if a.get(k) != b.get(k))
        elif key == "starts":
            said.append(f"{name} differ")
        else:
            said.append(f"{name} {_short(a)} there, {_short(b)} here")
    if not said:
        return "other missions or options"
    more = f"; and {len(said) - 3} more" if len(said) > 3 else ""
    return "; ".join(said[:3]) + more


_ABSENT = object()


def _mission_differences(old: Any, new: Any) -> list[str]:
    """The mission settings that differ, by their dotted key (``mission
    declare_source.radius_m 10 there, 8 here``), in the first configuration that differs."""
    if not (isinstance(old, list) and isinstance(new, list)) or len(old) != len(new):
        count = len(old) if isinstance(old, list) else "?"
        return [f"configurations {count} there, {len(new)} here"]
    for a, b in zip(old, new, strict=True):
        try:
            paths = _setting_paths(yaml.safe_load(a), yaml.safe_load(b), ())
        except (yaml.YAMLError, TypeError):
            break
        if paths:
            return [f"mission {dotted(key) + ' ' if key else ''}{_setting(x)} there, "
                    f"{_setting(y)} here" for key, x, y in paths]
    return ["the missions' settings differ"]


def _setting_paths(a: Any, b: Any, at: Loc) -> list[tuple[Loc, Any, Any]]:
    """(key path, value there, value here) of every leaf that differs, in key order; into
    lists of one length too (a mission's behaviours are a list: a review was told the whole
    list, cut before the change)."""
    if isinstance(a, dict) and isinstance(b, dict):
        out = []
        for key in sorted({*a, *b}, key=str):
            out += _setting_paths(a.get(key, _ABSENT), b.get(key, _ABSENT), (*at, str(key)))
        return out
    if isinstance(a, list) and isinstance(b, list) and len(a) == len(b):
        return [d for i, (x, y) in enumerate(zip(a, b, strict=True))
                for d in _setting_paths(x, y, (*at, i))]
    return [] if a == b else [(at, a, b)]


def _setting(value: Any) -> str:
    if value is _ABSENT:
        return "not set"
    return _short(value) if value is not None else "null"


def _sweep_difference(path: str, there: Any, here: Any) -> str:
    """One swept path's values there and here: the values only one side has, where both are
    lists (a whole behaviour's mappings cut at 60 characters had hidden the one that differed),
    else both lists whole."""
    if not (isinstance(there, list) and isinstance(here, list)):
        return (f"sweep {path} {_short(there or 'none', 60)} there, "
                f"{_short(here or 'none', 60)} here")
    only_there = [v for v in there if v not in here]
    only_here = [v for v in here if v not in there]
    if not only_there and not only_here:  # the same values in another order
        return f"sweep {path} {_values(there)} there, {_values(here)} here"
    return (f"sweep {path} " + "; ".join(
        [f"{_values(only_there)} there only"] * bool(only_there)
        + [f"{_values(only_here)} here only"] * bool(only_here)))


def _values(values: list[Any]) -> str:
    return ", ".join(map(value_yaml, values))


def _short(value: Any, limit: int = 40) -> str:
    if value is None:  # an option not given: the mission's own value
        return "the mission's"
    text = json.dumps(value, default=str) if not isinstance(value, str) else value
    return text if len(text) <= limit else text[:limit - 1] + "…"
