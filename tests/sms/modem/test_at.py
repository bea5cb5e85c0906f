"""The pure AT layer (sms/modem/at.py): line reader, parsers, error codes.

References: docs/sms.md, 'The GSM modem'; 3GPP TS 27.005 §3 (text-mode formats).
"""

from __future__ import annotations

import random
from datetime import UTC, datetime, timedelta, timezone

import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from sms import gsm7
from sms.modem.at import (
    AtReader,
    Echo,
    FinalResult,
    Noise,
    Prompt,
    ReceivedSms,
    Response,
    Urc,
    describe_error,
    parse_cmgs,
    parse_cmti,
    parse_cpms,
    parse_final,
    parse_message_header,
    parse_scts,
    split_fields,
)
from sms.modem.errors import AtParseError, ModemError, ModemUsageError

STAMP = datetime(2026, 11, 23, 14, 5, tzinfo=timezone(timedelta(hours=10)))
CMGR_CSDH0 = b'\r\n+CMGR: "REC UNREAD","+61400000001",,"26/11/23,14:05:00+40"\r\n'
CMGR_CSDH1 = (
    b'\r\n+CMGR: "REC UNREAD","+61400000001",,"26/11/23,14:05:00+40",145,4,0,0,'
    b'"+61418706700",145,%d\r\n'
)


def answer(command: str, stream: bytes) -> list[object]:
    reader = AtReader()
    reader.start(command)
    return reader.feed(stream)


def only_response(events: list[object]) -> Response:
    [response] = [e for e in events if isinstance(e, Response)]
    return response


# -- final results and errors ---------------------------------------------------------------------


def test_final_results_numeric_and_verbose() -> None:
    assert parse_final("OK") == FinalResult("OK", None, "OK")
    assert parse_final("ERROR").kind == "ERROR"
    cms = parse_final("+CMS ERROR: 331")
    assert (cms.kind, cms.code, cms.meaning, cms.temporary) == (
        "+CMS ERROR",
        331,
        "no network service",
        True,
    )
    verbose = parse_final("+CMS ERROR: SIM not inserted")
    assert (verbose.code, verbose.temporary) == (310, False)
    assert parse_final("+CME ERROR: 14").temporary  # SIM busy
    assert parse_final('+CMTI: "SM",3') is None
    assert parse_final("OKAY") is None


def test_network_trouble_is_temporary_and_refusals_are_permanent() -> None:
    for code in (331, 332, 42, 314):
        assert describe_error("+CMS ERROR", code)[1], code
    for code in (1, 21, 302, 305, 310, 311, 321, 322, 330):
        assert not describe_error("+CMS ERROR", code)[1], code
    assert describe_error("+CMS ERROR", 304)[0] == "invalid PDU mode parameter"  # TS 27.005
    assert describe_error("+CMS ERROR", 777) == ("code 777", True)  # unknown: retry, bounded
    assert describe_error("ERROR", None) == ("the modem refused the command", False)


# -- the reader -----------------------------------------------------------------------------------


def test_an_answer_with_information_lines_and_ok() -> None:
    response = only_response(answer("AT+CSQ", b"\r\n+CSQ: 21,99\r\n\r\nOK\r\n"))
    assert response.lines == ("+CSQ: 21,99",)
    assert response.result.ok


def test_the_echo_of_our_command_before_ate0_is_not_an_answer() -> None:
    events = answer("ATE0", b"ATE0\r\r\nOK\r\n")
    assert events[0] == Echo("ATE0")
    assert only_response(events).lines == ()


def test_a_urc_in_the_middle_of_an_answer_is_reported_apart() -> None:
    events = answer("AT+CSQ", b'\r\n+CSQ: 9,99\r\n\r\n+CMTI: "SM",4\r\n\r\nRING\r\n\r\nOK\r\n')
    assert [e.name for e in events if isinstance(e, Urc)] == ["+CMTI", "RING"]
    assert only_response(events).lines == ("+CSQ: 9,99",)


