"""vessels.sql.execute_prepared: the single post, planned once per PostgreSQL connection."""

from __future__ import annotations

import datetime as dt
from typing import Any

import pytest
from django.db import connection
from django.test.utils import CaptureQueriesContext

from vessels.sql import execute_prepared

pytestmark = pytest.mark.django_db(transaction=True)

SQL = "SELECT %s + %s, %s"
NOW = dt.datetime(2026, 11, 23, 10, tzinfo=dt.UTC)


def _run(params: list[Any]) -> tuple[Any, list[str]]:
    with CaptureQueriesContext(connection) as queries, connection.cursor() as cursor:
        execute_prepared(cursor, SQL, params)
        row = cursor.fetchone()
    return row, [q["sql"].split(None, 1)[0].upper() for q in queries]


def test_it_answers_as_the_plain_statement_and_prepares_once_per_connection() -> None:
    first, kinds = _run([1, 2, NOW])
    assert first[0] == 3
    again, kinds_again = _run([2, 3, NOW])
    assert again[0] == 5
    if connection.vendor == "postgresql":
        assert (kinds, kinds_again) == (["PREPARE", "EXECUTE"], ["EXECUTE"])
        assert again[1] == NOW
    else:
        assert kinds == kinds_again == ["SELECT"]


@pytest.mark.skipif("connection.vendor != 'postgresql'")
def test_a_statement_the_server_lost_is_prepared_again() -> None:
    _run([1, 2, NOW])
    with connection.cursor() as cursor:
        cursor.execute("DEALLOCATE ALL")  # what a pooler's reset does
    row, kinds = _run([4, 5, NOW])
    assert row[0] == 9
    assert kinds == ["EXECUTE", "PREPARE", "EXECUTE"]


def test_off_it_runs_the_statement_as_it_is(settings: Any) -> None:
    settings.DB_PREPARED_STATEMENTS = False
    row, kinds = _run([1, 2, NOW])
    assert row[0] == 3
    assert kinds == ["SELECT"]
