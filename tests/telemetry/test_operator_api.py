"""Operator reads of a vessel's fixes: JSON cursor pages and CSV."""

from __future__ import annotations

import csv
import io
import json
from typing import Any

import pytest
from rest_framework.test import APIClient

from telemetry.services import fix_ingest
from tests.support import BASE, fixes_url, iso
from vessels.models import Vessel


def test_it_pages_fixes_in_time_order_with_a_cursor(operator: APIClient, track: list) -> None:
    seen: list[str] = []
    url: str | None = fixes_url() + "?page_size=4"
    pages = 0
    while url:
        body = operator.get(url).json()
        assert set(body) == {"next", "previous", "results"}
        seen += [f["time"] for f in body["results"]]
        url = body["next"]
        pages += 1
    assert pages == 3
    assert seen == [iso(t) for t in track]


def test_a_fix_carries_its_values(operator: APIClient, track: list) -> None:
    first = operator.get(fixes_url() + "?page_size=1").json()["results"][0]
    assert first["time"] == "2026-11-23T08:00:00Z"
    assert (first["lat"], first["lon"], first["readings"]) == (-32.0, 115.7, {"t": 0.0, "s": 35.5})
    assert first["heading_deg"] is None


@pytest.mark.parametrize(
    ("query", "expected"),
    [
        ("?from=2026-11-23T08:03:00Z&to=2026-11-23T08:06:00Z", [3, 4, 5]),
        ("?from=2026-11-23T08:08:00Z", [8, 9]),
        ("?to=2026-11-23T08:01:00Z", [0]),
        (f"?from={BASE.timestamp() + 540:.0f}", [9]),
        ("?from=2026-11-23T10:03:00%2B02:00&to=2026-11-23T08:05:00Z", [3, 4]),
        ("?from=2026-11-23T09:00:00Z", []),
    ],
)
def test_it_filters_fixes_by_time_range(
    operator: APIClient, track: list, query: str, expected: list[int]
) -> None:
    body = operator.get(fixes_url() + query).json()
    assert [f["readings"]["t"] for f in body["results"]] == expected


@pytest.mark.parametrize(
    ("query", "field"),
    [("?from=yesterday", "from"), ("?to=2026-11-23T08:00:00", "to"), ("?from=1", "from")],
)
def test_a_bad_time_range_is_a_400_naming_the_parameter(
    operator: APIClient, track: list, query: str, field: str
) -> None:
    response = operator.get(fixes_url() + query)
    assert response.status_code == 400
    body = response.json()
    assert body["error"] == "invalid"
    assert list(body["detail"]) == [field]


def test_only_the_named_vessels_fixes_are_listed(
    operator: APIClient, track: list, vessel_b: Vessel
) -> None:
    fix_ingest(vessel=vessel_b, records=[{"time": iso(BASE), "lat": 1, "lon": 1}])
    assert len(operator.get(fixes_url("spab-2")).json()["results"]) == 1
    assert len(operator.get(fixes_url()).json()["results"]) == 10
    assert operator.get(fixes_url("nope")).status_code == 404


def csv_body(response: Any) -> bytes:
    assert response.status_code == 200
    assert response["Content-Type"] == "text/csv; charset=utf-8"
    return b"".join(response.streaming_content)


def test_it_exports_fixes_as_the_track_exports_csv(operator: APIClient, track: list) -> None:
    response = operator.get(
        fixes_url() + "?format=csv&from=2026-11-23T08:07:00Z&to=2026-11-23T08:09:00Z"
    )
    assert response["Content-Disposition"] == 'attachment; filename="spab-fixes.csv"'
    text = csv_body(response).decode()
    lines = text.split("\r\n")
    assert lines[0] == "time,lat,lon,heading_deg,speed_mps,battery_v,readings"
    assert lines[1].startswith("2026-11-23T08:07:00Z,-31.93,115.7,,,,")
    assert lines[2].startswith("2026-11-23T08:08:00Z,-31.92,115.7,,,,")
    assert lines[3:] == [""]
    rows = list(csv.DictReader(io.StringIO(text)))
    assert [json.loads(r["readings"]) for r in rows] == [
        {"t": 7.0, "s": 35.5},
        {"t": 8.0, "s": 35.5},
    ]


@pytest.mark.parametrize(
    "query",
    [
        "from=2026-11-23T08:02:00Z&to=2026-11-23T08:07:30Z",
        f"from={BASE.timestamp():.0f}&to={BASE.timestamp() + 600:.0f}",
        "from=2026-11-23T09:00:00Z&to=2026-11-23T10:00:00Z",
    ],
)
def test_both_csv_exports_give_the_same_file_for_the_same_range(
    operator: APIClient, track: list, query: str
) -> None:
    fixes = csv_body(operator.get(f"{fixes_url()}?format=csv&{query}"))
    exported = csv_body(operator.get(f"/api/v1/vessels/spab/track/export/?format=csv&{query}"))
    assert fixes == exported


def test_the_fixes_csv_range_may_be_open(operator: APIClient, track: list) -> None:
    whole = csv_body(operator.get(fixes_url() + "?format=csv")).decode()
    assert [r["time"] for r in csv.DictReader(io.StringIO(whole))] == [iso(t) for t in track]
    since = csv_body(operator.get(fixes_url() + "?format=csv&from=2026-11-23T08:08:00Z"))
    assert [r["time"][11:16] for r in csv.DictReader(io.StringIO(since.decode()))] == [
        "08:08",
        "08:09",
    ]


@pytest.mark.parametrize(
    "path", ["fixes/?format=csv", "track/export/?format=csv&from=2026-11-23T00:00:00Z"]
)
@pytest.mark.parametrize("name", ['=HYPERLINK("http://x")', "+1", "@SUM(A1)", "-x"])
def test_the_csv_export_never_starts_a_cell_with_a_formula(
    operator: APIClient, vessel_a: Vessel, name: str, path: str
) -> None:
    # Reading names come from the boat: one must not become a formula in the operator's
    # spreadsheet (CSV injection). Numbers may start with '-'; text cells never may.
    fix_ingest(
        vessel=vessel_a,
        records=[{"time": "2026-11-23T08:00:00Z", "lat": -1.0, "lon": 2.0, "readings": {name: 1}}],
    )
    body = csv_body(operator.get(f"/api/v1/vessels/spab/{path}")).decode()
    [row] = list(csv.reader(io.StringIO(body)))[1:]
    assert [float(cell) for cell in row[1:3]] == [-1.0, 2.0]  # as the database writes them
    assert json.loads(row[6]) == {name: 1.0}
    for cell in (row[0], row[6]):
        assert not cell.startswith(("=", "+", "-", "@", "\t", "\r"))


# --- commands ---
