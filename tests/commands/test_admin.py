"""The command admin: the catalog-built form, the cancel action, the read-only history."""

from __future__ import annotations

import re

import pytest
from django.conf import settings
from django.contrib.auth.models import User
from django.test import Client

from commands.models import Command, CommandEvent, Source
from commands.services import command_ack, command_claim_open, command_enqueue
from tests.conftest import give_position
from vessels.models import Mission, Vessel, VesselKey
from vessels.services import mission_save, mission_save_items

pytestmark = pytest.mark.django_db


def test_the_command_form_queues_a_valid_command(admin_ui: Client, vessel_a: Vessel) -> None:
    give_position(vessel_a)
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


def test_statuses_show_in_their_colour_superseded_in_grey_not_failed_red(
    admin_ui: Client, vessel_a: Vessel
) -> None:
    give_position(vessel_a, -31.0, 115.0)
    replaced = command_enqueue(vessel=vessel_a, kind="move_to", params={"lat": -31, "lon": 115})
    command_claim_open(vessel=vessel_a)
    command_ack(vessel=vessel_a, uid=replaced.uid, status="superseded", detail="replaced")
    failed = command_enqueue(vessel=vessel_a, kind="arm", params={})
    command_claim_open(vessel=vessel_a)
    command_ack(vessel=vessel_a, uid=failed.uid, status="failed", detail="pre-arm")
    changelist = admin_ui.get("/admin/commands/command/").content.decode()
    assert '<span class="command-status cmd-superseded">superseded</span>' in changelist
    assert '<span class="command-status cmd-failed">failed</span>' in changelist
    assert "commands/status.css" in changelist
    page = admin_ui.get(f"/admin/commands/command/{replaced.pk}/change/").content.decode()
    assert '<span class="command-status cmd-superseded">superseded</span>' in page
    css = (settings.BASE_DIR / "commands/static/commands/status.css").read_text()
    assert re.search(r"\.cmd-superseded[^{]*\{ background: #757575; \}", css)  # grey


def test_a_command_is_titled_by_its_vessels_name_and_listed_with_its_source(
    admin_ui: Client, vessel_a: Vessel, vessel_b: Vessel
) -> None:
    # vessel_b's id is not 1: a title with the id would read "hold → 2".
    command = command_enqueue(vessel=vessel_b, kind="hold", params={}, source=Source.MAP)
    assert str(command) == "hold → SPAB 2 (queued)"
    page = admin_ui.get(f"/admin/commands/command/{command.pk}/change/").content.decode()
    assert "hold → SPAB 2 (queued)" in page
    assert f"hold → {vessel_b.pk}" not in page
    command_enqueue(vessel=vessel_a, kind="arm", params={}, source=Source.ADMIN)
    changelist = admin_ui.get("/admin/commands/command/").content.decode()
    assert '<td class="field-source">Map</td>' in changelist
    assert '<td class="field-source">Admin</td>' in changelist
    only_map = admin_ui.get("/admin/commands/command/?source__exact=map").content.decode()
    assert '<td class="field-source">Map</td>' in only_map
    assert '<td class="field-source">Admin</td>' not in only_map


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


def test_an_operator_without_permission_cannot_queue(
    client: Client, readonly_user: User, vessel_a: Vessel
) -> None:
    client.force_login(readonly_user)
    assert client.get("/admin/commands/command/add/").status_code == 403


def test_a_commands_page_follows_its_state_until_it_is_finished(
    admin_ui: Client, vessel_a: Vessel
) -> None:
    give_position(vessel_a)
    command = command_enqueue(
        vessel=vessel_a, kind="hold", params={}, source=Source.ADMIN, created_by="t"
    )
    page = admin_ui.get(f"/admin/commands/command/{command.pk}/change/").content.decode()
    assert 'id="command-live"' in page and "command_live.js" in page
    assert f'data-state-url="/admin/commands/command/{command.pk}/state/"' in page
    assert 'data-status="queued"' in page and 'data-unfinished="1"' in page

    def state() -> dict:
        return admin_ui.get(f"/admin/commands/command/{command.pk}/state/").json()

    assert state() == {
        "status": "queued",
        "events": command.events.count(),
        "unfinished": True,
        "poll_s": settings.FLEET_MAP_POLL_S,
    }
    command_claim_open(vessel=vessel_a)
    assert state()["status"] == "sent" and state()["unfinished"]
    command_ack(vessel=vessel_a, uid=str(command.uid), status="done", detail="")
    assert state()["status"] == "done" and not state()["unfinished"]
    page = admin_ui.get(f"/admin/commands/command/{command.pk}/change/").content.decode()
    assert 'data-unfinished=""' in page and "finished" in page
    assert admin_ui.get("/admin/commands/command/999999/state/").status_code == 404


def test_a_commands_state_is_not_shown_without_the_right_to_see_commands(
    vessel_a: Vessel,
) -> None:
    give_position(vessel_a)
    command = command_enqueue(
        vessel=vessel_a, kind="hold", params={}, source=Source.ADMIN, created_by="t"
    )
    user = User.objects.create_user("nosy", password="x", is_staff=True)
    client = Client()
    client.force_login(user)
    assert client.get(f"/admin/commands/command/{command.pk}/state/").status_code in (403, 404)
