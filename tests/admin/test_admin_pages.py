"""The admin is the operator's home: its pages render and act, through the services."""

from __future__ import annotations

import re

import pytest
from django.contrib.auth.models import User
from django.test import Client

from commands.models import Command, CommandEvent
from commands.services import command_claim_open, command_enqueue
from telemetry.services import fix_ingest
from vessels.keys import hash_key
from vessels.models import Mission, Vessel, VesselKey
from vessels.services import mission_save, mission_save_items

pytestmark = pytest.mark.django_db


@pytest.fixture
def admin_ui(admin_user: User) -> Client:
    client = Client()
    client.force_login(admin_user)
    return client


@pytest.fixture
def reported(vessel_a: Vessel, make_fix) -> Vessel:
    fix_ingest(vessel=vessel_a, records=[make_fix(battery_v=12.34)])
    vessel_a.refresh_from_db()
    return vessel_a


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


def test_the_vessel_page_shows_keys_recent_fixes_and_commands(
    admin_ui: Client, reported: Vessel, key_a: str
) -> None:
    command_enqueue(vessel=reported, kind="hold", params={})
    page = admin_ui.get(f"/admin/vessels/vessel/{reported.pk}/change/").content.decode()
    assert key_a[:12] in page  # the prefix, never the key
    assert key_a not in page
    assert "Issue a new key" in page
    assert "2026-11-23 10:00:00" in page
    assert "hold" in page and "queued" in page


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
            "notes": "",
        },
    )
    assert response.status_code == 302
    assert Vessel.objects.get(slug="third").telemetry_period_s == 30


def test_the_command_form_queues_a_valid_command(admin_ui: Client, vessel_a: Vessel) -> None:
    page = admin_ui.get("/admin/commands/command/add/").content.decode()
    assert "move_to__lat" in page and "command_form.js" in page
    response = admin_ui.post(
        "/admin/commands/command/add/",
        {
            "vessel": vessel_a.pk,
            "kind": "move_to",
            "move_to__lat": "-31.95",
            "move_to__lon": "115.86",
        },
    )
    assert response.status_code == 302
    command = Command.objects.get()
    assert (command.kind, command.params, command.source) == (
        "move_to",
        {"lat": -31.95, "lon": 115.86},
        "admin",
    )
    assert command.events.get().to_status == "queued"


def test_the_command_form_refuses_what_the_catalog_refuses(
    admin_ui: Client, vessel_a: Vessel, glider: Vessel
) -> None:
    missing = admin_ui.post(
        "/admin/commands/command/add/",
        {"vessel": vessel_a.pk, "kind": "move_to", "move_to__lat": "-31.95"},
    )
    assert "lon is required" in missing.content.decode()
    wrong_kind = admin_ui.post(
        "/admin/commands/command/add/",
        {"vessel": glider.pk, "kind": "move_to", "move_to__lat": "1", "move_to__lon": "2"},
    )
    assert "not available for wave_glider" in wrong_kind.content.decode()
    assert not Command.objects.exists()


def test_the_command_form_refuses_what_the_service_refuses(
    admin_ui: Client, vessel_a: Vessel
) -> None:
    # command_enqueue's own rules (past expiry, inactive vessel) are form errors, not a 500.
    past = admin_ui.post(
        "/admin/commands/command/add/",
        {
            "vessel": vessel_a.pk,
            "kind": "hold",
            "expires_at_0": "2001-01-01",
            "expires_at_1": "00:00:00",
        },
    )
    assert past.status_code == 200
    assert "expires_at must be in the future" in past.content.decode()
    Vessel.objects.filter(pk=vessel_a.pk).update(active=False)
    inactive = admin_ui.post(
        "/admin/commands/command/add/", {"vessel": vessel_a.pk, "kind": "hold"}
    )
    assert inactive.status_code == 200
    assert "vessel spab is not active" in inactive.content.decode()
    assert not Command.objects.exists()


def test_the_command_form_sends_a_mission_and_glider_commands(
    admin_ui: Client, vessel_a: Vessel, glider: Vessel
) -> None:
    mission = mission_save(mission=Mission(name="loop", vessel=vessel_a))
    mission_save_items(
        mission=mission, items=[{"lat": -31.9, "lon": 115.8}, {"lat": -31.91, "lon": 115.81}]
    )
    admin_ui.post(
        "/admin/commands/command/add/",
        {"vessel": vessel_a.pk, "kind": "mission", "mission": mission.pk},
    )
    admin_ui.post(
        "/admin/commands/command/add/",
        {
            "vessel": glider.pk,
            "kind": "fcourse",
            "fcourse__mode": "HOLD",
            "fcourse__indices": "3, 4 1",
        },
    )
    sent = {c.kind: c.params for c in Command.objects.all()}
    assert len(sent["mission"]["items"]) == 2
    assert sent["fcourse"] == {"mode": "HOLD", "indices": [3, 4, 1]}


def test_the_cancel_action_cancels_open_commands_only(admin_ui: Client, vessel_a: Vessel) -> None:
    open_one = command_enqueue(vessel=vessel_a, kind="arm", params={})
    done_one = command_enqueue(vessel=vessel_a, kind="disarm", params={})
    Command.objects.filter(pk=done_one.pk).update(status="done")
    admin_ui.post(
        "/admin/commands/command/",
        {"action": "cancel", "_selected_action": [open_one.pk, done_one.pk]},
    )
    open_one.refresh_from_db()
    done_one.refresh_from_db()
    assert (open_one.status, done_one.status) == ("cancelled", "done")


