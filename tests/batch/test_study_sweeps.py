"""Study sweeps: every kind of mission path is set where the mission keeps it."""

from __future__ import annotations

from pathlib import Path

import pytest

from cptbt.batch.sweeps import Sweep, apply_setting


def data() -> dict:  # type: ignore[type-arg]
    return {
        "speed_mps": 1.5,
        "perception": {"threshold": 0.2},
        "behaviours": [{"maintain_plume": {"variant": "track_in_out", "beta_deg": 10}}],
    }


@pytest.mark.parametrize(
    ("path", "value", "where"),
    [
        ("speed_mps", 2.0, ("speed_mps",)),
        ("perception.lambda_s", 4.0, ("perception", "lambda_s")),
        ("perception.threshold", 0.5, ("perception", "threshold")),
        ("evaluation.success_radius_m", 5.0, ("evaluation", "success_radius_m")),
        ("environment.flow.mean_speed_mps", 0.3, ("environment", "flow", "mean_speed_mps")),
        ("maintain_plume.beta_deg", 20, ("behaviours", 0, "maintain_plume", "beta_deg")),
        # an attacker's op_area sweep read "the mission has no 'op_area' behaviour"
        ("op_area.corners", [[0, 0], [1, 0], [1, 1], [0, 1]], ("op_area", "corners")),
    ],
)
def test_a_sweep_sets_its_path(path: str, value: object, where: tuple) -> None:  # type: ignore[type-arg]
    d = data()
    apply_setting(d, path, value)
    node = d
    for key in where:
        node = node[key]
    assert node == value


def test_a_variant_sweep_drops_the_old_variants_params() -> None:
    d = data()
    apply_setting(d, "maintain_plume.variant", "counter_turn")
    assert d["behaviours"][0] == {"maintain_plume": {"variant": "counter_turn"}}


@pytest.mark.parametrize("path", ["nonsense", "find_plume.dtheta_up_deg"])
def test_a_sweep_of_nothing_is_an_error(path: str) -> None:
    with pytest.raises(ValueError, match="sweep path"):
        apply_setting(data(), path, 1)


@pytest.mark.parametrize(("path", "why"), [("environment.seed", "the same plumes"),
                                           ("start", "the same runs")])
def test_a_sweep_of_what_a_study_sets_itself_is_refused(path: str, why: str) -> None:
    """A review swept environment.seed for more plumes: both 'worlds' came out identical, run
    for run, told they differed; a start sweep flew the study's own starts at every value."""
    with pytest.raises(ValueError, match=f"sweep path '{path}': .*{why}"):
        apply_setting(data(), path, 1)


def test_sweep_parses_joined_paths_and_yaml_values() -> None:
    s = Sweep.parse("maintain_plume.variant+reacquire_plume.variant=strategy_1,strategy_2")
    assert s.paths == ("maintain_plume.variant", "reacquire_plume.variant")
    assert s.values == ("strategy_1", "strategy_2") and s.name.count("+") == 1
    assert Sweep.parse("perception.lambda_s=1,2.5").values == (1, 2.5)


def test_sweep_values_may_be_points() -> None:
    """An attacker's ``environment.source=[1,2]`` was split at its comma, a YAML parser dump."""
    assert Sweep.parse("environment.source=[1, 2],[3,4]").values == ([1, 2], [3, 4])


def test_sweep_values_read_exponent_floats_as_a_mission_file_does() -> None:
    # YAML 1.1 (PyYAML's) reads 1e-3 as a string; a mission reads it as a number (YAML 1.2).
    assert Sweep.parse("declare_source.false_alarm_prob=1e-3,2E-2").values == (0.001, 0.02)
    assert Sweep.parse("x='1e-3'").values == ("1e-3",)  # quoted: a string, refused later


def test_a_sweep_value_yaml_cannot_read_is_a_value_error() -> None:
    with pytest.raises(ValueError, match="not YAML"):
        Sweep.parse("speed_mps=[")


