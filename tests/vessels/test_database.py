"""Which database errors are "away for a moment", told from the exception alone."""

from __future__ import annotations

import sqlite3

import psycopg
import psycopg.errors
import pytest
from django.db import InterfaceError, OperationalError, ProgrammingError

from vessels.database import database_unavailable


def wrapped(django_type: type[Exception], driver: Exception) -> Exception:
    """What Django's error wrapper raises: its own type, `from` the driver's error."""
    try:
        raise django_type(*driver.args) from driver
    except django_type as exc:
        return exc


@pytest.mark.parametrize(
    "exc",
    [
        wrapped(OperationalError, psycopg.errors.AdminShutdown("terminating connection")),
        wrapped(OperationalError, psycopg.errors.ConnectionFailure("connection failure")),
        # libpq's own words: no SQLSTATE, the server never answered.
        wrapped(OperationalError, psycopg.OperationalError("consuming input failed: server")),
        wrapped(OperationalError, psycopg.OperationalError("the connection is lost")),
        wrapped(InterfaceError, psycopg.InterfaceError("the connection is closed")),
        psycopg.OperationalError("server closed the connection unexpectedly"),
        InterfaceError("connection already closed"),
        wrapped(OperationalError, sqlite3.OperationalError("database is locked")),
    ],
    ids=repr,
)
def test_the_database_going_away_is_unavailable(exc: Exception) -> None:
    assert database_unavailable(exc)


@pytest.mark.parametrize(
    "exc",
    [
        wrapped(ProgrammingError, psycopg.errors.UndefinedTable('relation "x" does not exist')),
        wrapped(OperationalError, psycopg.errors.DiskFull("could not extend file")),
        wrapped(OperationalError, psycopg.errors.QueryCanceled("statement timeout")),
        wrapped(OperationalError, sqlite3.OperationalError("no such table: x")),
        OperationalError("something else"),
        ValueError("database is locked"),
    ],
    ids=repr,
)
def test_a_fault_a_retry_cannot_fix_is_not_unavailable(exc: Exception) -> None:
    assert not database_unavailable(exc)
