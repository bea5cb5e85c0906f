"""The mission API (/api/v1/missions/): CRUD, file import and export, sending, permissions."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import jsonschema
import pytest
from django.contrib.auth.models import User
from django.core.files.uploadedfile import SimpleUploadedFile
from django.db import connection
from django.test.utils import CaptureQueriesContext
from rest_framework.test import APIClient

from commands.models import Command
from edge_client.contract import geo
from tests.conftest import OPERATOR_PERMS, make_user
from tests.support import commands_url
from vessels import missionfiles
from vessels.errors import MissionCheckError
from vessels.missions import MISSION_MAX_ITEMS
from vessels.models import Mission, Vessel
from vessels.services import mission_save, mission_save_items

pytestmark = pytest.mark.django_db

MISSIONS = "/api/v1/missions/"
IMPORT = "/api/v1/missions/import/"
FILES = Path(__file__).parent / "files"
MISSION_PERMS = [
    "vessels.view_mission",
    "vessels.add_mission",
    "vessels.change_mission",
    "vessels.delete_mission",
]
START = (-31.98412, 115.83095)


def detail(mission: Mission | int) -> str:
    return f"{MISSIONS}{getattr(mission, 'pk', mission)}/"


def client_for(user: User) -> APIClient:
    client = APIClient()
    client.force_authenticate(user)
    return client


@pytest.fixture
def planner(db: None) -> APIClient:
    """Carol: plans missions and sends them to the boats she can see."""
    return client_for(make_user("carol", [*OPERATOR_PERMS, *MISSION_PERMS]))


@pytest.fixture
def template_planner(db: None) -> APIClient:
    """Dave: may plan missions but not see vessels, so only templates."""
    return client_for(make_user("dave", MISSION_PERMS))


def route(*metres_east: float) -> list[dict[str, float]]:
    return [dict(zip(("lat", "lon"), geo.offset(*START, 90, m), strict=True)) for m in metres_east]


def saved(vessel: Vessel | None, items: list[dict[str, Any]], **fields: Any) -> Mission:
    mission = mission_save(mission=Mission(name=fields.pop("name", "Run"), vessel=vessel, **fields))
    return mission_save_items(mission=mission, items=items)


def upload(filename: str, content: bytes | None = None, **fields: Any) -> dict[str, Any]:
    content = (FILES / filename).read_bytes() if content is None else content
    return {"file": SimpleUploadedFile(filename, content), **fields}


# --- CRUD ---


def test_a_planner_creates_a_mission_with_its_items_in_order(
    planner: APIClient, vessel_a: Vessel
) -> None:
    items = [{**p, "hold_s": 30} for p in route(0, 300)] + [{**route(600)[0], "speed_mps": 3}]
    body = {"name": "Bay", "vessel": "spab", "end": "loop", "items": items}
    response = planner.post(MISSIONS, body, format="json")
    assert response.status_code == 201, response.json()
    data = response.json()
    assert [i["seq"] for i in data["items"]] == [1, 2, 3]
    assert data["items"][2]["speed_mps"] == 3 and data["items"][0]["hold_s"] == 30
    mission = Mission.objects.get()
    assert (mission.vessel, mission.end, mission.items.count()) == (vessel_a, "loop", 3)


def test_the_mission_shows_legs_and_totals_at_the_vessels_cruise_speed(
    planner: APIClient, vessel_a: Vessel
) -> None:
    vessel_a.cruise_speed_mps = 2.0
    vessel_a.save()
    mission = saved(vessel_a, route(0, 400, 1000))
    data = planner.get(detail(mission)).json()
    assert [(leg["from"], leg["to"]) for leg in data["legs"]] == [(1, 2), (2, 3)]
    assert [round(leg["distance_m"]) for leg in data["legs"]] == [400, 600]
    assert round(data["total_m"]) == 1000 and round(data["total_s"]) == 500


def test_a_patch_without_items_keeps_them_and_a_put_replaces_them(
    planner: APIClient, vessel_a: Vessel
) -> None:
    mission = saved(vessel_a, route(0, 300, 600))
    assert planner.patch(detail(mission), {"name": "Renamed"}, format="json").status_code == 200
    assert mission.items.count() == 3
    body = {"name": "Short", "vessel": "spab", "end": "stop", "items": route(0, 100)}
    assert planner.put(detail(mission), body, format="json").status_code == 200
    mission.refresh_from_db()
    assert (mission.name, mission.items.count()) == ("Short", 2)


def test_bad_items_and_half_a_home_are_refused(planner: APIClient) -> None:
    bad = planner.post(MISSIONS, {"name": "x", "items": [{"lat": 95, "lon": 0}]}, format="json")
    assert bad.status_code == 400 and "items" in bad.json()["detail"]
    half = planner.post(MISSIONS, {"name": "x", "home_lat": -32}, format="json")
    assert half.status_code == 400 and "home_lat" in half.json()["detail"]
    assert Mission.objects.count() == 0


@pytest.mark.parametrize(
    ("body", "field"),
    [
        ({"name": 0}, "name"),
        ({"name": "x", "notes": 5}, "notes"),
        ({"name": "x", "home_lat": "-32", "home_lon": 115.8}, "home_lat"),
        ({"name": "x", "items": [{"lat": 0, "lon": 0, "hold_s": True}]}, "items"),
    ],
)
def test_a_value_of_another_json_type_than_the_schema_says_is_refused(
    planner: APIClient, body: dict[str, Any], field: str
) -> None:
    response = planner.post(MISSIONS, body, format="json")
    assert response.status_code == 400
    assert field in response.json()["detail"]
    assert Mission.objects.count() == 0


def test_the_schema_states_the_home_rule_string_rules_and_the_plan_export_type(
    planner: APIClient,
) -> None:
    schema = planner.get("/api/v1/schema/", HTTP_ACCEPT="application/json").json()
    paths = schema["paths"]

    def valid(body: dict[str, Any], component: str) -> bool:
        root = {**schema, "$ref": f"#/components/schemas/{component}"}
        return jsonschema.Draft7Validator(root).is_valid(body)

    for component in ("MissionRequest", "PatchedMissionRequest"):
        assert valid({"name": "x"}, component)
        assert valid({"name": "x", "home_lat": -32.0, "home_lon": 115.8}, component)
        assert not valid({"name": "x", "home_lat": -32.0}, component)
        assert not valid({"name": "x", "home_lon": 115.8}, component)
    assert not valid({"name": 0}, "MissionRequest")
    assert not valid({"name": "a\x00b"}, "MissionRequest")  # refused as the API refuses them
    assert not valid({"name": " \t"}, "MissionRequest")
    assert valid({"name": "x", "notes": ""}, "MissionRequest")
    export = paths["/api/v1/missions/{id}/export/"]["get"]["responses"]["200"]["content"]
    assert export["application/json"]["schema"]["type"] == "object"  # a .plan is JSON
    assert export["text/plain"]["schema"]["type"] == "string"


def test_a_patch_is_checked_against_the_home_half_it_leaves(
    planner: APIClient, vessel_a: Vessel
) -> None:
    mission = saved(vessel_a, route(0, 300))
    half = planner.patch(detail(mission), {"home_lat": -32}, format="json")
    assert half.status_code == 400 and "home_lat" in half.json()["detail"]
    both = {"home_lat": -32.0, "home_lon": 115.8}
    assert planner.patch(detail(mission), both, format="json").status_code == 200
    moved = planner.patch(detail(mission), {"home_lon": 115.9}, format="json")
    assert moved.status_code == 200
    mission.refresh_from_db()
    assert (mission.home_lat, mission.home_lon) == (-32.0, 115.9)


def test_a_planner_deletes_a_mission(planner: APIClient, vessel_a: Vessel) -> None:
    mission = saved(vessel_a, route(0, 100))
    assert planner.delete(detail(mission)).status_code == 204
    assert not Mission.objects.exists()


# --- permissions ---


def test_an_operator_without_mission_rights_is_refused(
    operator: APIClient, readonly: APIClient, vessel_a: Vessel
) -> None:
    mission = saved(vessel_a, route(0, 100))
    for client in (operator, readonly):
        assert client.get(MISSIONS).status_code == 403
        assert client.get(detail(mission)).status_code == 403
        assert (
            client.post(IMPORT, upload("stations.geojson"), format="multipart").status_code == 403
        )
    assert Mission.objects.count() == 1


def test_missions_of_vessels_an_operator_cannot_see_are_invisible_to_them(
    template_planner: APIClient, vessel_a: Vessel
) -> None:
    hidden = saved(vessel_a, route(0, 100), name="Vessel run")
    template = saved(None, route(0, 100), name="Template")
    assert [m["name"] for m in template_planner.get(MISSIONS).json()] == ["Template"]
    assert template_planner.get(detail(hidden)).status_code == 404
    assert template_planner.get(detail(template) + "export/?format=plan").status_code == 200
    assert template_planner.get(detail(hidden) + "export/?format=plan").status_code == 404
    # Nor can they put a mission on a vessel by naming it.
    body = {"name": "x", "vessel": "spab", "items": route(0, 100)}
    refused = template_planner.post(MISSIONS, body, format="json")
    assert refused.status_code == 400 and "vessel" in refused.json()["detail"]


# --- import ---


def test_importing_a_plan_with_a_survey_answers_400_naming_the_item(planner: APIClient) -> None:
    response = planner.post(IMPORT, upload("survey.plan"), format="multipart")
    assert response.status_code == 400
    assert response.json()["detail"]["file"][0] == (
        "item 4 (ComplexItem survey): a Shoreside mission holds simple items only"
    )
    assert not Mission.objects.exists()


def test_importing_with_skip_unsupported_answers_201_with_the_skipped_items(
    planner: APIClient, vessel_a: Vessel
) -> None:
    fields = {"vessel": "spab", "name": "Survey run", "skip_unsupported": "true"}
    response = planner.post(IMPORT, upload("survey.plan", **fields), format="multipart")
    assert response.status_code == 201, response.json()
    data = response.json()
    assert (data["name"], data["vessel"], data["end"]) == ("Survey run", "spab", "return_home")
    assert (data["home_lat"], data["home_lon"]) == (-31.9852, 115.8327)
    assert [i["seq"] for i in data["items"]] == [1, 2, 3]
    assert data["skipped"] == [
        "item 4 (ComplexItem survey): a Shoreside mission holds simple items only"
    ]
    assert "Skipped item 4 (ComplexItem survey)" in Mission.objects.get().notes


def test_importing_a_waypoints_file_keeps_its_speed_changes_and_loop(planner: APIClient) -> None:
    response = planner.post(IMPORT, upload("matilda-bay.waypoints"), format="multipart")
    assert response.status_code == 201
    data = response.json()
    assert (data["name"], data["vessel"], data["end"], data["skipped"]) == (
        "matilda-bay",
        None,
        "loop",
        [],
    )
    assert [i["speed_mps"] for i in data["items"]] == [1.8, None, 3.0]


def test_an_import_without_a_file_or_of_garbage_is_a_400(planner: APIClient) -> None:
    assert planner.post(IMPORT, {}, format="multipart").status_code == 400
    garbage = planner.post(IMPORT, upload("x.plan", b"\x00\x01 nope"), format="multipart")
    assert garbage.status_code == 400
    assert "not a QGroundControl plan file" in garbage.json()["detail"]["file"][0]


def waypoints_file(count: int) -> bytes:
    rows = ["QGC WPL 110", "0\t1\t0\t16\t0\t0\t0\t0\t-31.98\t115.83\t0\t1"]
    for n in range(1, count + 1):
        lon = 115.83 + n / 10_000
        rows.append(f"{n}\t0\t3\t16\t0\t0\t0\t0\t-31.98\t{lon:.6f}\t0\t1")
    return ("\n".join(rows) + "\n").encode()


def test_a_mission_past_the_item_limit_is_refused_and_nothing_is_stored(
    planner: APIClient,
) -> None:
    items = route(*range(0, 10 * (MISSION_MAX_ITEMS + 1), 10))
    response = planner.post(MISSIONS, {"name": "Long", "items": items}, format="json")
    assert response.status_code == 400
    assert f"no more than {MISSION_MAX_ITEMS} elements" in str(response.json()["detail"]["items"])
    assert not Mission.objects.exists()


def test_a_waypoints_file_past_the_item_limit_is_refused_clearly(planner: APIClient) -> None:
    content = waypoints_file(600)
    response = planner.post(IMPORT, upload("long.waypoints", content), format="multipart")
    assert response.status_code == 400
    assert response.json()["detail"]["file"] == [
        f"the file has 600 waypoints; a mission holds at most {MISSION_MAX_ITEMS}"
    ]
    assert not Mission.objects.exists()


def test_saving_items_past_the_limit_keeps_the_old_ones(vessel_a: Vessel) -> None:
    mission = saved(vessel_a, route(0, 300))
    with pytest.raises(MissionCheckError, match=f"601 waypoints; at most {MISSION_MAX_ITEMS}"):
        mission_save_items(mission=mission, items=route(*range(0, 6010, 10)))
    assert mission.items.count() == 2


def test_a_full_mission_is_written_in_a_few_statements_not_one_per_item(
    vessel_a: Vessel,
) -> None:
    mission = saved(vessel_a, route(0, 300))
    with CaptureQueriesContext(connection) as queries:
        mission_save_items(mission=mission, items=route(*range(0, 10 * MISSION_MAX_ITEMS, 10)))
    assert mission.items.count() == MISSION_MAX_ITEMS
    assert len(queries) < 10


# --- export ---


@pytest.mark.parametrize(
    ("fmt", "content_type"),
    [
        ("plan", "application/json"),
        ("waypoints", "text/plain; charset=utf-8"),
        ("geojson", "application/geo+json"),
    ],
)
def test_each_export_is_a_file_that_imports_back_the_same(
    planner: APIClient, vessel_a: Vessel, fmt: str, content_type: str
) -> None:
    items = route(0, 300, 600)
    items[1].update(hold_s=45.0, radius_m=4.0, speed_mps=2.5)
    mission = saved(
        vessel_a, items, name="Bay run", end="return_home", home_lat=-31.9, home_lon=115.8
    )
    response = planner.get(detail(mission) + f"export/?format={fmt}")
    assert response.status_code == 200
    assert response["Content-Type"] == content_type
    assert response["Content-Disposition"] == f'attachment; filename="bay-run.{fmt}"'
    back = missionfiles.load(response.content, format=fmt)
    assert [i.as_dict() for i in back.items] == mission.item_dicts()
    assert (back.end, back.home) == ("return_home", (-31.9, 115.8))


def test_an_unknown_export_format_is_a_400(planner: APIClient, vessel_a: Vessel) -> None:
    mission = saved(vessel_a, route(0, 100))
    response = planner.get(detail(mission) + "export/?format=kml")
    assert response.status_code == 400 and "format" in response.json()["detail"]


# --- send ---


def send_url(mission: Mission) -> str:
    return detail(mission) + "send/"


def test_sending_queues_a_mission_command_for_its_vessel(
    planner: APIClient, vessel_a: Vessel
) -> None:
    mission = saved(vessel_a, [{**p, "speed_mps": 2.0} for p in route(0, 300)], end="loop")
    response = planner.post(send_url(mission), {}, format="json")
    assert response.status_code == 201, response.json()
    command = Command.objects.get()
    assert (response.json()["uid"], command.vessel, command.kind) == (
        str(command.uid),
        vessel_a,
        "mission",
    )
    assert (command.params["end"], command.params["loop"]) == ("loop", True)
    assert command.params["items"][1]["speed_mps"] == 2.0
    assert command.created_by == "carol" and command.source == "api"


def test_a_template_is_sent_to_the_vessel_named(planner: APIClient, vessel_b: Vessel) -> None:
    template = saved(None, route(0, 300))
    refused = planner.post(send_url(template), {}, format="json")
    assert refused.status_code == 400 and "template has no vessel" in str(refused.json())
    sent = planner.post(send_url(template), {"vessel": "spab-2"}, format="json")
    assert sent.status_code == 201 and Command.objects.get().vessel == vessel_b


def test_sending_to_an_unknown_vessel_is_a_400_naming_the_field(
    planner: APIClient, vessel_a: Vessel
) -> None:
    template = saved(None, route(0, 300))
    response = planner.post(send_url(template), {"vessel": "nope"}, format="json")
    assert response.status_code == 400
    assert response.json()["detail"] == {"vessel": ["no vessel 'nope'"]}
    assert not Command.objects.exists()


def test_a_mission_failing_its_checks_is_not_sent_and_says_why(
    planner: APIClient, vessel_a: Vessel, settings: Any
) -> None:
    settings.MISSION_MAX_LEG_M = 1000
    mission = saved(vessel_a, route(0, 300, 300, 5300))
    response = planner.post(send_url(mission), {}, format="json")
    assert response.status_code == 400
    message = response.json()["detail"]["params"][0]
    assert "waypoints 2 and 3 are the same point" in message
    assert "leg 3 → 4 is 5.0 km, longer than the limit of 1.0 km" in message
    assert not Command.objects.exists()


def test_the_command_api_checks_a_mission_the_same_way(
    planner: APIClient, vessel_a: Vessel, settings: Any
) -> None:
    settings.MISSION_MAX_LEG_M = 1000
    body = {"kind": "mission", "params": {"items": route(0, 5000)}}
    response = planner.post(commands_url(), body, format="json")
    assert response.status_code == 400
    assert "leg 1 → 2 is 5.0 km" in response.json()["detail"]["params"][0]


def test_a_mission_too_big_for_the_autopilot_is_refused(
    planner: APIClient, vessel_a: Vessel
) -> None:
    # 400 waypoints, each with a speed change: 1 + 400 + 400 items, past ArduPilot's 724.
    items = [{**p, "speed_mps": 1.0 + (n % 2)} for n, p in enumerate(route(*range(0, 4000, 10)))]
    mission = saved(vessel_a, items)
    response = planner.post(send_url(mission), {}, format="json")
    assert response.status_code == 400
    assert "needs 801 autopilot items" in response.json()["detail"]["params"][0]


def test_sending_needs_the_right_to_add_commands(
    template_planner: APIClient, vessel_a: Vessel
) -> None:
    template = saved(None, route(0, 300))
    assert template_planner.post(send_url(template), {}, format="json").status_code == 403
    assert not Command.objects.exists()


def test_the_openapi_schema_documents_the_mission_endpoints(planner: APIClient) -> None:
    paths = planner.get("/api/v1/schema/", HTTP_ACCEPT="application/json").json()["paths"]
    for path in (MISSIONS, IMPORT, "/api/v1/missions/{id}/export/", "/api/v1/missions/{id}/send/"):
        assert path in paths


def test_an_oversized_file_is_refused_unread(planner: APIClient) -> None:
    big = b"QGC WPL 110\n" + b" " * missionfiles.MAX_FILE_BYTES
    response = planner.post(IMPORT, upload("big.waypoints", big), format="multipart")
    assert response.status_code == 400  # within the body's multipart allowance: read, then refused
    assert "a mission file is at most 5.2 MB" in response.json()["detail"]["file"][0]
    bigger = big + b" " * missionfiles.MULTIPART_ALLOWANCE_BYTES
    response = planner.post(IMPORT, upload("big.waypoints", bigger), format="multipart")
    assert response.status_code == 413
    assert response.json() == {
        "error": "too_large",
        "detail": "the upload is 5.3 MB; a mission file is at most 5.2 MB",
    }


def test_an_upload_declared_too_big_is_refused_before_its_body_is_read(
    planner: APIClient,
) -> None:
    # The body is a small valid file: only the declared length can refuse it.
    declared = str(missionfiles.MAX_FILE_BYTES * 2)
    response = planner.post(
        IMPORT, upload("matilda-bay.waypoints"), format="multipart", CONTENT_LENGTH=declared
    )
    assert response.status_code == 413
    assert "a mission file is at most 5.2 MB" in response.json()["detail"]
    assert not Mission.objects.exists()
