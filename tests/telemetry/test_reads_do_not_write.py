"""Map reads never write (issue 17 item 5): with minutes waiting for the background rebuild,
`GET …/track/` and `…/series/` issue no INSERT/UPDATE/DELETE, leave the marks for the rebuild,
answer as the fixes say, and are served by a PostgreSQL role that may only SELECT."""

from __future__ import annotations

import datetime as dt
import math
import uuid
from collections.abc import Iterator
from typing import Any

import pytest
from django.db import ProgrammingError, connection, transaction
from django.test.utils import CaptureQueriesContext
from rest_framework.test import APIClient

from telemetry.models import Fix, TrackBucket, TrackDirty
from telemetry.services import fix_ingest, track_overview_refresh
from tests.support import BASE, iso
from vessels.models import Vessel

END = BASE + dt.timedelta(hours=3)
WRITES = ("INSERT", "UPDATE", "DELETE")


def record(i: int) -> dict[str, Any]:
    return {
        "time": iso(BASE + dt.timedelta(seconds=15 * i)),
        "lat": -32 + 0.01 * math.sin(i / 20),
        "lon": 115.7 + 0.0001 * i,
        "battery_v": 12 + (i % 40) / 100,
        "readings": {"water_temp_c": 18 + (i % 9) / 10},
    }


@pytest.fixture
def half_built(vessel_a: Vessel) -> Vessel:
    """Three hours every 15 s; the background rebuild ran after the first 100 minutes, so the
    rest are dirty and the coarse buckets over the boundary stale."""
    records = [record(i) for i in range(720)]
    fix_ingest(vessel=vessel_a, records=records[:400])
    track_overview_refresh(vessel_id=vessel_a.pk)
    fix_ingest(vessel=vessel_a, records=records[400:])
    assert TrackBucket.objects.filter(vessel=vessel_a).exists()
    assert TrackDirty.objects.filter(vessel=vessel_a).count() == 80
    return vessel_a


def reads() -> list[str]:
    query = f"?from={iso(BASE)}&to={iso(END)}"
    return [
        f"/api/v1/vessels/spab/track/{query}&max_points=40",
        f"/api/v1/vessels/spab/track/{query}",
        f"/api/v1/vessels/spab/series/{query}&buckets=7",
        f"/api/v1/vessels/spab/series/{query}",
    ]


def check_answers(client: APIClient, vessel: Vessel) -> None:
    fixes = list(Fix.objects.filter(vessel=vessel).order_by("recorded_at"))
    for path in reads():
        response = client.get(path)
        assert response.status_code == 200, response.content
        body = response.json()
        if "/track/" in path:
            props = body["features"][0]["properties"]
            times = [t for line in props["times"] for t in line]
            assert props["fixes"] == len(fixes)
            assert (times[0], times[-1]) == (
                fixes[0].recorded_at.timestamp(),
                fixes[-1].recorded_at.timestamp(),
            )
            assert max(fixes, key=lambda f: f.lat).recorded_at.timestamp() in times
        else:
            battery = body["channels"]["battery_v"]
            assert max(v for v in battery["max"] if v is not None) == max(
                f.battery_v for f in fixes
            )
            assert body["channels"]["water_temp_c"]["min"][-1] == min(
                f.readings["water_temp_c"]
                for f in fixes
                if f.recorded_at.timestamp() >= body["t"][-1]
            )


def test_a_map_read_issues_no_write_and_leaves_the_marks(
    operator: APIClient, half_built: Vessel
) -> None:
    marks = sorted(TrackDirty.objects.values_list("start", flat=True))
    buckets = sorted(TrackBucket.objects.values_list("width", "start", "count"))
    with CaptureQueriesContext(connection) as queries:
        check_answers(operator, half_built)
    writes = [q["sql"] for q in queries if q["sql"].lstrip().upper().startswith(WRITES)]
    assert writes == []
    assert sorted(TrackDirty.objects.values_list("start", flat=True)) == marks
    assert sorted(TrackBucket.objects.values_list("width", "start", "count")) == buckets


@pytest.fixture
def select_only_role() -> Iterator[str]:
    """A role that may only SELECT, taken by this connection for the test (all inside the
    test's transaction, so the role and its grants are rolled back with it)."""
    if connection.vendor != "postgresql":
        pytest.skip("database roles are PostgreSQL's")
    role = f"shoreside_reader_{uuid.uuid4().hex[:12]}"
    with connection.cursor() as cursor:
        cursor.execute(f"CREATE ROLE {role} NOLOGIN")
        cursor.execute(f"GRANT SELECT ON ALL TABLES IN SCHEMA public TO {role}")
        cursor.execute(f"SET ROLE {role}")
        cursor.execute("SELECT current_user")
        assert cursor.fetchone()[0] == role
    try:
        yield role
    finally:
        with connection.cursor() as cursor:
            cursor.execute("RESET ROLE")


def test_a_select_only_role_serves_the_maps(
    operator: APIClient, half_built: Vessel, select_only_role: str
) -> None:
    check_answers(operator, half_built)
    # The role really cannot write: the rebuild a read used to do is refused.
    with pytest.raises(ProgrammingError, match="permission denied"), transaction.atomic():
        with connection.cursor() as cursor:
            cursor.execute(f"DELETE FROM {TrackDirty._meta.db_table}")
