"""The JSON Schema editors read agrees with ``cptbt validate`` on good and bad missions.

The schema is draft-07 (what yaml-language-server reads); the missions are the shipped ones, the
corpus base in N-E and geodetic form, and field-level mistakes a schema can express. Cross-field
rules (rectangle, places inside the OpArea, limits, contracts) are validate's alone: the schema
says so in its description, and they are not in this agreement set.
"""

from __future__ import annotations

from pathlib import Path

import jsonschema
import pytest
import yaml

from cptbt.cli import main
from cptbt.cli.inspect_cmds import environment_model
from cptbt.registry import default_registry
from cptbt.schema import DRAFT_07, mission_json_schema

ROOT = Path(__file__).resolve().parents[2]
BASE = (Path(__file__).parent / "data" / "corpus_base.yaml").read_text(encoding="utf-8")
SCHEMA = mission_json_schema(default_registry(), environment_model())
VALIDATOR = jsonschema.Draft7Validator(SCHEMA)

GOOD = {p.name: p.read_text(encoding="utf-8") for p in sorted((ROOT / "missions").glob("*.yaml"))}
GOOD["corpus_base"] = BASE

BAD = {
    "unknown top key": BASE.replace("speed_mps: 1.5", "speed_mps: 1.5\ncolour: red"),
    "unknown param": BASE.replace("beta_deg: 10}", "beta_dge: 10}"),
    "unknown perception key": BASE.replace("  threshold: 0.2", "  treshold: 0.2"),
    "unknown environment key": BASE.replace("  seed: 3", "  sead: 3"),
    "unknown flow override": BASE.replace("  seed: 3", "  seed: 3\n  flow: {noise: 1}"),
    "bad frame": BASE.replace("frame: ne", "frame: utm"),
    "speed not a number": BASE.replace("speed_mps: 1.5", "speed_mps: fast"),
    "negative speed": BASE.replace("speed_mps: 1.5", "speed_mps: -1"),
    "cycle rate too high": BASE.replace("cycle_hz: 1", "cycle_hz: 500"),
    "three corners": BASE.replace(", [-100, -50]]", "]"),
    "three-number home": BASE.replace("home: [-90, 0]", "home: [-90, 0, 1]"),
    "unknown variant": BASE.replace("{variant: cloverleaf}", "{variant: clover}"),
    "unknown behaviour": BASE.replace("- safety: {variant: oparea}", "- safty: {}"),
    "path in name": BASE.replace("name: corpus_base", "name: ../../tmp/x"),
    "zero success radius": BASE.replace("time_limit_s: 1800",
                                        "time_limit_s: 1800\nevaluation: {success_radius_m: 0}"),
    "bad criterion": BASE.replace("time_limit_s: 1800",
                                  "time_limit_s: 1800\nevaluation: {criterion: vibes}"),
    "negative seed": BASE.replace("seed: 3", "seed: -1"),
    "missing home": BASE.replace("home: [-90, 0]\n", ""),
}


def test_schema_is_draft_07_without_2020_keywords() -> None:
    text = str(SCHEMA)
    assert SCHEMA["$schema"] == DRAFT_07
    assert "prefixItems" not in text and "discriminator" not in text and "$defs" not in text
    jsonschema.Draft7Validator.check_schema(SCHEMA)


def test_every_section_is_described_and_the_simulator_section_is_typed() -> None:
    assert all("description" in v for v in SCHEMA["properties"].values())
    env = SCHEMA["definitions"]["Environment"]["properties"]
    assert {"mean_speed_mps", "preset"} <= set(env["flow"]["properties"])
    assert env["flow"]["additionalProperties"] is False


@pytest.mark.parametrize("name", list(GOOD))
def test_schema_and_validate_accept_good_missions(tmp_path: Path, name: str, capsys) -> None:  # type: ignore[no-untyped-def]
    errors = [e.message for e in VALIDATOR.iter_errors(yaml.safe_load(GOOD[name]))]
    assert not errors, errors
    path = tmp_path / "m.yaml"
    path.write_text(GOOD[name], encoding="utf-8")
    assert main(["validate", str(path)]) == 0, capsys.readouterr().err


@pytest.mark.parametrize("name", list(BAD))
def test_schema_and_validate_reject_bad_missions(tmp_path: Path, name: str, capsys) -> None:  # type: ignore[no-untyped-def]
    text = BAD[name]
    assert text != BASE, "the edit did not apply"
    assert list(VALIDATOR.iter_errors(yaml.safe_load(text))), f"schema accepts {name}"
    path = tmp_path / "m.yaml"
    path.write_text(text, encoding="utf-8")
    assert main(["validate", str(path)]) == 2
    capsys.readouterr()
