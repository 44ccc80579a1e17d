"""A corpus of malformed, hostile and borderline missions: each gets one precise line, exit 2.

Every case edits the valid ``data/corpus_base.yaml`` (or builds a hostile file from scratch) and
runs ``cptbt validate`` in-process; the assertion is the whole promise of the gate: exit status 2,
exactly one line on stderr, ``FILE:LINE: path: message`` with the line of the offending key and
its path, no traceback, and a message that says what is wrong.
"""

from __future__ import annotations

import re
from collections.abc import Callable
from pathlib import Path

import pytest

from cptbt.cli import main

BASE = (Path(__file__).parent / "data" / "corpus_base.yaml").read_text(encoding="utf-8")
Edit = Callable[[str], str]


def sub(old: str, new: str) -> Edit:
    def edit(text: str) -> str:
        assert old in text, old
        return text.replace(old, new, 1)

    return edit


def whole(text: str) -> Edit:
    return lambda _: text


def bomb(levels: int = 10, width: int = 9) -> str:
    lines = ["a0: &a0 [x, x, x, x, x, x, x, x, x]"]
    for i in range(1, levels):
        refs = ", ".join([f"*a{i - 1}"] * width)
        lines.append(f"a{i}: &a{i} [{refs}]")
    return "\n".join(lines) + "\n"


AB_PAIRS = sub("maintain_plume: {variant: track_in_out, beta_deg: 10}",
               "maintain_plume: {variant: strategy_3}")

