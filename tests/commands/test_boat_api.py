"""Boat API v1 (DESIGN §5): telemetry, the command poll with ETag/304, and acks."""

from __future__ import annotations

import base64
import datetime as dt
import json
from collections.abc import Callable
from typing import Any

import pytest
from django.contrib.auth.models import User
from django.utils import timezone
from rest_framework.test import APIClient

from commands.lifecycle import Status
from commands.models import Command, CommandEvent
from commands.services import command_cancel, command_enqueue
from telemetry.models import Fix
from tests.conftest import boat_client
from vessels.models import Vessel

TELEMETRY = "/api/v1/boat/telemetry/"
COMMANDS = "/api/v1/boat/commands/"
BROWSER_HEADERS = (
    "X-Frame-Options",
    "Referrer-Policy",
    "Vary",
    "Allow",
    "X-Content-Type-Options",
    "Cross-Origin-Opener-Policy",
    "Strict-Transport-Security",
)

MakeFix = Callable[..., dict[str, Any]]


def ack_url(uid: object) -> str:
    return f"/api/v1/boat/commands/{uid}/ack/"


def iso(when: dt.datetime) -> str:
    return when.isoformat().replace("+00:00", "Z")


def call(client: APIClient, endpoint: str, uid: object) -> Any:
    if endpoint == "telemetry":
        return client.post(TELEMETRY, [], format="json")
    if endpoint == "commands":
        return client.get(COMMANDS)
    return client.post(ack_url(uid), {"status": "acknowledged"}, format="json")


ENDPOINTS = ["telemetry", "commands", "ack"]


# --- the auth matrix ---


@pytest.mark.parametrize("endpoint", ENDPOINTS)
def test_anonymous_gets_401_on_every_boat_endpoint(
    anonymous: APIClient, command_a: Command, endpoint: str
) -> None:
    response = call(anonymous, endpoint, command_a.uid)
    assert response.status_code == 401
    assert response["WWW-Authenticate"] == "Api-Key"
    assert response.json() == {
        "error": "not_authenticated",
        "detail": "Authentication credentials were not provided.",
    }


@pytest.mark.parametrize("persona", ["session_operator", "token_operator", "operator"])
@pytest.mark.parametrize("endpoint", ENDPOINTS)
def test_operators_are_not_boats(
    request: pytest.FixtureRequest, command_a: Command, persona: str, endpoint: str
) -> None:
    client: APIClient = request.getfixturevalue(persona)
    response = call(client, endpoint, command_a.uid)
    # A real session or token is not even tried on the boat API (401); a user forced onto
    # the request (DRF's test shortcut) is known but is not a boat (403).
    assert response.status_code == (403 if persona == "operator" else 401)
    command_a.refresh_from_db()
    assert command_a.status == Status.QUEUED


@pytest.mark.parametrize("endpoint", ENDPOINTS)
def test_a_revoked_key_gets_401(revoked_boat: APIClient, command_a: Command, endpoint: str) -> None:
    response = call(revoked_boat, endpoint, command_a.uid)
    assert response.status_code == 401
    assert response.json() == {
        "error": "authentication_failed",
        "detail": "This vessel key has been revoked.",
    }


@pytest.mark.parametrize(
    "header",
    [
        "Api-Key",
        "Api-Key ",
        "Api-Key not-a-key",
        "Api-Key " + "x" * 500,
        "api-key ssk_wrong",
        "Bearer abc",
        "Basic " + base64.b64encode(b"spab:whatever").decode(),
    ],
)
@pytest.mark.parametrize("endpoint", ENDPOINTS)
def test_a_malformed_or_wrong_header_gets_401(
    command_a: Command, header: str, endpoint: str
) -> None:
    client = APIClient()
    client.credentials(HTTP_AUTHORIZATION=header)
    response = call(client, endpoint, command_a.uid)
    assert response.status_code == 401
    assert response.json()["error"] in {"authentication_failed", "not_authenticated"}


def test_a_key_of_an_inactive_vessel_gets_401(vessel_a: Vessel, boat_a: APIClient) -> None:
    Vessel.objects.filter(pk=vessel_a.pk).update(active=False)
    response = boat_a.get(COMMANDS)
    assert response.status_code == 401
    assert response.json()["detail"] == "This vessel is not active."


