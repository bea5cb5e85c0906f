"""The map's reads (issue 9): track, nearest fix, plot series and exports, checked against a
brute-force computation over the raw fixes, through the overview and around it."""

from __future__ import annotations

import csv
import datetime as dt
import io
import json
import math
import xml.etree.ElementTree as ET
from typing import Any

import pytest
from django.core.management import CommandError, call_command
from rest_framework.test import APIClient

from telemetry import services
from telemetry import track as track_module
from telemetry.models import Fix, SensorChannel, TrackBucket, TrackDirty
from telemetry.services import (
    fix_ingest,
    sensor_channel_save,
    track_overview_rebuild,
    track_overview_refresh,
)
from tests.support import BASE, iso
from vessels.models import Vessel

STEP_S = 20
SILENCE = (BASE + dt.timedelta(minutes=90), BASE + dt.timedelta(minutes=100))
END = BASE + dt.timedelta(hours=3)


def url(what: str, slug: str = "spab") -> str:
    return f"/api/v1/vessels/{slug}/{what}/"


def record(when: dt.datetime, i: int, **extra: Any) -> dict[str, Any]:
    return {
        "time": iso(when),
        "lat": -32 + 0.01 * math.sin(i / 30),
        "lon": 115.7 + 0.0001 * i,
        "heading_deg": float(i % 360),
        "speed_mps": 1.5,
        "battery_v": 12 + (i % 50) / 100,
        "readings": {"water_temp_c": 18 + (i % 7) / 10, "odd_sensor": float(i % 3)},
        **extra,
    }


@pytest.fixture
def voyage(vessel_a: Vessel) -> Vessel:
    """Three hours of vessel A (period 10 s) every 20 s, silent for ten minutes at 09:30,
    sent as a boat would: in batches, with one retry re-sending fixes it already sent. The
    background rebuild ran after the third batch, so reads meet built buckets, minutes not
    rebuilt yet, and coarse buckets stale for those."""
    times = [BASE + dt.timedelta(seconds=s) for s in range(0, 3 * 3600, STEP_S)]
    records = [record(t, i) for i, t in enumerate(times) if not SILENCE[0] <= t < SILENCE[1]]
    for start in range(0, len(records), 100):
        fix_ingest(vessel=vessel_a, records=records[start : start + 100])
        if start == 200:
            track_overview_refresh(vessel_id=vessel_a.pk)
    fix_ingest(vessel=vessel_a, records=records[200:210])  # duplicates
    sensor_channel_save(
        channel=SensorChannel(key="water_temp_c", label="Water temperature", unit="°C")
    )
    return vessel_a


@pytest.fixture(params=["raw", "overview"])
def path(request: pytest.FixtureRequest, monkeypatch: pytest.MonkeyPatch) -> str:
    """Each track test runs on the raw fixes and through the overview buckets."""
    if request.param == "overview":
        monkeypatch.setattr(track_module, "TRACK_RAW_FIXES", 0)
    else:
        monkeypatch.setattr(track_module, "TRACK_RAW_FIXES", 10**9)
        monkeypatch.setattr(track_module, "SERIES_RAW_SPAN_S", 10**9)
    return request.param


def brute(vessel: Vessel, start: dt.datetime, end: dt.datetime) -> list[Fix]:
    return list(Fix.objects.filter(vessel=vessel, recorded_at__gte=start, recorded_at__lt=end)
                .order_by("recorded_at"))  # fmt: skip


def get_track(client: APIClient, query: str) -> tuple[dict[str, Any], list, list]:
    response = client.get(url("track") + query)
    assert response.status_code == 200, response.content
    assert response["Content-Type"] == "application/geo+json"
    body = response.json()
    feature = body["features"][0]
    return feature["properties"], feature["geometry"]["coordinates"], feature["properties"]["times"]


def q(start: dt.datetime, end: dt.datetime, **extra: Any) -> str:
    params = {"from": iso(start), "to": iso(end), **extra}
    return "?" + "&".join(f"{k}={v}" for k, v in params.items())


# --- track ---


