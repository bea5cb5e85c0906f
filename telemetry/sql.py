"""The telemetry app's hand-written SQL, each statement beside the benchmark that justifies
it: the track overview's reads, the fix exports, the fix ingest and the overview's writes.
Each is tested on every database by tests/telemetry/test_sql.py.
"""

from __future__ import annotations

import datetime as dt
import functools
import json
from collections.abc import Iterator, Sequence
from typing import Any

from django.db import connection

from edge_client.contract import fix as fix_shape
from telemetry.models import Fix, TrackBucket, TrackDirty
from telemetry.overview import WIDTHS, RawFix, Summary, bucket_start
from telemetry.parsing import FixData
from vessels import sql as vessels_sql
from vessels.sql import execute_prepared

# -- Shared by every statement: times and JSON as the database writes them ----------------------


def from_epoch(t: float) -> dt.datetime:
    return dt.datetime.fromtimestamp(t, dt.UTC)


def db_time(t: float) -> Any:
    """A Unix time as the backend's parameter for a DateTimeField (naive UTC text on SQLite)."""
    return connection.ops.adapt_datetimefield_value(from_epoch(t))


def epoch_sql(column: str) -> str:
    """SQL for a DateTimeField column as Unix seconds (float), computed by the database.

    Cheaper than the driver's datetime conversion per row (profiled), and it leaves the
    column's declared type behind, so SQLite's timestamp converter never runs. SQLite stores
    naive UTC text "YYYY-MM-DD HH:MM:SS[.ffffff]": whole seconds from strftime('%s'), the
    fraction from the text.
    """
    if connection.vendor == "postgresql":
        return f"EXTRACT(EPOCH FROM {column})::float8"
    # '%%s': the query goes through the driver's parameter substitution.
    whole = f"CAST(strftime('%%s', {column}) AS INTEGER)"
    return f"({whole} + CAST('0' || substr({column}, 20) AS REAL))"


def iso_sql(column: str) -> str:
    """SQL for a DateTimeField column as ISO 8601 UTC text with a Z (fraction only if any)."""
    if connection.vendor == "postgresql":
        text = f"to_char({column} AT TIME ZONE 'UTC', 'YYYY-MM-DD\"T\"HH24:MI:SS.US')"
        return f"(regexp_replace({text}, '\\.000000$', '') || 'Z')"
    return f"(replace({column}, ' ', 'T') || 'Z')"


def as_json(value: Any) -> Any:
    """A JSON column from a raw cursor: text on SQLite (and psycopg's text loader), or parsed."""
    return json.loads(value) if isinstance(value, str | bytes) else value


def as_json_many(values: list[Any]) -> list[Any]:
    """Many JSON columns at once: one json.loads over all the texts, not one call each (a
    month of overview rows spent most of its time in per-call overhead, profiled)."""
    if values and all(isinstance(v, str) for v in values):
        return json.loads("[" + ",".join(values) + "]")
    return [as_json(v) for v in values]


@functools.cache
def column_names(model: Any) -> dict[str, str]:
    """Quoted column names of a model's fields, and its quoted table name under `table`."""
    qn = connection.ops.quote_name
    meta = model._meta
    names = {f.name: qn(f.column) for f in meta.concrete_fields}
    names["table"] = qn(meta.db_table)
    return names


# -- The track overview's reads (telemetry.track; the rebuild in telemetry.services) ------------
#
# Benchmark: bench.maps. Raw cursors: a day of track is ~1,500 bucket rows and a month of plots
# ~700, and the ORM's per-row model work cost more than the query (profiled).


def _query(sql: str, params: list[Any]) -> list[tuple[Any, ...]]:
    with connection.cursor() as cursor:
        cursor.execute(sql, params)
        return cursor.fetchall()


