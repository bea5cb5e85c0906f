"""`/api/v1/fences/`: fences drawn by scripts, imported from files, sent to a vessel; each
persona gets what its rights say (carol: every right; alice: the fleet but no fences; bob: no
rights; a boat key: none of the operator API)."""

from __future__ import annotations

import json

import pytest
from django.core.files.uploadedfile import SimpleUploadedFile

from audit.models import AuditEntry
from commands.models import Command
from tests.vessels.test_fence_geometry import PLAN, SQUARE, polygon
from vessels.fence_services import fence_create
from vessels.models import Fence

pytestmark = pytest.mark.django_db
URL = "/api/v1/fences/"
CIRCLE = {"type": "Point", "coordinates": [115.71, -32.005]}


def test_an_operator_draws_a_polygon_and_a_circle(watcher, vessel_a):
    r = watcher.post(URL, {"name": "Harbour", "vessel": "spab", "inclusion": True,
                           "geometry": polygon(SQUARE)}, format="json")  # fmt: skip
    assert r.status_code == 201, r.content
    body = r.json()
    assert body["vessel"] == "spab" and body["shape"] == "polygon, 4 vertices"
    assert body["geometry"] == polygon(SQUARE) and body["radius_m"] is None
    r = watcher.post(URL, {"name": "Wreck", "vessel": None, "inclusion": False,
                           "geometry": CIRCLE, "radius_m": 30}, format="json")  # fmt: skip
    assert r.status_code == 201, r.content
    assert r.json()["shape"] == "circle, 30 m"
    entries = AuditEntry.objects.filter(action="fence.created").order_by("pk")
    assert [(e.actor, e.via, e.vessel) for e in entries] == [
        ("carol", "api", "spab"),
        ("carol", "api", ""),
    ]
    listed = watcher.get(URL).json()
    assert [f["name"] for f in listed] == ["Harbour", "Wreck"]


@pytest.mark.parametrize(
    ("body", "field", "said"),
    [
        ({"geometry": polygon(SQUARE[:-1])}, "geometry", "must be closed"),
        ({"geometry": CIRCLE}, "radius_m", "needs radius_m"),
        ({"geometry": [1, 2]}, "geometry", "GeoJSON object"),
        ({"geometry": polygon(SQUARE), "vessel": "nope"}, "vessel", "does not exist"),
    ],
)
def test_a_bad_fence_is_a_400_naming_the_field(watcher, vessel_a, body, field, said):
    r = watcher.post(URL, {"name": "Bad", **body}, format="json")
    assert r.status_code == 400
    assert field in r.json()["detail"]
    assert said in " ".join(r.json()["detail"][field])
    assert not Fence.objects.exists()


def test_patch_and_delete(watcher, vessel_a):
    fence = fence_create(name="Box", geometry=polygon(SQUARE), vessel=vessel_a)
    r = watcher.patch(f"{URL}{fence.pk}/", {"inclusion": False}, format="json")
    assert r.status_code == 200 and r.json()["inclusion"] is False
    assert watcher.delete(f"{URL}{fence.pk}/").status_code == 204
    assert not Fence.objects.exists()
    assert [e.action for e in AuditEntry.objects.order_by("pk")] == [
        "fence.created", "fence.changed", "fence.deleted",
    ]  # fmt: skip


def test_a_plan_file_is_imported(watcher, vessel_a):
    upload = SimpleUploadedFile("harbour.plan", json.dumps(PLAN).encode())
    r = watcher.post(f"{URL}import/", {"file": upload, "vessel": "spab"}, format="multipart")
    assert r.status_code == 201, r.content
    assert [(f["name"], f["inclusion"], f["shape"]) for f in r.json()] == [
        ("harbour 1", True, "polygon, 4 vertices"),
        ("harbour 2", False, "polygon, 3 vertices"),
        ("harbour 3", False, "circle, 40.5 m"),
    ]


