"""The SMS service (sms/services/): authorisation personas, duplicates, rate limits, commands,
queries and #STATUS answered from the vessel's known state, the outgoing queue."""

from __future__ import annotations

import datetime as dt
from typing import Any

import pytest
from hypothesis import HealthCheck, example, given
from hypothesis import settings as hypothesis_settings
from hypothesis import strategies as st

from commands.models import Command, CommandEvent
from commands.services import command_ack, command_claim_open, command_enqueue
from sms.errors import InvalidNumber, NumberNotFound
from sms.language import NOT_ENABLED
from sms.models import AuthorisedNumber, Outcome, SendStatus, SmsMessage
from sms.services import (
    authorised_number_authorise,
    authorised_number_deauthorise,
    number_normalise,
    sms_handle_incoming,
    sms_mark_failed,
    sms_mark_sent,
    sms_outgoing_pending,
)
from telemetry.services import fix_ingest
from tests.sms.test_language import table_with_enabled, typeable_sms
from tests.support import BASE, iso
from vessels.models import Vessel
from vessels.services import vessel_create

SKIPPER = "+61412345678"  # control
WATCHER = "+61498765432"  # query only
STRANGER = "+61400000001"


@pytest.fixture
def other_glider(db: None) -> Vessel:
    return vessel_create(slug="glider-2", name="Wave Glider 2", kind="wave_glider")


@pytest.fixture
def skipper(glider: Vessel) -> AuthorisedNumber:
    return authorised_number_authorise(
        number="0412 345 678", vessels=[glider], role="control", name="Skipper"
    )


@pytest.fixture
def watcher(glider: Vessel) -> AuthorisedNumber:
    return authorised_number_authorise(
        number=WATCHER, vessels=[glider], role="query", name="Watcher"
    )


def send(vessel: Vessel, text: str, number: str = SKIPPER, **kwargs: Any) -> Any:
    kwargs.setdefault("received_at", BASE)
    return sms_handle_incoming(vessel=vessel, number=number, text=text, **kwargs)


# --- numbers ---


@pytest.mark.parametrize(
    "written",
    ["+61412345678", "+61 412 345 678", "+61-412-345-678", "0412 345 678", "0412-345-678",
     "(0412) 345678", "0011 61 412 345 678"],
)  # fmt: skip
def test_one_number_in_national_and_international_forms_matches_one_entry(
    glider: Vessel, skipper: AuthorisedNumber, written: str
) -> None:
    assert skipper.number == SKIPPER
    result = send(glider, "#FHEAD 230", number=written)
    assert result.outcome == Outcome.ACCEPTED
    assert result.message.authorised_number == skipper
    assert result.reply_texts == ["#FHEAD 230 QUEUED"]


def test_authorising_the_same_number_again_updates_its_one_entry(
    glider: Vessel, other_glider: Vessel, skipper: AuthorisedNumber
) -> None:
    again = authorised_number_authorise(
        number="+61 412 345 678", vessels=[other_glider], role="query", name="Skipper B"
    )
    assert again.pk == skipper.pk
    assert AuthorisedNumber.objects.count() == 1
    assert list(again.vessels.all()) == [other_glider]
    assert again.role == "query"


@pytest.mark.parametrize("bad", ["", "hello", "123", "+99 1234", "0412 345 67"])
def test_a_number_that_is_not_a_phone_number_is_refused(bad: str) -> None:
    with pytest.raises(InvalidNumber):
        number_normalise(raw=bad)


def test_national_numbers_are_read_in_the_default_region(settings: Any) -> None:
    settings.SMS_DEFAULT_REGION = "GB"
    assert number_normalise(raw="07911 123456") == "+447911123456"
    assert number_normalise(raw="+61 412 345 678") == SKIPPER


# --- authorisation personas: logged, never answered ---


def test_a_stranger_is_logged_and_learns_nothing(glider: Vessel, skipper: AuthorisedNumber) -> None:
    result = send(glider, "#FHEAD 230", number=STRANGER)
    assert result.outcome == Outcome.STRANGER
    assert result.replies == () and result.commands == ()
    message = SmsMessage.objects.get()
    assert (message.number_e164, message.authorised, message.text) == (
        STRANGER,
        False,
        "#FHEAD 230",
    )
    assert not Command.objects.exists()