def test_cpin_is_an_answer_to_cpin_and_a_restart_line_otherwise() -> None:
    assert only_response(answer("AT+CPIN?", b"\r\n+CPIN: READY\r\n\r\nOK\r\n")).lines == (
        "+CPIN: READY",
    )
    reader = AtReader()
    events = reader.feed(b"\r\nRDY\r\n\r\n+CFUN: 1\r\n\r\n+CPIN: READY\r\n\r\nSMS Ready\r\n")
    assert [e.name for e in events] == ["RDY", "+CFUN", "+CPIN", "SMS READY"]
    assert all(isinstance(e, Urc) and e.restart for e in events)
    assert not Urc("+CREG", "+CREG: 1").restart


def test_cmgr_without_csdh_reads_the_text() -> None:
    response = only_response(answer("AT+CMGR=3", CMGR_CSDH0 + b"#FHEAD 230\r\n\r\nOK\r\n"))
    assert response.messages == (
        ReceivedSms(None, "REC UNREAD", "+61400000001", "#FHEAD 230", STAMP),
    )


def test_a_text_that_looks_like_a_result_or_urc_is_still_text() -> None:
    for text in (b"OK", b'+CMTI: "SM",9', b'+CMGL: 1,"REC READ"', b"ERROR", b"RDY"):
        response = only_response(answer("AT+CMGR=3", CMGR_CSDH0 + text + b"\r\n\r\nOK\r\n"))
        assert response.messages[0].text == text.decode()


def test_with_csdh_a_text_of_several_lines_is_read_exactly() -> None:
    text = b'#HOLD\r\nOK\r\n+CMTI: "SM",2\r\n\r\nend'
    stream = (CMGR_CSDH1 % len(text)) + text + b"\r\n\r\nOK\r\n"
    response = only_response(answer("AT+CMGR=1", stream))
    assert response.messages[0].text == text.decode()
    assert response.result.ok


def test_with_csdh_a_urc_right_after_the_text_is_a_urc() -> None:
    stream = (CMGR_CSDH1 % 5) + b'hello\r\n\r\n+CMTI: "SM",2\r\n\r\nOK\r\n'
    events = answer("AT+CMGR=1", stream)
    assert only_response(events).messages[0].text == "hello"
    assert [e.text for e in events if isinstance(e, Urc)] == ['+CMTI: "SM",2']


def test_text_is_gsm7_one_byte_per_septet() -> None:
    body = gsm7.encode("@5 £ _ é")
    response = only_response(answer("AT+CMGR=1", CMGR_CSDH0 + body + b"\r\n\r\nOK\r\n"))
    assert response.messages[0].text == "@5 £ _ é"


def test_cmgl_lists_messages_with_and_without_lengths() -> None:
    csdh0 = (
        b'\r\n+CMGL: 1,"REC READ","+61400000001",,"26/11/23,14:05:00+40"\r\n#FHEAD 230\r\n'
        b'+CMGL: 2,"REC UNREAD","0400000002",,"26/11/23,14:06:00+40"\r\nline one\nline two\r\n'
        b'+CMGL: 3,"STO UNSENT","+61400000003",\r\ndraft\r\n\r\nOK\r\n'
    )
    csdh1 = (
        b'\r\n+CMGL: 1,"REC READ","+61400000001",,"26/11/23,14:05:00+40",145,10\r\n#FHEAD 230\r\n'
        b'+CMGL: 2,"REC UNREAD","0400000002",,"26/11/23,14:06:00+40",129,13\r\nOK\r\n+CMGL: x\r\n'
        b"\r\nOK\r\n"
    )
    first = only_response(answer('AT+CMGL="ALL"', csdh0)).messages
    assert [(m.index, m.status, m.text) for m in first] == [
        (1, "REC READ", "#FHEAD 230"),
        (2, "REC UNREAD", "line one\nline two"),
        (3, "STO UNSENT", "draft"),
    ]
    assert first[1].number == "0400000002" and not first[2].received
    second = only_response(answer('AT+CMGL="ALL"', csdh1)).messages
    assert [m.text for m in second] == ["#FHEAD 230", "OK\r\n+CMGL: x"]