def raw_fixes(vessel_id: int, lo: float, hi: float) -> list[RawFix]:
    """(t, lat, lon, battery_v, readings) of the vessel's fixes in [lo, hi), by time."""
    f = column_names(Fix)
    sql = (
        f"SELECT {epoch_sql(f['recorded_at'])}, {f['lat']}, {f['lon']}, {f['battery_v']},"
        f" {f['readings']} FROM {f['table']} WHERE {f['vessel']} = %s"
        f" AND {f['recorded_at']} >= %s AND {f['recorded_at']} < %s ORDER BY {f['recorded_at']}"
    )
    rows = _query(sql, [vessel_id, db_time(lo), db_time(hi)])
    readings = as_json_many([row[4] for row in rows])
    return [(t, lat, lon, b, r) for (t, lat, lon, b, _), r in zip(rows, readings, strict=True)]


def raw_points(vessel_id: int, lo: float, hi: float) -> list[tuple[float, float, float]]:
    """(t, lat, lon) of the vessel's fixes in [lo, hi), by time."""
    f = column_names(Fix)
    sql = (
        f"SELECT {epoch_sql(f['recorded_at'])}, {f['lat']}, {f['lon']} FROM {f['table']}"
        f" WHERE {f['vessel']} = %s AND {f['recorded_at']} >= %s AND {f['recorded_at']} < %s"
        f" ORDER BY {f['recorded_at']}"
    )
    return _query(sql, [vessel_id, db_time(lo), db_time(hi)])  # type: ignore[return-value]


def _point(value: list[float] | None) -> tuple[float, float, float] | None:
    return (value[0], value[1], value[2]) if value else None


NO_POINTS = [None] * 8


def summary_from_row(start: int, count: int, points: Any, channels: Any) -> Summary:
    first, last, north, south, east, west, gap_from, gap_to = map(_point, points or NO_POINTS)
    gap = (gap_from, gap_to) if gap_from and gap_to else None
    return Summary(start, count, first, last, north, south, east, west, gap, channels or {})  # type: ignore[arg-type]


def buckets(
    vessel_id: int, width: int, lo: float, hi: float, *, points: bool = True, channels: bool = True
) -> list[Summary]:
    """The overview buckets of ``width`` starting in [lo, hi), by time. The track needs only
    the points, the plots only the channels: the other column is left unread."""
    b = column_names(TrackBucket)
    sql = (
        f"SELECT {b['start']}, {b['count']}, {b['points'] if points else 'NULL'},"
        f" {b['channels'] if channels else 'NULL'} FROM {b['table']}"
        f" WHERE {b['vessel']} = %s AND {b['width']} = %s"
        f" AND {b['start']} >= %s AND {b['start']} < %s ORDER BY {b['start']}"
    )
    rows = _query(sql, [vessel_id, width, lo, hi])
    point_sets = as_json_many([r[2] for r in rows]) if points else [None] * len(rows)
    channel_sets = as_json_many([r[3] for r in rows]) if channels else [None] * len(rows)
    return [
        summary_from_row(r[0], r[1], p, c)
        for r, p, c in zip(rows, point_sets, channel_sets, strict=True)
    ]


def dirty_minutes(vessel_id: int, lo: float, hi: float) -> list[int]:
    """Starts of the vessel's minutes touching [lo, hi) whose buckets are not rebuilt yet
    (TrackDirty), sorted: a read takes their fixes instead of their stale buckets."""
    d = column_names(TrackDirty)
    sql = (
        f"SELECT {d['start']} FROM {d['table']} WHERE {d['vessel']} = %s"
        f" AND {d['start']} > %s AND {d['start']} < %s ORDER BY {d['start']}"
    )
    return [row[0] for row in _query(sql, [vessel_id, lo - WIDTHS[0], hi])]


# Rows read from the cursor at a time: memory stays flat whatever the range.
EXPORT_CHUNK = 5000
# The fix's numbers in every export, in column order (between `time` and `readings`): the
# contract's wire shape (edge_client.contract.fix).
EXPORT_NUMBERS = fix_shape.NUMBERS
# A GeoJSON feature's properties after its time: every value but the point's own.
FEATURE_PROPERTIES = tuple(n for n in fix_shape.FIELDS if n not in ("time", "lat", "lon"))
QUOTE = '"'
# An export row: (time as ISO text, Unix seconds, lat, lon, heading, speed, battery, readings
# as JSON text).
Row = tuple[str, float, float, float, float | None, float | None, float | None, str]


