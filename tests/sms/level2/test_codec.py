"""Codec: every vector of docs/level2.md (§3, §11.1, §11.2, §16, the captured frames)."""

from __future__ import annotations

import binascii

import pytest

from sms.level2.codec import (
    BROADCAST,
    CC_MAIN,
    Address,
    Frame,
    MessageType,
    crc16_arc,
    escape,
    peek_header,
    unescape,
)
from sms.level2.errors import ChecksumError, FrameError, LocalProtocolError


def h(text: str) -> bytes:
    return bytes.fromhex(text.replace("…", ""))


# §3 worked vectors: input after the SOF without the CRC, the CRC, its wire bytes.
CRC_VECTORS = [
    ("31 32 33 34 35 36 37 38 39", 0xBB3D, "3D BB"),
    ("10 00 FF FF 00 00 17 00 10 00 01 00 01 00", 0xC437, "37 C4"),
    ("0C 00 00 01 00 00 1A 00 40 00", 0x27E6, "E6 27"),
    ("0C 00 00 01 00 00 C8 02 40 00", 0x9F7E, "7D 5E 9F"),
]


@pytest.mark.parametrize(("data", "crc", "wire"), CRC_VECTORS)
def test_crc_matches_the_protocol_page(data: str, crc: int, wire: str) -> None:
    assert crc16_arc(h(data)) == crc
    assert escape(crc.to_bytes(2, "little")) == h(wire)
    # §3: residue over the frame after SOF, CRC included (little-endian), is zero
    assert crc16_arc(h(data) + crc.to_bytes(2, "little")) == 0


def test_crc_is_appended_little_endian_not_big_endian() -> None:
    assert crc16_arc(b"123456789" + (0xBB3D).to_bytes(2, "big")) == 0xC2E3  # §3


def test_crc_is_not_xmodem_nor_modbus_and_masks_high_bytes() -> None:
    assert binascii.crc_hqx(b"123456789", 0) == 0x31C3 != crc16_arc(b"123456789")
    assert crc16_arc(b"123456789") != 0x4B37  # CRC-16/MODBUS check value
    assert crc16_arc(h("80 FF")) == 0x8021  # §3: the signed-char bug gives 0xC09E


# Appendix A: real frames, unescaped as captured, CRC verified.
APPENDIX_A = {
    "enumerate": "7E 10 00 FF FF 00 00 17 00 10 00 01 00 01 00 37 C4",
    "enum_reply": "7E 3C 00 00 00 00 01 17 00 01 00 10 00 01 00 01 00 01 00 01 00 00 01 31 32 33 "
    "34 35 36 00 14 00 00 00 00 02 01 80 01 46 75 6C 6C 20 50 49 42 20 20 20 20 20 20 20 20 20 20 "
    "20 20 CC DA",
    "status_request": "7E 1B 00 00 01 00 00 19 00 22 00 FF 00 00 00 00 00 00 00 00 00 00 00 00 00 "
    "00 CD EC",
    "status_flagged": "7E 1E 00 00 00 00 01 19 00 01 00 22 00 01 00 01 00 01 80 00 01 00 00 00 00 "
    "15 23 15 64 46 25",
    "status_plain": "7E 1E 00 00 00 00 01 1E 00 01 00 22 00 01 00 01 00 01 00 00 01 00 00 00 00 15 "
    "23 15 64 D9 01",
    "request_queued": "7E 0C 00 00 01 00 00 1A 00 40 00 E6 27",
}
# §7: sizes of the real frames, unescaped, SOF included
APPENDIX_A_SIZES = {
    "enumerate": 17,
    "enum_reply": 61,
    "status_request": 28,
    "status_flagged": 31,
    "status_plain": 31,
    "request_queued": 13,
}


@pytest.mark.parametrize("name", sorted(APPENDIX_A))
def test_appendix_a_frames_round_trip_byte_identically(name: str) -> None:
    wire = h(APPENDIX_A[name])
    frame = Frame.from_bytes(wire)
    assert bytes(frame) == wire
    assert len(frame.to_unescaped()) == APPENDIX_A_SIZES[name]


def test_header_fields_of_the_enumerate_broadcast() -> None:
    frame = Frame.from_bytes(h(APPENDIX_A["enumerate"]))
    assert frame.msg_type == MessageType.ENUMERATE
    assert frame.dest == BROADCAST and frame.src == CC_MAIN
    assert frame.tid == 0x17 and not frame.no_ack
    assert frame.body == h("01 00 01 00")


