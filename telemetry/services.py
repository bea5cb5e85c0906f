"""Telemetry writes: the ingest of fix batches (boat API v1 and the legacy SPAB endpoint)."""

from __future__ import annotations

import datetime as dt
import functools
import json
import logging
from collections.abc import Callable, Sequence
from typing import Any

from django.conf import settings
from django.db import DatabaseError, connection, transaction
from django.db.models import QuerySet
from django.utils import timezone

from edge_client.contract import fix as fix_shape
from edge_client.contract.batch import BatchAnswer
from telemetry import selectors
from telemetry.errors import BatchTooLarge
from telemetry.models import Fix, SensorChannel, TrackBucket, TrackDirty
from telemetry.overview import WIDTHS, Summary, bucket_start, group_by_bucket, merge, summarize
from telemetry.parsing import FixData, FixErrors, parse_fix, parse_legacy_fix
from vessels.database import database_unavailable
from vessels.models import Vessel
from vessels.services import vessel_record_fix, vessel_record_fix_statement

logger = logging.getLogger(__name__)

# Rows per INSERT: 9 parameters each stays far below SQLite's 32,766-variable limit.
INSERT_CHUNK = 1000


IngestResult = BatchAnswer  # the telemetry upload's answer is the contract's batch answer


def fix_ingest(
    *,
    vessel: Vessel,
    records: Sequence[Any],
    legacy: bool = False,
    now: dt.datetime | None = None,
) -> IngestResult:
    """Store a batch of telemetry records for ``vessel``.

    0. A batch over FIX_MAX_BATCH records is refused whole (BatchTooLarge), before any work.
    1. Each record is validated on its own; a bad one is reported by index and never costs
       the good ones of the batch.
    2. Records repeating a time already in this batch count as duplicates (first one wins).
    3. The rest go in with INSERT … ON CONFLICT DO NOTHING RETURNING, so a fix already stored
       (a store-and-forward retry) is a counted duplicate, exactly, even when two requests race.
    4. The vessel's last fix moves forward only if this batch holds a newer fix.
    """
    if len(records) > settings.FIX_MAX_BATCH:
        raise BatchTooLarge(limit=settings.FIX_MAX_BATCH, got=len(records))
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
            result.reject(index, exc.errors)
            continue
        if fix.recorded_at in fixes:
            result.duplicates += 1
        else:
            fixes[fix.recorded_at] = fix
    inserted = _store(vessel, fixes, now)
    result.accepted = len(inserted)
    result.duplicates += len(fixes) - len(inserted)
    return result


def _store(vessel: Vessel, fixes: dict[dt.datetime, FixData], now: dt.datetime) -> list[Any]:
    """Insert the fixes and advance the vessel's last fix, in one transaction.

    A connection lost before COMMIT (a database restart, a failover) rolled everything back:
    try once more on a fresh connection. Safe even if it was the COMMIT's answer that was
    lost, because the insert is idempotent (the retry counts those fixes as duplicates).
    Inside a caller's transaction there is nothing to retry from: the error goes up.
    """
    try:
        return _store_once(vessel, fixes, now)
    except DatabaseError as exc:
        if connection.in_atomic_block or not database_unavailable(exc):
            raise
        logger.warning("ingest for %s lost its database connection; retrying", vessel.slug)
        connection.close()
    return _store_once(vessel, fixes, now)


def _store_once(vessel: Vessel, fixes: dict[dt.datetime, FixData], now: dt.datetime) -> list[Any]:
    if connection.vendor == "postgresql" and 0 < len(fixes) <= INSERT_CHUNK:
        return _store_postgres_in_one_statement(vessel, list(fixes.values()), now)
    with transaction.atomic():
        inserted = _insert_new(vessel.pk, list(fixes.values()), now)
        _mark_dirty(vessel.pk, inserted)
        _advance_last_fix(vessel, [fixes[t] for t in inserted], now)
    return inserted


FIX_COLUMNS = (
    "vessel_id",
    "recorded_at",
    "received_at",
    "lat",
    "lon",
    "heading_deg",
    "speed_mps",
    "battery_v",
    "readings",
)