def test_an_alphanumeric_sender_is_a_stranger(glider: Vessel) -> None:
    result = send(glider, "#STATUS", number="Telstra")
    assert (result.outcome, result.message.number, result.message.number_e164) == (
        Outcome.STRANGER,
        "Telstra",
        "",
    )
    assert result.replies == ()


def test_an_inactive_number_is_refused_without_a_reply(
    glider: Vessel, skipper: AuthorisedNumber
) -> None:
    authorised_number_deauthorise(number=SKIPPER)
    result = send(glider, "#STATUS")
    assert (result.outcome, result.message.detail) == (Outcome.REFUSED, "number inactive")
    assert result.replies == ()
    assert SmsMessage.objects.count() == 1


def test_an_expired_number_is_refused_without_a_reply(glider: Vessel) -> None:
    authorised_number_authorise(
        number=SKIPPER, vessels=[glider], role="control", name="Temp", expires_at=BASE
    )
    result = send(glider, "#FHEAD 230", received_at=BASE + dt.timedelta(seconds=1))
    assert result.outcome == Outcome.REFUSED
    assert result.message.detail.startswith("authorisation expired")
    assert result.replies == () and not Command.objects.exists()
    before = send(glider, "#FHEAD 230", received_at=BASE - dt.timedelta(seconds=1))
    assert before.outcome == Outcome.ACCEPTED


def test_a_number_of_another_vessel_is_refused_without_a_reply(
    other_glider: Vessel, skipper: AuthorisedNumber
) -> None:
    result = send(other_glider, "#FHEAD 230")
    assert (result.outcome, result.message.detail) == (
        Outcome.REFUSED,
        "not authorised for glider-2",
    )
    assert result.replies == () and not Command.objects.exists()


@pytest.mark.parametrize(
    "text", ["#FHEAD 230", "#HOLD", "#STATUS; #LIGHT ON", "#FHEAD 999", "#HOLD 1"]
)
def test_a_query_role_number_trying_to_command_is_refused_without_a_reply(
    glider: Vessel, watcher: AuthorisedNumber, text: str
) -> None:
    result = send(glider, text, number=WATCHER)
    assert (result.outcome, result.message.detail) == (
        Outcome.REFUSED,
        "query role: may not command",
    )
    assert result.replies == () and not Command.objects.exists()


def test_a_query_role_number_may_ask(glider: Vessel, watcher: AuthorisedNumber) -> None:
    result = send(glider, "#LIGHT\n#STATUS\n#HELP", number=WATCHER)
    assert result.outcome == Outcome.ACCEPTED
    assert result.reply_texts[0].startswith("#LIGHT unknown; #STATUS pos unknown")


# --- commands ---


def test_a_command_is_queued_with_source_sms_and_the_number_as_creator(
    glider: Vessel, skipper: AuthorisedNumber
) -> None:
    result = send(glider, "#fhead 230")
    command = Command.objects.get()
    assert (command.kind, command.params, command.source, command.created_by) == (
        "fhead",
        {"bearing": 230},
        "sms",
        SKIPPER,
    )
    assert CommandEvent.objects.get(command=command).actor == SKIPPER
    assert list(result.message.commands.all()) == [command]
    reply = result.replies[0]
    assert (reply.direction, reply.number, reply.status, reply.reply_to) == (
        "out",
        SKIPPER,
        SendStatus.PENDING,
        result.message,
    )
    assert list(reply.commands.all()) == [command]
    assert result.message.parsed == [
        {"kind": "command", "text": "#FHEAD 230", "command": "fhead", "params": {"bearing": 230}}
    ]


def test_table_4_through_the_service_with_the_shipped_table(
    glider: Vessel, skipper: AuthorisedNumber
) -> None:
    texts = ["#FHEAD 230", "#HOLD", "#WAYPOINT 1 -32.0380 115.3325", "#HOLDWP 1", "#FSEQ 1 1 4"]
    replies = [send(glider, t, received_at=BASE + dt.timedelta(minutes=i)).reply_texts[0]
               for i, t in enumerate(texts)]  # fmt: skip
    assert replies == [
        "#FHEAD 230 QUEUED",
        "#HOLD QUEUED",
        "#WAYPOINT 1 -32.0380 115.3325 QUEUED",
        f"#HOLDWP 1 ERR {NOT_ENABLED}",
        f"#FSEQ 1 1 4 ERR {NOT_ENABLED}",
    ]
    assert list(Command.objects.order_by("pk").values_list("kind", flat=True)) == [
        "fhead",
        "hold",
        "waypoint",
    ]
    assert SmsMessage.objects.filter(direction="in", outcome=Outcome.ERROR).count() == 2