def test_a_status_report_in_a_listing_has_no_text() -> None:
    stream = (
        b'\r\n+CMGL: 4,"REC READ",6,233,"+61400000001",145,"26/11/23,14:05:00+40",'
        b'"26/11/23,14:05:02+40",0\r\n'
        b'+CMGL: 5,"REC READ","+61400000001",,"26/11/23,14:05:00+40"\r\nhi\r\n\r\nOK\r\n'
    )
    response = only_response(answer('AT+CMGL="ALL"', stream))
    assert [m.index for m in response.messages] == [5]


def test_the_prompt_has_no_line_ending() -> None:
    reader = AtReader()
    reader.start('AT+CMGS="+61400000001"')
    assert reader.feed(b"\r\n>") == []
    assert reader.feed(b" ") == [Prompt()]
    events = reader.feed(b"\r\n+CMGS: 17\r\n\r\nOK\r\n")
    assert parse_cmgs(only_response(events).lines[0]) == 17


def test_no_prompt_is_seen_for_other_commands_or_in_a_text() -> None:
    events = answer("AT+CMGR=1", CMGR_CSDH0 + b"> quoted\r\n\r\nOK\r\n")
    assert not any(isinstance(e, Prompt) for e in events)
    assert only_response(events).messages[0].text == "> quoted"


def test_lines_with_no_command_in_flight_are_urcs_or_noise() -> None:
    reader = AtReader()
    events = reader.feed(b"\r\nOK\r\n\r\n\xff\xfe junk\r\n\r\n+CREG: 1\r\n")
    assert isinstance(events[0], Noise) and events[0].reason.startswith("result with no")
    assert isinstance(events[1], Noise)
    assert events[2] == Urc("+CREG", "+CREG: 1")
    assert reader.noise_lines == 2


def test_an_endless_line_is_reported_in_pieces() -> None:
    reader = AtReader()
    events = reader.feed(b"x" * 5000)
    assert len(events) == 4 and all(isinstance(e, Noise) for e in events)


def test_one_command_at_a_time_and_cancel_forgets_it() -> None:
    reader = AtReader()
    reader.start("AT")
    with pytest.raises(ModemUsageError):
        reader.start("AT+CSQ")
    reader.cancel()
    assert isinstance(reader.feed(b"\r\nOK\r\n")[0], Noise)  # a late answer


def test_a_pushed_cmt_carries_its_message() -> None:
    events = AtReader().feed(b'\r\n+CMT: "+61400000001",,"26/11/23,14:05:00+40"\r\n#HELP\r\n')
    [urc] = events
    assert isinstance(urc, Urc) and urc.sms is not None and urc.sms.text == "#HELP"


# -- parsers ---------------------------------------------------------------------------------------


def test_scts_zone_is_in_quarter_hours() -> None:
    assert parse_scts("26/11/23,14:05:00+40") == STAMP
    assert parse_scts("26/11/23,14:05:00-22").utcoffset() == -timedelta(hours=5, minutes=30)
    assert parse_scts("26/11/23,14:05:00+00").tzinfo == UTC
    assert parse_scts("26/11/23,14:05:00").tzinfo == UTC  # firmware without a zone
    for bad in ("26/13/23,14:05:00+40", "26/11/23 14:05:00", "26/11/23,14:05:00+99", ""):
        with pytest.raises(AtParseError):
            parse_scts(bad)


def test_cmti_cmgs_cpms() -> None:
    assert parse_cmti('+CMTI: "SM",12') == ("SM", 12)
    assert parse_cmti('+CMTI: "ME", 3') == ("ME", 3)
    assert parse_cmgs("+CMGS: 255") == 255
    assert [(u.memory, u.used, u.total) for u in parse_cpms("+CPMS: 3,30,3,30,3,30")] == [
        (None, 3, 30)
    ] * 3
    assert parse_cpms('+CPMS: "SM",1,20,"SM",1,20,"SM",1,20')[0].memory == "SM"
    for bad, parser in (("+CMTI: SM", parse_cmti), ("+CMGS: x", parse_cmgs)):
        with pytest.raises(AtParseError):
            parser(bad)


