"""Mission files: loading, round-trip, and one-line errors with file, line and field (STYLE 7)."""

from __future__ import annotations

import pytest
from conftest import scripted_registry

from cptbt.loader import MissionError, dump_mission, load_mission, loads_mission

REG = scripted_registry("safety", "maintain_plume", "find_plume", "move_to_field")

GOOD = """\
name: demo
frame: planning
op_area:
  corners: [[0, -50], [100, -50], [100, 50], [0, 50]]
home: [5, 0]
start: [50, 10]
speed_mps: 1.0
cycle_hz: 10
behaviours:
  - safety: {}
  - maintain_plume: {heading_deg: 180}
  - find_plume: {variant: scripted, active_at: [1, 2]}
  - move_to_field: {}
"""


def load(text: str):  # type: ignore[no-untyped-def]
    return loads_mission(text, "m.yaml", REG)


def test_good_mission_loads_with_defaults_and_priorities() -> None:
    m = load(GOOD)
    assert [e.family for e in m.entries()] == [
        "safety", "maintain_plume", "find_plume", "move_to_field"
    ]
    assert m.entries()[2].params.active_at == (1.0, 2.0)
    assert m.perception.threshold == 0.2 and m.perception.flow_window_s == 100
    area = m.op_area_geometry()
    assert (area.xmin, area.xmax, area.ymin, area.ymax) == (0, 100, -50, 50)


def test_round_trip_dump_loads_back_equal() -> None:
    m = load(GOOD)
    again = load(dump_mission(m))
    assert again == m
    assert dump_mission(again) == dump_mission(m)


def test_load_from_file_names_the_file(tmp_path) -> None:  # type: ignore[no-untyped-def]
    path = tmp_path / "bad.yaml"
    path.write_text(GOOD.replace("speed_mps: 1.0", "speed_mps: fast"))
    with pytest.raises(MissionError) as exc:
        load_mission(path, REG)
    assert exc.value.problems == [
        f"{path}:7: speed_mps: Input should be a valid number, unable to parse string as a number"
    ]


def test_missing_file_is_one_line(tmp_path) -> None:  # type: ignore[no-untyped-def]
    with pytest.raises(MissionError) as exc:
        load_mission(tmp_path / "nope.yaml", REG)
    assert len(exc.value.problems) == 1
    assert "nope.yaml: (file): cannot be read" in exc.value.problems[0]


BAD = [
    # (what, edit, expected line prefix, expected fragment)
    ("unknown top key", lambda s: s + "colour: red\n", "m.yaml:14: colour:", "unknown key"),
    ("missing field", lambda s: s.replace("home: [5, 0]\n", ""), "m.yaml:1: home:", "required"),
    ("bad number", lambda s: s.replace("[5, 0]", "[5, x]"), "m.yaml:5: home[1]:", "number"),
    ("negative speed", lambda s: s.replace("1.0", "-1"), "m.yaml:7: speed_mps:", "greater than 0"),
    ("three corners", lambda s: s.replace(", [0, 50]]", "]"), "m.yaml:4: op_area.corners:",
     "at least 4"),
    ("unknown behaviour", lambda s: s.replace("- safety: {}", "- safty: {}"),
     "m.yaml:10: behaviours[0]:", "did you mean 'safety'"),
    ("unknown variant", lambda s: s.replace("variant: scripted", "variant: scriptd"),
     "m.yaml:12: behaviours[2].find_plume.variant:", "did you mean 'scripted'"),
    ("unknown param", lambda s: s.replace("{heading_deg: 180}", "{headin_deg: 180}"),
     "m.yaml:11: behaviours[1].maintain_plume.headin_deg:", "unknown key"),
    ("bad param type", lambda s: s.replace("active_at: [1, 2]", "active_at: soon"),
     "m.yaml:12: behaviours[2].find_plume.active_at:", "valid tuple"),
    ("behaviour twice", lambda s: s + "  - safety: {}\n",
     "m.yaml:14: behaviours[4].safety:", "listed twice"),
    ("entry not a mapping", lambda s: s.replace("- safety: {}", "- safety"),
     "m.yaml:10: behaviours[0]:", "one mapping"),
    ("duplicate key", lambda s: s.replace("cycle_hz: 10", "cycle_hz: 10\ncycle_hz: 5"),
     "m.yaml:9: cycle_hz:", "duplicate key"),
    ("broken yaml", lambda s: s.replace("[5, 0]", "[5, 0"), "m.yaml:", "(yaml)"),
    ("unsafe tag", lambda s: s.replace("name: demo", "name: !!python/object/apply:os.getcwd []"),
     "m.yaml:1: (yaml):", "could not determine a constructor"),
    ("not a mapping", lambda s: "- just\n- a list\n", "m.yaml:1: (top):", "mapping"),
    ("empty file", lambda s: "", "m.yaml:1: (top):", "empty"),
    ("planning area not aligned", lambda s: s.replace("[100, 50]", "[101, 50]"),
     "m.yaml:4: op_area.corners:", "axis-aligned"),
    # Allowed outside, but beyond the AMP's 30 m give-back: the run would end at once (start)
    # or never reach home.
    ("home beyond give-back", lambda s: s.replace("home: [5, 0]", "home: [-35, 0]\n"
                                                  "allow_outside: [home]"),
     "m.yaml:5: home:", "gives control back 30 m outside"),
    ("start beyond give-back", lambda s: s.replace("start: [50, 10]", "start: [50, 85]\n"
                                                   "allow_outside: [start]"),
     "m.yaml:6: start:", "could never fly there"),
]


