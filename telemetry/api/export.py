"""Full-resolution fix exports (issue 9): CSV, GeoJSON and GPX 1.1, streamed. One writer per
format: every endpoint that offers a format answers with these bytes (the track export, and
the fixes endpoint's CSV), so the same range gives the same file.

Rows come from the database cursor in chunks (a server-side cursor on PostgreSQL) and leave in
chunks: memory stays flat whatever the range. For CSV and GeoJSON the database writes each
fix's whole line (string concatenation in SQL, numbers by CAST AS TEXT): formatting three
floats a row in Python was most of the export's time (profiled, bench.maps). Numbers come out
as the database writes them: the shortest exact form on PostgreSQL, 15 significant digits on
SQLite (its text form of a REAL; 1e-13 degrees, some ten nanometres).
"""

from __future__ import annotations

import datetime as dt
import json
from collections.abc import Iterable, Iterator
from typing import Any
from xml.sax.saxutils import escape

from django.db import connection
from django.http import StreamingHttpResponse

from telemetry.models import Fix
from telemetry.selectors import db_time, epoch_sql, iso_sql

EXPORT_CHUNK = 5000
FORMATS = {
    "csv": "text/csv; charset=utf-8",
    "geojson": "application/geo+json",
    "gpx": "application/gpx+xml",
}
# The fix's shape in every export (the names of the fix JSON: `time`, not `recorded_at`).
COLUMNS = ("time", "lat", "lon", "heading_deg", "speed_mps", "battery_v", "readings")
NUMBERS = COLUMNS[1:6]
CSV_HEADER = ",".join(COLUMNS) + "\r\n"
GPX_NS = "http://www.topografix.com/GPX/1/1"
# Our own GPX extension namespace for speed and battery (GPX 1.1 has no field for either).
EXT_NS = "https://shoreside.invalid/gpx/1"
QUOTE = '"'

# (time as ISO text, Unix seconds, lat, lon, heading, speed, battery, readings as JSON text)
Row = tuple[str, float, float, float, float | None, float | None, float | None, str]


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


def _rows(vessel_id: int, start: dt.datetime, end: dt.datetime) -> Iterator[list[Row]]:
    """The fixes of [start, end) in chunks, with their Unix time (GPX's breaks)."""
    qn = connection.ops.quote_name
    t = qn("recorded_at")
    columns = [
        iso_sql(t),
        epoch_sql(t),
        *(qn(c) for c in NUMBERS),
        f"CAST({qn('readings')} AS TEXT)",
    ]
    yield from _chunks(*fixes_sql(vessel_id, start, end, ", ".join(columns)))


def _lines(
    vessel_id: int, start: dt.datetime | None, end: dt.datetime | None, line: str
) -> Iterator[list[str]]:
    """Each fix of [start, end) as the text the SQL expression ``line`` makes of it."""
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
    """SQL for one fix's CSV line, without its line end: the cells of ``COLUMNS``."""
    # The readings cell is quoted JSON ('"' doubled): it starts with '{', never a formula
    # sign (a spreadsheet runs a cell starting with = + - @ as a formula; names come from
    # the boat).
    readings = f"replace({_text('readings', '{}')}, {_literal(QUOTE)}, {_literal(QUOTE * 2)})"
    cells = [
        _time(),
        *(_text(c, "") for c in NUMBERS),
        _concat(_literal(QUOTE), readings, _literal(QUOTE)),
    ]
    return _concat(*[part for cell in cells for part in (cell, _literal(","))][:-1])


def _feature_line() -> str:
    """One Point Feature per fix, every value in its properties (GeoJSON text, by SQL)."""
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


def csv_chunks(
    vessel_id: int, start: dt.datetime | None = None, end: dt.datetime | None = None
) -> Iterator[str]:
    """The CSV of every endpoint that offers one: ``CSV_HEADER``, then a CRLF line per fix."""
    yield CSV_HEADER
    for lines in _lines(vessel_id, start, end, csv_line_sql()):
        yield "\r\n".join(lines) + "\r\n"


def geojson_chunks(
    vessel_id: int, start: dt.datetime, end: dt.datetime, properties: dict[str, Any]
) -> Iterator[str]:
    """One Point feature per fix, with every value of the fix in its properties."""
    yield '{"type":"FeatureCollection","properties":' + json.dumps(properties)
    yield ',"features":['
    separator = ""
    for lines in _lines(vessel_id, start, end, _feature_line()):
        yield separator + ",".join(lines)
        separator = ","
    yield "]}\n"


def gpx_chunks(
    vessel_id: int, start: dt.datetime, end: dt.datetime, *, name: str, gap_s: float
) -> Iterator[str]:
    """GPX 1.1: one trk, a new trkseg after each silence longer than ``gap_s``."""
    yield (
        '<?xml version="1.0" encoding="UTF-8"?>\n'
        f'<gpx version="1.1" creator="Shoreside" xmlns="{GPX_NS}" xmlns:s="{EXT_NS}">\n'
        f"<trk><name>{escape(name)}</name>\n"
    )
    previous: float | None = None
    for rows in _rows(vessel_id, start, end):
        parts = []
        for t, now, lat, lon, _h, s, b, _r in rows:
            if previous is None:
                parts.append("<trkseg>\n")
            elif now - previous > gap_s:
                parts.append("</trkseg>\n<trkseg>\n")
            previous = now
            extensions = _gpx_extensions(s, b)
            parts.append(
                f'<trkpt lat="{lat!r}" lon="{lon!r}"><time>{t}</time>{extensions}</trkpt>\n'
            )
        yield "".join(parts)
    yield ("</trkseg>\n" if previous is not None else "") + "</trk>\n</gpx>\n"


def _gpx_extensions(speed: float | None, battery: float | None) -> str:
    if speed is None and battery is None:
        return ""
    inner = (f"<s:speed_mps>{speed!r}</s:speed_mps>" if speed is not None else "") + (
        f"<s:battery_v>{battery!r}</s:battery_v>" if battery is not None else ""
    )
    return f"<extensions>{inner}</extensions>"


def streamed(chunks: Iterable[str], *, fmt: str, filename: str) -> StreamingHttpResponse:
    """An export as an attachment, sent as it is written."""
    response = StreamingHttpResponse(chunks, content_type=FORMATS[fmt])
    response["Content-Disposition"] = f'attachment; filename="{filename}"'
    return response
