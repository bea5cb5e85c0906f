"""The telemetry app's hand-written SQL, each statement beside the benchmark that justifies
it: the track overview's reads and the fix exports.

Not here yet: the fix ingest's and the overview rebuild's statements (telemetry.services,
being rewritten for the single post), each with its reason beside it there.
"""

from __future__ import annotations

import datetime as dt
import functools
import json
from collections.abc import Iterator
from typing import Any

from django.db import connection

from edge_client.contract import fix as fix_shape
from telemetry.models import Fix, TrackBucket, TrackDirty
from telemetry.overview import WIDTHS, RawFix, Summary

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
