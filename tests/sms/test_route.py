"""The shore's SMS route (sms.services.route.sms_send_command): a command texted to its glider
through the shore's SMS sender (the alerts' modem, here the modem simulator through the real
driver; or an HTTP gateway, here a local server), logged, and counted once, as sent."""

from __future__ import annotations

import datetime as dt
from collections.abc import Iterator
from typing import Any

import pytest
from django.utils import timezone

from alerts.notify.registry import sms_sender_from_settings
from alerts.notify.sms import ModemSender
from commands.models import Command
from commands.services import command_enqueue
from links.models import LinkDay
from sms.command_text import read_reference, render, split_reference, verified_uid
from sms.errors import NotSayable, RouteNotConfigured
from sms.gsm7 import on_air
from sms.models import Direction, SendStatus, SmsMessage
from sms.modem import ModemConfig
from sms.modem.simulator import ModemServer, SimulatedModem
from sms.services import sms_log_upload, sms_send_command
from sms.services.route import signing_key_hash
from tests.alerts.notify.conftest import Receiver, receiver  # noqa: F401 (a fixture)
from vessels.models import Vessel, VesselKey
from vessels.services import vessel_key_issue, vessel_key_revoke

pytestmark = pytest.mark.django_db

GLIDER_PHONE = "+61400000077"
SHORE_PHONE = "+61400000001"


@pytest.fixture
def texted_glider(glider: Vessel) -> Vessel:
    glider.sms_number = GLIDER_PHONE
    glider.save(update_fields=["sms_number"])
    vessel_key_issue(vessel=glider, label="shore link")
    return glider


def key_hash(vessel: Vessel) -> str:
    """The hash of the vessel's one key (the texted glider's)."""
    return VesselKey.objects.get(vessel=vessel).key_hash


@pytest.fixture
def sim() -> Iterator[tuple[SimulatedModem, ModemServer]]:
    modem = SimulatedModem()
    with ModemServer(modem, "tcp:0") as server:
        yield modem, server


def fast(url: str) -> ModemConfig:
    return ModemConfig(url, command_timeout_s=1, send_timeout_s=2, wake_timeout_s=0.3,
                       settle_s=0.05, relist_interval_s=None)  # fmt: skip


def fhead(vessel: Vessel, bearing: int = 230) -> Command:
    return command_enqueue(vessel=vessel, kind="fhead", params={"bearing": bearing},
                           created_by="operator")  # fmt: skip


def sms_row(vessel: Vessel) -> LinkDay | None:
    return LinkDay.objects.filter(vessel=vessel, transport="sms").first()


def test_a_command_goes_through_the_modem_logged_and_counted_once(texted_glider, sim):
    modem, server = sim
    command = fhead(texted_glider)
    sender = ModemSender(fast(server.url))
    now = timezone.now()
    try:
        message = sms_send_command(command, sender=sender, now=now)
    finally:
        sender.close()
    ((number, text, reference),) = [(s.number, s.text, s.reference) for s in modem.sent]
    signed = key_hash(texted_glider)
    assert number == GLIDER_PHONE and text == render("fhead", {"bearing": 230}, command.uid, signed)
    assert text.startswith("#FHEAD 230 ref:")
    assert verified_uid("#FHEAD 230", text.split()[-1], signed) == command.uid
    message.refresh_from_db()
    assert (message.direction, message.status, message.number) == ("out", "sent", GLIDER_PHONE)
    assert (message.text, message.reference, message.sent_at) == (text, str(reference), now)
    assert list(message.commands.all()) == [command]
    assert message.parsed == [{"route": "sms", "command": "fhead", "uid": str(command.uid)}]
    row = sms_row(texted_glider)
    assert (row.messages_out, row.bytes_out, row.credits) == (1, on_air(text)[0], 1)
    assert (row.messages_in, row.last_contact_at) == (0, None)  # sending to it is not contact
    assert Command.objects.get(pk=command.pk).status == "queued"  # the glider's ack moves it on


