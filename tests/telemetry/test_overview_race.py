"""A map read rebuilding the overview while an ingest is still open (PostgreSQL, READ COMMITTED):
the late fix must end in the overview, whichever commits first."""

from __future__ import annotations

import datetime as dt
import threading
import time

import pytest
from django.db import connection, connections, transaction

from telemetry.models import TrackBucket
from telemetry.overview import WIDTHS, bucket_start
from telemetry.services import fix_ingest, track_overview_refresh
from tests.support import BASE, iso
from vessels.models import Vessel

WAIT_S = 30


def fix(when: dt.datetime) -> dict:
    return {"time": iso(when), "lat": -32.0, "lon": 115.7}


def waiting_on_a_lock() -> bool:
    with connection.cursor() as cursor:
        cursor.execute(
            "SELECT count(*) FROM pg_stat_activity"
            " WHERE datname = current_database() AND wait_event_type = 'Lock'"
        )
        return cursor.fetchone()[0] > 0


@pytest.mark.django_db(transaction=True)
def test_a_refresh_during_an_open_ingest_never_leaves_its_fix_out(vessel_a: Vessel) -> None:
    if connection.vendor != "postgresql":
        pytest.skip("SQLite runs one writer at a time: the refresh cannot overlap the ingest")
    fix_ingest(vessel=vessel_a, records=[fix(BASE)])  # marks the minute out of date
    ingested, release = threading.Event(), threading.Event()

    def ingest_and_hold() -> None:
        try:
            with transaction.atomic():
                fix_ingest(vessel=vessel_a, records=[fix(BASE + dt.timedelta(seconds=20))])
                ingested.set()
                release.wait(WAIT_S)
        finally:
            connections.close_all()

    def refresh() -> None:
        try:
            track_overview_refresh(vessel_id=vessel_a.pk)
        finally:
            connections.close_all()

    ingest = threading.Thread(target=ingest_and_hold)
    ingest.start()
    assert ingested.wait(WAIT_S)
    reader = threading.Thread(target=refresh)
    reader.start()
    # The refresh either finishes before the ingest commits (the race lost the fix) or waits
    # for the ingest's lock on the mark; commit the ingest only then.
    while reader.is_alive() and not waiting_on_a_lock():
        time.sleep(0.01)
    release.set()
    ingest.join(WAIT_S)
    reader.join(WAIT_S)
    assert not ingest.is_alive() and not reader.is_alive()
    track_overview_refresh(vessel_id=vessel_a.pk)  # whatever marks are left
    minute = bucket_start(BASE.timestamp(), WIDTHS[0])
    assert TrackBucket.objects.get(vessel=vessel_a, width=WIDTHS[0], start=minute).count == 2
