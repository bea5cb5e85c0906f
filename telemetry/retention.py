"""Retention (issue 19 item 6): thin old fixes in small batches that never hold up ingest.

Fixes older than FIX_RETENTION_DAYS are thinned to the first and last fix of each
FIX_THIN_INTERVAL_S (telemetry/thinning.py), keeping every fix another record points at (an
alert's opening fix) and every fix received in the last RECEIVED_GRACE_S. Run by
`manage.py prune_fixes` and by the alerts loop when FIX_RETENTION_DAYS is set.

Why it never holds up a boat's post:
- the fixes are read outside any transaction, READ_ROWS at a time (keyset on the (vessel, time)
  index), and deleted in transactions sized to hold the database briefly (PACE: SQLite has one
  writer, and a post waits for the whole transaction), one DELETE by id each (sql.fixes_delete);
- between two transactions it rests at least as long as it held the database, and never less
  than the PACE's pause, so a waiting post always gets its turn;
- every transaction stands alone: stopped anywhere, the next run carries on (FixThinning keeps
  how far each vessel is thinned), and thinning again changes nothing.

The track overview stays right: each transaction marks the minutes it deletes from out of date
(TrackDirty, as the admin's delete does), so reads take those minutes from the fixes left; and
after each read's deletions the prune rebuilds those minutes' buckets itself, in short
transactions of their own (track_overview_refresh, an hour of minutes at a time). The overview
then summarises the fixes that are stored, as the exports and the fix list do: one story at
every zoom, and the same story after `rebuild_track_overview` rebuilds it from scratch.
"""

from __future__ import annotations

import datetime as dt
import logging
import time
from collections.abc import Callable, Collection, Iterable, Sequence
from dataclasses import dataclass, field

from django.conf import settings
from django.db import IntegrityError, connection, transaction
from django.db.models import BooleanField, ExpressionWrapper, Q

from telemetry import sql
from telemetry.models import Fix, FixThinning, TrackDirty
from telemetry.services import track_overview_refresh
from telemetry.thinning import Thinner, interval_start
from vessels.models import Vessel

logger = logging.getLogger(__name__)

# Fixes read per query: memory stays flat whatever the history (an hour and a half at 1 Hz).
READ_ROWS = 5000
# Fixes deleted per transaction start at DELETE_ROWS_START, are halved (down to DELETE_ROWS_MIN)
# while a transaction holds the database longer than its Pace's hold_s, and grow back (up to
# max_rows) while it is quicker.
DELETE_ROWS_MIN = 25
DELETE_ROWS_START = 200


@dataclass(frozen=True)
class Pace:
    """How hard a prune leans on the database: rows per transaction at most, how long one
    transaction should hold it, and the least rest after one (never less than the hold)."""

    max_rows: int
    hold_s: float
    pause_s: float


PACE = {
    # One writer: a post waits for the whole transaction, so it is kept short, and shorter than
    # the work alone needs: on a busy machine the prune may lose its CPU while it holds the
    # lock (bench.retention: 2,000-row transactions of 20 ms of work held it 100 ms at times).
    # The rest: SQLite's busy handler (sqliteDefaultBusyCallback) lets a waiting writer try
    # again after 1, 2, 5, 10, 15, 20, 25, 25, 25, 50 … ms, so a gap over 25 ms lets in every
    # writer that has waited less than ~180 ms.
    "sqlite": Pace(max_rows=500, hold_s=0.01, pause_s=0.03),
    # Row locks: a post waits on no lock thinning takes (old rows, old minutes). A short
    # transaction's time is mostly its COMMIT's flush, so bigger ones cost little more; the rest
    # (as long as the hold) leaves the disk to the posts half the time.
    "postgresql": Pace(max_rows=2000, hold_s=0.05, pause_s=0.005),
}

# A fix received this recently is not thinned, however old its time: the alerts loop looks at
# the fixes that arrived since its last pass, and an alert it opens on one keeps that fix.
RECEIVED_GRACE_S = 3600

