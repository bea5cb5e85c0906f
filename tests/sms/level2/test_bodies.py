"""Typed bodies and coordinates (§8, §11 of docs/level2.md; the captured frames)."""

from __future__ import annotations

from datetime import UTC, datetime

import pytest

from sms.level2.bodies import (
    AckNakQueued,
    CommandPacket,
    DeviceInfo,
    Enumerate,
    EnumerationReply,
    InnerResponse,
    QueuedReply,
    RawBody,
    StatusBlock,
    StatusReply,
    StatusRequest,
    degrees_to_l2,
    format_l2,
    l2_to_degrees,
    parse_body,
    response_meaning,
    summarize,
)
from sms.level2.codec import Frame
from sms.level2.errors import BodyError, LocalProtocolError

from .test_codec import ACK_NAK_8041, APPENDIX_A, TELEMETRY_91, h


def frame(name: str) -> Frame:
    return Frame.from_bytes(h(APPENDIX_A[name]))


def test_enumeration_reply_of_the_real_pib() -> None:
    body = parse_body(frame("enum_reply"))
    assert isinstance(body, EnumerationReply)
    [device] = body.devices
    assert (device.task, device.board, device.device_type) == (0x00, 0x01, 0x0001)
    assert device.serial == b"123456" and device.poll_period_s == 20 and device.flags == 0
    assert (device.fw_major, device.fw_minor, device.fw_revision) == (2, 1, 0x0180)
    assert device.description == b"Full PIB            "  # padded with spaces (§8.2)
    assert len(bytes(device)) == 42
    assert bytes(body) == frame("enum_reply").body


def test_default_device_block_is_the_real_pibs() -> None:
    assert bytes(EnumerationReply((DeviceInfo(),))) == frame("enum_reply").body


def test_acfr_50_byte_device_blocks_are_tolerated_and_kept() -> None:
    acfr = bytes(DeviceInfo()) + bytes(8)
    body = h("10 00 01 00 01 00") + acfr
    reply = EnumerationReply.from_bytes(body)
    assert reply.devices[0].extra == bytes(8)
    assert bytes(reply) == body


@pytest.mark.parametrize("size", [41, 43, 60])
def test_other_device_block_sizes_are_the_peers_error(size: int) -> None:
    with pytest.raises(BodyError):
        EnumerationReply.from_bytes(h("10 00 01 00 01 00") + bytes(size))


def test_status_request_without_fix() -> None:
    request = parse_body(frame("status_request"))
    assert isinstance(request, StatusRequest)
    assert not request.valid and request.utc is None
    assert bytes(request) == frame("status_request").body


def test_status_request_with_fix_decodes_the_real_coordinates() -> None:
    # §8.3: 2B 14 16 11 04 0E = 2014-04-17 22:20:43; 85 F0 50 01 = 36°48.1669'N;
    # 1A FF A4 FB = 121°47.2870'W.
    body = h("2B 14 16 11 04 0E 85 F0 50 01 1A FF A4 FB 59")
    request = StatusRequest.from_bytes(body)
    assert request.utc == datetime(2014, 4, 17, 22, 20, 43, tzinfo=UTC)
    assert request.lat == 22_081_669 and request.lon == -73_072_870 and request.valid
    assert format_l2(request.lat, "N", "S") == "36°48.1669'N"
    assert format_l2(request.lon, "E", "W") == "121°47.2870'W"
    rebuilt = StatusRequest.with_fix(
        request.utc, l2_to_degrees(request.lat), l2_to_degrees(request.lon)
    )
    assert bytes(rebuilt) == body


@pytest.mark.parametrize(
    ("degrees", "value"),
    [(36 + 48.1669 / 60, 22_081_669), (-(121 + 47.2870 / 60), -73_072_870), (0.0, 0)],
)
def test_coordinates_round_trip(degrees: float, value: int) -> None:
    assert degrees_to_l2(degrees) == value
    assert degrees_to_l2(l2_to_degrees(value)) == value


def test_coordinates_out_of_range_are_refused() -> None:
    with pytest.raises(LocalProtocolError):
        degrees_to_l2(91, limit=90)


def test_status_replies_of_the_real_pib() -> None:
    flagged = parse_body(frame("status_flagged"))
    plain = parse_body(frame("status_plain"))
    assert isinstance(flagged, StatusReply) and isinstance(plain, StatusReply)
    assert flagged.block.queued and flagged.block.version == 0x8001
    assert not plain.block.queued
    assert plain.block == StatusBlock(0x0001, 0, 1, 0, 0, 0, 21, 35, 21, 100)
    assert bytes(flagged) == frame("status_flagged").body


def test_request_queued_has_an_empty_raw_body() -> None:
    assert parse_body(frame("request_queued")) == RawBody(b"")


def test_real_ack_nak_queued_with_a_read_waypoint_response() -> None:
    result = parse_body(Frame.from_bytes(h(ACK_NAK_8041)))
    assert isinstance(result, AckNakQueued)
    assert result.ok and result.format == 1
    inner = result.response
    assert inner is not None and inner.kind == 0x10 and inner.ident == 0
    assert len(inner.data) == 35  # §11.2: size = the bytes that follow, no inner CRC
    lat, lon = inner.waypoint()
    assert format_l2(lat, "N", "S") == "36°48.1780'N"  # Moss Landing (§11.2)
    assert format_l2(lon, "E", "W") == "121°47.2796'W"


def test_real_telemetry_is_a_queued_reply_for_the_iridium_task() -> None:
    reply = parse_body(Frame.from_bytes(h(TELEMETRY_91)))
    assert isinstance(reply, QueuedReply) and not reply.more
    assert reply.data[0] == 0x91


@pytest.mark.parametrize(("code", "meaning"), [(0, "accepted"), (2, "invalid data"), (9, "9")])
def test_response_meanings(code: int, meaning: str) -> None:
    assert meaning in response_meaning(code)


def test_command_packet_parses_both_size_conventions() -> None:
    for includes in (False, True):
        packet = CommandPacket(8, h("00 00 00 E6 00"), size_includes_crc=includes)
        assert CommandPacket.from_bytes(bytes(packet)) == packet


def test_command_packet_with_a_bad_inner_crc_is_refused() -> None:
    wire = bytearray(bytes(CommandPacket(8)))
    wire[-1] ^= 1
    with pytest.raises(BodyError):
        CommandPacket.from_bytes(bytes(wire))


@pytest.mark.parametrize(
    ("cls", "data"),
    [
        (Enumerate, b"\x01"),
        (StatusRequest, bytes(14)),
        (StatusReply, bytes(17)),
        (AckNakQueued, bytes(3)),
        (InnerResponse, h("10 00 00 00 00 05 00 01")),
        (QueuedReply, b"\x40"),
    ],
)
def test_short_bodies_are_the_peers_error(cls: type, data: bytes) -> None:
    with pytest.raises(BodyError):
        cls.from_bytes(data)


def test_summaries_name_the_type_addresses_and_contents() -> None:
    assert summarize(frame("enumerate")) == (
        "ENUMERATE 00/00->FF/FF tid=0x0017 protocols=1 formats=1"
    )
    assert "QUEUED" in summarize(frame("status_flagged"))
    assert "'Full PIB'" in summarize(frame("enum_reply"))
    assert "code=0 (accepted)" in summarize(Frame.from_bytes(h(ACK_NAK_8041)))
    short = Frame(0x22, b"\x00", 1)
    assert "body-error" in summarize(short)
