"""The fleet map's overlays (issue 18 §2): each vessel's trail of the last minutes and its
running mission, read seldom beside the cheap fleet poll."""

from __future__ import annotations

import datetime as dt
import json
import os
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest
import time_machine
from django.core.cache import cache
from django.core.management import call_command
from django.db import connection
from django.test import Client
from django.test.utils import CaptureQueriesContext
from django.utils import timezone
from rest_framework.test import APIClient

from alerts.selectors import vessel_endurance_hours
from commands.models import Command
from commands.services import command_ack, command_claim_open, command_enqueue
from fleet.console import TRAIL_MAX_POINTS
from fleet.maps import trail_choices
from telemetry.models import TrackDirty
from telemetry.services import fix_ingest
from tests.alerts.conftest import T0
from tests.alerts.test_evaluator import drain
from tests.conftest import make_user
from vessels.models import Vessel

ROOT = Path(__file__).resolve().parents[2]
OVERLAYS = "/api/v1/fleet/overlays/"
WRITES = ("INSERT", "UPDATE", "DELETE")
ROUTE = [
    {"lat": -31.990, "lon": 115.700},
    {"lat": -31.995, "lon": 115.705},
    {"lat": -32.000, "lon": 115.700},
    {"lat": -31.995, "lon": 115.695},
]


def iso(t: dt.datetime) -> str:
    return t.isoformat().replace("+00:00", "Z")


def sail(
    vessel: Vessel, minutes: int, *, every_s: int = 10, end: dt.datetime | None = None
) -> list:
    """Fixes every ``every_s`` seconds over the last ``minutes``, heading north-east."""
    end = end or timezone.now()
    count = minutes * 60 // every_s
    times = [end - dt.timedelta(seconds=every_s * (count - i)) for i in range(count)]
    fix_ingest(
        vessel=vessel,
        records=[
            {"time": iso(t), "lat": -32 + i * 1e-4, "lon": 115.7 + i * 1e-4}
            for i, t in enumerate(times)
        ],
    )
    vessel.refresh_from_db()
    return times


def by_slug(body: dict[str, Any]) -> dict[str, dict[str, Any]]:
    return {v["slug"]: v for v in body["vessels"]}


def running_mission(vessel: Vessel, items: list[dict[str, float]] = ROUTE) -> Command:
    command = command_enqueue(vessel=vessel, kind="mission", params={"items": items})
    command_claim_open(vessel=vessel)
    command, _ = command_ack(vessel=vessel, uid=command.uid, status="acknowledged")
    return command


def test_a_trail_is_the_last_minutes_of_fixes_oldest_first(
    operator: APIClient, vessel_a: Vessel, vessel_b: Vessel
) -> None:
    times = sail(vessel_a, 90)
    body = operator.get(OVERLAYS, {"minutes": 30}).json()
    assert (body["minutes"], body["trails"], body["missions"]) == (30, True, True)
    trail = by_slug(body)["spab"]["trail"]
    assert trail["gap_s"] == vessel_a.telemetry_period_s * 3
    [line] = trail["lines"]
    stamps = [p[0] for p in line]
    assert stamps == sorted(stamps)
    start = dt.datetime.fromisoformat(body["server_time"]) - dt.timedelta(minutes=30)
    inside = [t for t in times if t >= start]
    assert stamps[0] == pytest.approx(inside[0].timestamp())  # nothing older than 30 min
    assert stamps[-1] == pytest.approx(times[-1].timestamp())  # up to the newest fix
    assert line[-1][1:] == [
        round(-32 + (len(times) - 1) * 1e-4, 6),
        round(115.7 + (len(times) - 1) * 1e-4, 6),
    ]
    assert by_slug(body)["spab-2"]["trail"] == {
        "gap_s": vessel_b.telemetry_period_s * 3,
        "lines": [],
    }


def test_a_long_trail_is_simplified_and_broken_at_silences(
    operator: APIClient, vessel_a: Vessel
) -> None:
    now = timezone.now()
    sail(vessel_a, 40, every_s=1, end=now - dt.timedelta(minutes=20))  # then silent 10 min
    sail(vessel_a, 10, every_s=1, end=now)
    lines = by_slug(operator.get(OVERLAYS).json())["spab"]["trail"]["lines"]
    assert len(lines) == 2
    assert sum(len(line) for line in lines) <= TRAIL_MAX_POINTS
    assert lines[1][0][0] - lines[0][-1][0] > 9 * 60