# A vessel is thinned an hour at a time at least: called every minute (the alerts loop), a
# prune does not write a mark per vessel per minute.
STEP_S = 3600

# The overview of the thinned minutes is rebuilt an hour of them per transaction.
REFRESH_SPAN_S = 3600

# Given fix ids, the ones to keep for the caller's own reasons.
KeepFn = Callable[[Sequence[int]], Collection[int]]


@dataclass
class VesselPrune:
    """One vessel's part of a prune: fixes read (older than the cutoff) and deleted (or, in a
    dry run, that would be)."""

    slug: str
    examined: int = 0
    deleted: int = 0

    @property
    def kept(self) -> int:
        return self.examined - self.deleted


@dataclass
class PruneResult:
    cutoff: dt.datetime | None  # None: retention is off (FIX_RETENTION_DAYS=0)
    interval_s: int
    dry_run: bool
    vessels: list[VesselPrune] = field(default_factory=list)
    # False: stopped early (max_seconds, stop); the next call carries on.
    finished: bool = True
    transactions: int = 0
    longest_hold_s: float = 0.0

    @property
    def deleted(self) -> int:
        return sum(v.deleted for v in self.vessels)

    @property
    def examined(self) -> int:
        return sum(v.examined for v in self.vessels)


class _Stopped(Exception):
    pass


def fixes_prune(
    *,
    now: dt.datetime,
    older_than_days: int | None = None,
    interval_s: int | None = None,
    dry_run: bool = False,
    keep: KeepFn | None = None,
    vessels: Iterable[Vessel] | None = None,
    rescan: bool = False,
    max_seconds: float | None = None,
    stop: Callable[[], bool] | None = None,
    sleep: Callable[[float], None] = time.sleep,
) -> PruneResult:
    """Thin every vessel's fixes older than ``older_than_days`` (default FIX_RETENTION_DAYS;
    0 does nothing) to the first and last of each ``interval_s`` (FIX_THIN_INTERVAL_S).

    1. The cutoff is ``now`` less the retention, down to a whole interval: only whole
       intervals are thinned, and a younger fix is never read.
    2. Per vessel, from where the last prune stopped (FixThinning; from its first fix with
       ``rescan``, or after a change of interval), the fixes are read in time order, READ_ROWS
       at a time, and fed to a Thinner; kept for their own sake are the fixes another record
       points at (fixes_referenced), those ``keep`` names, and those received since
       ``now`` - RECEIVED_GRACE_S.
    3. What the Thinner gives up is deleted in short transactions (see the module's notes),
       each marking its minutes out of date for the track overview, whose buckets are then
       rebuilt from the fixes left; then the vessel's mark moves on. A dry run deletes
       nothing and moves no mark.
    4. ``max_seconds`` or ``stop()`` end the prune between two reads or two vessels; the
       result says ``finished=False`` and the next call carries on.
    """
    days = settings.FIX_RETENTION_DAYS if older_than_days is None else older_than_days
    interval = interval_s or settings.FIX_THIN_INTERVAL_S
    if days <= 0:
        return PruneResult(cutoff=None, interval_s=interval, dry_run=dry_run)
    cutoff = sql.from_epoch(interval_start((now - dt.timedelta(days=days)).timestamp(), interval))
    result = PruneResult(cutoff=cutoff, interval_s=interval, dry_run=dry_run)
    deadline = None if max_seconds is None else time.monotonic() + max_seconds

    def should_stop() -> bool:
        return (stop is not None and stop()) or (
            deadline is not None and time.monotonic() > deadline
        )

    pacer = _Pacer(sleep=sleep, pace=PACE.get(connection.vendor, PACE["postgresql"]))
    job = _Job(cutoff, interval, now - dt.timedelta(seconds=RECEIVED_GRACE_S), keep, pacer)
    for vessel in Vessel.objects.order_by("pk") if vessels is None else vessels:
        if should_stop():
            result.finished = False
            break
        report = VesselPrune(vessel.slug)
        try:
            job.vessel(vessel, report, dry_run=dry_run, rescan=rescan, should_stop=should_stop)
        except _Stopped:
            result.finished = False
        if report.examined:
            result.vessels.append(report)
            logger.info(
                "prune_fixes: %s: %d fixes older than %s, %s %d",
                vessel.slug, report.examined, cutoff.isoformat(),
                "would delete" if dry_run else "deleted", report.deleted,
            )  # fmt: skip
        if not result.finished:
            break
    result.transactions, result.longest_hold_s = pacer.transactions, pacer.longest
    return result


