"""Incremental decoder: captures, chunked feeds, resync, timeouts, hypothesis.

References: §4 and §16 (decoding) of docs/level2.md; tests/sms/level2/data/README.md.
"""

from __future__ import annotations

import random

import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from sms.level2.cfa import Capture
from sms.level2.codec import Address, Frame
from sms.level2.errors import ChecksumError, FrameError, Level2Error
from sms.level2.framing import Decoder, decode_stream

GOOD_FRAMES_IN_CAPTURES = 58  # captures/README.md: 58 of 59 pass
ENUMERATE = bytes.fromhex("7E 10 00 FF FF 00 00 17 00 10 00 01 00 01 00 37 C4")
QUEUED_7E = bytes.fromhex("7E 0C 00 00 01 00 00 7D 5E 00 40 00 F9 17")  # §16: tid 0x007E


def all_streams(captures: dict[str, Capture]) -> list[bytes]:
    return [s for c in captures.values() for s in (c.cc_to_payload, c.payload_to_cc)]


def run(decoder: Decoder) -> tuple[list[Frame], list[FrameError]]:
    frames, errors = [], []
    for item in decoder.frames():
        (frames if isinstance(item, Frame) else errors).append(item)
    return frames, errors


def feed_in_chunks(stream: bytes, sizes: list[int]) -> tuple[list[Frame], Decoder]:
    decoder = Decoder()
    frames: list[Frame] = []
    pos = 0
    for size in sizes:
        decoder.feed(stream[pos : pos + size])
        pos += size
        frames += run(decoder)[0]
    decoder.feed(stream[pos:])
    frames += run(decoder)[0]
    return frames, decoder


def test_captures_hold_58_good_frames_and_one_bad(captures: dict[str, Capture]) -> None:
    good = bad = 0
    for stream in all_streams(captures):
        decoder = Decoder()
        decoder.feed(stream)
        _frames, errors = run(decoder)
        good += decoder.good_frames
        bad += decoder.bad_frames
        assert all(isinstance(e, ChecksumError) for e in errors)
    assert (good, bad) == (GOOD_FRAMES_IN_CAPTURES, 1)


def test_the_malformed_capture_frame_is_the_hand_made_enumeration_reply(
    captures: dict[str, Capture],
) -> None:
    decoder = Decoder()
    decoder.feed(captures["Responses.cfa"].payload_to_cc)
    _frames, errors = run(decoder)
    [error] = errors
    assert isinstance(error, ChecksumError)
    assert error.unescaped[9:13] == bytes.fromhex("01 00 10 00")  # a reply to enumerate


def test_every_capture_frame_re_encodes_byte_identically(captures: dict[str, Capture]) -> None:
    checked = 0
    for stream in all_streams(captures):
        pos = 0
        for frame in decode_stream(stream):
            wire = bytes(frame)
            at = stream.find(wire, pos)
            assert at >= pos, f"frame tid 0x{frame.tid:04X} not found as encoded"
            # the encoded frame is the next thing on the line after junk and bad frames
            assert stream.find(b"\x7e", pos) <= at
            pos = at + len(wire)
            checked += 1
    assert checked == GOOD_FRAMES_IN_CAPTURES


def test_the_last_console_reply_of_appendix_a_is_in_the_capture(
    captures: dict[str, Capture],
) -> None:
    # Appendix A: header 7E 53 00 03 00 00 01 1C 00 01 00, body 40 00 00 05 41 00 + 65 bytes
    # of ASCII, CRC EA AC.
    [frame] = [
        f
        for f in decode_stream(captures["OA_enum_first_2014Mar19.cfa"].payload_to_cc)
        if f.tid == 0x1C
    ]
    wire = bytes(frame)
    assert wire[:11] == bytes.fromhex("7E 53 00 03 00 00 01 1C 00 01 00")
    assert frame.body[:6] == bytes.fromhex("40 00 00 05 41 00") and len(frame.body) == 6 + 65
    assert frame.body[6:].strip() == b"Board ID=01, Task ID=03, Task Running is an Empty PM Sensor"
    assert wire[-2:] == bytes.fromhex("EA AC")