# -- Fix exports (telemetry.api.export) ---------------------------------------------------------
#
# Benchmark: bench.maps (the export, through gunicorn, beside its same-bytes ceiling: a bare
# COPY on PostgreSQL, the sqlite3 CLI on SQLite). Rows come from the database cursor in chunks
# (a server-side cursor on PostgreSQL) and, for CSV and GeoJSON, the database writes each
# fix's whole line (string concatenation in SQL, numbers by CAST AS TEXT): formatting three
# floats a row in Python was most of the export's time (profiled). Numbers come out as the
# database writes them: the shortest exact form on PostgreSQL, 15 significant digits on SQLite
# (its text form of a REAL; 1e-13 degrees, some ten nanometres).


def fixes_sql(
    vessel_id: int, start: dt.datetime | None, end: dt.datetime | None, select: str
) -> tuple[str, list[Any]]:
    """SQL and parameters selecting ``select`` for each of the vessel's fixes in [start, end)
    in time order; a missing bound leaves that side open. Shared by every export and by
    bench.maps' same-bytes ceiling."""
    qn = connection.ops.quote_name
    t = qn("recorded_at")
    where, params = [f"{qn('vessel_id')} = %s"], [vessel_id]
    if start is not None:
        where.append(f"{t} >= %s")
        params.append(db_time(start.timestamp()))
    if end is not None:
        where.append(f"{t} < %s")
        params.append(db_time(end.timestamp()))
    table = qn(Fix._meta.db_table)
    return f"SELECT {select} FROM {table} WHERE {' AND '.join(where)} ORDER BY {t}", params


def _chunks(sql: str, params: list[Any]) -> Iterator[list[tuple[Any, ...]]]:
    # chunked_cursor: a named (server-side) cursor on PostgreSQL, so rows arrive as read.
    with connection.chunked_cursor() as cursor:
        cursor.execute(sql, params)
        while rows := cursor.fetchmany(EXPORT_CHUNK):
            yield rows


def export_rows(vessel_id: int, start: dt.datetime, end: dt.datetime) -> Iterator[list[Row]]:
    """The fixes of [start, end) in chunks of rows (time as ISO text, Unix seconds, the
    EXPORT_NUMBERS, readings as JSON text): for the writers that format in Python (GPX)."""
    qn = connection.ops.quote_name
    t = qn("recorded_at")
    columns = [
        iso_sql(t),
        epoch_sql(t),
        *(qn(c) for c in EXPORT_NUMBERS),
        f"CAST({qn('readings')} AS TEXT)",
    ]
    yield from _chunks(*fixes_sql(vessel_id, start, end, ", ".join(columns)))


def export_lines(
    vessel_id: int, start: dt.datetime | None, end: dt.datetime | None, line: str
) -> Iterator[list[str]]:
    """Each fix of [start, end), in chunks, as the text the SQL expression ``line`` (one of
    csv_line_sql, feature_line_sql) makes of it."""
    for rows in _chunks(*fixes_sql(vessel_id, start, end, line)):
        yield [row[0] for row in rows]


def _text(column: str, empty: str) -> str:
    qn = connection.ops.quote_name
    return f"coalesce(CAST({qn(column)} AS TEXT), {_literal(empty)})"


def _literal(text: str) -> str:
    """A constant SQL string (our own text, never input)."""
    return "'" + text.replace("'", "''") + "'"


def _concat(*parts: str) -> str:
    return " || ".join(parts)


def _time() -> str:
    return iso_sql(connection.ops.quote_name("recorded_at"))


def csv_line_sql() -> str:
    """SQL for one fix's CSV line, without its line end: time, the EXPORT_NUMBERS, readings."""
    # The readings cell is quoted JSON ('"' doubled): it starts with '{', never a formula
    # sign (a spreadsheet runs a cell starting with = + - @ as a formula; names come from
    # the boat).
    readings = f"replace({_text('readings', '{}')}, {_literal(QUOTE)}, {_literal(QUOTE * 2)})"
    cells = [
        _time(),
        *(_text(c, "") for c in EXPORT_NUMBERS),
        _concat(_literal(QUOTE), readings, _literal(QUOTE)),
    ]
    return _concat(*[part for cell in cells for part in (cell, _literal(","))][:-1])