@pytest.mark.parametrize(("what", "edit", "where", "fragment"), BAD, ids=[b[0] for b in BAD])
def test_bad_files_give_one_precise_line(what, edit, where, fragment) -> None:  # type: ignore[no-untyped-def]
    with pytest.raises(MissionError) as exc:
        load(edit(GOOD))
    problems = exc.value.problems
    assert any(p.startswith(where) and fragment in p for p in problems), problems
    assert all("\n" not in p for p in problems)


def test_a_place_allowed_outside_within_the_give_back_distance_loads() -> None:
    mission = load(GOOD.replace("home: [5, 0]", "home: [-25, 0]\nallow_outside: [home]"))
    assert mission.home == (-25, 0)


def _none_where_default_is_not() -> list[tuple[str, str, str]]:
    """(family, variant, parameter) of every shipped behaviour parameter that accepts None
    while its default is not None: None there means something (a check off, a rule off)."""
    from cptbt.registry import default_registry

    out = []
    for spec in default_registry().specs():
        for name, f in spec.params.model_fields.items():
            if f.default is None or name == "variant":
                continue
            try:
                spec.params.model_validate({name: None})
            except ValueError:
                continue
            out.append((spec.family, spec.variant, name))
    return out


NONE_PARAMS = _none_where_default_is_not()


def test_such_parameters_exist() -> None:
    assert ("declare_source", "likelihood_map", "upflow_check_m") in NONE_PARAMS
    assert len(NONE_PARAMS) > 10


@pytest.mark.parametrize(("family", "variant", "name"), NONE_PARAMS)
def test_a_null_parameter_survives_the_dump(family: str, variant: str, name: str) -> None:
    """A behaviour parameter set to null where its default is not null dumps as null and loads
    back as None (it was left out of the dump, and a batch, which flies the mission as dumped,
    flew the default)."""
    from cptbt.mission import BehaviourEntry
    from cptbt.registry import default_registry

    spec = default_registry().get(family, variant)
    params = spec.params.model_validate({name: None})
    data = BehaviourEntry(family=family, variant=variant, params=params).to_data()[family]
    assert name in data and data[name] is None
    assert spec.params.model_validate({k: v for k, v in data.items() if k != "variant"}) == params


