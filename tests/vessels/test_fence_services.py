"""Fence writes (vessels.fence_services): checked, normalised, audited; imports all or none."""

from __future__ import annotations

import json

import pytest
from django.core.exceptions import ValidationError

from audit.models import AuditEntry
from tests.vessels.test_fence_geometry import PLAN, SQUARE, polygon
from vessels.errors import VesselsError
from vessels.fence_services import fence_create, fence_delete, fence_import, fence_update
from vessels.models import Fence

pytestmark = pytest.mark.django_db


def test_a_fence_is_created_checked_and_audited(vessel_a):
    fence = fence_create(name="Harbour", geometry=polygon(SQUARE), vessel=vessel_a, by="alice",
                         via="api", ip="10.0.0.5")  # fmt: skip
    fence.refresh_from_db()
    assert fence.geometry == polygon(SQUARE) and fence.inclusion and fence.radius_m is None
    entry = AuditEntry.objects.get()
    assert (entry.action, entry.actor, entry.via, entry.ip, entry.vessel) == (
        "fence.created", "alice", "api", "10.0.0.5", "spab",
    )  # fmt: skip
    assert entry.subject == "Harbour (inclusion, polygon, 4 vertices)"
    assert entry.subject_id == str(fence.pk)


def test_a_bad_fence_is_not_stored_nor_audited():
    with pytest.raises(ValidationError) as caught:
        fence_create(name="Open", geometry=polygon(SQUARE[:-1]))
    assert "must be closed" in caught.value.message_dict["geometry"][0]
    with pytest.raises(ValidationError) as caught:
        fence_create(name="Dot", geometry={"type": "Point", "coordinates": [115.7, -32]})
    assert "radius_m" in caught.value.message_dict
    assert not Fence.objects.exists() and not AuditEntry.objects.exists()


def test_an_update_records_what_changed_and_a_polygon_drops_the_radius():
    fence = fence_create(name="Buoy", geometry={"type": "Point", "coordinates": [115.7, -32]},
                         radius_m=50, inclusion=False)  # fmt: skip
    fence_update(fence=fence, fields={"geometry": polygon(SQUARE), "name": "Box"}, by="bob")
    fence.refresh_from_db()
    assert fence.radius_m is None and fence.name == "Box"
    entry = AuditEntry.objects.filter(action="fence.changed").get()
    assert entry.actor == "bob"
    assert set(entry.detail["changed"]) == {"geometry", "name"}
    # Nothing changed: no entry.
    fence_update(fence=fence, fields={"name": "Box"}, by="bob")
    assert AuditEntry.objects.filter(action="fence.changed").count() == 1


def test_a_deleted_fence_keeps_its_geometry_in_the_log():
    fence = fence_create(name="Box", geometry=polygon(SQUARE))
    fence_delete(fence=fence, by="alice")
    assert not Fence.objects.exists()
    entry = AuditEntry.objects.get(action="fence.deleted")
    assert entry.detail["geometry"] == polygon(SQUARE)


def test_a_plan_imports_every_fence_named_after_the_file(vessel_a):
    created = fence_import(content=json.dumps(PLAN).encode(), filename="harbour.plan",
                           vessel=vessel_a, by="alice")  # fmt: skip
    assert [f.name for f in created] == ["harbour 1", "harbour 2", "harbour 3"]
    assert [f.inclusion for f in created] == [True, False, False]
    assert all(f.vessel == vessel_a for f in created)
    assert AuditEntry.objects.filter(action="fence.created").count() == 3


def test_an_import_with_one_bad_fence_stores_none():
    bad = json.loads(json.dumps(PLAN))
    bad["geoFence"]["circles"][0]["circle"]["radius"] = 0
    with pytest.raises(VesselsError):
        fence_import(content=json.dumps(bad), filename="bad.plan")
    assert not Fence.objects.exists()
