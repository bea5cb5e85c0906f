"""Which database errors mean "the database is away for a moment" (a restart, a failover, a
lock held too long), as opposed to a fault that retrying will not fix (a missing table after a
deploy without `migrate`, a bad query). Shared by the API's 503 and ingest's one retry.

The answer comes from the exception alone. Asking the connection afterwards misleads: when a
transaction (`atomic`) loses its connection, Django drops it and has already opened a new,
healthy one by the time the error reaches a handler.
"""

from __future__ import annotations

import sqlite3

import psycopg
from django.db import InterfaceError, OperationalError, connection

# What a 503 for a database away for a moment asks the client to wait, in seconds.
RETRY_AFTER_S = 5

# SQLSTATE classes 08 (connection exception) and 57P (operator intervention: admin shutdown,
# crash shutdown, cannot connect now), PostgreSQL Appendix A.
_LOST_STATES = ("08", "57P")
# SQLite's transient refusals: another writer held the lock past busy_timeout.
_SQLITE_TRANSIENT = ("database is locked", "database table is locked")
# A lost connection in the words of libpq, psycopg and Django, for an error that carries
# neither a SQLSTATE nor a driver exception to tell by.
_LOST_MESSAGES = (
    "server closed the connection",
    "terminating connection",
    "connection is closed",
    "connection is lost",
    "connection already closed",
    "consuming input failed",
    "sending query failed",
    "could not receive data from server",
    "could not send data to server",
    "connection reset by peer",
    "broken pipe",
    "connection refused",
)


def database_unavailable(exc: BaseException) -> bool:
    """True when ``exc`` says the database went away or is busy, not that the request is bad."""
    if isinstance(exc, InterfaceError | psycopg.InterfaceError):
        return True
    if not isinstance(exc, OperationalError | psycopg.OperationalError):
        return False
    # Django re-raises the driver's error as its own, `from` the original.
    driver = exc if isinstance(exc, psycopg.Error) else exc.__cause__
    if isinstance(driver, sqlite3.Error):
        return any(text in str(exc) for text in _SQLITE_TRANSIENT)
    if isinstance(driver, psycopg.Error):
        if driver.sqlstate:
            return driver.sqlstate.startswith(_LOST_STATES)
        # No SQLSTATE: the server never answered this statement, so libpq speaks about the
        # connection itself ("server closed the connection unexpectedly", "the connection is
        # lost", a failed reconnect), never about the query.
        return True
    message = str(exc).lower()
    return any(text in message for text in (*_LOST_MESSAGES, *_SQLITE_TRANSIENT))


def health_check_spare() -> None:
    """Spare this request the connection's health check, for a caller that retries its
    statement once on a fresh connection when :func:`database_unavailable` says the database
    went away: what the check (CONN_HEALTH_CHECKS) would have done before it.

    On PostgreSQL the check is a `SELECT 1` round trip before a request's first query: half
    of the single-fix post's round trips, whose one statement is its own transaction
    (telemetry.services; benchmark `python -m bench.server --single-only`). A query already
    run in this request has had the check; inside a transaction nothing is retried.
    """
    if connection.connection is not None and not connection.in_atomic_block:
        connection.health_check_done = True
