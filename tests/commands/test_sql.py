"""commands.sql's statements on whichever database the suite runs on (SQLite, and PostgreSQL
with DATABASE_URL)."""

from __future__ import annotations

from django.db import connection, transaction
from django.test.utils import CaptureQueriesContext

from commands import sql
from commands.lifecycle import Status
from commands.models import Command
from tests.support import BASE
from vessels.models import Vessel


def command(vessel: Vessel, kind: str, status: str = Status.QUEUED, **fields: object) -> Command:
    return Command.objects.create(vessel=vessel, kind=kind, params={}, status=status, **fields)


def test_supersede_changes_only_the_other_queued_commands_of_those_kinds(
    vessel_a: Vessel, vessel_b: Vessel
) -> None:
    keep = command(vessel_a, "hold")
    older = command(vessel_a, "hold")
    older_goto = command(vessel_a, "goto")
    sent = command(vessel_a, "hold", Status.SENT)
    reported = command(vessel_a, "hold", reported=True)
    other_kind = command(vessel_a, "light")
    other_vessel = command(vessel_b, "hold")
    changed = sql.queued_supersede(
        vessel_id=vessel_a.pk, kinds=["hold", "goto"], keep=keep.pk, now=BASE, detail="by test"
    )
    assert changed == sorted([older.pk, older_goto.pk])
    statuses = dict(Command.objects.values_list("pk", "status"))
    assert statuses[older.pk] == statuses[older_goto.pk] == Status.SUPERSEDED
    for untouched, status in [
        (keep, Status.QUEUED),
        (sent, Status.SENT),
        (reported, Status.QUEUED),
        (other_kind, Status.QUEUED),
        (other_vessel, Status.QUEUED),
    ]:
        assert statuses[untouched.pk] == status
    older.refresh_from_db()
    assert (older.finished_at, older.result_detail) == (BASE, "by test")


def test_supersede_with_nothing_to_change_returns_no_ids(vessel_a: Vessel) -> None:
    keep = command(vessel_a, "hold")
    assert (
        sql.queued_supersede(
            vessel_id=vessel_a.pk, kinds=["hold"], keep=keep.pk, now=BASE, detail=""
        )
        == []
    )


def test_the_enqueue_lock_is_one_statement_on_postgresql_and_none_elsewhere(
    vessel_a: Vessel,
) -> None:
    with transaction.atomic(), CaptureQueriesContext(connection) as context:
        sql.enqueue_lock(vessel_a.pk)
        sql.enqueue_lock(vessel_a.pk)  # the transaction's own lock: taken again at once
    locks = [q["sql"] for q in context.captured_queries if "pg_advisory_xact_lock" in q["sql"]]
    assert len(locks) == (2 if connection.vendor == "postgresql" else 0)
