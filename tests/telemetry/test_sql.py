"""telemetry.sql's statements on whichever database the suite runs on (SQLite, and PostgreSQL
with DATABASE_URL): the range the exports select and the text the database writes, the
overview's reads, and the ingest's and the overview's writes."""

from __future__ import annotations

import csv
import datetime as dt
import json

import pytest
from django.db import connection
from django.test.utils import CaptureQueriesContext

from telemetry import sql
from telemetry.models import Fix, TrackBucket, TrackDirty
from telemetry.overview import Summary
from telemetry.parsing import FixData
from tests.support import BASE
from vessels.models import Vessel


def fix(vessel: Vessel, seconds: float, **fields: object) -> Fix:
    values: dict[str, object] = {"lat": -31.5, "lon": 115.25, "readings": {}, "received_at": BASE}
    values.update(fields)
    return Fix.objects.create(
        vessel=vessel, recorded_at=BASE + dt.timedelta(seconds=seconds), **values
    )


def lines(vessel: Vessel, line: str, start: dt.datetime | None, end: dt.datetime | None) -> list:
    return [text for chunk in sql.export_lines(vessel.pk, start, end, line) for text in chunk]


def test_the_range_is_half_open_in_time_order_and_one_vessels(
    vessel_a: Vessel, vessel_b: Vessel
) -> None:
    for seconds in (30, 0, 10, 20):
        fix(vessel_a, seconds)
    fix(vessel_b, 10)
    start, end = BASE + dt.timedelta(seconds=10), BASE + dt.timedelta(seconds=30)
    times = [row[0] for chunk in sql.export_rows(vessel_a.pk, start, end) for row in chunk]
    assert times == ["2026-11-23T08:00:10Z", "2026-11-23T08:00:20Z"]
    assert len(lines(vessel_a, sql.csv_line_sql(), None, None)) == 4  # open both sides
    assert len(lines(vessel_a, sql.csv_line_sql(), start, None)) == 3


def test_a_row_carries_its_unix_time_numbers_and_readings(vessel_a: Vessel) -> None:
    fix(vessel_a, 1.5, heading_deg=90.0, battery_v=12.5, readings={"t": 19.5})
    [[row]] = list(sql.export_rows(vessel_a.pk, BASE, BASE + dt.timedelta(minutes=1)))
    iso, epoch, lat, lon, heading, speed, battery, readings = row
    assert iso == "2026-11-23T08:00:01.500000Z"
    assert epoch == (BASE + dt.timedelta(seconds=1.5)).timestamp()
    assert (lat, lon, heading, speed, battery) == (-31.5, 115.25, 90.0, None, 12.5)
    assert json.loads(readings) == {"t": 19.5}


def test_the_csv_line_is_the_databases_text_of_each_cell(vessel_a: Vessel) -> None:
    fix(vessel_a, 0, speed_mps=1.25, readings={"say": 'a "b"'})
    [line] = lines(vessel_a, sql.csv_line_sql(), None, None)
    [cells] = list(csv.reader([line]))
    assert cells[0] == "2026-11-23T08:00:00Z"
    assert [float(c) if c else None for c in cells[1:6]] == [-31.5, 115.25, None, 1.25, None]
    assert json.loads(cells[6]) == {"say": 'a "b"'}


def test_the_feature_line_is_a_geojson_point_with_every_value(vessel_a: Vessel) -> None:
    fix(vessel_a, 0, battery_v=12.5, readings={"t": 19.5})
    [line] = lines(vessel_a, sql.feature_line_sql(), None, None)
    assert json.loads(line) == {
        "type": "Feature",
        "geometry": {"type": "Point", "coordinates": [115.25, -31.5]},
        "properties": {
            "time": "2026-11-23T08:00:00Z",
            "heading_deg": None,
            "speed_mps": None,
            "battery_v": 12.5,
            "readings": {"t": 19.5},
        },
    }


# -- the track overview's reads ------------------------------------------------------------------


