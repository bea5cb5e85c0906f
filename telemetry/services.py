"""Telemetry writes: the ingest of fix batches (boat API v1 and the legacy SPAB endpoint)."""

from __future__ import annotations

import datetime as dt
import functools
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

from django.conf import settings
from django.db import connection, transaction
from django.utils import timezone

from telemetry.models import Fix, SensorChannel
from telemetry.parsing import FixData, FixErrors, parse_fix, parse_legacy_fix
from vessels.models import Vessel

# Rows per INSERT: 9 parameters each stays far below SQLite's 32,766-variable limit.
INSERT_CHUNK = 1000


@dataclass
class IngestResult:
    accepted: int = 0
    duplicates: int = 0
    rejected: list[dict[str, Any]] = field(default_factory=list)

    def as_dict(self) -> dict[str, Any]:
        return {"accepted": self.accepted, "duplicates": self.duplicates, "rejected": self.rejected}


def fix_ingest(
    *,
    vessel: Vessel,
    records: Sequence[Any],
    legacy: bool = False,
    now: dt.datetime | None = None,
) -> IngestResult:
    """Store a batch of telemetry records for ``vessel``.

    1. Each record is validated on its own; a bad one is reported by index and never costs
       the good ones of the batch.
    2. Records repeating a time already in this batch count as duplicates (first one wins).
    3. The rest go in with INSERT … ON CONFLICT DO NOTHING RETURNING, so a fix already stored
       (a store-and-forward retry) is a counted duplicate, exactly, even when two requests race.
    4. The vessel's last fix moves forward only if this batch holds a newer fix.
    """
    now = now or timezone.now()
    result = IngestResult()
    parse: Callable[..., FixData] = parse_legacy_fix if legacy else parse_fix
    fixes: dict[dt.datetime, FixData] = {}
    for index, record in enumerate(records):
        try:
            fix = (
                parse(record, now=now, index=index, max_future_s=settings.FIX_MAX_FUTURE_S)
                if legacy
                else parse(record, now=now, max_future_s=settings.FIX_MAX_FUTURE_S)
            )
        except FixErrors as exc:
            result.rejected.append({"index": index, "errors": exc.errors})
            continue
        if fix.recorded_at in fixes:
            result.duplicates += 1
        else:
            fixes[fix.recorded_at] = fix
    with transaction.atomic():
        inserted = _insert_new(vessel.pk, list(fixes.values()), now)
        result.accepted = len(inserted)
        result.duplicates += len(fixes) - len(inserted)
        _advance_last_fix(vessel, [fixes[t] for t in inserted], now)
    return result


def _insert_new(vessel_id: int, fixes: list[FixData], now: dt.datetime) -> list[dt.datetime]:
    """Insert ``fixes``; return the recorded_at of those that were new."""
    if not fixes:
        return []
    meta = Fix._meta
    cols = [
        "vessel_id",
        "recorded_at",
        "received_at",
        "lat",
        "lon",
        "heading_deg",
        "speed_mps",
        "battery_v",
        "readings",
    ]
    # The backend's own adapters, straight: the field layer around them cost more per fix
    # than the insert (profiled). Values are already validated aware-UTC datetimes and dicts.
    prep_time = connection.ops.adapt_datetimefield_value
    qn = connection.ops.quote_name
    received = prep_time(now)
    inserted: list[dt.datetime] = []
    by_db_time: dict[Any, dt.datetime] = {}
    for start in range(0, len(fixes), INSERT_CHUNK):
        chunk = fixes[start : start + INSERT_CHUNK]
        params: list[Any] = []
        for fix in chunk:
            db_time = prep_time(fix.recorded_at)
            by_db_time[db_time] = fix.recorded_at
            params += [
                vessel_id,
                db_time,
                received,
                fix.lat,
                fix.lon,
                fix.heading_deg,
                fix.speed_mps,
                fix.battery_v,
                connection.ops.adapt_json_value(fix.readings, None),
            ]
        row = "(" + ", ".join(["%s"] * len(cols)) + ")"
        sql = (
            f"INSERT INTO {qn(meta.db_table)} ({', '.join(qn(c) for c in cols)}) "
            f"VALUES {', '.join([row] * len(chunk))} "
            f"ON CONFLICT ({qn('vessel_id')}, {qn('recorded_at')}) DO NOTHING "
            f"RETURNING {qn('recorded_at')}"
        )
        with connection.cursor() as cursor:
            cursor.execute(sql, params)
            returned = [r[0] for r in cursor.fetchall()]
        # PostgreSQL returns an aware datetime equal to the one sent; SQLite's driver parses
        # the stored text into a naive one. Both normalise to naive UTC for the lookup.
        by_key = {_key(db_time): fix_time for db_time, fix_time in by_db_time.items()}
        inserted += [by_key[_key(value)] for value in returned]
        by_db_time.clear()
    return inserted


def _key(value: Any) -> dt.datetime:
    """Naive UTC, from stored text, a naive UTC datetime or an aware one."""
    if isinstance(value, dt.datetime):
        if value.tzinfo is None:
            return value
        return value.astimezone(dt.UTC).replace(tzinfo=None)
    text = str(value)
    return dt.datetime.fromisoformat(text).replace(tzinfo=None)


@functools.cache
def _advance_sql(vendor: str) -> str:
    meta, qn = Vessel._meta, connection.ops.quote_name
    seen, fix, fix_at = (
        qn(meta.get_field(n).column) for n in ("last_seen_at", "last_fix", "last_fix_at")
    )
    newer = f"({fix_at} IS NULL OR {fix_at} < %s)"
    return (
        f"UPDATE {qn(meta.db_table)} SET {seen} = %s, "
        f"{fix} = CASE WHEN {newer} THEN %s ELSE {fix} END, "
        f"{fix_at} = CASE WHEN {newer} THEN %s ELSE {fix_at} END "
        f"WHERE {qn(meta.pk.column)} = %s"
    )


def _advance_last_fix(vessel: Vessel, new: list[FixData], now: dt.datetime) -> None:
    """Mark the vessel seen now; move its last fix forward only if ``new`` holds a newer one.

    One conditional UPDATE, written once (as the insert is): backlogs arrive oldest first and
    out of order, so "newer" is decided in the database, under the row lock, not here. The
    ORM version cost more than the insert itself on a single-fix post (profiled).
    """
    meta = Vessel._meta
    prep_time = meta.get_field("last_fix_at").get_db_prep_save
    seen = prep_time(now, connection)
    if not new:
        Vessel.objects.filter(pk=vessel.pk).update(last_seen_at=now)
        return
    newest = max(new, key=lambda f: f.recorded_at)
    at = prep_time(newest.recorded_at, connection)
    summary = meta.get_field("last_fix").get_db_prep_save(fix_summary(newest), connection)
    with connection.cursor() as cursor:
        cursor.execute(_advance_sql(connection.vendor), [seen, at, summary, at, at, vessel.pk])


def fix_summary(fix: FixData) -> dict[str, Any]:
    """The denormalised copy of a fix kept on Vessel.last_fix."""
    summary: dict[str, Any] = {
        "time": fix.recorded_at.isoformat(),
        "lat": fix.lat,
        "lon": fix.lon,
    }
    for name in ("heading_deg", "speed_mps", "battery_v"):
        value = getattr(fix, name)
        if value is not None:
            summary[name] = value
    if fix.readings:
        summary["readings"] = fix.readings
    return summary


def sensor_channel_save(*, channel: SensorChannel) -> SensorChannel:
    channel.full_clean()
    channel.save()
    return channel