# (id, edit, line, path, fragment of the message)
CASES: list[tuple[str, Edit, int, str, str]] = [
    # -- the loader cannot be made to explode ------------------------------------------------
    ("alias bomb", whole(bomb()), 5, "a4[5]", "more than 50000 values"),
    ("self alias", whole("name: x\nloop: &s [*s]\n"), 2, "loop[0]", "contains it"),
    ("nul byte", sub("name: corpus_base", "name: corpus\0base"), 1, "(yaml)", "NUL byte"),
    ("complex key", sub("speed_mps: 1.5", "? [a, b]\n: 1"), 7, "(top)", "plain word"),
    # a key YAML reads as null or true/false (a review's `~: 1.5` was told at line 1, as None)
    ("null key", sub("speed_mps: 1.5", "~: 1.5"), 7, "'~'", "reads as null"),  # quoted: not a word
    # control characters in a key: escaped and quoted, one line, no terminal codes (an attacker)
    ("control key", sub("speed_mps: 1.5", 'speed_mps: 1.5\n"evil\\nkey\\x1b[31m": 1'), 8,
     "'evil\\nkey\\x1b[31m'", "unknown key"),
    ("true/false key", sub("speed_mps: 1.5", "yes: 1.5"), 7, "yes", "reads as true/false"),
    ("deep nesting", whole("x: " + "[" * 3000 + "]" * 3000 + "\n"), 1, "(yaml)",
     "nested deeper than 40"),
    ("huge file", whole("description: '" + "x" * 1_100_000 + "'\n"), 1, "(file)", "at most"),
    ("5000-digit integer", sub("seed: 3", "seed: " + "9" * 5000), 31, "environment.seed",
     "a number 5000 characters long"),
    ("unsafe tag", sub("name: corpus_base", "name: !!python/object/apply:os.getcwd []"), 1,
     "(yaml)", "constructor"),
    ("duplicate key", sub("cycle_hz: 1", "cycle_hz: 1\ncycle_hz: 2"), 9, "cycle_hz",
     "duplicate key (first at line 8)"),
    # a point of one coordinate is short, not missing (the message had said "Field required")
    ("short point", sub("start: [-80, 20]", "start: [-80]"), 5, "start",
     "too few values: 1 given, item 2 missing"),
    # an unclosed bracket is found lines later: the line it began on is said too
    ("unclosed bracket", sub("start: [-80, 20]", "start: [-80, 20"), 6, "(yaml)",
     "(it began at line 5)"),
    # a tab: PyYAML's "found character '\t' that cannot start any token" said what, not why
    ("tab indent", sub("  - safety: {variant: oparea}", "\t- safety: {variant: oparea}"), 15,
     "(yaml)", "a tab character at column 1: YAML indents and separates with spaces only"),
    # the value given is echoed with a range error, and an unknown parameter names its variant
    ("speed below range", sub("speed_mps: 1.5", "speed_mps: -1"), 7, "speed_mps",
     "Input should be greater than 0, got -1"),
    ("parameter of another variant", sub("{variant: track_in_out, beta_deg: 10}",
                                         "{variant: track_in_out, beta_deg: 10, d_leaf_m: 3}"),
     17, "behaviours[2].maintain_plume.d_leaf_m", "unknown key of maintain_plume track_in_out"),
    # -- names and paths ---------------------------------------------------------------------
    ("path in name", sub("name: corpus_base", "name: ../../../../tmp/pwned"), 1, "name",
     "should match pattern"),
    ("empty name", sub("name: corpus_base", "name: ''"), 1, "name", "should match pattern"),
    # -- finite numbers only -----------------------------------------------------------------
    ("nan speed", sub("speed_mps: 1.5", "speed_mps: .nan"), 7, "speed_mps", "finite number"),
    ("inf time limit", sub("time_limit_s: 1800", "time_limit_s: .inf"), 9, "time_limit_s",
     "finite number"),
    ("1e309 home", sub("home: [-90, 0]", "home: [-90, 1e309]"), 6, "home[1]", "finite number"),
    ("nan cycle", sub("cycle_hz: 1", "cycle_hz: .nan"), 8, "cycle_hz", "finite number"),
    ("inf param", sub("beta_deg: 10}", "beta_deg: .inf}"), 17,
     "behaviours[2].maintain_plume.beta_deg", "finite number"),
    ("inf flow speed", sub("flow_speed_mps: 0.1", "flow_speed_mps: .inf"), 30,
     "environment.flow_speed_mps", "finite number"),
    ("nan corner", sub("[100, -50], [100, 50]", "[100, -50], [.nan, 50]"), 4,
     "op_area.corners[1][0]", "finite number"),
    ("negative seed", sub("seed: 3", "seed: -1"), 31, "environment.seed",
     "greater than or equal to 0"),
    ("negative flow gate",
     sub("flow_window_s: 100", "flow_window_s: 100\n  max_flow_speed_mps: -1"), 14,
     "perception.max_flow_speed_mps", "greater than 0"),
    ("zero success radius", sub("time_limit_s: 1800", "time_limit_s: 1800\nevaluation: "
                                "{success_radius_m: 0}"), 10, "evaluation.success_radius_m",
     "greater than 0"),
    # -- a mission that validates flies in bounded time ---------------------------------------
    ("cycle too slow", sub("cycle_hz: 1", "cycle_hz: 1e-7"), 8, "cycle_hz",
     "greater than or equal to 0.01"),
    ("cycle longer than the limit", sub("cycle_hz: 1\ntime_limit_s: 1800",
                                        "cycle_hz: 0.01\ntime_limit_s: 60"), 8, "cycle_hz",
     "cycle of 100 s, longer than time_limit_s (60 s)"),
    ("cycle longer than the study's limit",
     sub("cycle_hz: 1\ntime_limit_s: 1800",
         "cycle_hz: 0.1\ntime_limit_s: 1800\nstudy: {grid: [2, 2], time_limit_s: 5}"), 8,
     "cycle_hz", "longer than study.time_limit_s (5 s)"),
    ("tiny vehicle step", sub("  seed: 3", "  seed: 3\n  dt_s: 0.000001"), 32,
     "environment.dt_s", "greater than or equal to 0.005"),
    ("day-long spin-up", sub("  seed: 3", "  seed: 3\n  warm_up_s: 1e8"), 32,
     "environment.warm_up_s", "less than or equal to 86400"),
    ("a billion cloverleaves", sub("{variant: cloverleaf}",
                                   "{variant: cloverleaf, repeats: 1000000000}"), 18,
     "behaviours[3].reacquire_plume.repeats", "less than or equal to 100"),
    ("three-point visits", sub("{variant: cloverleaf}", "{variant: three_point, visits: 100000}"),
     18, "behaviours[3].reacquire_plume.visits", "less than or equal to 1000"),
    ("a 1e300 m/s current", sub("flow_speed_mps: 0.1", "flow_speed_mps: 1e300"), 30,
     "environment.flow_speed_mps", "less than or equal to 10"),
    ("a flow grid too fine to step", sub("  seed: 3", "  seed: 3\n  flow: {diffusivity_m2ps: 1e6}"),
     26, "environment", "the flow model would step every"),
    ("a flow speed given twice (the short key overrides: NaN went unread)",
     sub("  seed: 3", "  seed: 3\n  flow: {mean_speed_mps: .nan}"), 32,
     "environment.flow.mean_speed_mps", "given with environment.flow_speed_mps"),
    ("a point as a YAML set (unordered: read as (0, 100))",
     sub("  seed: 3", "  seed: 3\n  launch: !!set {100, 0}"), 32, "environment.launch",
     "!!set: a mission value is"),
    ("a watchdog that never fires (infinite numbers in mission_a were let through)",
     sub("  amp_depth_m: 3", "  amp_depth_m: 3\n  watchdog_s: .inf"), 25,
     "mission_a.watchdog_s", "finite number"),
    ("a billion puffs", sub("  seed: 3", "  seed: 3\n  plume: {max_puffs: 1000000000}"), 32,
     "environment.plume.max_puffs", "less than or equal to 200000"),
    ("too many sources", sub("  seed: 3", "  seed: 3\n  extra_sources: [" +
                             ", ".join(["[50, 0]"] * 21) + "]"), 32,
     "environment.extra_sources", "at most 20 items"),
    ("a mission A of 3e4 years", sub("  amp_depth_m: 3", "  amp_depth_m: 3\n"
                                     "  duration_limit_s: 1e12"), 25,
     "mission_a.duration_limit_s", "less than or equal to 604800"),
    ("a million starts", sub("time_limit_s: 1800", "time_limit_s: 1800\n"
                             "study: {grid: [1000, 1000]}"), 10, "study",
     "more than 100000 starts"),
    ("10^11 runs", sub("time_limit_s: 1800", "time_limit_s: 1800\n"
                       "study: {grid: [1000, 100], runs_per_start: 1000000}"), 10, "study",
     "100,000,000,000 runs, more than 10,000,000: split the study"),
    ("a million groups", sub("time_limit_s: 1800", "time_limit_s: 1800\n"
                             "study: {runs_per_start: 1000000, sweeps: {speed_mps: [1, 2]}}"),
     10, "study", "2,000,000 groups, more than 1,000,000"),
    ("misspelt preset", sub("preset: tro_ocean", "preset: tro_ocaen"), 27, "environment.preset",
     "unknown value 'tro_ocaen': one of 'tro_ocean', 'ab_small_meander', 'ab_large_meander'; "
     "did you mean 'tro_ocean'?"),
    # -- numbers are YAML numbers: no booleans or quoted strings converted --------------------
    ("boolean cycle", sub("cycle_hz: 1", "cycle_hz: yes"), 8, "cycle_hz",
     "expected a number, got a YAML boolean (yes, on and true all read as true)"),
    ("quoted speed", sub("speed_mps: 1.5", "speed_mps: '1.5'"), 7, "speed_mps",
     "expected a number, got '1.5' (a quoted string)"),
    ("quoted param", sub("beta_deg: 10}", "beta_deg: \"10\"}"), 17,
     "behaviours[2].maintain_plume.beta_deg", "a quoted string"),
    ("boolean flow speed", sub("flow_speed_mps: 0.1", "flow_speed_mps: on"), 30,
     "environment.flow_speed_mps", "a YAML boolean"),
    ("quoted corner", sub("[100, -50], [100, 50]", "[100, -50], ['100', 50]"), 4,
     "op_area.corners[1][0]", "a quoted string"),
    ("quoted exponent float", sub("speed_mps: 1.5", "speed_mps: '15e-1'"), 7, "speed_mps",
     "expected a number, got '15e-1' (a quoted string)"),
    ("fractional seed", sub("seed: 3", "seed: 3.5"), 31, "environment.seed", "integer"),
    # inside the simulator's override sections too (a review: noise_std: true flew as 1.0)
    ("boolean sensor noise", sub("  seed: 3", "  seed: 3\n  fluorometer: {noise_std: true}"),
     32, "environment.fluorometer.noise_std", "expected a number, got a YAML boolean"),
    ("quoted adcp noise", sub("  seed: 3", "  seed: 3\n  adcp: {noise_std_mps: '0.02'}"),
     32, "environment.adcp.noise_std_mps", "expected a number, got '0.02' (a quoted string)"),
    ("boolean noise order", sub("  seed: 3", "  seed: 3\n  flow: {noise_order: true}"),
     32, "environment.flow.noise_order", "expected one of 1, 2, got a YAML boolean (yes, on"),
    # -- the OpArea is a rectangle consistent with its bearing -------------------------------
    ("kite", sub("[[100, -50], [100, 50], [-100, 50], [-100, -50]]",
                 "[[100, 0], [0, 50], [-100, 0], [0, -50]]"), 4, "op_area.corners",
     "not a rectangle"),
    ("trapezium", sub("[-100, 50], [-100, -50]]", "[-100, 80], [-100, -80]]"), 4,
     "op_area.corners", "not a rectangle"),
    ("collinear", sub("[[100, -50], [100, 50], [-100, 50], [-100, -50]]",
                      "[[0, 0], [10, 0], [20, 0], [30, 0]]"), 4, "op_area.corners", ""),
    ("repeated corner", sub("[-100, 50], [-100, -50]]", "[-100, 50], [-100, 50]]"), 4,
     "op_area.corners", "distinct"),
    ("bearing off the sides", sub("  corners: [[100, -50], [100, 50], [-100, 50], [-100, -50]]",
                                  "  corners: [[100, -50], [100, 50], [-100, 50], [-100, -50]]"
                                  "\n  x_axis_bearing_deg: 30"), 5, "op_area.x_axis_bearing_deg",
     "not parallel"),
    # -- places inside the OpArea ------------------------------------------------------------
    ("start outside", sub("start: [-80, 20]", "start: [-180, 20]"), 5, "start",
     "80.0 m outside the OpArea"),
    ("home outside", sub("home: [-90, 0]", "home: [-90, 70]"), 6, "home", "outside the OpArea"),
    ("source outside", sub("source: [60, 0]", "source: [160, 0]"), 28, "environment.source",
     "outside the OpArea"),
    ("source missing", sub("  source: [60, 0]\n", ""), 26, "environment.source", "required"),
    # -- vehicle limits ----------------------------------------------------------------------
    ("cruise beyond limits", sub("speed_mps: 1.5", "speed_mps: 3.5"), 7, "speed_mps",
     "outside the vehicle's limits"),
    ("override beyond limits", sub("{variant: go_to}", "{variant: go_to, speed_mps: 0.1}"), 20,
     "behaviours[5].move_to_field.speed_mps", "outside the vehicle's limits"),
    ("amp depth beyond limits", sub("amp_depth_m: 3", "amp_depth_m: 80"), 24,
     "mission_a.amp_depth_m", "deeper than the vehicle's limit"),
    # -- geodetic ----------------------------------------------------------------------------
    ("latitude out of range", lambda s: geodetic(s).replace("[32.981, -118.537]",
                                                            "[95.0, -118.537]", 1),
     4, "op_area.corners[0]", "not [latitude, longitude]"),
    ("longitude out of range", lambda s: geodetic(s).replace("home: [32.9802, -118.5368]",
                                                             "home: [32.9805, 218.5]"),
     6, "home", "not [latitude, longitude]"),
    ("longitude just past 180", lambda s: geodetic(s).replace("home: [32.9802, -118.5368]",
                                                              "home: [32.9805, 180.0003]"),
     6, "home", "[32.9805, 180.0003] is not [latitude, longitude]"),  # not rounded to 180
    ("source not lat/lon", lambda s: geodetic(s).replace("source: [32.9805, -118.5365]",
                                                         "source: [-118.5365, 32.9805]"),
     28, "environment.source", "[-118.5365, 32.9805] is not [latitude, longitude]"),
    # frame 'ne' with a geodetic origin: a review's [91, 0] validated and the run ended in
    # an internal error
    ("ne centre not lat/lon", sub("[-100, -50]]\n",
                                  "[-100, -50]]\n  geodetic_centre_deg: [91, 0]\n"),
     5, "op_area.geodetic_centre_deg", "[91, 0] is not [latitude, longitude]"),
    # one frame's coordinates under another: a review's metres under 'geodetic' validated as a
    # 6 700 km box, and [lat, lon] under 'ne' as one of millimetres
    ("metres under geodetic", lambda s: geodetic(s).replace(
        "[[32.981, -118.537], [32.981, -118.536], [32.979, -118.536], [32.979, -118.537]]",
        "[[30, -20], [30, 20], [-30, 20], [-30, -20]]"),
     4, "op_area.corners", "metres written under frame 'geodetic'"),
    # absurd corners in figures a reader can read (a review's ±1e200 printed 300 digits)
    ("corners of 1e200", sub("[[100, -50], [100, 50], [-100, 50], [-100, -50]]",
                             "[[1e200, -1e200], [1e200, 1e200], [-1e200, 1e200], "
                             "[-1e200, -1e200]]"),
     4, "op_area.corners", "the OpArea is 2e+197 km x 2e+197 km, longer than"),
    ("lat/lon under ne", sub("[[100, -50], [100, 50], [-100, 50], [-100, -50]]",
                             "[[78.2301, 15.601], [78.2301, 15.605], [78.2299, 15.605], "
                             "[78.2299, 15.601]]"),
     4, "op_area.corners", "narrower than 1 m; [latitude, longitude] written under frame 'ne'"),
    # an OpArea over a pole: there is no north (a review's was refused as "origin latitude
    # must be in (-90, 90)", a wider one accepted with an accidental north)
    ("ne centre by the pole", sub("[-100, -50]]\n",
                                  "[-100, -50]]\n  geodetic_centre_deg: [89.9999, 0]\n"),
     5, "op_area.geodetic_centre_deg", "the OpArea contains the North Pole: at the North "
     "Pole every direction is south"),
    ("corners about the pole", lambda s: geodetic(s).replace(
        "[[32.981, -118.537], [32.981, -118.536], [32.979, -118.536], [32.979, -118.537]]",
        "[[89.9999, 45], [89.9999, 135], [89.9999, -135], [89.9999, -45]]"),
     4, "op_area.corners", "the corners' centre is the North Pole"),
    ("corners across the pole", lambda s: geodetic(s).replace(
        "[[32.981, -118.537], [32.981, -118.536], [32.979, -118.536], [32.979, -118.537]]",
        "[[-89.999, 0], [-89.999, 90], [-89.999, 180], [-89.999, -90]]"),
     4, "op_area.corners", "the OpArea contains the South Pole: at the South Pole every "
     "direction is north"),
    # -- behaviours --------------------------------------------------------------------------
    ("behaviour twice", sub("  - find_plume: {variant: billiard}",
                            "  - find_plume: {variant: billiard}\n  - safety: {}"), 20,
     "behaviours[5].safety", "listed twice (first at behaviours[0])"),
    ("AB halves mismatched", lambda s: AB_PAIRS(s).replace(
        "reacquire_plume: {variant: cloverleaf}",
        "reacquire_plume: {variant: strategy_1, give_up_s: 10}"), 17,
     "behaviours[2].maintain_plume.variant", "must be paired with reacquire_plume strategy_3"),
    ("AB half with cloverleaf", AB_PAIRS, 17, "behaviours[2].maintain_plume.variant",
     "not cloverleaf"),
    ("flow needed", sub("flow_window_s: 100", "flow_window_s: 100\n  flow_source: none"), 14,
     "perception.flow_source", "declare_source upflow_cluster, maintain_plume track_in_out"),
    # the cast runs from lambda_s to give_up_s: a TRO lambda of 8.5 s with AB's T_W of 4 s
    # flew with no reacquire at all (a review's strategy swap on a TRO mission timed out)
    ("AB cast never casts", lambda s: AB_PAIRS(s).replace(
        "reacquire_plume: {variant: cloverleaf}", "reacquire_plume: {variant: strategy_3}"), 18,
     "behaviours[3].reacquire_plume", "lambda_s = 8.5 s is not below give_up_s = 4 s"),
    ("counter-turn never turns", sub("{variant: track_in_out, beta_deg: 10}",
                                     "{variant: counter_turn, hold_s: 10}"), 17,
     "behaviours[2].maintain_plume", "set perception.lambda_s above hold_s"),
    ("variant not a name", sub("{variant: cloverleaf}", "{variant: [a, b]}"), 18,
     "behaviours[3]", "variant must be a name"),
    ("no behaviours", whole("name: x\nop_area: {corners: [[0, 0], [0, 9], [9, 9], [9, 0]]}\n"
                            "home: [1, 1]\nbehaviours: []\n"), 4, "behaviours", "at least 1"),
    # -- unknown and moved keys --------------------------------------------------------------
    ("unknown top key", sub("speed_mps: 1.5", "speed_mps: 1.5\nbehaviors: []"), 8,
     "behaviors", "did you mean 'behaviours'"),
    ("unknown param", sub("beta_deg: 10}", "beta_dge: 10}"), 17,
     "behaviours[2].maintain_plume.beta_dge", "did you mean 'beta_deg'"),
    ("unknown perception key", sub("  threshold: 0.2", "  treshold: 0.2"), 11,
     "perception.treshold", "did you mean 'threshold'"),
    ("unknown environment key", sub("  seed: 3", "  sead: 3"), 31, "environment.sead",
     "did you mean 'seed'"),
    ("unknown mission_a key", sub("  amp_enable_s: 10", "  amp_enable_sec: 10"), 23,
     "mission_a.amp_enable_sec", "did you mean 'amp_enable_s'"),
    ("old top-level threshold", sub("cycle_hz: 1", "cycle_hz: 1\nthreshold: 0.2"), 9,
     "threshold", "moved to perception.threshold"),
    ("old lambda on maintain", sub("beta_deg: 10}", "beta_deg: 10, lambda_s: 8.5}"), 17,
     "behaviours[2].maintain_plume.lambda_s", "moved to perception.lambda_s"),
    ("old oracle", sub("{variant: upflow_cluster}", "{variant: oracle, radius_m: 1}"), 16,
     "behaviours[1].declare_source.variant", "evaluation: {criterion: arrival"),
    # a speed the simulated vehicle would clip (a review's speed_mps 16 flew at 2.8 m/s)
    ("cruise beyond the simulated vehicle",
     lambda t: sub("  seed: 3", "  seed: 3\n  vehicle: {max_speed_mps: 2}")(
         sub("speed_mps: 1.5", "speed_mps: 2.5")(t)), 7, "speed_mps",
     "2.5 m/s is outside the simulated vehicle's speeds [0.25, 2] m/s"),
    ("behaviour below the simulated vehicle",
     lambda t: sub("  seed: 3", "  seed: 3\n  vehicle: {min_speed_mps: 0.5}")(
         sub("{variant: go_to}", "{variant: go_to, speed_mps: 0.3}")(t)), 20,
     "behaviours[5].move_to_field.speed_mps", "it would fly at 0.5 m/s"),
    ("initial speed beyond the simulated vehicle",
     sub("  seed: 3", "  seed: 3\n  vehicle: {initial_speed_mps: 10}"), 32,
     "environment.vehicle.initial_speed_mps", "10 m/s is outside the simulated vehicle's"),
    ("launch heading beyond a turn", sub("  seed: 3", "  seed: 3\n  launch_heading_deg: 1e300"),
     32, "environment.launch_heading_deg", "less than or equal to 360"),
    ("only a document marker", whole("---\n"), 1, "(top)", "not an empty document"),
    ("a number for a key", sub("cycle_hz: 1", "cycle_hz: 1\n1: foo"), 9, "[1]",
     "Keys should be strings"),
    # -- YAML 1.1's other number forms, which PyYAML reads and YAML 1.2 does not ----------------
    ("octal seed", sub("seed: 3", "seed: 017"), 31, "environment.seed",
     "'017' is read by YAML 1.1 as 15 (octal)"),
    ("hexadecimal speed", sub("speed_mps: 1.5", "speed_mps: 0x1"), 7, "speed_mps",
     "as 1 (hexadecimal)"),
    ("grouped digits", sub("flow_speed_mps: 0.1", "flow_speed_mps: 1_0"), 30,
     "environment.flow_speed_mps", "as 10 (digits grouped with _)"),
    ("base-60 angle", sub("beta_deg: 10", "beta_deg: 1:30"), 17,
     "behaviours[2].maintain_plume.beta_deg", "as 90 (base 60)"),
    ("leading-zero decimal", sub("time_limit_s: 1800", "time_limit_s: 01800"), 9,
     "time_limit_s", "'01800' has a leading zero, which YAML 1.1 reads as text"),
    # an attacker's: "(yaml): ... use sys.set_int_max_str_digits()" at line 1, no key named
    ("a 5001-digit number", sub("speed_mps: 1.5", "speed_mps: " + "1" * 5001), 7, "speed_mps",
     "a number 5001 characters long: no mission value needs more than 100"),
    ("maintain criterion with mission_a",
     sub("cycle_hz: 1", "cycle_hz: 1\nevaluation: {criterion: maintain}"), 9,
     "evaluation.criterion", "remove the mission_a section"),
]


