"""The thesis' SPAB endpoints (DESIGN §5 "Legacy SPAB wire format"): Listings 1 and 2 of
../shared/seed/000_87a6d6aa4cee2e16.txt, the telemAck reply and the three ways to send a key."""

from __future__ import annotations

import base64
import datetime as dt
import json
from typing import Any

import pytest
from django.utils import timezone
from rest_framework.test import APIClient

from commands.lifecycle import Status
from commands.models import Command
from commands.services import command_enqueue
from telemetry.models import Fix
from telemetry.parsing import LEGACY_EPOCH, LEGACY_TICKS_PER_S
from tests.conftest import boat_client
from vessels.models import Vessel

DATA = "/spab/data.cgi"
COMMANDS = "/spab/requestCommands.cgi"

# Listing 1 ("Logging JSON"), as real JSON with the same keys and values.
LISTING_1 = [
    {
        "timestamp": 1536551550,
        "latitude": -31.9505,
        "longitude": 115.8605,
        "temperature": 301.3,
        "salinity": 35.5,
    },
    {
        "timestamp": 1536552678,
        "latitude": -30.1505,
        "longitude": 116.8705,
        "temperature": 299.1,
        "salinity": 35.5,
    },
]


def post(client: APIClient, body: Any, **extra: Any) -> Any:
    return client.post(DATA, json.dumps(body), content_type="application/json", **extra)


def telem_ack(response: Any) -> tuple[str, str]:
    body = response.json()
    assert body[0] == {"type": "telemAck"}
    assert set(body[1]) == {"success", "message"}
    return body[1]["success"], body[1]["message"]


def ticks(when: dt.datetime) -> int:
    """The old server's timestamp: units of 10 µs since 2015-01-01."""
    return round((when - LEGACY_EPOCH).total_seconds() * LEGACY_TICKS_PER_S)


# --- data.cgi ---


def test_it_stores_listing_1_and_answers_telem_ack(boat_a: APIClient, vessel_a: Vessel) -> None:
    response = post(boat_a, LISTING_1)
    assert response.status_code == 200
    assert telem_ack(response) == ("true", "accepted 2, duplicates 0, rejected 0")
    fixes = list(vessel_a.fixes.order_by("recorded_at"))
    assert [(f.recorded_at, f.lat, f.lon, f.readings) for f in fixes] == [
        (
            dt.datetime(2018, 9, 10, 3, 52, 30, tzinfo=dt.UTC),
            -31.9505,
            115.8605,
            {"temperature": 301.3, "salinity": 35.5},
        ),
        (
            dt.datetime(2018, 9, 10, 4, 11, 18, tzinfo=dt.UTC),
            -30.1505,
            116.8705,
            {"temperature": 299.1, "salinity": 35.5},
        ),
    ]
    vessel_a.refresh_from_db()
    assert vessel_a.last_fix["lat"] == -30.1505
    assert vessel_a.last_fix_at == fixes[1].recorded_at


def test_it_takes_a_single_object_too(boat_a: APIClient, vessel_a: Vessel) -> None:
    response = post(boat_a, LISTING_1[0])
    assert telem_ack(response) == ("true", "accepted 1, duplicates 0, rejected 0")
    assert vessel_a.fixes.get().readings == {"temperature": 301.3, "salinity": 35.5}


def test_a_resent_listing_is_counted_as_duplicates(boat_a: APIClient, vessel_a: Vessel) -> None:
    post(boat_a, LISTING_1)
    response = post(boat_a, LISTING_1)
    assert telem_ack(response) == ("true", "accepted 0, duplicates 2, rejected 0")
    assert vessel_a.fixes.count() == 2


def test_it_reads_the_old_servers_10_microsecond_ticks(boat_a: APIClient, vessel_a: Vessel) -> None:
    when = dt.datetime(2026, 11, 23, 9, 30, 15, 120000, tzinfo=dt.UTC)
    post(boat_a, {"timestamp": ticks(when), "latitude": -32, "longitude": 115.7})
    fix = vessel_a.fixes.get()
    assert fix.recorded_at == when
    assert "timestamp_raw" not in fix.readings


