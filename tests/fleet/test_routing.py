"""Per-vessel routing against the real database and RockBLOCK's MT API (a local HTTP server
standing in for it): what a pass relays, once, and what it leaves to HTTP."""

from __future__ import annotations

import datetime as dt
from io import StringIO
from typing import Any

import pytest
from django.core.management import call_command
from django.utils import timezone

from commands.models import Command, Relay
from commands.services import command_cancel, command_enqueue, command_relay_claim
from edge_client.contract import compact_command
from fleet.relays import configured_senders
from fleet.routing import Refused, Sent, route_pending, routing_summary
from links.routing import Route
from links.services import link_count
from tests.alerts.notify.conftest import Receiver as Gateway
from tests.alerts.notify.conftest import receiver  # noqa: F401 (a fixture)
from tests.sbd.conftest import IMEI, MtEndpoint, mt_endpoint, sbd_vessel  # noqa: F401 (fixtures)
from tests.sms.test_route import gateway  # noqa: F401 (a fixture)
from vessels.models import Vessel, VesselKey
from vessels.services import vessel_key_issue, vessel_key_revoke

pytestmark = pytest.mark.django_db


@pytest.fixture(autouse=True)
def _no_move_limit(settings: Any) -> None:
    settings.MOVE_TO_MAX_M = 0


@pytest.fixture
def mt(settings: Any, mt_endpoint: MtEndpoint) -> MtEndpoint:  # noqa: F811 (the fixture)
    settings.SBD_ROCKBLOCK_MT_URL = mt_endpoint.url
    settings.SBD_ROCKBLOCK_USERNAME = "shore@example.org"
    settings.SBD_ROCKBLOCK_PASSWORD = "s3cret"
    return mt_endpoint


def heard_over_http(vessel: Vessel, ago_s: float) -> None:
    at = timezone.now() - dt.timedelta(seconds=ago_s)
    link_count(vessel_id=vessel.pk, transport="http", at=at, contact=True, messages_in=1)


def move_to(vessel: Vessel, **kw: Any) -> Command:
    return command_enqueue(
        vessel=vessel, kind="move_to", params={"lat": -32.06, "lon": 115.75}, **kw
    )


def notes(command: Command) -> list[str]:
    return [e.detail for e in command.events.filter(actor="shore").order_by("pk")]


def test_a_command_for_a_vessel_silent_over_http_goes_by_sbd_once(
    mt: MtEndpoint,
    sbd_vessel: Vessel,  # noqa: F811
) -> None:
    heard_over_http(sbd_vessel, ago_s=3 * 600 + 60)  # three 10-minute periods and a minute
    command = move_to(sbd_vessel)
    report = route_pending(senders=configured_senders())
    assert report.relayed == [(str(command.uid), Route.SBD)]
    [form] = mt.posts
    assert form["imei"] == IMEI
    assert compact_command.decode(bytes.fromhex(form["data"])).uid == str(command.uid)
    command.refresh_from_db()
    assert (command.relay, command.status) == (Relay.SBD, "queued")  # HTTP still offers it
    assert notes(command) == [
        "silent over HTTP for 31 min (its schedule: 600 s): "
        "sent by Iridium SBD (27 bytes, 1 credit), RockBLOCK message 5001"
    ]
    assert route_pending(senders=configured_senders()).relayed == []
    assert len(mt.posts) == 1


def test_a_reporting_vessel_waits_for_http_unless_the_command_is_urgent(
    mt: MtEndpoint,
    sbd_vessel: Vessel,  # noqa: F811
) -> None:
    heard_over_http(sbd_vessel, ago_s=20)
    calm = move_to(sbd_vessel)
    assert route_pending(senders=configured_senders()).relayed == []
    urgent = command_enqueue(vessel=sbd_vessel, kind="hold", params={}, urgent=True)
    report = route_pending(senders=configured_senders())
    assert report.relayed == [(str(urgent.uid), Route.SBD)]
    assert compact_command.decode(bytes.fromhex(mt.posts[0]["data"])).kind == "hold"
    calm.refresh_from_db()
    assert calm.relay == ""


def test_with_no_sbd_account_nothing_is_relayed(sbd_vessel: Vessel) -> None:  # noqa: F811
    move_to(sbd_vessel, urgent=True)
    assert configured_senders() == {}
    report = route_pending(senders=configured_senders())
    assert report.relayed == [] and report.impossible == []
    assert Command.objects.get().relay == ""