def test_the_scheme_name_is_case_insensitive(key_a: str) -> None:
    client = APIClient()
    client.credentials(HTTP_AUTHORIZATION=f"api-key {key_a}")
    assert client.get(COMMANDS).status_code == 200


@pytest.mark.parametrize("endpoint", ENDPOINTS)
def test_boat_a_is_served(boat_a: APIClient, command_a: Command, endpoint: str) -> None:
    if endpoint == "ack":
        boat_a.get(COMMANDS)
    assert call(boat_a, endpoint, command_a.uid).status_code == 200


def test_boat_b_never_sees_boat_as_commands(
    boat_b: APIClient, command_a: Command, vessel_b: Vessel
) -> None:
    assert boat_b.get(COMMANDS).json() == {"commands": []}
    command_a.refresh_from_db()
    assert command_a.status == Status.QUEUED


@pytest.mark.parametrize("status", ["acknowledged", "done", "failed"])
def test_boat_b_gets_404_for_boat_as_command_uid(
    boat_a: APIClient, boat_b: APIClient, command_a: Command, status: str
) -> None:
    boat_a.get(COMMANDS)
    response = boat_b.post(ack_url(command_a.uid), {"status": status}, format="json")
    assert response.status_code == 404
    assert response.json() == {
        "error": "not_found",
        "detail": f"no command {command_a.uid} for this vessel",
    }
    command_a.refresh_from_db()
    assert command_a.status == Status.SENT


def test_boat_b_cannot_tell_a_foreign_uid_from_a_missing_one(
    boat_a: APIClient, boat_b: APIClient, command_a: Command
) -> None:
    missing = "00000000-0000-4000-8000-000000000000"
    foreign = boat_b.post(ack_url(command_a.uid), {"status": "done"}, format="json")
    absent = boat_b.post(ack_url(missing), {"status": "done"}, format="json")
    assert foreign.status_code == absent.status_code == 404
    assert foreign.json()["detail"].replace(str(command_a.uid), "X") == absent.json()[
        "detail"
    ].replace(missing, "X")


def test_boat_b_telemetry_goes_to_boat_b(
    boat_b: APIClient, vessel_a: Vessel, vessel_b: Vessel, make_fix: MakeFix
) -> None:
    boat_b.post(TELEMETRY, [make_fix()], format="json")
    assert Fix.objects.get().vessel == vessel_b
    assert not vessel_a.fixes.exists()


# --- the poll: ETag / 304 and at-least-once delivery ---


def test_a_poll_lists_open_commands_oldest_first(boat_a: APIClient, vessel_a: Vessel) -> None:
    arm = command_enqueue(vessel=vessel_a, kind="arm", params={})
    nav = command_enqueue(vessel=vessel_a, kind="move_to", params={"lat": -31, "lon": 115})
    response = boat_a.get(COMMANDS)
    assert response.status_code == 200
    body = response.json()
    assert [c["uid"] for c in body["commands"]] == [str(arm.uid), str(nav.uid)]
    assert body["commands"][1] == {
        "uid": str(nav.uid),
        "kind": "move_to",
        "params": {"lat": -31.0, "lon": 115.0},
        "created_at": nav.created_at.isoformat(),
        "expires_at": nav.expires_at.isoformat(),
    }
    for command in (arm, nav):
        command.refresh_from_db()
        assert command.status == Status.SENT


def test_a_poll_without_news_is_a_bare_304(boat_a: APIClient, command_a: Command) -> None:
    first = boat_a.get(COMMANDS)
    etag = first["ETag"]
    assert etag.startswith('"') and etag.endswith('"')
    second = boat_a.get(COMMANDS, HTTP_IF_NONE_MATCH=etag)
    assert second.status_code == 304
    assert second.content == b""
    assert second["ETag"] == etag
    for header in BROWSER_HEADERS + ("Content-Type",):
        assert header not in second.headers, header


def test_boat_responses_carry_no_browser_headers(boat_a: APIClient, make_fix: MakeFix) -> None:
    for response in (
        boat_a.get(COMMANDS),
        boat_a.post(TELEMETRY, [make_fix()], format="json"),
        boat_a.post(TELEMETRY, "{", content_type="application/json"),
    ):
        for header in BROWSER_HEADERS:
            assert header not in response.headers, header


