"""Full-resolution track exports (issue 9): CSV, GeoJSON and GPX 1.1, streamed.

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
from collections.abc import Callable, Iterator
from typing import Any
from xml.sax.saxutils import escape

from django.db import connection

from telemetry.models import Fix
from telemetry.selectors import db_time, epoch_sql, iso_sql

EXPORT_CHUNK = 5000
FORMATS = {
    "csv": "text/csv; charset=utf-8",
    "geojson": "application/geo+json",
    "gpx": "application/gpx+xml",
}
CSV_HEADER = "time,lat,lon,heading_deg,speed_mps,battery_v,readings\r\n"
GPX_NS = "http://www.topografix.com/GPX/1/1"
# Our own GPX extension namespace for speed and battery (GPX 1.1 has no field for either).
EXT_NS = "https://shoreside.invalid/gpx/1"
QUOTE = '"'

# (time as ISO text, Unix seconds, lat, lon, heading, speed, battery, readings as JSON text)
Row = tuple[str, float, float, float, float | None, float | None, float | None, str]


def _rows(
    vessel_id: int, start: dt.datetime, end: dt.datetime, *, epoch: bool = False
) -> Iterator[list[Row]]:
    """The fixes of [start, end) in chunks; the Unix time only if ``epoch`` (GPX's breaks):
    on SQLite it costs a date parse per row."""
    qn = connection.ops.quote_name
    t = qn("recorded_at")
    numbers = [qn(c) for c in ("lat", "lon", "heading_deg", "speed_mps", "battery_v")]
    time_columns = [iso_sql(t), epoch_sql(t) if epoch else "NULL"]
    columns = [*time_columns, *numbers, f"CAST({qn('readings')} AS TEXT)"]
    sql = (
        f"SELECT {', '.join(columns)} FROM {qn(Fix._meta.db_table)}"
        f" WHERE {qn('vessel_id')} = %s AND {t} >= %s AND {t} < %s ORDER BY {t}"
    )
    # chunked_cursor: a named (server-side) cursor on PostgreSQL, so rows arrive as read.
    with connection.chunked_cursor() as cursor:
        cursor.execute(sql, [vessel_id, db_time(start.timestamp()), db_time(end.timestamp())])
        while rows := cursor.fetchmany(EXPORT_CHUNK):
            yield rows


def _lines(
    vessel_id: int, start: dt.datetime, end: dt.datetime, line: Callable[..., str]
) -> Iterator[list[str]]:
    """Each fix of [start, end) as the text the SQL expression ``line(column)`` makes of it."""
    qn = connection.ops.quote_name
    t = qn("recorded_at")
    sql = (
        f"SELECT {line(qn)} FROM {qn(Fix._meta.db_table)}"
        f" WHERE {qn('vessel_id')} = %s AND {t} >= %s AND {t} < %s ORDER BY {t}"
    )
    with connection.chunked_cursor() as cursor:
        cursor.execute(sql, [vessel_id, db_time(start.timestamp()), db_time(end.timestamp())])
        while rows := cursor.fetchmany(EXPORT_CHUNK):
            yield [row[0] for row in rows]


def _text(qn: Callable[[str], str], column: str, empty: str) -> str:
    return f"coalesce(CAST({qn(column)} AS TEXT), {_literal(empty)})"


def _literal(text: str) -> str:
    """A constant SQL string (our own text, never input)."""
    return "'" + text.replace("'", "''") + "'"


def _concat(*parts: str) -> str:
    return " || ".join(parts)


def _csv_line(qn: Callable[[str], str]) -> str:
    # The readings cell is quoted JSON ('"' doubled): it never starts with a formula sign.
    readings = f"replace({_text(qn, 'readings', '{}')}, {_literal(QUOTE)}, {_literal(QUOTE * 2)})"
    cells = [
        iso_sql(qn("recorded_at")),
        *(_text(qn, c, "") for c in ("lat", "lon", "heading_deg", "speed_mps", "battery_v")),
        _concat(_literal(QUOTE), readings, _literal(QUOTE)),
    ]
    return _concat(*[part for cell in cells for part in (cell, _literal(","))][:-1])


def _feature_line(qn: Callable[[str], str]) -> str:
    """One Point Feature per fix, every value in its properties (GeoJSON text, by SQL)."""
    return _concat(
        _literal('{"type":"Feature","geometry":{"type":"Point","coordinates":['),
        _text(qn, "lon", "null"),
        _literal(","),
        _text(qn, "lat", "null"),
        _literal(']},"properties":{"time":"'),
        iso_sql(qn("recorded_at")),
        _literal('","heading_deg":'),
        _text(qn, "heading_deg", "null"),
        _literal(',"speed_mps":'),
        _text(qn, "speed_mps", "null"),
        _literal(',"battery_v":'),
        _text(qn, "battery_v", "null"),
        _literal(',"readings":'),
        _text(qn, "readings", "{}"),
        _literal("}}"),
    )


def csv_chunks(vessel_id: int, start: dt.datetime, end: dt.datetime) -> Iterator[str]:
    yield CSV_HEADER
    for lines in _lines(vessel_id, start, end, _csv_line):
        yield "\r\n".join(lines) + "\r\n"


def geojson_chunks(
    vessel_id: int, start: dt.datetime, end: dt.datetime, properties: dict[str, Any]
) -> Iterator[str]:
    """One Point feature per fix, with every value of the fix in its properties."""
    yield '{"type":"FeatureCollection","properties":' + json.dumps(properties)
    yield ',"features":['
    separator = ""
    for lines in _lines(vessel_id, start, end, _feature_line):
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
    for rows in _rows(vessel_id, start, end, epoch=True):
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