def _insert_new(vessel_id: int, fixes: list[FixData], now: dt.datetime) -> list[dt.datetime]:
    """Insert ``fixes``; return the recorded_at of those that were new.

    INSERT … ON CONFLICT DO NOTHING RETURNING tells exactly which fixes were new, even when
    two requests race with the same fixes. SQLite gets multi-row VALUES; PostgreSQL gets the
    whole chunk as one JSON document unpacked by jsonb_to_recordset() (psycopg re-parsed a
    4,500-placeholder statement on every batch: profiled at half the request).
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
    row = "(" + ", ".join(["%s"] * len(FIX_COLUMNS)) + ")"
    sql = _insert_head() + f"VALUES {', '.join([row] * len(fixes))}" + _insert_tail()
    with connection.cursor() as cursor:
        cursor.execute(sql, params)
        return [r[0] for r in cursor.fetchall()]


_PG_RECORD = "t timestamptz, lat float8, lon float8, h float8, s float8, b float8, r jsonb"


def _insert_postgres(vessel_id: int, now: dt.datetime, fixes: list[FixData]) -> list[Any]:
    sql, params = _insert_postgres_statement(vessel_id, now, fixes)
    with connection.cursor() as cursor:
        cursor.execute(sql, params)
        return [r[0] for r in cursor.fetchall()]


def _insert_postgres_statement(
    vessel_id: int, now: dt.datetime, fixes: list[FixData]
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
        + _insert_tail()
    )
    return sql, [vessel_id, now, document]


def _store_postgres_in_one_statement(
    vessel: Vessel, fixes: list[FixData], now: dt.datetime
) -> list[dt.datetime]:
    """Insert the fixes and advance the vessel in ONE statement, outside any transaction.

    A single statement is its own transaction on PostgreSQL, so this costs one round trip
    where BEGIN, INSERT, UPDATE and COMMIT cost four (a legacy client posts one fix per
    request; the round trips were most of it). The vessel takes the batch's newest fix
    only if that one was new (the `newest` CTE reads the insert's RETURNING rows); an older
    new fix of the same batch could not be newer than the vessel's last fix anyway. The
    `dirty` CTE marks the new fixes' minutes for the track overview in the same statement.
    """
    newest = max(fixes, key=lambda f: f.recorded_at)
    insert_sql, insert_params = _insert_postgres_statement(vessel.pk, now, fixes)
    update_sql, update_params = vessel_record_fix_statement(
        vessel_id=vessel.pk,
        seen_at=now,
        fix_at=newest.recorded_at,
        summary=fix_summary(newest),
        also_if="EXISTS (SELECT 1 FROM newest)",
    )
    sql = (
        f"WITH inserted AS ({insert_sql}), "
        "newest AS (SELECT 1 FROM inserted WHERE recorded_at = %s), "
        f"vessel AS ({update_sql}), "
        f"{_mark_dirty_cte()} "
        "SELECT recorded_at FROM inserted"
    )
    by_time = {_key(f.recorded_at): f.recorded_at for f in fixes}
    with connection.cursor() as cursor:
        cursor.execute(sql, [*insert_params, newest.recorded_at, *update_params, vessel.pk])
        return [by_time[_key(row[0])] for row in cursor.fetchall()]


def _key(value: Any) -> dt.datetime:
    """Naive UTC, from stored text, a naive UTC datetime or an aware one."""
    if isinstance(value, dt.datetime):
        if value.tzinfo is None:
            return value
        return value.astimezone(dt.UTC).replace(tzinfo=None)
    text = str(value)
    return dt.datetime.fromisoformat(text).replace(tzinfo=None)


def _advance_last_fix(vessel: Vessel, new: list[FixData], now: dt.datetime) -> None:
    """Mark the vessel seen now; offer it the newest of ``new`` as its last fix."""
    if not new:
        vessel_record_fix(vessel_id=vessel.pk, seen_at=now)
        return
    newest = max(new, key=lambda f: f.recorded_at)
    vessel_record_fix(
        vessel_id=vessel.pk, seen_at=now, fix_at=newest.recorded_at, summary=fix_summary(newest)
    )


# A fix's numbers a boat may leave out (all but lat and lon), in the wire shape's order.
_OPTIONAL_NUMBERS = tuple(n for n in fix_shape.NUMBERS if n not in fix_shape.REQUIRED)


def fix_summary(fix: FixData | Fix) -> dict[str, Any]:
    """A fix as the boat API takes it (DESIGN §5): the copy kept on Vessel.last_fix, and what
    the glider's shore link posts to ``boat/telemetry/``."""
    summary: dict[str, Any] = {
        "time": fix.recorded_at.isoformat(),
        "lat": fix.lat,
        "lon": fix.lon,
    }
    for name in _OPTIONAL_NUMBERS:
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


# --- the track overview (telemetry/overview.py): marked dirty by ingest, rebuilt in the
# background (rebuild_track_overview --loop); reads take the fixes of the dirty minutes ---

# Dirty minutes closer than this are rebuilt from one read of the fixes between them.
DIRTY_RUN_JOIN_S = 1800
# A full rebuild reads the fixes a day at a time: bounded memory for any history.
REBUILD_WINDOW_S = 86400


# An existing mark is updated to itself rather than left alone: the update locks the row until
# the ingest commits, so a refresh that claims (deletes) the mark meanwhile waits, and then reads
# the new fixes. DO NOTHING takes no lock: on PostgreSQL a refresh could claim the mark and
# rebuild before the ingest committed, leaving its fixes out of the overview for good.
_KEEP_MARK_LOCKED = 'DO UPDATE SET "start" = EXCLUDED."start"'


def _dirty_minutes(times: Sequence[dt.datetime]) -> list[int]:
    return sorted({bucket_start(t.timestamp(), WIDTHS[0]) for t in times})


def _mark_dirty(vessel_id: int, times: Sequence[dt.datetime]) -> None:
    """Mark the minutes of newly stored fixes out of date (same transaction as the fixes)."""
    minutes = _dirty_minutes(times)
    if not minutes:
        return
    qn = connection.ops.quote_name
    table = qn(TrackDirty._meta.db_table)
    rows = ", ".join(["(%s, %s)"] * len(minutes))
    sql = (
        f"INSERT INTO {table} ({qn('vessel_id')}, {qn('start')}) VALUES {rows}"
        f" ON CONFLICT ({qn('vessel_id')}, {qn('start')}) {_KEEP_MARK_LOCKED}"
    )
    with connection.cursor() as cursor:
        cursor.execute(sql, [value for m in minutes for value in (vessel_id, m)])


def _mark_dirty_cte() -> str:
    """The same marks as _mark_dirty, as a CTE over the `inserted` rows (PostgreSQL)."""
    qn = connection.ops.quote_name
    table = qn(TrackDirty._meta.db_table)
    minute = WIDTHS[0]
    return (
        f"dirty AS (INSERT INTO {table} ({qn('vessel_id')}, {qn('start')})"
        f" SELECT DISTINCT %s, (floor(extract(epoch FROM recorded_at) / {minute}) * {minute})"
        "::bigint FROM inserted"
        f" ON CONFLICT ({qn('vessel_id')}, {qn('start')}) {_KEEP_MARK_LOCKED})"
    )


def track_overview_refresh(*, vessel_id: int, max_span_s: int | None = None) -> int:
    """Rebuild the overview buckets of the vessel's dirty minutes; how many minutes.

    The marks are claimed (DELETE … RETURNING) in the transaction that rebuilds them: a fix
    stored meanwhile either is visible to the rebuild's reads or leaves a new mark behind.
    ``max_span_s`` claims only the marks within that many seconds of the oldest one: a backlog
    is then rebuilt in short transactions, and an ingest marking one of its minutes waits for
    one of them, not for the whole backlog (call again until it returns 0).
    """
    if not TrackDirty.objects.filter(vessel_id=vessel_id).exists():
        return 0
    qn = connection.ops.quote_name
    table, vessel, start = qn(TrackDirty._meta.db_table), qn("vessel_id"), qn("start")
    sql = f"DELETE FROM {table} WHERE {vessel} = %s"
    params: list[Any] = [vessel_id]
    if max_span_s is not None:
        sql += f" AND {start} < (SELECT MIN({start}) FROM {table} WHERE {vessel} = %s) + %s"
        params += [vessel_id, max_span_s]
    with transaction.atomic():
        with connection.cursor() as cursor:
            cursor.execute(f"{sql} RETURNING {start}", params)
            minutes = sorted(row[0] for row in cursor.fetchall())
        for lo, hi in _runs(minutes):
            _rebuild_range(vessel_id, lo, hi)
    return len(minutes)


def track_overview_dirty_vessels() -> list[int]:
    """Ids of the vessels with minutes waiting for a rebuild."""
    return sorted(set(TrackDirty.objects.values_list("vessel_id", flat=True).distinct()))


def _runs(minutes: list[int]) -> list[tuple[int, int]]:
    """Sorted minute starts as [lo, hi) ranges, near ones joined, none longer than
    REBUILD_WINDOW_S: each range's fixes are read into memory at once, and a backlog (a week of
    store-and-forward, or a whole history marked by a migration) must not be read whole."""
    runs: list[list[int]] = []
    for m in minutes:
        if runs and m - runs[-1][1] <= DIRTY_RUN_JOIN_S:
            runs[-1][1] = m + WIDTHS[0]
        else:
            runs.append([m, m + WIDTHS[0]])
    return [
        (start, min(start + REBUILD_WINDOW_S, hi))
        for lo, hi in runs
        for start in range(lo, hi, REBUILD_WINDOW_S)
    ]


def track_overview_rebuild(*, vessel: Vessel) -> None:
    """Rebuild the vessel's whole overview from its fixes (after a bulk load or deletions)."""
    TrackDirty.objects.filter(vessel=vessel).delete()
    TrackBucket.objects.filter(vessel=vessel).delete()
    first = Fix.objects.filter(vessel=vessel).order_by("recorded_at").first()
    last = Fix.objects.filter(vessel=vessel).order_by("-recorded_at").first()
    if first is None or last is None:
        return
    lo = bucket_start(first.recorded_at.timestamp(), WIDTHS[-1])
    end = last.recorded_at.timestamp() + WIDTHS[0]
    while lo < end:
        hi = lo + REBUILD_WINDOW_S
        with transaction.atomic():
            _rebuild_range(vessel.pk, lo, hi)
        lo = hi


def _rebuild_range(vessel_id: int, lo: int, hi: int) -> None:
    """Rebuild every level's buckets touching [lo, hi) (minute-aligned)."""
    fixes = selectors.raw_fixes(vessel_id, lo, hi)
    minute = WIDTHS[0]
    groups = group_by_bucket(fixes, minute, lambda f: f[0])
    _replace_buckets(
        vessel_id, minute, lo, hi, [summarize(start, group) for start, group in groups.items()]
    )
    for finer, width in zip(WIDTHS, WIDTHS[1:], strict=False):
        lo, hi = bucket_start(lo, width), -(-hi // width) * width
        parts = selectors.buckets(vessel_id, finer, lo, hi)
        groups = group_by_bucket(parts, width, lambda s: s.start)
        merged = [merge(start, group) for start, group in groups.items()]
        _replace_buckets(vessel_id, width, lo, hi, merged)


def _replace_buckets(
    vessel_id: int, width: int, lo: int, hi: int, summaries: list[Summary]
) -> None:
    """Replace the buckets of ``width`` starting in [lo, hi) with ``summaries``.

    Plain DELETE and executemany: a month of minutes is ~45,000 rows, and building a model
    instance per row cost more than the insert (profiled, bench.maps).
    """
    b = selectors.column_names(TrackBucket)
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


def fixes_delete(*, fixes: QuerySet[Fix]) -> int:
    """Delete fixes (the admin's delete) and mark their minutes for the track overview."""
    with transaction.atomic():
        marks: dict[int, list[dt.datetime]] = {}
        for vessel_id, recorded_at in fixes.values_list("vessel_id", "recorded_at").iterator():
            marks.setdefault(vessel_id, []).append(recorded_at)
        for vessel_id, times in marks.items():
            for start in range(0, len(times), INSERT_CHUNK):
                _mark_dirty(vessel_id, times[start : start + INSERT_CHUNK])
        deleted, _ = Fix.objects.filter(pk__in=fixes.values("pk")).delete()
    return deleted