@pytest.mark.parametrize(
    ("start", "end"),
    [
        (BASE, END),
        (BASE + dt.timedelta(minutes=7, seconds=13), BASE + dt.timedelta(minutes=153, seconds=7)),
        (BASE + dt.timedelta(minutes=30), BASE + dt.timedelta(minutes=31)),
    ],
)
def test_the_track_holds_the_ranges_fixes_ends_and_extremes(
    operator: APIClient, voyage: Vessel, path: str, start: dt.datetime, end: dt.datetime
) -> None:
    fixes = brute(voyage, start, end)
    props, lines, times = get_track(operator, q(start, end, max_points=40))
    assert props["fixes"] == len(fixes)
    assert props["vessel"] == "spab" and props["gap_s"] == 30.0
    flat = [tuple(c) for line in lines for c in line]
    flat_t = [t for line in times for t in line]
    assert 0 < props["points"] <= 40 and len(flat) == len(flat_t)
    assert flat_t[0] == fixes[0].recorded_at.timestamp()
    assert flat_t[-1] == fixes[-1].recorded_at.timestamp()
    assert flat_t == sorted(flat_t)
    rounded = {(round(f.lon, 6), round(f.lat, 6)) for f in fixes}
    assert set(flat) <= rounded
    for extreme in (max, min):
        north = extreme(fixes, key=lambda f: f.lat)
        assert north.recorded_at.timestamp() in flat_t
        east = extreme(fixes, key=lambda f: f.lon)
        assert east.recorded_at.timestamp() in flat_t


def test_a_silence_is_a_break_in_the_line(operator: APIClient, voyage: Vessel, path: str) -> None:
    _props, lines, times = get_track(operator, q(BASE, END))
    assert len(lines) == 2
    last_before = (SILENCE[0] - dt.timedelta(seconds=STEP_S)).timestamp()
    assert times[0][-1] == last_before and times[1][0] == SILENCE[1].timestamp()


def test_late_fixes_and_duplicates_show_in_the_next_read(
    operator: APIClient, voyage: Vessel, path: str
) -> None:
    track_overview_refresh(vessel_id=voyage.pk)  # the overview is built
    # Store-and-forward: the fixes of the silence arrive hours late, one far north.
    late = [record(SILENCE[0] + dt.timedelta(seconds=s), 5000 + s) for s in range(0, 600, STEP_S)]
    late[7]["lat"] = -31.5
    fix_ingest(vessel=voyage, records=late + late[:3])
    assert TrackDirty.objects.filter(vessel=voyage).exists()
    props, lines, times = get_track(operator, q(BASE, END))
    assert props["fixes"] == len(brute(voyage, BASE, END))
    assert len(lines) == 1  # the silence is filled
    assert dt.datetime.fromisoformat(late[7]["time"]).timestamp() in times[0]
    # The read wrote nothing; the background rebuild clears the marks, and the answer stands.
    assert TrackDirty.objects.filter(vessel=voyage).exists()
    track_overview_refresh(vessel_id=voyage.pk)
    assert not TrackDirty.objects.filter(vessel=voyage).exists()
    assert get_track(operator, q(BASE, END)) == (props, lines, times)


def test_the_track_defaults_to_the_last_day_and_two_thousand_points(
    operator: APIClient, vessel_a: Vessel
) -> None:
    now = dt.datetime.now(dt.UTC).replace(microsecond=0)
    fix_ingest(vessel=vessel_a, records=[
        record(now - dt.timedelta(hours=h), h) for h in (1, 2, 23, 25)
    ])  # fmt: skip
    props, lines, times = get_track(operator, "")
    assert props["fixes"] == 3
    to = dt.datetime.fromisoformat(props["to"])
    assert to - dt.datetime.fromisoformat(props["from"]) == dt.timedelta(hours=24)
    # Three fixes hours apart: each its own line, drawn as the same position twice.
    assert len(lines) == 3 and all(len(line) == 2 and line[0] == line[1] for line in lines)
    assert props["points"] == 3


def test_an_empty_range_is_an_empty_track(operator: APIClient, voyage: Vessel) -> None:
    props, lines, _ = get_track(operator, q(END, END + dt.timedelta(days=2)))
    assert (props["fixes"], props["points"], lines) == (0, 0, [])


def test_many_fixes_are_simplified_within_the_bound(
    operator: APIClient, voyage: Vessel, path: str
) -> None:
    props, _lines, _ = get_track(operator, q(BASE, END, max_points=6))
    assert 2 <= props["points"] <= 6
    props, _lines, _ = get_track(operator, q(BASE, END))
    # Under the bound every fix is drawn (through the overview too: its minute buckets of
    # three fixes keep all three).
    assert props["points"] == props["fixes"] == len(brute(voyage, BASE, END))
    props, _lines, _ = get_track(operator, q(BASE, END, max_points=100))
    assert 6 < props["points"] <= 100


