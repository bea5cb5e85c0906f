"""`/api/v1/alert-rules/`, `/api/v1/alerts/` (+ ack) and `/api/v1/notification-channels/` for
each persona: carol (every right), alice (the fleet, no alert rights), bob (none), a boat."""

from __future__ import annotations

import datetime as dt

import pytest
from django.utils import timezone

from alerts.models import Alert, AlertRule, AlertState, NotificationChannel
from alerts.services.rules import alert_rule_create
from audit.models import AuditEntry
from telemetry.models import SensorChannel
from tests.vessels.test_fence_geometry import SQUARE, polygon
from vessels.fence_services import fence_create

pytestmark = pytest.mark.django_db
RULES = "/api/v1/alert-rules/"
ALERTS = "/api/v1/alerts/"
CHANNELS = "/api/v1/notification-channels/"


def test_an_overdue_rule_for_one_vessel(watcher, vessel_a):
    channel = NotificationChannel.objects.create(name="Ops", kind="email", target="ops@example.org")
    r = watcher.post(RULES, {"name": "SPAB silent", "vessel": "spab", "kind": "overdue",
                             "threshold": 3, "channels": [channel.pk]}, format="json")  # fmt: skip
    assert r.status_code == 201, r.content
    body = r.json()
    assert (body["vessel"], body["vessel_kind"], body["threshold"], body["channels"]) == (
        "spab", None, 3.0, [channel.pk],
    )  # fmt: skip
    rule = AlertRule.objects.get()
    assert list(rule.channels.all()) == [channel]
    entry = AuditEntry.objects.get()
    assert (entry.action, entry.actor, entry.via, entry.vessel) == (
        "rule.created",
        "carol",
        "api",
        "spab",
    )


def test_a_reading_rule_takes_min_and_max_on_the_wire(watcher):
    r = watcher.post(RULES, {"name": "Leak", "vessel": None, "vessel_kind": "wave_glider",
                             "kind": "reading", "reading": "hull_humidity_pct", "max": 60},
                     format="json")  # fmt: skip
    assert r.status_code == 201, r.content
    rule = AlertRule.objects.get()
    assert (rule.reading, rule.minimum, rule.maximum, rule.vessel_kind) == (
        "hull_humidity_pct", None, 60.0, "wave_glider",
    )  # fmt: skip
    assert r.json()["max"] == 60.0 and r.json()["min"] is None


def test_a_reading_rule_may_use_the_channels_limits():
    SensorChannel.objects.create(key="hull_humidity_pct", label="Hull humidity", maximum=60)
    rule = alert_rule_create(
        fields={"name": "Leak", "kind": "reading", "reading": "hull_humidity_pct"}
    )
    assert rule.maximum is None  # the evaluator reads the channel's


@pytest.mark.parametrize(
    ("body", "errors"),
    [
        ({"kind": "battery"}, {"threshold": "a battery rule needs a threshold (volts)"}),
        ({"kind": "endurance", "threshold": -1}, {"threshold": "must be above 0 (hours)"}),
        ({"kind": "reading"}, {"reading": "a reading rule needs the reading's key"}),
        (
            {"kind": "reading", "reading": "t", "min": 5, "max": 1},
            {"max": "must be above the minimum"},
        ),
        ({"kind": "reading", "reading": "t"}, {"min": "give a minimum or a maximum"}),
        ({"kind": "fence"}, {"fence": "a fence rule needs a fence"}),
        ({"kind": "command", "threshold": 2}, {"threshold": "a command rule has no threshold"}),
        ({"kind": "overdue", "threshold": 3, "reading": "t"}, {"reading": "only a reading rule"}),
        ({"kind": "nope"}, {"kind": "is not a valid choice"}),
    ],
)
def test_a_rule_is_checked_for_its_kind(watcher, body, errors):
    r = watcher.post(RULES, {"name": "Rule", **body}, format="json")
    assert r.status_code == 400, r.content
    detail = r.json()["detail"]
    for field, said in errors.items():
        assert field in detail and said in " ".join(detail[field]), detail
    assert not AlertRule.objects.exists() and not AuditEntry.objects.exists()


