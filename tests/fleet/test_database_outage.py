"""A database that drops every connection (a PostgreSQL restart or failover) costs the boats
nothing: the next request reconnects (CONN_HEALTH_CHECKS) instead of failing with a 500."""

from __future__ import annotations

from typing import Any

import pytest
import requests
from django.db import OperationalError, connection

from commands.api import boat as boat_views
from telemetry import services
from telemetry.models import Fix
from tests.conftest import boat_client
from tests.support import COMMANDS, TELEMETRY
from vessels.models import Vessel


@pytest.mark.django_db(transaction=True)
def test_boat_requests_survive_the_database_dropping_every_connection(
    live_server, vessel_a: Vessel, key_a: str
) -> None:
    if connection.vendor != "postgresql":
        pytest.skip("SQLite has no server to restart; run the suite with DATABASE_URL")
    http = requests.Session()
    http.headers["Authorization"] = f"Api-Key {key_a}"
    telemetry = live_server.url + "/api/v1/boat/telemetry/"
    first = {"time": "2026-11-23T10:00:00Z", "lat": -31.95, "lon": 115.86}
    assert http.post(telemetry, json={"fixes": [first]}, timeout=10).json()["accepted"] == 1

    # What a restart does to the server's pooled connections: the backends are gone.
    with connection.cursor() as cursor:
        cursor.execute(
            "SELECT count(pg_terminate_backend(pid)) FROM pg_stat_activity"
            " WHERE datname = current_database() AND pid <> pg_backend_pid()"
        )
        assert cursor.fetchone()[0] >= 1  # the live server's connection was among them

    second = {**first, "time": "2026-11-23T10:00:10Z"}
    response = http.post(telemetry, json={"fixes": [second]}, timeout=10)
    assert response.status_code == 200, response.text
    assert response.json()["accepted"] == 1
    assert http.get(live_server.url + "/api/v1/boat/commands/", timeout=10).status_code == 200
    assert Fix.objects.filter(vessel=vessel_a).count() == 2


def drop_own_connection() -> None:
    """What a restart does to this request's connection: gone, mid-request."""
    if connection.vendor == "postgresql":
        with connection.cursor() as cursor:
            cursor.execute("SELECT pg_terminate_backend(pg_backend_pid())")
    # SQLite has no server to lose: its transient refusal is a lock held past busy_timeout.
    raise OperationalError("database is locked")


@pytest.mark.django_db(transaction=True)
def test_an_ingest_that_loses_its_connection_before_commit_is_retried_once(
    vessel_a: Vessel, key_a: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    real_store, calls = services._store_once, []

    def store_dropping_the_first_time(*args: Any) -> Any:
        calls.append(args)
        if len(calls) == 1:
            drop_own_connection()
        return real_store(*args)

    monkeypatch.setattr(services, "_store_once", store_dropping_the_first_time)
    fix = {"time": "2026-11-23T10:00:00Z", "lat": -31.95, "lon": 115.86}
    response = boat_client(key_a).post(TELEMETRY, {"fixes": [fix]}, format="json")
    assert response.status_code == 200, response.content
    assert response.json()["accepted"] == 1
    assert len(calls) == 2
    assert Fix.objects.filter(vessel=vessel_a).count() == 1
    vessel_a.refresh_from_db()
    assert vessel_a.last_fix_at is not None


@pytest.mark.django_db(transaction=True)
def test_a_request_whose_database_goes_away_is_a_503_json_with_retry_after(
    live_server: Any, vessel_a: Vessel, key_a: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    def claim_dropping(**kwargs: Any) -> Any:
        drop_own_connection()

    http = requests.Session()
    http.headers["Authorization"] = f"Api-Key {key_a}"
    monkeypatch.setattr(boat_views, "command_claim_open", claim_dropping)
    response = http.get(live_server.url + COMMANDS, timeout=10)
    assert response.status_code == 503
    assert response.headers["Retry-After"] == "5"
    assert response.json()["error"] == "database_unavailable"
    # The server closes the broken connection after the request; the next one reconnects.
    monkeypatch.undo()
    assert http.get(live_server.url + COMMANDS, timeout=10).status_code == 200


@pytest.mark.django_db(transaction=True)
def test_a_database_fault_that_a_retry_cannot_fix_is_a_500_not_a_503(
    vessel_a: Vessel, key_a: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A missing table (a deploy without `migrate`) must not look like a passing outage."""
    calls = []

    def store_on_a_missing_table(*args: Any) -> Any:
        calls.append(args)
        with connection.cursor() as cursor:
            cursor.execute("SELECT * FROM no_such_table")

    monkeypatch.setattr(services, "_store_once", store_on_a_missing_table)
    client = boat_client(key_a)
    client.raise_request_exception = False
    fix = {"time": "2026-11-23T10:00:00Z", "lat": -31.95, "lon": 115.86}
    response = client.post(TELEMETRY, {"fixes": [fix]}, format="json")
    assert response.status_code == 500
    assert response.json()["error"] == "server_error"
    assert len(calls) == 1  # not retried