def test_a_whole_behaviour_sweep_sets_a_variant_then_its_settings() -> None:
    """A ``<family>`` sweep: a name as ``<family>.variant`` sets it, a mapping its variant (the
    mission's keeps its settings, another starts from its defaults) and then each setting."""
    cases = [
        ("track_in_out", {"variant": "track_in_out", "beta_deg": 10}),
        ("counter_turn", {"variant": "counter_turn"}),
        ({"beta_deg": 20}, {"variant": "track_in_out", "beta_deg": 20}),
        ({"variant": "track_in_out", "speed_mps": 1}, {"variant": "track_in_out",
                                                        "beta_deg": 10, "speed_mps": 1}),
        ({"variant": "counter_turn", "speed_mps": 1}, {"variant": "counter_turn",
                                                        "speed_mps": 1}),
    ]
    for value, flown in cases:
        d = data()
        apply_setting(d, "maintain_plume", value)
        assert d["behaviours"][0] == {"maintain_plume": flown}, value
    for junk in (3, [1, 2], {}, {1: 2}, None):
        with pytest.raises(ValueError, match="neither a variant's name nor a mapping"):
            apply_setting(data(), "maintain_plume", junk)


def test_a_label_splits_at_its_settings_not_inside_a_behaviours_mapping() -> None:
    from cptbt.batch.sweeps import label_parts

    whole = "declare_source=likelihood_map(radius_m=12, flyby=true)"
    assert label_parts(f"speed_mps=1, {whole}") == ["speed_mps=1", whole]
    assert label_parts("tro2006_msn007") == ["tro2006_msn007"]


def test_sweep_values_split_at_commas_outside_brackets_and_quotes() -> None:
    from cptbt.batch.sweeps import split_values

    assert split_values("a,'b,c',{k: 'x,y'},o'clock,d") == [
        "a", "'b,c'", "{k: 'x,y'}", "o'clock", "d"]


def test_a_whole_behaviour_sweep_parses_mappings_with_commas() -> None:
    s = Sweep.parse("declare_source=upflow_cluster,{variant: likelihood_map, radius_m: 8},"
                    " {variant: likelihood_map, flyby: true}, 'a,b'")
    assert s.values == ("upflow_cluster", {"variant": "likelihood_map", "radius_m": 8},
                        {"variant": "likelihood_map", "flyby": True}, "a,b")
    assert s.text == ("declare_source=upflow_cluster,{variant: likelihood_map, radius_m: 8},"
                      "{variant: likelihood_map, flyby: true},a,b")


def test_a_whole_behaviour_sweep_compares_a_variant_with_settings_of_another() -> None:
    """One study: the mission's rule against two settings of the likelihood map, each labelled
    by what it flies; the mission's own settings of a variant not swept in are said dropped."""
    from cptbt.batch.scenario import Environment
    from cptbt.batch.study import configurations
    from cptbt.batch.sweeps import study_notes
    from cptbt.loader import loads_mission
    from cptbt.registry import default_registry

    path = Path(__file__).resolve().parents[2] / "missions/tro2006_msn007.yaml"
    mission = loads_mission(path.read_text(encoding="utf-8"), str(path), default_registry(),
                            Environment)
    sweep = Sweep.parse("declare_source=upflow_cluster,{variant: likelihood_map, radius_m: 8},"
                        "{variant: likelihood_map, radius_m: 12, flyby: true},{epsilon_m: 6}")
    configs = configurations(mission, [sweep], str(path))
    assert [c.coords for c in configs] == [
        {"declare_source": "upflow_cluster"},
        {"declare_source": "likelihood_map(radius_m=8)"},
        {"declare_source": "likelihood_map(radius_m=12, flyby=true)"},
        # a mapping without a variant is the mission's (a review's read "(epsilon_m=6)")
        {"declare_source": "upflow_cluster(epsilon_m=6)"}]
    configs = configs[:3]
    flown = [next(e for e in c.mission.entries() if e.family == "declare_source")
             for c in configs]
    assert [e.variant for e in flown] == ["upflow_cluster", "likelihood_map", "likelihood_map"]
    assert flown[0].params.epsilon_m == 4 and flown[0].params.recent_points == 6  # the mission's
    assert (flown[1].params.radius_m, flown[1].params.flyby) == (8, False)
    assert (flown[2].params.radius_m, flown[2].params.flyby) == (12, True)
    own, note = study_notes(mission, [sweep])
    assert note.startswith("sweep declare_source: likelihood_map flies with its own defaults")
    assert "no parameter for recent_points=6, epsilon_m=4.0" in note
    # a review: a bare name flew the mission's settings in one study, the defaults in another
    assert own == ("sweep declare_source: upflow_cluster is the mission's own variant: where "
                   "a value does not set them, it flies the mission's declare_source settings "
                   "(recent_points=6, epsilon_m=4.0), not its defaults")
    # the variant swept twice over is refused, and a bad setting names its sweep
    with pytest.raises(ValueError, match=r"declare_source and declare_source\.variant"):
        configurations(mission, [sweep, Sweep.parse("declare_source.variant=recent_box")],
                       str(path))
    # a setting a mapping gives, swept too: one would silently replace the other (a diff
    # review's labels showed confidence=0.95 where 0.8 and 0.9 flew)
    with pytest.raises(ValueError, match=r"declare_source and declare_source\.radius_m both "
                                         r"set radius_m"):
        configurations(mission, [sweep, Sweep.parse("declare_source.radius_m=5,10")],
                       str(path))
    from cptbt.loader import MissionError

    with pytest.raises(MissionError, match=r"sweep declare_source=likelihood_map\(radius_m=-1\)"):
        configurations(mission, [Sweep.parse("declare_source={variant: likelihood_map, "
                                             "radius_m: -1}")], str(path))



