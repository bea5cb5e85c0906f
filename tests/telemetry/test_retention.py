"""Retention (issue 19 item 6): old fixes thinned to the first and last of each interval, alert
fixes and recent fixes kept, dry runs, marks, the overview after a prune, and ingest carrying on
while a prune runs."""

from __future__ import annotations

import datetime as dt
import math
import threading
from typing import Any

import pytest
from django.core.management import CommandError, call_command
from django.db import connections

from alerts.models import Alert, AlertRule
from telemetry import retention
from telemetry.models import Fix, FixThinning, TrackDirty
from telemetry.overview import WIDTHS, bucket_start
from telemetry.retention import fixes_prune
from telemetry.services import fix_ingest, track_overview_rebuild, track_overview_refresh
from telemetry.track import series, track
from tests.support import iso
from vessels.models import Vessel

BASE = dt.datetime(2026, 11, 1, tzinfo=dt.UTC)
DAY = dt.timedelta(days=1)
NOW = BASE + 10 * DAY  # with 7 days' retention the cutoff is BASE + 3 days
CUTOFF = BASE + 3 * DAY


def no_rest(seconds: float) -> None:
    pass


def record(when: dt.datetime, i: int = 0) -> dict[str, Any]:
    return {
        "time": iso(when),
        "lat": -32 + 0.01 * math.sin(i / 30),
        "lon": 115.7 + 0.0001 * i,
        "battery_v": 12 + (i % 50) / 100,
        "readings": {"water_temp_c": 18 + (i % 7) / 10},
    }


def load(vessel: Vessel, start: dt.datetime, seconds: int, step: int = 10) -> list[dt.datetime]:
    """Fixes every ``step`` s for ``seconds`` from ``start``, received soon after."""
    times = [start + dt.timedelta(seconds=s) for s in range(0, seconds, step)]
    for at in range(0, len(times), 1000):
        chunk = times[at : at + 1000]
        records = [record(t, at + i) for i, t in enumerate(chunk)]
        fix_ingest(vessel=vessel, records=records, now=chunk[-1] + dt.timedelta(minutes=1))
    return times


def stored(vessel: Vessel) -> list[dt.datetime]:
    return list(vessel.fixes.order_by("recorded_at").values_list("recorded_at", flat=True))


def prune(**kwargs: Any) -> retention.PruneResult:
    kwargs.setdefault("now", NOW)
    kwargs.setdefault("older_than_days", 7)
    kwargs.setdefault("interval_s", 60)
    kwargs.setdefault("sleep", no_rest)
    return fixes_prune(**kwargs)


def first_and_last_per_minute(times: list[dt.datetime], interval: int = 60) -> list[dt.datetime]:
    minutes: dict[int, list[dt.datetime]] = {}
    for t in times:
        minutes.setdefault(bucket_start(t.timestamp(), interval), []).append(t)
    return sorted({t for group in minutes.values() for t in (group[0], group[-1])})


@pytest.fixture
def small_steps(monkeypatch: pytest.MonkeyPatch) -> None:
    """Reads and transactions of a few fixes: a test's history spans many of each."""
    monkeypatch.setattr(retention, "READ_ROWS", 37)
    monkeypatch.setattr(retention, "DELETE_ROWS_START", 5)
    for vendor in ("sqlite", "postgresql"):
        monkeypatch.setitem(retention.PACE, vendor, retention.Pace(8, hold_s=1.0, pause_s=0))


# --- what is kept ---


@pytest.mark.django_db
def test_it_keeps_the_first_and_last_fix_of_each_old_minute(vessel_a: Vessel, small_steps) -> None:
    old = load(vessel_a, BASE, 2 * 3600)
    recent = load(vessel_a, CUTOFF, 3600)
    result = prune()
    assert stored(vessel_a) == first_and_last_per_minute(old) + recent
    (report,) = result.vessels
    assert (report.slug, report.examined, report.deleted) == ("spab", 720, 480)
    assert result.transactions >= 480 // 8  # never more than the Pace's max_rows in one
    assert result.finished