def test_operator_pages_keep_their_browser_headers(operator: APIClient) -> None:
    response = operator.get("/api/v1/vessels/")
    assert response["X-Frame-Options"] == "DENY"
    assert response["X-Content-Type-Options"] == "nosniff"


@pytest.mark.parametrize("form", ["W/{tag}", '"other", {tag}', '"x",W/{tag}'])
def test_a_weakened_or_listed_etag_still_matches(
    boat_a: APIClient, command_a: Command, form: str
) -> None:
    etag = boat_a.get(COMMANDS)["ETag"]
    response = boat_a.get(COMMANDS, HTTP_IF_NONE_MATCH=form.format(tag=etag))
    assert response.status_code == 304


def test_a_stale_or_foreign_etag_gets_the_full_list(
    boat_a: APIClient, boat_b: APIClient, vessel_a: Vessel, command_a: Command
) -> None:
    tag_b = boat_b.get(COMMANDS)["ETag"]
    response = boat_a.get(COMMANDS, HTTP_IF_NONE_MATCH=tag_b)
    assert response.status_code == 200
    assert len(response.json()["commands"]) == 1
    assert boat_a.get(COMMANDS, HTTP_IF_NONE_MATCH='"garbage"').status_code == 200


def test_the_etag_changes_when_a_command_is_queued_cancelled_or_acked(
    boat_a: APIClient, vessel_a: Vessel, operator_user: User
) -> None:
    etag = boat_a.get(COMMANDS)["ETag"]
    command = command_enqueue(vessel=vessel_a, kind="arm", params={})
    response = boat_a.get(COMMANDS, HTTP_IF_NONE_MATCH=etag)
    assert response.status_code == 200
    assert [c["uid"] for c in response.json()["commands"]] == [str(command.uid)]
    etag = response["ETag"]
    boat_a.post(ack_url(command.uid), {"status": "acknowledged"}, format="json")
    response = boat_a.get(COMMANDS, HTTP_IF_NONE_MATCH=etag)
    assert response.status_code == 200
    assert response.json() == {"commands": []}
    etag = response["ETag"]
    other = command_enqueue(vessel=vessel_a, kind="disarm", params={})
    command_cancel(command=other, actor="alice")
    response = boat_a.get(COMMANDS, HTTP_IF_NONE_MATCH=etag)
    assert response.status_code == 200
    assert response.json() == {"commands": []}
    assert boat_a.get(COMMANDS, HTTP_IF_NONE_MATCH=response["ETag"]).status_code == 304


def test_a_sent_command_is_offered_again_until_acked(boat_a: APIClient, command_a: Command) -> None:
    for _ in range(3):
        response = boat_a.get(COMMANDS)
        assert [c["uid"] for c in response.json()["commands"]] == [str(command_a.uid)]
    assert command_a.events.filter(to_status="sent").count() == 1
    boat_a.post(ack_url(command_a.uid), {"status": "acknowledged"}, format="json")
    assert boat_a.get(COMMANDS).json() == {"commands": []}


def test_a_poll_does_not_offer_an_expired_command(boat_a: APIClient, vessel_a: Vessel) -> None:
    now = timezone.now()
    command = command_enqueue(
        vessel=vessel_a,
        kind="arm",
        params={},
        now=now - dt.timedelta(hours=1),
        expires_at=now - dt.timedelta(minutes=1),
    )
    assert boat_a.get(COMMANDS).json() == {"commands": []}
    command.refresh_from_db()
    assert command.status == Status.EXPIRED


# --- acks ---


def test_an_ack_moves_the_command_and_is_idempotent(boat_a: APIClient, command_a: Command) -> None:
    boat_a.get(COMMANDS)
    url = ack_url(command_a.uid)
    response = boat_a.post(url, {"status": "acknowledged"}, format="json")
    assert response.status_code == 200
    assert response.json() == {"uid": str(command_a.uid), "status": "acknowledged"}
    response = boat_a.post(url, {"status": "done", "detail": "arrived"}, format="json")
    assert response.json() == {"uid": str(command_a.uid), "status": "done"}
    again = boat_a.post(url, {"status": "done", "detail": "arrived"}, format="json")
    late = boat_a.post(url, {"status": "acknowledged"}, format="json")
    assert again.status_code == late.status_code == 200
    assert late.json() == {"uid": str(command_a.uid), "status": "done"}
    command_a.refresh_from_db()
    assert command_a.status == Status.DONE
    assert command_a.result_detail == "arrived"
    assert [e.to_status for e in command_a.events.all()] == [
        "queued",
        "sent",
        "acknowledged",
        "done",
    ]


