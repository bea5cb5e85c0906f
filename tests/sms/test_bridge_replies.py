"""Replies that wait for the C&C's answer (issue 11 §3): the pure composition (sms.replies) and
the held replies in the SMS service (sms_handle_incoming with a reply window, sms_replies_due)."""

from __future__ import annotations

import datetime as dt

import pytest
from hypothesis import given
from hypothesis import strategies as st

from commands.models import Command
from commands.services import command_complete, command_mark_sent
from sms import replies
from sms.bridge.commands import ACK_DETAIL, NAK_DETAIL, NO_ANSWER
from sms.gsm7 import SMS_SEPTETS, septets
from sms.models import Direction, SendStatus, SmsMessage
from sms.services import authorised_number_authorise, sms_handle_incoming, sms_replies_due
from vessels.models import Vessel

PHONE = "+61400000001"
T0 = dt.datetime(2026, 11, 25, 6, 0, tzinfo=dt.UTC)


# -- pure ---------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("status", "detail", "reason", "outcome"),
    [
        ("done", ACK_DETAIL, None, "OK"),
        ("failed", NAK_DETAIL.format(code=2, meaning="invalid data"), "invalid data",
         "FAILED invalid data"),
        ("failed", NO_ANSWER, None, "FAILED no answer from the C&C box"),
        ("failed", "refused by the inner command table: not enabled", "not enabled",
         "FAILED not enabled"),
        # the reason is the recorded field, whatever the detail beside it says
        ("failed", "the C&C box said no", "invalid data", "FAILED invalid data"),
        ("failed", "", None, "FAILED"),
        ("superseded", "", None, "SUPERSEDED"),
        ("queued", "", None, None),
        ("sent", "", None, None),
        ("acknowledged", "", None, None),
    ],
)  # fmt: skip
def test_a_command_outcome_reads_as_the_reply_says_it(
    status: str, detail: str, reason: str | None, outcome: str | None
) -> None:
    assert replies.command_outcome(status, detail, reason) == outcome


def test_settle_replaces_each_command_outcome_and_says_whether_all_ended() -> None:
    records = [
        {"echo": "#FHEAD 230", "outcome": "QUEUED", "command": 1},
        {"echo": "#LIGHT", "outcome": "ON"},
        {"echo": "#LIGHT OFF", "outcome": "QUEUED", "command": 2},
    ]
    text, ended = replies.settle(records, {1: "OK", 2: None})
    assert (text, ended) == ("#FHEAD 230 OK; #LIGHT ON; #LIGHT OFF QUEUED", False)
    text, ended = replies.settle(records, {1: "OK", 2: "FAILED invalid data"})
    assert (text, ended) == ("#FHEAD 230 OK; #LIGHT ON; #LIGHT OFF FAILED invalid data", True)


@given(st.lists(st.text(max_size=200), min_size=1, max_size=12), st.text(max_size=300))
def test_a_settled_reply_always_fits_one_sms(echoes: list[str], reason: str) -> None:
    records = [{"echo": e, "outcome": "QUEUED", "command": i} for i, e in enumerate(echoes)]
    text, ended = replies.settle(records, {i: f"FAILED {reason}" for i in range(len(echoes))})
    assert ended and septets(text) <= SMS_SEPTETS


def test_readings_are_spelled_short() -> None:
    readings = {"humidity_temp_c": 21.34, "humidity_pct": 45.2, "pressure_kpa": 101.3,
                "leak1": 0, "leak2": 1, "other": 3}  # fmt: skip
    assert replies.readings_text(readings) == "21.3C 45%RH 101.3kPa leak 0/1"
    assert replies.readings_text({}) == ""


@pytest.mark.parametrize(
    ("limit", "window_s", "until", "expected", "when"),
    [
        (10, 600, dt.datetime(2026, 11, 25, 6, 10, tzinfo=dt.UTC), "10 per 10 min", "06:10 UTC"),
        # rounded up: a text at 06:10:00 would still be held back
        (10, 600, dt.datetime(2026, 11, 25, 6, 10, 1, tzinfo=dt.UTC), "", "06:11 UTC"),
        (5, 3600, dt.datetime(2026, 11, 25, 7, 0, tzinfo=dt.UTC), "5 per 1 h", "07:00 UTC"),
        (5, 90, dt.datetime(2026, 11, 25, 6, 1, 30, tzinfo=dt.UTC), "5 per 90 s", "06:02 UTC"),
        (5, 2 * 86400, dt.datetime(2026, 11, 27, 6, 0, tzinfo=dt.UTC), "5 per 2 days",
         "2026-11-27 06:00 UTC"),
        # another time zone's clock is given in UTC
        (1, 60, dt.datetime(2026, 11, 25, 16, 1, tzinfo=dt.timezone(dt.timedelta(hours=10))),
         "1 per 1 min", "06:01 UTC"),
    ],
)  # fmt: skip
def test_the_rate_limit_notice_says_the_limit_and_when_in_utc(
    limit: int, window_s: int, until: dt.datetime, expected: str, when: str
) -> None:
    text = replies.rate_limit_notice(limit=limit, window_s=window_s, until=until, now=T0)
    assert text.endswith(f"texts are not answered until {when}.")
    assert f"({expected})" in text or not expected
    assert septets(text) <= SMS_SEPTETS