def test_a_trail_is_read_from_the_rebuilt_overview_not_every_fix(
    operator: APIClient, vessel_a: Vessel
) -> None:
    """An hour of 1 Hz fixes: once the overview is rebuilt, a trail reads its minute buckets
    (a few points a minute) and the raw fixes of the ragged ends only."""
    times = sail(vessel_a, 60, every_s=1)
    call_command("rebuild_track_overview")
    operator.get(OVERLAYS)
    with CaptureQueriesContext(connection) as queries:
        body = operator.get(OVERLAYS).json()
    [line] = by_slug(body)["spab"]["trail"]["lines"]
    assert line[-1][0] == pytest.approx(times[-1].timestamp())
    assert 60 < len(line) <= TRAIL_MAX_POINTS
    fix_reads = [q["sql"] for q in queries.captured_queries if "telemetry_fix" in q["sql"]]
    assert len(fix_reads) <= 2  # the two ragged ends, never the whole hour


def test_reading_the_overlays_writes_nothing(operator: APIClient, vessel_a: Vessel) -> None:
    """Reads never write: minutes waiting for the background rebuild stay marked for it."""
    sail(vessel_a, 30, every_s=5)
    running_mission(vessel_a)
    marks = sorted(TrackDirty.objects.values_list("start", flat=True))
    assert marks
    with CaptureQueriesContext(connection) as queries:
        assert operator.get(OVERLAYS).status_code == 200
    writes = [q["sql"] for q in queries if q["sql"].lstrip().upper().startswith(WRITES)]
    assert writes == []
    assert sorted(TrackDirty.objects.values_list("start", flat=True)) == marks


def test_the_running_mission_is_the_acknowledged_one(operator: APIClient, vessel_a: Vessel) -> None:
    sail(vessel_a, 5)
    running = running_mission(vessel_a)
    body = by_slug(operator.get(OVERLAYS).json())
    mission = body["spab"]["mission"]
    assert mission["uid"] == str(running.uid)
    assert mission["status"] == "acknowledged"
    assert mission["items"] == ROUTE
    assert mission["end"] == "stop"
    assert mission["acknowledged_at"] is not None

    # A newer mission on its way (queued) does not hide the one the boat runs.
    command_enqueue(vessel=vessel_a, kind="mission", params={"items": ROUTE[:2], "end": "loop"})
    assert by_slug(operator.get(OVERLAYS).json())["spab"]["mission"]["uid"] == str(running.uid)

    # Once the boat reports it replaced, the new one is the vessel's mission, not yet running.
    command_ack(vessel=vessel_a, uid=running.uid, status="superseded")
    mission = by_slug(operator.get(OVERLAYS).json())["spab"]["mission"]
    assert (mission["status"], mission["end"], len(mission["items"])) == ("queued", "loop", 2)


def test_a_finished_mission_is_not_drawn(operator: APIClient, vessel_a: Vessel) -> None:
    command = running_mission(vessel_a)
    command_ack(vessel=vessel_a, uid=command.uid, status="done")
    command_enqueue(vessel=vessel_a, kind="hold", params={})
    assert by_slug(operator.get(OVERLAYS).json())["spab"]["mission"] is None


def test_each_part_needs_its_right(vessel_a: Vessel) -> None:
    sail(vessel_a, 5)
    running_mission(vessel_a)
    client = APIClient()
    client.force_authenticate(make_user("carol", ["vessels.view_vessel", "commands.view_command"]))
    body = client.get(OVERLAYS).json()
    assert (body["trails"], body["missions"]) == (False, True)
    assert body["vessels"][0]["trail"] is None and body["vessels"][0]["mission"] is not None
    assert body["vessels"][0]["endurance"] is None  # a figure from the fixes
    client.force_authenticate(make_user("dave", ["vessels.view_vessel", "telemetry.view_fix"]))
    body = client.get(OVERLAYS).json()
    assert (body["trails"], body["missions"]) == (True, False)
    assert body["vessels"][0]["trail"]["lines"] and body["vessels"][0]["mission"] is None
    client.force_authenticate(make_user("erin", ["telemetry.view_fix", "commands.view_command"]))
    assert client.get(OVERLAYS).status_code == 403


def test_the_trail_length_is_checked(operator: APIClient, vessel_a: Vessel, settings) -> None:
    settings.FLEET_MAP_TRAIL_MINUTES = 45
    sail(vessel_a, 5)
    assert operator.get(OVERLAYS).json()["minutes"] == 45
    assert by_slug(operator.get(OVERLAYS, {"minutes": 0}).json())["spab"]["trail"] is None
    for bad in ("1441", "-1", "ten"):
        response = operator.get(OVERLAYS, {"minutes": bad})
        assert response.status_code == 400
        assert "minutes" in response.json()["detail"]


def test_unchanged_overlays_answer_304(operator: APIClient, vessel_a: Vessel) -> None:
    sail(vessel_a, 5)
    first = operator.get(OVERLAYS)
    again = operator.get(OVERLAYS, HTTP_IF_NONE_MATCH=first["ETag"])
    assert again.status_code == 304 and again["ETag"] == first["ETag"]
    running_mission(vessel_a)
    assert operator.get(OVERLAYS, HTTP_IF_NONE_MATCH=first["ETag"]).status_code == 200


