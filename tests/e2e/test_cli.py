"""The command line as a new user meets it: the shipped missions, bad input, and the README."""

from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
MISSIONS = sorted((ROOT / "missions").glob("*.yaml"))


SCRIPT = Path(sys.executable).parent / "cptbt"


def cptbt(*args: str, cwd: Path = ROOT) -> subprocess.CompletedProcess[str]:
    """Run the installed console script, as a user would (not ``python -m``, which would put the
    source folder, without its package-dir mapping, first on ``sys.path``)."""
    return subprocess.run([str(SCRIPT), *args], cwd=cwd, text=True, capture_output=True,
                          timeout=300)


def test_every_command_has_help() -> None:
    for cmd in ("validate", "tree", "behaviours", "schema", "run", "phases", "batch", "plot"):
        res = cptbt(cmd, "--help")
        assert res.returncode == 0 and "usage: cptbt" in res.stdout, (cmd, res.stderr)


@pytest.mark.parametrize("mission", MISSIONS, ids=[m.name for m in MISSIONS])
def test_shipped_missions_validate(mission: Path) -> None:
    res = cptbt("validate", str(mission))
    assert res.returncode == 0, res.stderr
    assert ": ok (" in res.stdout
    assert "warning" not in res.stderr, res.stderr  # no advisories for a shipped mission


def test_plume_behaviours_listed_below_find_plume_are_warned_of(tmp_path: Path) -> None:
    """A review listed find_plume above maintain_plume and reacquire_plume: it validated
    silently and searched for 600 s, its plume never tracked (find-plume drives every cycle)."""
    text = (ROOT / "missions/omae2003.yaml").read_text(encoding="utf-8")
    find = "  - find_plume: {variant: billiard, dtheta_up_deg: 125, dtheta_down_deg: 60}\n"
    assert find in text
    text = text.replace(find, "").replace("  - maintain_plume:", find + "  - maintain_plume:")
    bad = tmp_path / "order.yaml"
    bad.write_text(text, encoding="utf-8")
    res = cptbt("validate", str(bad))
    assert res.returncode == 0, res.stderr
    lines = [ln for ln in res.stderr.strip().splitlines() if ": note: " not in ln]
    assert [ln.split(": ")[1] for ln in lines] == ["behaviours[3].maintain_plume",
                                                  "behaviours[4].reacquire_plume"], lines
    assert all("listed below find_plume (behaviours[2])" in ln and "never drives" in ln
               for ln in lines)


def said(stderr: str) -> str:
    """What a command warned of, less the narrow-OpArea warning a 30-m box earns."""
    return "\n".join(ln for ln in stderr.splitlines()
                     if "even with turn_guard_radius_m" not in ln)


