"""v1 telemetry (docs/api.md#boat-api-v1): batches in, one bad fix never loses the good ones."""

from __future__ import annotations

import datetime as dt
import json
from typing import Any

import pytest
from django.db import connection
from django.test.utils import CaptureQueriesContext
from django.utils import timezone
from rest_framework.test import APIClient

from telemetry.models import Fix, TrackDirty
from tests.support import TELEMETRY, MakeFix, iso
from vessels.auth import key_forget, key_is_recent
from vessels.models import Vessel


def test_boat_b_telemetry_goes_to_boat_b(
    boat_b: APIClient, vessel_a: Vessel, vessel_b: Vessel, make_fix: MakeFix
) -> None:
    boat_b.post(TELEMETRY, [make_fix()], format="json")
    assert Fix.objects.get().vessel == vessel_b
    assert not vessel_a.fixes.exists()


# --- the poll: ETag / 304 and at-least-once delivery ---


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
    # Python's ISO parser stops at a NUL: these were taken as 10:00Z and 10:00+05:00.
    ({"time": "2026-11-23T10:00:00Z\x00"}, {"time": "Null characters are not allowed."}),
    ({"time": "2026-11-23T10:00:00\x00+05:00"}, {"time": "Null characters are not allowed."}),
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


ODD_NUMBERS = [
    ('"lat": NaN, "lon": 115.86', "lat"),
    ('"lat": Infinity, "lon": 115.86', "lat"),
    ('"lat": -31.95, "lon": -Infinity', "lon"),
    ('"lat": ' + "9" * 5000 + ', "lon": 115.86', "lat"),
    ('"lat": -31.95, "lon": 115.86, "readings": {"t": NaN}', "readings"),
]


@pytest.mark.parametrize(("position", "field"), ODD_NUMBERS)
def test_a_non_standard_number_costs_only_its_own_fix(
    boat_a: APIClient, vessel_a: Vessel, position: str, field: str
) -> None:
    good = '{"time": "2026-11-23T10:00:00Z", "lat": -31.95, "lon": 115.86}'
    odd = '{"time": "2026-11-23T10:00:10Z", ' + position + "}"
    body = '{"fixes": [' + good + ", " + odd + "]}"
    response = boat_a.generic("POST", TELEMETRY, body, content_type="application/json")
    assert response.status_code == 200, response.content
    answer = response.json()
    assert answer["accepted"] == 1
    assert [(r["index"], list(r["errors"])) for r in answer["rejected"]] == [(1, [field])]
    assert Fix.objects.filter(vessel=vessel_a).count() == 1


# What one single-fix post sends, by database (statement kinds, in order). No key lookup: the
# key comes from the process's recent lookups and the writes check it themselves (a revoked key
# still stops at once: tests below). PostgreSQL: the fix, its overview mark and the vessel's
# last fix in ONE statement (CTEs, no BEGIN/COMMIT: one round trip). SQLite cannot put writes in
# CTEs; its statements are calls into the library, not round trips: one transaction, one
# statement per table written, all built before BEGIN. The key's last use (once a minute) and
# the throttle counts (the cache) are not among them.
# Benchmark: `python -m bench.server --single-only` (issue 17 item 8).
SINGLE_POST_STATEMENTS = {
    "postgresql": ["EXECUTE"],
    "sqlite": ["BEGIN", "INSERT", "INSERT", "UPDATE", "COMMIT"],
}


@pytest.mark.django_db(transaction=True)
def test_a_single_fix_post_sends_the_fewest_statements(
    boat_a: APIClient, vessel_a: Vessel, make_fix: MakeFix
) -> None:
    """Outside a test transaction, so BEGIN and COMMIT show where the server sends them."""
    boat_a.post(TELEMETRY, [make_fix(time="2026-11-23T09:00:00Z")], format="json")  # key touch
    with CaptureQueriesContext(connection) as queries:
        response = boat_a.post(TELEMETRY, [make_fix()], format="json")
    assert response.json()["accepted"] == 1
    kinds = [q["sql"].split(None, 1)[0].upper() for q in queries]
    assert kinds == SINGLE_POST_STATEMENTS[connection.vendor], [q["sql"][:80] for q in queries]
    vessel_a.refresh_from_db()
    assert vessel_a.last_fix_at == dt.datetime(2026, 11, 23, 10, tzinfo=dt.UTC)
    assert vessel_a.last_fix["battery_v"] == 12.6
    assert TrackDirty.objects.filter(vessel=vessel_a).count() == 2  # 09:00 and 10:00 marked