@pytest.mark.parametrize(
    "raw",
    [
        123_456,  # the old client's milliseconds since autopilot boot
        0,
        -5,
        4_102_444_800,  # 2100-01-01 in Unix seconds: far in the future
        1e30,
    ],
)
def test_an_implausible_timestamp_gets_the_receive_time_and_keeps_the_raw_value(
    boat_a: APIClient, vessel_a: Vessel, raw: float
) -> None:
    before = timezone.now()
    response = post(boat_a, {"timestamp": raw, "latitude": -32, "longitude": 115.7})
    assert telem_ack(response)[0] == "true"
    fix = vessel_a.fixes.get()
    assert before <= fix.recorded_at <= timezone.now()
    # PostgreSQL keeps 1e30 as the JSON number 1000…000, which reads back as an int.
    assert fix.readings == {"timestamp_raw": pytest.approx(raw)}


def test_implausible_timestamps_in_one_batch_do_not_collide(
    boat_a: APIClient, vessel_a: Vessel
) -> None:
    batch = [
        {"timestamp": 1000 + i, "latitude": -32, "longitude": 115.7 + i / 100} for i in range(5)
    ]
    response = post(boat_a, batch)
    assert telem_ack(response) == ("true", "accepted 5, duplicates 0, rejected 0")
    fixes = list(vessel_a.fixes.order_by("recorded_at"))
    assert len({f.recorded_at for f in fixes}) == 5
    # Batch order is kept: the boat sent them oldest first.
    assert [f.readings["timestamp_raw"] for f in fixes] == [1000, 1001, 1002, 1003, 1004]


def test_a_missing_timestamp_gets_the_receive_time(boat_a: APIClient, vessel_a: Vessel) -> None:
    post(boat_a, {"latitude": -32, "longitude": 115.7, "temperature": 290})
    assert vessel_a.fixes.get().readings == {"temperature": 290}


def test_bad_records_are_reported_in_the_telem_ack_and_the_good_ones_kept(
    boat_a: APIClient, vessel_a: Vessel
) -> None:
    batch = [
        LISTING_1[0],
        {"timestamp": 1536552678, "latitude": 95, "longitude": 116.8705},
        {"timestamp": 1536552679, "latitude": -30, "longitude": 116, "temperature": "hot"},
        "not a record",
    ]
    response = post(boat_a, batch)
    assert response.status_code == 200
    success, message = telem_ack(response)
    assert success == "false"
    assert message == (
        "accepted 1, duplicates 0, rejected 3; record 1: latitude must be between -90 and 90"
        "; record 2: temperature must be a number"
        "; record 3: non_field_errors each record must be a JSON object"
    )
    assert vessel_a.fixes.count() == 1


def test_a_batch_of_only_bad_records_is_a_400(boat_a: APIClient) -> None:
    response = post(boat_a, [{"timestamp": 1536551550, "latitude": True, "longitude": 115}])
    assert response.status_code == 400
    assert telem_ack(response) == (
        "false",
        "accepted 0, duplicates 0, rejected 1; record 0: latitude must be a number",
    )
    assert not Fix.objects.exists()


@pytest.mark.parametrize(
    ("body", "message"),
    [
        ("{oops", "JSON parse error"),
        ("42", "expected a JSON object or a list of objects"),
        ('"hello"', "expected a JSON object or a list of objects"),
    ],
)
def test_a_body_that_is_no_record_is_a_400_telem_ack(
    boat_a: APIClient, body: str, message: str
) -> None:
    response = boat_a.post(DATA, body, content_type="application/json")
    assert response.status_code == 400
    success, text = telem_ack(response)
    assert success == "false"
    assert message in text


def test_a_batch_over_the_limit_is_a_400_telem_ack_naming_the_limit(
    boat_a: APIClient, settings: Any
) -> None:
    settings.FIX_MAX_BATCH = 1
    response = post(boat_a, LISTING_1)
    assert response.status_code == 400
    assert telem_ack(response) == ("false", "At most 1 fixes per request (got 2).")
    assert not Fix.objects.exists()


# --- the three ways to send a key, and the errors ---


def basic(slug: str, key: str) -> str:
    return "Basic " + base64.b64encode(f"{slug}:{key}".encode()).decode()