def feature_line_sql() -> str:
    """SQL for one fix as a GeoJSON Point Feature, every value in its properties."""
    return _concat(
        _literal('{"type":"Feature","geometry":{"type":"Point","coordinates":['),
        _text("lon", "null"),
        _literal(","),
        _text("lat", "null"),
        _literal(']},"properties":{"time":"'),
        _time(),
        *(
            part
            for i, name in enumerate(FEATURE_PROPERTIES)
            for part in (
                _literal(f'{"" if i else QUOTE},"{name}":'),  # the first closes the time
                _text(name, "{}" if name == "readings" else "null"),
            )
        ),
        _literal("}}"),
    )


# -- Fix ingest (telemetry.services.fix_ingest) -------------------------------------------------
#
# Benchmark: bench.server (single-fix posts against a naive DRF view, and batches); a single
# post's statements are pinned by tests/telemetry/test_boat_api.py. INSERT … ON CONFLICT DO
# NOTHING RETURNING tells exactly which fixes were new, even when two requests race with the
# same fixes: the ORM's bulk_create cannot say which rows it skipped.

# Rows per INSERT: 9 parameters each stays far below SQLite's 32,766-variable limit.
INSERT_CHUNK = 1000
FIX_COLUMNS = ("vessel_id", "recorded_at", "received_at", "lat", "lon", "heading_deg",
               "speed_mps", "battery_v", "readings")  # fmt: skip


def insert_new(vessel_id: int, fixes: list[FixData], now: dt.datetime) -> list[dt.datetime]:
    """Insert ``fixes``; return the recorded_at of those that were new.

    SQLite gets multi-row VALUES; PostgreSQL gets the whole chunk as one JSON document unpacked
    by jsonb_to_recordset() (psycopg re-parsed a 4,500-placeholder statement on every batch:
    profiled at half the request).
    """
    insert = _insert_postgres if connection.vendor == "postgresql" else _insert_sqlite
    inserted: list[dt.datetime] = []
    for start in range(0, len(fixes), INSERT_CHUNK):
        chunk = fixes[start : start + INSERT_CHUNK]
        by_time = {_key(f.recorded_at): f.recorded_at for f in chunk}
        # PostgreSQL returns aware datetimes, SQLite's driver naive ones: compare as naive UTC.
        inserted += [by_time[_key(value)] for value in insert(vessel_id, now, chunk)]
    return inserted


@functools.cache
def _insert_head() -> str:
    qn = connection.ops.quote_name
    return f"INSERT INTO {qn(Fix._meta.db_table)} ({', '.join(qn(c) for c in FIX_COLUMNS)}) "


@functools.cache
def _insert_tail() -> str:
    qn = connection.ops.quote_name
    return (
        f" ON CONFLICT ({qn('vessel_id')}, {qn('recorded_at')}) DO NOTHING"
        f" RETURNING {qn('recorded_at')}"
    )


def _insert_sqlite(vessel_id: int, now: dt.datetime, fixes: list[FixData]) -> list[Any]:
    return _returning(insert_sqlite_statement(vessel_id, now, fixes))


def insert_sqlite_statement(
    vessel_id: int, now: dt.datetime, fixes: list[FixData], key_id: int | None = None
) -> tuple[str, list[Any]]:
    """The SQLite insert of ``fixes`` as (sql, params); with ``key_id``, it carries the key's
    check (vessels.sql.key_valid_sql) and inserts nothing if the key no longer works."""
    # The backend's own adapters, straight: the field layer around them cost more per fix
    # than the insert (profiled). Values are already validated aware-UTC datetimes and dicts.
    adapt_time, adapt_json = (
        connection.ops.adapt_datetimefield_value,
        connection.ops.adapt_json_value,
    )
    received = adapt_time(now)
    params = [
        value
        for f in fixes
        for value in (vessel_id, adapt_time(f.recorded_at), received, f.lat, f.lon,
                      f.heading_deg, f.speed_mps, f.battery_v, adapt_json(f.readings, None))
    ]  # fmt: skip
    values = _sqlite_values(len(fixes))
    if key_id is None:
        return _insert_head() + values + _insert_tail(), params
    # SQLite reads ON CONFLICT after INSERT … SELECT only when the SELECT has a WHERE: it has.
    checked = f"SELECT * FROM ({values}) WHERE {vessels_sql.key_valid_sql(connection.vendor)}"
    return _insert_head() + checked + _insert_tail(), [*params, key_id]