@pytest.mark.django_db
def test_fixes_younger_than_the_retention_are_untouched(vessel_a: Vessel) -> None:
    # 7 days before now falls mid-interval (5 min): that interval is younger in part, so kept
    # whole; the two before it are thinned.
    now = NOW + dt.timedelta(seconds=150)
    times = load(vessel_a, CUTOFF - dt.timedelta(minutes=10), 20 * 60)
    prune(now=now, interval_s=300)
    first, second = times[:30], times[30:60]
    assert stored(vessel_a) == [first[0], first[-1], second[0], second[-1], *times[60:]]


@pytest.mark.django_db
def test_a_fix_that_opened_an_alert_is_kept(vessel_a: Vessel) -> None:
    times = load(vessel_a, BASE, 600)
    middle = vessel_a.fixes.get(recorded_at=times[3])
    rule = AlertRule.objects.create(name="low", kind="battery", threshold=11.5)
    Alert.objects.create(rule=rule, vessel=vessel_a, kind="battery", opened_at=BASE, fix=middle)
    prune()
    assert times[3] in stored(vessel_a)
    assert stored(vessel_a) == sorted({*first_and_last_per_minute(times), times[3]})
    assert Alert.objects.get().fix_id == middle.pk


@pytest.mark.django_db(transaction=True)
def test_a_fix_pointed_at_after_the_check_is_kept(vessel_a: Vessel, monkeypatch) -> None:
    """An alert opening on a fix between the check and the COMMIT: the foreign key (checked at
    COMMIT) refuses the transaction, and the batch is checked and deleted again."""
    times = load(vessel_a, BASE, 600)
    middle = vessel_a.fixes.get(recorded_at=times[3])
    rule = AlertRule.objects.create(name="low", kind="battery", threshold=11.5)
    Alert.objects.create(rule=rule, vessel=vessel_a, kind="battery", opened_at=BASE, fix=middle)
    real, calls = retention.fixes_referenced, []

    def late_check(ids: Any) -> set[int]:
        calls.append(ids)
        return set() if len(calls) == 1 else real(ids)  # the first misses it: made too early

    monkeypatch.setattr(retention, "fixes_referenced", late_check)
    prune()
    assert len(calls) == 2 and calls[0] == calls[1]  # the refused batch, then the same again
    assert stored(vessel_a) == sorted({*first_and_last_per_minute(times), times[3]})
    assert Alert.objects.get().fix_id == middle.pk


@pytest.mark.django_db
def test_the_callers_keep_list_is_kept(vessel_a: Vessel) -> None:
    times = load(vessel_a, BASE, 600)
    chosen = set(vessel_a.fixes.filter(recorded_at__in=times[20:25]).values_list("pk", flat=True))
    asked: list[int] = []

    def keep(ids: Any) -> set[int]:
        asked.extend(ids)
        return chosen & set(ids)

    prune(keep=keep)
    assert set(times[20:25]) <= set(stored(vessel_a))
    assert len(asked) == len(times)


@pytest.mark.django_db
def test_a_fix_received_in_the_last_hour_is_kept_however_old(vessel_a: Vessel) -> None:
    records = [record(BASE + dt.timedelta(seconds=s)) for s in range(0, 60, 10)]
    fix_ingest(vessel=vessel_a, records=records, now=NOW - dt.timedelta(minutes=30))
    assert prune().deleted == 0
    assert len(stored(vessel_a)) == 6
    assert prune(now=NOW + dt.timedelta(hours=1), rescan=True).deleted == 4


# --- dry runs, marks, idempotence ---


@pytest.mark.django_db
def test_a_dry_run_counts_and_deletes_nothing(vessel_a: Vessel, small_steps) -> None:
    load(vessel_a, BASE, 3600)
    before = stored(vessel_a)
    TrackDirty.objects.all().delete()
    dry = prune(dry_run=True)
    assert stored(vessel_a) == before
    assert not TrackDirty.objects.exists() and not FixThinning.objects.exists()
    real = prune()
    assert [(v.examined, v.deleted) for v in dry.vessels] == [
        (v.examined, v.deleted) for v in real.vessels
    ]
    assert real.deleted == 360 - 120