def test_raw_fixes_and_points_are_the_half_open_range_by_time_in_unix_seconds(
    vessel_a: Vessel, vessel_b: Vessel
) -> None:
    for seconds in (20.25, 0, 10):
        fix(vessel_a, seconds, battery_v=12.5, readings={"t": seconds})
    fix(vessel_b, 10)
    lo, hi = BASE.timestamp(), BASE.timestamp() + 20.25
    assert sql.raw_points(vessel_a.pk, lo, hi) == [
        (lo, -31.5, 115.25),
        (lo + 10, -31.5, 115.25),
    ]
    assert sql.raw_fixes(vessel_a.pk, lo, hi + 1)[2] == (hi, -31.5, 115.25, 12.5, {"t": 20.25})


def test_buckets_read_the_width_asked_and_leave_the_unasked_column_out(vessel_a: Vessel) -> None:
    start = int(BASE.timestamp())
    point = [start + 1.0, -31.5, 115.25]
    for width, at in ((60, start), (60, start + 60), (600, start)):
        TrackBucket.objects.create(
            vessel=vessel_a,
            width=width,
            start=at,
            count=2,
            points=[point, point, point, point, point, point, None, None],
            channels={"": [12.0, 13.0, 25.0, 2.0]},
        )
    [one] = sql.buckets(vessel_a.pk, 60, start, start + 60)
    assert (one.start, one.count, one.first, one.gap) == (start, 2, tuple(point), None)
    assert one.channels == {"": [12.0, 13.0, 25.0, 2.0]}
    [plain] = sql.buckets(vessel_a.pk, 600, start, start + 1, points=False, channels=False)
    assert (plain.first, plain.channels) == (None, {})


def test_dirty_minutes_are_those_touching_the_range(vessel_a: Vessel, vessel_b: Vessel) -> None:
    start = int(BASE.timestamp())
    for minute in (-2, -1, 0, 1, 3):
        TrackDirty.objects.create(vessel=vessel_a, start=start + 60 * minute)
    TrackDirty.objects.create(vessel=vessel_b, start=start)
    # The minute before ends where the range starts; the one at its end starts after it.
    assert sql.dirty_minutes(vessel_a.pk, start, start + 120) == [start, start + 60]
    assert sql.dirty_minutes(vessel_a.pk, start + 30, start + 90) == [start, start + 60]


# -- The ingest's and the overview's writes -------------------------------------------------


def fix_data(seconds: float, **fields: object) -> FixData:
    return FixData(
        recorded_at=BASE + dt.timedelta(seconds=seconds), lat=-31.5, lon=115.25, **fields
    )  # type: ignore[arg-type]


def test_insert_new_stores_each_fix_once_and_names_only_the_new_ones(vessel_a: Vessel) -> None:
    first = [fix_data(0, battery_v=12.5, readings={"t": 1.0}), fix_data(10)]
    assert sql.insert_new(vessel_a.pk, first, BASE) == [f.recorded_at for f in first]
    again = [fix_data(10), fix_data(20, heading_deg=90.0)]
    assert sql.insert_new(vessel_a.pk, again, BASE) == [again[1].recorded_at]
    stored = Fix.objects.filter(vessel=vessel_a).order_by("recorded_at")
    assert [(f.battery_v, f.heading_deg, f.readings) for f in stored] == [
        (12.5, None, {"t": 1.0}),
        (None, None, {}),
        (None, 90.0, {}),
    ]
    assert {f.received_at for f in stored} == {BASE}


def test_insert_new_goes_past_one_statements_chunk(vessel_a: Vessel) -> None:
    fixes = [fix_data(n) for n in range(sql.INSERT_CHUNK + 3)]
    assert len(sql.insert_new(vessel_a.pk, fixes, BASE)) == len(fixes)
    assert Fix.objects.filter(vessel=vessel_a).count() == len(fixes)


def test_marks_are_the_minutes_of_the_times_once_each(vessel_a: Vessel) -> None:
    start = int(BASE.timestamp())
    times = [BASE + dt.timedelta(seconds=s) for s in (0, 30, 59, 60, 185)]
    sql.mark_dirty(vessel_a.pk, times)
    sql.mark_dirty(vessel_a.pk, times[:2])  # marked again: still one mark
    sql.mark_dirty(vessel_a.pk, [])
    marks = sorted(TrackDirty.objects.filter(vessel=vessel_a).values_list("start", flat=True))
    assert marks == [start, start + 60, start + 180]


