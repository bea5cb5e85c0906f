"""sms.sql's statements on whichever database the suite runs on (SQLite, and PostgreSQL with
DATABASE_URL): what they answer, checked against the ORM's answer to the same question."""

from __future__ import annotations

import datetime as dt

from django.db.models import Q

from commands.lifecycle import Status
from commands.models import Command
from sms import sql
from tests.support import BASE
from vessels.models import Vessel


def command(vessel: Vessel, status: str, minutes: int, expires: int | None = None) -> Command:
    made = Command.objects.create(
        vessel=vessel,
        kind="light",
        params={"state": "ON"},
        status=status,
        expires_at=None if expires is None else BASE + dt.timedelta(minutes=expires),
    )
    # created_at is set on insert: back-date it so the order is the test's own.
    Command.objects.filter(pk=made.pk).update(created_at=BASE + dt.timedelta(minutes=minutes))
    return made


def orm_waiting(vessel: Vessel, now: dt.datetime) -> list[int]:
    return list(
        Command.objects.filter(vessel=vessel, status=Status.QUEUED)
        .filter(Q(expires_at__isnull=True) | Q(expires_at__gt=now))
        .order_by("created_at", "pk")
        .values_list("pk", flat=True)
    )


def test_queued_reads_count_and_find_the_oldest_unexpired_queued_command(
    glider: Vessel, vessel_a: Vessel
) -> None:
    command(glider, Status.DONE, 0)
    expired = command(glider, Status.QUEUED, 1, expires=5)
    oldest = command(glider, Status.QUEUED, 2, expires=30)
    command(glider, Status.QUEUED, 3)
    command(glider, Status.SENT, 4)
    command(vessel_a, Status.QUEUED, 0)  # another vessel's
    now = BASE + dt.timedelta(minutes=10)
    assert sql.queued_count(glider.pk, now) == len(orm_waiting(glider, now)) == 2
    assert sql.queued_oldest_id(glider.pk, now) == oldest.pk == orm_waiting(glider, now)[0]
    # Before the first one expires, it is the oldest.
    earlier = BASE + dt.timedelta(minutes=4)
    assert sql.queued_oldest_id(glider.pk, earlier) == expired.pk
    assert sql.queued_count(glider.pk, earlier) == 3


def test_queued_reads_of_a_vessel_with_nothing_queued(glider: Vessel) -> None:
    command(glider, Status.DONE, 0)
    assert sql.queued_count(glider.pk, BASE) == 0
    assert sql.queued_oldest_id(glider.pk, BASE) is None