def geodetic(text: str) -> str:
    """The base mission in latitude/longitude (a small area off San Clemente Island)."""
    text = text.replace("frame: ne", "frame: geodetic")
    text = text.replace("[[100, -50], [100, 50], [-100, 50], [-100, -50]]",
                        "[[32.981, -118.537], [32.981, -118.536], [32.979, -118.536], "
                        "[32.979, -118.537]]")
    text = text.replace("start: [-80, 20]", "start: [32.9795, -118.5366]")
    text = text.replace("home: [-90, 0]", "home: [32.9805, -118.5375]")
    text = text.replace("home: [32.9805, -118.5375]", "home: [32.9802, -118.5368]")
    text = text.replace("waypoints: [[-90, 0], [-50, 0]]",
                        "waypoints: [[32.9802, -118.5368], [32.9804, -118.5368]]")
    return text.replace("source: [60, 0]", "source: [32.9805, -118.5365]")


def test_the_base_and_its_geodetic_form_are_valid(tmp_path: Path, capsys) -> None:  # type: ignore[no-untyped-def]
    for name, text in (("base.yaml", BASE), ("geo.yaml", geodetic(BASE))):
        path = tmp_path / name
        path.write_text(text, encoding="utf-8")
        assert main(["validate", str(path)]) == 0, capsys.readouterr().err