@functools.lru_cache(maxsize=16)
def _sqlite_values(rows: int) -> str:
    row = "(" + ", ".join(["%s"] * len(FIX_COLUMNS)) + ")"
    return f"VALUES {', '.join([row] * rows)}"


_PG_RECORD = "t timestamptz, lat float8, lon float8, h float8, s float8, b float8, r jsonb"


def _insert_postgres(vessel_id: int, now: dt.datetime, fixes: list[FixData]) -> list[Any]:
    return _returning(_insert_postgres_statement(vessel_id, now, fixes))


def _returning(statement: tuple[str, list[Any]]) -> list[Any]:
    with connection.cursor() as cursor:
        cursor.execute(*statement)
        return [r[0] for r in cursor.fetchall()]


def _insert_postgres_statement(
    vessel_id: int, now: dt.datetime, fixes: list[FixData], where: str = ""
) -> tuple[str, list[Any]]:
    document = json.dumps([
        {"t": f.recorded_at.isoformat(), "lat": f.lat, "lon": f.lon, "h": f.heading_deg,
         "s": f.speed_mps, "b": f.battery_v, "r": f.readings}
        for f in fixes
    ])  # fmt: skip
    sql = (
        _insert_head()
        + "SELECT %s, u.t, %s, u.lat, u.lon, u.h, u.s, u.b, u.r "
        + f"FROM jsonb_to_recordset(%s::jsonb) AS u({_PG_RECORD})"
        + (f" WHERE {where}" if where else "")
        + _insert_tail()
    )
    return sql, [vessel_id, now, document]


def insert_with_vessel(
    vessel_id: int,
    fixes: list[FixData],
    now: dt.datetime,
    *,
    newest: FixData,
    summary: dict[str, Any],
    key_id: int | None = None,
) -> list[dt.datetime] | None:
    """Insert the fixes and advance the vessel in ONE statement, outside any transaction
    (PostgreSQL): the recorded_at of the new ones, or None if the key ``key_id`` no longer
    works (nothing written). ``newest`` is the batch's newest fix, ``summary`` its last_fix.

    One statement is its own transaction: one round trip where BEGIN, INSERT, UPDATE and
    COMMIT cost four. The vessel takes ``newest`` only if it was new (the `newest` CTE reads
    the insert's RETURNING rows); the `dirty` CTE marks the overview's minutes; the `key` CTE
    checks the key once and every write waits on it (a NULL row: it no longer works).
    Prepared once per connection: planning was half its time in the database (bench.server).
    """
    key_cte, works = "", ""
    key_params: list[Any] = []
    if key_id is not None:
        key_cte = f"key AS (SELECT {vessels_sql.key_valid_sql(connection.vendor)} AS works), "
        key_params, works = [key_id], "(SELECT works FROM key)"
    insert_sql, insert_params = _insert_postgres_statement(vessel_id, now, fixes, works)
    update_sql, update_params = vessels_sql.record_fix_statement(
        vessel_id=vessel_id,
        seen_at=now,
        fix_at=newest.recorded_at,
        summary=summary,
        also_if="EXISTS (SELECT 1 FROM newest)",
        only_if=(works, ()),
    )
    sql = (
        f"WITH {key_cte}inserted AS ({insert_sql}), "
        "newest AS (SELECT 1 FROM inserted WHERE recorded_at = %s), "
        f"vessel AS ({update_sql}), "
        f"{mark_dirty_cte()} "
        "SELECT recorded_at FROM inserted"
        + (" UNION ALL SELECT NULL FROM key WHERE NOT works" if key_id is not None else "")
    )
    params = [*key_params, *insert_params, newest.recorded_at, *update_params, vessel_id]
    by_time = {_key(f.recorded_at): f.recorded_at for f in fixes}
    with connection.cursor() as cursor:
        execute_prepared(cursor, sql, params)
        rows = cursor.fetchall()
    if any(row[0] is None for row in rows):
        return None
    return [by_time[_key(row[0])] for row in rows]


