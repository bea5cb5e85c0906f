"""The notification services against the database and local servers: queueing per channel,
sending once, retrying with backoff, giving up, summarising a flood, and making channels."""

from __future__ import annotations

import datetime as dt
from typing import Any

import pytest
from django.core.exceptions import ValidationError

from alerts.models import Notification, NotificationChannel
from alerts.services.notifications import (
    CLAIM_TIMEOUT,
    notification_channel_create,
    notifications_queue,
    notifications_send_due,
)
from audit.models import AuditEntry
from sms.modem.simulator import ModemServer, SimulatedModem
from tests.alerts.notify.conftest import (
    BASE,
    SECRET,
    Receiver,
    Smtp,
    make_alert,
    make_channel,
    make_rule,
    make_vessel,
)

pytestmark = pytest.mark.django_db
S = dt.timedelta(seconds=1)


@pytest.fixture
def hook(receiver: Receiver) -> NotificationChannel:
    return make_channel("webhook", receiver.url, secret=SECRET)


def states() -> list[tuple[str, int]]:
    return [(n.state, n.attempts) for n in Notification.objects.order_by("pk")]


def test_an_event_is_owed_to_each_active_channel_of_the_rule(hook: NotificationChannel) -> None:
    off = make_channel("email", "off@shore.test")
    off.active = False
    off.save()
    rule = make_rule("Overdue", hook, off, make_channel("sms", "+61412345678"))
    alert = make_alert(rule, make_vessel("spab"))
    assert notifications_queue(alert=alert, event="alert.opened", now=BASE) == 2
    rows = Notification.objects.order_by("pk")
    assert sorted((n.channel.kind, n.event, n.state, n.due_at) for n in rows) == [
        ("sms", "alert.opened", "pending", BASE),
        ("webhook", "alert.opened", "pending", BASE),
    ]
    with pytest.raises(ValueError):
        notifications_queue(alert=alert, event="alert.exploded", now=BASE)


def test_a_rule_without_channels_owes_nothing() -> None:
    alert = make_alert(make_rule("Quiet"), make_vessel("spab"))
    assert notifications_queue(alert=alert, event="alert.opened") == 0


def test_a_due_notification_is_sent_signed_once(hook: NotificationChannel, receiver) -> None:  # type: ignore[no-untyped-def]
    alert = make_alert(make_rule("Overdue", hook), make_vessel("spab"))
    notifications_queue(alert=alert, event="alert.opened", now=BASE)
    assert notifications_send_due(now=BASE - S, worker="w1") == 0  # not due yet
    assert notifications_send_due(now=BASE, worker="w1") == 1
    assert notifications_send_due(now=BASE + S, worker="w1") == 0  # and not again
    [got] = receiver.received
    assert got.signed
    assert got.json()["event"] == "alert.opened"
    assert got.json()["alert"]["id"] == alert.pk
    row = Notification.objects.get()
    assert (row.state, row.attempts, row.sent_at, row.last_error) == ("sent", 1, BASE, "")
    assert row.claimed_by.startswith("w1/")


def test_a_failing_receiver_is_retried_with_backoff_until_it_answers(
    hook: NotificationChannel, receiver: Receiver, caplog: pytest.LogCaptureFixture
) -> None:
    receiver.answers = [500, 503]
    notifications_queue(alert=make_alert(make_rule("Overdue", hook), make_vessel("spab")),
                        event="alert.opened", now=BASE)  # fmt: skip
    assert notifications_send_due(now=BASE, worker="w1") == 0
    row = Notification.objects.get()
    assert (row.state, row.attempts, row.due_at) == ("pending", 1, BASE + 30 * S)
    assert "answered 500" in row.last_error and row.claimed_by == ""
    assert "not sent" in caplog.text and "again in 30 s" in caplog.text
    assert notifications_send_due(now=BASE + 29 * S, worker="w1") == 0  # waiting
    assert notifications_send_due(now=BASE + 30 * S, worker="w1") == 0  # 503: doubled wait
    row.refresh_from_db()
    assert (row.state, row.attempts, row.due_at) == ("pending", 2, BASE + 90 * S)
    assert notifications_send_due(now=BASE + 90 * S, worker="w1") == 1
    row.refresh_from_db()
    assert (row.state, row.attempts, row.last_error) == ("sent", 3, "")
    assert len(receiver.received) == 3 and all(r.signed for r in receiver.received)


def test_a_permanent_refusal_fails_at_once(hook: NotificationChannel, receiver: Receiver) -> None:
    receiver.answers = [400]
    notifications_queue(alert=make_alert(make_rule("Overdue", hook), make_vessel("spab")),
                        event="alert.opened", now=BASE)  # fmt: skip
    assert notifications_send_due(now=BASE, worker="w1") == 0
    row = Notification.objects.get()
    assert (row.state, row.attempts) == ("failed", 1)
    assert "answered 400" in row.last_error
    assert notifications_send_due(now=BASE + dt.timedelta(days=1), worker="w1") == 0
    assert len(receiver.received) == 1


