"""The telemetry app's hand-written SQL for the fix exports, each statement beside the
benchmark that justifies it.

Not here yet: the fix ingest's statements (telemetry.services, being rewritten for the single
post) and the overview's raw reads (telemetry.selectors), each with its reason beside it.
"""

from __future__ import annotations

import datetime as dt
from collections.abc import Iterator
from typing import Any

from django.db import connection

from telemetry.models import Fix
from telemetry.selectors import db_time, epoch_sql, iso_sql

# Rows read from the cursor at a time: memory stays flat whatever the range.
EXPORT_CHUNK = 5000
# The fix's numbers in every export, in column order (between `time` and `readings`).
EXPORT_NUMBERS = ("lat", "lon", "heading_deg", "speed_mps", "battery_v")
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
        _literal('","heading_deg":'),
        _text("heading_deg", "null"),
        _literal(',"speed_mps":'),
        _text("speed_mps", "null"),
        _literal(',"battery_v":'),
        _text("battery_v", "null"),
        _literal(',"readings":'),
        _text("readings", "{}"),
        _literal("}}"),
    )
