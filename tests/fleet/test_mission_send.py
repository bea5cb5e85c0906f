"""The mission page's Send and the planner's review (issue 16 §1, §4, §11): a send queues the
mission only when the route the operator confirmed is the saved one, after a summary; the
planner's figures and checks come from the server's one review."""

from __future__ import annotations

import json

import pytest
from django.core.files.uploadedfile import SimpleUploadedFile
from django.test import Client
from rest_framework.test import APIClient

from commands.models import Command
from edge_client.contract import geo
from tests.conftest import make_user
from vessels.models import Mission, Vessel
from vessels.services import mission_save, mission_save_items

pytestmark = pytest.mark.django_db

START = (-31.9505, 115.8605)  # the fixture fix's position


def five_waypoints(vessel: Vessel) -> Mission:
    mission = mission_save(mission=Mission(name="Five", vessel=vessel))
    points = [geo.offset(*START, 90, 200 * n) for n in range(1, 6)]
    return mission_save_items(mission=mission, items=[{"lat": a, "lon": b} for a, b in points])


def send(client: Client, mission: Mission, confirmed: object, shown_at: str | None = "") -> str:
    """Post the page's Send form: the route it showed, and the version it was rendered from
    (by default the mission's current one, as a page loaded just now)."""
    body = {} if confirmed is None else {"confirmed": json.dumps(confirmed)}
    if shown_at is not None:
        body["updated_at"] = shown_at or Mission.objects.get(pk=mission.pk).updated_at.isoformat()
    answer = client.post(f"/admin/vessels/mission/{mission.pk}/send/", body, follow=True)
    assert answer.status_code == 200
    return answer.content.decode()


def test_a_send_of_a_route_other_than_the_saved_one_is_refused_and_nothing_is_queued(
    admin_ui: Client, reported: Vessel
) -> None:
    mission = five_waypoints(reported)
    on_screen = {"end": "stop", "items": mission.item_dicts()[:4]}  # waypoint 5 deleted, unsaved
    page = send(admin_ui, mission, on_screen)
    assert "not sent: the mission on screen is not the one saved" in page
    assert "4 waypoints on screen, 5 saved" in page
    assert send(admin_ui, mission, None).count("the route on screen was not confirmed") == 1
    assert not Command.objects.exists()

    page = send(admin_ui, mission, {"end": "stop", "items": mission.item_dicts()})
    assert "queued as command" in page
    assert len(Command.objects.get().params["items"]) == 5


def test_a_send_from_a_page_older_than_the_last_save_is_refused(
    admin_ui: Client, reported: Vessel, vessel_b: Vessel
) -> None:
    """The page's summary said "Send to SPAB"; someone else then moved the mission to SPAB 2
    with the same route. The route matches, yet the send must not go out under that summary."""
    mission = five_waypoints(reported)
    page = admin_ui.get(f"/admin/vessels/mission/{mission.pk}/change/").content.decode()
    mission.refresh_from_db()
    shown_at = mission.updated_at.isoformat()
    assert f'name="updated_at" value="{shown_at}"' in page
    mission.vessel = vessel_b
    mission_save(mission=mission)
    route = {"end": "stop", "items": mission.item_dicts()}
    answer = send(admin_ui, mission, route, shown_at=shown_at)
    assert "not sent: the mission was saved at" in answer
    assert "did not say which version" in send(admin_ui, mission, route, shown_at=None)
    assert not Command.objects.exists()
    assert "queued as command" in send(admin_ui, mission, route)
    assert Command.objects.get().vessel == vessel_b


@pytest.mark.parametrize(
    "item",
    [
        {"lat": 1e308, "lon": 115.86},
        {"lat": "x", "lon": 115.86},
        {"lat": float("nan"), "lon": 115.86},
        {"lon": 115.86},
    ],
)
def test_a_malformed_confirmed_route_is_refused_not_a_500(
    admin_ui: Client, reported: Vessel, item: dict
) -> None:
    mission = five_waypoints(reported)
    items = [item, *mission.item_dicts()[1:]]
    page = send(admin_ui, mission, {"end": "stop", "items": items})
    assert "waypoint 1 on screen is not waypoint 1 as saved" in page
    assert not Command.objects.exists()


def test_the_send_button_carries_a_summary_to_confirm(admin_ui: Client, reported: Vessel) -> None:
    mission = five_waypoints(reported)
    page = admin_ui.get(f"/admin/vessels/mission/{mission.pk}/change/").content.decode()
    assert (
        'data-confirm="Send to SPAB: 5 waypoints · 800 m · 9 min. SPAB&#x27;s last fix is '
        '200 m from waypoint 1; then it stops at the last waypoint."'
    ) in page


def test_sending_needs_the_right_to_command(client: Client, reported: Vessel) -> None:
    mission = five_waypoints(reported)
    client.force_login(make_user("viv", ["vessels.view_vessel", "vessels.view_mission"]))
    answer = client.post(
        f"/admin/vessels/mission/{mission.pk}/send/",
        {"confirmed": json.dumps({"end": "stop", "items": mission.item_dicts()})},
    )
    assert answer.status_code == 403
    assert not Command.objects.exists()


def review(client: Client, body: object) -> object:
    return client.post("/admin/vessels/mission/review/", body, content_type="application/json")


