"""Telemetry reads: a vessel's fixes in a range, and the track overview's buckets.

The overview reads go through raw cursors: a day of track is ~1,500 bucket rows and a month
of plots ~700, and the ORM's per-row model work cost more than the query (profiled, bench.maps).
"""

from __future__ import annotations

import datetime as dt
import functools
import json
from typing import Any

from django.db import connection
from django.db.models import QuerySet

from telemetry.models import Fix, TrackBucket, TrackDirty
from telemetry.overview import WIDTHS, RawFix, Summary
from vessels.models import Vessel


def fixes_in_range(
    *, vessel: Vessel, start: dt.datetime | None = None, end: dt.datetime | None = None
) -> QuerySet[Fix]:
    """A vessel's fixes in [start, end), on the (vessel, recorded_at) unique index."""
    fixes = Fix.objects.filter(vessel=vessel)
    if start is not None:
        fixes = fixes.filter(recorded_at__gte=start)
    if end is not None:
        fixes = fixes.filter(recorded_at__lt=end)
    return fixes


def fix_nearest(*, vessel: Vessel, when: dt.datetime) -> Fix | None:
    """The vessel's fix nearest in time to ``when`` (the earlier one on a tie)."""
    before = Fix.objects.filter(vessel=vessel, recorded_at__lte=when).order_by("-recorded_at")
    after = Fix.objects.filter(vessel=vessel, recorded_at__gt=when).order_by("recorded_at")
    candidates = [f for f in (before.first(), after.first()) if f is not None]
    if not candidates:
        return None
    return min(candidates, key=lambda f: abs((f.recorded_at - when).total_seconds()))


# --- raw reads, shared by the overview reads and its rebuild ---


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