def test_the_configured_gateway_sends_it(texted_glider, gateway, settings):
    settings.ALERTS_SMS_MODEM_URL, settings.ALERTS_SMS_GATEWAY_URL = "", gateway.url
    settings.ALERTS_SMS_GATEWAY_TOKEN = "gw-token"
    command = command_enqueue(vessel=texted_glider, kind="waypoint",
                              params={"index": 1, "lat": -32.038, "lon": 115.3325})  # fmt: skip
    message = sms_send_command(command, sender=sms_sender_from_settings())
    [post] = gateway.received
    assert post.headers["Authorization"] == "Bearer gw-token"
    assert post.json() == {"to": GLIDER_PHONE, "text": message.text}
    assert message.text.startswith("#WAYPOINT 1 -32.038 115.3325 ref:")
    assert message.status == SendStatus.SENT and message.reference == ""
    assert sms_row(texted_glider).messages_out == 1


@pytest.mark.parametrize(("answer", "reason"), [(401, "answered 401"), (503, "answered 503")])
def test_a_gateway_refusal_is_logged_failed_with_the_reason_not_raised_nor_counted(
    texted_glider, gateway, settings, answer, reason, caplog
):
    settings.ALERTS_SMS_MODEM_URL, settings.ALERTS_SMS_GATEWAY_URL = "", gateway.url
    gateway.answers = [answer]
    command = fhead(texted_glider)
    message = sms_send_command(command, sender=sms_sender_from_settings())
    stored = SmsMessage.objects.get(pk=message.pk)
    assert stored.status == SendStatus.FAILED and reason in stored.status_detail
    assert stored.status_detail.startswith("not sent: ") and stored.sent_at is None
    assert sms_row(texted_glider) is None
    assert any(str(command.uid) in r.getMessage() and reason in r.getMessage()
               for r in caplog.records if r.levelname == "WARNING")  # fmt: skip


def test_a_modem_that_refuses_or_is_not_there_fails_the_sms_not_the_caller(
    texted_glider, sim, tmp_path
):
    modem, server = sim
    modem.faults.send_error = 21  # short message transfer rejected
    sender = ModemSender(fast(server.url))
    try:
        refused = sms_send_command(fhead(texted_glider, 10), sender=sender)
    finally:
        sender.close()
    assert refused.status == SendStatus.FAILED and "21" in refused.status_detail
    missing = sms_send_command(
        fhead(texted_glider, 20), sender=ModemSender(fast(str(tmp_path / "ttyUSB9")))
    )
    assert missing.status == SendStatus.FAILED and "cannot open" in missing.status_detail
    assert modem.sent == [] and sms_row(texted_glider) is None


def test_what_cannot_go_is_refused_by_name_before_anything_is_written(
    glider, texted_glider, vessel_a, settings, sim
):
    _modem, server = sim
    sender = ModemSender(fast(server.url))
    mission = command_enqueue(vessel=texted_glider, kind="hold", params={})
    Command.objects.filter(pk=mission.pk).update(kind="mission", params={"items": []})
    mission.refresh_from_db()
    with pytest.raises(NotSayable, match="mission: a Wave Glider has no SMS word"):
        sms_send_command(mission, sender=sender)
    Vessel.objects.filter(pk=glider.pk).update(sms_number="")
    with pytest.raises(RouteNotConfigured, match="Wave Glider has no SMS number"):
        sms_send_command(fhead(Vessel.objects.get(pk=glider.pk)), sender=sender)
    boat = command_enqueue(vessel=vessel_a, kind="hold", params={})
    with pytest.raises(RouteNotConfigured, match="not a Wave Glider"):
        sms_send_command(boat, sender=sender)
    sender.close()
    assert not SmsMessage.objects.exists() and not LinkDay.objects.exists()


