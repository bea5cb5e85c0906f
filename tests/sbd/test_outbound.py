"""Commands out as mobile-terminated messages: the compact form, the queue, the provider's MT
API (a real HTTP server on a local port standing in for it)."""

from __future__ import annotations

import datetime as dt
from typing import Any

import pytest
from django.utils import timezone

from commands.catalog import KINDS
from commands.models import Command
from commands.services import command_cancel, command_enqueue
from edge_client.contract import compact_command
from sbd.errors import SbdError
from sbd.models import Direction, SbdMessage, Status
from sbd.selectors import sbd_usage
from sbd.services import sbd_queue_command, sbd_send_command, sbd_send_queued
from sbd.transport import RockBlockMt, configured_transport
from tests.sbd.conftest import IMEI, MtEndpoint
from vessels.models import Vessel

pytestmark = pytest.mark.django_db


@pytest.fixture(autouse=True)
def _no_move_limit(settings: Any) -> None:
    settings.MOVE_TO_MAX_M = 0  # the vessels here have no fix to measure a move_to from


@pytest.fixture
def mt(settings: Any, mt_endpoint: MtEndpoint) -> MtEndpoint:
    settings.SBD_ROCKBLOCK_MT_URL = mt_endpoint.url
    settings.SBD_ROCKBLOCK_USERNAME = "shore@example.org"
    settings.SBD_ROCKBLOCK_PASSWORD = "s3cret"
    settings.SBD_MT_MAX_ATTEMPTS = 3
    return mt_endpoint


def later(seconds: float) -> dt.datetime:
    return timezone.now() + dt.timedelta(seconds=seconds)


def move_to(vessel: Vessel) -> Command:
    return command_enqueue(vessel=vessel, kind="move_to", params={"lat": -32.06, "lon": 115.75})


def test_every_kind_of_the_catalog_has_a_compact_form() -> None:
    assert set(KINDS) == {name for name, _ in compact_command.KINDS}


def test_a_command_goes_to_the_provider_in_the_compact_form(
    mt: MtEndpoint, sbd_vessel: Vessel
) -> None:
    command = move_to(sbd_vessel)
    message = sbd_send_command(command)
    assert message.status == Status.SENT and message.provider_ref == "5001"
    [form] = mt.posts
    assert form == {
        "imei": IMEI,
        "username": "shore@example.org",
        "password": "s3cret",
        "data": bytes(message.payload).hex(),
    }
    # What the boat reads out of it: the command by its uid.
    wire = compact_command.decode(bytes.fromhex(form["data"]))
    assert (wire.uid, wire.kind) == (str(command.uid), "move_to")
    assert wire.params == {"lat": -32.06, "lon": 115.75}
    stored = SbdMessage.objects.get()
    assert (stored.direction, stored.imei, stored.bytes, stored.attempts) == (
        Direction.OUT,
        IMEI,
        27,
        1,
    )
    assert stored.command == command and stored.sent_at is not None


def test_a_temporary_failure_stays_queued_and_the_next_pass_sends_it(
    mt: MtEndpoint, sbd_vessel: Vessel
) -> None:
    mt.answers = [(200, "FAILED,13,Insufficient credit"), (503, "busy")]
    message = sbd_send_command(move_to(sbd_vessel))
    message.refresh_from_db()
    assert message.status == Status.QUEUED and message.attempts == 1
    assert "13 Insufficient credit" in message.detail
    assert sbd_send_queued() == 0 and len(mt.posts) == 1  # not due yet: backing off
    assert sbd_send_queued(now=later(31)) == 0  # the 503
    assert sbd_send_queued(now=later(60)) == 0 and len(mt.posts) == 2  # next due at 90 s
    assert sbd_send_queued(now=later(91)) == 1
    message.refresh_from_db()
    assert (message.status, message.attempts, message.detail) == (Status.SENT, 3, "")
    assert len(mt.posts) == 3


def test_a_permanent_refusal_fails_the_message_at_once(mt: MtEndpoint, sbd_vessel: Vessel) -> None:
    mt.answers = [(200, "FAILED,11,No RockBLOCK with this IMEI found on your account")]
    message = sbd_send_command(move_to(sbd_vessel))
    message.refresh_from_db()
    assert message.status == Status.FAILED and "11 No RockBLOCK" in message.detail
    assert sbd_send_queued() == 0 and len(mt.posts) == 1