def test_a_claim_takes_the_marks_or_those_near_the_oldest(
    vessel_a: Vessel, vessel_b: Vessel
) -> None:
    start = int(BASE.timestamp())
    for minute in (0, 1, 5, 60):
        TrackDirty.objects.create(vessel=vessel_a, start=start + 60 * minute)
    TrackDirty.objects.create(vessel=vessel_b, start=start)
    assert sql.dirty_claim(vessel_a.pk, max_span_s=301) == [start, start + 60, start + 300]
    assert sql.dirty_claim(vessel_a.pk) == [start + 3600]
    assert sql.dirty_claim(vessel_a.pk) == []
    assert TrackDirty.objects.filter(vessel=vessel_b).count() == 1


def test_replace_buckets_replaces_only_that_width_and_range(vessel_a: Vessel) -> None:
    start = int(BASE.timestamp())
    point = (start + 1.0, -31.5, 115.25)
    for width, at in ((60, start), (60, start + 60), (60, start + 120), (600, start)):
        TrackBucket.objects.create(
            vessel=vessel_a, width=width, start=at, count=1, points=[None] * 8, channels={}
        )
    new = Summary(start + 60, 3, point, point, point, point, point, point, None, {"": [1, 2, 3, 3]})
    sql.replace_buckets(vessel_a.pk, 60, start, start + 120, [new])
    kept = TrackBucket.objects.filter(vessel=vessel_a).order_by("width", "start")
    assert [(b.width, b.start, b.count) for b in kept] == [
        (60, start + 60, 3),
        (60, start + 120, 1),
        (600, start, 1),
    ]
    [read] = sql.buckets(vessel_a.pk, 60, start + 60, start + 61)
    assert read == new
    sql.replace_buckets(vessel_a.pk, 600, start, start + 600, [])  # nothing left in the range
    assert not TrackBucket.objects.filter(vessel=vessel_a, width=600).exists()


@pytest.mark.postgres
def test_the_one_statement_post_inserts_marks_and_advances_the_vessel(vessel_a: Vessel) -> None:
    if connection.vendor != "postgresql":
        pytest.skip("one statement with data-modifying CTEs: PostgreSQL only")
    fixes = [fix_data(0), fix_data(90)]
    with CaptureQueriesContext(connection) as queries:
        new = sql.insert_with_vessel(
            vessel_a.pk, fixes, BASE, newest=fixes[1], summary={"time": "newest"}
        )
    assert len(queries) == 1 and new == [f.recorded_at for f in fixes]
    vessel_a.refresh_from_db()
    assert vessel_a.last_fix == {"time": "newest"} and vessel_a.last_seen_at == BASE
    start = int(BASE.timestamp())
    assert sorted(TrackDirty.objects.values_list("start", flat=True)) == [start, start + 60]
    # The same newest fix again is no news: seen moves, the last fix stays.
    later = BASE + dt.timedelta(hours=1)
    assert sql.insert_with_vessel(vessel_a.pk, fixes[1:], later, newest=fixes[1], summary={}) == []
    vessel_a.refresh_from_db()
    assert vessel_a.last_fix == {"time": "newest"} and vessel_a.last_seen_at == later


def test_fixes_delete_deletes_those_ids_in_one_statement(
    vessel_a: Vessel, vessel_b: Vessel
) -> None:
    fixes = [fix(vessel_a, s) for s in range(5)] + [fix(vessel_b, 2)]
    with CaptureQueriesContext(connection) as queries:
        sql.fixes_delete([fixes[1].pk, fixes[3].pk, fixes[5].pk])
    assert len(queries) == 1
    assert list(Fix.objects.order_by("pk").values_list("pk", flat=True)) == [
        fixes[0].pk, fixes[2].pk, fixes[4].pk,
    ]  # fmt: skip
