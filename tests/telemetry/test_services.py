"""fix_ingest: idempotent batches, per-fix errors, and the vessel's last fix."""

from __future__ import annotations

import datetime as dt
from typing import Any

import pytest

from telemetry import sql
from telemetry.models import Fix
from telemetry.services import fix_ingest
from vessels.models import Vessel

pytestmark = pytest.mark.django_db

NOW = dt.datetime(2026, 11, 23, 10, 0, tzinfo=dt.UTC)
BASE = dt.datetime(2026, 11, 23, 8, 0, tzinfo=dt.UTC)


def rec(seconds: float, **extra: Any) -> dict[str, Any]:
    when = BASE + dt.timedelta(seconds=seconds)
    return {"time": when.isoformat(), "lat": -32 + seconds / 1e5, "lon": 115.7, **extra}


def test_it_stores_a_batch_and_reports_counts(vessel_a: Vessel) -> None:
    result = fix_ingest(vessel=vessel_a, records=[rec(0), rec(1, battery_v=12.1)], now=NOW)
    assert result.as_dict() == {"accepted": 2, "duplicates": 0, "rejected": []}
    fixes = list(vessel_a.fixes.order_by("recorded_at"))
    assert [f.recorded_at for f in fixes] == [BASE, BASE + dt.timedelta(seconds=1)]
    assert fixes[1].battery_v == 12.1
    assert all(f.received_at == NOW for f in fixes)


def test_resending_a_batch_is_a_no_op(vessel_a: Vessel) -> None:
    batch = [rec(i, readings={"t": i}) for i in range(5)]
    fix_ingest(vessel=vessel_a, records=batch, now=NOW)
    stored = list(Fix.objects.order_by("pk").values())
    again = fix_ingest(vessel=vessel_a, records=batch, now=NOW + dt.timedelta(minutes=1))
    assert again.as_dict() == {"accepted": 0, "duplicates": 5, "rejected": []}
    assert list(Fix.objects.order_by("pk").values()) == stored  # first copy kept, untouched


def test_a_resent_fix_with_different_values_keeps_the_first(vessel_a: Vessel) -> None:
    fix_ingest(vessel=vessel_a, records=[rec(0, battery_v=12.0)], now=NOW)
    result = fix_ingest(vessel=vessel_a, records=[rec(0, battery_v=9.0)], now=NOW)
    assert (result.accepted, result.duplicates) == (0, 1)
    assert vessel_a.fixes.get().battery_v == 12.0


def test_duplicates_inside_a_batch_count_once_and_the_first_wins(vessel_a: Vessel) -> None:
    same_instant = BASE.astimezone(dt.timezone(dt.timedelta(hours=2)))  # 10:00+02:00
    batch = [
        rec(0, battery_v=1.0),
        rec(0, battery_v=2.0),
        {"time": same_instant.isoformat(), "lat": 0, "lon": 0},  # 08:00Z written as +02:00
        {"time": BASE.timestamp(), "lat": 0, "lon": 0},  # and as Unix seconds
        rec(1),
    ]
    result = fix_ingest(vessel=vessel_a, records=batch, now=NOW)
    assert result.as_dict() == {"accepted": 2, "duplicates": 3, "rejected": []}
    first = vessel_a.fixes.get(recorded_at=BASE)
    assert first.battery_v == 1.0


def test_same_time_on_two_vessels_is_two_fixes(vessel_a: Vessel, vessel_b: Vessel) -> None:
    fix_ingest(vessel=vessel_a, records=[rec(0)], now=NOW)
    result = fix_ingest(vessel=vessel_b, records=[rec(0)], now=NOW)
    assert result.accepted == 1
    assert Fix.objects.count() == 2


def test_bad_records_are_reported_and_the_good_ones_stored(vessel_a: Vessel) -> None:
    result = fix_ingest(
        vessel=vessel_a,
        records=[rec(0), {"lat": 0}, rec(2, lat=-100), "x", rec(4)],
        now=NOW,
    )
    assert result.accepted == 2
    assert [r["index"] for r in result.rejected] == [1, 2, 3]
    assert result.rejected[1]["errors"] == {"lat": "must be between -90 and 90"}
    assert vessel_a.fixes.count() == 2


def test_an_empty_batch_still_marks_the_vessel_seen(vessel_a: Vessel) -> None:
    assert fix_ingest(vessel=vessel_a, records=[], now=NOW).as_dict() == {
        "accepted": 0,
        "duplicates": 0,
        "rejected": [],
    }
    vessel_a.refresh_from_db()
    assert (vessel_a.last_seen_at, vessel_a.last_fix) == (NOW, None)