def test_a_batch_flies_a_null_parameter_as_null() -> None:
    from pathlib import Path

    from cptbt.batch.scenario import Environment
    from cptbt.batch.study import configurations
    from cptbt.batch.sweeps import Sweep
    from cptbt.registry import default_registry

    path = Path(__file__).resolve().parents[2] / "missions" / "two_sources.yaml"
    text = path.read_text().replace("max_sources: 2}", "max_sources: 2, same_source_m: null}")
    mission = loads_mission(text, "m.yaml", default_registry(), Environment)
    configs = configurations(mission, [Sweep(("declare_source.known_plume_max_prob",),
                                             (0.2, None))], "m.yaml")
    flown = [loads_mission(c.mission_yaml, "c.yaml", default_registry(), Environment)
             for c in configs]
    (declare,) = {e.params for m in flown for e in m.entries()
                  if e.family == "declare_source" and e.params.known_plume_max_prob is None}
    assert declare.same_source_m is None
    assert [next(e.params.known_plume_max_prob for e in m.entries()
                 if e.family == "declare_source") for m in flown] == [0.2, None]


def test_a_plug_in_family_one_slip_from_a_slot_is_told() -> None:
    """A review's plug-in registered its variant under ``reaquire_plume``: a mission naming
    the slot was told only "unknown variant", and one naming the misspelt family validated
    silently."""
    from conftest import Scripted

    from cptbt.registry import BehaviourSpec, misspelt_slot

    reg = scripted_registry("safety", "reaquire_plume", "find_plume", "move_to_field")
    # the slot's own name, no variant of it installed: did you mean the plug-in's family
    with pytest.raises(MissionError) as exc:
        loads_mission(GOOD.replace("maintain_plume: {heading_deg: 180}",
                                   "reacquire_plume: {variant: scripted}"), "m.yaml", reg)
    (line,) = exc.value.problems
    assert "unknown behaviour 'reacquire_plume'; did you mean 'reaquire_plume'" in line, line
    # the slot installed too: its variant is found under the other family, and said so
    both = scripted_registry("safety", "reacquire_plume", "find_plume", "move_to_field")
    mine = type("Mine", (Scripted,), {"family": "reaquire_plume", "variant": "mine"})
    both.register(BehaviourSpec.of(mine, default=True))
    with pytest.raises(MissionError) as exc:
        loads_mission(GOOD.replace("maintain_plume: {heading_deg: 180}",
                                   "reacquire_plume: {variant: mine}"), "m.yaml", both)
    (line,) = exc.value.problems
    assert ("unknown variant 'mine' of reacquire_plume: 'mine' is registered under the "
            "family 'reaquire_plume', a plug-in's own family (misspelt?)") in line, line
    # the misspelt family: valid (a new family is allowed), with a warning at its entry
    m = loads_mission(GOOD.replace("maintain_plume: {heading_deg: 180}",
                                   "reaquire_plume: {variant: scripted}"), "m.yaml", reg)
    ((loc, why),) = [(loc, why) for loc, why in m.advisories() if "slip" in why]
    assert loc == ("behaviours", 1, "reaquire_plume")
    assert "one slip from 'reacquire_plume'" in why, why
    # a family of its own name is no slip
    assert misspelt_slot("plume_mapper") is None and misspelt_slot("safety") is None
    assert misspelt_slot("declare_sources") == "declare_source"


def test_safety_not_listed_first_is_told() -> None:
    """A review's safety listed last validated silently (the declaration listed there was
    told): the OpArea guard below find-plume never drives."""
    last = load(GOOD.replace("  - safety: {}\n", "").replace(
        "  - move_to_field: {}\n", "  - move_to_field: {}\n  - safety: {}\n"))
    ((loc, why),) = [(loc, why) for loc, why in last.advisories() if "OpArea guard" in why]
    assert loc == ("behaviours", 3, "safety")
    assert ("below find_plume (behaviours[1]), which has a command every cycle: it never "
            "drives") in why, why
    second = load(GOOD.replace("  - safety: {}\n", "").replace(
        "  - find_plume:", "  - safety: {}\n  - find_plume:"))
    ((loc, why),) = [(loc, why) for loc, why in second.advisories() if "OpArea guard" in why]
    assert loc == ("behaviours", 1, "safety") and "below maintain_plume: it drives only" in why
    assert not [w for _, w in load(GOOD).advisories() if "OpArea guard" in w]