def test_an_illegal_ack_is_a_409_naming_both_statuses(
    boat_a: APIClient, command_a: Command
) -> None:
    boat_a.get(COMMANDS)
    command_cancel(command=command_a, actor="alice")
    response = boat_a.post(ack_url(command_a.uid), {"status": "done"}, format="json")
    assert response.status_code == 409
    assert response.json() == {
        "error": "conflict",
        "detail": "command is cancelled; it cannot become done",
    }
    command_a.refresh_from_db()
    assert command_a.status == Status.CANCELLED


def test_a_conflicting_final_ack_is_a_409(boat_a: APIClient, command_a: Command) -> None:
    boat_a.get(COMMANDS)
    boat_a.post(ack_url(command_a.uid), {"status": "done"}, format="json")
    response = boat_a.post(ack_url(command_a.uid), {"status": "failed"}, format="json")
    assert response.status_code == 409
    command_a.refresh_from_db()
    assert command_a.status == Status.DONE


def test_acking_a_command_never_polled_is_a_409(boat_a: APIClient, command_a: Command) -> None:
    response = boat_a.post(ack_url(command_a.uid), {"status": "acknowledged"}, format="json")
    assert response.status_code == 409


@pytest.mark.parametrize(
    ("body", "field", "message"),
    [
        ({"status": "finished"}, "status", "status must be acknowledged, done or failed"),
        ({}, "status", "status must be acknowledged, done or failed"),
        ({"status": True}, "status", "status must be acknowledged, done or failed"),
        ({"status": "done", "detail": 3}, "detail", "must be a string"),
        ({"status": "done", "detail": None}, "detail", "must be a string"),
    ],
)
def test_a_bad_ack_is_a_400_naming_the_field(
    boat_a: APIClient, command_a: Command, body: dict[str, Any], field: str, message: str
) -> None:
    boat_a.get(COMMANDS)
    response = boat_a.post(ack_url(command_a.uid), body, format="json")
    assert response.status_code == 400
    assert response.json() == {"error": "invalid", "detail": {field: [message]}}
    command_a.refresh_from_db()
    assert command_a.status == Status.SENT


@pytest.mark.parametrize("body", ['["done"]', '"done"', "3", "null"])
def test_an_ack_body_that_is_not_an_object_is_a_400(
    boat_a: APIClient, command_a: Command, body: str
) -> None:
    response = boat_a.post(ack_url(command_a.uid), body, content_type="application/json")
    assert response.status_code == 400
    assert response.json()["error"] == "parse_error"
    assert "Expected a JSON object" in response.json()["detail"]


def test_an_ack_with_malformed_json_is_a_400(boat_a: APIClient, command_a: Command) -> None:
    response = boat_a.post(ack_url(command_a.uid), '{"status":', content_type="application/json")
    assert response.status_code == 400
    assert response.json()["error"] == "parse_error"


# ~200 kB of brackets: Python's json raises RecursionError, which is no ValueError (a 500).
DEEPLY_NESTED = "[" * 100_000 + "]" * 100_000


@pytest.mark.parametrize("path", [TELEMETRY, ack_url("00000000-0000-4000-8000-000000000000")])
def test_a_deeply_nested_body_is_a_400(boat_a: APIClient, path: str) -> None:
    response = boat_a.post(path, DEEPLY_NESTED, content_type="application/json")
    assert response.status_code == 400
    assert response.json()["error"] == "parse_error"
    assert "nested" in response.json()["detail"]


@pytest.mark.parametrize("uid", ["not-a-uuid", "00000000-0000-4000-8000-000000000000"])
def test_an_ack_for_an_unknown_uid_is_a_404(boat_a: APIClient, uid: str) -> None:
    response = boat_a.post(ack_url(uid), {"status": "done"}, format="json")
    assert response.status_code == 404
    assert response.json()["error"] == "not_found"