def test_a_fence_rule_must_not_watch_another_vessels_fence(watcher, vessel_a, vessel_b):
    theirs = fence_create(name="B's", geometry=polygon(SQUARE), vessel=vessel_b)
    r = watcher.post(RULES, {"name": "Out", "kind": "fence", "fence": theirs.pk, "vessel": "spab"},
                     format="json")  # fmt: skip
    assert r.status_code == 400 and "belongs to another vessel" in r.json()["detail"]["fence"][0]
    body = {"name": "Out", "kind": "fence", "fence": theirs.pk, "vessel": "spab-2"}
    r = watcher.post(RULES, body, format="json")
    assert r.status_code == 201


def test_patch_is_checked_as_a_whole_rule_and_delete_is_audited(watcher, vessel_a):
    rule = alert_rule_create(fields={"name": "Low", "kind": "battery", "threshold": 11.5})
    r = watcher.patch(f"{RULES}{rule.pk}/", {"kind": "reading"}, format="json")
    assert r.status_code == 400  # a reading rule has no threshold and needs a reading
    r = watcher.patch(f"{RULES}{rule.pk}/", {"threshold": 11.8, "active": False}, format="json")
    assert r.status_code == 200 and r.json()["threshold"] == 11.8
    change = AuditEntry.objects.get(action="rule.changed")
    assert change.detail["changed"]["threshold"] == {"from": 11.5, "to": 11.8}
    assert watcher.delete(f"{RULES}{rule.pk}/").status_code == 204
    assert AuditEntry.objects.filter(action="rule.deleted").exists()
    assert not AlertRule.objects.exists()


def test_who_may_see_and_write_rules(watcher, operator, readonly, boat_a, vessel_a):
    body = {"name": "Low", "kind": "battery", "threshold": 11.5}
    for client in (operator, readonly, boat_a):
        assert client.get(RULES).status_code == 403
        assert client.post(RULES, body, format="json").status_code == 403
    assert watcher.get(RULES).json() == []


def open_alert(vessel, *, minutes_ago=5, state=AlertState.OPEN, kind="battery") -> Alert:
    """An alert as the evaluator opens one (its own service is tested with it)."""
    rule = AlertRule.objects.filter(kind=kind).first() or alert_rule_create(
        fields={"name": f"{kind} rule", "kind": kind, "threshold": 11.5}
    )
    return Alert.objects.create(
        rule=rule, vessel=vessel, kind=kind, state=state, value=11.2, detail="battery 11.2 V",
        opened_at=timezone.now() - dt.timedelta(minutes=minutes_ago),
        resolved_at=timezone.now() if state == AlertState.RESOLVED else None,
    )  # fmt: skip


def test_alerts_are_listed_newest_first_and_filtered(watcher, vessel_a, vessel_b):
    old = open_alert(vessel_a, minutes_ago=60, state=AlertState.RESOLVED)
    new = open_alert(vessel_a, minutes_ago=1)
    other = open_alert(vessel_b, minutes_ago=2)
    ids = [a["id"] for a in watcher.get(ALERTS).json()["results"]]
    assert ids == [new.pk, other.pk, old.pk]
    assert [a["id"] for a in watcher.get(ALERTS, {"state": "open"}).json()["results"]] == [
        new.pk,
        other.pk,
    ]
    assert [a["id"] for a in watcher.get(ALERTS, {"vessel": "spab-2"}).json()["results"]] == [
        other.pk
    ]
    assert watcher.get(ALERTS, {"state": "closed"}).status_code == 400
    first = watcher.get(ALERTS).json()["results"][0]
    assert (first["vessel"], first["rule_name"], first["state"]) == ("spab", "battery rule", "open")


def test_an_operator_acknowledges_an_alert(watcher, vessel_a):
    alert = open_alert(vessel_a)
    r = watcher.post(f"{ALERTS}{alert.pk}/ack/")
    assert r.status_code == 200, r.content
    alert.refresh_from_db()
    assert (alert.state, alert.acknowledged_by) == ("acknowledged", "carol")
    assert r.json()["acknowledged_at"] is not None
    entry = AuditEntry.objects.get(action="alert.acknowledged")
    assert (entry.actor, entry.vessel, entry.subject_id) == ("carol", "spab", str(alert.pk))
    # Again: as it was.
    again = watcher.post(f"{ALERTS}{alert.pk}/ack/")
    assert (
        again.status_code == 200 and again.json()["acknowledged_at"] == r.json()["acknowledged_at"]
    )