AB1 = "missions/ab2001_strategy1.yaml"


def _give_up(config) -> object:  # type: ignore[no-untyped-def]
    import yaml

    body = yaml.safe_load(config.mission_yaml)["behaviours"]
    return next(e["reacquire_plume"] for e in body if "reacquire_plume" in e).get("give_up_s")


def test_a_variant_sweep_says_which_mission_settings_it_drops() -> None:
    from pathlib import Path

    from cptbt.batch.scenario import Environment
    from cptbt.batch.study import configurations
    from cptbt.batch.sweeps import variant_sweep_notes
    from cptbt.loader import loads_mission
    from cptbt.registry import default_registry

    path = Path(__file__).resolve().parents[2] / AB1
    text = path.read_text(encoding="utf-8").replace("give_up_s: 4}", "give_up_s: 7}")
    assert "give_up_s: 7}" in text
    mission = loads_mission(text, str(path), default_registry(), Environment)
    strategies = Sweep.parse("maintain_plume.variant+reacquire_plume.variant=strategy_1,strategy_3")
    (note,) = variant_sweep_notes(mission, [strategies])
    assert "reacquire_plume.variant" in note and "give_up_s=4.0 (the mission's 7.0)" in note
    assert [_give_up(c) for c in configurations(mission, [strategies], str(path))] == [7, 4]
    # The same setting swept beside it is kept, in either order: no note, and every
    # configuration flies with it.
    give_up = Sweep.parse("reacquire_plume.give_up_s=7")
    for sweeps in ([strategies, give_up], [give_up, strategies]):
        assert variant_sweep_notes(mission, sweeps) == []
        assert [_give_up(c) for c in configurations(mission, sweeps, str(path))] == [7, 7]
    # A sweep of the mission's own variant alone drops nothing.
    same = Sweep.parse("maintain_plume.variant+reacquire_plume.variant=strategy_1")
    assert variant_sweep_notes(mission, [same]) == []


def test_a_variant_sweep_names_the_settings_the_other_variant_has_no_parameter_for() -> None:
    from cptbt.batch.scenario import Environment
    from cptbt.batch.sweeps import variant_sweep_notes
    from cptbt.loader import loads_mission
    from cptbt.registry import default_registry

    # A two-source likelihood map swept against one-source rules: max_sources and the fly-by
    # do not apply to them (the comparison is not like for like, and is said so); the map's
    # settings left at its own defaults are no choice of the mission's, and not listed.
    path = Path(__file__).resolve().parents[2] / "missions/two_sources.yaml"
    text = path.read_text(encoding="utf-8").replace("max_sources: 2", "max_sources: 2, flyby: true")
    assert "flyby: true" in text
    mission = loads_mission(text, str(path), default_registry(), Environment)
    notes = variant_sweep_notes(
        mission, [Sweep.parse("declare_source.variant=likelihood_map,upflow_cluster")])
    assert notes == ["sweep declare_source.variant: upflow_cluster flies with its own defaults, "
                     "not the mission's declare_source settings: it has no parameter for "
                     "max_sources=2, flyby=True"], notes
    # a setting both variants have: the value flown is the variant's default, the mission's
    # beside it (a review read the mission's value as the one flown)
    text = OBLIQUE.read_text(encoding="utf-8").replace("{variant: cloverleaf, d_leaf_m: 15,",
                                                       "{variant: cloverleaf, d_leaf_m: 15, "
                                                       "arrive_radius_m: 4,")
    assert "arrive_radius_m: 4" in text
    mission = loads_mission(text, str(OBLIQUE), default_registry(), Environment)
    (note,) = variant_sweep_notes(mission, [Sweep.parse("reacquire_plume.variant=three_point")])
    assert "it flies arrive_radius_m=" in note and "(the mission's 4.0)" in note, note


OBLIQUE = Path(__file__).resolve().parents[2] / "missions/oblique_flow.yaml"