def test_an_enabled_table_entry_lets_the_command_through(
    glider: Vessel, skipper: AuthorisedNumber
) -> None:
    result = send(glider, "#FSEQ 1 1 4", table=table_with_enabled("fseq"))
    assert result.reply_texts == ["#FSEQ 1 1 4 QUEUED"]
    assert Command.objects.get().params == {"target": 1, "begin": 1, "end": 4}


def test_two_navigation_orders_in_one_sms_say_which_one_stands(
    glider: Vessel, skipper: AuthorisedNumber
) -> None:
    result = send(glider, "#HOLD; #FHEAD 230; #LIGHT ON")
    assert result.reply_texts == ["#HOLD SUPERSEDED; #FHEAD 230 QUEUED; #LIGHT ON QUEUED"]
    assert len(result.commands) == 3


def test_an_inactive_vessel_answers_the_command_with_the_reason(
    glider: Vessel, skipper: AuthorisedNumber
) -> None:
    Vessel.objects.filter(pk=glider.pk).update(active=False)
    glider.refresh_from_db()
    result = send(glider, "#FHEAD 230")
    assert result.reply_texts == ["#FHEAD 230 ERR vessel glider is not active"]
    assert result.outcome == Outcome.ERROR


# --- queries and #STATUS from the known state ---


def test_a_query_answers_from_the_newest_command_the_vessel_has(
    glider: Vessel, skipper: AuthorisedNumber
) -> None:
    assert send(glider, "#LIGHT").reply_texts == ["#LIGHT unknown"]
    command_enqueue(vessel=glider, kind="light", params={"state": "on"})
    assert send(glider, "#LIGHT", received_at=BASE + dt.timedelta(minutes=1)).reply_texts == [
        "#LIGHT unknown, ON QUEUED"
    ]
    (sent,) = command_claim_open(vessel=glider)
    assert send(glider, "#LIGHT", received_at=BASE + dt.timedelta(minutes=2)).reply_texts == [
        "#LIGHT ON (sent)"
    ]
    command_ack(vessel=glider, uid=sent.uid, status="done")
    assert send(glider, "#LIGHT", received_at=BASE + dt.timedelta(minutes=3)).reply_texts == [
        "#LIGHT ON"
    ]


def test_status_says_unknown_when_nothing_is_known(
    glider: Vessel, skipper: AuthorisedNumber
) -> None:
    assert send(glider, "#STATUS").reply_texts == [
        "#STATUS pos unknown, batt unknown, nav unknown, 0 pending"
    ]


def test_status_gives_position_age_battery_navigation_and_pending(
    glider: Vessel, skipper: AuthorisedNumber
) -> None:
    fix_ingest(
        vessel=glider,
        records=[{"time": iso(BASE), "lat": -32.038, "lon": 115.3325, "battery_v": 12.34}],
    )
    send(glider, "#FHEAD 230; #LIGHT ON", received_at=BASE + dt.timedelta(minutes=1))
    result = send(glider, "#status", received_at=BASE + dt.timedelta(minutes=12))
    assert result.reply_texts == [
        "#STATUS pos -32.0380 115.3325 12m ago, batt 12.3V, nav #FHEAD 230 queued, 2 pending"
    ]


# --- duplicates and rate limits ---


def test_the_same_delivery_twice_is_handled_once(glider: Vessel, skipper: AuthorisedNumber) -> None:
    stamp = BASE - dt.timedelta(seconds=30)
    first = send(glider, "#FHEAD 230", modem_timestamp=stamp)
    again = send(
        glider, "#FHEAD 230", modem_timestamp=stamp, received_at=BASE + dt.timedelta(hours=1)
    )
    assert again.duplicate and not first.duplicate
    assert again.message.pk == first.message.pk
    assert again.reply_texts == first.reply_texts == ["#FHEAD 230 QUEUED"]
    assert [c.pk for c in again.commands] == [c.pk for c in first.commands]
    assert Command.objects.count() == 1
    assert SmsMessage.objects.count() == 2  # the SMS and its one reply