def test_the_ack_detail_is_kept_within_bounds(boat_a: APIClient, command_a: Command) -> None:
    boat_a.get(COMMANDS)
    boat_a.post(ack_url(command_a.uid), {"status": "failed", "detail": "x" * 5000}, format="json")
    command_a.refresh_from_db()
    assert command_a.status == Status.FAILED
    assert len(command_a.result_detail) == 2000


@pytest.mark.parametrize("text", ["ok\x00then", "ok\ud800then"])
def test_an_ack_detail_the_database_cannot_store_is_kept_readable(
    boat_a: APIClient, command_a: Command, text: str
) -> None:
    # NUL (PostgreSQL text refuses it) and a lone surrogate (not UTF-8 at all) were a 500.
    boat_a.get(COMMANDS)
    body = json.dumps({"status": "failed", "detail": text})
    response = boat_a.post(ack_url(command_a.uid), body, content_type="application/json")
    assert response.status_code == 200
    command_a.refresh_from_db()
    assert command_a.status == Status.FAILED
    assert command_a.result_detail == "ok\ufffdthen"
    assert command_a.events.last().detail == "ok\ufffdthen"


# --- telemetry ---


def test_it_stores_a_list_or_an_object_of_fixes(
    boat_a: APIClient, vessel_a: Vessel, make_fix: MakeFix
) -> None:
    response = boat_a.post(TELEMETRY, [make_fix(time="2026-11-23T09:00:00Z")], format="json")
    assert response.json() == {"accepted": 1, "duplicates": 0, "rejected": []}
    response = boat_a.post(
        TELEMETRY, {"fixes": [make_fix(time="2026-11-23T09:00:01+00:00")]}, format="json"
    )
    assert response.json() == {"accepted": 1, "duplicates": 0, "rejected": []}
    fix = vessel_a.fixes.order_by("recorded_at").first()
    assert (fix.lat, fix.lon, fix.heading_deg, fix.speed_mps, fix.battery_v) == (
        -31.9505,
        115.8605,
        90.0,
        1.2,
        12.6,
    )
    assert fix.readings == {"water_temp_c": 19.5}
    vessel_a.refresh_from_db()
    assert vessel_a.last_fix_at == dt.datetime(2026, 11, 23, 9, 0, 1, tzinfo=dt.UTC)
    assert vessel_a.last_seen_at is not None


def test_it_takes_unix_seconds(boat_a: APIClient, vessel_a: Vessel, make_fix: MakeFix) -> None:
    when = timezone.now().replace(microsecond=0) - dt.timedelta(minutes=5)
    boat_a.post(TELEMETRY, [make_fix(time=when.timestamp())], format="json")
    assert vessel_a.fixes.get().recorded_at == when


def test_a_resent_batch_counts_as_duplicates(
    boat_a: APIClient, vessel_a: Vessel, make_fix: MakeFix
) -> None:
    batch = [make_fix(time=f"2026-11-23T09:00:0{i}Z") for i in range(3)]
    boat_a.post(TELEMETRY, batch[:2], format="json")
    response = boat_a.post(TELEMETRY, batch, format="json")
    assert response.json() == {"accepted": 1, "duplicates": 2, "rejected": []}
    assert vessel_a.fixes.count() == 3


@pytest.mark.parametrize(
    ("body", "message"),
    [
        ("{not json", "JSON parse error"),
        ('[{"time": 1, "lat": NaN, "lon": 0}]', "NaN"),
        ('[{"lat": Infinity}]', "Infinity"),
        ('{"lat": 1, "lon": 2}', 'Expected a JSON list of fixes, or an object {"fixes": [...]}.'),
        ('{"fixes": {"lat": 1}}', "Expected a JSON list of fixes"),
        ('"fixes"', "Expected a JSON list of fixes"),
        ("42", "Expected a JSON list of fixes"),
        ("null", "Expected a JSON list of fixes"),
        ("", "Expected a JSON list of fixes"),
    ],
)
def test_a_body_that_is_not_a_list_of_fixes_is_a_400(
    boat_a: APIClient, vessel_a: Vessel, body: str, message: str
) -> None:
    response = boat_a.post(TELEMETRY, body, content_type="application/json")
    assert response.status_code == 400
    assert response.json()["error"] == "parse_error"
    assert message in response.json()["detail"]
    assert not Fix.objects.exists()


