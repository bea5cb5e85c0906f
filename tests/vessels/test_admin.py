"""The vessel, key and mission admins (vessels.admin)."""

from __future__ import annotations

import re

import pytest
from django.test import Client

from vessels.keys import hash_key
from vessels.models import Mission, Vessel, VesselKey

pytestmark = pytest.mark.django_db


def test_it_lists_vessels_with_status_position_and_battery(
    admin_ui: Client, reported: Vessel, vessel_b: Vessel
) -> None:
    page = admin_ui.get("/admin/vessels/vessel/").content.decode()
    assert "SPAB 2" in page and "never seen" in page
    assert "-31.95050, 115.86050" in page
    assert "12.34" in page


def test_it_filters_vessels_by_status(admin_ui: Client, reported: Vessel, vessel_b: Vessel) -> None:
    page = admin_ui.get("/admin/vessels/vessel/?status=never+seen").content.decode()
    assert "SPAB 2" in page and ">SPAB<" not in page


def test_issuing_a_key_shows_it_once_and_stores_only_its_hash(
    admin_ui: Client, vessel_a: Vessel
) -> None:
    response = admin_ui.post(
        "/admin/vessels/vesselkey/add/", {"vessel": vessel_a.pk, "label": "pi"}
    )
    assert response.status_code == 200
    assert "no-store" in response["Cache-Control"]
    raw = re.search(r'id="vessel-key"[^>]*>(ssk_[^<]+)<', response.content.decode()).group(1)
    key = VesselKey.objects.get(vessel=vessel_a)
    assert key.key_hash == hash_key(raw) and key.label == "pi"
    assert raw not in admin_ui.get(f"/admin/vessels/vessel/{vessel_a.pk}/change/").content.decode()


def test_the_revoke_action_revokes_keys(admin_ui: Client, key_a: str) -> None:
    key = VesselKey.objects.get()
    admin_ui.post("/admin/vessels/vesselkey/", {"action": "revoke", "_selected_action": [key.pk]})
    key.refresh_from_db()
    assert key.revoked_at is not None


def test_it_creates_a_vessel_through_the_form(admin_ui: Client) -> None:
    response = admin_ui.post(
        "/admin/vessels/vessel/add/",
        {
            "name": "Third",
            "slug": "third",
            "kind": "mavlink",
            "active": "on",
            "telemetry_period_s": 30,
            "cruise_speed_mps": 2.0,
            "notes": "",
        },
    )
    assert response.status_code == 302
    third = Vessel.objects.get(slug="third")
    assert (third.telemetry_period_s, third.cruise_speed_mps) == (30, 2.0)


def test_the_mission_admin_saves_items_in_order(admin_ui: Client, vessel_a: Vessel) -> None:
    data = {
        "name": "Survey",
        "vessel": vessel_a.pk,
        "end": "stop",
        "notes": "",
        "items-TOTAL_FORMS": 2,
        "items-INITIAL_FORMS": 0,
        "items-0-seq": 2,
        "items-0-lat": -31.91,
        "items-0-lon": 115.81,
        "items-0-hold_s": 0,
        "items-1-seq": 1,
        "items-1-lat": -31.90,
        "items-1-lon": 115.80,
        "items-1-hold_s": 5,
    }
    assert admin_ui.post("/admin/vessels/mission/add/", data).status_code == 302
    mission = Mission.objects.get()
    assert [(i.seq, i.lat) for i in mission.items.all()] == [(1, -31.90), (2, -31.91)]


def test_a_vessels_slug_cannot_be_changed_once_created(admin_ui: Client, vessel_a: Vessel) -> None:
    admin_ui.post(
        f"/admin/vessels/vessel/{vessel_a.pk}/change/",
        {
            "name": "Renamed",
            "slug": "other",
            "kind": "mavlink",
            "active": "on",
            "telemetry_period_s": 10,
            "cruise_speed_mps": 1.5,
            "notes": "",
            "keys-TOTAL_FORMS": 0,
            "keys-INITIAL_FORMS": 0,
        },
    )
    vessel_a.refresh_from_db()
    assert (vessel_a.name, vessel_a.slug) == ("Renamed", "spab")
