"""The admin site as assembled (fleet.admin): pages joining apps, logins, every page renders."""

from __future__ import annotations

import pytest
from django.test import Client

from commands.models import Command
from commands.services import command_enqueue
from tests.conftest import make_user
from vessels.models import Mission, Vessel
from vessels.services import mission_save, mission_save_items

pytestmark = pytest.mark.django_db


def test_the_vessel_page_shows_keys_recent_fixes_and_commands(
    admin_ui: Client, reported: Vessel, key_a: str
) -> None:
    command_enqueue(vessel=reported, kind="hold", params={}, source="map")
    page = admin_ui.get(f"/admin/vessels/vessel/{reported.pk}/change/").content.decode()
    assert key_a[:12] in page  # the prefix, never the key
    assert key_a not in page
    assert "Issue a new key" in page
    assert "2026-11-23 10:00:00" in page
    assert "hold" in page and "queued" in page
    assert "<th>source</th>" in page and "<td>Map</td>" in page
    # The status in the colour the command list and the map give it (superseded grey).
    assert '<span class="command-status cmd-queued">queued</span>' in page
    assert "commands/status.css" in page


def send_action(client: Client, chosen: list[Mission]) -> str:
    """The list's Send action as an operator uses it: choose, read the summaries (nothing is
    queued yet), confirm. Returns the page after the confirmation."""
    chosen_pks = [m.pk for m in chosen]
    asked = client.post(
        "/admin/vessels/mission/", {"action": "send_to_vessel", "_selected_action": chosen_pks}
    )
    assert asked.status_code == 200 and "Send these missions?" in asked.content.decode()
    assert not Command.objects.exists()
    versions = {
        f"updated_at_{m.pk}": m.updated_at.isoformat()
        for m in Mission.objects.filter(pk__in=chosen_pks)
    }
    answer = client.post(
        "/admin/vessels/mission/",
        {"action": "send_to_vessel", "_selected_action": chosen_pks, "confirm": "yes", **versions},
        follow=True,
    )
    return answer.content.decode()


def test_the_send_action_asks_first_with_each_summary_and_skips_a_mission_saved_since(
    admin_ui: Client, reported: Vessel
) -> None:
    mission = mission_save(mission=Mission(name="Bay", vessel=reported))
    mission_save_items(mission=mission, items=[{"lat": -31.9505, "lon": 115.8705}])
    asked = admin_ui.post(
        "/admin/vessels/mission/", {"action": "send_to_vessel", "_selected_action": [mission.pk]}
    ).content.decode()
    assert "Bay</strong>: Send to SPAB: 1 waypoint" in asked
    assert "from waypoint 1; then it stops at the last waypoint." in asked
    assert not Command.objects.exists()
    mission.refresh_from_db()
    summed_up = mission.updated_at.isoformat()
    mission_save_items(mission=mission, items=[{"lat": -31.96, "lon": 115.88}])  # saved since
    confirm = {
        "action": "send_to_vessel",
        "_selected_action": [mission.pk],
        "confirm": "yes",
        f"updated_at_{mission.pk}": summed_up,
    }
    page = admin_ui.post("/admin/vessels/mission/", confirm, follow=True).content.decode()
    assert "Bay: not sent: the mission was saved at" in page
    assert not Command.objects.exists()
    assert "queued as command" in send_action(admin_ui, [mission])
    assert Command.objects.get().params["items"][0]["lat"] == -31.96


def test_the_send_action_queues_a_mission_and_explains_what_it_cannot_send(
    admin_ui: Client, vessel_a: Vessel, glider: Vessel
) -> None:
    ready = mission_save(mission=Mission(name="Ready", vessel=vessel_a, end="loop"))
    mission_save_items(mission=ready, items=[{"lat": -31.9, "lon": 115.8, "radius_m": 5}])
    template = mission_save(mission=Mission(name="Template"))
    for_glider = mission_save(mission=Mission(name="Glider run", vessel=glider))
    mission_save_items(mission=for_glider, items=[{"lat": -32.0, "lon": 115.3}])
    page = send_action(admin_ui, [ready, template, for_glider])
    assert "Template: a template has no vessel" in page
    assert "Glider run: mission is not available for wave_glider vessels" in page
    command = Command.objects.get()
    assert (command.vessel, command.kind, command.source) == (vessel_a, "mission", "admin")
    assert command.params == {
        "mission_id": ready.pk,
        "loop": True,
        "end": "loop",
        "items": [{"lat": -31.9, "lon": 115.8, "hold_s": 0.0, "radius_m": 5.0, "speed_mps": None}],
    }


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


@pytest.mark.parametrize(
    "url", ["/admin/auth/user/", "/admin/auth/group/", "/admin/operators/operatortoken/"]
)
def test_operators_and_their_api_tokens_are_managed_in_the_admin(
    admin_ui: Client, url: str
) -> None:
    assert admin_ui.get(url).status_code == 200


def test_the_send_action_shows_why_a_mission_fails_its_checks(
    admin_ui: Client, vessel_a: Vessel, settings: object
) -> None:
    settings.MISSION_MAX_LEG_M = 1000
    far = mission_save(mission=Mission(name="Far", vessel=vessel_a))
    mission_save_items(
        mission=far, items=[{"lat": -31.9, "lon": 115.8}, {"lat": -32.0, "lon": 115.8}]
    )
    page = send_action(admin_ui, [far])
    assert "Far: leg 1 → 2 is 11.1 km, longer than the limit of 1.0 km" in page
    assert not Command.objects.exists()


def test_the_send_action_needs_the_right_to_see_vessels_as_the_api_does(
    client: Client, vessel_a: Vessel
) -> None:
    perms = ["vessels.view_mission", "vessels.change_mission", "commands.add_command"]
    client.force_login(make_user("mo", perms))
    template = mission_save(mission=Mission(name="Template"))
    listing = client.get("/admin/vessels/mission/").content.decode()
    assert "Template" in listing and "send_to_vessel" not in listing
    client.post(
        "/admin/vessels/mission/",
        {"action": "send_to_vessel", "_selected_action": [template.pk]},
    )
    assert not Command.objects.exists()
    client.force_login(make_user("vic", [*perms, "vessels.view_vessel"]))
    assert "send_to_vessel" in client.get("/admin/vessels/mission/").content.decode()


def test_the_vessel_pages_recent_fixes_read_as_the_fixes_list(
    admin_ui: Client, vessel_a: Vessel, make_fix
) -> None:
    from telemetry.services import fix_ingest

    fix_ingest(
        vessel=vessel_a,
        records=[make_fix(lat=-32.038, lon=115.3325, readings={"mode_number": 11, "armed": 0})],
    )
    command_enqueue(vessel=vessel_a, kind="hold", params={})
    page = admin_ui.get(f"/admin/vessels/vessel/{vessel_a.pk}/change/").content.decode()
    assert '<td class="nowrap">2026-11-23 10:00:00 UTC</td>' in page
    assert 'title="32°02.280′S 115°19.950′E">-32.03800°, 115.33250°</td>' in page
    assert "1.2 m/s (2.3 kn)" in page
    assert (
        '<span class="nowrap">Mode RTL</span>\u00a0· <span class="nowrap">disarmed</span>' in page
    )
    command = Command.objects.get()
    assert f"<td>{command.created_at:%Y-%m-%d %H:%M:%S} UTC</td>" in page