def test_the_planner_review_marks_a_long_leg_and_an_impossible_row(
    admin_ui: Client, vessel_a: Vessel, settings
) -> None:
    settings.MISSION_MAX_LEG_M = 50_000
    far = geo.offset(*START, 90, 113_000)
    rows = [
        {"lat": START[0], "lon": START[1], "hold_s": 30},
        {"lat": 95, "lon": START[1]},
        {"lat": far[0], "lon": far[1]},
    ]
    answer = review(admin_ui, {"rows": rows, "end": "stop", "vessel": vessel_a.pk})
    assert answer.status_code == 200
    data = answer.json()
    assert data["rows"] == [[], ["latitude 95 is not within -90…90"], []]
    assert data["holds"] == ["30 s", "", ""]
    assert [(leg["from"], leg["to"]) for leg in data["legs"]] == [(1, 2)]
    assert data["legs"][0]["problem"].startswith("leg 1 → 2 is 113.0 km, longer than")
    assert data["total"].startswith("2 waypoints · 113.0 km")


def test_the_route_table_and_the_planner_show_the_same_totals(
    admin_ui: Client, vessel_a: Vessel
) -> None:
    mission = mission_save(mission=Mission(name="Bay", vessel=vessel_a))
    rows = [{"lat": START[0], "lon": START[1], "hold_s": 30}]
    rows.append(dict(zip(("lat", "lon"), geo.offset(*START, 90, 1095), strict=True)))
    mission_save_items(mission=mission, items=rows)
    page = admin_ui.get(f"/admin/vessels/mission/{mission.pk}/change/").content.decode()
    total = review(admin_ui, {"rows": rows, "end": "stop", "vessel": vessel_a.pk}).json()["total"]
    assert total == "2 waypoints · 1.1 km · 13 min (holds 30 s)"
    assert f'<b id="mission-route-total">{total}</b>' in page


def test_the_review_refuses_what_is_not_a_route(admin_ui: Client, client: Client) -> None:
    assert review(admin_ui, "[1, 2]").status_code == 400
    assert review(admin_ui, {"rows": [1]}).status_code == 400
    assert (
        admin_ui.post(
            "/admin/vessels/mission/review/", b"\xff", content_type="application/json"
        ).status_code
        == 400
    )
    client.force_login(make_user("nobody", []))
    assert review(client, {"rows": []}).status_code == 403


def api_for(user_perms: list[str]) -> APIClient:
    client = APIClient()
    client.force_authenticate(make_user("api-carol", user_perms))
    return client


API_PERMS = [
    "vessels.view_vessel",
    "vessels.view_mission",
    "vessels.add_mission",
    "vessels.change_mission",
    "commands.add_command",
]


def test_an_api_send_naming_an_older_version_is_refused(reported: Vessel) -> None:
    api = api_for(API_PERMS)
    mission = five_waypoints(reported)
    seen = api.get(f"/api/v1/missions/{mission.pk}/").json()["updated_at"]
    api.patch(f"/api/v1/missions/{mission.pk}/", {"items": mission.item_dicts()[:4]}, format="json")
    stale = api.post(f"/api/v1/missions/{mission.pk}/send/", {"updated_at": seen}, format="json")
    assert stale.status_code == 400
    assert "not sent: the mission was saved at" in stale.json()["detail"]["updated_at"][0]
    assert not Command.objects.exists()
    now = api.get(f"/api/v1/missions/{mission.pk}/").json()["updated_at"]
    sent = api.post(f"/api/v1/missions/{mission.pk}/send/", {"updated_at": now}, format="json")
    assert sent.status_code == 201 and len(Command.objects.get().params["items"]) == 4


LONG_LEG = b"""QGC WPL 110
0\t1\t0\t16\t0\t0\t0\t0\t-31.979000\t115.817000\t0.000000\t1
1\t0\t3\t16\t0\t0\t0\t0\t-31.980000\t115.820000\t0.000000\t1
2\t0\t3\t16\t0\t0\t0\t0\t-31.980000\t117.020000\t0.000000\t1
"""


def test_importing_a_file_with_an_over_long_leg_says_so(
    admin_ui: Client, vessel_a: Vessel, settings
) -> None:
    settings.MISSION_MAX_LEG_M = 50_000
    api = api_for(API_PERMS)
    answer = api.post(
        "/api/v1/missions/import/",
        {"file": SimpleUploadedFile("far.waypoints", LONG_LEG)},
        format="multipart",
    )
    assert answer.status_code == 201
    [problem] = answer.json()["problems"]
    assert problem.startswith("leg 1 → 2 is 113.2 km, longer than the limit of 50.0 km")
    page = admin_ui.post(
        "/admin/vessels/mission/import/",
        {"file": SimpleUploadedFile("far.waypoints", LONG_LEG), "vessel": vessel_a.pk},
        follow=True,
    ).content.decode()
    assert f"Imported, but it cannot be sent yet: {problem}." in page


def test_a_sent_mission_lands_on_its_commands_page_for_whoever_may_see_commands(
    admin_ui: Client, reported: Vessel
) -> None:
    mission = five_waypoints(reported)
    route = {"end": "stop", "items": mission.item_dicts()}
    updated = Mission.objects.get(pk=mission.pk).updated_at.isoformat()
    answer = admin_ui.post(
        f"/admin/vessels/mission/{mission.pk}/send/",
        {"confirmed": json.dumps(route), "updated_at": updated},
    )
    command = Command.objects.get()
    assert answer.status_code == 302
    assert answer["Location"] == f"/admin/commands/command/{command.pk}/change/"

    # Without the right to see commands, the mission page again (the command page would 403).
    sender = make_user(
        "sam",
        [
            "vessels.view_vessel",
            "vessels.view_mission",
            "vessels.change_mission",
            "commands.add_command",
        ],
    )
    client = Client()
    client.force_login(sender)
    answer = client.post(
        f"/admin/vessels/mission/{mission.pk}/send/",
        {"confirmed": json.dumps(route), "updated_at": updated},
    )
    assert answer.status_code == 302
    assert answer["Location"] == f"/admin/vessels/mission/{mission.pk}/change/"
    assert Command.objects.count() == 2