@pytest.mark.django_db
def test_pruning_again_changes_nothing(vessel_a: Vessel, vessel_b: Vessel, small_steps) -> None:
    load(vessel_a, BASE, 3600)
    load(vessel_b, BASE, 1800, step=7)
    prune()
    after = {v.slug: stored(v) for v in (vessel_a, vessel_b)}
    assert prune().deleted == 0  # from the marks: nothing to read
    assert prune(rescan=True).deleted == 0  # from the first fix: nothing to delete
    assert {v.slug: stored(v) for v in (vessel_a, vessel_b)} == after
    marks = FixThinning.objects.order_by("vessel__slug")
    assert [(m.interval_s, m.thinned_before) for m in marks] == [(60, CUTOFF), (60, CUTOFF)]


@pytest.mark.django_db
def test_a_prune_stopped_early_carries_on_where_it_stopped(vessel_a: Vessel, small_steps) -> None:
    times = load(vessel_a, BASE, 3600)
    reads = iter(range(100))
    first = prune(stop=lambda: next(reads) >= 2)  # after three reads
    assert not first.finished and 0 < first.deleted < 240
    mark = FixThinning.objects.get(vessel=vessel_a).thinned_before
    assert BASE < mark < BASE + dt.timedelta(hours=1)
    second = prune()
    assert second.finished and first.deleted + second.deleted == 240
    assert second.vessels[0].examined < len(times)  # it started at the mark, not the beginning
    assert stored(vessel_a) == first_and_last_per_minute(times)


@pytest.mark.django_db
def test_a_prune_out_of_time_stops_before_the_next_vessel(vessel_a: Vessel) -> None:
    load(vessel_a, BASE, 600)
    result = prune(max_seconds=0)
    assert not result.finished and result.deleted == 0 and len(stored(vessel_a)) == 60
    assert prune(max_seconds=60).finished


@pytest.mark.django_db
def test_a_new_interval_thins_the_history_again(vessel_a: Vessel) -> None:
    times = load(vessel_a, BASE, 3600)
    prune(interval_s=60)
    prune(interval_s=600)
    assert stored(vessel_a) == first_and_last_per_minute(times, 600)


@pytest.mark.django_db
def test_retention_off_does_nothing(vessel_a: Vessel, settings: Any) -> None:
    settings.FIX_RETENTION_DAYS = 0
    load(vessel_a, BASE, 600)
    result = fixes_prune(now=NOW)
    assert result.cutoff is None and result.deleted == 0
    assert len(stored(vessel_a)) == 60


# --- the track overview after a prune ---


def rounded(value: Any) -> Any:
    """Means summed from buckets and from fixes differ in the last bits."""
    if isinstance(value, float):
        return round(value, 9)
    if isinstance(value, dict):
        return {k: rounded(v) for k, v in value.items()}
    if isinstance(value, list):
        return [rounded(v) for v in value]
    return value


def overview_reads(vessel: Vessel) -> tuple[Any, ...]:
    start, end = BASE, BASE + 4 * DAY
    t = track(vessel=vessel, start=start, end=end, max_points=500)
    s = series(vessel=vessel, start=start, end=end, max_buckets=200)
    return t.fixes, t.segments, s.starts, rounded(s.channels)


@pytest.mark.django_db
def test_the_prune_leaves_the_overview_rebuilt_from_the_fixes_left(vessel_a: Vessel) -> None:
    load(vessel_a, BASE, 4 * 3600, step=5)
    track_overview_refresh(vessel_id=vessel_a.pk)  # buckets of the full-resolution fixes
    prune()
    assert not TrackDirty.objects.exists()  # nothing left for the rebuild loop
    after_prune = overview_reads(vessel_a)
    track_overview_rebuild(vessel=vessel_a)  # from scratch, from the fixes left
    assert after_prune == overview_reads(vessel_a)
    assert after_prune[0] == vessel_a.fixes.count() == 4 * 60 * 2