# §16 edge-case vectors: escapes in tid, CRC and length.
def test_tid_0x007e_is_escaped() -> None:
    frame = Frame.make(MessageType.REQUEST_QUEUED, tid=0x007E, dest=Address(0, 1), src=CC_MAIN)
    assert bytes(frame) == h("7E 0C 00 00 01 00 00 7D 5E 00 40 00 F9 17")


def test_tid_0x007d_is_escaped() -> None:
    frame = Frame.make(MessageType.REQUEST_QUEUED, tid=0x007D, dest=Address(0, 1), src=CC_MAIN)
    assert bytes(frame) == h("7E 0C 00 00 01 00 00 7D 5D 00 40 00 F9 53")


def test_crc_byte_0x7e_is_escaped() -> None:
    frame = Frame.make(MessageType.REQUEST_QUEUED, tid=0x02C8, dest=Address(0, 1), src=CC_MAIN)
    assert bytes(frame).endswith(h("40 00 7D 5E 9F"))
    assert Frame.from_bytes(bytes(frame)) == frame


def test_status_request_with_tid_0x7d7e() -> None:
    body = h("FF") + bytes(14)
    frame = Frame.make(
        MessageType.REQUEST_STATUS, body, tid=0x7D7E, dest=Address(0, 1), src=CC_MAIN
    )
    wire = bytes(frame)
    assert wire.startswith(h("7E 1B 00 00 01 00 00 7D 5E 7D 5D 22 00 FF 00"))
    assert wire.endswith(h("6E E4"))
    assert Frame.from_bytes(wire) == frame


@pytest.mark.parametrize("length", [0x7D, 0x7E])
def test_length_byte_0x7d_or_0x7e_is_escaped(length: int) -> None:
    frame = Frame.make(0x0077, bytes(length - 12), tid=1, dest=Address(0, 1), src=CC_MAIN)
    wire = bytes(frame)
    assert wire[:3] == bytes((0x7E, 0x7D, length ^ 0x20))
    assert Frame.from_bytes(wire) == frame


# §11.1 computed example (Goby layout) and the PC variant.
GOBY_FHEAD = (
    "7E 29 00 01 00 00 01 1B 00 01 00 40 00 01 00 0A FF FF FF FF 12 00 10 08 00 00 00 00 E6 "
    "00 00 00 00 00 00 00 00 00 C5 31 11 47"
)


def test_the_computed_fixed_heading_frame_round_trips() -> None:
    frame = Frame.from_bytes(h(GOBY_FHEAD))
    assert frame.dest == Address(0x01, 0x00) and frame.src == Address(0x00, 0x01)
    assert bytes(frame) == h(GOBY_FHEAD)


# §11.2 the real C&C response inside 0x8041, from PC's EnumerationTransaction.txt. The page gives
# its CRC as "B0 0E", but in the student's transcription the frame ends "… A4 FB 2A 43" and the
# bytes that follow ("7E 17 00 … B0 0E") are a second 0x8041 frame: B0 0E is that frame's CRC.
# Both frames check with these CRCs; neither checks with the page's reading.
READ_WAYPOINT_DATA = (
    "20 05 00 14 00 05 00 00 14 00 00 14 03 00 00 00 FF 73 46 14 00 00 3C 00 00 00 0F"
)
ACK_NAK_8041 = (
    "7E 3A 00 10 00 00 00 6A 04 41 80 01 00 00 00 10 00 00 00 00 23 00 "
    + READ_WAYPOINT_DATA
    + " F4 F0 50 01 64 FF A4 FB 2A 43"
)
ACK_NAK_8041_NEXT = "7E 17 00 00 00 00 00 6B 04 41 80 01 00 00 00 00 00 00 00 00 00 00 B0 0E"
# The 169-byte 0x91 telemetry frame transcribed in the same file (§11.3), CRC 69 C5.
TELEMETRY_91 = (
    "7E A9 00 02 00 00 01 42 20 01 00 40 00 91 98 00 90 00 00 00 01 01 31 01 00 00 00 00 00 00 00 "
    "00 00 00 00 00 53 2B 50 59 43 E9 2B 92 41 B1 EF B8 42 C3 E6 24 43 E8 5A D0 41 B2 63 6F 42 CB "
    "40 A5 3F A8 B0 F2 C0 82 CB 4A 41 B3 D6 B8 42 C8 0C 11 C0 72 0A 60 41 B4 1C 77 42 CB 17 45 43 "
    "E8 95 73 41 B5 7A 08 42 C1 0B 35 43 E7 57 F0 41 B5 EE D8 42 CB 4B F5 3F AE 2E B2 00 00 00 00 "
    "00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 00 3F 2E 14 7B 3F 61 47 AE 3F 87 AE 14 3F 4A 3D "
    "71 3F 80 00 00 3F 85 1E B8 3F EE 70 3B 69 C5"
)


