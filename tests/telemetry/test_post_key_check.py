"""The telemetry post takes its key from the process's recent lookups and its writes check the
key themselves (issue 17 item 8): a key revoked, or a vessel deactivated, after a successful post
still stops the very next one, whatever that post holds, and nothing of it is written."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import pytest
from django.db import connection
from django.test.utils import CaptureQueriesContext
from rest_framework.test import APIClient

from telemetry.models import Fix, TrackDirty
from tests.support import TELEMETRY, MakeFix
from vessels.models import Vessel, VesselKey
from vessels.services import vessel_key_revoke

pytestmark = pytest.mark.django_db(transaction=True)


def _revoke(vessel: Vessel) -> None:
    for key in VesselKey.objects.filter(vessel=vessel):
        vessel_key_revoke(key=key)


def _deactivate(vessel: Vessel) -> None:
    Vessel.objects.filter(pk=vessel.pk).update(active=False)


def _delete_keys(vessel: Vessel) -> None:
    VesselKey.objects.filter(vessel=vessel).delete()


CHANGES: dict[str, tuple[Callable[[Vessel], None], str]] = {
    "revoked": (_revoke, "revoked"),
    "deactivated": (_deactivate, "not active"),
    "deleted": (_delete_keys, "Invalid vessel key"),
}

# What the next post holds: new fixes (the write's own check refuses), a fix already stored (a
# duplicate: nothing inserted, the key is asked), fixes that are all rejected (nothing to
# write), a body that is not JSON (a 400 before any write), and too many fixes.
BODIES: dict[str, Callable[[MakeFix], Any]] = {
    "new fixes": lambda make_fix: [make_fix(time="2026-11-23T10:00:05Z")],
    "a duplicate": lambda make_fix: [make_fix(time="2026-11-23T10:00:00Z")],
    "bad fixes only": lambda make_fix: [{"time": "nope", "lat": 99, "lon": 0}],
    "a batch": lambda make_fix: [make_fix(time=f"2026-11-23T10:01:{s:02d}Z") for s in range(3)],
    "too many fixes": lambda make_fix: [make_fix()] * 5001,
}


@pytest.mark.parametrize("change", CHANGES)
@pytest.mark.parametrize("body", BODIES)
def test_a_key_that_stops_working_stops_the_next_post(
    boat_a: APIClient, vessel_a: Vessel, make_fix: MakeFix, change: str, body: str
) -> None:
    first = boat_a.post(TELEMETRY, [make_fix(time="2026-11-23T10:00:00Z")], format="json")
    assert first.status_code == 200, first.content
    stop, message = CHANGES[change]
    stop(vessel_a)
    vessel_a.refresh_from_db()
    before = (Fix.objects.count(), TrackDirty.objects.count(), vessel_a.last_seen_at)

    response = boat_a.post(TELEMETRY, BODIES[body](make_fix), format="json")

    assert response.status_code == 401, response.content
    assert message in response.json()["detail"]
    assert response["WWW-Authenticate"] == "Api-Key"
    vessel_a.refresh_from_db()
    assert (Fix.objects.count(), TrackDirty.objects.count(), vessel_a.last_seen_at) == before


def test_a_revoked_key_with_a_body_that_is_not_json_is_a_401(
    boat_a: APIClient, vessel_a: Vessel, make_fix: MakeFix
) -> None:
    assert boat_a.post(TELEMETRY, [make_fix()], format="json").status_code == 200
    _revoke(vessel_a)
    response = boat_a.generic("POST", TELEMETRY, "{not json", content_type="application/json")
    assert response.status_code == 401
    assert "revoked" in response.json()["detail"]


def test_the_key_is_looked_up_once_then_checked_by_the_write(
    boat_a: APIClient, make_fix: MakeFix
) -> None:
    """The second post sends no key SELECT (the statement-count test pins the rest), and a
    working key's errors still answer as before: a bad body is a 400."""
    boat_a.post(TELEMETRY, [make_fix(time="2026-11-23T10:00:00Z")], format="json")
    with CaptureQueriesContext(connection) as queries:
        boat_a.post(TELEMETRY, [make_fix(time="2026-11-23T10:00:01Z")], format="json")
    assert not [q["sql"] for q in queries if q["sql"].lstrip().upper().startswith("SELECT")]
    response = boat_a.generic("POST", TELEMETRY, "{not json", content_type="application/json")
    assert response.status_code == 400
    response = boat_a.post(TELEMETRY, {"fixes": "no"}, format="json")
    assert response.status_code == 400