def test_a_spent_budget_holds_back_what_is_not_urgent(
    mt: MtEndpoint,
    sbd_vessel: Vessel,  # noqa: F811
) -> None:
    sbd_vessel.sbd_daily_credit_budget = 2
    sbd_vessel.save()
    link_count(vessel_id=sbd_vessel.pk, transport="sbd", at=timezone.now(), credits=1)
    first = move_to(sbd_vessel)
    second = command_enqueue(vessel=sbd_vessel, kind="arm", params={})
    # Never heard over HTTP: both are due, but the second credit of the day spends the budget.
    report = route_pending(senders=configured_senders())
    assert report.relayed == [(str(first.uid), Route.SBD)]
    second.refresh_from_db()
    assert second.relay == "" and len(mt.posts) == 1


def test_a_command_no_link_can_carry_is_marked_and_not_tried_again(
    sbd_vessel: Vessel,  # noqa: F811
) -> None:
    tries = []

    def refuse(command: Command, now: dt.datetime) -> Sent:
        tries.append(command.uid)
        raise Refused("280 bytes: more than one message holds")

    command = move_to(sbd_vessel)
    report = route_pending(senders={Route.SBD: refuse})
    assert report.impossible == [str(command.uid)] and report.relayed == []
    command.refresh_from_db()
    assert command.relay == Relay.NONE
    assert notes(command) == [
        "never heard over HTTP, but no link could carry it: "
        "sbd: 280 bytes: more than one message holds"
    ]
    route_pending(senders={Route.SBD: refuse})
    assert len(tries) == 1


def test_a_refusing_link_hands_the_command_to_the_next(sbd_vessel: Vessel) -> None:  # noqa: F811
    sbd_vessel.kind, sbd_vessel.sms_number = "wave_glider", "+61400000009"
    sbd_vessel.save()
    command = command_enqueue(vessel=sbd_vessel, kind="hold", params={})

    def no_sms(command: Command, now: dt.datetime) -> Sent:
        raise Refused("the gateway answered 500")

    def sbd(command: Command, now: dt.datetime) -> Sent:
        return Sent("sent by Iridium SBD")

    report = route_pending(senders={Route.SMS: no_sms, Route.SBD: sbd})
    assert report.relayed == [(str(command.uid), Route.SBD)]
    command.refresh_from_db()
    assert command.relay == Relay.SBD
    assert notes(command) == [
        "never heard over HTTP: sent by Iridium SBD (not by sms: the gateway answered 500)"
    ]


def test_sms_is_only_for_a_glider(sbd_vessel: Vessel) -> None:  # noqa: F811
    sbd_vessel.sms_number = "+61400000009"  # an ArduPilot boat: its modem is for data
    sbd_vessel.imei = None
    sbd_vessel.save()
    move_to(sbd_vessel)
    sent = []
    route_pending(senders={Route.SMS: lambda c, now: sent.append(c) or Sent("sent")})
    assert sent == []


def test_a_relay_is_claimed_once(sbd_vessel: Vessel) -> None:  # noqa: F811
    command = move_to(sbd_vessel)
    other = Command.objects.get(pk=command.pk)
    assert command_relay_claim(command=command, relay="sbd")
    assert not command_relay_claim(command=other, relay="sms")
    other.refresh_from_db()
    assert other.relay == "sbd"


def test_expired_cancelled_and_sent_commands_are_left_alone(
    mt: MtEndpoint,
    sbd_vessel: Vessel,  # noqa: F811
) -> None:
    expired = move_to(sbd_vessel)
    Command.objects.filter(pk=expired.pk).update(expires_at=timezone.now())
    sent = command_enqueue(vessel=sbd_vessel, kind="hold", params={})
    Command.objects.filter(pk=sent.pk).update(status="sent")
    assert route_pending(senders=configured_senders()).relayed == []
    assert mt.posts == []


# The command calls close_old_connections(), which closes a connection left inside a test's
# transaction: a real transaction here (as tests/alerts/test_run_alerts.py).
@pytest.mark.django_db(transaction=True)
def test_run_links_once_relays_and_says_so(mt: MtEndpoint, sbd_vessel: Vessel) -> None:  # noqa: F811
    command = move_to(sbd_vessel)
    out = StringIO()
    call_command("run_links", "--once", stdout=out)
    assert out.getvalue() == f"run_links: command {command.uid} relayed by sbd\n"
    assert len(mt.posts) == 1