def fixes_referenced(ids: Sequence[int]) -> set[int]:
    """The fixes among ``ids`` that another record points at (an alert's opening fix, today).

    The foreign keys are found in Django's model registry, not imported: telemetry sits below
    the apps that point at fixes (tests/fleet/test_layers.py) and keeps what they point at
    without knowing them, and a new one (an audit entry, a report) is covered as it is added.
    """
    found: set[int] = set()
    for model, name in _pointers_to_fixes():
        rows = model._base_manager.filter(**{f"{name}__in": ids}).values_list(name, flat=True)
        found.update(r for r in rows if r is not None)
    return found


def _pointers_to_fixes() -> list[tuple[type, str]]:
    """(model, field name) of every foreign key, one-to-one or many-to-many to Fix."""
    return [
        (rel.related_model, rel.field.name)
        for rel in Fix._meta.get_fields(include_hidden=True)
        if rel.auto_created and not rel.concrete and rel.is_relation
    ]


@dataclass
class _Pacer:
    """Sizes the delete transactions and rests between them (module notes, Pace)."""

    sleep: Callable[[float], None]
    pace: Pace
    rows: int = DELETE_ROWS_START
    transactions: int = 0
    longest: float = 0.0

    def held(self, seconds: float, *, resize: bool = True) -> None:
        """A transaction held the database ``seconds``: size the next delete (``resize``),
        then rest."""
        self.transactions += 1
        self.longest = max(self.longest, seconds)
        if resize and seconds > self.pace.hold_s:
            self.rows = max(DELETE_ROWS_MIN, self.rows // 2)
        elif resize and seconds < self.pace.hold_s / 2:
            self.rows = min(self.pace.max_rows, self.rows + self.rows // 4 + 1)
        self.sleep(max(self.pace.pause_s, seconds))


@dataclass
class _Job:
    cutoff: dt.datetime
    interval_s: int
    received_before: dt.datetime
    keep: KeepFn | None
    pacer: _Pacer

    def vessel(
        self,
        vessel: Vessel,
        report: VesselPrune,
        *,
        dry_run: bool,
        rescan: bool,
        should_stop: Callable[[], bool],
    ) -> None:
        """Thin one vessel's fixes before the cutoff, from its mark; raise _Stopped if told."""
        mark = None if rescan else FixThinning.objects.filter(vessel=vessel).first()
        after = mark.thinned_before if mark and mark.interval_s == self.interval_s else None
        if after is not None and (self.cutoff - after).total_seconds() < STEP_S:
            return
        thinner = Thinner(self.interval_s)
        times: dict[int, dt.datetime] = {}
        inclusive = True  # the first read starts at the mark (an interval's start), the next after
        while True:
            rows = self._read(vessel.pk, after, inclusive)
            if not rows:
                break
            ids = [pk for pk, _, _ in rows]
            # The fixes pointed at are left out where they are deleted, under the lock (a
            # Thinner that takes one for an ordinary fix gives the same survivors); a dry run
            # leaves them out here.
            kept = set(self.keep(ids)) if self.keep else set()
            if dry_run:
                kept |= fixes_referenced(ids)
            times.update((pk, t) for pk, t, _ in rows)
            doomed = thinner.feed((pk, t.timestamp(), new or pk in kept) for pk, t, new in rows)
            report.examined += len(rows)
            if dry_run:
                report.deleted += len(doomed)
            else:
                report.deleted += self._delete(vessel.pk, doomed, times)
                self._refresh_overview(vessel.pk)
                self._save_mark(vessel, sql.from_epoch(thinner.open_start))  # type: ignore[arg-type]
            times = {thinner.pending: times[thinner.pending]} if thinner.pending else {}
            after, inclusive = rows[-1][1], False
            if len(rows) < READ_ROWS:
                break
            if should_stop():
                raise _Stopped
        if not dry_run:
            self._save_mark(vessel, self.cutoff)  # the pending fix, if any, was its interval's last

    def _read(
        self, vessel_id: int, after: dt.datetime | None, inclusive: bool
    ) -> list[tuple[int, dt.datetime, bool]]:
        """The next READ_ROWS fixes before the cutoff, (id, time, received too recently)."""
        fixes = Fix.objects.filter(vessel_id=vessel_id, recorded_at__lt=self.cutoff)
        if after is not None:
            fixes = (
                fixes.filter(recorded_at__gte=after)
                if inclusive
                else fixes.filter(recorded_at__gt=after)
            )
        recent = ExpressionWrapper(
            Q(received_at__gte=self.received_before), output_field=BooleanField()
        )
        rows = fixes.order_by("recorded_at").annotate(recent=recent)
        return [
            (pk, t, bool(r))
            for pk, t, r in rows.values_list("pk", "recorded_at", "recent")[:READ_ROWS]
        ]

    def _delete(self, vessel_id: int, doomed: list[int], times: dict[int, dt.datetime]) -> int:
        """Delete ``doomed`` but the fixes pointed at, a short transaction at a time; how many."""
        deleted, at = 0, 0
        while at < len(doomed):
            chunk = doomed[at : at + self.pacer.rows]
            at += len(chunk)
            started = time.perf_counter()
            try:
                deleted += self._delete_chunk(vessel_id, chunk, times)
            except IntegrityError:
                # PostgreSQL: a record pointing at one of them was committed after the check
                # (the foreign key is checked at COMMIT): check again.
                logger.info("prune_fixes: a fix was pointed at meanwhile; trying again")
                deleted += self._delete_chunk(vessel_id, chunk, times)
            self.pacer.held(time.perf_counter() - started)
        return deleted

    def _delete_chunk(self, vessel_id: int, chunk: list[int], times: dict[int, dt.datetime]) -> int:
        with transaction.atomic():
            # In the transaction: on SQLite nothing can point at them before it commits.
            pointed_at = fixes_referenced(chunk)
            chunk = [pk for pk in chunk if pk not in pointed_at]
            if chunk:
                sql.mark_dirty(vessel_id, [times[pk] for pk in chunk])
                sql.fixes_delete(chunk)
        return len(chunk)

    def _refresh_overview(self, vessel_id: int) -> None:
        """Rebuild the overview of the minutes thinned so far (marked by _delete_chunk), an hour
        of them per transaction, as the rebuild loop would, but now: left to the loop, a long
        prune's marks pile up into its day-long rebuild transactions (bench.retention: 300 ms
        on SQLite, a post waiting all that time)."""
        cutoff = self.cutoff.timestamp()
        while TrackDirty.objects.filter(vessel_id=vessel_id, start__lt=cutoff).exists():
            started = time.perf_counter()
            track_overview_refresh(vessel_id=vessel_id, max_span_s=REFRESH_SPAN_S)
            self.pacer.held(time.perf_counter() - started, resize=False)

    def _save_mark(self, vessel: Vessel, thinned_before: dt.datetime) -> None:
        FixThinning.objects.update_or_create(
            vessel=vessel,
            defaults={"interval_s": self.interval_s, "thinned_before": thinned_before},
        )