def test_quoted_fields_may_hold_commas() -> None:
    assert split_fields('+CMGR: "REC READ","+614","Smith, J","26/11/23,14:05:00+40"') == [
        ("REC READ", True),
        ("+614", True),
        ("Smith, J", True),
        ("26/11/23,14:05:00+40", True),
    ]


def test_a_pdu_mode_header_is_refused() -> None:
    with pytest.raises(AtParseError):
        parse_message_header("+CMGR: 0,,26")


# -- any bytes, any splits (hypothesis) -----------------------------------------------------------

PIECES = [
    b"\r\nOK\r\n",
    b"\r\nERROR\r\n",
    b"\r\n+CMS ERROR: 331\r\n",
    b"\r\n+CME ERROR: SIM busy\r\n",
    b'\r\n+CMTI: "SM",3\r\n',
    b"\r\nRDY\r\n",
    b"\r\n+CMGS: 4\r\n",
    b"\r\n> ",
    CMGR_CSDH0 + b"OK\r\n",
    (CMGR_CSDH1 % 9) + b"a\r\nb\r\nOK\r\n",
    b'\r\n+CMGL: 1,"REC READ","+614",,"26/11/23,14:05:00+40"\r\ntext\r\n',
    b'AT+CMGS="+61400000001"\r',
    b"\xff\x00\x1a\x1b\r",
    b"\n",
    b"\r",
    b">",
]


def run_in_chunks(command: str, stream: bytes, cuts: list[int]) -> list[object]:
    reader = AtReader()
    reader.start(command)
    events: list[object] = []
    last = 0
    for cut in sorted(set(cuts)):
        events += reader.feed(stream[last:cut])
        last = cut
    events += reader.feed(stream[last:])
    return events


@settings(max_examples=300, deadline=None)
@given(
    st.sampled_from(['AT+CMGS="+61400000001"', "AT+CMGR=1", 'AT+CMGL="ALL"', "AT"]),
    st.lists(st.one_of(st.sampled_from(PIECES), st.binary(max_size=8)), max_size=12),
    st.randoms(use_true_random=False),
)
@example("AT+CMGR=1", [CMGR_CSDH0, b"OK\r\n", b"\r\nOK\r\n"], random.Random(1))
def test_the_same_stream_in_any_chunks_gives_the_same_events(
    command: str, pieces: list[bytes], rng: random.Random
) -> None:
    stream = b"".join(pieces)
    whole = run_in_chunks(command, stream, [])
    bytewise = run_in_chunks(command, stream, list(range(len(stream))))
    cuts = [rng.randrange(len(stream) + 1) for _ in range(rng.randrange(6))]
    assert bytewise == whole
    assert run_in_chunks(command, stream, cuts) == whole


@settings(max_examples=300, deadline=None)
@given(st.binary(max_size=3000), st.lists(st.integers(0, 3000), max_size=8))
@example(b"\r\n> " + b"x" * 1100, [3])
def test_any_bytes_give_events_never_an_exception(data: bytes, cuts: list[int]) -> None:
    events = run_in_chunks('AT+CMGS="+1"', data, [c for c in cuts if c <= len(data)])
    assert all(isinstance(e, Response | Urc | Prompt | Echo | Noise) for e in events)


@settings(max_examples=300, deadline=None)
@given(st.text(max_size=120))
@example('+CMGL: 1,"REC READ",,,"')
@example("+CMGR: ")
def test_parsers_return_a_value_or_raise_the_package_error(line: str) -> None:
    for parser in (parse_cmti, parse_cmgs, parse_cpms, parse_message_header, parse_scts):
        try:
            parser(line)
        except ModemError as exc:
            assert isinstance(exc, AtParseError)
