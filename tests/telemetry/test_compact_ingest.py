"""Compact fixes on `POST /api/v1/boat/telemetry/` (issue 20 §2): the same ingest as JSON,
decoded with the posting vessel's channel table, answered like JSON."""

from __future__ import annotations

import datetime as dt

import pytest
from django.core.exceptions import ValidationError
from django.utils import timezone
from rest_framework.test import APIClient

from edge_client.contract.compact import CONTENT_TYPE, Channel, encode
from telemetry.models import Fix
from vessels.models import Vessel

URL = "/api/v1/boat/telemetry/"
TABLE = [{"name": "humidity_pct", "step": 0.1}, {"name": "water_temp_c", "step": 0.01}]
CHANNELS = [Channel("humidity_pct", 0.1), Channel("water_temp_c", 0.01)]


def fixes(n: int, start: dt.datetime | None = None) -> list[dict]:
    start = start or timezone.now() - dt.timedelta(minutes=10)
    return [
        {
            "time": (start + dt.timedelta(seconds=10 * i)).isoformat(),
            "lat": -32.05 + i * 1e-4,
            "lon": 115.74 + i * 1e-4,
            "heading_deg": 45.0,
            "speed_mps": 1.8,
            "battery_v": 12.61,
            "readings": {"humidity_pct": 41.2 + i / 10, "water_temp_c": 18.37},
        }  # fmt: skip
        for i in range(n)
    ]


def post(client: APIClient, payload: bytes):
    return client.post(URL, data=payload, content_type=CONTENT_TYPE)


@pytest.fixture
def tabled(vessel_a: Vessel) -> Vessel:
    vessel_a.compact_channels = TABLE
    vessel_a.full_clean()
    vessel_a.save()
    return vessel_a


def test_a_compact_batch_is_stored_like_json(boat_a: APIClient, tabled: Vessel) -> None:
    sent = fixes(30)
    response = post(boat_a, encode(sent, CHANNELS))
    assert response.status_code == 200, response.content
    assert response["Content-Type"] == "application/json"
    assert response.json() == {"accepted": 30, "duplicates": 0, "rejected": []}
    stored = list(Fix.objects.filter(vessel=tabled).order_by("recorded_at"))
    assert len(stored) == 30
    last = stored[-1]
    assert last.lat == pytest.approx(sent[-1]["lat"], abs=1.1e-5)
    assert last.lon == pytest.approx(sent[-1]["lon"], abs=1.1e-5)
    assert (last.heading_deg, last.speed_mps, last.battery_v) == (45.0, 1.8, 12.61)
    assert last.readings == {"humidity_pct": pytest.approx(44.1), "water_temp_c": 18.37}
    tabled.refresh_from_db()
    assert tabled.last_fix["lat"] == pytest.approx(sent[-1]["lat"], abs=1.1e-5)
    # Sent again (the answer was lost at sea): counted once.
    again = post(boat_a, encode(sent, CHANNELS))
    assert again.json() == {"accepted": 0, "duplicates": 30, "rejected": []}


def test_a_fix_the_ingest_refuses_is_refused_by_index(boat_a: APIClient, tabled: Vessel) -> None:
    sent = fixes(3)
    sent[2]["time"] = (timezone.now() + dt.timedelta(days=2)).isoformat()  # in the future
    answer = post(boat_a, encode(sent, CHANNELS)).json()
    assert answer["accepted"] == 2 and [r["index"] for r in answer["rejected"]] == [2]


@pytest.mark.parametrize(
    ("payload", "said"),
    [
        (b"", "compact fixes: the body is empty"),
        (b"\xa1\x00", "compact fixes: too short for a compact payload"),
        (b'{"fixes": []}', "compact fixes: not a compact payload (its first byte)"),
        (b"\xa1" + bytes(20), "compact fixes: the payload's checksum does not match"),
    ],
)
def test_bytes_that_are_not_a_payload_are_a_400_saying_why(
    boat_a: APIClient, tabled: Vessel, payload: bytes, said: str
) -> None:
    response = post(boat_a, payload)
    assert response.status_code == 400
    assert response.json()["detail"].startswith(said)
    assert not Fix.objects.exists()


def test_readings_from_another_table_are_refused_not_misread(
    boat_a: APIClient, vessel_a: Vessel
) -> None:
    response = post(boat_a, encode(fixes(2), CHANNELS))  # the vessel has no table
    assert response.status_code == 400
    assert "channel table" in response.json()["detail"]
    assert not Fix.objects.exists()


def test_a_compact_post_needs_the_vessels_key(anonymous: APIClient, tabled: Vessel) -> None:
    assert post(anonymous, encode(fixes(1), CHANNELS)).status_code == 401
    assert not Fix.objects.exists()


@pytest.mark.parametrize(
    "table",
    [{"name": "a"}, [{"name": "a", "step": -1}], [{"name": "a"}, {"name": "a"}], [{"step": 1}]],
)
def test_a_channel_table_that_is_not_one_is_refused_where_it_is_edited(
    vessel_a: Vessel, table: object
) -> None:
    vessel_a.compact_channels = table
    with pytest.raises(ValidationError) as refused:
        vessel_a.full_clean()
    assert "compact_channels" in refused.value.message_dict