def test_a_body_that_is_not_json_at_all_is_a_415(boat_a: APIClient) -> None:
    response = boat_a.post(TELEMETRY, "lat=1&lon=2", content_type="text/plain")
    assert response.status_code == 415
    assert response.json()["error"] == "unsupported_media_type"


def test_a_batch_over_the_limit_is_refused_whole(
    boat_a: APIClient, make_fix: MakeFix, settings: Any
) -> None:
    settings.FIX_MAX_BATCH = 5
    base = dt.datetime(2026, 11, 23, 9, tzinfo=dt.UTC)
    batch = [make_fix(time=iso(base + dt.timedelta(seconds=i))) for i in range(6)]
    response = boat_a.post(TELEMETRY, batch, format="json")
    assert response.status_code == 400
    assert response.json() == {
        "error": "parse_error",
        "detail": "At most 5 fixes per request (got 6).",
    }
    assert not Fix.objects.exists()
    assert boat_a.post(TELEMETRY, batch[:5], format="json").json()["accepted"] == 5


def _future() -> str:
    return iso(timezone.now() + dt.timedelta(hours=1))


BAD_FIXES: list[tuple[dict[str, Any], dict[str, str]]] = [
    ({"lat": 91}, {"lat": "must be between -90 and 90"}),
    ({"lon": -180.5}, {"lon": "must be between -180 and 180"}),
    ({"lat": "-31.9"}, {"lat": "must be a number"}),
    ({"lat": True}, {"lat": "must be a number"}),
    ({"lon": False}, {"lon": "must be a number"}),
    ({"lat": None}, {"lat": "is required"}),
    ({"lat": ...}, {"lat": "is required"}),
    ({"lat": 10**400}, {"lat": "must be a number"}),
    ({"time": ...}, {"time": "is required"}),
    ({"time": "2026-11-23T10:00:00"}, {"time": "needs a UTC offset, e.g. 2026-11-23T10:00:00Z"}),
    ({"time": "yesterday"}, {"time": "must be ISO 8601 (with offset) or Unix seconds"}),
    ({"time": True}, {"time": "must be ISO 8601 (with offset) or Unix seconds"}),
    ({"time": 1e20}, {"time": "is out of range"}),
    ({"time": "2009-01-01T00:00:00Z"}, {"time": "is before 2018-01-01"}),
    ({"heading_deg": 361}, {"heading_deg": "must be between 0 and 360"}),
    ({"heading_deg": "N"}, {"heading_deg": "must be a number"}),
    ({"speed_mps": -1}, {"speed_mps": "must be between 0 and 1000"}),
    ({"battery_v": True}, {"battery_v": "must be a number"}),
    ({"readings": [1, 2]}, {"readings": "must be an object of name: number"}),
    ({"readings": {"t": "hot"}}, {"readings": "t must be a number"}),
    ({"readings": {"t": None}}, {"readings": "t must be a number"}),
    ({"readings": {"t": True}}, {"readings": "t must be a number"}),
    ({"readings": {"x" * 51: 1}}, {"readings": f"name {'x' * 20!r} must be 1-50 characters"}),
    ({"readings": {f"r{i}": i for i in range(65)}}, {"readings": "has more than 64 values"}),
]


@pytest.mark.parametrize(("overrides", "errors"), BAD_FIXES)
def test_a_bad_fix_is_rejected_by_index_naming_the_field(
    boat_a: APIClient,
    vessel_a: Vessel,
    make_fix: MakeFix,
    overrides: dict[str, Any],
    errors: dict[str, str],
) -> None:
    response = boat_a.post(TELEMETRY, [make_fix(**overrides)], format="json")
    assert response.status_code == 200
    assert response.json() == {
        "accepted": 0,
        "duplicates": 0,
        "rejected": [{"index": 0, "errors": errors}],
    }
    assert not Fix.objects.exists()
    vessel_a.refresh_from_db()
    assert vessel_a.last_fix is None


