"""command_enqueue's writes are few and fixed: one statement each for the command, the
superseded ones, all the events, the version bump and the audit entry, however many commands
it supersedes."""

from __future__ import annotations

import pytest
from django.db import connection
from django.test.utils import CaptureQueriesContext

from commands.errors import CatalogError
from commands.lifecycle import Status
from commands.models import Command, CommandEvent
from commands.services import command_enqueue
from vessels.models import Vessel

TRANSACTION_CONTROL = ("BEGIN", "COMMIT", "ROLLBACK", "SAVEPOINT", "RELEASE")


def statements(context: CaptureQueriesContext) -> list[str]:
    return [
        q["sql"]
        for q in context.captured_queries
        if not q["sql"].lstrip().upper().startswith(TRANSACTION_CONTROL)
    ]


def version(vessel: Vessel) -> int:
    vessel.refresh_from_db(fields=["commands_version"])
    return vessel.commands_version


def hold(vessel: Vessel) -> Command:
    return command_enqueue(vessel=vessel, kind="hold", params={})


def test_superseding_two_commands_takes_one_update_and_one_insert_for_all_events(
    glider: Vessel,
) -> None:
    first, second = (
        hold(glider),
        command_enqueue(vessel=glider, kind="fhead", params={"bearing": 230}),
    )
    # The fhead superseded the hold; put the hold back in the queue to have two to replace.
    Command.objects.filter(pk=first.pk).update(status=Status.QUEUED, finished_at=None)
    before = version(glider)
    with CaptureQueriesContext(connection) as context:
        newest = hold(glider)
    lock = 1 if connection.vendor == "postgresql" else 0  # the per-vessel advisory lock
    # INSERT the command, UPDATE … RETURNING the superseded, INSERT the events, bump, and
    # INSERT the audit entry (command.queued: who queued it, through what, from where).
    assert len(statements(context)) == 5 + lock
    assert not any(q["sql"].startswith("SAVEPOINT") for q in context.captured_queries)
    for old in (first, second):
        old.refresh_from_db()
        assert old.status == Status.SUPERSEDED
        assert old.finished_at is not None
        assert str(newest.uid) in old.result_detail
        assert list(old.events.values_list("to_status", "actor"))[-1] == ("superseded", "system")
    assert newest.events.get().to_status == Status.QUEUED
    # One for the new command entering the boat's list, one for each leaving it.
    assert version(glider) == before + 3


def test_an_enqueue_with_nothing_to_supersede_writes_four_statements(glider: Vessel) -> None:
    with CaptureQueriesContext(connection) as context:
        light = command_enqueue(vessel=glider, kind="light", params={"state": "on"})
    assert len(statements(context)) == 4  # the command, its event, the bump, the audit entry
    assert CommandEvent.objects.filter(command=light).count() == 1


def test_a_refused_command_writes_nothing(glider: Vessel) -> None:
    before = version(glider)
    with CaptureQueriesContext(connection) as context:
        with pytest.raises(CatalogError):
            command_enqueue(vessel=glider, kind="fhead", params={"bearing": 400})
    assert statements(context) == []
    assert version(glider) == before