def test_the_vessel_page_says_where_commands_go(
    mt: MtEndpoint,
    sbd_vessel: Vessel,  # noqa: F811
) -> None:
    senders = configured_senders()
    assert routing_summary(sbd_vessel, senders) == (
        "Queued commands also go by Iridium SBD: never heard over HTTP."
    )
    heard_over_http(sbd_vessel, ago_s=30)
    assert routing_summary(sbd_vessel, senders) == (
        "HTTP is reporting: commands go by HTTP; urgent ones also by Iridium SBD."
    )
    sbd_vessel.sbd_daily_credit_budget = 0
    heard_over_http(sbd_vessel, ago_s=3600)  # an older contact does not move it back
    assert "HTTP is reporting" in routing_summary(sbd_vessel, senders)
    assert routing_summary(sbd_vessel, {}) == (
        "Commands go by HTTP alone: no SMS number or Iridium IMEI the site can send to."
    )


def test_a_silent_vessel_over_budget_waits_for_http(sbd_vessel: Vessel) -> None:  # noqa: F811
    sbd_vessel.sbd_daily_credit_budget = 0
    summary = routing_summary(sbd_vessel, {Route.SBD: lambda c, now: Sent("sent")})
    assert summary == "Queued commands wait for HTTP: never heard over HTTP, but sbd budget spent."


# -- SMS to a glider, through the shore's HTTP SMS gateway (a local server standing in) -------


def test_a_silent_glider_gets_its_command_by_sms_before_sbd(
    glider: Vessel,
    gateway: Gateway,  # noqa: F811 (the fixture)
    mt: MtEndpoint,
    settings: Any,
) -> None:
    settings.ALERTS_SMS_MODEM_URL, settings.ALERTS_SMS_GATEWAY_URL = "", gateway.url
    glider.sms_number, glider.imei = "+61400000077", IMEI
    glider.save()
    vessel_key_issue(vessel=glider)  # its shore link's: the SMS's reference is signed with it
    heard_over_http(glider, ago_s=4 * glider.telemetry_period_s)
    command = command_enqueue(vessel=glider, kind="fhead", params={"bearing": 230})
    senders = configured_senders()
    assert set(senders) == {Route.SMS, Route.SBD}
    report = route_pending(senders=senders)
    assert report.relayed == [(str(command.uid), Route.SMS)]
    [post] = gateway.received
    body = post.json()
    assert body["to"] == "+61400000077" and body["text"].startswith("#FHEAD 230 ref:")
    assert mt.posts == []  # the cheaper link took it: SBD is not paid for as well
    command.refresh_from_db()
    assert command.relay == Relay.SMS
    [note] = notes(command)
    assert (
        note.startswith("silent over HTTP for 4 min (its schedule: 60 s)")
        and "sent by SMS to +61400000077" in note
    )


def test_a_failed_sms_hands_the_command_to_sbd(
    glider: Vessel,
    gateway: Gateway,  # noqa: F811 (the fixture)
    mt: MtEndpoint,
    settings: Any,
) -> None:
    settings.ALERTS_SMS_MODEM_URL, settings.ALERTS_SMS_GATEWAY_URL = "", gateway.url
    gateway.answers = [503]
    glider.sms_number, glider.imei = "+61400000077", IMEI
    glider.save()
    vessel_key_issue(vessel=glider)
    command = command_enqueue(vessel=glider, kind="hold", params={}, urgent=True)
    report = route_pending(senders=configured_senders())
    assert report.relayed == [(str(command.uid), Route.SBD)]
    assert len(gateway.received) == 1 and len(mt.posts) == 1
    command.refresh_from_db()
    assert command.relay == Relay.SBD
    [note] = notes(command)
    assert note.startswith("urgent: sent by Iridium SBD")


# -- what the review found: a pass reads its list before it sends ------------------------------


def test_a_command_cancelled_while_a_pass_sends_another_is_not_relayed(
    sbd_vessel: Vessel,  # noqa: F811
) -> None:
    first = command_enqueue(vessel=sbd_vessel, kind="arm", params={})
    second = command_enqueue(vessel=sbd_vessel, kind="disarm", params={})
    sent = []

    def slow(command: Command, now: dt.datetime) -> Sent:
        sent.append(command.kind)
        if command.pk == first.pk:  # the operator cancels the second meanwhile
            command_cancel(command=Command.objects.get(pk=second.pk), actor="alice")
        return Sent("sent")

    report = route_pending(senders={Route.SBD: slow})
    assert sent == ["arm"] and report.impossible == []
    second.refresh_from_db()
    assert (second.status, second.relay) == ("cancelled", "")