def test_settings_unlikely_meant_for_a_small_oparea_are_warned_of(tmp_path: Path) -> None:
    # A 30 x 30 m box with the 15 m success radius (default) and the likelihood map's 10 m
    # declaration disc: valid (exit 0), each warned of at its line.
    text = (ROOT / "missions/small_oparea.yaml").read_text(encoding="utf-8")
    for a, b in (("start: [-15, -15]", "start: [-10, -10]"), ("25", "15"),
                 ("[-20, 0]", "[-12, 0]"), ("source: [12, 10]", "source: [6, 5]")):
        text = text.replace(a, b)
    start = text.index("- declare_source:")
    text = text[:start] + "- declare_source: {variant: likelihood_map}" \
        + text[text.index("\n", start):]
    small = tmp_path / "small.yaml"
    small.write_text(text, encoding="utf-8")
    res = cptbt("validate", str(small))
    assert res.returncode == 0 and ": ok (" in res.stdout, res.stderr
    # a 30-m box is under 5 turning radii: warned even with the turn guard (its own test),
    # and left out of what this test reads
    assert res.stderr.count("even with turn_guard_radius_m") == 1, res.stderr
    lines = said(res.stderr).strip().splitlines()
    assert len(lines) == 3, lines
    line = text[:text.index("- declare_source:")].count("\n") + 1
    top = next(i for i, ln in enumerate(text.splitlines(), 1) if ln.startswith("name:"))
    # no evaluation key: the default is warned of at the mission's first key, and said so
    assert lines[0].startswith(f"{small}:{top}: evaluation.success_radius_m: warning: 15 m "
                               "(the default): a disc this size covers 79% of the OpArea, so a "
                               "declaration drawn at random"), lines[0]
    assert lines[1].startswith(f"{small}:{line}: behaviours[1].declare_source.radius_m: "
                               "warning: 10 m: the declaration disc covers 35%"), lines[1]
    # and the three-point tour's 15 m, which no orientation fits in the 10 m left inside the
    # walls' 10-m inset
    three = text[:text.index("- reacquire_plume:")].count("\n") + 1
    assert lines[2].startswith(f"{small}:{three}: behaviours[3].reacquire_plume.radius_m: "
                               "warning: 15 m: the tour's points, 120° apart at that "
                               "distance from its centre, fit in no orientation inside the "
                               "OpArea less wall_inset_m each side (10 × 10 m)"), lines[2]
    # a thin area: what fits inside counts (120 x 12 m: a 15 m disc covers 24%, not 49%)
    thin = text.replace("[15, -15]", "[60, -6]").replace("[15, 15]", "[60, 6]") \
        .replace("[-15, 15]", "[-60, 6]").replace("[-15, -15]", "[-60, -6]") \
        .replace("start: [-10, -10]", "start: [-50, -3]").replace("source: [6, 5]",
                                                                   "source: [40, 2]")
    small.write_text(thin, encoding="utf-8")
    res = cptbt("validate", str(small))
    assert res.returncode == 0 and "success_radius_m" not in res.stderr, res.stderr
    text += "evaluation: {criterion: declaration, success_radius_m: 5}\n"
    text = text.replace("radius_m: 15, visits", "radius_m: 5, visits")  # fits in 10 m
    small.write_text(text.replace("likelihood_map}", "likelihood_map, radius_m: 5}"),
                     encoding="utf-8")
    assert said(cptbt("validate", str(small)).stderr) == ""
    quiet = cptbt("run", str(small), "--quiet", "--no-figure", "--out", str(tmp_path / "o"))
    assert quiet.returncode == 0 and said(quiet.stderr) == "" and quiet.stdout == ""
    # a batch's swept values are checked too: each warning names its sweep
    res = cptbt("batch", str(small), "--runs-per-start", "1", "--workers", "1", "--out",
                str(tmp_path / "b"), "--sweep", "evaluation.success_radius_m=5,15")
    assert res.returncode == 0, res.stderr
    (warned,) = [ln for ln in said(res.stderr).splitlines() if "warning" in ln]
    assert warned.startswith(f"{small} [sweep evaluation.success_radius_m=15]: "
                             "evaluation.success_radius_m: warning: 15 m: a disc"), warned
    # the file's own warning is shown at its line while some sweep flies it, not when every
    # sweep overrides it
    text = text.replace("likelihood_map}", "likelihood_map, radius_m: 5}")
    small.write_text(text.replace("success_radius_m: 5", "success_radius_m: 15"),
                     encoding="utf-8")
    res = cptbt("batch", str(small), "--runs-per-start", "1", "--workers", "1", "--out",
                str(tmp_path / "c"), "--sweep", "evaluation.success_radius_m=4,5")
    assert res.returncode == 0 and "warning" not in said(res.stderr), res.stderr
    res = cptbt("batch", str(small), "--runs-per-start", "1", "--workers", "1", "--out",
                str(tmp_path / "d"), "--sweep", "declare_source.radius_m=4,5")
    assert res.returncode == 0, res.stderr
    (warned,) = [ln for ln in said(res.stderr).splitlines() if "warning" in ln]
    line = text.count("\n")  # the evaluation line, appended last
    assert warned.startswith(f"{small}:{line}: evaluation.success_radius_m: warning: 15 m: "), \
        warned


def test_tree_prints_the_subsumption_order_and_writes_dot(tmp_path: Path) -> None:
    dot = tmp_path / "amp.dot"
    res = cptbt("tree", "missions/tro2006_msn007.yaml", "--dot", str(dot))
    assert res.returncode == 0, res.stderr
    body = res.stdout.split("subsumption", 1)[1]  # after the watchers
    order = [n for n in ("safety.oparea", "declare_source.upflow_cluster", "track_in",
                         "track_out", "reacquire_plume.cloverleaf", "find_plume.billiard",
                         "move_to_field.go_to") if n in body]
    assert len(order) == 7
    positions = [body.index(n) for n in order]
    assert positions == sorted(positions)
    assert dot.read_text().startswith("digraph amp {")
    # the symbols are explained under the tree (a review read them without a key)
    assert "key (py_trees): [-] sequence" in res.stdout and "[o] selector" in res.stdout


def test_behaviours_lists_parameters_with_defaults() -> None:
    res = cptbt("behaviours")
    assert res.returncode == 0, res.stderr
    assert re.search(r"beta_deg = 10", res.stdout)
    assert "cloverleaf (default)" in res.stdout
    # plain text for a terminal: no docstring markup, lines wrapped (a review)
    assert "``" not in res.stdout and "(psi_u)" in res.stdout
    assert max(len(line) for line in res.stdout.splitlines()) <= 100
    # a pairing validate enforces is said where the variant is listed (a review learnt it late)
    assert "  map_guided: " in res.stdout
    after = res.stdout.split("  map_guided: ", 1)[1].splitlines()
    assert "      (with declare_source likelihood_map only)" in after[:3], after[:3]
    listing = json.loads(cptbt("behaviours", "--json").stdout)
    assert {"family", "variant", "params", "pairs_with", "package"} <= listing[0].keys()
    assert {e["package"] for e in listing} == {"cptbt"}