@pytest.mark.parametrize(
    ("query", "field"),
    [
        ("?max_points=5", "max_points"),
        ("?max_points=100000", "max_points"),
        ("?max_points=lots", "max_points"),
        ("?from=yesterday", "from"),
        ("?from=2026-11-23T09:00:00Z&to=2026-11-23T08:00:00Z", "from"),
    ],
)
def test_bad_track_parameters_are_a_400_naming_them(
    operator: APIClient, vessel_a: Vessel, query: str, field: str
) -> None:
    response = operator.get(url("track") + query)
    assert response.status_code == 400
    assert response.json()["error"] == "invalid"
    assert list(response.json()["detail"]) == [field]


@pytest.mark.parametrize("what", ["track", "series", "track/export", "fixes/nearest"])
def test_the_map_reads_follow_the_fixes_permissions(
    what: str,
    operator: APIClient,
    readonly: APIClient,
    anonymous: APIClient,
    boat_a: APIClient,
    vessel_a: Vessel,
) -> None:
    query = "?time=2026-11-23T08:00:00Z"
    assert readonly.get(url(what) + query).status_code == 403
    assert readonly.get(url(what, "nope") + query).status_code == 403  # no existence leak
    assert anonymous.get(url(what) + query).status_code in (401, 403)
    assert boat_a.get(url(what) + query).status_code in (401, 403)
    response = operator.get(url(what, "nope") + query)
    assert response.status_code == 404
    assert response.json()["error"] == "not_found"


def test_only_the_named_vessels_fixes_are_drawn(
    operator: APIClient, voyage: Vessel, vessel_b: Vessel
) -> None:
    fix_ingest(vessel=vessel_b, records=[record(BASE + dt.timedelta(minutes=5), 1, lat=10)])
    props, _lines, _ = get_track(operator, q(BASE, END))
    assert props["fixes"] == len(brute(voyage, BASE, END))
    response = operator.get(url("track", "spab-2") + q(BASE, END))
    assert response.json()["features"][0]["properties"]["fixes"] == 1


# --- nearest fix ---


def test_the_nearest_fix_is_found_either_side(operator: APIClient, voyage: Vessel) -> None:
    before = (BASE + dt.timedelta(seconds=20 * 10 + 9)).isoformat()
    body = operator.get(url("fixes/nearest"), {"time": before}).json()
    assert body["time"] == iso(BASE + dt.timedelta(seconds=200))
    assert set(body) >= {"lat", "lon", "heading_deg", "speed_mps", "battery_v", "readings"}
    assert body["readings"]["odd_sensor"] == 1.0
    after = BASE.timestamp() + 211
    body = operator.get(url("fixes/nearest"), {"time": after}).json()
    assert body["time"] == iso(BASE + dt.timedelta(seconds=220))


def test_nearest_needs_a_time_and_a_vessel_with_fixes(
    operator: APIClient, vessel_a: Vessel
) -> None:
    response = operator.get(url("fixes/nearest"))
    assert response.status_code == 400 and list(response.json()["detail"]) == ["time"]
    response = operator.get(url("fixes/nearest"), {"time": "2026-11-23T08:00:00Z"})
    assert response.status_code == 404
    assert response.json()["error"] == "not_found"


# --- series ---