def test_a_fix_far_in_the_future_is_rejected(boat_a: APIClient, make_fix: MakeFix) -> None:
    response = boat_a.post(TELEMETRY, [make_fix(time=_future())], format="json")
    assert response.json()["rejected"] == [
        {"index": 0, "errors": {"time": "is more than 300 s in the future (check the clock)"}}
    ]
    assert not Fix.objects.exists()


def test_an_unknown_field_is_rejected_naming_it(boat_a: APIClient, make_fix: MakeFix) -> None:
    response = boat_a.post(TELEMETRY, [make_fix(altitude=3)], format="json")
    errors = response.json()["rejected"][0]["errors"]
    assert list(errors) == ["altitude"]
    assert errors["altitude"].startswith("unknown field (allowed: battery_v, heading_deg, lat")


def test_a_fix_that_is_not_an_object_is_rejected_by_index(
    boat_a: APIClient, make_fix: MakeFix
) -> None:
    response = boat_a.post(TELEMETRY, [make_fix(), [1, 2], "fix", None], format="json")
    body = response.json()
    assert body["accepted"] == 1
    assert [r["index"] for r in body["rejected"]] == [1, 2, 3]
    assert body["rejected"][0]["errors"] == {"non_field_errors": "each fix must be a JSON object"}


@pytest.mark.parametrize("name", ["a\x00b", "a\ud800b"])
def test_a_reading_name_the_database_cannot_store_costs_only_its_own_fix(
    boat_a: APIClient, vessel_a: Vessel, make_fix: MakeFix, name: str
) -> None:
    # On PostgreSQL this failed the whole INSERT: a 500, and the good fix lost with it.
    batch = [
        make_fix(time="2026-11-23T09:00:00Z"),
        make_fix(time="2026-11-23T09:00:01Z", readings={name: 1.0}),
        make_fix(time="2026-11-23T09:00:02Z", **{name: 1.0}),
    ]
    body = json.dumps({"fixes": batch})
    response = boat_a.post(TELEMETRY, body, content_type="application/json")
    assert response.status_code == 200
    assert response.json()["accepted"] == 1
    assert [r["index"] for r in response.json()["rejected"]] == [1, 2]
    assert vessel_a.fixes.count() == 1


def test_the_good_fixes_of_a_mixed_batch_are_stored(
    boat_a: APIClient, vessel_a: Vessel, make_fix: MakeFix
) -> None:
    batch = [
        make_fix(time="2026-11-23T09:00:00Z"),
        make_fix(time="2026-11-23T09:00:01Z", lat=123),
        make_fix(time="2026-11-23T09:00:02Z", lon=True),
        make_fix(time="2026-11-23T09:00:03Z", lat=-32.0),
        make_fix(time=_future()),
        make_fix(time="2026-11-23T09:00:05"),
        make_fix(time="2026-11-23T09:00:00Z"),  # a repeat of the first, inside the batch
    ]
    response = boat_a.post(TELEMETRY, batch, format="json")
    assert response.status_code == 200
    body = response.json()
    assert (body["accepted"], body["duplicates"]) == (2, 1)
    assert [(r["index"], list(r["errors"])) for r in body["rejected"]] == [
        (1, ["lat"]),
        (2, ["lon"]),
        (4, ["time"]),
        (5, ["time"]),
    ]
    stored = list(vessel_a.fixes.order_by("recorded_at").values_list("recorded_at", "lat"))
    assert stored == [
        (dt.datetime(2026, 11, 23, 9, 0, 0, tzinfo=dt.UTC), -31.9505),
        (dt.datetime(2026, 11, 23, 9, 0, 3, tzinfo=dt.UTC), -32.0),
    ]
    vessel_a.refresh_from_db()
    assert vessel_a.last_fix["lat"] == -32.0


def test_a_key_use_updates_last_seen_even_without_fixes(
    boat_a: APIClient, vessel_a: Vessel
) -> None:
    assert boat_a.get(COMMANDS).status_code == 200
    vessel_a.refresh_from_db()
    assert vessel_a.last_seen_at is not None


def test_boat_client_helper_uses_the_api_key_scheme(key_a: str) -> None:
    assert boat_client(key_a).get(COMMANDS).status_code == 200
    assert CommandEvent.objects.count() == 0