def test_the_corpus_is_large_enough() -> None:
    assert len(CASES) >= 40


@pytest.mark.parametrize(("edit", "line", "path", "fragment"),
                         [c[1:] for c in CASES], ids=[c[0] for c in CASES])
def test_bad_mission_gives_one_precise_line(  # type: ignore[no-untyped-def]
    tmp_path: Path, capsys, edit: Edit, line: int, path: str, fragment: str
) -> None:
    mission = tmp_path / "m.yaml"
    mission.write_text(edit(BASE), encoding="utf-8")
    status = main(["validate", str(mission)])
    out = capsys.readouterr()
    lines = out.err.strip().splitlines()
    assert status == 2, out
    assert len(lines) == 1, lines
    assert "Traceback" not in out.err
    match = re.match(rf"{re.escape(str(mission))}:(\d+): (\S+): (.*)", lines[0])
    assert match, lines[0]
    assert (int(match[1]), match[2]) == (line, path), lines[0]
    assert fragment in match[3], lines[0]


def test_a_file_name_with_control_characters_stays_on_one_line(  # type: ignore[no-untyped-def]
        tmp_path: Path, capsys) -> None:
    """An attacker's file name with a newline and a colour code split its problem over two
    lines, the second in red."""
    mission = tmp_path / "nl\nname\x1b[31m.yaml"
    mission.write_text(BASE.replace("speed_mps: 1.5", "speed_mps: -1"), encoding="utf-8")
    assert main(["validate", str(mission)]) == 2
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert line.startswith(f"{tmp_path}/nl\\nname\\x1b[31m.yaml:") and "\x1b" not in line
    # its warnings and its "ok" line alike (a diff review: only errors were escaped)
    mission.write_text(BASE.replace("time_limit_s: 1800", "time_limit_s: 1800\n"
                                    "evaluation: {success_radius_m: 80}"), encoding="utf-8")
    assert main(["validate", str(mission)]) == 0
    out = capsys.readouterr()
    (warning,) = out.err.strip().splitlines()
    (ok,) = out.out.strip().splitlines()
    assert "warning: 80 m" in warning and "\x1b" not in warning + ok
    assert ok.startswith(f"{tmp_path}/nl\\nname\\x1b[31m.yaml: ok"), ok
    # a space of another kind is part of a name, not an attack (a second review)
    from cptbt.mission import printable

    assert printable("my\u00a0survey.yaml") == "my\u00a0survey.yaml"
    assert printable("a\u2028b\tc") == "a\\u2028b\\tc"