def test_a_channel_that_keeps_failing_is_given_up_after_the_last_attempt(
    settings: Any, hook: NotificationChannel, receiver: Receiver, caplog: pytest.LogCaptureFixture
) -> None:
    settings.ALERTS_NOTIFY_MAX_ATTEMPTS = 3
    receiver.answers = [502] * 5
    notifications_queue(alert=make_alert(make_rule("Overdue", hook), make_vessel("spab")),
                        event="alert.opened", now=BASE)  # fmt: skip
    for _ in range(5):
        notifications_send_due(now=BASE + dt.timedelta(hours=1) * _, worker="w1")
    row = Notification.objects.get()
    assert (row.state, row.attempts) == ("failed", 3)
    assert row.last_error.startswith("gave up after 3 attempts: ")
    assert "failed: gave up after 3 attempts" in caplog.text
    assert len(receiver.received) == 3


def test_one_broken_channel_does_not_hold_up_the_others(
    hook: NotificationChannel, receiver: Receiver, smtp_server: Smtp
) -> None:
    dead = make_channel("webhook", "http://127.0.0.1:9/nobody", secret=SECRET)
    rule = make_rule("Overdue", dead, hook, make_channel("email", "ops@shore.test"))
    notifications_queue(alert=make_alert(rule, make_vessel("spab")), event="alert.opened",
                        now=BASE)  # fmt: skip
    assert notifications_send_due(now=BASE, worker="w1") == 2
    assert sorted(states()) == [("pending", 1), ("sent", 1), ("sent", 1)]
    assert len(receiver.received) == 1 and len(smtp_server.messages) == 1


def test_a_stop_hands_back_what_was_not_sent_yet(
    hook: NotificationChannel, receiver: Receiver
) -> None:
    rule = make_rule("Overdue", hook)
    for slug in ("spab", "spab-2", "glider"):
        notifications_queue(alert=make_alert(rule, make_vessel(slug)), event="alert.opened",
                            now=BASE)  # fmt: skip

    def stop() -> bool:  # told to stop once the first went out
        return len(receiver.received) >= 1

    assert notifications_send_due(now=BASE, worker="w1", stop=stop) == 1
    assert sorted(states()) == [("pending", 0), ("pending", 0), ("sent", 1)]
    assert not Notification.objects.filter(state="pending").exclude(claimed_by="").exists()
    # The next sender takes them at once, as due as they were.
    assert notifications_send_due(now=BASE, worker="w2") == 2
    assert len(receiver.received) == 3


def test_a_claim_left_by_a_dead_worker_is_taken_over_when_stale(
    hook: NotificationChannel, receiver: Receiver
) -> None:
    notifications_queue(alert=make_alert(make_rule("Overdue", hook), make_vessel("spab")),
                        event="alert.opened", now=BASE)  # fmt: skip
    Notification.objects.update(state="sending", claimed_by="dead/1", claimed_at=BASE, attempts=1)
    assert notifications_send_due(now=BASE + CLAIM_TIMEOUT, worker="w2") == 0  # still its own
    assert notifications_send_due(now=BASE + CLAIM_TIMEOUT + S, worker="w2") == 1
    row = Notification.objects.get()
    assert (row.state, row.attempts, row.claimed_by[:3]) == ("sent", 2, "w2/")
    assert len(receiver.received) == 1


def test_a_claim_whose_sender_died_on_every_attempt_is_given_up(
    settings: Any, hook: NotificationChannel, receiver: Receiver
) -> None:
    settings.ALERTS_NOTIFY_MAX_ATTEMPTS = 3
    notifications_queue(alert=make_alert(make_rule("Overdue", hook), make_vessel("spab")),
                        event="alert.opened", now=BASE)  # fmt: skip
    Notification.objects.update(state="sending", claimed_by="dead/3", claimed_at=BASE, attempts=3)
    assert notifications_send_due(now=BASE + CLAIM_TIMEOUT + S, worker="w2") == 0
    row = Notification.objects.get()
    assert row.state == "failed" and "never came back" in row.last_error
    assert receiver.received == []


def test_a_channel_turned_off_after_queueing_sends_nothing(
    hook: NotificationChannel, receiver: Receiver
) -> None:
    notifications_queue(alert=make_alert(make_rule("Overdue", hook), make_vessel("spab")),
                        event="alert.opened", now=BASE)  # fmt: skip
    NotificationChannel.objects.update(active=False)
    assert notifications_send_due(now=BASE, worker="w1") == 0
    row = Notification.objects.get()
    assert (row.state, row.last_error) == ("failed", "the channel was turned off")
    assert receiver.received == []


