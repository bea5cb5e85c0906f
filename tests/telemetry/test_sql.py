"""telemetry.sql's export statements on whichever database the suite runs on (SQLite, and
PostgreSQL with DATABASE_URL): the range they select and the text the database writes."""

from __future__ import annotations

import csv
import datetime as dt
import json

from telemetry import sql
from telemetry.models import Fix
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
