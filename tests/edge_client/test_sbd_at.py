"""The pure SBD layer (edge_client/sbd/at.py, session_codes.py): parsers, frames, the reader.

References: Iridium ISU AT Command Reference (+SBDWB, +SBDRB, +SBDIX, +CSQ, SBDRING), as
publicly documented; the RockBLOCK pages' worked example of the checksum ("hello").
"""

from __future__ import annotations

import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from edge_client.sbd.at import (
    MO_MAX,
    BadFrame,
    Frame,
    SbdixResult,
    SbdReader,
    checksum,
    encode_frame,
    is_final,
    is_ring,
    parse_csq,
    parse_digit,
    parse_sbdix,
    split_frame,
    with_checksum,
)
from edge_client.sbd.errors import SbdError, SbdParseError
from edge_client.sbd.session_codes import Retry, mo_status

# -- checksums and frames -------------------------------------------------------------------------


def test_the_documented_checksum_of_hello() -> None:
    assert checksum(b"hello") == 0x0214
    assert with_checksum(b"hello") == bytes.fromhex("68656c6c6f0214")


def test_the_checksum_keeps_the_low_16_bits() -> None:
    assert checksum(b"\xff" * 340) == (255 * 340) & 0xFFFF
    assert checksum(b"\xff" * 300) == 76500 - 65536  # the sum wraps
    assert checksum(b"") == 0


def test_a_frame_is_length_payload_checksum() -> None:
    assert encode_frame(b"hello") == b"\x00\x05hello\x02\x14"
    assert encode_frame(b"") == b"\x00\x00\x00\x00"


@given(st.binary(max_size=400), st.binary(max_size=20))
@example(b"", b"")
def test_frames_round_trip_and_leave_what_follows(payload: bytes, rest: bytes) -> None:
    frame = encode_frame(payload)
    assert split_frame(frame + rest) == (payload, len(frame))
    for cut in range(len(frame)):
        assert split_frame(frame[:cut]) is None  # incomplete: wait for more


@given(st.binary(min_size=1, max_size=MO_MAX), st.integers(0, 0xFFFF))
def test_a_wrong_checksum_never_passes(payload: bytes, wrong: int) -> None:
    frame = encode_frame(payload)
    if wrong == checksum(payload):
        wrong ^= 1
    with pytest.raises(SbdParseError, match="checksum"):
        split_frame(frame[:-2] + wrong.to_bytes(2, "big"))


def test_an_implausible_length_is_refused() -> None:
    with pytest.raises(SbdParseError, match="implausible"):
        split_frame(b"\x08\x00")
    with pytest.raises(SbdParseError):
        encode_frame(b"x" * 0x800)


# -- answers --------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("line", "expected"),
    [
        ("+SBDIX: 0, 12, 1, 3, 5, 2", SbdixResult(0, 12, 1, 3, 5, 2)),
        ("+SBDIX:32,5,2,0,0,0", SbdixResult(32, 5, 2, 0, 0, 0)),
        ("+SBDIXA: 1, 65535, 0, 65535, 0, 7", SbdixResult(1, 65535, 0, 65535, 0, 7)),
        ("  +SBDIX: 35, 0, 2, 0, 0, 0  ", SbdixResult(35, 0, 2, 0, 0, 0)),
    ],
)
def test_sbdix_answers(line: str, expected: SbdixResult) -> None:
    assert parse_sbdix(line) == expected


@pytest.mark.parametrize(
    "line",
    [
        "+SBDIX: 0, 12, 1, 3, 5",  # five numbers
        "+SBDIX: 0, 12, 1, 3, 5, 2, 9",
        "+SBDIX: 0, 70000, 1, 3, 5, 2",  # MOMSN wraps at 65535
        "+SBDIX: 0, 1, 3, 3, 5, 2",  # MT status is 0-2
        "+SBDIX: 0, 1, 1, 3, 4000, 2",  # no ISU takes 4000 bytes
        "+SBDIX: -1, 1, 1, 3, 5, 2",
        "+SBDIX: ٣, 1, 1, 3, 5, 2",  # a digit, but not an ASCII one
        "+SBDI: 0, 1, 0, 0",
        "SBDRING",
        "",
    ],
)
def test_bad_sbdix_answers_raise_a_parse_error(line: str) -> None:
    with pytest.raises(SbdParseError):
        parse_sbdix(line)


def test_the_sbdix_result_explains_itself() -> None:
    result = parse_sbdix("+SBDIX: 32, 5, 2, 0, 0, 0")
    assert not result.mo.success and result.mo.retry is Retry.RETRY
    assert "no network service" in result.mo.meaning
    assert "error" in result.mt_meaning and not result.mt_received


def test_csq() -> None:
    assert parse_csq("+CSQ:5") == 5
    assert parse_csq("+CSQ: 0") == 0
    assert parse_csq("+CSQF:3") == 3
    for bad in ("+CSQ:6", "+CSQ: 21,99", "+CSQ:", "CSQ:3"):
        with pytest.raises(SbdParseError):
            parse_csq(bad)


def test_one_number_results() -> None:
    assert parse_digit("0", range(4)) == 0
    assert parse_digit(" 3 ", range(4)) == 3
    for bad in ("4", "", "OK", "²", "-1"):
        with pytest.raises(SbdParseError):
            parse_digit(bad, range(4))


def test_rings_and_finals() -> None:
    assert is_ring("SBDRING") and is_ring("+SBDRING") and is_ring(" sbdring ")
    assert not is_ring("RING")
    assert is_final("OK") and is_final("ERROR") and not is_final("READY")


# -- session codes --------------------------------------------------------------------------------


@pytest.mark.parametrize("code", [0, 1, 2, 3, 4])
def test_statuses_0_to_4_are_success(code: int) -> None:
    assert mo_status(code).success and mo_status(code).retry is Retry.NONE