@pytest.mark.parametrize("how", ["authorization", "api-key-header", "basic", "query"])
def test_it_takes_the_key_in_each_of_the_old_ways(key_a: str, vessel_a: Vessel, how: str) -> None:
    client = APIClient()
    url = DATA
    if how == "authorization":
        client.credentials(HTTP_AUTHORIZATION=f"Api-Key {key_a}")
    elif how == "api-key-header":
        client.credentials(HTTP_API_KEY=key_a)
    elif how == "basic":
        client.credentials(HTTP_AUTHORIZATION=basic("spab", key_a))
    else:
        url = f"{DATA}?key={key_a}"
    response = client.post(url, json.dumps(LISTING_1), content_type="application/json")
    assert response.status_code == 200
    assert vessel_a.fixes.count() == 2
    commands = client.get(COMMANDS if how != "query" else f"{COMMANDS}?key={key_a}")
    assert commands.status_code == 200


@pytest.mark.parametrize(
    ("credentials", "query", "message"),
    [
        ({}, "", "Authentication credentials were not provided."),
        ({"HTTP_AUTHORIZATION": "BASIC_SPAB"}, "", "Authentication credentials were not provided."),
        ({"HTTP_API_KEY": "ssk_nope"}, "", "Invalid vessel key."),
        ({}, "?key=ssk_nope", "Invalid vessel key."),
        ({"HTTP_AUTHORIZATION": "Basic !!!"}, "", "Malformed Basic credentials."),
        # Header values arrive as latin-1 text: base64 of non-ASCII raised ValueError (a 500).
        ({"HTTP_AUTHORIZATION": "Basic é"}, "", "Malformed Basic credentials."),
    ],
)
@pytest.mark.parametrize("path", [DATA, COMMANDS])
def test_missing_or_wrong_keys_get_a_401_telem_ack(
    vessel_a: Vessel, credentials: dict[str, str], query: str, message: str, path: str
) -> None:
    client = APIClient()
    client.credentials(**credentials)
    response = (
        client.get(path + query)
        if path == COMMANDS
        else client.post(path + query, json.dumps(LISTING_1), content_type="application/json")
    )
    assert response.status_code == 401
    assert response["WWW-Authenticate"] == 'Basic realm="shoreside"'
    assert telem_ack(response) == ("false", message)
    assert not Fix.objects.exists()


def test_a_deeply_nested_body_is_a_400_telem_ack(boat_a: APIClient) -> None:
    body = "[" * 100_000 + "]" * 100_000
    response = boat_a.post(DATA, body, content_type="application/json")
    assert response.status_code == 400
    success, message = telem_ack(response)
    assert success == "false" and "nested" in message


@pytest.mark.parametrize("name", ["a\x00b", "a\ud800b"])
def test_a_reading_name_the_database_cannot_store_costs_only_its_own_record(
    boat_a: APIClient, vessel_a: Vessel, name: str
) -> None:
    body = [LISTING_1[0], {**LISTING_1[1], name: 1.0}]
    response = post(boat_a, body)
    assert response.status_code == 200
    success, message = telem_ack(response)
    assert success == "false" and "accepted 1" in message and "record 1" in message
    assert vessel_a.fixes.count() == 1


def test_basic_auth_with_another_vessels_slug_gets_401(key_a: str, vessel_b: Vessel) -> None:
    client = APIClient()
    client.credentials(HTTP_AUTHORIZATION=basic("spab-2", key_a))
    response = post(client, LISTING_1)
    assert response.status_code == 401
    assert telem_ack(response) == ("false", "The key does not belong to that vessel.")
    assert not Fix.objects.exists()


@pytest.mark.parametrize("how", ["authorization", "basic", "query"])
def test_a_revoked_key_gets_401_whichever_way_it_comes(revoked_key_a: str, how: str) -> None:
    client = APIClient()
    url = DATA
    if how == "authorization":
        client.credentials(HTTP_AUTHORIZATION=f"Api-Key {revoked_key_a}")
    elif how == "basic":
        client.credentials(HTTP_AUTHORIZATION=basic("spab", revoked_key_a))
    else:
        url += f"?key={revoked_key_a}"
    response = client.post(url, json.dumps(LISTING_1), content_type="application/json")
    assert response.status_code == 401
    assert telem_ack(response) == ("false", "This vessel key has been revoked.")