@pytest.mark.django_db
def test_reads_between_a_deletion_and_its_rebuild_take_the_fixes_left(
    vessel_a: Vessel, monkeypatch: pytest.MonkeyPatch
) -> None:
    load(vessel_a, BASE, 4 * 3600, step=5)
    track_overview_refresh(vessel_id=vessel_a.pk)
    monkeypatch.setattr(retention._Job, "_refresh_overview", lambda self, vessel_id: None)
    prune()
    thinned = {bucket_start(t.timestamp(), WIDTHS[0]) for t in stored(vessel_a)}
    assert set(TrackDirty.objects.values_list("start", flat=True)) == thinned
    marked = overview_reads(vessel_a)  # the marked minutes are read from their fixes
    track_overview_refresh(vessel_id=vessel_a.pk)
    rebuilt = overview_reads(vessel_a)
    track_overview_rebuild(vessel=vessel_a)
    assert marked == rebuilt == overview_reads(vessel_a)
    assert rebuilt[0] == vessel_a.fixes.count()


# --- the command ---


@pytest.mark.django_db
def test_the_command_prints_each_vessel(vessel_a: Vessel, vessel_b: Vessel, capsys) -> None:
    load(vessel_a, BASE, 600)
    call_command("prune_fixes", "--dry-run", "--older-than-days", "7")
    out = capsys.readouterr().out
    assert "spab: 60 read, would delete 40, kept 20" in out
    assert vessel_b.slug not in out and len(stored(vessel_a)) == 60
    call_command("prune_fixes", "--older-than-days", "7", "--interval", "300", vessel_a.slug)
    assert "spab: 60 read, deleted 56, kept 4" in capsys.readouterr().out


@pytest.mark.django_db
def test_the_command_without_retention_keeps_everything(vessel_a: Vessel, settings, capsys) -> None:
    settings.FIX_RETENTION_DAYS = 0
    call_command("prune_fixes")
    assert "every fix is kept" in capsys.readouterr().out
    with pytest.raises(CommandError, match="no such vessel: nope"):
        call_command("prune_fixes", "--older-than-days", "7", "nope")
    with pytest.raises(CommandError, match="--interval"):
        call_command("prune_fixes", "--older-than-days", "7", "--interval", "0")


# --- ingest carries on ---


@pytest.mark.django_db(transaction=True)
def test_ingest_carries_on_while_a_prune_runs(vessel_a: Vessel, monkeypatch) -> None:
    """A boat posts a fix at a time while its history is thinned: every post is stored."""
    monkeypatch.setattr(retention, "READ_ROWS", 200)
    old = load(vessel_a, BASE, 3 * 3600, step=2)
    posted: list[dt.datetime] = []
    errors: list[BaseException] = []
    done = threading.Event()

    def ingest() -> None:
        try:
            i = 0
            while not done.is_set() or i < 20:
                when = NOW - dt.timedelta(minutes=5) + dt.timedelta(seconds=i)
                result = fix_ingest(vessel=vessel_a, records=[record(when, i)], now=when)
                assert result.accepted == 1
                posted.append(when)
                i += 1
        except BaseException as exc:  # noqa: BLE001 — reported by the main thread
            errors.append(exc)
        finally:
            connections.close_all()

    boat = threading.Thread(target=ingest)
    boat.start()
    try:
        result = prune(sleep=retention.time.sleep)
        during = len(posted)
    finally:
        done.set()
        boat.join(60)
    assert not errors and not boat.is_alive()
    assert during > 0  # posts went in between the prune's transactions
    assert result.deleted == len(old) - len(first_and_last_per_minute(old))
    assert stored(vessel_a) == first_and_last_per_minute(old) + posted
    assert Fix.objects.count() == len(first_and_last_per_minute(old)) + len(posted)
