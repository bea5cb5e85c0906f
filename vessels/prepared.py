"""A statement PostgreSQL plans once per connection instead of on every request.

The single-fix post (telemetry.services) is one statement of four CTEs; PostgreSQL parsed and
planned it afresh on every post, half of its time in the database (profiled: 0.94 ms of the
server's CPU per post, 0.43 ms prepared; benchmark `python -m bench.server --single-only`).
Django leaves psycopg's automatic preparation off, for the sake of poolers in transaction mode
(pgBouncer before 1.21 loses a prepared statement between transactions); with such a pooler, set
DB_PREPARED_STATEMENTS=0 and the statement runs as it is.

A statement is prepared by name (a hash of its text) on first use on each connection, with its
parameters' types taken from the values; a server that has lost it (a pooler, DISCARD ALL) is
asked to prepare it again, once.
"""

from __future__ import annotations

import datetime as dt
import hashlib
import weakref
from collections.abc import Sequence
from typing import Any

from django.conf import settings
from django.db import ProgrammingError, connection
from psycopg.types.json import Jsonb

# SQLSTATE 26000, invalid_sql_statement_name: "prepared statement … does not exist".
_UNKNOWN_STATEMENT = "26000"
# Names prepared on each live psycopg connection (a new connection starts with none).
_prepared: weakref.WeakKeyDictionary[Any, set[str]] = weakref.WeakKeyDictionary()


def _pg_type(value: Any) -> str:
    if isinstance(value, bool):
        return "boolean"
    if isinstance(value, int):
        return "bigint"
    if isinstance(value, float):
        return "float8"
    if isinstance(value, dt.datetime):
        return "timestamptz"
    if isinstance(value, Jsonb):
        return "jsonb"
    return "text"


def _numbered(sql: str) -> str:
    """``%s`` placeholders as PREPARE's $1, $2, … (the text holds no other ``%``)."""
    parts = sql.split("%s")
    return "".join(f"{part}${i}" for i, part in enumerate(parts[:-1], start=1)) + parts[-1]


def execute_prepared(cursor: Any, sql: str, params: Sequence[Any]) -> None:
    """Run ``sql`` (``%s`` placeholders, no NULL parameters) with ``params`` on ``cursor``:
    prepared once per PostgreSQL connection, or as it is when that is off or unavailable."""
    if connection.vendor != "postgresql" or not settings.DB_PREPARED_STATEMENTS or "%%" in sql:
        cursor.execute(sql, params)
        return
    types = ", ".join(_pg_type(v) for v in params)
    name = "shoreside_" + hashlib.sha256(f"{types}|{sql}".encode()).hexdigest()[:20]
    names = _prepared.setdefault(connection.connection, set())
    execute = f"EXECUTE {name}({', '.join(['%s'] * len(params))})" if params else f"EXECUTE {name}"
    if name not in names:
        cursor.execute(f"PREPARE {name}({types}) AS {_numbered(sql)}")
        names.add(name)
    try:
        cursor.execute(execute, params)
    except ProgrammingError as exc:
        lost = getattr(exc.__cause__, "sqlstate", None) == _UNKNOWN_STATEMENT
        if not lost or connection.in_atomic_block:
            raise
        cursor.execute(f"PREPARE {name}({types}) AS {_numbered(sql)}")
        cursor.execute(execute, params)
