"""The admin pages for fences (map drawing, import, send), alert rules, alerts (acknowledge)
and channels (a webhook's secret shown once), each writing through the services."""

from __future__ import annotations

import json

import pytest
from django.core.files.uploadedfile import SimpleUploadedFile

from alerts.models import Alert, AlertRule, NotificationChannel
from audit.models import AuditEntry
from tests.alerts.test_api_rules import open_alert
from tests.vessels.test_fence_geometry import PLAN, SQUARE, polygon
from vessels.fence_services import fence_create
from vessels.models import Fence

pytestmark = pytest.mark.django_db


def test_the_fence_page_has_the_drawing_map(admin_ui, vessel_a):
    page = admin_ui.get("/admin/vessels/fence/add/").content.decode()
    assert 'id="fence-map"' in page
    assert "leaflet/draw/leaflet.draw.js" in page and "alerts/fence_editor.js" in page
    assert 'name="geometry"' in page and 'name="radius_m"' in page


def test_a_fence_drawn_and_saved_is_stored_and_audited(admin_ui, vessel_a):
    r = admin_ui.post("/admin/vessels/fence/add/", {
        "name": "Harbour", "vessel": vessel_a.pk, "inclusion": "on",
        "geometry": json.dumps(polygon(SQUARE)), "radius_m": "", "notes": "",
    })  # fmt: skip
    assert r.status_code == 302, r.content.decode()[-2000:]
    fence = Fence.objects.get()
    assert fence.geometry == polygon(SQUARE) and fence.vessel == vessel_a
    entry = AuditEntry.objects.exclude(action__startswith="login.").get()
    assert (entry.action, entry.via, entry.actor) == ("fence.created", "admin", "admin")
    # Changed on the page: the entry says what changed.
    r = admin_ui.post(f"/admin/vessels/fence/{fence.pk}/change/", {
        "name": "Harbour", "vessel": vessel_a.pk, "geometry": json.dumps(polygon(SQUARE)),
        "radius_m": "", "notes": "",
    })  # fmt: skip
    assert r.status_code == 302
    assert AuditEntry.objects.get(action="fence.changed").detail["changed"] == {
        "inclusion": {"from": True, "to": False}
    }


def test_an_open_ring_is_marked_on_the_page(admin_ui):
    r = admin_ui.post("/admin/vessels/fence/add/", {
        "name": "Open", "geometry": json.dumps(polygon(SQUARE[:-1])), "radius_m": "",
    })  # fmt: skip
    assert r.status_code == 200
    assert "the ring must be closed" in r.content.decode()
    assert not Fence.objects.exists()


def test_fences_are_imported_from_a_plan(admin_ui, vessel_a):
    assert "Import fences" in admin_ui.get("/admin/vessels/fence/").content.decode()
    upload = SimpleUploadedFile("reef.plan", json.dumps(PLAN).encode())
    r = admin_ui.post("/admin/vessels/fence/import/", {"file": upload, "vessel": vessel_a.pk})
    assert r.status_code == 302
    assert sorted(Fence.objects.values_list("name", flat=True)) == ["reef 1", "reef 2", "reef 3"]
    bad = SimpleUploadedFile("bad.geojson", b'{"type": "Point", "coordinates": [1, 2]}')
    r = admin_ui.post("/admin/vessels/fence/import/", {"file": bad})
    assert "needs radius_m" in r.content.decode()


def test_sending_a_fence_says_what_happened_per_vessel(admin_ui, vessel_a):
    fence = fence_create(name="Box", geometry=polygon(SQUARE), vessel=vessel_a)
    chosen = {"action": "send_to_vessel", "_selected_action": [fence.pk]}
    r = admin_ui.post("/admin/vessels/fence/", chosen, follow=True)
    page = r.content.decode()
    assert "Box → SPAB:" in page  # queued, or the catalog's reason why not


def test_a_rule_is_checked_for_its_kind_on_the_page(admin_ui):
    r = admin_ui.post(
        "/admin/alerts/alertrule/add/", {"name": "Low", "kind": "battery", "active": "on"}
    )
    assert r.status_code == 200
    assert "a battery rule needs a threshold (volts)" in r.content.decode()
    r = admin_ui.post("/admin/alerts/alertrule/add/", {
        "name": "Low", "kind": "battery", "threshold": "11.5", "active": "on",
    })  # fmt: skip
    assert r.status_code == 302
    rule = AlertRule.objects.get()
    assert AuditEntry.objects.exclude(action__startswith="login.").get().action == "rule.created"
    listed = admin_ui.get("/admin/alerts/alertrule/").content.decode()
    assert "11.5 V" in listed and "every vessel" in listed
    admin_ui.post(f"/admin/alerts/alertrule/{rule.pk}/delete/", {"post": "yes"})
    assert not AlertRule.objects.exists()
    assert AuditEntry.objects.filter(action="rule.deleted").exists()


def test_alerts_are_acknowledged_from_the_list(admin_ui, vessel_a):
    alert = open_alert(vessel_a)
    page = admin_ui.get("/admin/alerts/alert/?active=yes").content.decode()
    assert "alert-open" in page and "battery 11.2 V" in page
    chosen = {"action": "acknowledge", "_selected_action": [alert.pk]}
    r = admin_ui.post("/admin/alerts/alert/", chosen, follow=True)
    assert "Acknowledged 1 alert(s)." in r.content.decode()
    alert.refresh_from_db()
    assert (alert.state, alert.acknowledged_by) == ("acknowledged", "admin")
    assert Alert.objects.count() == 1


def test_a_webhooks_secret_is_shown_once_after_saving(admin_ui):
    r = admin_ui.post("/admin/alerts/notificationchannel/add/", {
        "name": "Pager", "kind": "webhook", "target": "https://pager.example.org/hook",
    }, follow=True)  # fmt: skip
    channel = NotificationChannel.objects.get()
    page = r.content.decode()
    assert channel.secret and f'<code class="channel-secret">{channel.secret}</code>' in page
    again = admin_ui.get(f"/admin/alerts/notificationchannel/{channel.pk}/change/").content.decode()
    assert channel.secret not in again
    admin_ui.post(f"/admin/alerts/notificationchannel/{channel.pk}/change/", {
        "name": "Pager", "target": "https://pager.example.org/hook2",
    })  # fmt: skip
    channel.refresh_from_db()
    assert channel.target.endswith("hook2") and channel.active is False
    assert AuditEntry.objects.filter(action="channel.changed").exists()