def brute_series(fixes: list[Fix], starts: list[int], width: int) -> dict[str, dict[str, list]]:
    out: dict[str, dict[str, list]] = {}
    index = {s: i for i, s in enumerate(starts)}
    for fix in fixes:
        values = {"battery_v": fix.battery_v, **fix.readings}
        for key, value in values.items():
            if value is None:
                continue
            channel = out.setdefault(key, {"v": [[] for _ in starts]})
            channel["v"][index[int(fix.recorded_at.timestamp() // width * width)]].append(value)
    return {
        key: {
            "min": [min(v) if v else None for v in c["v"]],
            "max": [max(v) if v else None for v in c["v"]],
            "mean": [sum(v) / len(v) if v else None for v in c["v"]],
        }
        for key, c in out.items()
    }


@pytest.mark.parametrize(
    ("start", "end", "buckets"),
    [
        (BASE, END, 1000),
        (BASE - dt.timedelta(minutes=1, seconds=5), END + dt.timedelta(seconds=33), 7),
        (BASE + dt.timedelta(minutes=3, seconds=1), BASE + dt.timedelta(minutes=150), 100),
    ],
)
def test_the_series_equals_a_brute_force_one(
    operator: APIClient,
    voyage: Vessel,
    path: str,
    start: dt.datetime,
    end: dt.datetime,
    buckets: int,
) -> None:
    # Late fixes into already-built buckets, and duplicates, before the read.
    operator.get(url("series") + q(start, end, buckets=buckets))
    fix_ingest(vessel=voyage, records=[
        record(SILENCE[0] + dt.timedelta(seconds=30), 1, battery_v=30.0),
        record(BASE + dt.timedelta(seconds=20), 1),
    ])  # fmt: skip
    body = operator.get(url("series") + q(start, end, buckets=buckets)).json()
    assert len(body["t"]) <= buckets
    expected = brute_series(brute(voyage, start, end), body["t"], body["bucket_s"])
    assert set(body["channels"]) == {"battery_v", "water_temp_c", "odd_sensor"}
    for key, want in expected.items():
        got = body["channels"][key]
        assert got["min"] == want["min"] and got["max"] == want["max"], key
        for a, b in zip(got["mean"], want["mean"], strict=True):
            assert (a is None and b is None) or math.isclose(a, b, rel_tol=1e-9)
    assert max(v for v in body["channels"]["battery_v"]["max"] if v) == 30.0


def test_series_channels_carry_labels_and_units(operator: APIClient, voyage: Vessel) -> None:
    body = operator.get(url("series") + q(BASE, END)).json()
    channels = body["channels"]
    assert list(channels)[0] == "battery_v"
    assert (channels["battery_v"]["label"], channels["battery_v"]["unit"]) == ("Battery", "V")
    assert (channels["water_temp_c"]["label"], channels["water_temp_c"]["unit"]) == (
        "Water temperature",
        "°C",
    )
    # No SensorChannel: it still plots, under its key.
    assert (channels["odd_sensor"]["label"], channels["odd_sensor"]["unit"]) == ("odd_sensor", "")
    assert body["bucket_s"] == 60 and body["t"][1] - body["t"][0] == 60
    # The ten silent minutes are empty buckets, in every channel.
    silent = body["t"].index(int(SILENCE[0].timestamp()))
    for channel in channels.values():
        assert channel["min"][silent : silent + 10] == [None] * 10
        assert channel["mean"][silent - 1] is not None


@pytest.mark.parametrize("query", ["?buckets=0", "?buckets=x", "?buckets=999999"])
def test_bad_series_parameters_are_a_400(operator: APIClient, vessel_a: Vessel, query: str) -> None:
    response = operator.get(url("series") + query)
    assert response.status_code == 400
    assert list(response.json()["detail"]) == ["buckets"]


# --- exports ---


def export(client: APIClient, fmt: str, start: dt.datetime, end: dt.datetime) -> Any:
    response = client.get(url("track/export") + q(start, end, format=fmt))
    assert response.status_code == 200
    assert response.streaming
    return response


def test_the_csv_export_has_every_fix_of_the_range(operator: APIClient, voyage: Vessel) -> None:
    start, end = BASE + dt.timedelta(minutes=10), BASE + dt.timedelta(minutes=20)
    response = export(operator, "csv", start, end)
    assert response["Content-Type"].startswith("text/csv")
    assert response["Content-Disposition"] == (
        'attachment; filename="spab-20261123T081000Z-20261123T082000Z.csv"'
    )
    text = b"".join(response.streaming_content).decode()
    rows = list(csv.DictReader(io.StringIO(text)))
    fixes = brute(voyage, start, end)
    assert [r["time"] for r in rows] == [iso(f.recorded_at) for f in fixes]
    # As the database writes numbers: 15 significant digits on SQLite, exact on PostgreSQL.
    assert [float(r["lat"]) for r in rows] == pytest.approx([f.lat for f in fixes], rel=1e-14)
    assert [json.loads(r["readings"]) for r in rows] == [f.readings for f in fixes]
    assert float(rows[0]["battery_v"]) == pytest.approx(fixes[0].battery_v, rel=1e-14)
    assert rows[0]["heading_deg"] != "" and float(rows[0]["speed_mps"]) == 1.5


def test_the_geojson_export_has_a_point_per_fix(operator: APIClient, voyage: Vessel) -> None:
    body = json.loads(b"".join(export(operator, "geojson", BASE, END).streaming_content))
    fixes = brute(voyage, BASE, END)
    assert body["type"] == "FeatureCollection"
    assert len(body["features"]) == len(fixes)
    last = body["features"][-1]
    assert last["geometry"]["coordinates"] == pytest.approx(
        [fixes[-1].lon, fixes[-1].lat], rel=1e-14
    )
    assert last["properties"]["time"] == iso(fixes[-1].recorded_at)
    assert last["properties"]["readings"] == fixes[-1].readings
    assert last["properties"]["speed_mps"] == 1.5


def test_the_gpx_export_is_gpx_1_1_with_a_segment_per_run(
    operator: APIClient, voyage: Vessel
) -> None:
    text = b"".join(export(operator, "gpx", BASE, END).streaming_content)
    ns = {"g": "http://www.topografix.com/GPX/1/1"}
    root = ET.fromstring(text)
    assert root.tag == "{http://www.topografix.com/GPX/1/1}gpx" and root.get("version") == "1.1"
    segments = root.findall("g:trk/g:trkseg", ns)
    assert len(segments) == 2  # the silence
    points = [p for s in segments for p in s.findall("g:trkpt", ns)]
    fixes = brute(voyage, BASE, END)
    assert len(points) == len(fixes)
    assert float(points[0].get("lat")) == fixes[0].lat
    assert points[0].find("g:time", ns).text == iso(fixes[0].recorded_at)


def test_an_empty_export_is_still_a_valid_document(operator: APIClient, vessel_a: Vessel) -> None:
    for fmt in ("csv", "geojson", "gpx"):
        content = b"".join(export(operator, fmt, BASE, END).streaming_content)
        if fmt == "geojson":
            assert json.loads(content)["features"] == []
        elif fmt == "gpx":
            assert ET.fromstring(content).find("{http://www.topografix.com/GPX/1/1}trk") is not None
        else:
            assert content.decode().splitlines() == [
                "time,lat,lon,heading_deg,speed_mps,battery_v,readings"
            ]


def test_an_unknown_export_format_is_a_400(operator: APIClient, vessel_a: Vessel) -> None:
    response = operator.get(url("track/export") + "?format=kml")
    assert response.status_code == 400
    assert list(response.json()["detail"]) == ["format"]


# --- the overview itself ---


def test_a_rebuild_gives_the_same_buckets_as_the_incremental_upkeep(
    operator: APIClient, voyage: Vessel
) -> None:
    track_overview_refresh(vessel_id=voyage.pk)
    incremental = sorted(TrackBucket.objects.values_list("width", "start", "count", "points"))
    track_overview_rebuild(vessel=voyage)
    rebuilt = sorted(TrackBucket.objects.values_list("width", "start", "count", "points"))
    assert incremental == rebuilt
    assert {w for w, *_ in rebuilt} == {60, 600, 3600}


def test_deleting_fixes_in_the_admin_updates_the_track(
    operator: APIClient, admin_ui: Any, voyage: Vessel, path: str
) -> None:
    get_track(operator, q(BASE, END))
    northmost = max(brute(voyage, BASE, END), key=lambda f: f.lat)
    response = admin_ui.post(
        "/admin/telemetry/fix/",
        {"action": "delete_selected", "_selected_action": [northmost.pk], "post": "yes"},
    )
    assert response.status_code == 302
    props, _lines, times = get_track(operator, q(BASE, END))
    assert props["fixes"] == len(brute(voyage, BASE, END))
    assert northmost.recorded_at.timestamp() not in [t for line in times for t in line]


def test_the_rebuild_command_rebuilds_named_vessels(voyage: Vessel) -> None:
    out = io.StringIO()
    call_command("rebuild_track_overview", "spab", stdout=out)
    assert out.getvalue().startswith("spab: rebuilt")
    assert TrackBucket.objects.filter(vessel=voyage, width=3600).count() == 3
    with pytest.raises(CommandError, match="nope"):
        call_command("rebuild_track_overview", "nope")


def test_the_openapi_schema_validates_with_the_map_endpoints(db: None) -> None:
    out = io.StringIO()
    call_command("spectacular", "--validate", "--fail-on-warn", stdout=out)
    schema = out.getvalue()
    for path in ("/track/", "/track/export/", "/series/", "/fixes/nearest/", "/api/v1/fleet/"):
        assert path in schema


def test_a_long_backlog_is_rebuilt_a_day_at_a_time() -> None:
    minute = 60
    day = services.REBUILD_WINDOW_S
    # A week of dirty minutes every 10 minutes: one run by the join rule, read a day at a time.
    minutes = list(range(0, 7 * day, 10 * minute))
    runs = services._runs(minutes)
    assert runs[0][0] == 0 and runs[-1][1] == minutes[-1] + minute
    assert all(hi - lo <= day for lo, hi in runs)
    assert all(a[1] == b[0] for a, b in zip(runs, runs[1:], strict=False))  # no minute lost
    # Far-apart minutes stay separate runs.
    assert services._runs([0, 10 * day]) == [(0, minute), (10 * day, 10 * day + minute)]
