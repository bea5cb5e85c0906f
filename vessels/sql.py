"""The vessels app's hand-written SQL, each statement beside the reason for it and the benchmark
that measures it: the boat API's key lookup and the vessel's last-fix update.

Benchmark: bench.server (the boat API: polls and single-fix posts, against a naive DRF view);
the statements of a single post are pinned by tests/telemetry/test_boat_api.py, and each
statement here is tested on every database by tests/vessels/test_sql.py.
"""

from __future__ import annotations

import datetime as dt
import functools
import hashlib
import weakref
from collections.abc import Sequence
from typing import Any

from django.conf import settings
from django.db import ProgrammingError, connection
from psycopg.types.json import Jsonb

from vessels.models import Vessel, VesselKey

# -- The boat API's key lookup (vessels.selectors.vessel_key_by_hash) ---------------------------
#
# Every boat request authenticates, so this is the hottest query of the site: the ORM spent
# ~1 ms compiling `select_related` for it (profiled), several times the query itself. The SQL
# is written once from the models' metadata instead; only these columns load, and the rest of
# each instance is deferred (fetched if ever touched).
_KEY_COLUMNS = ("id", "vessel_id", "revoked_at", "last_used_at")
_VESSEL_COLUMNS = ("id", "slug", "kind", "active", "commands_version")


@functools.cache
def _key_lookup_sql(vendor: str) -> str:
    qn = connection.ops.quote_name
    key, vessel = VesselKey._meta, Vessel._meta
    columns = [f"k.{qn(key.get_field(c).column)}" for c in _KEY_COLUMNS]
    columns += [f"v.{qn(vessel.get_field(c).column)}" for c in _VESSEL_COLUMNS]
    return (
        f"SELECT {', '.join(columns)} FROM {qn(key.db_table)} k "
        f"JOIN {qn(vessel.db_table)} v ON v.{qn(vessel.pk.column)} = k.{qn('vessel_id')} "
        f"WHERE k.{qn(key.get_field('key_hash').column)} = %s"
    )


def _as_datetime(value: Any) -> dt.datetime | None:
    """SQLite returns stored text, PostgreSQL aware datetimes; both become aware UTC."""
    if value is None or isinstance(value, dt.datetime) and value.tzinfo is not None:
        return value
    if isinstance(value, str):
        value = dt.datetime.fromisoformat(value)
    return value.replace(tzinfo=dt.UTC)


def key_by_hash(key_hash: str) -> VesselKey | None:
    """The key with this hash and its vessel (partly loaded, see above), or None."""
    with connection.cursor() as cursor:
        cursor.execute(_key_lookup_sql(connection.vendor), [key_hash])
        row = cursor.fetchone()
    if row is None:
        return None
    key_id, vessel_id, revoked_at, last_used_at, *vessel_row = row
    vessel = Vessel.from_db(connection.alias, list(_VESSEL_COLUMNS), vessel_row)
    vessel.active = bool(vessel.active)
    key = VesselKey.from_db(
        connection.alias,
        list(_KEY_COLUMNS),
        [key_id, vessel_id, _as_datetime(revoked_at), _as_datetime(last_used_at)],
    )
    key.vessel = vessel
    return key


# -- A recent key's check, carried by the writes it makes (vessels.auth.key_lookup_recent) ------
#
# The single-fix post does not look its key up again (the process keeps recent lookups): its
# writes carry this condition instead, so a revoked key stops at once (issue 17 item 8).


@functools.cache
def key_valid_sql(vendor: str) -> str:
    """SQL true while the key with id %s works (not revoked, its vessel active): the condition
    a write made on a recently looked-up key carries, so a revoked key stops at once even
    though its lookup was not repeated."""
    qn = connection.ops.quote_name
    key, vessel = VesselKey._meta, Vessel._meta
    revoked, active = key.get_field("revoked_at").column, vessel.get_field("active").column
    return (
        f"EXISTS (SELECT 1 FROM {qn(key.db_table)} k JOIN {qn(vessel.db_table)} v"
        f" ON v.{qn(vessel.pk.column)} = k.{qn('vessel_id')}"
        f" WHERE k.{qn(key.pk.column)} = %s AND k.{qn(revoked)} IS NULL AND v.{qn(active)})"
    )


def key_works(key_id: int) -> bool:
    """Whether the key still works (see key_valid_sql)."""
    with connection.cursor() as cursor:
        cursor.execute(f"SELECT 1 WHERE {key_valid_sql(connection.vendor)}", [key_id])
        return cursor.fetchone() is not None