def test_an_operator_is_not_a_legacy_boat(operator: APIClient) -> None:
    response = post(operator, LISTING_1)
    assert response.status_code == 403
    assert telem_ack(response)[0] == "false"
    assert not Fix.objects.exists()


def test_legacy_responses_carry_no_browser_headers(boat_a: APIClient) -> None:
    for response in (post(boat_a, LISTING_1), boat_a.get(COMMANDS), post(APIClient(), [])):
        for header in (
            "X-Frame-Options",
            "Referrer-Policy",
            "Vary",
            "Allow",
            "X-Content-Type-Options",
            "Cross-Origin-Opener-Policy",
        ):
            assert header not in response.headers


# --- requestCommands.cgi (Listing 2) ---


def test_it_answers_listing_2_with_the_command_uid_as_task_id(
    boat_a: APIClient, vessel_a: Vessel, glider: Vessel
) -> None:
    first = command_enqueue(
        vessel=vessel_a, kind="move_to", params={"lat": -31.9505, "lon": 115.8605}
    )
    # Two move_to commands would supersede each other; the thesis shows two, so the
    # second arrives as its own (already sent) navigation order: deliver one, then queue.
    response = boat_a.get(COMMANDS)
    assert response.status_code == 200
    assert response.json() == [
        {"type": "command"},
        {
            "action": "moveTo",
            "latitude": -31.9505,
            "longitude": 115.8605,
            "timestamp": int(first.created_at.timestamp()),
            "taskId": str(first.uid),
        },
    ]
    second = command_enqueue(
        vessel=vessel_a, kind="move_to", params={"lat": -30.1505, "lon": 116.8705}
    )
    hold = command_enqueue(vessel=vessel_a, kind="hold", params={})
    command_enqueue(vessel=vessel_a, kind="arm", params={})  # no legacy form: never offered
    response = boat_a.get(COMMANDS)
    second.refresh_from_db()
    assert second.status == Status.SUPERSEDED  # the newer hold replaced it before delivery
    assert response.json() == [
        {"type": "command"},
        {"action": "hold", "timestamp": int(hold.created_at.timestamp()), "taskId": str(hold.uid)},
    ]


def test_a_delivered_legacy_command_counts_as_acknowledged(
    boat_a: APIClient, vessel_a: Vessel
) -> None:
    command = command_enqueue(vessel=vessel_a, kind="move_to", params={"lat": -31, "lon": 115})
    boat_a.get(COMMANDS)
    command.refresh_from_db()
    assert command.status == Status.ACKNOWLEDGED
    assert [e.to_status for e in command.events.all()] == ["queued", "sent", "acknowledged"]
    # The old client cannot dedupe, so it is not handed the same waypoint again.
    assert boat_a.get(COMMANDS).json() == [{"type": "command"}]


def test_the_task_id_is_stable_between_the_v1_and_legacy_polls(
    boat_a: APIClient, vessel_a: Vessel
) -> None:
    command = command_enqueue(vessel=vessel_a, kind="move_to", params={"lat": -31, "lon": 115})
    v1 = boat_a.get("/api/v1/boat/commands/").json()["commands"][0]["uid"]
    legacy = boat_a.get(COMMANDS).json()[1]["taskId"]
    assert v1 == legacy == str(command.uid)
    assert command.events.filter(to_status="sent").count() == 1


def test_another_boats_commands_are_never_listed(boat_b: APIClient, vessel_a: Vessel) -> None:
    command = command_enqueue(vessel=vessel_a, kind="hold", params={})
    assert boat_b.get(COMMANDS).json() == [{"type": "command"}]
    command.refresh_from_db()
    assert command.status == Status.QUEUED
    assert Command.objects.filter(vessel=vessel_a, status="queued").count() == 1


def test_the_api_key_header_persona_works_on_legacy_commands(key_a: str) -> None:
    assert boat_client(key_a).get(COMMANDS).json() == [{"type": "command"}]
