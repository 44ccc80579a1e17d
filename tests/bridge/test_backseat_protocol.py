"""The backseat protocol: every message round-trips, matches the JSON Schema, and nothing that
arrives from the wire can raise."""

from __future__ import annotations

import json
import math
from importlib import resources

import jsonschema
import pytest

from cptbt.bridge import LinkURIError, parse_uri
from cptbt.bridge.backseat import MAX_DATAGRAM, Decoder, Heartbeat, encode, pack, parse_line
from cptbt.link import (
    CommandRefused,
    ConcentrationSample,
    FlowSample,
    HeadingSpeedCommand,
    OverrideEnded,
    OverrideRelease,
    OverrideRequest,
    VehicleState,
)

MESSAGES = [
    VehicleState(12.5, 1.0, -2.0, 45.0, 1.5, 3.0, "override", 2),
    VehicleState(0.1, 0.0, 0.0, -170.0, 0.0, None, "pre_launch", 0),
    ConcentrationSample(12.6, 0.31),
    FlowSample(14.0, 0.07, -0.05),
    CommandRefused(15.0, HeadingSpeedCommand(10.0, 3.5, 2.0), "speed 3.5 m/s outside"),
    OverrideEnded(16.0, "watchdog", (3.0, 4.0)),
    HeadingSpeedCommand(-120.0, 1.5, None),
    HeadingSpeedCommand(30.0, 1.5, 3.0),
    OverrideRequest(),
    OverrideRelease(),
    Heartbeat(),
    Heartbeat(20.0, "mission"),
]


@pytest.fixture(scope="module")
def validator() -> jsonschema.Draft7Validator:
    text = resources.files("cptbt.bridge").joinpath("schemas/backseat-v1.schema.json")
    schema = json.loads(text.read_text(encoding="utf-8"))
    jsonschema.Draft7Validator.check_schema(schema)
    return jsonschema.Draft7Validator(schema)


@pytest.mark.parametrize("msg", MESSAGES, ids=lambda m: type(m).__name__)
def test_every_message_round_trips_and_matches_the_schema(msg: object, validator) -> None:
    line = encode(msg, 7)  # type: ignore[arg-type]
    assert line.endswith(b"\n") and line.count(b"\n") == 1
    validator.validate(json.loads(line))
    seq, back = parse_line(line)
    assert seq == 7 and back == msg


def test_a_sensor_dropout_is_a_null_reading_not_a_malformed_line(validator) -> None:
    """A field review: a NaN fluorometer value over the link was ignored as a malformed line
    and counted nowhere the summary shows. A dropout is a null reading, decoded as NaN, which
    the planner drops and counts (missing_samples, rejected_flow_samples)."""
    from cptbt.perception import Perception, PerceptionSettings
    from cptbt.testing import square_area

    for msg in (ConcentrationSample(3.0, math.nan), FlowSample(3.0, math.nan, math.nan)):
        line = encode(msg, 4)
        validator.validate(json.loads(line))
        _, back = parse_line(line)
        assert type(back) is type(msg) and back.t_s == 3.0
    assert b'"value":null' in encode(ConcentrationSample(3.0, math.nan), 4)
    decoder = Decoder()
    (sample,) = decoder.feed(b'{"v":1,"seq":1,"type":"sample","t_s":1,"value":null}\n')
    (flow,) = decoder.feed(b'{"v":1,"seq":2,"type":"flow","t_s":1,"vx_mps":null,"vy_mps":0}\n')
    assert decoder.ignored == 0
    p = Perception(square_area(), PerceptionSettings(threshold=0.2))
    p.add_sample(sample.t_s, sample.value)
    p.add_flow(flow.t_s, flow.vx_mps, flow.vy_mps)
    assert p.faults()["missing_samples"] == 1
    p.cycle(1.5)
    assert p.faults()["rejected_flow_samples"] == 1


@pytest.mark.parametrize("line", [
    b'{"v":true,"seq":1,"type":"take"}',                          # true is no version (an attacker)
    b'{"v":1,"seq":1,"type":"sample","t_s":1}',                   # no value at all, not null
    b'{"v":1,"seq":1,"type":"nav","t_s":1}',                      # fields missing
    b'{"v":1,"seq":1,"type":"command","heading_deg":"north","speed_mps":1}',
    b'{"v":1,"seq":-1,"type":"take"}',
    b'{"v":1,"type":"take"}',
    b'{"v":1,"seq":1,"type":"teleport"}',
    b'{"v":1,"seq":1,"type":"nav","t_s":1,"x_m":0,"y_m":0,"heading_deg":0,"speed_mps":1,'
    b'"mode":"flying","waypoints_reached":0}',
])
def test_the_schema_and_the_parser_reject_the_same_lines(line: bytes, validator) -> None:
    assert not validator.is_valid(json.loads(line))
    decoder = Decoder()
    assert decoder.feed(line) == [] and decoder.ignored == 1