def test_a_resolved_alert_cannot_be_acknowledged(watcher, vessel_a):
    alert = open_alert(vessel_a, state=AlertState.RESOLVED)
    r = watcher.post(f"{ALERTS}{alert.pk}/ack/")
    assert r.status_code == 409 and r.json()["error"] == "conflict"


def test_who_may_see_and_acknowledge_alerts(operator, readonly, boat_a, vessel_a):
    from rest_framework.test import APIClient

    from tests.alerts.conftest import ALERT_PERMS
    from tests.conftest import make_user

    alert = open_alert(vessel_a)
    viewer = APIClient()
    viewer.force_authenticate(make_user("erin", ["vessels.view_vessel", "alerts.view_alert"]))
    assert viewer.get(ALERTS).status_code == 200
    assert viewer.post(f"{ALERTS}{alert.pk}/ack/").status_code == 403  # needs change_alert
    for client in (operator, readonly, boat_a):
        assert client.get(ALERTS).status_code == 403
        assert client.post(f"{ALERTS}{alert.pk}/ack/").status_code == 403
    assert Alert.objects.get().state == "open"
    assert ALERT_PERMS  # the full set is carol's


def test_a_webhook_channels_secret_is_shown_once(watcher):
    body = {"name": "Pager", "kind": "webhook", "target": "https://pager.example.org/hook"}
    r = watcher.post(CHANNELS, body, format="json")
    assert r.status_code == 201, r.content
    secret = r.json()["secret"]
    assert len(secret) >= 32 and r.json()["has_secret"] is True
    channel = NotificationChannel.objects.get()
    assert channel.secret == secret
    assert "secret" not in watcher.get(f"{CHANNELS}{channel.pk}/").json()
    assert secret not in watcher.get(CHANNELS).content.decode()
    given = watcher.post(CHANNELS, {"name": "Mine", "kind": "webhook", "target": "http://10.0.0.2/",
                                    "secret": "s" * 20}, format="json")  # fmt: skip
    assert given.json()["secret"] == "s" * 20


@pytest.mark.parametrize(
    ("body", "field"),
    [
        ({"kind": "email", "target": "not an address"}, "target"),
        ({"kind": "sms", "target": "0412 345 678"}, "target"),
        ({"kind": "webhook", "target": "ftp://example.org/"}, "target"),
        ({"kind": "email", "target": "ops@example.org", "secret": "x" * 20}, "secret"),
    ],
)
def test_a_channels_target_fits_its_kind(watcher, body, field):
    r = watcher.post(CHANNELS, {"name": "C", **body}, format="json")
    assert r.status_code == 400 and field in r.json()["detail"]


def test_email_and_sms_channels_have_no_secret(watcher):
    r = watcher.post(CHANNELS, {"name": "Skipper", "kind": "sms", "target": "+61412345678"},
                     format="json")  # fmt: skip
    assert r.status_code == 201 and r.json()["secret"] == "" and r.json()["has_secret"] is False


def test_who_may_see_and_make_channels(operator, readonly, boat_a):
    body = {"name": "Ops", "kind": "email", "target": "ops@example.org"}
    for client in (operator, readonly, boat_a):
        assert client.get(CHANNELS).status_code == 403
        assert client.post(CHANNELS, body, format="json").status_code == 403
    assert not NotificationChannel.objects.exists()


def test_the_alerts_pages_with_a_cursor_and_refuses_a_bad_one(watcher, vessel_a):
    for minutes in (3, 2, 1):
        open_alert(vessel_a, minutes_ago=minutes, state=AlertState.RESOLVED)
    first = watcher.get(ALERTS, {"page_size": 2}).json()
    assert len(first["results"]) == 2 and first["next"]
    second = watcher.get(first["next"]).json()
    assert len(second["results"]) == 1
    assert watcher.get(ALERTS, {"cursor": "nonsense"}).status_code == 400
    assert watcher.get(ALERTS, {"page_size": "lots"}).status_code == 400
