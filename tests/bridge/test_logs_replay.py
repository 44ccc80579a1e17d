"""MCAP cycle logs: written by a simulated run, read by the mcap reader, replayed bit for bit."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from mcap.reader import make_reader
from wire_doubles import MISSIONS

from cptbt.batch.phased import simulate_phased
from cptbt.batch.scenario import to_sim_params
from cptbt.loader import load_mission, loads_mission
from cptbt.logs import CycleLog, LogError, read_log
from cptbt.mission import MissionBase
from cptbt.replay import replay, story


@pytest.fixture(scope="module")
def msn007() -> MissionBase:
    return load_mission(MISSIONS / "tro2006_msn007.yaml")


@pytest.fixture(scope="module")
def logged(msn007: MissionBase, tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("log") / "msn007.mcap"
    log = CycleLog.open(path, msn007, source="test")
    try:
        simulate_phased(msn007, to_sim_params(msn007), planner=log.planner, observers=[log])
    finally:
        log.close()
    return path


def test_the_log_opens_with_the_mcap_reader_with_json_schemas(logged: Path) -> None:
    with logged.open("rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        assert summary is not None
        topics = {c.topic: c for c in summary.channels.values()}
        assert set(topics) == {"/cptbt/mission", "/cptbt/cycle", "/cptbt/phase"}
        for ch in topics.values():
            assert ch.message_encoding == "json"
            assert summary.schemas[ch.schema_id].encoding == "jsonschema"
        first = next(m for _, c, m in reader.iter_messages(topics=["/cptbt/cycle"]))
    cycle = json.loads(first.data)
    assert cycle["phase"] == "amp.override" and cycle["active"] == "move_to_field.go_to"
    assert {e[0] for e in cycle["inputs"]} == {"f", "p"}  # flow from Mission A, then the pose


def test_every_cycle_and_phase_change_is_logged(logged: Path) -> None:
    data = read_log(logged)
    assert data.mission["name"] == "tro2006_msn007"
    # A whole AMP part, take-over to home (seed 7 flies about 610 cycles since issue 11's
    # find-plume; about 900 before).
    assert len(data.cycles) > 500 and [c["seq"] for c in data.cycles] == list(
        range(len(data.cycles)))
    assert [p["trigger"] for p in data.phases][:3] == ["launch", "amp_enable", "declared_home"]
    assert data.cycles[-1]["declared_source"] is not None and data.cycles[-1]["done"]
    assert "mission_done" in data.cycles[-1]["blackboard"]


def test_the_same_mission_replays_bit_for_bit(logged: Path) -> None:
    rep = replay(logged)
    assert rep.identical and rep.commands_differing == 0 and rep.cycles > 500


def test_another_variant_diverges_and_the_report_says_where(logged: Path) -> None:
    text = (MISSIONS / "tro2006_msn007.yaml").read_text(encoding="utf-8")
    old = "reacquire_plume: {variant: cloverleaf, d_leaf_m: 15, repeats: 3}"
    assert old in text
    three_point = loads_mission(text.replace(old, "reacquire_plume: {variant: three_point}"))
    rep = replay(logged, three_point)
    assert rep.divergence is not None
    d = rep.divergence
    data = read_log(logged)
    assert data.cycles[d.seq]["active"].startswith("reacquire_plume")
    assert all(c["active"] is None or not c["active"].startswith("reacquire_plume")
               for c in data.cycles[: d.seq])  # the first reacquire is the first difference
    assert 0 < rep.commands_differing < rep.cycles


def test_a_tampered_input_breaks_the_replay_at_that_cycle(logged: Path) -> None:
    data = read_log(logged)
    k = 150
    pose = next(e for e in data.cycles[k]["inputs"] if e[0] == "p")
    pose[1] += 1e-9
    rep = replay(data)
    assert rep.divergence is not None and rep.divergence.seq >= k


def test_the_story_tells_the_phases_and_the_declaration(logged: Path) -> None:
    text = "\n".join(story(read_log(logged)))
    assert "amp_enable" in text and "first detection" in text and "source declared" in text
    # in the mission's own frame and lat/lon too, not only the planning frame (a review)
    declared = next(line for line in text.splitlines() if "source declared at" in line)
    assert " m, E " in declared and "(32.98" in declared and "(planning frame)" in declared
    # The story is told by family; the leaves behind it (track-in and track-out) get shares.
    shares = story(read_log(logged))[-1]
    assert shares.startswith("cycles in each behaviour:")
    assert "maintain_plume.track_in" in shares and "maintain_plume.track_out" in shares
    # cycles without a command read as `cptbt run` says them (a review: "none 0%")
    assert "none" not in shares and ("no output" in shares) == any(
        c["active"] is None for c in read_log(logged).cycles)
    # ... so its lines name the family, not whichever leaf it happened to start in.
    assert "behaviour maintain_plume\n" in text + "\n" and "behaviour maintain_plume." not in text


def test_a_file_that_is_not_a_log_is_one_error(tmp_path: Path) -> None:
    bad = tmp_path / "bad.mcap"
    bad.write_bytes(b"not an mcap file")
    with pytest.raises(LogError, match=r"bad\.mcap"):
        read_log(bad)
    with pytest.raises(LogError):
        read_log(tmp_path / "missing.mcap")


def test_a_log_whose_writer_was_killed_is_read_up_to_the_damage(
    msn007: MissionBase, logged: Path, tmp_path: Path
) -> None:
    # A log never closed (the writer killed): its flushed chunks are on disk, and they are
    # read; a 1 MiB chunk kept a killed serve's log empty, and a torn file read as nothing.
    path = tmp_path / "killed.mcap"
    log = CycleLog.open(path, msn007, source="test")
    simulate_phased(msn007, to_sim_params(msn007), planner=log.planner, observers=[log])
    log._stream.flush()  # what the process had written when it died: no close(), no summary
    data = read_log(path)
    assert data.truncated and "unfinished" in data.truncated
    full = read_log(logged)
    assert 0 < len(data.cycles) <= len(full.cycles) and data.cycles == full.cycles[
        :len(data.cycles)]
    assert len(data.cycles) > len(full.cycles) - 200  # at most a 64 KiB chunk lost
    # a file cut mid-chunk: what comes before the cut
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(logged.read_bytes()[:60_000])
    part = read_log(cut)
    assert part.truncated and 0 < len(part.cycles) < len(full.cycles)
    assert replay(part).identical  # what is there replays bit for bit


def test_bad_records_in_a_valid_log_are_one_line_errors(
    logged: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from mcap.writer import Writer

    from cptbt.cli import main

    full = read_log(logged)
    path = tmp_path / "bad.mcap"
    with path.open("wb") as f:
        w = Writer(f)
        w.start(profile="cptbt", library="test")
        sid = w.register_schema(name="x", encoding="jsonschema", data=b"{}")
        ids = {t: w.register_channel(topic=t, message_encoding="json", schema_id=sid)
               for t in ("/cptbt/mission", "/cptbt/cycle")}
        for topic, rec in (("/cptbt/mission", full.mission),
                           ("/cptbt/cycle", {k: v for k, v in full.cycles[0].items()
                                             if k != "inputs"})):  # a cycle without inputs
            w.add_message(channel_id=ids[topic], log_time=0, data=json.dumps(rec).encode(),
                          publish_time=0)
        w.finish()
    assert main(["replay", str(path)]) == 2  # was "internal error: KeyError", exit 1
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert line.startswith(f"cptbt: {path}: a record is not what cptbt writes (KeyError"), line


def test_a_replay_with_an_unlike_mission_says_so(
    logged: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # another OpArea, frame and rate: "612 of 612 commands differ" was all it said
    from cptbt.cli import main

    assert main(["replay", str(logged), "--mission",
                 str(MISSIONS / "ab2001_infotaxis.yaml")]) == 0
    (note,) = [ln for ln in capsys.readouterr().err.splitlines() if "note:" in ln]
    assert note.startswith("cptbt: note: OpArea, frame, cycle rate differ from the logged "
                           "mission's"), note
    # another variant of the same mission: no note
    variant = tmp_path / "v.yaml"
    variant.write_text((MISSIONS / "tro2006_msn007.yaml").read_text(encoding="utf-8").replace(
        "{variant: cloverleaf, d_leaf_m: 15, repeats: 3}", "{variant: three_point}"),
        encoding="utf-8")
    assert main(["replay", str(logged), "--mission", str(variant)]) == 0
    assert "note:" not in capsys.readouterr().err