# -- The command list's version (commands.api.boat.commands_exchange) ----------------------------
#
# Read beside every telemetry post that carries X-Commands-ETag (the edge client's everyday
# post): through the ORM it added half the post's own CPU time (0.19 ms on 0.36 ms, profiled in
# process on SQLite); written out, 0.02 ms. Benchmark: bench.server --single-only, "+exchange".


@functools.cache
def _commands_version_sql(vendor: str) -> str:
    qn, meta = connection.ops.quote_name, Vessel._meta
    column = meta.get_field("commands_version").column
    return f"SELECT {qn(column)} FROM {qn(meta.db_table)} WHERE {qn(meta.pk.column)} = %s"


def commands_version(vessel_id: int) -> int:
    """The vessel's commands_version as stored now (0 for no such vessel)."""
    with connection.cursor() as cursor:
        cursor.execute(_commands_version_sql(connection.vendor), [vessel_id])
        row = cursor.fetchone()
    return row[0] if row else 0


# -- The vessel's last fix (vessels.services.vessel_record_fix; telemetry's ingest) -------------
#
# One conditional UPDATE, written once: backlogs arrive oldest first and out of order, so
# "newer" is decided in the database, under the row lock, not in Python. The ORM version cost
# more than the fix insert itself on a single-fix post (profiled).


@functools.cache
def _record_fix_sql(vendor: str, also_if: str = "", only_if: str = "") -> str:
    meta, qn = Vessel._meta, connection.ops.quote_name
    seen, fix, fix_at = (
        qn(meta.get_field(n).column) for n in ("last_seen_at", "last_fix", "last_fix_at")
    )
    newer = f"({fix_at} IS NULL OR {fix_at} < %s)"
    if also_if:
        newer = f"({newer} AND {also_if})"
    return (
        f"UPDATE {qn(meta.db_table)} SET {seen} = %s, "
        f"{fix} = CASE WHEN {newer} THEN %s ELSE {fix} END, "
        f"{fix_at} = CASE WHEN {newer} THEN %s ELSE {fix_at} END "
        f"WHERE {qn(meta.pk.column)} = %s" + (f" AND {only_if}" if only_if else "")
    )


def record_fix(
    *, vessel_id: int, seen_at: dt.datetime, fix_at: dt.datetime, summary: dict[str, Any] | None
) -> None:
    """Mark the vessel seen at ``seen_at``; make ``summary`` its last fix if ``fix_at`` is
    newer than the one it has."""
    sql, params = record_fix_statement(
        vessel_id=vessel_id, seen_at=seen_at, fix_at=fix_at, summary=summary
    )
    with connection.cursor() as cursor:
        cursor.execute(sql, params)


def record_fix_statement(
    *,
    vessel_id: int,
    seen_at: dt.datetime,
    fix_at: dt.datetime,
    summary: dict[str, Any] | None,
    also_if: str = "",
    only_if: tuple[str, Sequence[Any]] = ("", ()),
) -> tuple[str, list[Any]]:
    """:func:`record_fix` as (sql, params), for a caller that runs it as part of one
    statement of its own (ingest on PostgreSQL: fixes and vessel in one round trip).
    ``also_if``, a parameterless SQL condition, must hold too for the fix to be taken;
    ``only_if`` (SQL and its parameters), for the row to be written at all."""
    # The backend's adapters, straight (both fields are plain: no encoder, aware UTC times):
    # the field layer around them cost a tenth of a single-fix post (profiled, bench.server).
    ops = connection.ops
    at = ops.adapt_datetimefield_value(fix_at)
    summary_value = ops.adapt_json_value(summary, None)
    params = [ops.adapt_datetimefield_value(seen_at), at, summary_value, at, at, vessel_id]
    return _record_fix_sql(connection.vendor, also_if, only_if[0]), [*params, *only_if[1]]


# -- Prepared statements (telemetry.sql's single-fix post) -------------------------------------
#
# A statement PostgreSQL plans once per connection instead of on every request.
#
# The single-fix post (telemetry.services) is one statement of four CTEs; PostgreSQL parsed and
# planned it afresh on every post, half of its time in the database (profiled: 0.94 ms of the
# server's CPU per post, 0.43 ms prepared; benchmark `python -m bench.server --single-only`).
# Django leaves psycopg's automatic preparation off, for the sake of poolers in transaction mode
# (pgBouncer before 1.21 loses a prepared statement between transactions); with such a pooler, set
# DB_PREPARED_STATEMENTS=0 and the statement runs as it is.
#
# A statement is prepared by name (a hash of its text) on first use on each connection, with its
# parameters' types taken from the values; a server that has lost it (a pooler, DISCARD ALL) is
# asked to prepare it again, once.

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
