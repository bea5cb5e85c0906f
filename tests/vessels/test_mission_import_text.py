"""Text a mission file carries (names, item types) passes the API's text rule on import: a
NUL or a lone surrogate is a clear 400 naming where it is, never a 500 and never stored
(issue 16 §17). One test per format, through the API as an operator would send it."""

from __future__ import annotations

import json

import pytest
from django.core.files.uploadedfile import SimpleUploadedFile
from rest_framework.test import APIClient

from tests.conftest import make_user
from vessels import missionfiles
from vessels.errors import MissionFileError
from vessels.models import Mission

pytestmark = pytest.mark.django_db

IMPORT = "/api/v1/missions/import/"
BAD_TEXT = ["a\u0000b", "a\ud800b"]


@pytest.fixture
def planner(db: None) -> APIClient:
    client = APIClient()
    client.force_authenticate(make_user("carol", ["vessels.add_mission", "vessels.view_mission"]))
    return client


def geojson_named(name: str) -> bytes:
    # json.dumps writes the NUL and the lone surrogate as \u escapes, as the audit sent them.
    return json.dumps(
        {
            "type": "FeatureCollection",
            "properties": {"name": name},
            "features": [
                {
                    "type": "Feature",
                    "geometry": {
                        "type": "LineString",
                        "coordinates": [[115.83, -31.98], [115.84, -31.98]],
                    },
                    "properties": {},
                },
            ],
        }
    ).encode()


def plan_with_complex(kind: str) -> bytes:
    waypoint = {
        "type": "SimpleItem",
        "command": 16,
        "frame": 3,
        "params": [0, 0, 0, None, -31.98, 115.83, 0],
    }
    survey = {"type": "ComplexItem", "complexItemType": kind}
    return json.dumps(
        {"fileType": "Plan", "version": 1, "mission": {"items": [waypoint, survey]}}
    ).encode()


def post(client: APIClient, filename: str, content: bytes, **fields: str) -> object:
    body = {"file": SimpleUploadedFile(filename, content), **fields}
    return client.post(IMPORT, body, format="multipart")


@pytest.mark.parametrize("name", BAD_TEXT)
def test_a_geojson_name_with_nul_or_a_lone_surrogate_is_a_400_and_nothing_is_stored(
    planner: APIClient, name: str
) -> None:
    response = post(planner, "route.geojson", geojson_named(name))
    assert response.status_code == 400
    assert "properties.name: the text holds" in response.json()["detail"]["file"][0]
    assert not Mission.objects.exists()


@pytest.mark.parametrize("kind", BAD_TEXT)
def test_a_plan_item_type_with_nul_or_a_lone_surrogate_is_a_400_even_when_skipping(
    planner: APIClient, kind: str
) -> None:
    # Skipped, the item's type would go into the answer and the mission's notes.
    response = post(planner, "x.plan", plan_with_complex(kind), skip_unsupported="true")
    assert response.status_code == 400
    assert "item 2: complexItemType: the text holds" in response.json()["detail"]["file"][0]
    assert not Mission.objects.exists()


def test_a_waypoints_file_with_a_nul_is_a_clear_400(planner: APIClient) -> None:
    content = b"QGC WPL 110\n1\t0\t3\t16\t0\t0\t0\t0\t-31.98\x00\t115.83\t0\t1\n"
    response = post(planner, "x.waypoints", content)
    assert response.status_code == 400
    assert "line 2" in response.json()["detail"]["file"][0]
    assert not Mission.objects.exists()


def test_a_geojson_geometry_type_with_nul_is_refused_by_the_pure_reader() -> None:
    data = {
        "type": "FeatureCollection",
        "features": [{"type": "Feature", "geometry": {"type": "Poly\u0000gon"}, "properties": {}}],
    }
    with pytest.raises(MissionFileError) as caught:
        missionfiles.load(json.dumps(data), format="geojson", skip_unsupported=True)
    assert "feature 1: geometry type: the text holds a NUL character" in caught.value.problems[0]


def test_a_good_name_still_imports(planner: APIClient) -> None:
    response = post(planner, "route.geojson", geojson_named("Matilda Bay"))
    assert response.status_code == 201
    assert Mission.objects.get().name == "Matilda Bay"
