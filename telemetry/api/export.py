"""Full-resolution track exports (issue 9): CSV, GeoJSON and GPX 1.1, streamed.

Rows come from the database cursor in chunks (a server-side cursor on PostgreSQL), are written
as text by hand (numbers need no quoting; the readings cell is quoted JSON) and leave in chunks:
memory stays flat whatever the range, and the cost per fix is a few string operations.
"""

from __future__ import annotations

import datetime as dt
import json
from collections.abc import Iterator
from typing import Any
from xml.sax.saxutils import escape

from django.db import connection

from telemetry.models import Fix
from telemetry.selectors import db_time

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

Row = tuple[Any, float, float, float | None, float | None, float | None, Any]


def _rows(vessel_id: int, start: dt.datetime, end: dt.datetime) -> Iterator[list[Row]]:
    qn = connection.ops.quote_name
    columns = ("recorded_at", "lat", "lon", "heading_deg", "speed_mps", "battery_v", "readings")
    sql = (
        f"SELECT {', '.join(qn(c) for c in columns)} FROM {qn(Fix._meta.db_table)}"
        f" WHERE {qn('vessel_id')} = %s AND {qn('recorded_at')} >= %s"
        f" AND {qn('recorded_at')} < %s ORDER BY {qn('recorded_at')}"
    )
    # chunked_cursor: a named (server-side) cursor on PostgreSQL, so rows arrive as read.
    with connection.chunked_cursor() as cursor:
        cursor.execute(sql, [vessel_id, db_time(start.timestamp()), db_time(end.timestamp())])
        while rows := cursor.fetchmany(EXPORT_CHUNK):
            yield rows


def _iso(value: Any) -> str:
    """A stored recorded_at as ISO 8601 UTC with a Z."""
    if isinstance(value, str):  # SQLite: "YYYY-MM-DD HH:MM:SS[.ffffff]", naive UTC
        return f"{value[:10]}T{value[11:]}Z"
    return value.astimezone(dt.UTC).replace(tzinfo=None).isoformat() + "Z"


def _epoch(value: Any) -> float:
    if isinstance(value, str):
        return dt.datetime.fromisoformat(value).replace(tzinfo=dt.UTC).timestamp()
    return value.timestamp()


def _json_text(value: Any) -> str:
    """A readings column as JSON text: stored text as is (SQLite), else encoded."""
    if value is None:
        return "{}"
    if isinstance(value, bytes):
        return value.decode()
    return value if isinstance(value, str) else json.dumps(value)


def _num(value: float | None) -> str:
    return "" if value is None else repr(value)


def _json_num(value: float | None) -> str:
    return "null" if value is None else repr(value)


def csv_chunks(vessel_id: int, start: dt.datetime, end: dt.datetime) -> Iterator[str]:
    yield CSV_HEADER
    for rows in _rows(vessel_id, start, end):
        yield "".join(
            f"{_iso(t)},{lat!r},{lon!r},{_num(h)},{_num(s)},{_num(b)},"
            f'"{_json_text(r).replace(chr(34), chr(34) * 2)}"\r\n'
            for t, lat, lon, h, s, b, r in rows
        )


def geojson_chunks(
    vessel_id: int, start: dt.datetime, end: dt.datetime, properties: dict[str, Any]
) -> Iterator[str]:
    """One Point feature per fix, with every value of the fix in its properties."""
    yield '{"type":"FeatureCollection","properties":' + json.dumps(properties)
    yield ',"features":['
    separator = ""
    for rows in _rows(vessel_id, start, end):
        parts = []
        for t, lat, lon, h, s, b, r in rows:
            parts.append(
                f'{separator}{{"type":"Feature","geometry":{{"type":"Point",'
                f'"coordinates":[{lon!r},{lat!r}]}},"properties":{{"time":"{_iso(t)}",'
                f'"heading_deg":{_json_num(h)},"speed_mps":{_json_num(s)},'
                f'"battery_v":{_json_num(b)},"readings":{_json_text(r)}}}}}'
            )
            separator = ","
        yield "".join(parts)
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
        for t, lat, lon, _h, s, b, _r in rows:
            now = _epoch(t)
            if previous is None:
                parts.append("<trkseg>\n")
            elif now - previous > gap_s:
                parts.append("</trkseg>\n<trkseg>\n")
            previous = now
            extensions = _gpx_extensions(s, b)
            parts.append(
                f'<trkpt lat="{lat!r}" lon="{lon!r}"><time>{_iso(t)}</time>{extensions}</trkpt>\n'
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
