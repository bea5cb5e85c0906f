"""What one SMS costs the database, pinned (bench.sms measures the time; this counts work):
the duplicate check, the sender, the rate count, the command's few writes, the SMS and its
reply with their links, and nothing read back that was just written."""

from __future__ import annotations

from django.db import connection
from django.test.utils import CaptureQueriesContext

from commands.lifecycle import Status
from commands.models import Command
from sms.models import AuthorisedNumber, Outcome
from sms.services import authorised_number_authorise, sms_handle_incoming
from tests.commands.test_enqueue_statements import statements
from tests.support import BASE
from vessels.models import Vessel

SKIPPER = "+61412345678"
# Reads: the earlier delivery, the sender's entry, the rate count. Writes: the command, the
# superseded ones, their events, the version bump, the audit entry (command.queued by the
# phone), the SMS, its reply, the links.
ONE_NAVIGATION_COMMAND = 11
ADVISORY_LOCK = 1  # PostgreSQL only: navigation enqueues take turns per vessel


def authorise(glider: Vessel) -> AuthorisedNumber:
    return authorised_number_authorise(
        number=SKIPPER, vessels=[glider], role="control", name="Skipper"
    )


def send(glider: Vessel, text: str, seconds: int) -> object:
    when = BASE.replace(second=seconds)
    return sms_handle_incoming(
        vessel=glider, number=SKIPPER, text=text, received_at=when, modem_timestamp=when
    )


def test_one_sms_with_one_navigation_command_takes_eleven_statements(glider: Vessel) -> None:
    authorise(glider)
    send(glider, "#HOLD", 1)
    with CaptureQueriesContext(connection) as context:
        result = send(glider, "#FHEAD 230", 2)
    assert result.outcome == Outcome.ACCEPTED
    assert result.reply_texts == ["#FHEAD 230 QUEUED"]
    lock = ADVISORY_LOCK if connection.vendor == "postgresql" else 0
    assert len(statements(context)) == ONE_NAVIGATION_COMMAND + lock
    assert Command.objects.get(kind="hold").status == Status.SUPERSEDED


def test_two_navigation_orders_in_one_sms_say_which_was_replaced_without_reading_back(
    glider: Vessel,
) -> None:
    authorise(glider)
    with CaptureQueriesContext(connection) as context:
        result = send(glider, "#HOLD; #FHEAD 230", 1)
    assert result.reply_texts == ["#HOLD SUPERSEDED; #FHEAD 230 QUEUED"]
    hold, fhead = result.commands
    assert hold.status == Status.SUPERSEDED and fhead.status == Status.QUEUED
    # What the reply says is what the database holds.
    assert Command.objects.get(pk=hold.pk).status == Status.SUPERSEDED
    assert Command.objects.get(pk=fhead.pk).status == Status.QUEUED
    assert not any('SELECT "commands_command"' in sql for sql in statements(context))