def statements(client: APIClient) -> int:
    with CaptureQueriesContext(connection) as queries:
        assert client.get(OVERLAYS).status_code == 200
    return len(queries)


def test_statements_grow_with_the_vessels_that_moved_only(
    operator: APIClient, vessel_a: Vessel, vessel_b: Vessel, glider: Vessel
) -> None:
    """The vessels, the missions, then a few per vessel with fixes in the window; a vessel
    silent for longer than the trail costs none."""
    sail(vessel_a, 60)
    running_mission(vessel_a)
    operator.get(OVERLAYS)  # the operator's permissions are cached on the user from here
    one = statements(operator)
    fix_ingest(vessel=glider, records=[{"time": "2020-01-01T00:00:00Z", "lat": -32, "lon": 115}])
    assert statements(operator) == one  # an old fix: nothing to read
    sail(vessel_b, 60)
    two = statements(operator)
    per_vessel = two - one
    assert 1 <= per_vessel <= 5
    assert one == 2 + per_vessel  # the vessels and the missions, one query each


def test_the_page_offers_the_configured_trail_length() -> None:
    assert trail_choices(60) == [0, 15, 60, 180, 720]
    assert trail_choices(90) == [0, 15, 60, 90, 180, 720]


def page_config(user) -> dict:
    client = Client()
    client.force_login(user)
    html = client.get("/admin/").content.decode()
    start = html.index('<script id="fleet-map-config" type="application/json">')
    start = html.index(">", start) + 1
    return json.loads(html[start : html.index("</script>", start)])


def test_the_fleet_map_page_is_told_where_and_how_long_the_trails_are(
    operator_user, settings
) -> None:
    settings.FLEET_MAP_TRAIL_MINUTES = 90
    settings.FLEET_MAP_TRAIL_REFRESH_S = 30
    config = page_config(operator_user)
    assert config["overlaysUrl"] == OVERLAYS
    assert (config["trailMinutes"], config["trailRefreshS"]) == (90, 30)
    assert config["trailChoices"] == [0, 15, 60, 90, 180, 720]
    # Neither fixes nor commands to see: nothing to read there.
    assert page_config(make_user("frank", ["vessels.view_vessel"]))["overlaysUrl"] == ""


@pytest.mark.parametrize(
    ("name", "raw", "said"),
    [
        ("FLEET_MAP_TRAIL_MINUTES", "1441", "is not 0 to 1440 minutes"),
        ("FLEET_MAP_TRAIL_MINUTES", "-5", "is not 0 to 1440 minutes"),
        ("FLEET_MAP_TRAIL_REFRESH_S", "1", "is under 5 seconds"),
    ],
)
def test_a_trail_setting_out_of_range_stops_the_site(name: str, raw: str, said: str) -> None:
    result = subprocess.run(
        [sys.executable, "-c", "import fleet.settings"],
        cwd=ROOT, env={**os.environ, name: raw}, capture_output=True, text=True, timeout=60,
    )  # fmt: skip
    assert result.returncode != 0
    assert f"{name}={raw} {said}" in result.stderr


def test_each_vessel_comes_with_its_battery_endurance(
    operator: APIClient, vessel_a: Vessel, vessel_b: Vessel, glider: Vessel, settings
) -> None:
    settings.ALERTS_BATTERY_EMPTY_V = 11.0
    # At a fixed hour: the last night's trough, and so the figure, moves with the time of day
    # (at 15:00 UTC it is 35.1 h), as in tests/alerts/test_evaluator.py.
    with time_machine.travel(T0, tick=False):
        drain(vessel_a, 50, start_v=12.5, per_hour=0.02)
        drain(glider, 50, start_v=12.5, per_hour=0.0)
        sail(vessel_b, 5)
        vessels = by_slug(operator.get(OVERLAYS).json())
        expected = round(vessel_endurance_hours(vessel=vessel_a), 1)
    falling = vessels["spab"]["endurance"]
    # The endurance rule's figure: about 30 h from the last night's trough at 0.02 V/h.
    assert falling["hours"] == expected
    assert falling["hours"] == pytest.approx(29.6, abs=0.2)
    assert falling["text"] == f"{falling['hours']:.0f} h to empty (11 V), day over day"
    assert vessels[glider.slug]["endurance"] == {
        "hours": None, "text": "the battery is not falling, day over day",
    }  # fmt: skip
    assert vessels[vessel_b.slug]["endurance"] == {
        "hours": None, "text": "not enough history yet (it needs two days of reports)",
    }  # fmt: skip


def test_endurance_is_read_once_per_five_minutes_not_per_poll(
    operator: APIClient, vessel_a: Vessel
) -> None:
    drain(vessel_a, 50, start_v=12.5, per_hour=0.02)
    operator.get(OVERLAYS)  # the operator's permissions are cached on the user from here
    cache.clear()
    cold = statements(operator)
    assert statements(operator) == cold - 1  # the hourly buckets of every vessel, in one query
