"""The legacy SPAB `data.cgi` (docs/api.md#legacy-spab-endpoints): the original
client's sample records (tests/support.py) in, the telemAck reply out."""

from __future__ import annotations

import datetime as dt
import json
from typing import Any

import pytest
import requests
from django.utils import timezone
from rest_framework.test import APIClient

from telemetry.models import Fix
from telemetry.parsing import MAX_READING_NAME, MAX_READINGS
from tests.support import DATA, LISTING_1, post_data, telem_ack, ticks
from vessels.models import Vessel


def test_it_stores_listing_1_and_answers_telem_ack(boat_a: APIClient, vessel_a: Vessel) -> None:
    response = post_data(boat_a, LISTING_1)
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
    response = post_data(boat_a, LISTING_1[0])
    assert telem_ack(response) == ("true", "accepted 1, duplicates 0, rejected 0")
    assert vessel_a.fixes.get().readings == {"temperature": 301.3, "salinity": 35.5}


def test_a_resent_listing_is_counted_as_duplicates(boat_a: APIClient, vessel_a: Vessel) -> None:
    post_data(boat_a, LISTING_1)
    response = post_data(boat_a, LISTING_1)
    assert telem_ack(response) == ("true", "accepted 0, duplicates 2, rejected 0")
    assert vessel_a.fixes.count() == 2


def test_it_reads_the_old_servers_10_microsecond_ticks(boat_a: APIClient, vessel_a: Vessel) -> None:
    when = dt.datetime(2026, 11, 23, 9, 30, 15, 120000, tzinfo=dt.UTC)
    post_data(boat_a, {"timestamp": ticks(when), "latitude": -32, "longitude": 115.7})
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
    response = post_data(boat_a, {"timestamp": raw, "latitude": -32, "longitude": 115.7})
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
    response = post_data(boat_a, batch)
    assert telem_ack(response) == ("true", "accepted 5, duplicates 0, rejected 0")
    fixes = list(vessel_a.fixes.order_by("recorded_at"))
    assert len({f.recorded_at for f in fixes}) == 5
    # Batch order is kept: the boat sent them oldest first.
    assert [f.readings["timestamp_raw"] for f in fixes] == [1000, 1001, 1002, 1003, 1004]


def test_a_missing_timestamp_gets_the_receive_time(boat_a: APIClient, vessel_a: Vessel) -> None:
    post_data(boat_a, {"latitude": -32, "longitude": 115.7, "temperature": 290})
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
    response = post_data(boat_a, batch)
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
    response = post_data(boat_a, [{"timestamp": 1536551550, "latitude": True, "longitude": 115}])
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
    response = post_data(boat_a, LISTING_1)
    assert response.status_code == 400
    assert telem_ack(response) == ("false", "At most 1 fixes per request (got 2).")
    assert not Fix.objects.exists()


# --- the three ways to send a key, and the errors ---


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
    response = post_data(boat_a, body)
    assert response.status_code == 200
    success, message = telem_ack(response)
    assert success == "false" and "accepted 1" in message and "record 1" in message
    assert vessel_a.fixes.count() == 1


def test_a_record_with_more_readings_than_v1_takes_is_rejected_and_logged(
    boat_a: APIClient, vessel_a: Vessel, caplog: pytest.LogCaptureFixture
) -> None:
    """v1's cap (MAX_READINGS, 64) holds here too: 3,000 readings were stored once."""
    full = {**LISTING_1[1], **{f"r{i}": float(i) for i in range(MAX_READINGS - 2)}}
    over = {**LISTING_1[0], **{f"r{i}": float(i) for i in range(3000)}}
    response = post_data(boat_a, [over, full])
    assert response.status_code == 200
    success, message = telem_ack(response)
    assert success == "false"
    assert message == (
        "accepted 1, duplicates 0, rejected 1;"
        f" record 0: readings has 3002 values (at most {MAX_READINGS})"
    )
    assert len(vessel_a.fixes.get().readings) == MAX_READINGS
    assert "data.cgi from spab" in caplog.text and "record 0: readings" in caplog.text


def test_a_reading_name_over_the_limit_is_rejected_not_dropped(
    boat_a: APIClient, vessel_a: Vessel
) -> None:
    name = "t" * (MAX_READING_NAME + 1)
    response = post_data(boat_a, [{**LISTING_1[0], name: 1.0}, LISTING_1[1]])
    success, message = telem_ack(response)
    assert success == "false"
    assert message.endswith(
        f"record 0: {'t' * 20}… name is longer than {MAX_READING_NAME} characters"
    )
    assert vessel_a.fixes.get().recorded_at == dt.datetime(2018, 9, 10, 4, 11, 18, tzinfo=dt.UTC)


@pytest.mark.parametrize(
    "content_type",
    ["text/plain", "application/x-www-form-urlencoded", "application/octet-stream", ""],
)
def test_data_cgi_reads_json_whatever_the_content_type(
    boat_a: APIClient, vessel_a: Vessel, content_type: str
) -> None:
    response = boat_a.generic("POST", DATA, json.dumps(LISTING_1), content_type=content_type)
    assert response.status_code == 200
    assert telem_ack(response)[0] == "true"
    assert Fix.objects.filter(vessel=vessel_a).count() == 2


@pytest.mark.django_db(transaction=True)
def test_data_cgi_reads_a_body_sent_with_no_content_type_at_all(
    live_server: Any, vessel_a: Vessel, key_a: str
) -> None:
    # requests sends bytes with no Content-Type header, as the original hand-built client did.
    response = requests.post(
        f"{live_server.url}{DATA}?key={key_a}", data=json.dumps(LISTING_1).encode(), timeout=10
    )
    assert "Content-Type" not in response.request.headers
    assert response.status_code == 200, response.text
    assert Fix.objects.filter(vessel=vessel_a).count() == 2


def test_a_non_standard_number_costs_only_its_own_record(
    boat_a: APIClient, vessel_a: Vessel
) -> None:
    body = (
        '[{"timestamp": 1536551550, "latitude": -31.95, "longitude": 115.86},'
        ' {"timestamp": 1536551560, "latitude": NaN, "longitude": 115.86},'
        ' {"timestamp": 1536551570, "latitude": -31.95, "longitude": 115.86, "t": Infinity}]'
    )
    response = boat_a.generic("POST", DATA, body, content_type="application/json")
    assert response.status_code == 200
    success, message = telem_ack(response)
    assert "accepted 1" in message and "record 1: latitude" in message
    assert "record 2: t must be a number" in message
    assert Fix.objects.filter(vessel=vessel_a).count() == 1