# -- the service --------------------------------------------------------------------------------


@pytest.fixture
def phone(glider: Vessel) -> str:
    authorised_number_authorise(number=PHONE, vessels=[glider], role="control", name="Skipper")
    return PHONE


def text_in(glider: Vessel, text: str, window: float = 30.0, at: dt.datetime = T0) -> SmsMessage:
    result = sms_handle_incoming(
        vessel=glider, number=PHONE, text=text, received_at=at, reply_window_s=window
    )
    return result.replies[0]


def outgoing(glider: Vessel) -> list[tuple[str, str]]:
    return [
        (m.status, m.text)
        for m in SmsMessage.objects.filter(vessel=glider, direction=Direction.OUT).order_by("pk")
    ]


def end(
    command: Command, *, ok: bool, detail: str = "", code: int | None = 0, reason: str = ""
) -> None:
    command_mark_sent(command=command, actor="test", now=T0)
    status = "done" if ok else "failed"
    command_complete(
        command=command,
        status=status,
        detail=detail or ACK_DETAIL,
        actor="test",
        now=T0,
        cc_code=code,
        cc_reason=reason,
    )


def test_a_command_reply_waits_and_says_ok_once_the_command_is_done(
    glider: Vessel, phone: str
) -> None:
    reply = text_in(glider, "#FHEAD 230")
    assert (reply.status, reply.due_at) == (SendStatus.WAITING, T0 + dt.timedelta(seconds=30))
    assert sms_replies_due(vessel=glider, now=T0) == 0  # still on its way
    end(Command.objects.get(), ok=True)
    assert sms_replies_due(vessel=glider, now=T0) == 1
    assert sms_replies_due(vessel=glider, now=T0) == 0  # released once
    assert outgoing(glider) == [("pending", "#FHEAD 230 OK")]


@pytest.mark.parametrize(
    "detail", [NAK_DETAIL.format(code=2, meaning="invalid data"), "C&C said no (code 2)"]
)
def test_a_nak_reply_names_the_reason_recorded_whatever_the_detail_says(
    glider: Vessel, phone: str, detail: str
) -> None:
    text_in(glider, "#FHEAD 230")
    end(Command.objects.get(), ok=False, detail=detail, code=2, reason="invalid data")
    sms_replies_due(vessel=glider, now=T0)
    assert outgoing(glider) == [("pending", "#FHEAD 230 FAILED invalid data")]


def test_a_failure_without_a_recorded_reason_says_its_detail_as_written(
    glider: Vessel, phone: str
) -> None:
    text_in(glider, "#FHEAD 230")
    end(Command.objects.get(), ok=False, detail=NO_ANSWER, code=None)
    sms_replies_due(vessel=glider, now=T0)
    assert outgoing(glider) == [("pending", "#FHEAD 230 FAILED no answer from the C&C box")]


def test_past_the_window_queued_goes_out_then_one_more_sms_when_it_ends(
    glider: Vessel, phone: str
) -> None:
    text_in(glider, "#STATUS; #FHEAD 230")
    assert sms_replies_due(vessel=glider, now=T0 + dt.timedelta(seconds=31)) == 1
    (status, text), (later_status, _) = outgoing(glider)
    assert status == "pending" and text.endswith("#FHEAD 230 QUEUED")
    assert later_status == "waiting"
    assert sms_replies_due(vessel=glider, now=T0 + dt.timedelta(hours=1)) == 0  # no window
    end(Command.objects.get(), ok=True)
    assert sms_replies_due(vessel=glider, now=T0 + dt.timedelta(hours=1)) == 1
    assert outgoing(glider)[1] == ("pending", "#FHEAD 230 OK")  # the commands only
    follow_up = SmsMessage.objects.filter(direction=Direction.OUT).order_by("pk").last()
    assert list(follow_up.commands.all()) == [Command.objects.get()]
    assert follow_up.reply_to == SmsMessage.objects.get(direction=Direction.IN)


def test_queries_and_errors_are_answered_at_once(glider: Vessel, phone: str) -> None:
    assert text_in(glider, "#FHEAD").status == SendStatus.PENDING
    assert text_in(glider, "#FHEAD 999", at=T0 + dt.timedelta(seconds=1)).status == "pending"


def test_without_a_window_the_reply_says_queued_at_once(glider: Vessel, phone: str) -> None:
    assert (text_in(glider, "#FHEAD 230", window=0).status, outgoing(glider)) == (
        SendStatus.PENDING,
        [("pending", "#FHEAD 230 QUEUED")],
    )


def test_a_held_reply_keeps_its_note_on_identical_commands_once_settled(
    glider: Vessel, phone: str
) -> None:
    text_in(glider, ";".join(["#HOLD"] * 12))
    end(Command.objects.get(), ok=True)  # one command, not twelve
    sms_replies_due(vessel=glider, now=T0)
    assert outgoing(glider) == [
        ("pending", "#HOLD OK (12 identical commands in this SMS taken once)")
    ]