def test_an_sms_that_fails_for_now_is_tried_again_then_given_up(glider: Vessel) -> None:
    glider.sms_number = "+61400000077"
    glider.save()
    command = command_enqueue(vessel=glider, kind="hold", params={})
    tries = []

    def down(command: Command, now: dt.datetime) -> Sent:
        tries.append(now)
        raise Refused("the gateway answered 503", temporary=True)

    for _ in range(2):
        assert route_pending(senders={Route.SMS: down}).retrying == [str(command.uid)]
        command.refresh_from_db()
        assert command.relay == ""  # released: the next pass tries again
    assert route_pending(senders={Route.SMS: down}).impossible == [str(command.uid)]
    command.refresh_from_db()
    assert command.relay == Relay.NONE and len(tries) == 3
    assert route_pending(senders={Route.SMS: down}).retrying == []
    assert len(tries) == 3
    assert notes(command)[0] == (
        "never heard over HTTP, but not sent (sms: the gateway answered 503): "
        "trying again next pass (try 1 of 3)"
    )


def test_a_glider_is_not_texted_past_its_rate_limit(glider: Vessel, settings: Any) -> None:
    settings.SMS_RATE_LIMIT = 3
    glider.sms_number = "+61400000077"
    glider.save()
    commands = [
        command_enqueue(vessel=glider, kind="light", params={"state": s})
        for s in ("on", "off", "on", "off", "on")
    ]
    texted = []
    senders = {Route.SMS: lambda c, now: texted.append(c.pk) or Sent("sent")}
    report = route_pending(senders=senders)
    assert texted == [c.pk for c in commands[:3]] and len(report.relayed) == 3
    assert route_pending(senders=senders).relayed == []  # the window is full: they wait
    assert Command.objects.filter(relay="").count() == 2


def test_urgent_commands_are_looked_at_first(sbd_vessel: Vessel) -> None:  # noqa: F811
    heard_over_http(sbd_vessel, ago_s=5)  # reporting: only urgent ones are relayed
    for _ in range(3):
        command_enqueue(vessel=sbd_vessel, kind="arm", params={})
    urgent = command_enqueue(vessel=sbd_vessel, kind="disarm", params={}, urgent=True)
    relayed = route_pending(senders={Route.SBD: lambda c, now: Sent("sent")}, limit=1).relayed
    assert relayed == [(str(urgent.uid), Route.SBD)]


def test_a_relay_spends_its_real_cost_of_the_budget(sbd_vessel: Vessel) -> None:  # noqa: F811
    sbd_vessel.sbd_daily_credit_budget = 5
    sbd_vessel.save()
    first = command_enqueue(vessel=sbd_vessel, kind="arm", params={})
    command_enqueue(vessel=sbd_vessel, kind="disarm", params={})
    report = route_pending(senders={Route.SBD: lambda c, now: Sent("a long one", 5)})
    assert report.relayed == [(str(first.uid), Route.SBD)]  # 5 credits: the budget is spent


def test_a_glider_without_an_active_key_is_not_texted_and_sbd_takes_it(
    glider: Vessel,
    gateway: Gateway,  # noqa: F811 (the fixture)
    mt: MtEndpoint,
    settings: Any,
) -> None:
    """Its SMS could not be signed (the glider refuses an unsigned reference): nothing is
    texted, and the next link takes the command."""
    settings.ALERTS_SMS_MODEM_URL, settings.ALERTS_SMS_GATEWAY_URL = "", gateway.url
    glider.sms_number, glider.imei = "+61400000077", IMEI
    glider.save()
    key, _raw = vessel_key_issue(vessel=glider)
    vessel_key_revoke(key=key)
    assert not VesselKey.objects.filter(vessel=glider, revoked_at__isnull=True).exists()
    command = command_enqueue(vessel=glider, kind="hold", params={}, urgent=True)
    report = route_pending(senders=configured_senders())
    assert report.relayed == [(str(command.uid), Route.SBD)]
    assert gateway.received == [] and len(mt.posts) == 1
