"""The fleet map's poll (issue 9): every active vessel, one small JSON, ETag and 304."""

from __future__ import annotations

import datetime as dt
from typing import Any

import pytest
from rest_framework.test import APIClient

from telemetry.services import fix_ingest
from vessels.models import Vessel
from vessels.services import vessel_create, vessel_save

FLEET = "/api/v1/fleet/"


def test_the_fleet_lists_active_vessels_with_their_state(
    operator: APIClient, reported: Vessel, vessel_b: Vessel, glider: Vessel
) -> None:
    retired = vessel_create(slug="old", name="Retired", kind="mavlink")
    retired.active = False
    vessel_save(vessel=retired)
    response = operator.get(FLEET)
    assert response.status_code == 200
    body = response.json()
    assert dt.datetime.fromisoformat(body["server_time"]).tzinfo is not None
    assert [v["slug"] for v in body["vessels"]] == ["spab", "spab-2", "glider"]  # by name
    spab, spab_2 = body["vessels"][0], body["vessels"][1]
    assert spab["status"] == "reporting"  # seen just now (the fix time does not count)
    assert spab["last_fix"] == {
        "time": "2026-11-23T10:00:00+00:00",
        "lat": -31.9505,
        "lon": 115.8605,
        "heading_deg": 90.0,
        "speed_mps": 1.2,
        "battery_v": 12.34,
        "readings": {"water_temp_c": 19.5},
    }
    assert spab["admin_url"] == f"/admin/vessels/vessel/{reported.pk}/change/"
    assert (spab["kind"], spab["telemetry_period_s"]) == ("mavlink", 10)
    assert (spab_2["status"], spab_2["last_fix"], spab_2["last_seen_at"]) == (
        "never seen",
        None,
        None,
    )


def test_an_unchanged_fleet_answers_304_with_no_body(operator: APIClient, reported: Vessel) -> None:
    first = operator.get(FLEET)
    etag = first["ETag"]
    again = operator.get(FLEET, HTTP_IF_NONE_MATCH=etag)
    assert again.status_code == 304
    assert again.content == b""
    assert again["ETag"] == etag
    assert operator.get(FLEET, HTTP_IF_NONE_MATCH=f'"other", W/{etag}').status_code == 304
    assert operator.get(FLEET, HTTP_IF_NONE_MATCH='"other"').status_code == 200


def test_a_new_fix_changes_the_etag(operator: APIClient, reported: Vessel, make_fix: Any) -> None:
    etag = operator.get(FLEET)["ETag"]
    fix_ingest(vessel=reported, records=[make_fix(time="2026-11-23T10:00:05Z")])
    response = operator.get(FLEET, HTTP_IF_NONE_MATCH=etag)
    assert response.status_code == 200
    assert response["ETag"] != etag


def test_going_overdue_changes_the_etag_with_no_row_changing(
    operator: APIClient, vessel_a: Vessel, make_fix: Any
) -> None:
    now = dt.datetime.now(dt.UTC)
    fix_ingest(vessel=vessel_a, records=[make_fix(time=now.isoformat())], now=now)
    first = operator.get(FLEET)
    assert first.json()["vessels"][0]["status"] == "reporting"
    # Period 10 s: overdue after 30 s of silence. Move the seen time back rather than sleep.
    Vessel.objects.filter(pk=vessel_a.pk).update(last_seen_at=now - dt.timedelta(seconds=25))
    assert operator.get(FLEET).json()["vessels"][0]["status"] == "reporting"
    etag = operator.get(FLEET)["ETag"]
    Vessel.objects.filter(pk=vessel_a.pk).update(last_seen_at=now - dt.timedelta(seconds=31))
    response = operator.get(FLEET, HTTP_IF_NONE_MATCH=etag)
    assert response.status_code == 200
    assert response.json()["vessels"][0]["status"] == "overdue"


def test_the_fleet_needs_the_right_to_view_vessels(
    readonly: APIClient, anonymous: APIClient, boat_a: APIClient, vessel_a: Vessel
) -> None:
    assert readonly.get(FLEET).status_code == 403
    assert anonymous.get(FLEET).status_code in (401, 403)
    assert boat_a.get(FLEET).status_code in (401, 403)


@pytest.mark.parametrize("client", ["session_operator", "token_operator"])
def test_the_fleet_answers_a_session_and_a_token(
    request: pytest.FixtureRequest, client: str, vessel_a: Vessel
) -> None:
    response = request.getfixturevalue(client).get(FLEET)
    assert response.status_code == 200
    assert response.json()["vessels"][0]["slug"] == "spab"


def test_the_fleet_is_one_query(
    operator: APIClient, reported: Vessel, glider: Vessel, django_assert_max_num_queries: Any
) -> None:
    operator.get(FLEET)  # the operator's permissions are cached on the user from here
    with django_assert_max_num_queries(1):
        operator.get(FLEET)