def test_a_geojson_file_with_a_bad_fence_imports_nothing(watcher):
    collection = {"type": "FeatureCollection", "features": [
        {"type": "Feature", "properties": {}, "geometry": polygon(SQUARE)},
        {"type": "Feature", "properties": {}, "geometry": CIRCLE},
    ]}  # fmt: skip
    upload = SimpleUploadedFile("areas.geojson", json.dumps(collection).encode())
    r = watcher.post(f"{URL}import/", {"file": upload}, format="multipart")
    assert r.status_code == 400
    assert r.json()["detail"]["file"] == [
        "feature 2: a circle (a Point) needs radius_m, its radius in metres"
    ]
    assert not Fence.objects.exists()


def test_who_may_see_and_write_fences(watcher, operator, readonly, boat_a, vessel_a):
    fence_create(name="Everyone's", geometry=polygon(SQUARE))
    body = {"name": "X", "geometry": polygon(SQUARE)}
    for client in (operator, readonly, boat_a):  # no fence rights, no rights, a boat
        assert client.get(URL).status_code == 403
        assert client.post(URL, body, format="json").status_code == 403
    assert watcher.get(URL).status_code == 200


def test_a_vessels_fence_is_hidden_without_the_right_to_see_vessels(vessel_a):
    from rest_framework.test import APIClient

    from tests.alerts.conftest import ALERT_PERMS
    from tests.conftest import make_user

    fence_create(name="Everyone's", geometry=polygon(SQUARE))
    mine = fence_create(name="SPAB's", geometry=polygon(SQUARE), vessel=vessel_a)
    user = make_user("dave", [p for p in ALERT_PERMS if p != "vessels.view_vessel"])
    client = APIClient()
    client.force_authenticate(user)
    assert [f["name"] for f in client.get(URL).json()] == ["Everyone's"]
    assert client.get(f"{URL}{mine.pk}/").status_code == 404


def test_a_fence_for_every_vessel_needs_a_vessel_to_be_sent(watcher, vessel_a, vessel_b):
    everyone = fence_create(name="Everyone's", geometry=polygon(SQUARE))
    r = watcher.post(f"{URL}{everyone.pk}/send/", {}, format="json")
    assert r.status_code == 400 and "name the vessel" in r.json()["detail"]["vessel"][0]
    theirs = fence_create(name="B's", geometry=polygon(SQUARE), vessel=vessel_b)
    r = watcher.post(f"{URL}{theirs.pk}/send/", {"vessel": "spab"}, format="json")
    assert r.status_code == 400 and r.json()["detail"]["vessel"] == [
        'fence "B\'s" belongs to SPAB 2, not SPAB'
    ]
    assert watcher.post(f"{URL}999/send/", {}, format="json").status_code == 404
    assert not Command.objects.exists()


def test_sending_needs_the_right_to_queue_commands(readonly, vessel_a):
    fence = fence_create(name="Box", geometry=polygon(SQUARE), vessel=vessel_a)
    assert readonly.post(f"{URL}{fence.pk}/send/", {}, format="json").status_code == 403


def test_sending_a_fence_queues_a_fence_command(watcher, vessel_a):
    fence = fence_create(name="Box", geometry=polygon(SQUARE), vessel=vessel_a)
    r = watcher.post(f"{URL}{fence.pk}/send/", {}, format="json")
    assert r.status_code == 201, r.content
    command = Command.objects.get()
    assert (command.kind, command.vessel, command.source, command.created_by) == (
        "fence", vessel_a, "api", "carol",
    )  # fmt: skip
    assert r.json()["uid"] == str(command.uid)


def test_sending_to_a_vessel_that_does_not_exist_is_a_400_naming_it(watcher, vessel_a):
    fence = fence_create(name="Box", geometry=polygon(SQUARE), vessel=None)
    r = watcher.post(f"{URL}{fence.pk}/send/", {"vessel": "nope"}, format="json")
    assert r.status_code == 400 and r.json()["detail"] == {"vessel": ["no vessel 'nope'"]}
    assert not Command.objects.exists()