def test_the_real_ack_nak_queued_frame_checks_and_round_trips() -> None:
    frame = Frame.from_bytes(h(ACK_NAK_8041))
    assert frame.msg_type == MessageType.ACK_NAK_QUEUED and frame.no_ack
    assert frame.type_word == 0x8041
    assert frame.dest == Address(0x10, 0x00) and frame.tid == 0x046A
    assert bytes(frame) == h(ACK_NAK_8041)
    with pytest.raises(ChecksumError):  # the page's reading, with the next frame's CRC
        Frame.from_bytes(h(ACK_NAK_8041)[:-2] + h("B0 0E"))


def test_the_frame_after_it_owns_the_crc_b0_0e() -> None:
    frame = Frame.from_bytes(h(ACK_NAK_8041_NEXT))
    assert frame.type_word == 0x8041 and frame.tid == 0x046B
    assert bytes(frame) == h(ACK_NAK_8041_NEXT)


def test_the_real_telemetry_frame_checks_and_round_trips() -> None:
    frame = Frame.from_bytes(h(TELEMETRY_91))
    assert len(frame.to_unescaped()) == 0xA9 + 1  # "169-byte" on the page is L = 169
    assert frame.dest == Address(0x02, 0x00) and frame.body[:3] == h("40 00 91")
    assert bytes(frame) == h(TELEMETRY_91)


def test_bad_checksum_raises_checksum_error_with_the_frame() -> None:
    wire = bytearray(h(APPENDIX_A["request_queued"]))
    wire[-1] ^= 0x01
    with pytest.raises(ChecksumError) as info:
        Frame.from_bytes(bytes(wire))
    header = peek_header(info.value.unescaped)
    assert header is not None and header[3] == 0x1A


@pytest.mark.parametrize(
    "wire",
    [
        "",
        "7E",
        "00 0C 00 00 01 00 00 1A 00 40 00 E6 27",  # no SOF
        "7E 0D 00 00 01 00 00 1A 00 40 00 E6 27",  # length disagrees
        "7E 0C 00 00 01 00 00 7D 41 00 40 00 E6 27",  # bad escape
        "7E 0C 00 00 01 00 00 1A 00 40 00 E6 7D",  # escape at the end
        "7E 0C 00 00 7E 00 00 1A 00 40 00 E6 27",  # raw SOF inside
    ],
)
def test_malformed_wire_frames_raise_frame_error(wire: str) -> None:
    with pytest.raises(FrameError):
        Frame.from_bytes(h(wire))


def test_escape_and_unescape_are_inverse_and_order_safe() -> None:
    data = bytes(range(256)) + b"\x7d\x5e\x7e\x5d"
    escaped = escape(data)
    assert 0x7E not in escaped
    assert unescape(escaped) == data
    assert escape(b"\x7e") == b"\x7d\x5e" and escape(b"\x7d") == b"\x7d\x5d"


@pytest.mark.parametrize(
    "kwargs",
    [
        {"tid": 0x10000},
        {"tid": -1},
        {"msg_type": 0x8000},
        {"dest_task": 256},
        {"src_board": -1},
        {"body": bytes(547)},
    ],
)
def test_out_of_range_fields_are_our_own_misuse(kwargs: dict) -> None:
    fields = {"msg_type": 0x22, "body": b"", "tid": 1} | kwargs
    with pytest.raises(LocalProtocolError):
        bytes(Frame(**fields))


def test_no_ack_bit_round_trips() -> None:
    frame = Frame.make(0x41, b"", tid=5, dest=Address(0, 1), src=CC_MAIN, no_ack=True)
    assert Frame.from_bytes(bytes(frame)).no_ack
    assert frame.to_unescaped()[9:11] == h("41 80")