def test_the_same_text_at_another_modem_time_is_a_new_message(
    glider: Vessel, skipper: AuthorisedNumber
) -> None:
    send(glider, "#LIGHT ON", modem_timestamp=BASE)
    second = send(glider, "#LIGHT ON", modem_timestamp=BASE + dt.timedelta(seconds=1))
    assert not second.duplicate
    assert Command.objects.count() == 2


def test_a_stranger_delivered_twice_is_logged_once(glider: Vessel) -> None:
    send(glider, "hi", number=STRANGER, modem_timestamp=BASE)
    assert send(glider, "hi", number=STRANGER, modem_timestamp=BASE).duplicate
    assert SmsMessage.objects.count() == 1


def test_a_burst_from_one_number_is_rate_limited(
    glider: Vessel, skipper: AuthorisedNumber, settings: Any
) -> None:
    settings.SMS_RATE_LIMIT, settings.SMS_RATE_WINDOW_S = 3, 60
    results = [send(glider, f"#FHEAD {i}", received_at=BASE + dt.timedelta(seconds=i))
               for i in range(5)]  # fmt: skip
    assert [r.outcome for r in results] == [Outcome.ACCEPTED] * 3 + [Outcome.RATE_LIMITED] * 2
    assert Command.objects.count() == 3
    # The first 3 came at 08:00:00, :01 and :02: the oldest leaves the window at 08:01:00.
    assert results[3].message.detail == (
        "more than 3 in 60 s; answered again from 2026-11-23 08:01:00 UTC"
    )
    later = send(glider, "#FHEAD 99", received_at=BASE + dt.timedelta(seconds=60))
    assert later.outcome == Outcome.ACCEPTED


def test_a_rate_limited_number_is_told_once_when_it_is_answered_again(
    glider: Vessel, skipper: AuthorisedNumber, settings: Any
) -> None:
    settings.SMS_RATE_LIMIT, settings.SMS_RATE_WINDOW_S = 3, 600
    at = [BASE + dt.timedelta(seconds=s) for s in (0, 1, 90, 100, 200, 599, 600)]
    results = [send(glider, "#STATUS", received_at=t, modem_timestamp=t) for t in at]
    assert [r.outcome for r in results] == ["accepted"] * 3 + ["rate_limited"] * 3 + ["accepted"]
    notice = results[3].replies[0]
    assert (
        notice.text == "SMS limit reached (3 per 10 min): texts are not answered until 08:10 UTC."
    )
    assert (notice.direction, notice.status, notice.number) == ("out", "pending", SKIPPER)
    assert notice.reply_to == results[3].message
    assert sms_outgoing_pending(vessel=glider)[-2:] == [notice, results[6].replies[0]]
    # Silence for the rest of the block: texts held back neither answer nor move it on.
    assert [r.replies for r in results[4:6]] == [(), ()]
    # A re-delivery of the text that got the notice gets nothing new.
    again = send(glider, "#STATUS", received_at=at[3], modem_timestamp=at[3])
    assert again.duplicate and again.replies == (notice,)
    assert SmsMessage.objects.filter(text__startswith="SMS limit").count() == 1


def test_a_new_block_gets_a_new_notice(
    glider: Vessel, skipper: AuthorisedNumber, settings: Any
) -> None:
    settings.SMS_RATE_LIMIT, settings.SMS_RATE_WINDOW_S = 1, 60
    texts = [send(glider, "#STATUS", received_at=BASE + dt.timedelta(seconds=s)).reply_texts
             for s in (0, 10, 20, 65, 70, 75)]  # fmt: skip
    assert texts[1] == ["SMS limit reached (1 per 1 min): texts are not answered until 08:01 UTC."]
    assert texts[2] == [] and texts[5] == []
    assert texts[4] == ["SMS limit reached (1 per 1 min): texts are not answered until 08:03 UTC."]


def test_sms_inject_shows_the_notice_but_never_sends_it(
    glider: Vessel, skipper: AuthorisedNumber, settings: Any
) -> None:
    settings.SMS_RATE_LIMIT = 1
    send(glider, "#STATUS", send_replies=False)
    result = send(glider, "#STATUS", send_replies=False, received_at=BASE + dt.timedelta(seconds=1))
    assert result.replies[0].status == SendStatus.NOT_SENT
    assert sms_outgoing_pending(vessel=glider) == []