def test_a_command_page_is_read_only_with_its_history(admin_ui: Client, vessel_a: Vessel) -> None:
    command = command_enqueue(vessel=vessel_a, kind="hold", params={})
    command_claim_open(vessel=vessel_a)
    page = admin_ui.get(f"/admin/commands/command/{command.pk}/change/").content.decode()
    assert "queued" in page and "sent" in page
    assert 'name="_save"' not in page
    assert CommandEvent.objects.filter(command=command).count() == 2


def test_commands_and_keys_are_never_deleted_from_the_admin(
    admin_ui: Client, vessel_a: Vessel, key_a: str
) -> None:
    # Their history is the audit trail: a command is cancelled, a key revoked (services).
    command = command_enqueue(vessel=vessel_a, kind="hold", params={})
    key = VesselKey.objects.get()
    for model, pk in (("commands/command", command.pk), ("vessels/vesselkey", key.pk)):
        assert admin_ui.get(f"/admin/{model}/{pk}/delete/").status_code == 403
        changelist = admin_ui.get(f"/admin/{model}/").content.decode()
        assert 'value="delete_selected"' not in changelist
    assert Command.objects.filter(pk=command.pk).exists()
    assert VesselKey.objects.filter(pk=key.pk).exists()


def test_the_fix_list_is_cheap_and_filterable(
    admin_ui: Client, reported: Vessel, vessel_b: Vessel
) -> None:
    page = admin_ui.get(f"/admin/telemetry/fix/?vessel={reported.pk}").content.decode()
    assert "-31.9505" in page
    assert admin_ui.get("/admin/telemetry/fix/?recorded=1h").status_code == 200
    assert "Add fix" not in page


@pytest.mark.parametrize("value", ["abc", "1.5", "99999999999999999999999"])
def test_a_malformed_vessel_filter_is_not_a_500(
    admin_ui: Client, reported: Vessel, value: str
) -> None:
    response = admin_ui.get(f"/admin/telemetry/fix/?vessel={value}")
    assert response.status_code in (200, 302)


def test_the_mission_admin_saves_items_in_order(admin_ui: Client, vessel_a: Vessel) -> None:
    data = {
        "name": "Survey",
        "vessel": vessel_a.pk,
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


def test_the_send_action_queues_a_mission_and_explains_what_it_cannot_send(
    admin_ui: Client, vessel_a: Vessel, glider: Vessel
) -> None:
    ready = mission_save(mission=Mission(name="Ready", vessel=vessel_a, loop=True))
    mission_save_items(mission=ready, items=[{"lat": -31.9, "lon": 115.8, "radius_m": 5}])
    template = mission_save(mission=Mission(name="Template"))
    for_glider = mission_save(mission=Mission(name="Glider run", vessel=glider))
    mission_save_items(mission=for_glider, items=[{"lat": -32.0, "lon": 115.3}])
    response = admin_ui.post(
        "/admin/vessels/mission/",
        {"action": "send_to_vessel", "_selected_action": [ready.pk, template.pk, for_glider.pk]},
        follow=True,
    )
    page = response.content.decode()
    assert "Template: a template has no vessel" in page
    assert "Glider run: mission is not available for wave_glider vessels" in page
    command = Command.objects.get()
    assert (command.vessel, command.kind, command.source) == (vessel_a, "mission", "admin")
    assert command.params == {
        "mission_id": ready.pk,
        "loop": True,
        "items": [{"lat": -31.9, "lon": 115.8, "hold_s": 0.0, "radius_m": 5.0}],
    }


def test_a_sensor_channel_is_added_and_validated_in_the_admin(admin_ui: Client) -> None:
    from telemetry.models import SensorChannel

    bad = admin_ui.post(
        "/admin/telemetry/sensorchannel/add/", {"key": "water temp", "label": "Water", "unit": "°C"}
    )
    assert bad.status_code == 200 and not SensorChannel.objects.exists()
    good = admin_ui.post(
        "/admin/telemetry/sensorchannel/add/",
        {"key": "water_temp_c", "label": "Water", "unit": "°C", "minimum": 10, "maximum": 30},
    )
    assert good.status_code == 302
    assert SensorChannel.objects.get().key == "water_temp_c"


@pytest.mark.parametrize(
    "url",
    [
        "/admin/",
        "/admin/vessels/vessel/add/",
        "/admin/vessels/mission/",
        "/admin/telemetry/sensorchannel/",
        "/admin/commands/command/",
    ],
)
def test_every_admin_page_renders(admin_ui: Client, vessel_a: Vessel, url: str) -> None:
    assert admin_ui.get(url).status_code == 200


def test_admin_pages_need_a_login(client: Client) -> None:
    response = client.get("/admin/vessels/vessel/")
    assert response.status_code == 302 and "/admin/login/" in response["Location"]


def test_an_operator_without_permission_cannot_queue(
    client: Client, readonly_user: User, vessel_a: Vessel
) -> None:
    client.force_login(readonly_user)
    assert client.get("/admin/commands/command/add/").status_code == 403


@pytest.mark.parametrize(
    "url", ["/admin/auth/user/", "/admin/auth/group/", "/admin/operators/operatortoken/"]
)
def test_operators_and_their_api_tokens_are_managed_in_the_admin(
    admin_ui: Client, url: str
) -> None:
    assert admin_ui.get(url).status_code == 200


def test_a_vessels_slug_cannot_be_changed_once_created(admin_ui: Client, vessel_a: Vessel) -> None:
    admin_ui.post(
        f"/admin/vessels/vessel/{vessel_a.pk}/change/",
        {
            "name": "Renamed",
            "slug": "other",
            "kind": "mavlink",
            "active": "on",
            "telemetry_period_s": 10,
            "notes": "",
            "keys-TOTAL_FORMS": 0,
            "keys-INITIAL_FORMS": 0,
        },
    )
    vessel_a.refresh_from_db()
    assert (vessel_a.name, vessel_a.slug) == ("Renamed", "spab")