def test_a_problem_echoing_a_huge_value_is_cut(  # type: ignore[no-untyped-def]
        tmp_path: Path, capsys) -> None:
    """An attacker's 300 000-character variant name was echoed whole, one 300-kB line; a
    start 1e300 m out printed all 301 digits."""
    mission = tmp_path / "m.yaml"
    mission.write_text(BASE.replace("start: [-80, 20]", "start: [1e300, 0]"), encoding="utf-8")
    main(["validate", str(mission)])
    assert "start: 1e+300 m outside the OpArea" in capsys.readouterr().err
    entry = re.search(r"  - (\w+): \{variant: (\w+)", BASE)
    assert entry is not None
    mission.write_text(BASE.replace(entry[0], f"  - {entry[1]}: {{variant: {'v' * 300_000}"),
                       encoding="utf-8")
    assert main(["validate", str(mission)]) == 2
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert len(line) < 2100 and line.endswith(" characters in all)"), line[-200:]


def test_a_file_not_in_utf8_is_reported_at_the_bad_bytes_line_and_column(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # Latin-1 'é' in a description (line 2): was ':0: (file): ... in position 41'.
    text = BASE.replace("frame: ne", "description: café\nframe: ne")
    path = tmp_path / "latin1.yaml"
    path.write_bytes(text.encode("latin-1"))
    assert main(["validate", str(path)]) == 2
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert line.startswith(f"{path}:2: (file): byte 0xe9 at column 17 is not UTF-8"), line


def _memory_cap() -> None:  # pragma: no cover - runs in the child
    import resource

    resource.setrlimit(resource.RLIMIT_AS, (2 << 30, 2 << 30))  # 2 GiB: a regression fails


def test_an_endless_file_is_refused_after_a_missions_size() -> None:
    # /dev/zero was read whole before its size was checked: 6.9 GB in 10 s, and no answer.
    # In a child with a memory cap and a time limit, so a regression fails instead of hanging.
    import subprocess
    import sys

    res = subprocess.run([sys.executable, "-m", "cptbt", "validate", "/dev/zero"],
                         capture_output=True, text=True, timeout=60, preexec_fn=_memory_cap)
    assert res.returncode == 2, res.stderr[-500:]
    (line,) = res.stderr.strip().splitlines()
    assert line.startswith("/dev/zero:1: (file): more than ") and "at most" in line, line


def test_whole_floats_for_counts_and_integers_for_floats_stay_valid(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # Only conversions from another YAML type are refused: 3.0 is a whole number, 1 a number.
    text = BASE.replace("seed: 3", "seed: 3.0").replace("speed_mps: 1.5", "speed_mps: 2")
    path = tmp_path / "fine.yaml"
    path.write_text(text, encoding="utf-8")
    assert main(["validate", str(path)]) == 0, capsys.readouterr().err


def test_every_mistake_of_a_file_is_told_at_once_in_line_order(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A review's file with five mistakes was told four, not in line order; the quoted number
    came only once the others were mended (its check ran only when the rest validated)."""
    path = tmp_path / "five.yaml"
    path.write_text(BASE.replace("speed_mps: 1.5", "speed_mps: '1.5'")
                    .replace("cycle_hz: 1", "cycle_hz: -1")
                    .replace("beta_deg: 10}", "beta_deg: 10, bta: 3}")
                    .replace("flow_speed_mps: 0.1", "flow_speed_mps: fast")
                    .replace("seed: 3", "seed: 3.5"), encoding="utf-8")
    assert main(["validate", str(path)]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert [line.split(": ")[1] for line in lines] == [
        "speed_mps", "cycle_hz", "behaviours[2].maintain_plume.bta",
        "environment.flow_speed_mps", "environment.seed"], lines
    assert "(a quoted string)" in lines[0]
    numbers = [int(line.split(":")[1]) for line in lines]
    assert numbers == sorted(numbers)


@pytest.mark.parametrize("params", ["beta_deg: '10', bta: 3, beta1_deg: x",
                                    "bta: 3, beta1_deg: x, beta_deg: '10'",
                                    "beta1_deg: x, beta_deg: '10', bta: 3"])
def test_mistakes_on_one_line_are_told_left_to_right(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], params: str
) -> None:
    """A flow mapping with three mistakes was told in the model's field order, not the line's
    (a review)."""
    path = tmp_path / "one_line.yaml"
    path.write_text(BASE.replace("beta_deg: 10}", params + "}"), encoding="utf-8")
    assert main(["validate", str(path)]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    told = [line.split(": ")[1].rsplit(".", 1)[1] for line in lines]
    assert told == [part.split(":")[0].strip() for part in params.split(",")], lines


def test_a_duplicate_key_is_told_with_the_files_other_mistakes(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A review's file with five mistakes was told only its duplicate key; then only its old
    number form; the rest came after both were mended."""
    path = tmp_path / "dup.yaml"
    path.write_text(BASE.replace("cycle_hz: 1", "cycle_hz: 1\ncycle_hz: 2")
                    .replace("speed_mps: 1.5", "speed_mps: '1.5'")
                    .replace("time_limit_s: 1800", "time_limit_s: 0x700")
                    .replace("beta_deg: 10}", "beta_deg: 10, bta: 3}"), encoding="utf-8")
    assert main(["validate", str(path)]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    told = [line.split(": ")[1] for line in lines]
    assert told == ["speed_mps", "cycle_hz", "time_limit_s",
                    "behaviours[2].maintain_plume.bta"], lines
    assert "duplicate key (first at line 8)" in lines[1]
    numbers = [int(line.split(":")[1]) for line in lines]
    assert numbers == sorted(numbers) and numbers[1] == 9  # the duplicate's own line
    # a duplicate inside an anchored mapping is told once, not again where an alias repeats it
    path.write_text("a: &x {b: 1, b: 2}\n" + BASE.replace("cycle_hz: 1", "cycle_hz: *x"),
                    encoding="utf-8")
    assert main(["validate", str(path)]) == 2
    told = capsys.readouterr().err
    assert told.count("duplicate key") == 1 and "a.b: duplicate key" in told, told


def test_a_file_of_thousands_of_mistakes_is_told_fifty_and_a_count(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """2 000 stray (or duplicate) keys had printed 2 000 lines: the first fifty are told, in
    line order, then how many more there are."""
    for name, extra in (("stray", "zz{i}: 1\n"), ("dup", "cycle_hz: {i}\n")):
        path = tmp_path / f"{name}.yaml"
        path.write_text(BASE + "".join(extra.format(i=i) for i in range(2000)), encoding="utf-8")
        assert main(["validate", str(path)]) == 2
        lines = capsys.readouterr().err.strip().splitlines()
        assert len(lines) == 51 and lines[-1] == ("cptbt: ... and 1950 more problems (mend "
                                                  "these and validate again)"), lines[-1]
        numbers = [int(line.split(":")[1]) for line in lines[:-1]]
        assert numbers == sorted(numbers)


def test_every_old_number_form_in_a_file_is_told_at_once(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A review fixed one, ran again, and met the next: each is a line of its own."""
    path = tmp_path / "old.yaml"
    path.write_text(BASE.replace("seed: 3", "seed: 0x10").replace("beta_deg: 10", "beta_deg: 1:30")
                    .replace("time_limit_s: 1800", "time_limit_s: 017"), encoding="utf-8")
    assert main(["validate", str(path)]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert [line.split(": ")[1] for line in lines] == [
        "time_limit_s", "behaviours[2].maintain_plume.beta_deg", "environment.seed"], lines


@pytest.mark.parametrize("spelling", ["-.5", "+.5"])
def test_signed_leading_dot_floats_are_numbers(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], spelling: str
) -> None:
    # YAML 1.2 reads -.5 as a number; PyYAML reads it as text, which had been refused as "a
    # quoted string" though nothing was quoted
    path = tmp_path / "dot.yaml"
    path.write_text(BASE.replace("flow_toward_deg: 180", f"flow_toward_deg: {spelling}"),
                    encoding="utf-8")
    assert main(["validate", "--dump", str(path)]) == 0, capsys.readouterr().err
    assert f"flow_toward_deg: {float(spelling)}" in capsys.readouterr().out


@pytest.mark.parametrize("spelling", ["15e-1", "1.5E0", "+.15e+1", "150e-2"])
def test_exponent_floats_without_a_dot_are_numbers(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], spelling: str
) -> None:
    # YAML 1.2 reads 1e-3 as a number; PyYAML (YAML 1.1) would read it as a string that the
    # strict-number rule then refuses as quoted. The mission loader resolves YAML 1.2 floats.
    path = tmp_path / "sci.yaml"
    path.write_text(BASE.replace("speed_mps: 1.5", f"speed_mps: {spelling}")
                    .replace("time_limit_s: 1800", "time_limit_s: 18e2"), encoding="utf-8")
    assert main(["validate", "--dump", str(path)]) == 0, capsys.readouterr().err
    out = capsys.readouterr().out
    assert "speed_mps: 1.5" in out and "time_limit_s: 1800.0" in out, out


def test_an_unknown_simulator_override_gets_suggestions(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    text = BASE.replace("  seed: 3", "  seed: 3\n  plume: {release_rat_hz: 3}")
    path = tmp_path / "typo.yaml"
    path.write_text(text, encoding="utf-8")
    assert main(["run", str(path), "--no-figure", "--quiet", "--out", str(tmp_path / "o")]) == 2
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert line.endswith("environment.plume.release_rat_hz: unknown key; did you mean "
                         "'release_rate_hz'?"), line