def test_tries_are_given_up_after_the_limit(mt: MtEndpoint, sbd_vessel: Vessel) -> None:
    mt.answers = [(500, "")] * 5
    command = move_to(sbd_vessel)
    message = sbd_send_command(command)
    for seconds in (31, 91, 211, 451):
        sbd_send_queued(now=later(seconds))
    message.refresh_from_db()
    assert (message.status, message.attempts) == (Status.FAILED, 3)
    assert len(mt.posts) == 3
    # The command's history says so: a relay that gave up.
    [note] = command.events.filter(actor="shore").values_list("detail", flat=True)
    assert note == "Iridium SBD gave up after 3 tries: the SBD provider answered HTTP 500"


def test_a_message_whose_command_moved_on_is_not_sent(mt: MtEndpoint, sbd_vessel: Vessel) -> None:
    """Cancelled (or expired, or taken over HTTP) while RockBLOCK was down: never sent after."""
    mt.answers = [(503, "busy")]
    command = move_to(sbd_vessel)
    message = sbd_send_command(command)
    command_cancel(command=command, actor="alice")
    assert sbd_send_queued(now=later(31)) == 0
    message.refresh_from_db()
    assert (message.status, message.detail) == (
        Status.FAILED,
        "not sent: the command is cancelled now",
    )
    assert len(mt.posts) == 1


def test_without_an_account_nothing_is_sent_and_the_message_waits(
    settings: Any, mt_endpoint: MtEndpoint, sbd_vessel: Vessel
) -> None:
    settings.SBD_ROCKBLOCK_USERNAME = ""
    assert configured_transport() is None
    message = sbd_send_command(move_to(sbd_vessel))
    assert message.status == Status.QUEUED and message.attempts == 0
    assert sbd_send_queued() == 0 and mt_endpoint.posts == []


def test_no_answer_in_time_is_a_temporary_failure(sbd_vessel: Vessel) -> None:
    import socket

    silent = socket.socket()
    silent.bind(("127.0.0.1", 0))
    silent.listen(1)  # accepts, never answers
    try:
        url = f"http://127.0.0.1:{silent.getsockname()[1]}/MT"
        transport = RockBlockMt(url=url, username="u", password="p", timeout_s=0.3)
        message = sbd_send_command(move_to(sbd_vessel), transport=transport)
    finally:
        silent.close()
    message.refresh_from_db()
    assert message.status == Status.QUEUED and "within 0.3 s" in message.detail


def test_a_vessel_without_an_imei_or_a_command_too_long_cannot_go_by_sbd(
    sbd_vessel: Vessel, vessel_a: Vessel
) -> None:
    with pytest.raises(SbdError, match="no Iridium IMEI"):
        sbd_queue_command(command=move_to(vessel_a))
    items = [{"lat": -32.0 - i / 1000, "lon": 115.7, "hold_s": 5} for i in range(40)]
    mission = command_enqueue(vessel=sbd_vessel, kind="mission", params={"items": items})
    with pytest.raises(SbdError, match="mission cannot go by SBD.*at most 270"):
        sbd_queue_command(command=mission)
    assert not SbdMessage.objects.exists()


def test_usage_counts_messages_bytes_and_credits(
    mt: MtEndpoint, sbd_vessel: Vessel, provider: Any
) -> None:
    from django.test import Client

    since = dt.datetime.now(dt.UTC) - dt.timedelta(hours=1)
    Client().post("/api/v1/sbd/rockblock/", provider.delivery(b"\x00" * 60))  # undecodable
    sbd_send_command(move_to(sbd_vessel))
    mt.answers = [(200, "FAILED,15,Data too long")]
    sbd_send_command(command_enqueue(vessel=sbd_vessel, kind="hold", params={}))
    usage = sbd_usage(vessel_id=sbd_vessel.pk, since=since)
    assert usage == {
        "in": {"messages": 1, "bytes": 60, "credits": 2},
        "out": {"messages": 1, "bytes": 27, "credits": 1},  # the failed one cost nothing
    }


def test_the_management_command_sends_the_queue(
    mt: MtEndpoint, sbd_vessel: Vessel, settings: Any
) -> None:
    from io import StringIO

    from django.core.management import call_command

    sbd_queue_command(command=move_to(sbd_vessel))
    out = StringIO()
    call_command("sbd_send_queued", stdout=out)
    assert out.getvalue().strip() == "sent 1" and len(mt.posts) == 1
    settings.SBD_ROCKBLOCK_USERNAME = ""
    err = StringIO()
    call_command("sbd_send_queued", stderr=err)
    assert "SBD_ROCKBLOCK_USERNAME" in err.getvalue()