def test_only_an_authorised_number_is_told_of_the_limit(
    glider: Vessel, skipper: AuthorisedNumber, settings: Any
) -> None:
    settings.SMS_RATE_LIMIT = 1
    for s in range(3):
        send(glider, "#STATUS", number=STRANGER, received_at=BASE + dt.timedelta(seconds=s))
    assert not SmsMessage.objects.filter(direction="out").exists()


def test_a_rate_limit_of_zero_is_off(
    glider: Vessel, skipper: AuthorisedNumber, settings: Any
) -> None:
    settings.SMS_RATE_LIMIT = 0
    assert all(send(glider, "#STATUS").outcome == Outcome.ACCEPTED for _ in range(15))


def test_identical_commands_in_one_sms_queue_one_command_none_superseded(
    glider: Vessel, skipper: AuthorisedNumber
) -> None:
    result = send(glider, ";".join(["#HOLD"] * 12))  # issue 16 §6: made 10, 9 superseded
    (command,) = Command.objects.all()
    assert (command.kind, command.status) == ("hold", "queued")
    assert result.commands == (command,)
    assert result.reply_texts == ["#HOLD QUEUED (12 identical commands in this SMS taken once)"]
    result.message.refresh_from_db()
    assert result.message.parsed == [
        {"kind": "command", "text": "#HOLD", "command": "hold", "repeats": 12}
    ]
    assert not CommandEvent.objects.filter(to_status="superseded").exists()


# --- the outgoing queue the modem loop sends ---


def test_pending_replies_are_sent_or_failed_once(glider: Vessel, skipper: AuthorisedNumber) -> None:
    first = send(glider, "#LIGHT ON").replies[0]
    second = send(glider, "#LIGHT OFF", received_at=BASE + dt.timedelta(seconds=5)).replies[0]
    assert sms_outgoing_pending(vessel=glider) == [first, second]
    later = BASE + dt.timedelta(minutes=1)
    assert sms_mark_sent(message=first, reference=17, now=later)
    assert not sms_mark_sent(message=first, reference=18, now=later)  # already sent
    assert sms_mark_failed(message=second, reason="+CMS ERROR: 38", now=later)
    assert sms_outgoing_pending(vessel=glider) == []
    first.refresh_from_db()
    second.refresh_from_db()
    assert (first.status, first.reference, first.sent_at) == ("sent", "17", later)
    assert (second.status, second.status_detail) == ("failed", "+CMS ERROR: 38")


def test_replies_shown_but_not_to_be_sent_never_reach_the_modem(
    glider: Vessel, skipper: AuthorisedNumber
) -> None:
    result = send(glider, "#STATUS", send_replies=False)
    assert result.replies[0].status == SendStatus.NOT_SENT
    assert sms_outgoing_pending(vessel=glider) == []


def test_deauthorising_an_unknown_number_says_so(db: None) -> None:
    with pytest.raises(NumberNotFound, match=r"\+61400000001 is not an authorised number"):
        authorised_number_deauthorise(number=STRANGER)


def test_text_the_database_cannot_hold_is_stored_with_replacement_characters(
    glider: Vessel, skipper: AuthorisedNumber
) -> None:
    result = send(glider, "#FHEAD 230\x00\ud800")
    result.message.refresh_from_db()
    assert result.message.text == "#FHEAD 230\ufffd\ufffd"


@hypothesis_settings(
    max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(
    text=st.text(max_size=200)
    | st.text(alphabet=st.characters(min_codepoint=0, max_codepoint=0xFFFF), max_size=40)
    | st.lists(
        st.sampled_from(
            [
                "#FHEAD 230",
                "#LIGHT",
                "#STATUS",
                "#FSEQ 1 1 4",
                "#HOLD 1",
                "#WAYPOINT 1 32 02.28S 115 19.95E",
                "#HELP",
                "x",
            ]
        ),
        max_size=12,
    ).map("\n".join)  # fmt: skip
)
@example(text="#FHEAD 230\x00\ud800")
def test_any_text_from_an_authorised_number_is_answered_in_one_sms_or_logged(
    glider: Vessel, skipper: AuthorisedNumber, settings: Any, text: str
) -> None:
    settings.SMS_RATE_LIMIT = 0
    result = send(glider, text)
    assert result.outcome in (Outcome.ACCEPTED, Outcome.ERROR)
    (reply,) = result.replies
    assert typeable_sms(reply.text)
    reply.refresh_from_db()
    result.message.refresh_from_db()
    assert result.message.parsed
