"""Full-resolution fix exports (issue 9): CSV, GeoJSON and GPX 1.1, streamed. One writer per
format: every endpoint that offers a format answers with these bytes (the track export, and
the fixes endpoint's CSV), so the same range gives the same file.

Rows come from the database in chunks and leave in chunks: memory stays flat whatever the
range. For CSV and GeoJSON the database writes each fix's whole line: the SQL, and the
benchmark that justifies it, are in telemetry.sql.
"""

from __future__ import annotations

import datetime as dt
import json
from collections.abc import Iterable, Iterator
from typing import Any
from xml.sax.saxutils import escape

from django.http import StreamingHttpResponse

from edge_client.contract import fix as fix_shape
from telemetry import sql

FORMATS = {
    "csv": "text/csv; charset=utf-8",
    "geojson": "application/geo+json",
    "gpx": "application/gpx+xml",
}
# The fix's shape in every export: the boat API's (edge_client.contract.fix), so `time`, not
# `recorded_at`.
COLUMNS = fix_shape.FIELDS
CSV_HEADER = ",".join(COLUMNS) + "\r\n"
GPX_NS = "http://www.topografix.com/GPX/1/1"
# Our own GPX extension namespace for speed and battery (GPX 1.1 has no field for either).
EXT_NS = "https://shoreside.invalid/gpx/1"


def csv_chunks(
    vessel_id: int, start: dt.datetime | None = None, end: dt.datetime | None = None
) -> Iterator[str]:
    """The CSV of every endpoint that offers one: ``CSV_HEADER``, then a CRLF line per fix."""
    yield CSV_HEADER
    for lines in sql.export_lines(vessel_id, start, end, sql.csv_line_sql()):
        yield "\r\n".join(lines) + "\r\n"


def geojson_chunks(
    vessel_id: int, start: dt.datetime, end: dt.datetime, properties: dict[str, Any]
) -> Iterator[str]:
    """One Point feature per fix, with every value of the fix in its properties."""
    yield '{"type":"FeatureCollection","properties":' + json.dumps(properties)
    yield ',"features":['
    separator = ""
    for lines in sql.export_lines(vessel_id, start, end, sql.feature_line_sql()):
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
    for rows in sql.export_rows(vessel_id, start, end):
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