@pytest.mark.parametrize("junk, kind", [
    (b"{not json", "malformed"),
    (b"\xff\xfe\x00", "malformed"),
    (b"[1, 2]", "malformed"),
    (b'{"v":1,"seq":1,"type":"sample","t_s":NaN,"value":1}', "malformed"),
    (b'{"v":1,"seq":1,"type":"sample","t_s":1,"value":Infinity}', "malformed"),
    # Literals beyond the float range (a review: 1e400 read as inf and was decoded):
    (b'{"v":1,"seq":1,"type":"sample","t_s":1e400,"value":1}', "malformed"),
    (b'{"v":1,"seq":1,"type":"nav","t_s":1,"x_m":-1e400,"y_m":0,"heading_deg":0,'
     b'"speed_mps":1,"depth_m":0,"mode":"mission","waypoints_reached":0}', "malformed"),
    (b'{"v":1,"seq":1,"type":"flow","t_s":1,"vx_mps":1' + b"0" * 400 + b',"vy_mps":0}',
     "malformed"),
    (b'{"v":1,"seq":1,"type":"command","heading_deg":1e400,"speed_mps":1.5}', "malformed"),
    (b"[" * 100000, "oversized"),
    (b'{"v":2,"seq":1,"type":"take"}', "version"),
    (b'{"v":1,"seq":1,"type":"hello"}', "unknown_type"),
    (b'{"v":1,"seq":1,"type":"flow","t_s":1,"vx_mps":true,"vy_mps":0}', "invalid"),
    (b'{"v":1,"seq":1,"type":"ended","t_s":1,"reason":"released","break_off_m":[1]}', "invalid"),
])
def test_junk_is_ignored_and_counted_never_raised(junk: bytes, kind: str) -> None:
    decoder = Decoder()
    good = encode(ConcentrationSample(1.0, 0.5), 1)
    msgs = decoder.feed(junk if kind == "oversized" else junk + b"\n" + good)
    assert decoder.counts[kind] == 1
    assert msgs == ([] if kind == "oversized" else [ConcentrationSample(1.0, 0.5)])


def test_datagrams_at_the_size_limit_are_read_and_one_byte_over_is_not() -> None:
    line = encode(ConcentrationSample(1.0, 0.5), 1)
    pad = b" " * (MAX_DATAGRAM - len(line))
    assert len(Decoder().feed(pad + line)) == 1
    d = Decoder()
    assert d.feed(b" " + pad + line) == [] and d.counts["oversized"] == 1


def test_a_late_nav_is_dropped_and_a_restarted_sender_is_heard() -> None:
    d = Decoder()
    nav = VehicleState(10.0, 0, 0, 0, 1)
    assert d.feed(encode(nav, 50)) == [nav]
    assert d.feed(encode(VehicleState(9.0, 0, 0, 0, 1), 49)) == []  # delayed datagram
    assert d.counts["late"] == 1
    assert d.feed(encode(ConcentrationSample(9.0, 1.0), 48)) != []  # late samples are fine
    restarted = VehicleState(0.1, 0, 0, 0, 1)
    d.feed(encode(nav, 5000))
    assert d.feed(encode(restarted, 1)) == [restarted]


def test_a_sender_restarting_its_count_near_the_last_one_is_heard_after_a_few() -> None:
    # a seq restart less than SEQ_RESTART_GAP below the last: every nav was dropped as late
    # (the AMP's clock froze, it never took over); a rising run of them is a restart
    d = Decoder()
    d.feed(encode(VehicleState(100.0, 0, 0, 0, 1), 500))
    heard = [d.feed(encode(VehicleState(float(k), 0, 0, 0, 1), k)) for k in range(1, 8)]
    assert [len(h) for h in heard] == [0, 0, 0, 0, 1, 1, 1]  # from the 5th of the run on
    assert d.counts["late"] == 4 and d.counts["restarts"] == 1 and d.ignored == 4
    # delayed datagrams scattered among fresh ones make no run
    d = Decoder()
    for k in range(100, 140):
        d.feed(encode(VehicleState(float(k), 0, 0, 0, 1), k))
        d.feed(encode(VehicleState(0.0, 0, 0, 0, 1), k - 3))  # late: each after a fresh one
    assert d.counts["restarts"] == 0 and d.counts["late"] == 40


