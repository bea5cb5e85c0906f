"""The C&C's status requests as the glider's fixes (sms/bridge/fixes.py, §8.3 of docs/level2.md)."""

from __future__ import annotations

import datetime as dt

import pytest
from django.db import OperationalError

from sms.bridge import fixes as fixes_module
from sms.bridge.fixes import FixRecorder
from sms.level2.payload import Fix
from telemetry.models import Fix as StoredFix
from vessels.models import Vessel

pytestmark = pytest.mark.django_db

NOW = dt.datetime.now(dt.UTC).replace(microsecond=0)
READINGS = {"pressure_kpa": 100.0, "humidity_pct": 35.0}


def fix(seconds_ago: int = 0, lat: float = 36.80278, lon: float = -121.78812) -> Fix:
    return Fix(NOW - dt.timedelta(seconds=seconds_ago), lat, lon)


def recorder(glider: Vessel, **kw: object) -> FixRecorder:
    return FixRecorder(vessel=glider, readings=lambda: READINGS, **kw)  # type: ignore[arg-type]


def test_fixes_are_stored_with_the_readings_known_then(glider: Vessel) -> None:
    fixes = recorder(glider)
    assert fixes.record(fix(20))
    assert fixes.record(fix(0, lat=36.81))
    result = fixes.flush()
    assert result is not None and result.accepted == 2
    stored = list(StoredFix.objects.filter(vessel=glider).order_by("recorded_at"))
    assert [f.recorded_at for f in stored] == [NOW - dt.timedelta(seconds=20), NOW]
    assert stored[1].lat == 36.81 and stored[1].readings == READINGS
    glider.refresh_from_db()
    assert glider.last_fix["lat"] == 36.81
    assert fixes.pending == 0 and fixes.stored == 2


def test_one_fix_per_distinct_cc_time(glider: Vessel) -> None:
    fixes = recorder(glider)
    assert fixes.record(fix(0))
    assert not fixes.record(fix(0)), "a retry, or a poll whose GPS time did not move"
    fixes.flush()
    again = recorder(glider)  # after a restart the database knows the time
    again.record(fix(0))
    result = again.flush()
    assert result is not None and (result.accepted, result.duplicates) == (0, 1)
    assert StoredFix.objects.filter(vessel=glider).count() == 1
    assert fixes.duplicates == 1


def test_fixes_without_a_time_or_with_an_implausible_one_are_dropped(glider: Vessel) -> None:
    fixes = recorder(glider)
    assert not fixes.record(Fix(None, 36.8, -121.8))
    captured = dt.datetime(2014, 4, 17, 22, 20, 43, tzinfo=dt.UTC)  # §8.3: before 2018
    fixes.record(Fix(captured, 36.8, -121.8))
    fixes.record(Fix(NOW + dt.timedelta(days=1), 36.8, -121.8))
    fixes.record(fix(0))
    result = fixes.flush()
    assert result is not None and result.accepted == 1 and len(result.rejected) == 2
    assert (fixes.no_time, fixes.rejected) == (1, 2)
    assert StoredFix.objects.filter(vessel=glider).count() == 1


def test_a_batch_is_due_by_size_or_by_age(glider: Vessel) -> None:
    now = [0.0]
    fixes = recorder(glider, batch_size=3, max_wait_s=10.0, clock=lambda: now[0])
    assert not fixes.flush_if_due()
    fixes.record(fix(3))
    fixes.record(fix(2))
    assert not fixes.due()
    fixes.record(fix(1))
    assert fixes.flush_if_due() and fixes.pending == 0
    fixes.record(fix(0))
    now[0] += 9.9
    assert not fixes.due()
    now[0] += 0.2
    assert fixes.flush_if_due()
    assert StoredFix.objects.filter(vessel=glider).count() == 4


def test_a_batch_the_database_refuses_stays_pending_and_bounded(
    glider: Vessel, monkeypatch: pytest.MonkeyPatch
) -> None:
    def refuse(**_kw: object) -> None:
        raise OperationalError("database is locked")

    fixes = recorder(glider, max_pending=3)
    for seconds_ago in range(5):
        fixes.record(fix(seconds_ago))
    monkeypatch.setattr(fixes_module, "fix_ingest", refuse)
    assert fixes.flush() is None
    assert (fixes.pending, fixes.evicted) == (3, 2)
    monkeypatch.undo()
    result = fixes.flush()
    assert result is not None and result.accepted == 3
    assert fixes.pending == 0