def test_schema_is_json_schema_naming_every_family() -> None:
    res = cptbt("schema")
    schema = json.loads(res.stdout)
    text = json.dumps(schema)
    for family in ("find_plume", "maintain_plume", "reacquire_plume", "declare_source"):
        assert family in text
    assert schema["title"] == "cptbt mission"


def test_bad_mission_is_one_line_per_problem_exit_2_no_traceback(tmp_path: Path) -> None:
    text = (ROOT / "missions/tro2006_msn007.yaml").read_text()
    bad = tmp_path / "bad.yaml"
    bad.write_text(text.replace("beta_deg: 10}", "beta_deg: -1}").replace(
        "flow_speed_mps: 0.1", "flow_speed_mps: 0.1\n  flow: {noise_std_mps: -3}"))
    for cmd in (("validate", str(bad)), ("tree", str(bad)), ("run", str(bad))):
        res = cptbt(*cmd)
        assert res.returncode == 2, (cmd, res.stderr)
        assert "Traceback" not in res.stderr
        lines = res.stderr.strip().splitlines()
        assert lines and all(line.startswith(f"{bad}:") for line in lines), lines
    res = cptbt("validate", str(bad))
    assert any("maintain_plume.beta_deg" in line for line in res.stderr.splitlines())


def test_environment_override_error_names_its_line(tmp_path: Path) -> None:
    text = (ROOT / "missions/tro2006_msn007.yaml").read_text()
    bad = tmp_path / "env.yaml"
    bad.write_text(text.replace("  seed: 7", "  seed: 7\n  plume: {max_puffs: 0}"))
    res = cptbt("validate", str(bad))
    assert res.returncode == 2
    line = text.count("\n", 0, text.index("  seed: 7")) + 2
    assert f"{bad}:{line}: environment.plume.max_puffs:" in res.stderr, res.stderr


def test_missing_mission_file_is_exit_2() -> None:
    res = cptbt("validate", "no/such/file.yaml")
    assert res.returncode == 2
    assert "no/such/file.yaml: (file): cannot be read: No such file" in res.stderr


def test_readme_snippets_run() -> None:
    """Every Python block of the README runs as printed (the plug-in example's too: a review
    could not write a variant from the README alone)."""
    readme = (ROOT / "README.md").read_text()
    blocks = [part.split("```", 1)[0] for part in readme.split("```python\n")[1:]]
    assert len(blocks) >= 2
    for code in blocks:
        exec(compile(code, "README.md", "exec"), {"__name__": "readme"})


def test_readme_has_the_two_setup_commands_and_ci_runs_the_test_one() -> None:
    readme = (ROOT / "README.md").read_text()
    commands = re.findall(r"```bash\n(python3 -m venv[^\n]*)\n```", readme)
    assert len(commands) == 2
    assert "cptbt run missions/" in commands[0]
    test_cmd = commands[1].split("&& ", 2)[-1]
    assert test_cmd in (ROOT / ".ci/run").read_text()


def test_verbosity_flags_control_the_log() -> None:
    mission = "missions/tro2006_msn007.yaml"
    assert "INFO: cptbt.mission" in cptbt("-v", "validate", mission).stderr
    # validate's own output, not a log: its note of TRO's corners (2.1 m off a rectangle)
    note = ("missions/tro2006_msn007.yaml:12: op_area.corners: note: the corners lie up to "
            "2.1 m off a rectangle")
    for flags in ((), ("-q",)):
        (line,) = cptbt(*flags, "validate", mission).stderr.splitlines()
        assert line.startswith(note), line
    assert cptbt("validate", "missions/oblique_flow.yaml").stderr == ""


def test_the_readmes_whole_mission_validates_without_warnings_and_flies(tmp_path: Path) -> None:
    """README's "Write a mission" shows every block of a mission in one file (a review found
    only some there): it must stay a mission that validates cleanly and declares."""
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    start = readme.index("```yaml\nname: my_survey") + len("```yaml\n")
    path = tmp_path / "my_survey.yaml"
    path.write_text(readme[start:readme.index("```", start)], encoding="utf-8")
    checked = cptbt("validate", str(path))
    assert checked.returncode == 0 and checked.stderr == "", checked.stderr
    run = cptbt("run", str(path), "--out", str(tmp_path / "out"), "--no-figure")
    assert run.returncode == 0, run.stderr
    summary = json.loads((tmp_path / "out" / "summary.json").read_text(encoding="utf-8"))
    assert summary["success"], summary["outcome"]