@pytest.mark.django_db(transaction=True)
def test_a_repeated_single_fix_post_writes_only_the_last_seen(
    boat_a: APIClient, vessel_a: Vessel, make_fix: MakeFix
) -> None:
    """A store-and-forward retry: a counted duplicate, no new mark, the vessel seen again."""
    boat_a.post(TELEMETRY, [make_fix()], format="json")
    TrackDirty.objects.all().delete()
    Vessel.objects.filter(pk=vessel_a.pk).update(last_seen_at=None)
    response = boat_a.post(TELEMETRY, [make_fix()], format="json")
    assert (response.json()["accepted"], response.json()["duplicates"]) == (0, 1)
    assert not TrackDirty.objects.exists()
    vessel_a.refresh_from_db()
    assert vessel_a.last_seen_at is not None
    assert vessel_a.last_fix_at == dt.datetime(2026, 11, 23, 10, tzinfo=dt.UTC)


# --- the everyday post's short way (TelemetryView.dispatch) answers as DRF's whole way ---
#
# A key this process looked up lately (vessels.auth.key_lookup_recent) lets a JSON post take the
# short way; the same body from a key not looked up yet goes DRF's whole way. Both boats post
# the same bodies: every answer (status, headers, body) must be the same.

WELL_FORMED = {
    "good": lambda fix: json.dumps([fix]),
    "object": lambda fix: json.dumps({"fixes": [fix, {**fix, "lat": 91}]}),
    "nan": lambda fix: json.dumps([{**fix, "lat": float("nan")}]),
    "not a list": lambda fix: json.dumps({"fix": fix}),
    "bad json": lambda fix: json.dumps([fix])[:-3],
    "not utf-8": lambda fix: json.dumps(
        [{**fix, "readings": {"t\xe9": 1}}], ensure_ascii=False
    ).encode("latin-1"),
    "empty": lambda fix: "",
}


def _answer(response: Any) -> tuple[int, dict[str, str], bytes]:
    return response.status_code, dict(response.headers), response.content


@pytest.mark.parametrize("content_type", ["application/json", "text/plain"])
@pytest.mark.parametrize("body", list(WELL_FORMED))
def test_the_short_way_answers_as_drf_whole_way(
    boat_a: APIClient,
    boat_b: APIClient,
    key_b: str,
    make_fix: MakeFix,
    body: str,
    content_type: str,
) -> None:
    boat_a.post(TELEMETRY, [make_fix(time="2026-11-23T08:00:00Z")], format="json")
    data = WELL_FORMED[body](make_fix())
    short = boat_a.generic("POST", TELEMETRY, data, content_type=content_type)
    key_forget(key_b)
    whole = boat_b.generic("POST", TELEMETRY, data, content_type=content_type)
    assert _answer(short) == _answer(whole)
    # An error answered is checked against a fresh lookup, which the recent keys then lack.
    assert key_is_recent(key_b) == (whole.status_code == 200)


def test_the_short_way_counts_the_throttle_and_refuses_past_it(
    settings: Any, boat_a: APIClient, make_fix: MakeFix
) -> None:
    settings.REST_FRAMEWORK = {
        **settings.REST_FRAMEWORK,
        "DEFAULT_THROTTLE_RATES": {"boat": "2/min", "operator": "2/min"},
    }
    first = boat_a.post(TELEMETRY, [make_fix(time="2026-11-23T08:00:00Z")], format="json")
    assert first.status_code == 200
    assert boat_a.post(TELEMETRY, [make_fix()], format="json").status_code == 200
    refused = boat_a.post(TELEMETRY, [make_fix(time="2026-11-23T10:00:01Z")], format="json")
    assert refused.status_code == 429
    assert refused.json()["error"] == "throttled"
    assert "Retry-After" in refused


def test_only_the_everyday_post_takes_the_short_way(
    rf: Any, boat_a: APIClient, key_a: str, key_b: str, make_fix: MakeFix
) -> None:
    from telemetry.api.boat import everyday_records

    boat_a.post(TELEMETRY, [make_fix(time="2026-11-23T08:00:00Z")], format="json")
    body = json.dumps({"fixes": [make_fix()]})

    def post(key: str = key_a, content_type: str = "application/json") -> Any:
        auth = f"Api-Key {key}"
        return rf.post(TELEMETRY, body, content_type=content_type, HTTP_AUTHORIZATION=auth)

    assert everyday_records(post()) == [make_fix()]
    assert everyday_records(post(key=key_b)) is None  # not looked up yet
    assert everyday_records(post(content_type="application/json; charset=utf-8")) is None
    assert everyday_records(rf.get(TELEMETRY, HTTP_AUTHORIZATION=f"Api-Key {key_a}")) is None