@pytest.mark.parametrize(("sweep", "where"), [
    # a key the file has: its line, the sweep named
    ("maintain_plume.beta_deg=5,500", ":43: behaviours[2].maintain_plume.beta_deg: Input should "
     "be less than 90, got 500 (with sweep maintain_plume.beta_deg=500)"),
    # a key the file lacks: no line (the swept mission's own text is no file the user has)
    ("reacquire_plume.arrive_radius_m=-1", " [sweep reacquire_plume.arrive_radius_m=-1]: "
     "behaviours[3].reacquire_plume.arrive_radius_m: Input should be greater than 0, got -1"),
    # the simulator's limits are checked before any run, as for the file itself
    ("environment.dt_s=1e-7", " [sweep environment.dt_s=1e-07]: environment.dt_s: Input should "
     "be greater than or equal to 0.005, got 1e-07"),
    # a flow speed the mission's flow_speed_mps overrides: every configuration would fly the
    # same flow (the sweep compared nothing)
    ("environment.flow.mean_speed_mps=0.1,0.2", " [sweep environment.flow.mean_speed_mps=0.1; "
     "environment.flow.mean_speed_mps=0.2]: environment.flow.mean_speed_mps: given with "
     "environment.flow_speed_mps, which sets it: give one of them"),
])
def test_a_bad_swept_value_is_reported_at_the_files_key_or_without_a_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], sweep: str, where: str
) -> None:
    from cptbt.cli import main

    status = main(["batch", str(OBLIQUE), "--grid", "1x1", "--sweep", sweep,
                   "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err.strip().splitlines()
    # the first bad value's line (every bad value is told: the flow sweep's 0.2 too)
    assert status == 2 and err[0] == f"{OBLIQUE}{where}", err
    assert not (tmp_path / "out").exists()


def test_a_time_limit_sweep_and_a_study_time_limit_are_refused_together(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # A review: --time-limit 45 replaced a time_limit_s=30,60 sweep in every configuration,
    # the rows still labelled 30 and 60.
    from cptbt.cli import main

    status = main(["batch", str(OBLIQUE), "--grid", "1x1", "--sweep", "time_limit_s=30,60",
                   "--time-limit", "45", "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err
    assert status == 2 and "would replace the swept time_limit_s" in err, err
    assert not (tmp_path / "out").exists()


TWO = Path(__file__).resolve().parents[2] / "missions/two_sources.yaml"


def with_study(tmp_path: Path, sweeps: str) -> tuple[Path, int]:
    """The shipped two-source mission with a study section sweeping ``sweeps`` (one YAML
    line); its path and the study line's number."""
    text = TWO.read_text(encoding="utf-8")
    path = tmp_path / "m.yaml"
    path.write_text(text + f"study:\n  sweeps:\n    {sweeps}\n", encoding="utf-8")
    return path, text.count("\n") + 1


@pytest.mark.parametrize(("sweeps", "expected"), [
    # a key the file lacks: at the study section's own line for that sweep
    ("declare_source.radius_m: [10, .nan]", ":{line}: behaviours[1].declare_source.radius_m: "
     "Input should be a finite number (with sweep declare_source.radius_m=nan)"),
    # a key the file has too: at the sweep's line, where the bad value is
    ("environment.flow_speed_mps: [0.1, -1]", ":{line}: environment.flow_speed_mps: Input "
     "should be greater than or equal to 0, got -1 (with sweep environment.flow_speed_mps=-1)"),
    ("infotaxis.cell_m: [1, 2]", ":{study}: study.sweeps: sweep path 'infotaxis.cell_m': the "
     "mission has no 'infotaxis' behaviour"),
    ("declare_source.radius_m: [10, 10.0]", ":{study}: study.sweeps: sweep "
     "declare_source.radius_m=10.0 flies the same mission as declare_source.radius_m=10: give "
     "each value once"),
])
def test_validate_makes_the_missions_own_study_configurations(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], sweeps: str, expected: str
) -> None:
    # `cptbt validate` said "ok" to a study that `cptbt batch` then refused
    from cptbt.cli import main

    path, study = with_study(tmp_path, sweeps)
    assert main(["validate", str(path)]) == 2
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert line == f"{path}" + expected.format(line=study + 2, study=study + 1), line


def test_validate_warns_of_a_swept_value_likely_not_meant(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from cptbt.cli import main

    path, _ = with_study(tmp_path, "declare_source.radius_m: [10, 500]")
    assert main(["validate", str(path)]) == 0
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert line.startswith(f"{path} [sweep declare_source.radius_m=500]: "
                           "behaviours[1].declare_source.radius_m: warning: 500 m"), line
    assert "off by up to about 278 m" in line  # not 500 m: no farther than across the area


def test_validate_reads_a_piped_mission_once() -> None:
    # the study's sweeps and the warnings re-read the file: a pipe was empty by then
    import subprocess
    import sys

    ab = Path(__file__).resolve().parents[2] / "missions/ab2001_fig9.yaml"
    res = subprocess.run([sys.executable, "-m", "cptbt", "validate", "/dev/stdin"],
                         input=ab.read_text(encoding="utf-8"), capture_output=True, text=True,
                         timeout=120)
    assert res.returncode == 0 and res.stdout.startswith("/dev/stdin: ok"), res.stderr


def test_a_sweep_whose_values_make_the_same_mission_is_refused(tmp_path: Path) -> None:
    # 10 and 10.0 are one radius: two identical configurations flew as if two
    from cptbt.cli import main

    res = main(["batch", str(TWO), "--grid", "1x1", "--sweep", "declare_source.radius_m=10,10.0",
                "--out", str(tmp_path / "o")])
    assert res == 2 and not (tmp_path / "o").exists()


def test_validate_names_what_a_studys_variant_sweep_drops(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # only the settings the mission made: max_spread_m = 20 is the likelihood map's own
    # default (and means another spread there), not a setting upflow_spread drops
    from cptbt.cli import main

    path, _ = with_study(tmp_path, "declare_source.variant: [likelihood_map, upflow_spread]")
    assert main(["validate", str(path)]) == 0
    err = capsys.readouterr().err.strip().splitlines()
    (note,) = [ln for ln in err if ": note: " in ln]
    assert note == (f"{path}: note: sweep declare_source.variant: upflow_spread flies with its "
                    "own defaults, not the mission's declare_source settings: it has no "
                    "parameter for max_sources=2"), note
    # and the world no run of that configuration can succeed in is warned of, named
    assert any("[sweep declare_source.variant=upflow_spread]" in ln and "declares one source"
               in ln for ln in err), err


def test_a_configuration_is_a_mission_without_the_study_it_belongs_to() -> None:
    """Each configuration's mission drops the study section (the plan is the mission's own):
    a 500-value sweep wrote and parsed its 500 values in each of its 1 000 mission texts."""
    from cptbt.batch.scenario import Environment
    from cptbt.batch.study import configurations
    from cptbt.loader import loads_mission
    from cptbt.registry import default_registry

    root = Path(__file__).resolve().parents[2]
    text = (root / "missions/tro2006_msn007.yaml").read_text(encoding="utf-8")
    text += "\nstudy:\n  runs_per_start: 3\n  sweeps:\n    speed_mps: [1.0, 1.2, 1.4]\n"
    mission = loads_mission(text, "m.yaml", default_registry(), Environment)
    assert mission.study is not None
    configs = configurations(mission, [Sweep(("speed_mps",), (1.0, 1.2, 1.4))], "m.yaml")
    flown = [loads_mission(c.mission_yaml, "c.yaml", default_registry(), Environment)
             for c in configs]
    assert [m.speed_mps for m in flown] == [1.0, 1.2, 1.4]
    assert all(m.study is None and "sweeps" not in c.mission_yaml
               for m, c in zip(flown, configs, strict=True))


def test_sweep_on_the_command_line_says_which_study_sweeps_it_replaces(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """--sweep replaces the study section's sweeps, all of them: the command says which of
    their values it does not fly, in the form that would keep them (it had replaced them
    silently), and what a path no --sweep sets is flown at. A study value the --sweep flies is
    not listed (ab_large_meander had been, with the sweep that flew it)."""
    from cptbt.cli import main

    ab = Path(__file__).resolve().parents[2] / "missions/ab2001_fig9.yaml"
    assert main(["batch", str(ab), "--sweep", "environment.preset=ab_large_meander",
                 "--runs-per-start", "1", "--time-limit", "5", "--workers", "1", "--no-plots",
                 "--quiet", "--out", str(tmp_path / "s")]) == 0
    notes = [line for line in capsys.readouterr().err.splitlines() if "replaces" in line]
    assert notes == [
        f"cptbt: note: --sweep replaces the sweeps of {ab}'s study section; not flown: "
        "environment.preset=ab_small_meander; maintain_plume.beta1_deg="
        "0,2.5,5,7.5,10,12.5,15,17.5,20,22.5,25 (give them as --sweep too to keep them); "
        "maintain_plume.beta1_deg falls back to the default, none (the three beta_*_deg, "
        "AB eq. 12)"]
    # The study's own sweeps, given again, are flown: no note.
    assert main(["batch", str(ab), "--sweep", "environment.preset=ab_large_meander,"
                 "ab_small_meander", "--sweep", "maintain_plume.beta1_deg=0", "--runs-per-start",
                 "1", "--time-limit", "5", "--workers", "1", "--no-plots", "--quiet",
                 "--out", str(tmp_path / "t")]) == 0
    notes = [line for line in capsys.readouterr().err.splitlines() if "replaces" in line]
    assert notes == [
        f"cptbt: note: --sweep replaces the sweeps of {ab}'s study section; not flown: "
        "maintain_plume.beta1_deg=2.5,5,7.5,10,12.5,15,17.5,20,22.5,25 (give them as --sweep "
        "too to keep them)"]


def test_a_study_value_is_flown_when_each_of_its_paths_takes_it() -> None:
    """The note's per-value comparison: joined paths need every path to take the value; a
    --sweep joining more paths still flies it."""
    from cptbt.cli.batch_sweeps import _not_flown

    own = [Sweep(("a", "b"), (1, 2)), Sweep(("c",), (3, 4))]
    assert _not_flown(own, [Sweep(("a",), (1, 2)), Sweep(("b",), (2,)),
                            Sweep(("c", "d"), (3, 4))]) == [Sweep(("a", "b"), (1,))]
    assert _not_flown(own, [Sweep(("a",), (1,))]) == own


def test_the_note_says_what_a_dropped_path_falls_back_to() -> None:
    """The mission's value where its file sets the path, else the default; a None is said with
    what None means (the field's description)."""
    from cptbt.cli.batch_sweeps import _fallback
    from cptbt.cli.inspect_cmds import load

    ab = load(str(Path(__file__).resolve().parents[2] / "missions/ab2001_fig9.yaml"),
              simulate=True, warn=False)
    assert _fallback(ab, "environment.preset") == (
        "environment.preset falls back to the mission's value, ab_large_meander")
    assert _fallback(ab, "maintain_plume.beta_mid_deg") == (
        "maintain_plume.beta_mid_deg falls back to the default, 65.0")
    assert _fallback(ab, "maintain_plume.beta1_deg") == (
        "maintain_plume.beta1_deg falls back to the default, none (the three beta_*_deg, "
        "AB eq. 12)")


def test_a_value_flown_as_a_dropped_paths_fallback_is_not_listed_as_not_flown() -> None:
    """A review's run: ``--sweep maintain_plume.beta1_deg=0,5`` on AB Fig. 9 flies the preset
    at the mission's ab_large_meander, which the note had listed as not flown beside saying
    the preset falls back to it."""
    from cptbt.cli.batch_sweeps import _fallback_value, _not_flown
    from cptbt.cli.inspect_cmds import load, study_sweeps

    ab = load(str(Path(__file__).resolve().parents[2] / "missions/ab2001_fig9.yaml"),
              simulate=True, warn=False)
    own = study_sweeps(ab)
    given = [Sweep(("maintain_plume.beta1_deg",), (0.0, 5.0))]
    left = {s.paths: s.values for s in
            _not_flown(own, given, lambda p: _fallback_value(ab, p)[0])}
    assert left[("environment.preset",)] == ("ab_small_meander",)
    assert 0.0 not in left[("maintain_plume.beta1_deg",)]
    assert 5.0 not in left[("maintain_plume.beta1_deg",)]


def test_every_bad_swept_value_is_reported_not_the_first_alone(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A review fixed and validated again once per bad value."""
    from cptbt.cli import main

    status = main(["batch", str(OBLIQUE), "--grid", "1x1", "--sweep",
                   "reacquire_plume.d_leaf_m=-1,abc,5", "--out", str(tmp_path / "s")])
    err = capsys.readouterr().err
    assert status == 2 and not (tmp_path / "s").exists()
    assert "(with sweep reacquire_plume.d_leaf_m=-1)" in err
    assert "(with sweep reacquire_plume.d_leaf_m=abc)" in err
    assert "d_leaf_m=5" not in err


def test_a_study_of_more_configurations_than_can_be_checked_is_refused_at_once(
        tmp_path: Path) -> None:
    """An attacker's 90 000-configuration study kept validate busy past two minutes, silent,
    at 800 MB and growing: the product of the sweeps' values is now bounded."""
    import subprocess
    import sys

    from cptbt.study_spec import MAX_CONFIGS

    root = Path(__file__).resolve().parents[2]
    text = (root / "missions/tro2006_msn007.yaml").read_text(encoding="utf-8")
    head = text.split("\nstudy:")[0]
    values = ", ".join(str(0.1 + i / 1000) for i in range(110))
    (tmp_path / "m.yaml").write_text(
        head + "\nstudy:\n  sweeps:\n"
        f"    perception.threshold: [{values}]\n"
        f"    perception.lambda_s: [{values.replace('0.1', '8.')}]\n", encoding="utf-8")
    cli = [sys.executable, "-m", "cptbt"]
    said = subprocess.run([*cli, "validate", str(tmp_path / "m.yaml")], capture_output=True,
                          text=True, timeout=60)
    assert said.returncode == 2 and f"more than {MAX_CONFIGS:,}" in said.stderr, said.stderr
    assert "12,100 configurations" in said.stderr
    flags = [f"--sweep=perception.threshold={values.replace(', ', ',')}",
             f"--sweep=perception.lambda_s={values.replace('0.1', '8.').replace(', ', ',')}"]
    said = subprocess.run([*cli, "batch", str(root / "missions/tro2006_msn007.yaml"),
                           "--amp-only", *flags, "--out", str(tmp_path / "s")],
                          capture_output=True, text=True, timeout=60)
    assert said.returncode == 2 and "12,100 configurations" in said.stderr, said.stderr
    assert not (tmp_path / "s").exists()


def test_one_problem_of_many_sweep_values_is_told_once() -> None:
    """An attacker's misspelt sweep path was told once per value (30 values, 30 lines)."""
    from cptbt.batch.scenario import Environment
    from cptbt.batch.study import configurations
    from cptbt.loader import MissionError, loads_mission
    from cptbt.registry import default_registry

    path = Path(__file__).resolve().parents[2] / "missions/tro2006_msn007.yaml"
    mission = loads_mission(path.read_text(encoding="utf-8"), str(path), default_registry(),
                            Environment)
    with pytest.raises(MissionError) as caught:
        configurations(mission, [Sweep.parse("perception.thresold=0.1,0.2,0.3,0.4,0.5")],
                       str(path))
    (line,) = caught.value.problems
    assert line == (f"{path} [sweep perception.thresold=0.1; perception.thresold=0.2; "
                    "perception.thresold=0.3 and 2 more]: perception.thresold: unknown key; "
                    "did you mean 'threshold'?"), line


@pytest.mark.parametrize(("text", "says"), [
    ("declare_source={variant: likelihood_map, radius_m: 010}", "'010' is read by YAML 1.1 as 8"),
    ("environment.source=[043, -55]", "'043' is read by YAML 1.1 as 35"),
    ("environment.source=[1" + "0" * 5000 + ", 0]", "a number 5001 characters long"),
    # the mission loader's guards (an attacker: RecursionError, and 0.9 GB for the bomb)
    ("declare_source=&a [*a]", "an alias refers to a value that contains it"),
    ("maintain_plume.beta_deg=[&a [1,1,1,1,1,1,1,1,1,1], " + ", ".join(
        f"&{b} [{', '.join([f'*{a}'] * 10)}]"
        for a, b in zip("abcdef", "bcdefg", strict=True)) + "]",
     "more than 50000 values once aliases are expanded"),
    ("maintain_plume.beta_deg=" + "[" * 45 + "1" + "]" * 45, "nested deeper than 40 levels"),
])
def test_old_numbers_inside_a_mapping_or_list_sweep_value_are_refused(text: str,
                                                                      says: str) -> None:
    """A diff review: a whole behaviour's ``radius_m: 010`` flew 8 and a point's
    ``[043, -55]`` put the source 8 m off, where a plain value or a mission file refuses."""
    with pytest.raises(ValueError, match=says) as caught:
        Sweep.parse(text)
    assert len(str(caught.value)) < 400


def test_a_sweep_that_takes_the_environment_away_is_told_at_its_line(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """An attacker's ``study: {sweeps: {environment: [null]}}`` validated, and the batch then
    ended in an internal error with no file, line or field."""
    from cptbt.cli import main

    text = (Path(__file__).resolve().parents[2] / "missions/small_oparea.yaml").read_text(
        encoding="utf-8")
    path = tmp_path / "m.yaml"
    path.write_text(text + "study: {sweeps: {environment: [null]}}\n", encoding="utf-8")
    line = len(text.splitlines()) + 1
    assert main(["validate", str(path)]) == 2
    told = capsys.readouterr()
    assert (f"m.yaml:{line}: environment: a simulated run needs an 'environment:' section"
            in told.out + told.err), told


def test_a_long_swept_value_is_shortened_in_a_problem() -> None:
    """An attacker's 20 000-value list printed a 129 kB problem line."""
    from cptbt.batch.scenario import Environment
    from cptbt.batch.study import configurations
    from cptbt.loader import MissionError, loads_mission
    from cptbt.registry import default_registry

    path = Path(__file__).resolve().parents[2] / "missions/tro2006_msn007.yaml"
    mission = loads_mission(path.read_text(encoding="utf-8"), str(path), default_registry(),
                            Environment)
    many = ", ".join(map(str, range(5000)))
    with pytest.raises(MissionError) as exc:
        configurations(mission, [Sweep.parse(f"maintain_plume.beta_deg=[{many}]")], str(path))
    (line,) = exc.value.problems
    assert "sweep maintain_plume.beta_deg=[0, 1, 2," in line and len(line) < 400, line


def test_a_problem_names_the_sweep_that_set_its_key_alone() -> None:
    """A diff review read a lambda_s problem "(with sweep perception.threshold=0.1,
    perception.lambda_s=-1, ...; ... and 107 more)": the other sweeps had nothing to do with
    it."""
    from cptbt.batch.scenario import Environment
    from cptbt.batch.study import configurations
    from cptbt.loader import MissionError, loads_mission
    from cptbt.registry import default_registry

    path = Path(__file__).resolve().parents[2] / "missions/tro2006_msn007.yaml"
    mission = loads_mission(path.read_text(encoding="utf-8"), str(path), default_registry(),
                            Environment)
    with pytest.raises(MissionError) as caught:
        configurations(mission, [Sweep.parse("perception.threshold=0.1,0.2,0.3"),
                                 Sweep.parse("perception.lambda_s=-1")], str(path))
    (line,) = caught.value.problems
    assert "[sweep perception.lambda_s=-1]: perception.lambda_s:" in line, line
    assert "perception.threshold=" not in line, line


def test_a_setting_one_swept_variant_lacks_points_to_the_whole_behaviour_sweep() -> None:
    """A plug-in author's review crossed a variant sweep with a sweep of a setting only one
    variant has: refused, and the refusal did not say that a whole-behaviour sweep gives it."""
    from cptbt.batch.scenario import Environment
    from cptbt.batch.study import configurations
    from cptbt.loader import MissionError, loads_mission
    from cptbt.registry import default_registry

    path = Path(__file__).resolve().parents[2] / "missions/small_oparea.yaml"
    mission = loads_mission(path.read_text(encoding="utf-8"), str(path), default_registry(),
                            Environment)
    sweeps = [Sweep.parse("reacquire_plume.variant=three_point,cloverleaf"),
              Sweep.parse("reacquire_plume.d_leaf_m=10,20")]
    with pytest.raises(MissionError) as info:
        configurations(mission, sweeps, str(path))
    assert str(info.value).rstrip().endswith(
        "unknown key of reacquire_plume three_point; known keys: speed_mps, arrive_radius_m, "
        "pass_radius_m, wall_inset_m, radius_m, visits, variant; a setting only some variants "
        "have goes in a whole-behaviour sweep, with them: --sweep "
        "'reacquire_plume=three_point,{variant: cloverleaf, d_leaf_m: 10},"
        "{variant: cloverleaf, d_leaf_m: 20}'"), str(info.value)
    assert str(info.value).count("\n") == 0  # told once, not once per swept value


def test_the_own_variant_note_leaves_out_what_every_value_sets() -> None:
    """An attacker's note listed radius_m=15 beside two values that each set radius_m."""
    from cptbt.batch.scenario import Environment
    from cptbt.batch.sweeps import study_notes
    from cptbt.loader import loads_mission
    from cptbt.registry import default_registry

    path = Path(__file__).resolve().parents[2] / "missions/small_oparea.yaml"
    mission = loads_mission(path.read_text(encoding="utf-8"), str(path), default_registry(),
                            Environment)
    (note,) = study_notes(mission, [Sweep.parse("reacquire_plume={radius_m: 10},{radius_m: 12}")])
    assert "(wall_inset_m=10.0, visits=10)" in note, note
    (note,) = study_notes(mission, [Sweep.parse("reacquire_plume=three_point,{radius_m: 12}")])
    assert "(wall_inset_m=10.0, radius_m=15.0, visits=10)" in note, note