def test_sms_with_nothing_configured_fails_and_says_what_to_set(settings: Any) -> None:
    settings.ALERTS_SMS_MODEM_URL = settings.ALERTS_SMS_GATEWAY_URL = ""
    rule = make_rule("Overdue", make_channel("sms", "+61412345678"))
    notifications_queue(alert=make_alert(rule, make_vessel("spab")), event="alert.opened",
                        now=BASE)  # fmt: skip
    notifications_send_due(now=BASE, worker="w1")
    row = Notification.objects.get()
    assert row.state == "failed" and "ALERTS_SMS_MODEM_URL" in row.last_error


def test_an_alert_reaches_a_phone_through_the_shore_modem(settings: Any) -> None:
    sim = SimulatedModem()
    with ModemServer(sim, "pty") as server:
        settings.ALERTS_SMS_MODEM_URL = server.url
        rule = make_rule("Overdue", make_channel("sms", "0412 345 678"))
        alert = make_alert(rule, make_vessel("spab"))
        notifications_queue(alert=alert, event="alert.opened", now=BASE)
        assert notifications_send_due(now=BASE, worker="w1") == 1
    assert [(s.number, s.text) for s in sim.sent] == [
        ("+61412345678", "ALERT spab 03:12Z Overdue: silent 25 min (3 periods)")
    ]


def test_an_alert_reaches_a_phone_through_the_http_gateway(
    settings: Any, receiver: Receiver
) -> None:
    settings.ALERTS_SMS_GATEWAY_URL, settings.ALERTS_SMS_GATEWAY_TOKEN = receiver.url, "tok"
    rule = make_rule("Overdue", make_channel("sms", "+61412345678"))
    alert = make_alert(rule, make_vessel("spab"), state="resolved", resolved_at=BASE + 60 * S)
    notifications_queue(alert=alert, event="alert.resolved", now=BASE)
    assert notifications_send_due(now=BASE, worker="w1") == 1
    [got] = receiver.received
    assert got.headers["Authorization"] == "Bearer tok"
    assert got.json() == {"to": "+61412345678", "text": "CLEAR spab 03:13Z Overdue: silent 25 min"
                          " (3 periods)"}  # fmt: skip


# -- floods ------------------------------------------------------------------------------------


def twenty_boats_overdue(*channels: NotificationChannel) -> list[Any]:
    rule = make_rule("Overdue", *channels)
    alerts = [make_alert(rule, make_vessel(f"boat-{i:02d}")) for i in range(20)]
    for alert in alerts:
        notifications_queue(alert=alert, event="alert.opened", now=BASE)
    return alerts


def test_a_flood_is_one_email_and_one_sms_but_every_webhook(
    settings: Any, hook: NotificationChannel, receiver: Receiver, smtp_server: Smtp
) -> None:
    sim = SimulatedModem()
    with ModemServer(sim, "pty") as server:
        settings.ALERTS_SMS_MODEM_URL = server.url
        mail = make_channel("email", "ops@shore.test")
        phone = make_channel("sms", "+61412345678")
        alerts = twenty_boats_overdue(mail, phone, hook)
        assert notifications_send_due(now=BASE, worker="w1") == 60
    [email] = smtp_server.messages
    assert email["Subject"].startswith("[Shoreside] ALERT x20: 20 alerts opened")
    assert all(f"- {a.vessel.slug}: Overdue" in email.get_content() for a in alerts)
    [sms] = sim.sent
    assert sms.text.startswith("ALERT x20 03:12Z Overdue: boat-00, boat-01,")
    assert sms.text.endswith(" more")
    assert len(receiver.received) == 20 and all(r.signed for r in receiver.received)
    for channel in (mail, phone):
        rows = list(Notification.objects.filter(channel=channel).order_by("pk"))
        carrier = rows[0]
        assert carrier.summarised_in is None
        assert all((r.state, r.summarised_in_id) == ("sent", carrier.pk) for r in rows[1:])
    assert not Notification.objects.filter(channel=hook, summarised_in__isnull=False).exists()


def test_a_few_at_once_go_one_by_one(smtp_server: Smtp) -> None:
    mail = make_channel("email", "ops@shore.test")
    rule = make_rule("Overdue", mail)
    for slug in ("a", "b", "c"):  # ALERTS_NOTIFY_FLOOD = 3: not more than it
        notifications_queue(alert=make_alert(rule, make_vessel(slug)), event="alert.opened",
                            now=BASE)  # fmt: skip
    assert notifications_send_due(now=BASE, worker="w1") == 3
    assert len(smtp_server.messages) == 3


