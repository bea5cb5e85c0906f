"""The one write of the links app, on the real database (SQLite here, PostgreSQL with
DATABASE_URL): it adds, never overwrites, and the last contact only moves forward."""

from __future__ import annotations

import datetime as dt
import threading

import pytest
from django.db import connection

from links.models import LinkDay, Transport
from links.services import link_count
from links.sql import link_day_add
from vessels.models import Vessel

pytestmark = pytest.mark.django_db

T = dt.datetime(2026, 11, 28, 10, 0, tzinfo=dt.UTC)


def test_the_first_add_creates_the_row_and_the_next_add_to_it(vessel_a: Vessel) -> None:
    day = T.date()
    link_day_add(vessel_id=vessel_a.pk, day=day, transport="sbd",
                 counts={"messages_in": 1, "bytes_in": 240, "credits": 5, "fixes_in": 60},
                 contact_at=T)  # fmt: skip
    link_day_add(vessel_id=vessel_a.pk, day=day, transport="sbd",
                 counts={"messages_out": 1, "bytes_out": 27, "credits": 1})  # fmt: skip
    row = LinkDay.objects.get()
    assert (row.day, row.transport) == (day, "sbd")
    assert (row.messages_in, row.messages_out, row.bytes_in, row.bytes_out) == (1, 1, 240, 27)
    assert (row.credits, row.fixes_in, row.last_contact_at) == (6, 60, T)


def test_the_last_contact_only_moves_forward(vessel_a: Vessel) -> None:
    for at in (T, T + dt.timedelta(minutes=5), T + dt.timedelta(minutes=2)):
        link_count(vessel_id=vessel_a.pk, transport="sms", at=at, contact=True, messages_in=1)
    link_count(
        vessel_id=vessel_a.pk, transport="sms", at=T + dt.timedelta(hours=1), messages_out=1
    )  # fmt: skip  (outbound: not contact)
    row = LinkDay.objects.get()
    assert row.messages_in == 3 and row.messages_out == 1
    assert row.last_contact_at == T + dt.timedelta(minutes=5)


def test_days_and_transports_and_vessels_are_rows_of_their_own(
    vessel_a: Vessel, vessel_b: Vessel
) -> None:
    late = dt.datetime(2026, 11, 28, 23, 59, 59, tzinfo=dt.UTC)
    # 01:00 in UTC+2 is still the 27th in UTC: days are UTC dates.
    early = dt.datetime(2026, 11, 28, 1, 0, tzinfo=dt.timezone(dt.timedelta(hours=2)))
    link_count(vessel_id=vessel_a.pk, transport="http", at=late, messages_in=1)
    link_count(vessel_id=vessel_a.pk, transport="http", at=early, messages_in=1)
    link_count(vessel_id=vessel_a.pk, transport="sbd", at=late, messages_in=1)
    link_count(vessel_id=vessel_b.pk, transport="http", at=late, messages_in=1)
    rows = sorted(LinkDay.objects.values_list("vessel__slug", "day", "transport"))
    assert rows == [
        ("spab", dt.date(2026, 11, 27), "http"),
        ("spab", dt.date(2026, 11, 28), "http"),
        ("spab", dt.date(2026, 11, 28), "sbd"),
        ("spab-2", dt.date(2026, 11, 28), "http"),
    ]


def test_an_unknown_counter_is_refused(vessel_a: Vessel) -> None:
    with pytest.raises(ValueError, match="not a link counter"):
        link_count(vessel_id=vessel_a.pk, transport="sbd", at=T, megabytes=1)


@pytest.mark.django_db(transaction=True)
def test_writers_at_once_lose_nothing(vessel_a: Vessel) -> None:
    """Threads adding to the same row, each on its own connection: the sum is exact (an
    upsert that read-modified-wrote would lose some)."""
    if "memory" in str(connection.settings_dict["TEST"].get("NAME") or ""):
        pytest.skip("an in-memory SQLite database is one connection")
    errors: list[BaseException] = []

    def add() -> None:
        try:
            for _ in range(20):
                link_count(vessel_id=vessel_a.pk, transport=Transport.HTTP, at=T,
                           messages_in=1, bytes_in=100)  # fmt: skip
        except BaseException as exc:  # noqa: BLE001 (reported below)
            errors.append(exc)
        finally:
            connection.close()

    threads = [threading.Thread(target=add) for _ in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert errors == []
    row = LinkDay.objects.get()
    assert (row.messages_in, row.bytes_in) == (80, 8000)