def test_the_ff_burst_before_the_first_frame_is_dropped_and_counted(
    captures: dict[str, Capture],
) -> None:
    stream = captures["OA_enum_first_2014Mar19.cfa"].payload_to_cc
    first = stream.index(b"\x7e")
    assert first > 9000  # §2: ≈9,680 bytes of 0xFF (0.9 s) before the first frame
    decoder = Decoder()
    decoder.feed(stream[: first + 1])
    assert decoder.next_frame() is None
    assert decoder.dropped_bytes == first and decoder.buffered == 1


def test_byte_at_a_time_and_random_splits_give_the_same_frames(
    captures: dict[str, Capture],
) -> None:
    for stream in all_streams(captures):
        whole = decode_stream(stream)
        one_by_one, decoder = feed_in_chunks(stream, [1] * len(stream))
        assert one_by_one == whole
        rng = random.Random(len(stream))
        for _ in range(5):
            sizes = [rng.randrange(1, 64) for _ in range(len(stream) // 16)]
            split, split_decoder = feed_in_chunks(stream, sizes)
            assert split == whole
            assert split_decoder.dropped_bytes == decoder.dropped_bytes


def test_escaped_frames_split_between_7d_and_its_partner() -> None:
    stream = QUEUED_7E * 3
    at = QUEUED_7E.index(0x7D)
    frames, _ = feed_in_chunks(stream, [at + 1, 1, len(QUEUED_7E) - at - 2, 1, 1])
    assert [f.tid for f in frames] == [0x7E] * 3


def test_garbage_between_frames_is_skipped_and_counted() -> None:
    decoder = Decoder()
    decoder.feed(b"\xff" * 100 + ENUMERATE + b"\x00\x01junk" + QUEUED_7E + b"\xff" * 7)
    frames, errors = run(decoder)
    assert [f.tid for f in frames] == [0x17, 0x7E] and errors == []
    assert decoder.dropped_bytes == 100 + 6 + 7


def test_a_new_sof_aborts_a_truncated_frame() -> None:
    decoder = Decoder()
    decoder.feed(ENUMERATE[:9] + ENUMERATE)
    frames, errors = run(decoder)
    assert [f.tid for f in frames] == [0x17]
    assert len(errors) == 1 and "truncated" in str(errors[0])
    assert decoder.dropped_bytes == 9 and decoder.bad_frames == 1


@pytest.mark.parametrize("length", [0, 11, 559, 0xFFFF])
def test_out_of_range_length_is_rejected_then_resyncs(length: int) -> None:
    bad = bytearray(ENUMERATE)
    bad[1:3] = length.to_bytes(2, "little")
    decoder = Decoder()
    decoder.feed(bytes(bad) + ENUMERATE)
    frames, errors = run(decoder)
    assert [f.tid for f in frames] == [0x17]
    assert errors and "length" in str(errors[0])


def test_bad_escape_is_rejected_then_resyncs() -> None:
    decoder = Decoder()
    decoder.feed(bytes.fromhex("7E 0C 00 00 01 00 00 7D 41 00 40 00 F9 17") + ENUMERATE)
    frames, errors = run(decoder)
    assert [f.tid for f in frames] == [0x17]
    assert "escape" in str(errors[0])


def test_bad_crc_is_consumed_then_the_next_frame_decodes() -> None:
    bad = bytearray(ENUMERATE)
    bad[-2] ^= 0xFF
    decoder = Decoder()
    decoder.feed(bytes(bad) + ENUMERATE)
    with pytest.raises(ChecksumError):
        decoder.next_frame()
    assert decoder.next_frame() is not None
    assert decoder.next_frame() is None


def test_inter_byte_timeout_drops_a_stale_half_frame() -> None:
    decoder = Decoder(interbyte_timeout=0.5)
    decoder.feed(ENUMERATE[:10], now=100.0)
    assert decoder.next_frame() is None
    decoder.feed(ENUMERATE[10:], now=100.6)  # the rest, too late: junk now
    with pytest.raises(FrameError, match="timeout"):
        decoder.next_frame()
    assert decoder.next_frame() is None
    assert decoder.timeouts == 1 and decoder.dropped_bytes == len(ENUMERATE)
    decoder.feed(ENUMERATE, now=100.7)
    assert decoder.next_frame() is not None


def test_a_slow_but_in_time_frame_is_kept() -> None:
    decoder = Decoder(interbyte_timeout=0.5)
    for i, byte in enumerate(ENUMERATE):
        decoder.feed(bytes((byte,)), now=i * 0.4)
    assert decoder.next_frame() is not None and decoder.timeouts == 0


def test_a_tick_without_bytes_expires_a_half_frame() -> None:
    decoder = Decoder(interbyte_timeout=0.5)
    decoder.feed(ENUMERATE[:5], now=1.0)
    decoder.feed(b"", now=2.0)
    with pytest.raises(FrameError, match="timeout"):
        decoder.next_frame()
    assert decoder.buffered == 0


def test_a_complete_frame_before_a_gap_is_not_lost() -> None:
    decoder = Decoder(interbyte_timeout=0.5)
    decoder.feed(ENUMERATE + ENUMERATE[:4], now=1.0)
    decoder.feed(ENUMERATE[4:], now=5.0)
    frames, errors = run(decoder)
    assert len(frames) == 1 and len(errors) == 1


# --- hypothesis ---------------------------------------------------------------------------


@settings(max_examples=400, deadline=None)
@given(st.binary(max_size=600))
@example(b"\x7e\x7d")
@example(b"\x7e\x0c\x00\x7d\x5e")
@example(b"\x7e\x0c\x00" + b"\x7d" * 20)
@example(b"\x7e\xff\xff")
@example(b"\x7e\x0c\x00\x00\x01\x00\x00\x1a\x00\x40\x00\xe6")
@example(ENUMERATE[:-1] + b"\x7e")
def test_any_bytes_decode_or_raise_the_package_error(data: bytes) -> None:
    decoder = Decoder()
    decoder.feed(data)
    for _ in range(len(data) + 2):
        try:
            if decoder.next_frame() is None:
                break
        except Level2Error:
            continue
    try:
        Frame.from_bytes(data)
    except Level2Error:
        pass


frames_strategy = st.builds(
    lambda t, body, tid, dest, src, no_ack: Frame.make(
        t, body, tid=tid, dest=Address(*dest), src=Address(*src), no_ack=no_ack
    ),
    st.integers(0, 0x7FFF),
    st.binary(max_size=80) | st.sampled_from([b"\x7e" * 5, b"\x7d\x7e\x7d", bytes(114)]),
    st.integers(0, 0xFFFF) | st.sampled_from([0x7E7D, 0x007E, 0x7D00]),
    st.tuples(st.integers(0, 255), st.integers(0, 255)),
    st.tuples(st.integers(0, 255), st.integers(0, 255)),
    st.booleans(),
)


@settings(max_examples=200, deadline=None)
@given(frames_strategy)
def test_any_frame_round_trips(frame: Frame) -> None:
    wire = bytes(frame)
    assert 0x7E not in wire[1:]
    assert Frame.from_bytes(wire) == frame
    assert decode_stream(wire) == [frame]


@settings(max_examples=150, deadline=None)
@given(
    st.lists(frames_strategy, min_size=1, max_size=6),
    st.lists(st.binary(max_size=12).map(lambda b: b.replace(b"\x7e", b"")), min_size=7, max_size=7),
    st.randoms(use_true_random=False),
)
def test_frames_between_junk_survive_any_split(
    frames: list[Frame], junk: list[bytes], rng: random.Random
) -> None:
    stream = b"".join(j + bytes(f) for j, f in zip(junk, frames, strict=False)) + junk[-1]
    sizes = [rng.randrange(1, 9) for _ in range(len(stream))]
    decoded, decoder = feed_in_chunks(stream, sizes)
    assert decoded == frames
    assert decoder.dropped_bytes == sum(len(j) for j in junk[: len(frames)]) + len(junk[-1])