def test_a_summary_that_fails_is_retried_for_all_it_carries(
    smtp_server: Smtp, settings: Any
) -> None:
    smtp_server.refuse = {"ops@shore.test": 451}
    mail = make_channel("email", "ops@shore.test")
    twenty_boats_overdue(mail)
    assert notifications_send_due(now=BASE, worker="w1") == 0
    assert set(states()) == {("pending", 1)}
    smtp_server.refuse = {}
    assert notifications_send_due(now=BASE + 30 * S, worker="w1") == 20
    assert len(smtp_server.messages) == 1


def test_a_backlog_on_one_channel_does_not_hold_up_another(
    hook: NotificationChannel, receiver: Receiver
) -> None:
    """bench.alerts' fence crossing whose webhook never came within 30 s: a backlog of e-mail
    owed (a loop stopped before it sent them) took the pass's whole claim, oldest first, and
    the webhook waited behind it pass after pass. Each channel now gets its own share."""
    mail = make_channel("email", "ops@shore.test")
    twenty_boats_overdue(mail)
    crossing = make_alert(make_rule("Fence", hook), make_vessel("spab"))
    notifications_queue(alert=crossing, event="alert.opened", now=BASE + S)
    assert notifications_send_due(now=BASE + S, worker="w1", limit=5) == 6
    [got] = receiver.received
    assert got.json()["alert"]["id"] == crossing.pk
    assert Notification.objects.filter(channel=mail, state="pending").count() == 15
    assert notifications_send_due(now=BASE + 2 * S, worker="w1", limit=5) == 5  # and so on


# -- channels ----------------------------------------------------------------------------------


def test_a_webhook_channel_gets_a_secret_shown_once_and_an_audit_entry() -> None:
    channel, secret = notification_channel_create(
        name="Ops hook", kind="webhook", target="https://ops.example.org/hook", by="alice"
    )
    assert len(secret) == 64 and channel.secret == secret
    other, other_secret = notification_channel_create(
        name="Two", kind="webhook", target="http://10.0.0.5:8080/in", by="alice"
    )
    assert other_secret != secret
    entry = AuditEntry.objects.get(subject_id=str(channel.pk))
    assert (entry.action, entry.actor, entry.subject_type) == (
        "channel.created", "alice", "notification_channel",
    )  # fmt: skip
    assert entry.detail == {"kind": "webhook", "target": "https://ops.example.org/hook"}
    assert secret not in str(entry.detail) and secret not in entry.subject


def test_a_given_secret_is_kept_and_a_short_one_refused(admin_user) -> None:  # type: ignore[no-untyped-def]
    _, secret = notification_channel_create(
        name="Hook",
        kind="webhook",
        secret=SECRET,
        target="https://ops.example.org/h",
        by=admin_user,
    )
    assert secret == SECRET
    assert AuditEntry.objects.get().actor == admin_user.username
    with pytest.raises(ValidationError) as caught:
        notification_channel_create(name="Hook", kind="webhook", secret="short",
                                    target="https://ops.example.org/h", by="alice")  # fmt: skip
    assert "secret" in caught.value.message_dict


@pytest.mark.parametrize(
    ("kind", "target", "stored"),
    [("email", " ops@shore.test ", "ops@shore.test"),
     ("sms", "0412 345 678", "+61412345678"),
     ("sms", "+44 7911 123456", "+447911123456"),
     ("webhook", "https://ops.example.org/hook?x=1", "https://ops.example.org/hook?x=1")],
)  # fmt: skip
def test_targets_are_checked_and_kept_in_one_form(kind: str, target: str, stored: str) -> None:
    channel, secret = notification_channel_create(name="c", kind=kind, target=target, by="al")
    assert channel.target == stored
    assert (secret == "") is (kind != "webhook")


@pytest.mark.parametrize(
    ("kind", "target", "field"),
    [("email", "not an address", "target"), ("sms", "12", "target"),
     ("sms", "call me maybe", "target"), ("webhook", "ftp://ops.example.org/", "target"),
     ("webhook", "ops.example.org/hook", "target"), ("email", "", "target"),
     ("pigeon", "loft 3", "kind")],
)  # fmt: skip
def test_a_bad_target_is_refused_and_nothing_is_written(kind: str, target: str, field: str) -> None:
    with pytest.raises(ValidationError) as caught:
        notification_channel_create(name="c", kind=kind, target=target, by="al")
    assert field in caught.value.message_dict
    assert not NotificationChannel.objects.exists() and not AuditEntry.objects.exists()


def test_only_a_webhook_has_a_secret() -> None:
    with pytest.raises(ValidationError) as caught:
        notification_channel_create(name="c", kind="email", target="a@b.test", secret=SECRET,
                                    by="al")  # fmt: skip
    assert "secret" in caught.value.message_dict
