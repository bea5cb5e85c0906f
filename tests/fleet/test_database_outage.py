"""A database that drops every connection (a PostgreSQL restart or failover) costs the boats
nothing: the next request reconnects (CONN_HEALTH_CHECKS) instead of failing with a 500."""

from __future__ import annotations

import collections
import datetime as dt
import os
import random
import socket
import threading
from typing import Any

import psycopg
import pytest
import requests
from django.db import DatabaseError, OperationalError, connection, transaction
from django.test import Client

from commands.api import boat as boat_views
from telemetry import services
from telemetry.models import Fix
from tests.conftest import boat_client
from tests.support import COMMANDS, TELEMETRY, iso
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


def _other_connection() -> psycopg.Connection:
    """A connection of the test's own, as an operator's psql would be, to terminate others."""
    s = connection.settings_dict
    return psycopg.connect(
        host=s["HOST"], port=s["PORT"] or 5432, user=s["USER"], dbname=s["NAME"], autocommit=True
    )


def _backend_pid() -> int:
    with connection.cursor() as cursor:
        cursor.execute("SELECT pg_backend_pid()")
        return cursor.fetchone()[0]


@pytest.mark.django_db(transaction=True)
def test_a_connection_lost_without_sqlstate_inside_a_transaction_is_a_503(
    live_server: Any, vessel_a: Vessel, key_a: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    """libpq's "server closed the connection unexpectedly" carries no SQLSTATE, and by the
    time the error reaches the handler the atomic block has dropped the connection and Django
    has opened a fresh one: only the exception can tell it was the database going away."""
    if connection.vendor != "postgresql":
        pytest.skip("a PostgreSQL connection loss")
    real_claim, lost = boat_views.command_claim_open, []

    def claim_on_a_cut_connection(**kwargs: Any) -> Any:
        # Cut this request's connection under libpq's feet, as a dead network or a killed
        # backend does: the server never gets to say why.
        with transaction.atomic():
            Vessel.objects.select_for_update().get(pk=vessel_a.pk)
            fd = connection.connection.pgconn.socket
            socket.socket(fileno=os.dup(fd)).shutdown(socket.SHUT_RDWR)
            try:
                return real_claim(**kwargs)
            except DatabaseError as exc:
                lost.append(getattr(exc.__cause__, "sqlstate", "?"))
                raise

    http = requests.Session()
    http.headers["Authorization"] = f"Api-Key {key_a}"
    monkeypatch.setattr(boat_views, "command_claim_open", claim_on_a_cut_connection)
    response = http.get(live_server.url + COMMANDS, timeout=10)
    assert lost == [None]
    assert response.status_code == 503, response.text
    assert response.headers["Retry-After"] == "5"
    assert response.json()["error"] == "database_unavailable"
    monkeypatch.undo()
    assert http.get(live_server.url + COMMANDS, timeout=10).status_code == 200


@pytest.mark.slow
@pytest.mark.django_db(transaction=True)
def test_backends_terminated_mid_ingest_are_never_a_500(
    live_server: Any, vessel_a: Vessel, key_a: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The audit's forced losses: another connection terminates the request's backend while
    its batch is being written, at a random moment. Some losses come back as 57P01, some
    (a batch still being sent) as a bare "server closed the connection unexpectedly"; every
    answer is a 200 (ingest's one retry) or a 503 with Retry-After, never a 500."""
    if connection.vendor != "postgresql":
        pytest.skip("pg_terminate_backend")
    killer, real_store = _other_connection(), services._store_once
    losses: collections.Counter[str | None] = collections.Counter()
    rng = random.Random(16)

    def store_while_terminated(*args: Any) -> Any:
        pid = _backend_pid()
        delay = rng.uniform(0, 0.01)
        kill = threading.Timer(delay, killer.execute, ["SELECT pg_terminate_backend(%s)", [pid]])
        kill.start()
        try:
            return real_store(*args)
        except DatabaseError as exc:
            losses[getattr(exc.__cause__, "sqlstate", "?")] += 1
            raise
        finally:
            kill.join()

    monkeypatch.setattr(services, "_store_once", store_while_terminated)
    http = requests.Session()
    http.headers["Authorization"] = f"Api-Key {key_a}"
    statuses: collections.Counter[int] = collections.Counter()
    start = dt.datetime(2026, 11, 1, tzinfo=dt.UTC)
    n = 0
    try:
        while n < 400 and (n < 60 or losses[None] < 3):
            size = rng.choice([1, 100, 1000, 3000])
            fixes = [
                {"time": iso(start + dt.timedelta(seconds=n * 10_000 + i)), "lat": -32, "lon": 115}
                for i in range(size)
            ]
            response = http.post(live_server.url + TELEMETRY, json={"fixes": fixes}, timeout=60)
            statuses[response.status_code] += 1
            if response.status_code == 503:
                assert response.headers["Retry-After"] == "5"
            n += 1
    finally:
        killer.close()
    assert set(statuses) <= {200, 503}, (statuses, losses)
    assert statuses[200] and statuses[503], statuses
    assert losses[None] >= 1, f"no loss without SQLSTATE in {n} requests: {losses}"


@pytest.mark.django_db(transaction=True)
def test_a_page_whose_database_goes_away_is_a_503_page_not_a_500(
    live_server: Any, vessel_a: Vessel, operator_user: Any, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The admin and the map pages are no DRF views: the middleware gives them the 503."""
    from fleet import views

    def lookup_dropping(slug: str) -> Any:
        drop_own_connection()

    login = Client()
    login.force_login(operator_user)
    http = requests.Session()
    http.cookies["sessionid"] = login.cookies["sessionid"].value
    page = f"{live_server.url}/fleet/vessels/{vessel_a.slug}/track/"
    monkeypatch.setattr(views, "vessel_by_slug", lookup_dropping)
    response = http.get(page, timeout=10)
    assert response.status_code == 503
    assert response.headers["Retry-After"] == "5"
    assert "The database is unavailable for a moment" in response.text
    monkeypatch.undo()
    assert http.get(page, timeout=10).status_code == 200
