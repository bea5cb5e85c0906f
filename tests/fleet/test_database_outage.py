"""A database that drops every connection (a PostgreSQL restart or failover) costs the boats
nothing: the next request reconnects (CONN_HEALTH_CHECKS) instead of failing with a 500."""

from __future__ import annotations

import pytest
import requests
from django.db import connection

from telemetry.models import Fix
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