def insert_sqlite_in_one_transaction(
    vessel_id: int,
    fixes: list[FixData],
    now: dt.datetime,
    *,
    newest: FixData,
    summary: dict[str, Any],
    key_id: int | None = None,
) -> tuple[list[FixData], bool]:
    """Insert the fixes, mark their minutes and advance the vessel (SQLite), in the caller's
    transaction: the new fixes, and whether marks and vessel were written (not when some were
    duplicates or the key ``key_id`` no longer works: the caller finishes). Every statement is
    built first: BEGIN IMMEDIATE takes SQLite's one write lock, which the other workers' posts
    wait for, so it is held for three library calls, not for the Python that builds them."""
    insert = insert_sqlite_statement(vessel_id, now, fixes, key_id)
    mark = mark_dirty_statement(vessel_id, [f.recorded_at for f in fixes])
    record = vessels_sql.record_fix_statement(
        vessel_id=vessel_id, seen_at=now, fix_at=newest.recorded_at, summary=summary
    )
    by_time = {_key(f.recorded_at): f for f in fixes}
    with connection.cursor() as cursor:
        cursor.execute(*insert)
        new = [by_time[_key(row[0])] for row in cursor.fetchall()]
        if len(new) != len(fixes):
            return new, False
        if mark:
            cursor.execute(*mark)
        cursor.execute(*record)
    return new, True


def _key(value: Any) -> dt.datetime:
    """Naive UTC, from stored text, a naive UTC datetime or an aware one."""
    if isinstance(value, dt.datetime):
        if value.tzinfo is None:
            return value
        return value.astimezone(dt.UTC).replace(tzinfo=None)
    text = str(value)
    return dt.datetime.fromisoformat(text).replace(tzinfo=None)


# -- The track overview's writes (telemetry.services: ingest marks, the rebuild replaces) -------
#
# Benchmark: bench.maps (ingest with and without the marks, the refresh, the rebuild). Marks
# go in with the fixes (ON CONFLICT, which the ORM's bulk_create cannot make lock an existing
# row, see below); the rebuild claims them with DELETE … RETURNING (the ORM's delete() returns
# a count) and replaces a range's buckets with a plain DELETE and executemany: a month of
# minutes is ~45,000 rows, and building a model instance per row cost more than the insert.

# PostgreSQL: an existing mark is updated to itself rather than left alone: the update locks the
# row until the ingest commits, so a refresh that claims (deletes) the mark meanwhile waits, and
# then reads the new fixes. DO NOTHING takes no lock: a refresh could claim the mark and rebuild
# before the ingest committed, leaving its fixes out of the overview for good.
_KEEP_MARK_LOCKED = 'DO UPDATE SET "start" = EXCLUDED."start"'
# SQLite: DO NOTHING, and the row is not written again. Its writers take the database's one write
# lock at BEGIN (IMMEDIATE) and keep it to COMMIT, so a refresh cannot claim the mark between
# this ingest's check and its commit: it runs wholly before (the mark is then new) or after
# (and reads the new fixes).
_MARK_CONFLICT = {"postgresql": _KEEP_MARK_LOCKED, "sqlite": "DO NOTHING"}


def _minutes_of(times: Sequence[dt.datetime]) -> list[int]:
    return sorted({bucket_start(t.timestamp(), WIDTHS[0]) for t in times})


