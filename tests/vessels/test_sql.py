"""vessels.sql's statements on whichever database the suite runs on (SQLite, and PostgreSQL
with DATABASE_URL): the key lookup and the vessel's last-fix update."""

from __future__ import annotations

import datetime as dt

from django.db import connection
from django.test.utils import CaptureQueriesContext

from tests.support import BASE
from vessels import sql
from vessels.keys import hash_key
from vessels.models import Vessel
from vessels.services import (
    vessel_bump_commands_version,
    vessel_key_issue,
    vessel_key_revoke,
    vessel_key_touch,
)


def test_the_key_lookup_loads_the_key_and_its_vessel_in_one_statement(vessel_a: Vessel) -> None:
    key, raw = vessel_key_issue(vessel=vessel_a, label="pi")
    vessel_key_touch(key=key, now=BASE)
    vessel_key_revoke(key=key, now=BASE + dt.timedelta(hours=1))
    with CaptureQueriesContext(connection) as queries:
        found = sql.key_by_hash(hash_key(raw))
        assert found is not None
        vessel = found.vessel
        seen = (found.pk, found.vessel_id, vessel.slug, vessel.kind, vessel.active)
    assert len(queries) == 1
    assert seen == (key.pk, vessel_a.pk, vessel_a.slug, vessel_a.kind, True)
    assert vessel.commands_version == vessel_a.commands_version
    # Aware UTC times on every database (SQLite hands back text).
    assert found.last_used_at == BASE and found.revoked_at == BASE + dt.timedelta(hours=1)


def test_an_unknown_hash_finds_no_key(vessel_a: Vessel) -> None:
    vessel_key_issue(vessel=vessel_a)
    assert sql.key_by_hash(hash_key("no such key")) is None


def test_a_fix_becomes_the_last_fix_only_when_newer(vessel_a: Vessel) -> None:
    def record(minutes: int, seen: int) -> Vessel:
        sql.record_fix(
            vessel_id=vessel_a.pk,
            seen_at=BASE + dt.timedelta(minutes=seen),
            fix_at=BASE + dt.timedelta(minutes=minutes),
            summary={"time": f"fix {minutes}"},
        )
        return Vessel.objects.get(pk=vessel_a.pk)

    assert record(10, seen=11).last_fix == {"time": "fix 10"}
    older = record(5, seen=12)  # a backlog arrives oldest first: seen moves, the fix does not
    assert older.last_fix == {"time": "fix 10"} and older.last_fix_at == BASE + dt.timedelta(
        minutes=10
    )
    assert older.last_seen_at == BASE + dt.timedelta(minutes=12)
    newer = record(20, seen=21)
    assert newer.last_fix == {"time": "fix 20"}
    assert newer.last_fix_at == BASE + dt.timedelta(minutes=20)


def test_the_statement_form_takes_a_further_condition(vessel_a: Vessel) -> None:
    statement, params = sql.record_fix_statement(
        vessel_id=vessel_a.pk, seen_at=BASE, fix_at=BASE, summary={"a": 1}, also_if="1 = 0"
    )
    with connection.cursor() as cursor:
        cursor.execute(statement, params)
    vessel = Vessel.objects.get(pk=vessel_a.pk)
    assert vessel.last_seen_at == BASE and vessel.last_fix_at is None  # the condition failed


def test_the_commands_version_is_read_as_stored(vessel_a: Vessel) -> None:
    assert sql.commands_version(vessel_a.pk) == 0
    vessel_bump_commands_version(vessel_id=vessel_a.pk)
    vessel_bump_commands_version(vessel_id=vessel_a.pk)
    assert sql.commands_version(vessel_a.pk) == 2
    assert sql.commands_version(vessel_a.pk + 1000) == 0  # no such vessel
