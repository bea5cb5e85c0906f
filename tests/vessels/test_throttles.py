"""API request limits (vessels/throttles.py): per vessel for boats, per user for operators;
429 with Retry-After and the API's one error shape."""

from __future__ import annotations

import datetime as dt
from collections.abc import Iterator
from typing import Any

import pytest
import time_machine
from django.contrib.auth.models import User
from rest_framework.test import APIClient

from commands.models import Command
from tests.conftest import boat_client
from vessels.models import Vessel
from vessels.services import vessel_key_issue

# Thirty seconds into a minute, so a 1/min window ends 30 s later.
NOON = dt.datetime(2026, 11, 23, 12, 0, 30, tzinfo=dt.UTC)


@pytest.fixture
def frozen() -> Iterator[time_machine.Coordinates]:
    with time_machine.travel(NOON, tick=False) as traveller:
        yield traveller


@pytest.fixture
def low_rates(settings: Any, frozen: time_machine.Coordinates) -> None:
    settings.REST_FRAMEWORK = {
        **settings.REST_FRAMEWORK,
        "DEFAULT_THROTTLE_RATES": {"boat": "3/min", "operator": "2/min"},
    }


def assert_throttled(response: Any, retry_after: int = 30) -> None:
    assert response.status_code == 429
    assert response["Retry-After"] == str(retry_after)
    body = response.json()
    assert body["error"] == "throttled"
    assert f"{retry_after} seconds" in body["detail"]


def test_a_boat_is_limited_per_vessel(low_rates: None, boat_a: APIClient) -> None:
    for _ in range(3):
        assert boat_a.get("/api/v1/boat/commands/").status_code == 200
    assert_throttled(boat_a.get("/api/v1/boat/commands/"))
    assert_throttled(boat_a.post("/api/v1/boat/telemetry/", [], format="json"))


def test_a_second_key_of_the_same_vessel_shares_its_limit(
    low_rates: None, boat_a: APIClient, vessel_a: Vessel
) -> None:
    other_key = boat_client(vessel_key_issue(vessel=vessel_a, label="spare")[1])
    for client in (boat_a, other_key, boat_a):
        assert client.get("/api/v1/boat/commands/").status_code == 200
    assert_throttled(other_key.get("/api/v1/boat/commands/"))


def test_another_boat_is_not_affected(
    low_rates: None, boat_a: APIClient, boat_b: APIClient
) -> None:
    for _ in range(4):
        boat_a.get("/api/v1/boat/commands/")
    assert boat_b.get("/api/v1/boat/commands/").status_code == 200


def test_the_limit_resets_with_the_next_window(
    low_rates: None, frozen: time_machine.Coordinates, boat_a: APIClient
) -> None:
    for _ in range(3):
        boat_a.get("/api/v1/boat/commands/")
    assert_throttled(boat_a.get("/api/v1/boat/commands/"))
    frozen.shift(30)
    assert boat_a.get("/api/v1/boat/commands/").status_code == 200


def test_legacy_requests_count_for_the_same_vessel(
    low_rates: None, boat_a: APIClient, key_a: str
) -> None:
    legacy = APIClient()
    for _ in range(3):
        assert legacy.get("/spab/requestCommands.cgi", {"key": key_a}).status_code == 200
    response = legacy.get("/spab/requestCommands.cgi", {"key": key_a})
    assert response.status_code == 429
    assert response["Retry-After"] == "30"
    assert response.json()[0] == {"type": "telemAck"}  # the old client's only error shape
    assert_throttled(boat_a.get("/api/v1/boat/commands/"))


def test_an_operator_is_limited_per_user_across_session_and_token(
    low_rates: None,
    session_operator: APIClient,
    token_operator: APIClient,
    readonly: APIClient,
    vessel_a: Vessel,
) -> None:
    assert session_operator.get("/api/v1/vessels/").status_code == 200
    assert token_operator.get("/api/v1/vessels/").status_code == 200
    assert_throttled(session_operator.get("/api/v1/vessels/"))
    assert_throttled(token_operator.get("/api/v1/vessels/"))
    # Bob has no rights: he is refused before any count, and counted apart from Alice.
    assert readonly.get("/api/v1/vessels/").status_code == 403


def test_another_operator_is_not_affected(
    low_rates: None, operator: APIClient, operator_user: User, vessel_a: Vessel
) -> None:
    for _ in range(3):
        operator.get("/api/v1/vessels/")
    carol = User.objects.create_superuser("carol", "carol@example.org", "pw")
    other = APIClient()
    other.force_authenticate(carol)
    assert other.get("/api/v1/vessels/").status_code == 200


def test_the_default_rates_let_a_busy_boat_through(
    frozen: time_machine.Coordinates, boat_a: APIClient, command_a: Command, make_fix: Any
) -> None:
    # One minute of a boat posting every second and polling every two, plus acks.
    for second in range(60):
        when = NOON + dt.timedelta(seconds=second)
        fix = make_fix(time=when.isoformat())
        assert boat_a.post("/api/v1/boat/telemetry/", [fix], format="json").status_code == 200
        if second % 2 == 0:
            assert boat_a.get("/api/v1/boat/commands/").status_code == 200
    ack = boat_a.post(
        f"/api/v1/boat/commands/{command_a.uid}/ack/", {"status": "done"}, format="json"
    )
    assert ack.status_code == 200


def test_the_file_cache_shared_by_workers_counts_too(
    low_rates: None, settings: Any, tmp_path: Any, boat_a: APIClient
) -> None:
    settings.CACHES = {
        "default": {
            "BACKEND": "django.core.cache.backends.filebased.FileBasedCache",
            "LOCATION": str(tmp_path / "cache"),
        }
    }
    for _ in range(3):
        assert boat_a.get("/api/v1/boat/commands/").status_code == 200
    assert_throttled(boat_a.get("/api/v1/boat/commands/"))
    assert any((tmp_path / "cache").iterdir())


def test_an_hourly_rate_holds_for_the_hour_in_the_file_cache(
    settings: Any, tmp_path: Any, boat_a: APIClient, frozen: time_machine.Coordinates
) -> None:
    settings.CACHES = {
        "default": {
            "BACKEND": "django.core.cache.backends.filebased.FileBasedCache",
            "LOCATION": str(tmp_path / "cache"),
        }
    }
    settings.REST_FRAMEWORK = {
        **settings.REST_FRAMEWORK,
        "DEFAULT_THROTTLE_RATES": {"boat": "3/hour", "operator": "3/hour"},
    }
    for _ in range(3):
        assert boat_a.get("/api/v1/boat/commands/").status_code == 200
    # Past the file cache's default 300 s timeout, which its incr() re-sets the key to.
    frozen.shift(dt.timedelta(seconds=400))
    assert boat_a.get("/api/v1/boat/commands/").status_code == 429