def mark_dirty(vessel_id: int, times: Sequence[dt.datetime]) -> None:
    """Mark the minutes of newly stored fixes out of date (same transaction as the fixes)."""
    statement = mark_dirty_statement(vessel_id, times)
    if statement is None:
        return
    with connection.cursor() as cursor:
        cursor.execute(*statement)


def mark_dirty_statement(
    vessel_id: int, times: Sequence[dt.datetime]
) -> tuple[str, list[Any]] | None:
    """:func:`mark_dirty` as (sql, params); None when there is nothing to mark."""
    minutes = _minutes_of(times)
    if not minutes:
        return None
    qn = connection.ops.quote_name
    table = qn(TrackDirty._meta.db_table)
    rows = ", ".join(["(%s, %s)"] * len(minutes))
    conflict = _MARK_CONFLICT.get(connection.vendor, _KEEP_MARK_LOCKED)
    sql = (
        f"INSERT INTO {table} ({qn('vessel_id')}, {qn('start')}) VALUES {rows}"
        f" ON CONFLICT ({qn('vessel_id')}, {qn('start')}) {conflict}"
    )
    return sql, [value for m in minutes for value in (vessel_id, m)]


def mark_dirty_cte() -> str:
    """The same marks as mark_dirty, as a CTE over the `inserted` rows (PostgreSQL)."""
    qn = connection.ops.quote_name
    table = qn(TrackDirty._meta.db_table)
    minute = WIDTHS[0]
    return (
        f"dirty AS (INSERT INTO {table} ({qn('vessel_id')}, {qn('start')})"
        f" SELECT DISTINCT %s, (floor(extract(epoch FROM recorded_at) / {minute}) * {minute})"
        "::bigint FROM inserted"
        f" ON CONFLICT ({qn('vessel_id')}, {qn('start')}) {_KEEP_MARK_LOCKED})"
    )


def dirty_claim(vessel_id: int, max_span_s: int | None = None) -> list[int]:
    """Delete the vessel's dirty marks and return their minute starts, sorted; with
    ``max_span_s``, only the marks within that many seconds of the oldest one. Run it in the
    transaction that rebuilds them."""
    qn = connection.ops.quote_name
    table, vessel, start = qn(TrackDirty._meta.db_table), qn("vessel_id"), qn("start")
    sql = f"DELETE FROM {table} WHERE {vessel} = %s"
    params: list[Any] = [vessel_id]
    if max_span_s is not None:
        sql += f" AND {start} < (SELECT MIN({start}) FROM {table} WHERE {vessel} = %s) + %s"
        params += [vessel_id, max_span_s]
    with connection.cursor() as cursor:
        cursor.execute(f"{sql} RETURNING {start}", params)
        return sorted(row[0] for row in cursor.fetchall())


def replace_buckets(vessel_id: int, width: int, lo: int, hi: int, summaries: list[Summary]) -> None:
    """Replace the buckets of ``width`` starting in [lo, hi) with ``summaries``."""
    b = column_names(TrackBucket)
    with connection.cursor() as cursor:
        cursor.execute(
            f"DELETE FROM {b['table']} WHERE {b['vessel']} = %s AND {b['width']} = %s"
            f" AND {b['start']} >= %s AND {b['start']} < %s",
            [vessel_id, width, lo, hi],
        )
        if not summaries:
            return
        cursor.executemany(
            f"INSERT INTO {b['table']} ({b['vessel']}, {b['width']}, {b['start']}, {b['count']},"
            f" {b['points']}, {b['channels']}) VALUES (%s, %s, %s, %s, %s, %s)",
            [
                (vessel_id, width, s.start, s.count, json.dumps(
                    [s.first, s.last, s.north, s.south, s.east, s.west, *(s.gap or (None, None))]
                ), json.dumps(s.channels))
                for s in summaries
            ],
        )  # fmt: skip


def fixes_delete(ids: Sequence[int]) -> None:
    """One DELETE by id (retention): the ORM's delete() makes a model of each row first."""
    f, where = column_names(Fix), ", ".join(["%s"] * len(ids))
    with connection.cursor() as cursor:
        cursor.execute(f"DELETE FROM {f['table']} WHERE {f['id']} IN ({where})", list(ids))
