"""Telemetry reads: a vessel's fixes in a range, and the track overview's buckets.

The overview reads go through raw cursors: a day of track is ~1,500 bucket rows and a month
of plots ~700, and the ORM's per-row model work cost more than the query (profiled, bench.maps).
"""

from __future__ import annotations

import datetime as dt
import functools
import json
from collections.abc import Callable
from typing import Any

from django.db import connection
from django.db.models import QuerySet

from telemetry.models import Fix, TrackBucket
from telemetry.overview import RawFix, Summary
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


def to_epoch(value: Any) -> float:
    """A stored recorded_at as Unix seconds: SQLite gives naive UTC text, PostgreSQL datetimes."""
    if isinstance(value, str):
        value = dt.datetime.fromisoformat(value)
    if value.tzinfo is None:
        value = value.replace(tzinfo=dt.UTC)
    return value.timestamp()


def as_json(value: Any) -> Any:
    """A JSON column from a raw cursor: text on SQLite (and psycopg's text loader), or parsed."""
    return json.loads(value) if isinstance(value, str | bytes) else value


@functools.cache
def _names(model: Any) -> dict[str, str]:
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
    f = _names(Fix)
    sql = (
        f"SELECT {f['recorded_at']}, {f['lat']}, {f['lon']}, {f['battery_v']}, {f['readings']}"
        f" FROM {f['table']} WHERE {f['vessel']} = %s"
        f" AND {f['recorded_at']} >= %s AND {f['recorded_at']} < %s ORDER BY {f['recorded_at']}"
    )
    return [
        (to_epoch(t), lat, lon, battery, as_json(readings))
        for t, lat, lon, battery, readings in _query(sql, [vessel_id, db_time(lo), db_time(hi)])
    ]


def raw_points(vessel_id: int, lo: float, hi: float) -> list[tuple[float, float, float]]:
    """(t, lat, lon) of the vessel's fixes in [lo, hi), by time."""
    f = _names(Fix)
    sql = (
        f"SELECT {f['recorded_at']}, {f['lat']}, {f['lon']} FROM {f['table']}"
        f" WHERE {f['vessel']} = %s AND {f['recorded_at']} >= %s AND {f['recorded_at']} < %s"
        f" ORDER BY {f['recorded_at']}"
    )
    rows = _query(sql, [vessel_id, db_time(lo), db_time(hi)])
    return [(to_epoch(t), lat, lon) for t, lat, lon in rows]


def _point(value: list[float] | None) -> tuple[float, float, float] | None:
    return (value[0], value[1], value[2]) if value else None


def summary_from_row(start: int, count: int, points: Any, channels: Any) -> Summary:
    first, last, north, south, east, west, gap_from, gap_to = map(_point, as_json(points))
    gap = (gap_from, gap_to) if gap_from and gap_to else None
    return Summary(
        start, count, first, last, north, south, east, west, gap, as_json(channels) or {}
    )  # type: ignore[arg-type]


def buckets(
    vessel_id: int, width: int, lo: float, hi: float, *, channels: bool = True
) -> list[Summary]:
    """The overview buckets of ``width`` starting in [lo, hi), by time; ``channels=False``
    leaves the channel aggregates unread (the track needs only the points)."""
    b = _names(TrackBucket)
    wanted = b["channels"] if channels else "NULL"
    sql = (
        f"SELECT {b['start']}, {b['count']}, {b['points']}, {wanted} FROM {b['table']}"
        f" WHERE {b['vessel']} = %s AND {b['width']} = %s"
        f" AND {b['start']} >= %s AND {b['start']} < %s ORDER BY {b['start']}"
    )
    make: Callable[..., Summary] = summary_from_row
    return [make(*row) for row in _query(sql, [vessel_id, width, lo, hi])]
