"""Telemetry writes: the ingest of fix batches (boat API v1 and the legacy SPAB endpoint)."""

from __future__ import annotations

import datetime as dt
import logging
from collections.abc import Callable, Sequence
from typing import Any

from django.conf import settings
from django.db import DatabaseError, connection, transaction
from django.db.models import QuerySet
from django.utils import timezone

from edge_client.contract import fix as fix_shape
from edge_client.contract.batch import BatchAnswer
from telemetry import sql
from telemetry.errors import BatchTooLarge, KeyRefused
from telemetry.models import Fix, SensorChannel, TrackBucket, TrackDirty
from telemetry.overview import WIDTHS, bucket_start, group_by_bucket, merge, summarize
from telemetry.parsing import FixData, FixErrors, parse_fix, parse_legacy_fix
from vessels.database import database_unavailable, health_check_spare
from vessels.models import Vessel
from vessels.selectors import vessel_key_works
from vessels.services import vessel_record_fix

logger = logging.getLogger(__name__)


IngestResult = BatchAnswer  # the telemetry upload's answer is the contract's batch answer


def fix_ingest(
    *,
    vessel: Vessel,
    records: Sequence[Any],
    legacy: bool = False,
    now: dt.datetime | None = None,
    key_id: int | None = None,
) -> IngestResult:
    """Store a batch of telemetry records for ``vessel``.

    ``key_id``: the vessel key the request came with, when its lookup may be a recent one
    (vessels.auth.key_lookup_recent): the writes then carry the key's check, and KeyRefused
    is raised, nothing written, if the key no longer works.

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
    inserted = _store(vessel, fixes, now, key_id)
    result.accepted = len(inserted)
    result.duplicates += len(fixes) - len(inserted)
    return result


def _store(
    vessel: Vessel, fixes: dict[dt.datetime, FixData], now: dt.datetime, key_id: int | None
) -> list[Any]:
    """Insert the fixes and advance the vessel's last fix, in one transaction.

    A connection lost before COMMIT (a database restart, a failover) rolled everything back:
    try once more on a fresh connection. Safe even if it was the COMMIT's answer that was
    lost, because the insert is idempotent (the retry counts those fixes as duplicates).
    Inside a caller's transaction there is nothing to retry from: the error goes up. That
    retry is what the per-request connection health check is for: it is spared.
    """
    health_check_spare()
    try:
        return _store_once(vessel, fixes, now, key_id)
    except DatabaseError as exc:
        if connection.in_atomic_block or not database_unavailable(exc):
            raise
        logger.warning("ingest for %s lost its database connection; retrying", vessel.slug)
        connection.close()
    return _store_once(vessel, fixes, now, key_id)


def _store_once(
    vessel: Vessel, fixes: dict[dt.datetime, FixData], now: dt.datetime, key_id: int | None
) -> list[Any]:
    batch = list(fixes.values())
    if 0 < len(batch) <= sql.INSERT_CHUNK and connection.vendor in ("postgresql", "sqlite"):
        return _store_small(vessel, batch, now, key_id)
    with transaction.atomic():
        if key_id is not None and not vessel_key_works(key_id):
            raise KeyRefused
        inserted = sql.insert_new(vessel.pk, batch, now)
        sql.mark_dirty(vessel.pk, inserted)
        _advance_last_fix(vessel, [fixes[t] for t in inserted], now)
    return inserted


def _store_small(
    vessel: Vessel, batch: list[FixData], now: dt.datetime, key_id: int | None
) -> list[dt.datetime]:
    """A batch in one statement (PostgreSQL) or one short transaction (SQLite): the single-fix
    post, the boat's everyday request (bench.server, issue 17 item 8)."""
    newest = max(batch, key=lambda f: f.recorded_at)
    summary = fix_summary(newest)
    if connection.vendor == "postgresql":
        inserted = sql.insert_with_vessel(
            vessel.pk, batch, now, newest=newest, summary=summary, key_id=key_id
        )
        if inserted is None:
            raise KeyRefused
        return inserted
    with transaction.atomic():
        new, finished = sql.insert_sqlite_in_one_transaction(
            vessel.pk, batch, now, newest=newest, summary=summary, key_id=key_id
        )
        if not finished:
            # Duplicates (a store-and-forward retry) or a key that no longer works: which one
            # is asked under the same lock; the marks and the vessel then for the new alone.
            if key_id is not None and not vessel_key_works(key_id):
                raise KeyRefused
            sql.mark_dirty(vessel.pk, [f.recorded_at for f in new])
            _advance_last_fix(vessel, new, now)
    return [f.recorded_at for f in new]


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
    """A fix as the boat API takes it (docs/api.md): the copy kept on Vessel.last_fix, and what
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
    with transaction.atomic():
        minutes = sql.dirty_claim(vessel_id, max_span_s)
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
    fixes = sql.raw_fixes(vessel_id, lo, hi)
    minute = WIDTHS[0]
    groups = group_by_bucket(fixes, minute, lambda f: f[0])
    sql.replace_buckets(
        vessel_id, minute, lo, hi, [summarize(start, group) for start, group in groups.items()]
    )
    for finer, width in zip(WIDTHS, WIDTHS[1:], strict=False):
        lo, hi = bucket_start(lo, width), -(-hi // width) * width
        parts = sql.buckets(vessel_id, finer, lo, hi)
        groups = group_by_bucket(parts, width, lambda s: s.start)
        merged = [merge(start, group) for start, group in groups.items()]
        sql.replace_buckets(vessel_id, width, lo, hi, merged)


def fixes_delete(*, fixes: QuerySet[Fix]) -> int:
    """Delete fixes (the admin's delete) and mark their minutes for the track overview."""
    with transaction.atomic():
        marks: dict[int, list[dt.datetime]] = {}
        for vessel_id, recorded_at in fixes.values_list("vessel_id", "recorded_at").iterator():
            marks.setdefault(vessel_id, []).append(recorded_at)
        for vessel_id, times in marks.items():
            for start in range(0, len(times), sql.INSERT_CHUNK):
                sql.mark_dirty(vessel_id, times[start : start + sql.INSERT_CHUNK])
        deleted, _ = Fix.objects.filter(pk__in=fixes.values("pk")).delete()
    return deleted
