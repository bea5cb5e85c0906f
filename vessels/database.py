"""Which database errors mean "the database is away for a moment" (a restart, a failover, a
lock held too long), as opposed to a fault that retrying will not fix (a missing table after a
deploy without `migrate`, a bad query). Shared by the API's 503 and ingest's one retry."""

from __future__ import annotations

from django.db import DatabaseError, InterfaceError, OperationalError, connection

# SQLSTATE classes 08 (connection exception) and 57P (operator intervention: admin shutdown,
# crash shutdown, cannot connect now), PostgreSQL Appendix A.
_LOST_STATES = ("08", "57P")
# SQLite's transient refusals: another writer held the lock past busy_timeout.
_SQLITE_TRANSIENT = ("database is locked", "database table is locked")


def database_unavailable(exc: BaseException) -> bool:
    """True when ``exc`` says the database went away or is busy, not that the request is bad."""
    if isinstance(exc, InterfaceError):
        return True
    if not isinstance(exc, OperationalError):
        return False
    state = getattr(exc.__cause__, "sqlstate", None) or ""
    if state.startswith(_LOST_STATES):
        return True
    if connection.vendor == "sqlite":
        return any(text in str(exc) for text in _SQLITE_TRANSIENT)
    # psycopg's own "the connection is closed" / "server closed the connection" carry no
    # SQLSTATE: ask the connection itself.
    return not _usable()


def _usable() -> bool:
    if connection.connection is None:
        return False
    try:
        return connection.is_usable()
    except DatabaseError:
        return False
