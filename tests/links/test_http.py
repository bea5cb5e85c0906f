"""The boat API's HTTP traffic on the vessel's link counts, through the real API (Django's
test client in the same process: the middleware and views as deployed), and the tally that
keeps it from costing a write per request."""

from __future__ import annotations

import datetime as dt
import logging
import threading
from typing import Any

import pytest
from django.db import connection
from rest_framework.test import APIClient

from links import http
from links.http import TALLY, Tally, request_bytes, response_bytes
from links.models import LinkDay
from tests.support import LISTING_1, post_data
from vessels.models import Vessel

pytestmark = pytest.mark.django_db

TELEMETRY = "/api/v1/boat/telemetry/"
COMMANDS = "/api/v1/boat/commands/"


@pytest.fixture
def every_response(settings: Any) -> None:
    settings.LINK_FLUSH_S = 0


def http_row(vessel: Vessel) -> LinkDay:
    return LinkDay.objects.get(vessel=vessel, transport="http")


class Sizes:
    """What the middleware measured, request by request (its own functions, wrapped)."""

    def __init__(self, monkeypatch: pytest.MonkeyPatch) -> None:
        self.sent: list[int] = []
        self.answered: list[int] = []
        self.bodies: list[int] = []

        def req(request: Any) -> int:
            self.sent.append(request_bytes(request))
            return self.sent[-1]

        def resp(response: Any) -> int:
            self.answered.append(response_bytes(response))
            self.bodies.append(len(response.content))
            return self.answered[-1]

        monkeypatch.setattr(http, "request_bytes", req)
        monkeypatch.setattr(http, "response_bytes", resp)


def test_each_boat_request_is_counted_with_its_bytes_and_fixes(
    every_response: None,
    boat_a: APIClient,
    vessel_a: Vessel,
    make_fix: Any,
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    sizes = Sizes(monkeypatch)
    # The everyday post (the short way), a batch (DRF's whole way), a poll, a legacy post.
    fast = boat_a.post(TELEMETRY, [make_fix()], format="json")
    assert fast.json()["accepted"] == 1
    batch = [make_fix(time=f"2026-11-23T10:0{i}:30Z") for i in range(3)] + [make_fix()]
    slow = boat_a.post(TELEMETRY, {"fixes": batch}, format="json", HTTP_X_TRACE="1")
    assert slow.json() == {"accepted": 3, "duplicates": 1, "rejected": []}
    assert boat_a.get(COMMANDS).status_code == 200
    assert post_data(boat_a, LISTING_1).status_code == 200  # /spab/data.cgi: 2 fixes
    row = http_row(vessel_a)
    assert (row.messages_in, row.messages_out, row.fixes_in) == (4, 4, 1 + 3 + 2)
    assert row.bytes_in == sum(sizes.sent) and row.bytes_out == sum(sizes.answered)
    assert row.last_contact_at is not None and row.credits == 0
    # What was measured is what crossed: each body and its headers at least.
    assert all(a > b for a, b in zip(sizes.answered, sizes.bodies, strict=True))
    assert sizes.sent[1] > len(slow.request["PATH_INFO"]) + int(slow.request["CONTENT_LENGTH"])


def test_a_request_is_measured_as_received_and_answered(
    every_response: None, boat_a: APIClient, vessel_a: Vessel, make_fix: Any
) -> None:
    body = b'[{"time": "2026-11-23T10:00:00Z", "lat": -31.95, "lon": 115.86}]'
    response = boat_a.generic("POST", TELEMETRY, body, content_type="application/json")
    assert response.json()["accepted"] == 1
    row = http_row(vessel_a)
    # POST, the path, the version; Authorization, Content-Type, Content-Length; the body.
    assert row.bytes_in >= len(body) + len("Authorization: Api-Key ") + 40
    headers = sum(len(k) + len(v) + 4 for k, v in response.items())
    assert row.bytes_out == len("HTTP/1.1 200 OK\r\n") + headers + 2 + len(response.content)


def test_nothing_is_written_before_the_flush_is_due(
    settings: Any, boat_a: APIClient, vessel_a: Vessel, make_fix: Any
) -> None:
    settings.LINK_FLUSH_S = 3600
    boat_a.post(TELEMETRY, [make_fix()], format="json")
    boat_a.get(COMMANDS)
    assert not LinkDay.objects.exists()  # in the worker's memory only
    assert TALLY.flush() == 1  # what a flush at exit does
    assert http_row(vessel_a).messages_in == 2
    assert TALLY.flush() == 0


def test_refused_and_other_requests_are_not_a_vessels_traffic(
    every_response: None, revoked_boat: APIClient, anonymous: APIClient, vessel_a: Vessel
) -> None:
    assert revoked_boat.get(COMMANDS).status_code == 401
    assert anonymous.get(COMMANDS).status_code == 401
    assert not LinkDay.objects.exists()


def test_the_tally_flushes_at_most_every_period() -> None:
    now = [100.0]
    tally = Tally(clock=lambda: now[0])
    at = dt.datetime(2026, 11, 28, 10, tzinfo=dt.UTC)
    tally.add(1, at, 10, 20, 1)
    assert not tally.due(10)
    now[0] += 10
    assert tally.due(10)
    assert tally.take() == {(1, at.date()): [1, 10, 20, 1, at]}
    assert not tally.due(10)  # nothing left to write


def test_threads_adding_at_once_lose_nothing() -> None:
    tally = Tally()
    at = dt.datetime(2026, 11, 28, 10, tzinfo=dt.UTC)

    def add() -> None:
        for _ in range(5000):
            tally.add(7, at, 3, 5, 1)

    threads = [threading.Thread(target=add) for _ in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert tally.take() == {(7, at.date()): [20000, 60000, 100000, 20000, at]}


def test_counts_of_a_deleted_vessel_are_dropped(vessel_a: Vessel, vessel_b: Vessel) -> None:
    tally = Tally()
    at = dt.datetime(2026, 11, 28, 10, tzinfo=dt.UTC)
    tally.add(vessel_a.pk, at, 1, 1, 0)
    tally.add(vessel_b.pk, at, 1, 1, 0)
    gone = vessel_b.pk
    vessel_b.delete()
    assert tally.flush() == 2
    assert list(LinkDay.objects.values_list("vessel_id", flat=True)) == [vessel_a.pk]
    assert gone not in LinkDay.objects.values_list("vessel_id", flat=True)


def test_a_database_that_fails_loses_the_batch_never_the_request(
    vessel_a: Vessel, caplog: pytest.LogCaptureFixture
) -> None:
    tally = Tally()
    tally.add(vessel_a.pk, dt.datetime(2026, 11, 28, 10, tzinfo=dt.UTC), 1, 1, 0)
    with connection.cursor() as cursor:
        cursor.execute("DROP TABLE links_linkday")  # rolled back with the test's transaction
    with caplog.at_level(logging.ERROR, logger="links.http"):
        assert tally.flush() == 0
    assert "HTTP counts of 1 vessel-days lost" in caplog.text