def test_move_to_field_without_a_start_is_told() -> None:
    """A review's half-typed ``start:`` (null) flew from home, move-to-field idle, silently."""
    null = load(GOOD.replace("start: [50, 10]", "start:"))
    ((loc, why),) = [(loc, why) for loc, why in null.advisories() if "no start" in why]
    assert loc == ("start",) and "move_to_field has no goal" in why, why
    absent = load(GOOD.replace("start: [50, 10]\n", ""))
    ((loc, _),) = [(loc, why) for loc, why in absent.advisories() if "no start" in why]
    assert loc == ("behaviours", 3, "move_to_field")
    without = load(GOOD.replace("start: [50, 10]\n", "").replace("  - move_to_field: {}\n", ""))
    assert not [w for _, w in without.advisories() if "no start" in w]
    assert not [w for _, w in load(GOOD).advisories() if "no start" in w]


def test_a_place_allowed_outside_but_inside_is_told() -> None:
    """A review: ``allow_outside: [home]`` with the home inside (a slip of frame or sign in a
    dock's coordinates) said nothing."""
    inside = load(GOOD.replace("home: [5, 0]", "home: [5, 0]\nallow_outside: [start, home]"))
    told = [(loc, why) for loc, why in inside.advisories() if "listing has no effect" in why]
    assert [loc for loc, _ in told] == [("allow_outside", 0), ("allow_outside", 1)]
    assert told[1][1].startswith("'home' is listed but lies inside the OpArea"), told
    outside = load(GOOD.replace("home: [5, 0]", "home: [-5, 0]\nallow_outside: [home]"))
    assert not [w for _, w in outside.advisories() if "no effect" in w]


def test_a_mission_without_safety_is_told() -> None:
    """A review removed safety and flew out to the give-back 30 m outside, validated silently."""
    none = load(GOOD.replace("  - safety: {}\n", ""))
    ((loc, why),) = [(loc, why) for loc, why in none.advisories() if "no safety" in why]
    assert loc == ("behaviours",) and "give-back 30 m outside" in why, why
    assert not [w for _, w in load(GOOD).advisories() if "no safety" in w]


def test_a_mission_judged_by_declaration_without_a_declaration_rule_is_told() -> None:
    """A review deleted declare_source: validate said ok, and every run flew to the time limit."""
    ((loc, why),) = [(loc, why) for loc, why in load(GOOD).advisories() if "declare_source" in why]
    assert loc == ("behaviours",) and "none can succeed" in why, why
    arrival = load(GOOD + "evaluation: {criterion: arrival}\n")
    assert not [w for _, w in arrival.advisories() if "declare_source" in w]


def test_corners_off_a_rectangle_within_the_tolerance_are_noted_with_the_corners_flown() -> None:
    """A review's corner typed 8 m off in an 800 x 500 m box was fitted silently: the OpArea
    flown reached 6 m beyond the east corners as written."""
    from cptbt.mission_checks import corner_fit_note

    box = GOOD.replace("frame: planning", "frame: ne").replace(
        "[[0, -50], [100, -50], [100, 50], [0, 50]]",
        "[[400, 250], [400, -250], [-400, -250], [-392, 256]]\n  x_axis_bearing_deg: 0"
    ).replace("home: [5, 0]", "home: [0, 0]").replace("start: [50, 10]", "start: [10, 10]")
    note = corner_fit_note(load(box))
    assert note is not None and "up to 8.0 m off a rectangle" in note, note
    assert "[400.0, 256.0]" in note and "[-400.0, -250.0]" in note
    exact = box.replace("[-392, 256]", "[-400, 250]")
    assert corner_fit_note(load(exact)) is None
    assert corner_fit_note(load(GOOD)) is None  # the planning frame: an axis-aligned box