def test_the_last_fix_moves_forward_only(vessel_a: Vessel) -> None:
    fix_ingest(vessel=vessel_a, records=[rec(60, battery_v=12.5, readings={"t": 1})], now=NOW)
    vessel_a.refresh_from_db()
    assert vessel_a.last_fix_at == BASE + dt.timedelta(seconds=60)
    assert vessel_a.last_fix == {
        "time": "2026-11-23T08:01:00+00:00",
        "lat": pytest.approx(-32 + 60 / 1e5),
        "lon": 115.7,
        "battery_v": 12.5,
        "readings": {"t": 1.0},
    }

    # A store-and-forward backlog arrives later: older fixes, newer receive time.
    later = NOW + dt.timedelta(minutes=5)
    result = fix_ingest(vessel=vessel_a, records=[rec(0), rec(30)], now=later)
    assert result.accepted == 2
    vessel_a.refresh_from_db()
    assert vessel_a.last_fix_at == BASE + dt.timedelta(seconds=60)
    assert vessel_a.last_fix["battery_v"] == 12.5
    assert vessel_a.last_seen_at == later

    fix_ingest(vessel=vessel_a, records=[rec(30), rec(90), rec(75)], now=later)
    vessel_a.refresh_from_db()
    assert vessel_a.last_fix_at == BASE + dt.timedelta(seconds=90)
    assert vessel_a.last_fix["time"] == "2026-11-23T08:01:30+00:00"


def test_a_batch_of_duplicates_does_not_move_the_last_fix(vessel_a: Vessel) -> None:
    fix_ingest(vessel=vessel_a, records=[rec(0, battery_v=11.0)], now=NOW)
    Vessel.objects.filter(pk=vessel_a.pk).update(last_fix=None, last_fix_at=None)
    fix_ingest(vessel=vessel_a, records=[rec(0, battery_v=11.0)], now=NOW)
    vessel_a.refresh_from_db()
    assert vessel_a.last_fix is None  # nothing new was stored, so nothing to show


def test_a_batch_over_one_insert_chunk_is_stored_whole(vessel_a: Vessel) -> None:
    size = sql.INSERT_CHUNK * 2 + 500
    batch = [rec(i) for i in range(size)]
    result = fix_ingest(vessel=vessel_a, records=batch, now=NOW)
    assert result.as_dict() == {"accepted": size, "duplicates": 0, "rejected": []}
    assert vessel_a.fixes.count() == size
    vessel_a.refresh_from_db()
    assert vessel_a.last_fix_at == BASE + dt.timedelta(seconds=size - 1)

    # Overlapping re-send across chunk boundaries: only the new tail is stored.
    overlap = [rec(i) for i in range(size - 1200, size + 300)]
    result = fix_ingest(vessel=vessel_a, records=overlap, now=NOW)
    assert (result.accepted, result.duplicates) == (300, 1200)
    assert vessel_a.fixes.count() == size + 300


def test_microsecond_times_survive_the_round_trip(vessel_a: Vessel) -> None:
    times = [BASE + dt.timedelta(microseconds=us) for us in (1, 2, 999_999)]
    result = fix_ingest(
        vessel=vessel_a,
        records=[{"time": t.isoformat(), "lat": 0, "lon": 0} for t in times],
        now=NOW,
    )
    assert result.accepted == 3
    assert sorted(vessel_a.fixes.values_list("recorded_at", flat=True)) == times
    again = fix_ingest(
        vessel=vessel_a,
        records=[{"time": t.isoformat(), "lat": 0, "lon": 0} for t in times],
        now=NOW,
    )
    assert again.duplicates == 3


def test_legacy_records_go_through_the_legacy_parser(vessel_a: Vessel) -> None:
    result = fix_ingest(
        vessel=vessel_a,
        records=[
            {"timestamp": 1536551550, "latitude": -31.9505, "longitude": 115.8605, "t": 301.3},
            {"timestamp": 77, "latitude": -31.9, "longitude": 115.8},
            {"timestamp": 78, "latitude": -31.9, "longitude": 115.8},
        ],
        legacy=True,
        now=NOW,
    )
    assert result.as_dict() == {"accepted": 3, "duplicates": 0, "rejected": []}
    received = list(
        vessel_a.fixes.filter(recorded_at__gte=NOW)
        .order_by("recorded_at")
        .values_list("recorded_at", "readings")
    )
    assert received == [
        (NOW + dt.timedelta(microseconds=1), {"timestamp_raw": 77.0}),
        (NOW + dt.timedelta(microseconds=2), {"timestamp_raw": 78.0}),
    ]