def test_pack_keeps_lines_whole_and_under_the_limit() -> None:
    lines = [encode(ConcentrationSample(float(i), 0.5), i) for i in range(500)]
    datagrams = pack(lines)
    assert len(datagrams) > 1 and all(len(d) <= MAX_DATAGRAM for d in datagrams)
    assert b"".join(datagrams) == b"".join(lines)


def test_non_finite_required_fields_cannot_be_sent() -> None:
    with pytest.raises(ValueError):
        encode(ConcentrationSample(float("nan"), 1.0), 1)
    assert b'"depth_m":null' in encode(HeadingSpeedCommand(1.0, 1.0, float("nan")), 1)


@pytest.mark.parametrize("uri", ["backseat:udp:127.0.0.1", "serial:udp:h:1", "backseat:tcp:h:1",
                                 "backseat:udp:h:port", "backseat:udp:h:70000",
                                 "backseat:udp::1"])
def test_bad_uris_say_why(uri: str) -> None:
    with pytest.raises(LinkURIError, match="link"):
        parse_uri(uri)


def test_a_good_uri() -> None:
    u = parse_uri("mavlink:udpin:0.0.0.0:14550")
    assert (u.protocol, u.transport, u.host, u.port) == ("mavlink", "udpin", "0.0.0.0", 14550)


def test_a_backlog_of_delayed_navs_flushed_in_order_is_no_restart() -> None:
    """A review held 10 s of datagrams and released them in order: the fifth late nav had been
    taken for a restarted sender, and the AMP steered by a 10-s-old fix 16 m away."""
    d = Decoder()
    for k in range(100, 200):  # 10 Hz navs up to seq 199, t 19.9 s
        d.feed(encode(VehicleState(k / 10, 0, 0, 0, 1), k))
    backlog = [d.feed(encode(VehicleState(k / 10, 0, 0, 0, 1), k)) for k in range(150, 170)]
    assert not any(backlog) and d.counts["restarts"] == 0 and d.counts["late"] == 20
    assert d.feed(encode(VehicleState(20.0, 0, 0, 0, 1), 200)) != []  # the newer ones go on
    # a sender that restarted its count, its clock running on, is still heard after a few
    heard = [d.feed(encode(VehicleState(20.0 + k / 10, 0, 0, 0, 1), 150 + k)) for k in range(7)]
    assert [len(h) for h in heard] == [0, 0, 0, 0, 1, 1, 1] and d.counts["restarts"] == 1


def test_an_ignored_line_says_why_in_the_log(caplog: pytest.LogCaptureFixture) -> None:
    """A review's navs lacked a field: 1 971 were ignored and nothing named it, even with -v."""
    d = Decoder()
    line = encode(VehicleState(1.0, 0, 0, 0, 1), 1).replace(b',"waypoints_reached":0', b"")
    assert b"waypoints_reached" not in line
    with caplog.at_level("WARNING"):
        for _ in range(12):
            d.feed(line)
    said = [r.getMessage() for r in caplog.records]
    assert len(said) == 2 and "invalid, 10 so far" in said[1], said
    assert "waypoints_reached" in said[0]


def test_a_backlog_early_in_a_mission_is_no_restart_either() -> None:
    """A diff review: navs 60..79 flushed after 80 (10 Hz) counted from a small number and
    were taken for a restart, 16 old fixes accepted as fresh."""
    d = Decoder()
    for k in range(1, 81):
        d.feed(encode(VehicleState(k / 10, 0, 0, 0, 1), k))
    backlog = [d.feed(encode(VehicleState(k / 10, 0, 0, 0, 1), k)) for k in range(60, 80)]
    assert not any(backlog) and d.counts["restarts"] == 0


def test_a_hostile_break_off_point_is_an_ignored_line_not_a_crash() -> None:
    """An attacker's ``ended`` line with a 400-digit break-off coordinate raised OverflowError
    out of the decoder and ended a served mission as an internal error; 1e400 read as inf."""
    decoder = Decoder()
    big = "1" + "0" * 400
    for value in (big, "1e400", '"north"', "true"):
        line = ('{"v":1,"seq":1,"type":"ended","t_s":1,"reason":"released","break_off_m":['
                + value + ',0]}\n').encode()
        assert decoder.feed(line) == []
    assert decoder.ignored == 4