def test_the_gliders_log_of_a_texted_command_is_not_counted_again(texted_glider, sim):
    """The glider logs the shore's SMS as received and uploads its log: that SMS was counted
    when the shore sent it; the glider's own texts are counted as before."""
    _modem, server = sim
    sender = ModemSender(fast(server.url))
    sent = sms_send_command(fhead(texted_glider), sender=sender)
    failed_cmd = fhead(texted_glider, 99)
    sender.close()
    at = timezone.now().replace(microsecond=0)
    never_sent = render("fhead", {"bearing": 99}, failed_cmd.uid, key_hash(texted_glider))
    entries = [
        upload_entry("g1", sent.text, at),
        upload_entry("g2", "#STATUS", at + dt.timedelta(seconds=1)),
        upload_entry("g3", never_sent, at + dt.timedelta(seconds=2)),  # the shore never sent it
    ]
    answer = sms_log_upload(vessel=texted_glider, entries=entries)
    assert answer.accepted == 3
    row = sms_row(texted_glider)
    assert (row.messages_out, row.credits) == (1, 3)  # the shore's SMS once, then #STATUS, g3
    assert row.messages_in == 2 and row.bytes_in == on_air("#STATUS")[0] + on_air(never_sent)[0]
    assert row.last_contact_at == at + dt.timedelta(seconds=2)  # still heard from
    assert read_reference(split_reference(sent.text)[1]).uid == sent.commands.get().uid


def test_a_forged_text_under_a_sent_reference_is_counted_as_received(texted_glider, sim):
    """The glider got a text carrying the reference of a command the shore sent, but not the
    shore's text (the command changed under it): not the shore's SMS, so it is counted in."""
    _modem, server = sim
    sender = ModemSender(fast(server.url))
    sent = sms_send_command(fhead(texted_glider, 230), sender=sender)
    sender.close()
    forged = sent.text.replace("#FHEAD 230", "#FHEAD 231")
    at = timezone.now().replace(microsecond=0)
    assert sms_log_upload(vessel=texted_glider, entries=[upload_entry("g1", forged, at)]).accepted
    row = sms_row(texted_glider)
    assert (row.messages_out, row.messages_in) == (1, 1)


# -- the key the reference is signed with ------------------------------------------------------


def test_the_reference_is_signed_with_the_active_key_used_most_recently(texted_glider, sim):
    (first,) = VesselKey.objects.filter(vessel=texted_glider)
    second, _raw = vessel_key_issue(vessel=texted_glider, label="new, never used")
    assert signing_key_hash(texted_glider) == second.key_hash  # none used yet: the newest
    now = timezone.now()
    VesselKey.objects.filter(pk=first.pk).update(last_used_at=now)
    assert signing_key_hash(texted_glider) == first.key_hash  # the one the glider presents
    VesselKey.objects.filter(pk=second.pk).update(last_used_at=now + dt.timedelta(minutes=1))
    assert signing_key_hash(texted_glider) == second.key_hash
    vessel_key_revoke(key=second)  # revoked: never, however recently used
    assert signing_key_hash(texted_glider) == first.key_hash
    _modem, server = sim
    sender = ModemSender(fast(server.url))
    command = fhead(texted_glider)
    message = sms_send_command(command, sender=sender)
    sender.close()
    token = split_reference(message.text)[1]
    assert verified_uid("#FHEAD 230", token, first.key_hash) == command.uid
    assert verified_uid("#FHEAD 230", token, second.key_hash) is None


def test_without_an_active_key_the_route_says_it_cannot_sign(texted_glider, vessel_a, sim):
    _modem, server = sim
    (key,) = VesselKey.objects.filter(vessel=texted_glider)
    vessel_key_revoke(key=key)
    vessel_key_issue(vessel=vessel_a)  # another vessel's key never signs for this one
    sender = ModemSender(fast(server.url))
    try:
        with pytest.raises(RouteNotConfigured, match="Wave Glider has no active vessel key"):
            sms_send_command(fhead(texted_glider), sender=sender)
    finally:
        sender.close()
    assert signing_key_hash(texted_glider) is None
    assert not SmsMessage.objects.exists() and not LinkDay.objects.exists()


def upload_entry(ident: str, text: str, at: dt.datetime) -> dict[str, Any]:
    return {"id": ident, "direction": Direction.IN, "number": SHORE_PHONE, "text": text,
            "created_at": at, "received_at": at, "authorised": True,
            "outcome": "accepted"}  # fmt: skip


@pytest.fixture
def gateway(receiver: Receiver) -> Receiver:  # noqa: F811 (the fixture)
    """The shore's HTTP SMS gateway: the alerts' local receiver, recording each POST and
    answering each with the next of its ``answers`` (then 204)."""
    return receiver