@pytest.mark.parametrize(
    ("code", "retry", "words"),
    [
        (5, Retry.RETRY, "reserved"),
        (10, Retry.RETRY, "allowed time"),
        (11, Retry.WAIT, "queue full"),
        (12, Retry.NEVER, "too many segments"),
        (13, Retry.RETRY, "did not complete"),
        (15, Retry.NEVER, "access is denied"),
        (16, Retry.NEVER, "locked"),
        (17, Retry.RETRY, "not responding"),
        (18, Retry.RETRY, "RF drop"),
        (19, Retry.RETRY, "link failure"),
        (25, Retry.RETRY, "reserved"),
        (32, Retry.RETRY, "no network service"),
        (33, Retry.NEVER, "antenna fault"),
        (34, Retry.NEVER, "radio is disabled"),
        (35, Retry.RETRY, "busy"),
        (36, Retry.WAIT, "3 minutes"),
        (37, Retry.WAIT, "temporarily disabled"),
        (38, Retry.WAIT, "traffic management"),
        (64, Retry.NEVER, "band violation"),
        (65, Retry.NEVER, "PLL"),
    ],
)
def test_failure_statuses_and_their_retry_decision(code: int, retry: Retry, words: str) -> None:
    status = mo_status(code)
    assert not status.success
    assert status.retry is retry
    assert words in status.meaning
    assert status.permanent == (retry is Retry.NEVER)
    assert (status.min_wait_s > 0) == (retry is Retry.WAIT)


def test_status_36_waits_three_minutes() -> None:
    assert mo_status(36).min_wait_s == 180.0


@given(st.integers(0, 255))
def test_every_status_has_a_meaning_and_a_decision(code: int) -> None:
    status = mo_status(code)
    assert status.meaning and status.code == code
    assert status.success == (code <= 4)


# -- the reader -----------------------------------------------------------------------------------


def lines_of(reader: SbdReader) -> list[str]:
    found = []
    while (line := reader.line()) is not None:
        found.append(line)
    return found


def test_lines_split_on_cr_or_crlf_and_empty_ones_drop() -> None:
    reader = SbdReader()
    reader.feed(b"AT+SBDIX\r\r\n+SBDIX: 0, 1, 0, 0, 0, 0\r\n\r\nOK\r\nSBDRING\r\n")
    assert lines_of(reader) == ["AT+SBDIX", "+SBDIX: 0, 1, 0, 0, 0, 0", "OK", "SBDRING"]
    assert reader.pending == 0


def test_an_incomplete_line_waits() -> None:
    reader = SbdReader()
    reader.feed(b"\r\nREA")
    assert reader.line() is None
    reader.feed(b"DY\r\n")
    assert reader.line() == "READY"


def test_an_endless_line_comes_out_in_pieces() -> None:
    reader = SbdReader()
    reader.feed(b"x" * 1100)
    assert [len(piece) for piece in lines_of(reader)] == [512, 512]
    assert reader.pending == 76


def test_a_frame_after_its_echo_then_ok() -> None:
    reader = SbdReader()
    reader.feed(b"AT+SBDRB\r" + encode_frame(b"\r\nOK\r\n") + b"\r\nOK\r\n")
    assert reader.frame() == "AT+SBDRB"  # the echo, as text
    assert reader.frame() == Frame(b"\r\nOK\r\n")  # a payload that looks like text is data
    assert lines_of(reader) == ["OK"]


def test_a_ring_or_garbage_before_the_frame_comes_out_as_text() -> None:
    reader = SbdReader()
    reader.feed(b"\r\nSBDRING\r\n\r\n\xfe\xfd\x99\r\n" + encode_frame(b"go"))
    assert reader.frame() == "SBDRING"
    assert reader.frame() == "\xfe\xfd\x99"
    assert reader.frame() == Frame(b"go")
    assert reader.frame() is None


def test_a_bad_frame_is_reported_and_dropped() -> None:
    reader = SbdReader()
    reader.feed(b"\x00\x02go\x00\x00\r\nOK\r\n")
    result = reader.frame()
    assert isinstance(result, BadFrame) and "checksum" in result.reason
    assert lines_of(reader) == ["OK"]


@given(st.binary(max_size=300), st.lists(st.integers(0, 300), max_size=6))
def test_the_same_bytes_in_any_chunks_give_the_same_lines(data: bytes, cuts: list[int]) -> None:
    whole = SbdReader()
    whole.feed(data)
    expected = lines_of(whole)
    chunked, got = SbdReader(), []
    start = 0
    for cut in sorted({min(c, len(data)) for c in cuts}) + [len(data)]:
        chunked.feed(data[start:cut])
        start = cut
        got += lines_of(chunked)
    # A line cut exactly after its CR may lose its LF to the next chunk: empty lines drop,
    # so the text lines are the same.
    assert got == expected


@settings(max_examples=300)
@given(st.binary(max_size=600))
def test_garbage_never_crashes_the_reader(data: bytes) -> None:
    reader = SbdReader()
    reader.feed(data)
    for _ in range(len(data) + 2):
        item = reader.frame()
        if item is None:
            break
        assert isinstance(item, Frame | BadFrame | str)
    lines_of(reader)


@settings(max_examples=300)
@given(st.text(max_size=80))
@example("+SBDIX: 0,0,0,0,0,0\x00")
@example("+CSQ:٣")
def test_garbage_lines_raise_only_parse_errors(line: str) -> None:
    for parse in (parse_sbdix, parse_csq, lambda text: parse_digit(text, range(4))):
        try:
            parse(line)
        except SbdParseError as exc:
            assert isinstance(exc, SbdError) and not exc.permanent
